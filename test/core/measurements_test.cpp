// Instruments (measurements.h): regions read the water volume they hold, probes read the
// hydrostatic pressure and read dry in air, spill counts what leaves every region, and validate()
// names bad instrument keys.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "fluid_sim/core/measurements.h"
#include "fluid_sim/core/mesh_inside_index.h"
#include "fluid_sim/core/simulation.h"
#include "small_scene.h"

using namespace fluid_sim;

namespace
{
constexpr double kG = 9.81;  // m/s^2

/// Water 0.2 x 0.2 x 0.4 m at 2 cm spacing (2000 particles) in a box tank 0.6 m high: the
/// hydrostatic tests' column (MLS, XSPH 0.01).
SceneConfig column()
{
  SceneConfig s;
  s.spacing = 0.02;
  s.domain = {Vec3d(-0.1, -0.1, -0.1), Vec3d(0.3, 0.3, 0.7)};
  s.time_step.fixed = 0.001;
  s.viscosity.model = ViscosityModel::Xsph;
  s.viscosity.coefficient = 0.01;
  FluidBlockConfig f;
  f.box = {Vec3d(0, 0, 0), Vec3d(0.2, 0.2, 0.4)};
  s.fluid.push_back(f);
  BoundaryConfig tank;
  tank.name = "tank";
  tank.type = ShapeType::Box;
  tank.box = {Vec3d(0, 0, 0), Vec3d(0.2, 0.2, 0.6)};
  tank.inside = true;
  s.boundaries.push_back(tank);
  return s;
}

RegionConfig boxRegion(const std::string& name, const Vec3d& min, const Vec3d& max, const Pose& pose = Pose())
{
  RegionConfig r;
  r.name = name;
  r.shape = RegionShape::Box;
  r.box = {min, max};
  r.pose = pose;
  return r;
}

ProbeConfig probe(const std::string& name, const Vec3d& position)
{
  ProbeConfig p;
  p.name = name;
  p.position = position;
  return p;
}

std::string errorKey(const SceneConfig& s)
{
  try
  {
    validate(s);
  }
  catch (const ConfigError& e)
  {
    return e.key();
  }
  return "";
}
}  // namespace

TEST(Measurements, NoInstrumentsIsEmpty)
{
  Simulation sim(test::smallScene());
  Measurements m(sim);
  EXPECT_TRUE(m.empty());
  const MeasurementReport r = m.evaluate(sim);
  EXPECT_TRUE(r.regions.empty());
  EXPECT_TRUE(r.probes.empty());
  EXPECT_FALSE(r.spill.enabled);
}

