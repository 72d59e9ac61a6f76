// Emitters (scene key `emitters`, emitters.h): the volume released, rest density without overlap,
// attachment to a moving body, budgets and the scene's checks.
#include "fluid_sim/core/emitters.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "fluid_sim/core/fluid_fill.h"
#include "fluid_sim/core/simulation.h"

#include "small_scene.h"

using namespace fluid_sim;

namespace
{
/// A dry 1 m box of a domain (no fluid, no bodies) at spacing 1 cm, a fixed 1 ms step.
SceneConfig dryScene()
{
  SceneConfig s;
  s.spacing = 0.01;
  s.domain = {Vec3d(-0.5, -0.5, -0.5), Vec3d(0.5, 0.5, 0.5)};
  s.time_step.fixed = 0.001;
  s.solver.warm_start = true;
  return s;
}

EmitterConfig tap(double flow_rate, double duration)
{
  EmitterConfig e;
  e.name = "tap";
  e.shape = NozzleShape::Circle;
  e.radius = 0.02;
  e.pose.translation = Vec3d(0, 0, 0.3);
  e.pose.rotation = Eigen::Quaterniond::FromTwoVectors(Vec3d::UnitZ(), -Vec3d::UnitZ());  // pointing down
  e.flow_rate = flow_rate;
  e.duration = duration;
  return e;
}

using fluid_sim::test::errorKey;

double closestPair(const std::vector<Vec3>& x)
{
  double best = 1e9;
  for (std::size_t i = 0; i < x.size(); ++i)
    for (std::size_t j = i + 1; j < x.size(); ++j) best = std::min(best, double((x[i] - x[j]).norm()));
  return best;
}
}  // namespace

TEST(Emitters, ReleasedVolumeIsFlowRateTimesDurationWithinOneParticle)
{
  // 0.2 l/s through a 2 cm nozzle for 0.37 s, opening at 0.05 s: 74 cm^3, not a whole number of
  // layers (13 points a layer at 1 cm). Nothing before the start, nothing after the end.
  SceneConfig s = dryScene();
  EmitterConfig e = tap(2.0e-4, 0.37);
  e.start = 0.05;
  s.emitters.push_back(e);
  Simulation sim(s);
  EXPECT_EQ(sim.numFluidParticles(), 0u);
  while (sim.time() < 0.05 - 1e-9) sim.step();
  EXPECT_EQ(sim.emitterTotals()[0].particles, 0u) << "released before its start";
  while (sim.time() < 0.6) sim.step();
  const EmitterTotal& t = sim.emitterTotals()[0];
  const double expected = 2.0e-4 * 0.37;      // m^3
  const double particle = 1e-6;               // m^3, one spacing cubed
  EXPECT_EQ(t.points, 13u);                   // |(i, j)| <= 2 on a 1 cm lattice
  EXPECT_NEAR(t.flow_rate, 2.0e-4, 1e-12);    // the speed follows from the nozzle
  EXPECT_NEAR(t.volume, expected, particle);  // within one particle
  EXPECT_LT(std::abs(t.volume - expected) / expected, 0.01);
  EXPECT_EQ(t.blocked, 0u);
  // Every released particle is either still in the domain or has fallen out of it.
  EXPECT_EQ(sim.numFluidParticles() + sim.removedTotal(), t.particles);
  const std::size_t at_end = t.particles;
  for (int k = 0; k < 50; ++k) sim.step();
  EXPECT_EQ(sim.emitterTotals()[0].particles, at_end) << "released after its end";
}

TEST(Emitters, StreamLeavesAtRestDensityAndExitSpeedWithoutSplash)
{
  // A 0.5 m/s jet pointing down: every particle is released at least half a spacing from any
  // other, none is compressed beyond the solver's tolerance, and none moves faster than free fall
  // from the nozzle allows (a release into its own stream would kick particles off).
  SceneConfig s = dryScene();
  EmitterConfig e = tap(0.0, 0.3);
  e.flow_rate = 0.0;
  e.speed = 0.5;
  s.emitters.push_back(e);
  Simulation sim(s);
  double max_speed = 0.0;
  for (int k = 0; k < 300; ++k)
  {
    const StepReport rep = sim.step();
    ASSERT_FALSE(rep.unstable) << rep.reason;
    max_speed = std::max(max_speed, rep.max_speed);
    EXPECT_GE(closestPair(sim.positions()), 0.5 * s.spacing - 1e-6) << "step " << k;
  }
  ASSERT_GT(sim.numFluidParticles(), 100u);
  for (Real rho : sim.densities()) EXPECT_LT(rho, 1000.0 * 1.01);
  // Free fall from the nozzle over 0.3 s: v = 0.5 + 9.81 x 0.3 = 3.44 m/s.
  EXPECT_LT(max_speed, 0.5 + 9.81 * 0.3 + 0.05);
  for (const Vec3& v : sim.velocities()) EXPECT_LT(std::abs(double(v.x())) + std::abs(double(v.y())), 0.05);
}

