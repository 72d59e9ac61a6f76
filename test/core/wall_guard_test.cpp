// The wall guard (solver.wall_guard, Eq. A31 of docs/method.md): no step carries a fluid particle
// across a wall's particle layer; water that stays off its walls is never touched.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "fluid_sim/core/bodies.h"
#include "fluid_sim/core/boundary_sampling.h"
#include "fluid_sim/core/neighborhoods.h"
#include "fluid_sim/core/simulation.h"
#include "fluid_sim/core/wall_guard.h"
#include "small_scene.h"

using namespace fluid_sim;

namespace
{
/// One particle at (0.1, 0.1, z0) in an empty 0.2 m box tank at 2 cm (its floor's layer at
/// z = -1 cm), thrown at the floor at `speed` (m/s), no gravity, no viscosity, 1 ms steps.
SceneConfig thrownAtTheFloor(double z0, double speed, double guard)
{
  SceneConfig s = test::waterTank(0.02, Vec3d(0.2, 0.2, 0.2), 0.0);
  s.gravity = Vec3d::Zero();
  s.viscosity.model = ViscosityModel::None;
  s.viscosity.coefficient = 0.0;
  s.stability.max_cfl = 10.0;
  s.fill.trim = false;  // the particle is placed nearer the floor than a lattice point may start
  s.solver.wall_guard = guard;
  ExplicitParticles p;
  p.positions = {Vec3d(0.1, 0.1, z0)};
  p.velocities = {Vec3d(0.0, 0.0, -speed)};
  FluidBlockConfig f;
  f.particles = p;
  s.fluid = {f};
  return s;
}

/// thrownAtTheFloor's tank with a lid over its middle: a solid box 8 x 8 cm whose lower face is
/// `gap` (m) above the floor's surface (its layer half a spacing inside, as the floor's).
SceneConfig withALid(SceneConfig s, double gap)
{
  BoundaryConfig lid;
  lid.name = "lid";
  lid.type = ShapeType::Box;
  lid.box = {Vec3d(0.06, 0.06, gap), Vec3d(0.14, 0.14, gap + 0.04)};
  s.boundaries.push_back(lid);
  return s;
}

/// Water (the box `fluid`, 1 cm spacing) in a mesh container (`closed`: held inside it; open: a
/// thin shell, which holds water as any wall does) under gravity tilted as by a `sideways` (m/s^2)
/// acceleration, XSPH 0.01, the adaptive step.
SceneConfig tiltedMeshContainer(const TriangleMesh& mesh, bool closed, const AxisBox& fluid, double guard,
                                BoundaryPressureMethod method, double sideways)
{
  SceneConfig s;
  s.spacing = 0.01;
  s.gravity = Vec3d(sideways, 0.0, -9.81);
  s.solver.boundary_pressure = method;
  s.domain = {Vec3d(-0.2, -0.2, -0.1), Vec3d(0.2, 0.2, 0.3)};
  s.time_step.adaptive = true;
  s.viscosity.model = ViscosityModel::Xsph;
  s.viscosity.coefficient = 0.01;
  s.solver.wall_guard = guard;
  BoundaryConfig container;
  container.name = "container";
  container.type = ShapeType::Mesh;
  container.mesh = mesh;
  container.mesh_closed = closed;
  container.inside = closed;
  s.boundaries.push_back(container);
  FluidBlockConfig f;
  f.box = fluid;
  s.fluid.push_back(f);
  return s;
}

/// Still water (8 x 8 x 4 cm: 256 particles) in a 32-facet mesh cylinder (r 8 cm): with MLS at
/// 2 m/s^2 the README's known problem before the guard and the rim's even sampling (25-70 of 256
/// particles through the floor near the wall in 3 s).
SceneConfig tiltedMeshCup(double guard, bool closed = true, BoundaryPressureMethod method = BoundaryPressureMethod::Mls,
                          double sideways = 2.0)
{
  return tiltedMeshContainer(test::cylinderMesh(32, 0.08, 0.2, closed), closed,
                             {Vec3d(-0.04, -0.04, 0.0), Vec3d(0.04, 0.04, 0.04)}, guard, method, sideways);
}

/// A 3 s run of `scene`: the fluid particles it started with and lost, and the particle-steps the
/// guard held.
struct ThreeSeconds
{
  std::size_t initial = 0, lost = 0, guarded = 0;
};
ThreeSeconds runThreeSeconds(const SceneConfig& scene)
{
  Simulation sim(scene);
  ThreeSeconds out;
  while (sim.time() < 3.0 - 1e-9)
  {
    const StepReport r = sim.step(3.0 - sim.time());
    EXPECT_FALSE(r.unstable) << r.reason;
    if (r.unstable) break;
    out.guarded += r.wall_guarded;
  }
  out.initial = sim.initialFluidParticles();
  out.lost = out.initial - sim.numFluidParticles();
  return out;
}
}  // namespace

