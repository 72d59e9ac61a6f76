// Instruments (measurements.h): regions read the water volume they hold, probes read the
// hydrostatic pressure and read dry in air, spill counts what leaves every region, and validate()
// names bad instrument keys.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "fluid_sim/core/kernel.h"
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
  return test::waterTank(0.02, Vec3d(0.2, 0.2, 0.6), 0.4);
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

/// The vertical gradient normalisation of the SPH sum at height z in the column (Eq. A1's kernel):
/// gamma = sum_j (m / rho_j) |dW/dr| / r (z_i - z_j)^2, the factor by which Eq. 1 turns a pressure
/// that grows linearly with depth into an acceleration (1 for the exact gradient; 1.020 on the
/// start's cubic lattice). Averaged over the particles within one spacing of z and at least the
/// kernel's support from the walls, whose neighbourhoods are all fluid. Dimensionless.
double verticalGradientNormalisation(const Simulation& sim, double z)
{
  const double s = 0.02, h = 2 * s;  // m, the column's spacing and support
  const CubicKernel kernel{Real(h)};
  const auto& x = sim.positions();
  const auto& rho = sim.densities();
  double sum = 0.0;
  int count = 0;
  for (std::size_t i = 0; i < x.size(); ++i)
  {
    const Vec3 xi = x[i];
    if (std::abs(xi.z() - z) > s || xi.x() < h || xi.x() > 0.2 - h || xi.y() < h || xi.y() > 0.2 - h) continue;
    double g = 0.0;
    for (std::size_t j = 0; j < x.size(); ++j)
    {
      const Vec3 r = xi - x[j];
      const double dz = r.z();
      g -= sim.particleMass() / rho[j] * kernel.gradFactor(r.norm()) * dz * dz;  // gradFactor < 0
    }
    sum += g;
    ++count;
  }
  return count > 0 ? sum / count : 0.0;
}