TEST(Measurements, BoxRegionReadsTheFilledVolume)
{
  SceneConfig s = column();
  // The whole block, its lower half (10 of the 20 layers), and the lower half again as a box
  // twice as wide turned 90 degrees about z through the block's axis: the same particles.
  s.regions.push_back(boxRegion("all", Vec3d(0, 0, 0), Vec3d(0.2, 0.2, 0.4)));
  s.regions.push_back(boxRegion("lower", Vec3d(0, 0, 0), Vec3d(0.2, 0.2, 0.2)));
  s.regions.push_back(boxRegion("turned", Vec3d(-0.1, -0.2, 0), Vec3d(0.1, 0.2, 0.2),
                                Pose::fromXyzRpy(Vec3d(0.1, 0.1, 0), Vec3d(0, 0, M_PI / 2))));
  RegionConfig sphere;
  sphere.name = "ball";
  sphere.shape = RegionShape::Sphere;
  sphere.sphere = {Vec3d(0.1, 0.1, 0.2), 0.05};
  s.regions.push_back(sphere);
  Simulation sim(s);
  ASSERT_EQ(sim.numFluidParticles(), 2000u);
  Measurements m(sim);
  const MeasurementReport r = m.evaluate(sim);
  ASSERT_EQ(r.regions.size(), 4u);

  const double v = 0.02 * 0.02 * 0.02;  // m^3 per particle, m / rho0
  EXPECT_EQ(r.regions[0].name, "all");
  EXPECT_EQ(r.regions[0].particles, 2000u);
  EXPECT_NEAR(r.regions[0].volume, 2000 * v, 1e-12);
  EXPECT_NEAR(r.regions[0].volume, 0.2 * 0.2 * 0.4, 1e-9);                   // the block's volume
  EXPECT_NEAR(r.regions[0].mass, 2000 * 1000.0 * 0.02 * 0.02 * 0.02, 1e-9);  // kg, rho0 s^3 each
  EXPECT_NEAR(r.regions[0].capacity, 0.016, 1e-12);
  EXPECT_NEAR(r.regions[0].fill_fraction, 1.0, 1e-9);
  EXPECT_EQ(r.regions[1].particles, 1000u);
  EXPECT_NEAR(r.regions[1].fill_fraction, 1.0, 1e-9);
  EXPECT_EQ(r.regions[2].particles, 1000u);
  EXPECT_NEAR(r.regions[2].capacity, 0.016, 1e-12);
  EXPECT_NEAR(r.regions[2].fill_fraction, 0.5, 1e-9);
  EXPECT_NEAR(r.regions[3].capacity, 4.0 / 3.0 * M_PI * 0.05 * 0.05 * 0.05, 1e-12);
  EXPECT_GT(r.regions[3].particles, 0u);
  EXPECT_LT(r.regions[3].particles, 1000u);
  EXPECT_TRUE(r.regions[0].mean_velocity.isZero(0));
}

TEST(Measurements, RegionMeanVelocityAndSpill)
{
  // The small scene's cube falls freely (no walls). Region: where it starts; spill below z = 0.
  SceneConfig s = test::smallScene();
  s.regions.push_back(boxRegion("start", Vec3d(-0.05, -0.05, 0), Vec3d(0.25, 0.25, 0.25)));
  s.spill.enabled = true;
  s.spill.below = 0.0;
  Simulation sim(s);
  Measurements m(sim);
  const std::size_t n = sim.numFluidParticles();
  MeasurementReport r = m.evaluate(sim);
  EXPECT_EQ(r.regions[0].particles, n);
  EXPECT_EQ(r.spill.particles, 0u);
  while (sim.time() < 0.12) ASSERT_FALSE(sim.step().unstable);
  // Fallen about g t^2 / 2 = 7 cm: the lower layers have left the region, below z = 0.
  r = m.evaluate(sim);
  ASSERT_EQ(sim.numFluidParticles(), n);
  EXPECT_GT(r.spill.particles, 0u);
  EXPECT_LT(r.regions[0].particles, n);
  EXPECT_EQ(r.regions[0].particles + r.spill.particles, n);
  EXPECT_NEAR(r.spill.volume, double(r.spill.particles) * 0.05 * 0.05 * 0.05, 1e-12);
  // Free fall: every particle moves at about -g t.
  EXPECT_NEAR(r.regions[0].mean_velocity.z(), -kG * sim.time(), 0.05 * kG * sim.time());
  EXPECT_NEAR(r.regions[0].mean_velocity.x(), 0.0, 1e-3);

  // Nothing is spilt below a height no particle reaches.
  s.spill.below = -1.0;
  Simulation sim2(s);
  Measurements m2(sim2);
  while (sim2.time() < 0.12) ASSERT_FALSE(sim2.step().unstable);
  EXPECT_EQ(m2.evaluate(sim2).spill.particles, 0u);
}