/// The guard alone (no pressure solve, which stops a lone particle by itself): one particle at
/// (0.1, 0.1, z0) in thrownAtTheFloor's tank (or `scene`, built on it) moved by dt v, the first
/// body's (the tank's) particles moving at `floor_velocity`, a second body's (a lid's) at
/// `lid_velocity`.
struct GuardOnly
{
  SceneConfig scene;
  CubicKernel kernel;
  BodySet bodies;
  FluidParticles fluid;
  BodyWrenches wrenches;
  WallGuardReport report;

  GuardOnly(double z0, const Vec3& v, double guard, const Vec3& floor_velocity, double dt)
      : GuardOnly(thrownAtTheFloor(z0, 0.0, guard), z0, v, floor_velocity, Vec3::Zero(), dt)
  {
  }

  GuardOnly(const SceneConfig& s, double z0, const Vec3& v, const Vec3& floor_velocity, const Vec3& lid_velocity,
            double dt)
      : scene(s), kernel(Real(2.0 * scene.spacing)), bodies(scene), wrenches(scene.boundaries.size())
  {
    const double guard = scene.solver.wall_guard;
    for (std::size_t b = 0; b < bodies.numParticles(); ++b)
      bodies.v[b] = bodies.body_of[b] == 0 ? floor_velocity : lid_velocity;
    fluid.add(Vec3(Real(0.1), Real(0.1), Real(z0)), v, Real(1000));
    Neighborhoods nb(scene, kernel);
    nb.sortFluid(fluid);
    nb.build(fluid, bodies);
    WallGuard g;
    g.prepare(guard * scene.spacing, scene.spacing, kernel, fluid, bodies, nb.fluid_boundary);
    fluid.x[0] += Real(dt) * fluid.v[0];
    report = g.apply(dt, kernel, fluid, bodies, Real(1000 * 0.02 * 0.02 * 0.02), wrenches, nb.fluid_boundary);
  }
};

TEST(WallGuard, AParticleThrownAtAFloorStopsHalfASpacingFromItsLayer)
{
  // 1.1 cm above the floor's layer (z = -1 cm; water at rest keeps 2 cm), 40 m/s for 1 ms: 4 cm,
  // through the layer. Held half a spacing (1 cm) from the layer, within the projection's 0.1 %
  // of c: on the floor's surface, and stopped there.
  GuardOnly g(0.001, Vec3(0, 0, -40), 0.5, Vec3::Zero(), 0.001);
  EXPECT_EQ(g.report.particles, 1u);
  const Vec3 x = g.fluid.x[0], v = g.fluid.v[0];
  EXPECT_NEAR(x.z(), 0.0, 5e-5);
  EXPECT_NEAR(x.x(), 0.1, 1e-6);
  EXPECT_NEAR(x.y(), 0.1, 1e-6);
  EXPECT_NEAR(v.z(), 0.0, 1e-6);
  EXPECT_NEAR(g.report.max_shift, x.z() - (0.001 - 0.04), 1e-6);
  // The momentum the fluid lost is the tank's: -m dv / dt, straight down.
  const double m = 1000.0 * 0.02 * 0.02 * 0.02;  // kg
  EXPECT_NEAR(g.wrenches.force[0].z(), -m * 40.0 / 0.001, 1e-4 * m * 40.0 / 0.001);
  EXPECT_NEAR(g.wrenches.force[0].x(), 0.0, 1e-4 * m * 40.0 / 0.001);
}

TEST(WallGuard, ABlownUpParticleCostsAFewChecksAndIsStillStopped)
{
  // 1e12 m/s for 1 ms: the path's check stops 4 spacings from the start (the lists see no wall
  // beyond); checked piece by piece to its end, 2e11 pieces (an unstable run hung in such a step).
  GuardOnly g(0.001, Vec3(0, 0, Real(-1e12)), 0.5, Vec3::Zero(), 0.001);
  EXPECT_EQ(g.report.particles, 1u);
  EXPECT_NEAR(g.fluid.x[0].z(), 0.0, 5e-5);
  EXPECT_NEAR(g.fluid.v[0].z(), 0.0, 1e-6);
}

TEST(WallGuard, AParticleAlreadyCloserIsHeldWhereItIs)
{
  // Guard distance one spacing (2 cm), the particle 1.1 cm from the layer and moving at it: the
  // step ends where it began, not pushed out to the guard distance in one jump.
  GuardOnly g(0.001, Vec3(0, 0, -5), 1.0, Vec3::Zero(), 0.001);
  EXPECT_EQ(g.report.particles, 1u);
  EXPECT_NEAR(g.fluid.x[0].z(), 0.001, 5e-5);
  EXPECT_NEAR(g.fluid.v[0].z(), 0.0, 1e-6);
}