TEST(Measurements, ProbeReadsHydrostaticPressureAndAirIsDry)
{
  SceneConfig s = column();
  // The Jacobi first guess (Eq. A10a), under which still water holds still. From zero (the default)
  // this column never comes to rest (below); the full validation's deep column and submerged cube
  // are why zero stays the default (docs/method_notes.md, Still water).
  s.solver.cold_start = ColdStart::Jacobi;
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
  std::vector<double> density(depths.size(), 0.0), gamma(depths.size(), 0.0);
  std::vector<std::vector<double>> readings(depths.size());  // Pa, each step's, for the swing
  int samples = 0;
  while (sim.time() < 3.0 - 1e-9)
  {
    ASSERT_FALSE(sim.step().unstable);
    if (sim.time() <= 1.0) continue;
    // Averaged over 1-3 s, once the column started from a lattice has settled.
    const MeasurementReport r = m.evaluate(sim);
    const double surface = sim.numFluidParticles() * std::pow(0.02, 3) / area;  // m
    for (std::size_t k = 0; k < depths.size(); ++k)
    {
      EXPECT_TRUE(r.probes[k].wet) << r.probes[k].name;
      mean[k] += r.probes[k].pressure;
      readings[k].push_back(r.probes[k].pressure);
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
    double swing = 0.0;  // the largest single step's departure from the mean, relative
    for (double p : readings[k]) swing = std::max(swing, std::abs(p / mean[k] - 1.0));
    gamma[k] = verticalGradientNormalisation(sim, 0.4 - depths[k]);
    std::printf(
        "probe at depth %.2f m: %.1f Pa, rho0 g d %.1f Pa, ratio %.4f (to rho0 g d / gamma %.4f, gamma %.4f); "
        "largest step swing %.3f; density %.1f kg/m^3\n",
        depths[k], mean[k], exact[k], mean[k] / exact[k], mean[k] * gamma[k] / exact[k], gamma[k], swing, density[k]);
    // Still water holds still: every step's reading within 10 % of the mean from 1 s on (the
    // Jacobi first guess, solver.cold_start: jacobi: 4 % at most, 1 % after 2 s). From zero,
    // the paper's start, each step's pressure jumped between 0.53, 0.80, 1.07 and 1.34 of the
    // mean for as long as it ran (6 s), the number of relaxed Jacobi iterations a step happened
    // to take, and the warm start swung by 60-135 % (docs/method_notes.md, Still water).
    if (depths[k] >= 0.1) EXPECT_LT(swing, 0.10) << "depth " << depths[k] << " m";
    // The 1 % below the first two layers, from 10 cm (5 spacings) down. At 5 cm the
    // probe's support (4 cm) reaches the second layer, whose pressure the free surface's density
    // deficit lowers, and the reading depends on how the top layers happened to pack (0.960 in
    // float, 1.002 in double when first measured). Not the interpolation: a linear MLS fit (Eqs.
    // 7-15, A20) of the neighbours' pressures in place of the Shepard mean read the same. Printed
    // above 10 cm, not held to 1 % (README, Instruments).
    if (depths[k] < 0.1) continue;
    // Still water in SPH does not carry exactly rho0 g d: Eq. 1 turns a pressure growing with depth
    // into gamma dp/dz / rho, so at rest dp/dz = rho0 g / gamma, and on the settled packing gamma is
    // 0.987-0.990 (1.020 on the start's lattice). From the top, the free surface's under-dense
    // layers start the pressure 1-2 mm of head late. At 10 and 20 cm the two nearly cancel (0.997,
    // 1.004); at 30 cm the first is 1.3 % and the second 0.4 %, and the reading, 1.010, is the
    // method's discretisation there, not the probe's (docs/method_notes.md, Still water). Held:
    // rho0 g d within 1 % at 10 and 20 cm, rho0 g d / gamma within 1 % at 30 cm, and the
    // hydrostatic law itself below.
    if (depths[k] <= 0.2)
      EXPECT_NEAR(mean[k] / exact[k], 1.0, 0.01) << "depth " << depths[k] << " m";
    else
      EXPECT_NEAR(mean[k] * gamma[k] / exact[k], 1.0, 0.01) << "depth " << depths[k] << " m";
    // Inside the water the SPH sum at a point is rest density within 1 % (at the particles the
    // solver holds it to 0.1 %; a settled packing is no longer a lattice, whose sum between
    // particles is within 0.2 % of the one at them).
    EXPECT_NEAR(density[k] / 1000.0, 1.0, 0.01) << "depth " << depths[k] << " m";
  }
  // The hydrostatic law between the probes at 10 and 30 cm, where the surface's offset cancels:
  // dp/dz against rho0 g / gamma, gamma the mean over the span (1.005 here; against rho0 g it is
  // 1.017, and the particles' density, 1001-1002 kg/m^3 at rest, is another 0.15 % of it).
  const double span_gamma = (gamma[2] + gamma[3] + gamma[4]) / 3.0;     // at 10, 20 and 30 cm
  const double gradient = (mean[4] - mean[2]) / (exact[4] - exact[2]);  // of rho0 g
  std::printf("dp/dz from 10 to 30 cm: %.4f of rho0 g, %.4f of rho0 g / gamma (gamma %.4f)\n", gradient,
              gradient * span_gamma, span_gamma);
  EXPECT_NEAR(gradient * span_gamma, 1.0, 0.01);
}

TEST(Measurements, DampedWarmStartHoldsStillWaterStill)
{
  // The probe test's column with solver.warm_start, read 30 cm deep after every step from 2 to
  // 3 s. With the previous step's pressure as the first guess (warm_start_guess: previous, the
  // default) each step's reading swung by up to 55 % of its mean and the water jittered at
  // 2.9 cm/s rms, as much as at 1-2 s and 3-4 s: the guess is a lagging feedback on the water's
  // compression. Half of it plus the Jacobi step of now (damped, docs/method.md Eq. A10b) held
  // every step within 0.3 % of the mean, with the same 2.00 density iterations per step, and the
  // water settling (rms 1.9, 1.0 and 0.4 cm/s over 1-2, 2-3 and 3-4 s, as the cold starts'). In
  // the double build over 2-3 s: previous 50 % and 3.0 cm/s, damped 1.7 % and 1.4 cm/s. (Cold,
  // the Jacobi guess also holds this column; in a shallower tank at 1.43 cm every cold start
  // swung by +-35 % where damped stayed within 2 %: docs/method_notes.md, Still water.)
  struct Outcome
  {
    double swing = 0.0, vrms = 0.0, iterations = 0.0;  // relative, m/s, per step
  };
  const auto run = [](WarmStartGuess guess) {
    SceneConfig s = column();
    s.solver.warm_start = true;
    s.solver.warm_start_guess = guess;
    s.probes.push_back(probe("d30", Vec3d(0.1, 0.1, 0.1)));
    Simulation sim(s);
    Measurements m(sim);
    std::vector<double> p;  // Pa
    Outcome out;
    double energy = 0.0;  // J, summed over the steps read
    while (sim.time() < 3.0 - 1e-9)
    {
      const StepReport r = sim.step();
      EXPECT_FALSE(r.unstable) << r.reason;
      if (sim.time() <= 2.0) continue;
      p.push_back(m.evaluate(sim).probes[0].pressure);
      energy += r.kinetic_energy;
      out.iterations += r.density_iterations;
    }
    double mean = 0.0;
    for (double x : p) mean += x / double(p.size());
    for (double x : p) out.swing = std::max(out.swing, std::abs(x / mean - 1.0));
    out.vrms = std::sqrt(2.0 * energy / double(p.size()) / (double(sim.numFluidParticles()) * sim.particleMass()));
    out.iterations /= double(p.size());
    return out;
  };
  const Outcome previous = run(WarmStartGuess::Previous), damped = run(WarmStartGuess::Damped);
  std::printf(
      "2-3 s, 30 cm deep: previous: swing %.3f, rms speed %.4f m/s, %.2f iterations/step; damped: swing "
      "%.3f, rms speed %.4f m/s, %.2f iterations/step\n",
      previous.swing, previous.vrms, previous.iterations, damped.swing, damped.vrms, damped.iterations);
  EXPECT_LT(damped.swing, 0.10);
  EXPECT_LT(damped.vrms, 0.02) << "m/s";
  EXPECT_LE(damped.iterations, previous.iterations + 0.1);
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