TEST(Emitters, NozzleInsideWaterLeavesOutWhatIsAlreadyThere)
{
  // A nozzle inside a resting block: the points where water already is are left out and counted,
  // nothing is released closer than half a spacing to a particle.
  SceneConfig s = dryScene();
  FluidBlockConfig block;
  block.box = {Vec3d(-0.1, -0.1, -0.1), Vec3d(0.1, 0.1, 0.1)};
  s.fluid.push_back(block);
  s.gravity = Vec3d::Zero();
  EmitterConfig e = tap(0.0, 0.2);
  e.speed = 0.2;
  e.pose.translation = Vec3d(0.005, 0.005, 0.0);  // among the lattice points
  s.emitters.push_back(e);
  Simulation sim(s);
  const std::size_t start = sim.numFluidParticles();
  for (int k = 0; k < 100; ++k) sim.step();
  const EmitterTotal& t = sim.emitterTotals()[0];
  EXPECT_GT(t.blocked, 0u);
  EXPECT_EQ(sim.numFluidParticles(), start + t.particles);
  EXPECT_GE(closestPair(sim.positions()), 0.3 * s.spacing);
}

TEST(Emitters, AttachedNozzleMovesWithItsBodyAndAddsItsVelocity)
{
  SceneConfig s = dryScene();
  s.gravity = Vec3d::Zero();
  BoundaryConfig cart;
  cart.name = "cart";
  cart.type = ShapeType::Box;
  cart.box = {Vec3d(-0.03, -0.03, 0.2), Vec3d(0.03, 0.03, 0.25)};
  cart.motion.linear_velocity = Vec3d(0.4, 0, 0);  // m/s
  s.boundaries.push_back(cart);
  EmitterConfig e = tap(0.0, 1.0);
  e.speed = 1.0;
  e.radius = 0.005;  // one point
  e.body = "cart";
  e.pose.translation = Vec3d(0, 0, 0.18);  // below the cart, in its frame (its origin is the world's at t = 0)
  s.emitters.push_back(e);
  Simulation sim(s);
  while (sim.time() < 0.2 - 1e-9) sim.step();
  const Pose nozzle = sim.emitterPose(0);
  EXPECT_NEAR(nozzle.translation.x(), 0.4 * 0.2, 0.4 * 0.0011);  // carried with the cart (posed at the step's start)
  ASSERT_GT(sim.numFluidParticles(), 10u);
  // Without gravity or neighbours in reach sideways, each particle keeps its release velocity:
  // 1 m/s down plus the cart's 0.4 m/s along x.
  for (const Vec3& v : sim.velocities())
  {
    EXPECT_NEAR(v.x(), 0.4, 0.02);
    EXPECT_NEAR(v.z(), -1.0, 0.05);
  }
}

TEST(Emitters, BudgetStopsTheNozzle)
{
  SceneConfig s = dryScene();
  EmitterConfig e = tap(2.0e-4, std::numeric_limits<double>::infinity());
  e.max_particles = 50;
  s.emitters.push_back(e);
  Simulation sim(s);
  for (int k = 0; k < 400; ++k) sim.step();
  EXPECT_EQ(sim.emitterTotals()[0].particles, 50u);
  EXPECT_TRUE(sim.emitterTotals()[0].budget_reached);
  // The scene's fluid budget bounds a nozzle without its own.
  SceneConfig g = dryScene();
  g.max_fluid_particles = 30;
  g.emitters.push_back(tap(2.0e-4, std::numeric_limits<double>::infinity()));
  Simulation capped(g);
  for (int k = 0; k < 400; ++k) capped.step();
  EXPECT_EQ(capped.numFluidParticles(), 30u);
  EXPECT_TRUE(capped.emitterTotals()[0].budget_reached);
}