TEST(WallGuard, AWallMovingIntoAParticleCarriesItAlong)
{
  // The floor rises at 2 m/s for 5 ms (1 cm) into a particle at rest 1.1 cm above its layer: the
  // particle ends half a spacing above the moved layer (z = 0 + 1 cm), moving with the floor.
  GuardOnly g(0.001, Vec3::Zero(), 0.5, Vec3(0, 0, 2), 0.005);
  EXPECT_EQ(g.report.particles, 1u);
  EXPECT_NEAR(g.fluid.x[0].z(), 0.01, 5e-5);
  EXPECT_NEAR(g.fluid.v[0].z(), 2.0, 1e-5);
  // A particle that keeps its distance is not touched.
  GuardOnly still(0.03, Vec3(0, 0, -1), 0.5, Vec3::Zero(), 0.001);
  EXPECT_EQ(still.report.particles, 0u);
  EXPECT_EQ(still.fluid.v[0], Vec3(0, 0, -1));
}

TEST(WallGuard, AParticleInAGapClosingFromBothSidesIsLeftToThePressure)
{
  // A lid whose lower face is level with the floor's surface: their layers one spacing apart, the
  // particle at rest on the floor's surface between them (c = 0.49 from the floor + 0.42 from the
  // lid = 0.90, its own limit). The lid comes down at 2 m/s for 1 ms: c there rises to 0.97, and
  // no point within the step's reach relative to the walls (1 mm) is back at 0.90. The guard
  // leaves the particle where it is and as it is, not pushed along a normal that two walls define
  // (the squeeze test threw such a particle at 26 m/s).
  const SceneConfig s = withALid(thrownAtTheFloor(0.0, 0.0, 0.5), 0.0);
  GuardOnly g(s, 0.0, Vec3::Zero(), Vec3::Zero(), Vec3(0, 0, -2), 0.001);
  ASSERT_EQ(g.bodies.size(), 2u);
  EXPECT_EQ(g.report.particles, 0u);
  EXPECT_EQ(g.fluid.x[0], Vec3(Real(0.1), Real(0.1), Real(0)));
  EXPECT_EQ(g.fluid.v[0], Vec3::Zero());
  // The same lid at rest and the particle moving 1 mm towards the floor: where it started c is
  // back at its limit, so the guard acts as anywhere else and holds it there.
  GuardOnly moving(s, 0.0, Vec3(0, 0, -1), Vec3::Zero(), Vec3::Zero(), 0.001);
  EXPECT_EQ(moving.report.particles, 1u);
  EXPECT_NEAR(moving.fluid.x[0].z(), 0.0, 5e-5);
  EXPECT_NEAR(moving.fluid.v[0].z(), 0.0, 1e-6);
}

TEST(WallGuard, WaterAtRestIsNotTouched)
{
  // Still water in a box tank (MLS, 2 cm, 0.1 m deep): the guard never acts, and every position
  // is bit for bit what the run without it computes.
  SceneConfig off = test::waterTank(0.02, Vec3d(0.2, 0.2, 0.2), 0.1);
  ASSERT_EQ(off.solver.wall_guard, 0.0);  // the default
  SceneConfig on = off;
  on.solver.wall_guard = 0.5;
  Simulation a(on), b(off);
  for (int k = 0; k < 300; ++k)
  {
    const StepReport r = a.step(1.0);
    b.step(1.0);
    ASSERT_EQ(r.wall_guarded, 0u) << "step " << k;
  }
  ASSERT_EQ(a.numFluidParticles(), b.numFluidParticles());
  for (std::size_t i = 0; i < a.numFluidParticles(); ++i)
  {
    ASSERT_EQ(a.positions()[i], b.positions()[i]) << "particle " << i;
    ASSERT_EQ(a.velocities()[i], b.velocities()[i]) << "particle " << i;
  }
}

TEST(WallGuard, KeepsWaterInACurvedMeshContainerUnderASidewaysLoad)
{
  // Since the mesh sampler evens out the samples along a curved rim (Eq. A32), the tilted cup
  // keeps nearly all its water without the guard (MLS at 2 m/s^2: 1 of 256 lost, was 70); single-
  // term mirroring, whose wall is weakest, still loses a few at 2, 4 and 6 m/s^2, and none with it.
  std::size_t off = 0, on = 0, guarded = 0;
  for (double sideways : {2.0, 4.0, 6.0})
  {
    off += runThreeSeconds(tiltedMeshCup(0.0, true, BoundaryPressureMethod::Mirroring, sideways)).lost;
    const ThreeSeconds with_guard =
        runThreeSeconds(tiltedMeshCup(0.5, true, BoundaryPressureMethod::Mirroring, sideways));
    on += with_guard.lost;
    guarded += with_guard.guarded;
  }
  std::printf(
      "tilted mesh cup, mirroring, 2, 4 and 6 m/s^2, 3 s each: %zu of 3 x 256 particles lost without the guard, "
      "%zu with it (%zu particle-steps guarded)\n",
      off, on, guarded);
  EXPECT_GT(off, 0u) << "the case no longer needs the guard: find a harder one";
  EXPECT_EQ(on, 0u);
  EXPECT_GT(guarded, 0u);
}