TEST(Measurements, ProbeReadsHydrostaticPressureAndAirIsDry)
{
  SceneConfig s = column();
  // On the column's axis at depths 5-30 cm below the 0.4 m surface (the first two layers are the
  // top 4 cm), one in the air above it and one on the dry tank wall above the water.
  const std::vector<double> depths = {0.05, 0.08, 0.1, 0.2, 0.3};  // m
  for (std::size_t k = 0; k < depths.size(); ++k)
    s.probes.push_back(probe("d" + std::to_string(k), Vec3d(0.1, 0.1, 0.4 - depths[k])));
  s.probes.push_back(probe("air", Vec3d(0.1, 0.1, 0.5)));
  s.probes.push_back(probe("dry_wall", Vec3d(0.0, 0.1, 0.55)));
  Simulation sim(s);
  Measurements m(sim);
  const double area = 0.2 * 0.2;  // m^2
  std::vector<double> mean(depths.size(), 0.0), exact(depths.size(), 0.0);
  std::vector<double> density(depths.size(), 0.0);
  int samples = 0;
  while (sim.time() < 3.0 - 1e-9)
  {
    ASSERT_FALSE(sim.step().unstable);
    if (sim.time() <= 1.0) continue;
    // Averaged over 1-3 s. The column started from a lattice still bounces: each step's pressure
    // swings by +-30 % of rho0 g d in phase over the whole column (vrms 1.5-3 cm/s at 1-2 s).
    // Means over 0.6-1.0 s, as first written, moved by 5 % between the float and the double
    // build (0.95 and 1.006 at 5 cm); over 1-3 s they agree within 0.4 % from 10 cm down.
    const MeasurementReport r = m.evaluate(sim);
    const double surface = sim.numFluidParticles() * std::pow(0.02, 3) / area;  // m
    for (std::size_t k = 0; k < depths.size(); ++k)
    {
      EXPECT_TRUE(r.probes[k].wet) << r.probes[k].name;
      mean[k] += r.probes[k].pressure;
      exact[k] += 1000.0 * kG * (surface - r.probes[k].position.z());
      density[k] += r.probes[k].density;
    }
    for (std::size_t k : {depths.size(), depths.size() + 1})
    {
      EXPECT_FALSE(r.probes[k].wet) << r.probes[k].name;
      EXPECT_EQ(r.probes[k].pressure, 0.0);
      EXPECT_TRUE(r.probes[k].velocity.isZero(0));
    }
    EXPECT_EQ(r.probes[depths.size()].density, 0.0);
    ++samples;
  }
  ASSERT_GT(samples, 0);
  for (std::size_t k = 0; k < depths.size(); ++k)
  {
    mean[k] /= samples;
    exact[k] /= samples;
    density[k] /= samples;
    std::printf("probe at depth %.2f m: %.1f Pa, rho0 g d %.1f Pa, ratio %.4f; density %.1f kg/m^3\n", depths[k],
                mean[k], exact[k], mean[k] / exact[k], density[k]);
    // The 1 % below the first two layers, from 10 cm (5 spacings) down: 0.991, 1.001 and
    // 1.002 of rho0 g d at 10, 20 and 30 cm in float, 0.999, 1.000, 1.003 in double. At 5 cm the
    // probe's support (4 cm) reaches the second layer, whose pressure the free surface's density
    // deficit lowers, and the reading depends on how the top layers happened to pack: 0.960 in
    // float, 1.002 in double. Not the interpolation: a linear MLS fit (Eqs. 7-15, A20) of the
    // neighbours' pressures in place of the Shepard mean read 0.963 in the same float run (1.003
    // in double); the particles' own pressures there are low, with the density at the probe 1.4 %
    // above rho0 (a denser packing, whose irregular gradient sum, Eq. 1, balances gravity with
    // less pressure). Nor the top layers alone: from 5 to 9 cm, in 1 cm steps, the deficit was
    // 12.6, 11.8, 16.5, 12.7 and 9.2 Pa in float (-1, -3, +8, +16 and +8 Pa in double), a pattern
    // of the packing some centimetres long, about rho0 g s / 10 in size; 1 % of rho0 g d is that
    // much only from 5-9 spacings down. Printed above 10 cm, not held to 1 % (README, Instruments).
    if (depths[k] < 0.1) continue;
    EXPECT_NEAR(mean[k] / exact[k], 1.0, 0.01) << "depth " << depths[k] << " m";
    // Inside the water the SPH sum at a point is rest density within 1 %: 1.003-1.007 here (at
    // the particles the solver holds it to 0.1 %; a settled packing is no longer a lattice, whose
    // sum between particles is within 0.2 % of the one at them). At 5 cm it read 0.997 in double
    // and 1.014 in float, the same packing of the top layers.
    EXPECT_NEAR(density[k] / 1000.0, 1.0, 0.01) << "depth " << depths[k] << " m";
  }
}