TEST(Emitters, BadEntriesNameTheirKey)
{
  SceneConfig s = dryScene();
  EXPECT_EQ(errorKey(s), "fluid");  // neither water nor an emitter
  s.emitters.push_back(tap(2.0e-4, 1.0));
  EXPECT_EQ(errorKey(s), "<no error>");
  SceneConfig both = s;
  both.emitters[0].speed = 1.0;
  EXPECT_EQ(errorKey(both), "emitters[0]");
  SceneConfig none = s;
  none.emitters[0].flow_rate = 0.0;
  EXPECT_EQ(errorKey(none), "emitters[0]");
  SceneConfig radius = s;
  radius.emitters[0].radius = -0.01;
  EXPECT_EQ(errorKey(radius), "emitters[0].circle.radius");
  SceneConfig rect = s;
  rect.emitters[0].shape = NozzleShape::Rectangle;
  rect.emitters[0].size = Eigen::Vector2d(0.02, 0.0);
  EXPECT_EQ(errorKey(rect), "emitters[0].rectangle.size");
  SceneConfig body = s;
  body.emitters[0].body = "nowhere";
  EXPECT_EQ(errorKey(body), "emitters[0].body");
  SceneConfig duration = s;
  duration.emitters[0].duration = 0.0;
  EXPECT_EQ(errorKey(duration), "emitters[0].duration");
  SceneConfig name = s;
  name.emitters[0].name = "2taps";
  EXPECT_EQ(errorKey(name), "emitters[0].name");
  SceneConfig nan = s;
  nan.emitters[0].pose.translation.x() = std::nan("");
  EXPECT_EQ(errorKey(nan), "emitters[0].pose.xyz");
}

TEST(Emitters, RectangularNozzleHasItsLatticeAndRate)
{
  SceneConfig s = dryScene();
  EmitterConfig e = tap(0.0, 0.2);
  e.shape = NozzleShape::Rectangle;
  e.size = Eigen::Vector2d(0.04, 0.02);
  e.speed = 0.5;
  s.emitters.push_back(e);
  Simulation sim(s);
  const EmitterTotal& t = sim.emitterTotals()[0];
  EXPECT_EQ(t.points, 8u);  // 4 x 2 points a spacing apart
  EXPECT_NEAR(t.flow_rate, 8 * 1e-4 * 0.5, 1e-12);
  while (sim.time() < 0.3) sim.step();
  EXPECT_NEAR(sim.emitterTotals()[0].volume, 8e-4 * 0.5 * 0.2, 1e-6);
}

TEST(Emitters, AStreamTooFastForTheTimeStepIsRefusedNamingItsKey)
{
  // 2e4 for 2e-4 m^3/s: a mistyped exponent asked for 1.6e7 m/s through 13 points (a million
  // layers in the first step; the run hung there). Refused before the run, naming the key given.
  SceneConfig s = dryScene();
  s.emitters.push_back(tap(2.0e4, 1.0));
  EXPECT_EQ(errorKey(s), "emitters[0].flow_rate");
  SceneConfig fast = dryScene();
  EmitterConfig e = tap(0.0, 1.0);
  e.speed = 25.0;  // 2.5 spacings per fixed 1 ms step, stability.max_cfl is 2
  fast.emitters.push_back(e);
  EXPECT_EQ(errorKey(fast), "emitters[0].speed");
  fast.emitters[0].speed = 19.0;  // 1.9 spacings a step
  EXPECT_EQ(errorKey(fast), "<no error>");
  // An adaptive step may go down to time_step.min: 25 m/s needs 0.8 ms, which it allows.
  fast.emitters[0].speed = 25.0;
  fast.time_step.adaptive = true;
  fast.time_step.min = 1.0e-4;
  EXPECT_EQ(errorKey(fast), "<no error>");
  fast.time_step.min = 1.0e-3;
  EXPECT_EQ(errorKey(fast), "emitters[0].speed");
}

TEST(Emitters, ANozzleFixedOutsideTheDomainIsRefused)
{
  SceneConfig s = dryScene();
  EmitterConfig e = tap(2.0e-4, 1.0);
  e.pose.translation = Vec3d(5, 5, 5);
  s.emitters.push_back(e);
  EXPECT_EQ(errorKey(s), "emitters[0].pose.xyz");
}