TEST(CurvedMeshContainer, ABowlUnderASidewaysLoadKeepsItsWaterWithoutTheGuard)
{
  // Water (10 x 10 x 6 cm at 1 cm) in a closed hemispherical mesh bowl (r 10 cm, 48 x 16 facets,
  // walls up to 20 cm) under gravity tilted by 2 m/s^2, 3 s, no wall guard. Before the sampler
  // evened out the samples its fill leaves on curved surfaces and beside ragged lattice borders
  // (Eq. A32) the water went through the bowl: 21 (MLS), 31 (SPH) and 296 (mirroring) of 596
  // particles; now 0, 0 and 1.
  for (const auto method :
       {BoundaryPressureMethod::Mls, BoundaryPressureMethod::SphExtrapolation, BoundaryPressureMethod::Mirroring})
  {
    const ThreeSeconds run =
        runThreeSeconds(tiltedMeshContainer(test::bowlMesh(0.1, 0.2, 48, 16), true,
                                            {Vec3d(-0.05, -0.05, 0.02), Vec3d(0.05, 0.05, 0.08)}, 0.0, method, 2.0));
    std::printf("bowl, method %d: %zu of %zu particles lost in 3 s\n", int(method), run.lost, run.initial);
    EXPECT_LE(run.lost, run.initial / 100) << "method " << int(method);
  }
}

TEST(WallGuard, TheFillsRelaxationKeepsWaterOffAThinShell)
{
  // The block in an open 32-facet cup (a shell sampled on its surface, no inside), under gravity
  // tilted by 4 m/s^2: the relaxation before t = 0 settles the trimmed block, and its pseudo-steps
  // take particles to within 0.27 s of the floor's layer without the guard; with it, they stay at
  // the guard's distance (0.5 s, within the 3 % a corner's c adds). Before the sampler evened out
  // the rim (Eq. A32) one went through the floor, to z = -3.2 mm, which this test asserted; no
  // such case was found since (open cups of 12-128 facets, blocks of half-width 4-5.5 cm, all
  // three methods, sideways 0-20 m/s^2: the lowest particle inside stays 1.7 mm or more above the
  // floor), so it asserts the guard's effect on the approach instead.
  auto lowest = [](double guard) {
    Simulation sim(tiltedMeshCup(guard, false, BoundaryPressureMethod::Mls, 4.0));
    double z = 1.0;
    for (const Vec3& x : sim.positions()) z = std::min(z, double(x.z()));
    return z;
  };
  const double s = 0.01, off = lowest(0.0), on = lowest(0.5);
  std::printf("open mesh cup at t = 0: lowest particle at z = %.5f m without the guard, %.5f m with it\n", off, on);
  EXPECT_LT(off, 0.4 * s) << "the relaxation no longer brings water near the floor: find a harder case";
  EXPECT_GE(on, 0.45 * s);  // the floor's layer is on its surface, at z = 0
}

TEST(WallGuard, AFlatLayerFillsMostOfTheKernelOnItAndNoneBeyondTheSupport)
{
  // Eq. A31's c of a flat layer at 2 cm (support 4 cm): 0.70 on its plane (the volume factor
  // gamma of Eq. A3), 0.49 half a spacing off it (the guard's 0.5), 0.15 a spacing off (water at
  // rest), 0 beyond the support.
  const double s = 0.02;
  EXPECT_EQ(flatLayerFill(s, 2 * s, 0.0), flatLayerVolumeFactor(s, 2 * s));
  EXPECT_NEAR(flatLayerFill(s, 2 * s, 0.0), 0.7006, 1e-3);
  EXPECT_NEAR(flatLayerFill(s, 2 * s, 0.5 * s), 0.4870, 1e-3);
  EXPECT_NEAR(flatLayerFill(s, 2 * s, 1.0 * s), 0.1497, 1e-3);
  EXPECT_EQ(flatLayerFill(s, 2 * s, 2.0 * s), 0.0);
}

TEST(WallGuard, DistanceIsChecked)
{
  SceneConfig s = test::waterTank(0.02, Vec3d(0.2, 0.2, 0.2), 0.1);
  s.solver.wall_guard = -0.1;
  EXPECT_EQ(test::errorKey(s), "solver.wall_guard");
  s.solver.wall_guard = 1.5;
  EXPECT_EQ(test::errorKey(s), "solver.wall_guard");
  s.solver.wall_guard = 0.0;
  EXPECT_EQ(test::errorKey(s), "<no error>");
}