/// A unit cube's surface (outward triangles), without its top face (z = 1) when `open`.
TriangleMesh cubeMesh(bool open)
{
  TriangleMesh m;
  for (int k = 0; k < 8; ++k) m.vertices.emplace_back(k & 1, (k >> 1) & 1, (k >> 2) & 1);
  m.triangles = {{0, 2, 1}, {1, 2, 3}, {0, 1, 5}, {0, 5, 4}, {1, 3, 7},
                 {1, 7, 5}, {3, 2, 6}, {3, 6, 7}, {2, 0, 4}, {2, 4, 6}};
  if (!open) m.triangles.insert(m.triangles.end(), {{4, 5, 7}, {4, 7, 6}});
  return m;
}

TEST(Measurements, OpeningsAreClosedOverTheRim)
{
  EXPECT_NEAR(enclosedVolume(cubeMesh(false)), 1.0, 1e-12);
  const TriangleMesh closed = closeOpenings(cubeMesh(true));  // a box-shaped cup, open at z = 1
  EXPECT_EQ(closed.vertices.size(), 9u);                      // the rim's centroid
  EXPECT_EQ(closed.triangles.size(), 14u);                    // four fan triangles
  EXPECT_NEAR(enclosedVolume(closed), 1.0, 1e-12);
  EXPECT_GT(windingNumber(closed, Vec3d(0.5, 0.5, 0.9)), 0);
  EXPECT_EQ(windingNumber(closed, Vec3d(0.5, 0.5, 1.1)), 0);
  // Inward triangles come back outward; a closed mesh keeps its triangles.
  TriangleMesh inward = cubeMesh(true);
  for (auto& t : inward.triangles) std::swap(t[1], t[2]);
  EXPECT_NEAR(enclosedVolume(closeOpenings(inward)), 1.0, 1e-12);
  EXPECT_EQ(closeOpenings(cubeMesh(false)).triangles.size(), 12u);
}

TEST(Measurements, BodyRegionFollowsItsBody)
{
  // The column's tank (a box container 0.2 x 0.2 x 0.6 m) and an open box-shaped cup mesh
  // 0.1 m wide and high standing in the water, turned 90 degrees about x: its opening faces -y,
  // so its inside (closed over the rim) is the box [0.055, 0.155]^3, whose faces lie between
  // the lattice's planes (0.01 + 0.02 k).
  SceneConfig s = column();
  BoundaryConfig cup;
  cup.name = "cup";
  cup.type = ShapeType::Mesh;
  cup.mesh = cubeMesh(true);
  for (auto& v : cup.mesh.vertices) v *= 0.1;
  cup.mesh_closed = false;
  cup.mesh_offset = SurfaceOffset::None;
  // Turned about x, the cup's (x, y, z) goes to (x, -z, y): it spans y in [-0.1, 0] before the shift.
  cup.pose = Pose::fromXyzRpy(Vec3d(0.055, 0.155, 0.055), Vec3d(M_PI / 2, 0, 0));
  s.boundaries.push_back(cup);
  RegionConfig tank, inside_cup;
  tank.name = "tank_inside";
  tank.shape = RegionShape::Body;
  tank.body = "tank";
  inside_cup.name = "cup_inside";
  inside_cup.shape = RegionShape::Body;
  inside_cup.body = "cup";
  s.regions = {tank, inside_cup, boxRegion("same_box", Vec3d(0.055, 0.055, 0.055), Vec3d(0.155, 0.155, 0.155))};
  s.fill.trim = false;  // keep the lattice points along the cup's walls
  s.fill.relax = false;
  Simulation sim(s);
  Measurements m(sim);
  const MeasurementReport r = m.evaluate(sim);
  EXPECT_NEAR(r.regions[0].capacity, 0.2 * 0.2 * 0.6, 1e-12);
  EXPECT_EQ(r.regions[0].particles, sim.numFluidParticles());
  EXPECT_NEAR(r.regions[1].capacity, 0.001, 1e-12);
  // The lattice points 0.07 ... 0.13 on each axis (the fill drops those at 0.15, half a spacing
  // from the cup's wall): the particles of the box region of the same place.
  EXPECT_EQ(r.regions[1].particles, 4u * 4u * 4u);
  EXPECT_EQ(r.regions[1].particles, r.regions[2].particles);
  EXPECT_NEAR(r.regions[1].fill_fraction, 64 * 0.02 * 0.02 * 0.02 / 0.001, 1e-9);
}