namespace
{
/// A 0.3 m square box tank 0.5 m high at spacing 2.5 cm (MLS, the default), water `depth` deep
/// (none for 0), and an inlet of 3 cm radius set on the middle of its floor pointing up at 0.5 m/s
/// for 0.3 s (`side`: on the middle of its x = 0 wall, 0.25 m up, pointing along +x).
SceneConfig floorInlet(double depth, bool side = false)
{
  SceneConfig s = dryScene();
  s.spacing = 0.025;
  s.domain = {Vec3d(-0.1, -0.1, -0.1), Vec3d(0.4, 0.4, 0.6)};
  s.solver.warm_start = false;
  s.viscosity.model = ViscosityModel::Xsph;
  s.viscosity.coefficient = 0.05;
  s.viscosity.boundary = 0.05;
  BoundaryConfig tank;
  tank.name = "tank";
  tank.type = ShapeType::Box;
  tank.box = {Vec3d(0, 0, 0), Vec3d(0.3, 0.3, 0.5)};
  tank.inside = true;
  s.boundaries.push_back(tank);
  if (depth > 0.0)
  {
    FluidBlockConfig block;
    block.box = {Vec3d(0, 0, 0), Vec3d(0.3, 0.3, depth)};
    s.fluid.push_back(block);
  }
  EmitterConfig e = tap(0.0, 0.3);
  e.radius = 0.03;
  e.speed = 0.5;
  e.pose.translation = side ? Vec3d(0.0, 0.15, 0.25) : Vec3d(0.15, 0.15, 0.0);
  e.pose.rotation = side ? Eigen::Quaterniond::FromTwoVectors(Vec3d::UnitZ(), Vec3d::UnitX())
                         : Eigen::Quaterniond::Identity();  // the exit direction is the frame's +z
  s.emitters.push_back(e);
  return s;
}

struct InletRun
{
  std::size_t released = 0, blocked = 0;
  double closest_to_wall = 1e9;  // m, from a released particle to the walls' layer, when released
  double fastest = 0.0;          // m/s, over the run
};

InletRun runInlet(const SceneConfig& s)
{
  Simulation sim(s);
  const std::size_t start = sim.numFluidParticles();
  const std::vector<Vec3> walls = sim.boundaryPositions();
  InletRun out;
  while (sim.time() < 0.3 - 1e-9)
  {
    const std::size_t before = sim.numFluidParticles();
    const StepReport rep = sim.step();
    EXPECT_FALSE(rep.unstable) << "t = " << sim.time() << ": " << rep.reason;
    if (rep.unstable) break;
    for (std::size_t i = before; i < sim.numFluidParticles(); ++i)
      for (const Vec3& w : walls)
        out.closest_to_wall = std::min(out.closest_to_wall, double((sim.positions()[i] - w).norm()));
    for (const Vec3& v : sim.velocities()) out.fastest = std::max(out.fastest, double(v.norm()));
  }
  out.released = sim.emitterTotals()[0].particles;
  out.blocked = sim.emitterTotals()[0].blocked;
  EXPECT_EQ(sim.numFluidParticles(), start + out.released);
  return out;
}
}  // namespace

TEST(Emitters, ANozzleOnADryTanksWallReleasesWhereTheFillWould)
{
  // Its points lie on the wall's surface, half a spacing from the wall's particle layer, where
  // the fill keeps water one spacing away. The stream's particles now start half a spacing in
  // front of the opening (the middle of the slab of water that left in their time), no nearer a
  // wall's layer than the fill's trim distance. 5 points, a layer every 0.05 s: 30 in 0.3 s.
  const InletRun r = runInlet(floorInlet(0.0, true));
  EXPECT_EQ(r.released, 30u);
  EXPECT_EQ(r.blocked, 0u);
  EXPECT_GE(r.closest_to_wall, trimDistance(0.025));
  EXPECT_LT(r.fastest, 0.5 + 9.81 * 0.3 + 0.05);  // its exit speed and the fall, no burst
}

TEST(Emitters, AnInletUnderStillWaterReleasesOnlyWhereThereIsRoom)
{
  // The same inlet under 0.2 m of water at rest: the water's first layer sits where the stream's
  // would, so there is no room. It released into it before (half a spacing from water was enough)
  // and the overlap shot water off at 4.7 m/s; set on the floor's surface, it blew the MLS solve
  // up 50 steps in. Now it releases nothing, and the water moves as in the tank without it.
  const InletRun r = runInlet(floorInlet(0.2));
  EXPECT_EQ(r.released, 0u);
  EXPECT_GT(r.blocked, 0u);
  SceneConfig plain = floorInlet(0.2);
  plain.emitters.clear();
  Simulation sim(plain);
  double fastest = 0.0;  // m/s
  while (sim.time() < 0.3 - 1e-9)
  {
    sim.step();
    for (const Vec3& v : sim.velocities()) fastest = std::max(fastest, double(v.norm()));
  }
  EXPECT_DOUBLE_EQ(r.fastest, fastest);
}

TEST(Emitters, ANozzleInsideASolidReleasesNothing)
{
  SceneConfig s = dryScene();
  BoundaryConfig block;
  block.name = "block";
  block.type = ShapeType::Box;
  block.box = {Vec3d(-0.1, -0.1, 0.2), Vec3d(0.1, 0.1, 0.4)};
  s.boundaries.push_back(block);
  s.emitters.push_back(tap(2.0e-4, 0.2));  // at (0, 0, 0.3), in the block's middle
  Simulation sim(s);
  for (int k = 0; k < 250; ++k) sim.step();
  EXPECT_EQ(sim.emitterTotals()[0].particles, 0u);
  EXPECT_GT(sim.emitterTotals()[0].blocked, 0u);
  EXPECT_EQ(sim.numFluidParticles(), 0u);
}