TEST(Measurements, BodyRegionNamesAMissingBody)
{
  SceneConfig s = column();
  RegionConfig r;
  r.name = "cup";
  r.shape = RegionShape::Body;
  r.body = "mug";
  s.regions.push_back(r);
  Simulation sim(s);
  try
  {
    Measurements m(sim);
    ADD_FAILURE() << "no error";
  }
  catch (const ConfigError& e)
  {
    EXPECT_EQ(e.key(), "regions[0].body");
    EXPECT_NE(std::string(e.what()).find("no boundary body named 'mug' (bodies: tank)"), std::string::npos) << e.what();
  }
}

TEST(Measurements, Wetness)
{
  EXPECT_TRUE(wetness(1.0, 0.0));   // deep in water
  EXPECT_TRUE(wetness(0.5, 0.0));   // on a flat free surface
  EXPECT_FALSE(wetness(0.4, 0.0));  // above it
  EXPECT_TRUE(wetness(0.5, 0.5));   // on a submerged wall
  EXPECT_FALSE(wetness(0.0, 0.5));  // on a dry floor
  EXPECT_FALSE(wetness(0.0, 1.2));  // among thick wall samples, no water
  EXPECT_FALSE(wetness(0.0, 0.0));  // in the air
}

TEST(Measurements, ValidateNamesBadInstruments)
{
  SceneConfig s = test::smallScene();
  s.regions.push_back(boxRegion("cup", Vec3d(0, 0, 0), Vec3d(0.1, 0.1, 0.1)));
  EXPECT_EQ(errorKey(s), "");
  s.regions.push_back(boxRegion("cup", Vec3d(0, 0, 0), Vec3d(0.1, 0.1, 0.1)));
  EXPECT_EQ(errorKey(s), "regions[1].name");  // duplicate
  s.regions[1].name = "my cup";
  EXPECT_EQ(errorKey(s), "regions[1].name");  // no ROS name
  s.regions[1].name = "2cup";
  EXPECT_EQ(errorKey(s), "regions[1].name");
  s.regions[1].name = "cup_2";
  EXPECT_EQ(errorKey(s), "");
  s.regions[1].box.max.z() = -0.1;
  EXPECT_EQ(errorKey(s), "regions[1].box");
  s.regions[1].box.max.z() = 0.1;
  RegionConfig ball;
  ball.name = "bowl";
  ball.shape = RegionShape::Sphere;
  ball.sphere.radius = 0.0;
  s.regions.push_back(ball);
  EXPECT_EQ(errorKey(s), "regions[2].sphere.radius");
  s.regions[2].sphere.radius = 0.1;
  EXPECT_EQ(errorKey(s), "");

  s.probes.push_back(probe("p1", Vec3d(0, 0, 0)));
  s.probes.push_back(probe("p1", Vec3d(0, 0, 0.1)));
  EXPECT_EQ(errorKey(s), "probes[1].name");
  s.probes[1].name = "p2";
  s.probes[1].position.x() = std::nan("");
  EXPECT_EQ(errorKey(s), "probes[1].position");
  s.probes[1].position.x() = 0;
  s.spill.enabled = true;
  s.spill.below = INFINITY;
  EXPECT_EQ(errorKey(s), "spill.below");
}
