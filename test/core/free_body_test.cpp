// Free rigid bodies (rigid_dynamics.h): mass properties of every shape, free flight, resting on a
// floor through contacts (Bullet's, the default, and the particle contacts, contacts.model:
// particles), floating at the draft Archimedes gives, and a heavy body that sinks.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>

#include "fluid_sim/core/bodies.h"
#include "fluid_sim/core/rigid_dynamics.h"
#include "fluid_sim/core/simulation.h"
#include "small_scene.h"

using namespace fluid_sim;

namespace
{
constexpr double kG = 9.81;  // m/s^2

BoundaryConfig freeBox(const std::string& name, const Vec3d& min, const Vec3d& max, double density)
{
  BoundaryConfig b;
  b.name = name;
  b.type = ShapeType::Box;
  b.box = {min, max};
  b.dynamic.enabled = true;
  b.dynamic.density = density;
  return b;
}

/// A unit cube's closed surface (outward triangles), scaled by `a` and moved by `o`.
TriangleMesh cubeMesh(double a, const Vec3d& o)
{
  TriangleMesh m;
  for (int k = 0; k < 8; ++k) m.vertices.push_back(o + a * Vec3d(k & 1, (k >> 1) & 1, (k >> 2) & 1));
  m.triangles = {{0, 2, 1}, {1, 2, 3}, {0, 1, 5}, {0, 5, 4}, {1, 3, 7}, {1, 7, 5},
                 {3, 2, 6}, {3, 6, 7}, {2, 0, 4}, {2, 4, 6}, {4, 5, 7}, {4, 7, 6}};
  return m;
}

}  // namespace

TEST(FreeBodyMass, PrimitivesAndMeshesHaveTheirTextbookProperties)
{
  // Box 0.1 x 0.2 x 0.3 m at density 500: m = 3 kg, I = m/12 (b^2 + c^2, ...).
  BoundaryConfig box = freeBox("b", Vec3d(0, 0, 0), Vec3d(0.1, 0.2, 0.3), 500.0);
  MassProperties mp = massProperties(box, "b");
  EXPECT_NEAR(mp.mass, 3.0, 1e-12);
  EXPECT_TRUE(mp.com.isApprox(Vec3d(0.05, 0.1, 0.15), 1e-12));
  EXPECT_NEAR(mp.inertia(0, 0), 3.0 / 12 * (0.04 + 0.09), 1e-12);
  EXPECT_NEAR(mp.inertia(2, 2), 3.0 / 12 * (0.01 + 0.04), 1e-12);
  EXPECT_NEAR(mp.inertia(0, 1), 0.0, 1e-15);

  // The same box as a closed mesh gives the same properties (tetrahedra from the origin).
  BoundaryConfig mesh = box;
  mesh.type = ShapeType::Mesh;
  mesh.mesh = cubeMesh(1.0, Vec3d::Zero());
  for (Vec3d& v : mesh.mesh.vertices) v = v.cwiseProduct(Vec3d(0.1, 0.2, 0.3)) + Vec3d(1, 2, 3);
  mp = massProperties(mesh, "m");
  EXPECT_NEAR(mp.mass, 3.0, 1e-9);
  EXPECT_TRUE(mp.com.isApprox(Vec3d(1.05, 2.1, 3.15), 1e-9));
  EXPECT_NEAR(mp.inertia(0, 0), 3.0 / 12 * (0.04 + 0.09), 1e-9);
  EXPECT_NEAR(mp.inertia(1, 1), 3.0 / 12 * (0.01 + 0.09), 1e-9);
  EXPECT_NEAR(mp.inertia(1, 2), 0.0, 1e-9);

  // Sphere: I = 2/5 m r^2. Cylinder along (1, 1, 0): 1/2 m r^2 about the axis, m (3 r^2 + l^2)/12 across.
  BoundaryConfig sphere = box;
  sphere.type = ShapeType::Sphere;
  sphere.sphere = {Vec3d(0, 0, 1), 0.1};
  sphere.dynamic.density = 0.0;
  sphere.dynamic.mass = 2.0;
  mp = massProperties(sphere, "s");
  EXPECT_NEAR(mp.inertia(1, 1), 0.4 * 2.0 * 0.01, 1e-12);
  BoundaryConfig cyl = box;
  cyl.type = ShapeType::Cylinder;
  cyl.cylinder = {Vec3d(0, 0, 0), Vec3d(1, 1, 0), 0.1, 0.4};
  mp = massProperties(cyl, "c");
  const double m = 500.0 * M_PI * 0.01 * 0.4;
  const Vec3d axis = Vec3d(1, 1, 0).normalized();
  EXPECT_NEAR(axis.dot(mp.inertia * axis), 0.5 * m * 0.01, 1e-9);
  EXPECT_NEAR(Vec3d::UnitZ().dot(mp.inertia * Vec3d::UnitZ()), m * (0.03 + 0.16) / 12.0, 1e-9);

  // A given centre of mass moves the shape's inertia there (parallel axes: + m d^2 across d).
  box.dynamic.center_of_mass = Vec3d(0.05, 0.1, 0.05);  // 0.1 m below the centroid
  mp = massProperties(box, "b");
  EXPECT_NEAR(mp.inertia(0, 0), 3.0 / 12 * (0.04 + 0.09) + 3.0 * 0.01, 1e-12);
  EXPECT_NEAR(mp.inertia(2, 2), 3.0 / 12 * (0.01 + 0.04), 1e-12);
}

TEST(FreeBodyMass, OpenOrInsideOutMeshesAndBadEntriesAreRefusedByName)
{
  SceneConfig s = test::waterTank(0.05, Vec3d(1, 1, 1), 0.0);
  BoundaryConfig mesh = freeBox("crate", Vec3d::Zero(), Vec3d::Zero(), 600.0);
  mesh.type = ShapeType::Mesh;
  mesh.mesh = cubeMesh(0.2, Vec3d(0.4, 0.4, 0.4));
  for (auto& t : mesh.mesh.triangles) std::swap(t[1], t[2]);  // inward normals
  s.boundaries.push_back(mesh);
  try
  {
    Simulation sim(s);
    FAIL() << "an inside-out mesh was accepted";
  }
  catch (const ConfigError& e)
  {
    EXPECT_NE(std::string(e.what()).find("crate"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("boundaries[1].dynamic"), std::string::npos) << e.what();
  }
  s.boundaries[1].mesh_closed = false;
  try
  {
    validate(s);
    FAIL() << "an open mesh without mass and inertia was accepted";
  }
  catch (const ConfigError& e)
  {
    EXPECT_NE(std::string(e.what()).find("open mesh"), std::string::npos) << e.what();
  }
  // With mass and inertia but no centre of mass it still has none to take (the message used to
  // ask only for the two it had).
  s.boundaries[1].dynamic.density = 0.0;
  s.boundaries[1].dynamic.mass = 2.0;
  s.boundaries[1].dynamic.inertia = std::array<double, 6>{0.01, 0.01, 0.01, 0, 0, 0};
  try
  {
    validate(s);
    FAIL() << "an open mesh without a centre of mass was accepted";
  }
  catch (const ConfigError& e)
  {
    EXPECT_NE(std::string(e.what()).find("center_of_mass"), std::string::npos) << e.what();
  }
  s.boundaries[1].dynamic.center_of_mass = Vec3d(0.5, 0.5, 0.5);
  EXPECT_NO_THROW(validate(s));
  s.boundaries[1] = freeBox("crate", Vec3d(0.4, 0.4, 0.4), Vec3d(0.6, 0.6, 0.6), 600.0);
  // A centre of mass beyond the body (5 m from a 0.2 m box): a unit or frame mistake.
  s.boundaries[1].dynamic.center_of_mass = Vec3d(5.0, 0.5, 0.5);
  try
  {
    Simulation sim(s);
    FAIL() << "a centre of mass 5 m outside the box was accepted";
  }
  catch (const ConfigError& e)
  {
    EXPECT_EQ(e.key(), "boundaries[1].dynamic.center_of_mass") << e.what();
  }
  s.boundaries[1].dynamic.center_of_mass = Vec3d(0.5, 0.5, 0.45);  // off-centre, inside
  EXPECT_NO_THROW(Simulation sim(s));
  s.boundaries[1].dynamic.center_of_mass.reset();
  s.boundaries[1].dynamic.density = 0.0;  // given as zero: the message says what it got
  try
  {
    validate(s);
    FAIL() << "a density of 0 was accepted";
  }
  catch (const ConfigError& e)
  {
    EXPECT_NE(std::string(e.what()).find("got density 0"), std::string::npos) << e.what();
  }
  s.boundaries[1].dynamic.density = 600.0;
  s.boundaries[1].dynamic.mass = 2.0;  // both density and mass
  EXPECT_THROW(validate(s), ConfigError);
  s.boundaries[1].dynamic.density = 0.0;
  s.boundaries[1].dynamic.inertia = std::array<double, 6>{1.0, 1.0, 3.0, 0, 0, 0};  // 1 + 1 < 3
  EXPECT_THROW(validate(s), ConfigError);
  s.boundaries[1].dynamic.inertia.reset();
  s.boundaries[0].dynamic = s.boundaries[1].dynamic;  // the tank, a container
  EXPECT_THROW(validate(s), ConfigError);
}

TEST(FreeBody, FliesOnAParabolaAndKeepsItsSpinWithoutFluid)
{
  SceneConfig s = test::waterTank(0.05, Vec3d(1, 1, 1), 0.0);
  s.domain = {Vec3d(-1, -1, -2), Vec3d(2, 1, 1)};
  s.boundaries.clear();
  s.fluid[0].box = {Vec3d(1.5, 0.5, 0.5), Vec3d(1.6, 0.6, 0.6)};  // away from the body
  BoundaryConfig b = freeBox("brick", Vec3d(-0.1, -0.05, -0.025), Vec3d(0.1, 0.05, 0.025), 800.0);
  b.dynamic.linear_velocity = Vec3d(1.0, 0.0, 2.0);
  b.dynamic.angular_velocity = Vec3d(0.0, 0.0, 3.0);  // about a principal axis
  s.boundaries.push_back(b);
  Simulation sim(s);
  const double dt = 0.001;
  for (int k = 0; k < 400; ++k) ASSERT_FALSE(sim.step().unstable);
  const BodyInfo info = sim.body(0);
  const double t = sim.time();
  EXPECT_TRUE(info.free);
  EXPECT_NEAR(info.mass, 800.0 * 0.2 * 0.1 * 0.05, 1e-12);
  // Symplectic Euler: z = v0 t - g t^2 / 2 - g dt t / 2 exactly for constant gravity.
  EXPECT_NEAR(info.center_of_mass.x(), 1.0 * t, 1e-9);
  EXPECT_NEAR(info.center_of_mass.z(), 2.0 * t - 0.5 * kG * t * t - 0.5 * kG * dt * t, 1e-9);
  EXPECT_NEAR(info.com_velocity.z(), 2.0 - kG * t, 1e-9);
  EXPECT_TRUE(info.angular_velocity.isApprox(Vec3d(0, 0, 3.0), 1e-12));
  const double yaw = 2.0 * std::atan2(info.pose.rotation.z(), info.pose.rotation.w());
  EXPECT_NEAR(yaw, 3.0 * t, 1e-9);
  // The boundary particles move with it: their velocities are the body's at their place.
  const Vec3 xb = sim.boundaryPositions()[info.first_particle];
  const Vec3d expected = info.com_velocity + info.angular_velocity.cross(xb.cast<double>() - info.center_of_mass);
  EXPECT_TRUE(sim.boundaryVelocities()[info.first_particle].cast<double>().isApprox(expected, 1e-5));
}

namespace
{
/// Contacts that make every free body's velocity NaN (a stand-in for a contact solver that failed).
struct PoisonedContacts : ContactResolver
{
  void apply(BodySet& bodies, double) override
  {
    for (std::size_t k = 0; k < bodies.size(); ++k)
      if (bodies[k].free) bodies[k].v_com.x() = std::numeric_limits<double>::quiet_NaN();
  }
};
struct NoContacts : ContactResolver
{
  void apply(BodySet&, double) override {}
};
}  // namespace

TEST(FreeBody, ANonFiniteStepIsNamedAndLeavesThePoseAlone)
{
  // What the demo once showed under load: a free body whose step gave NaN spread to every
  // particle in the next step. Now the step names the body and where the NaN came from.
  SceneConfig s = test::waterTank(0.05, Vec3d(1, 1, 1), 0.0);
  s.boundaries.clear();
  s.boundaries.push_back(freeBox("brick", Vec3d(-0.1, -0.05, -0.025), Vec3d(0.1, 0.05, 0.025), 800.0));
  s.boundaries.back().pose.translation = Vec3d(0.5, 0.5, 0.5);
  {
    BodySet bodies(s);
    NoContacts none;
    bodies[0].force = Vec3d(std::numeric_limits<double>::infinity(), 0, 0);  // N, as from a blown-up fluid
    const std::string fault = bodies.stepFree(0.001, s.gravity, none);
    EXPECT_NE(fault.find("'brick'"), std::string::npos) << fault;
    EXPECT_NE(fault.find("from the fluid's wrench"), std::string::npos) << fault;
    EXPECT_TRUE(bodies[0].pose.translation.isApprox(Vec3d(0.5, 0.5, 0.5))) << "the pose stays finite";
  }
  {
    BodySet bodies(s);
    PoisonedContacts poison;
    const std::string fault = bodies.stepFree(0.001, s.gravity, poison);
    EXPECT_NE(fault.find("'brick'"), std::string::npos) << fault;
    EXPECT_NE(fault.find("from the contacts"), std::string::npos) << fault;
    EXPECT_TRUE(bodies[0].pose.translation.allFinite());
  }
  {
    BodySet bodies(s);
    NoContacts none;
    EXPECT_EQ(bodies.stepFree(0.001, s.gravity, none), "");  // a finite step says nothing
  }
}

namespace
{
struct Resting
{
  BodyInfo body;
  double max_speed_late = 0.0;  // m/s after 0.5 s
};

/// A dense box dropped 3 cm onto a dry tank floor, for 1 s, with the given contact model.
Resting dropOnFloor(double s, ContactModel model)
{
  SceneConfig scene = test::waterTank(s, Vec3d(0.4, 0.4, 0.4), 0.0);
  scene.contacts.model = model;
  scene.boundaries.push_back(freeBox("block", Vec3d(0.12, 0.12, 0.03), Vec3d(0.24, 0.22, 0.09), 2000.0));
  Simulation sim(scene);
  Resting out;
  while (sim.time() < 1.0 - 1e-9)
  {
    EXPECT_FALSE(sim.step().unstable);
    if (sim.time() > 0.5) out.max_speed_late = std::max(out.max_speed_late, sim.body(1).com_velocity.norm());
  }
  out.body = sim.body(1);
  const BodyInfo& b = out.body;
  std::printf(
      "%s: block's centre of mass at z %.5f m (resting geometrically: 0.03 m), speed after 0.5 s <= %.2e m/s, "
      "contact force %.3f N (m g %.3f N), tilt %.2e rad\n",
      toString(model), b.center_of_mass.z(), out.max_speed_late, b.contact_force.z(), b.mass * kG,
      2.0 * std::asin(std::hypot(b.pose.rotation.x(), b.pose.rotation.y())));
  return out;
}
}  // namespace

TEST(FreeBody, ComesToRestOnTheFloorWithoutJitter)
{
  // Bullet's contacts (the default): on the floor's geometry, within 0.1 mm.
  const double s = 0.02;
  const Resting r = dropOnFloor(s, ContactModel::Bullet);
  const BodyInfo& b = r.body;
  EXPECT_NEAR(b.center_of_mass.z(), 0.03, 0.005 * s);
  EXPECT_LT(r.max_speed_late, 1e-3);  // 3.5e-4 m/s measured
  EXPECT_NEAR(b.contact_force.z(), b.mass * kG, 0.01 * b.mass * kG);
  // Nothing pushes it sideways, but Bullet's contact points, solved one after another in single
  // precision, shift the landing box by 0.11 mm here (the particle contacts: below 1e-6 m).
  EXPECT_NEAR(b.center_of_mass.x(), 0.18, 0.01 * s);
}

TEST(FreeBody, ComesToRestOnTheFloorWithParticleContacts)
{
  // contacts.model: particles: the two boundary layers one spacing apart, nesting by up to
  // 0.29 s where the lattices are offset (here they are aligned).
  const double s = 0.02;
  const Resting r = dropOnFloor(s, ContactModel::Particles);
  const BodyInfo& b = r.body;
  EXPECT_NEAR(b.center_of_mass.z(), 0.03, 0.3 * s);
  EXPECT_LT(r.max_speed_late, 1e-3);
  EXPECT_NEAR(b.contact_force.z(), b.mass * kG, 0.01 * b.mass * kG);
  EXPECT_NEAR(b.center_of_mass.x(), 0.18, 1e-6);
}

namespace
{
struct Floating
{
  double draft = 0.0;       // m, mean over the last second: water level minus the body's bottom
  double expected = 0.0;    // m, Archimedes: rho_b / rho0 times the height
  double heave_rms = 0.0;   // m, of the centre of mass about its mean over the last second
  double tilt = 0.0;        // rad, largest over the last second
  double tank_force = 0.0;  // N, the fluid's vertical force on the tank, mean over the last second
  double weight = 0.0;      // N, of the water and the box
  bool stable = true;
};

/// A box `a` wide and `h` high of `density` released with its bottom at the draft Archimedes
/// gives, in water 0.15 m deep at spacing `s` in a 0.3 x 0.3 m tank, for `duration` seconds (MLS).
Floating floatBox(double s, double a, double h, double density, double duration)
{
  const Vec3d size(0.3, 0.3, 0.3);
  SceneConfig scene = test::waterTank(s, size, 0.15);
  const double expected = density / 1000.0 * h;  // m
  // The level once the box displaces its own mass of water: rest level plus that over the area.
  const double level = 0.15 + density * a * a * h / 1000.0 / (size.x() * size.y());  // m
  const Vec3d c(0.15, 0.15, level - expected + 0.5 * h);
  scene.boundaries.push_back(
      freeBox("float", c - Vec3d(0.5 * a, 0.5 * a, 0.5 * h), c + Vec3d(0.5 * a, 0.5 * a, 0.5 * h), density));
  Simulation sim(scene);
  Floating out;
  out.expected = expected;
  std::vector<double> z;
  while (sim.time() < duration - 1e-9)
  {
    const StepReport r = sim.step();
    if (r.unstable)
    {
      out.stable = false;
      return out;
    }
    if (sim.time() < duration - 1.0) continue;
    const BodyInfo b = sim.body(1);
    // The water's level from its volume (each particle stands for s^3) and the part of the box
    // below it, which is the draft itself: level = (N s^3 + a^2 d) / A, d = level - bottom.
    const double bottom = b.center_of_mass.z() - 0.5 * h;  // m, the box kept level (tilt checked)
    const double water = sim.numFluidParticles() * s * s * s;
    const double area = size.x() * size.y();
    const double draft = (water / area - bottom) / (1.0 - a * a / area);
    out.draft += draft;
    out.tank_force += sim.body(0).force.z();
    z.push_back(b.center_of_mass.z());
    out.tilt = std::max(out.tilt, 2.0 * std::asin(std::min(1.0, std::hypot(b.pose.rotation.x(), b.pose.rotation.y()))));
  }
  out.draft /= double(z.size());
  out.tank_force /= double(z.size());
  out.weight = (sim.numFluidParticles() * sim.particleMass() + sim.body(1).mass) * kG;
  double mean = 0.0;
  for (double v : z) mean += v / double(z.size());
  for (double v : z) out.heave_rms += (v - mean) * (v - mean) / double(z.size());
  out.heave_rms = std::sqrt(out.heave_rms);
  return out;
}
}  // namespace

TEST(FreeBody, FloatsAtTheDraftArchimedesGives)
{
  // A flat box 8 x 8 x 3 spacings at 2 cm, density 500: draft half its height. Flat, because a
  // cube of that density floats tilted (upright it is stable only below 211 or above 789 kg/m^3);
  // this one has a metacentric height of 5.6 cm.
  const Floating f = floatBox(0.02, 0.16, 0.06, 500.0, 2.0);
  std::printf(
      "box 0.16 x 0.16 x 0.06 m, 500 kg/m^3: draft %.4f m (Archimedes %.4f m, ratio %.3f), heave rms %.2e m, "
      "tilt <= %.3f rad\n",
      f.draft, f.expected, f.draft / f.expected, f.heave_rms, f.tilt);
  ASSERT_TRUE(f.stable);
  // 0.957 here; 0.977 at 1.5 cm and 0.993 at 1 cm (the same box: 11 and 16 spacings across).
  EXPECT_NEAR(f.draft / f.expected, 1.0, 0.05);
  EXPECT_LT(f.tilt, 0.05);
  // Momentum: the tank carries the water and, through it, the floating box.
  std::printf("tank: %.3f N down, water and box weigh %.3f N\n", -f.tank_force, f.weight);
  EXPECT_NEAR(-f.tank_force / f.weight, 1.0, 0.01);
}

TEST(FreeBody, HeavySphereSinksToTheFloorAndKeepsTheWaterOut)
{
  // A sphere of 2000 kg/m^3, radius 4 cm (4 spacings across), released at the surface.
  const double s = 0.02, radius = 0.04;
  SceneConfig scene = test::waterTank(s, Vec3d(0.3, 0.3, 0.3), 0.15);
  BoundaryConfig ball;
  ball.name = "ball";
  ball.type = ShapeType::Sphere;
  ball.sphere = {Vec3d(0.15, 0.15, 0.17), radius};
  ball.dynamic.enabled = true;
  ball.dynamic.density = 2000.0;
  scene.boundaries.push_back(ball);
  Simulation sim(scene);
  const std::size_t n0 = sim.numFluidParticles();
  while (sim.time() < 1.5 - 1e-9) ASSERT_FALSE(sim.step().unstable);
  const BodyInfo b = sim.body(1);
  std::printf(
      "ball: centre at z %.4f m (on the floor: %.4f m), speed %.2e m/s, contact force %.3f N, "
      "weight less buoyancy %.3f N\n",
      b.center_of_mass.z(), radius, b.com_velocity.norm(), b.contact_force.z(), b.mass * kG * (1.0 - 1000.0 / 2000.0));
  // Bullet's contacts (the default) hold the sphere on the floor's geometry. (The particle
  // contacts hold boundary layers a spacing apart pair by pair: a curved body nests up to
  // s (1 - 1/sqrt(2)) = 0.29 s below touching.)
  EXPECT_NEAR(b.center_of_mass.z(), radius, 0.01 * s);
  EXPECT_LT(b.com_velocity.norm(), 0.01);
  EXPECT_EQ(sim.numFluidParticles(), n0);
  // No water inside the ball.
  double nearest = 1e9;  // m
  for (const Vec3& x : sim.positions()) nearest = std::min(nearest, (x.cast<double>() - b.center_of_mass).norm());
  EXPECT_GT(nearest, radius);
  // The floor carries more than the weight less buoyancy (6.2 N against 2.6 N here): at this
  // resolution no water gets under the ball near the floor, and the water above presses it down.
}

namespace
{
struct StackAndPush
{
  BodyInfo bottom, top, pushed;
  double closest = 1e9;  // m, smallest distance between a particle of the paddle and one of the pushed box
  double time = 0.0;     // s
};

/// Dry tank: a box resting on another, and a third pushed along the floor by a scripted paddle
/// at 0.3 m/s (kinematic: it pushes and is not pushed back), for 1 s.
StackAndPush stackAndPush(double s, ContactModel model)
{
  SceneConfig scene = test::waterTank(s, Vec3d(0.6, 0.4, 0.4), 0.0);
  scene.contacts.model = model;
  scene.fluid[0].box = {Vec3d(0.56, 0.36, 0.0), Vec3d(0.6, 0.4, 0.04)};  // the drop, in a far corner
  scene.boundaries.push_back(freeBox("bottom", Vec3d(0.04, 0.24, 0.0), Vec3d(0.16, 0.36, 0.06), 1000.0));
  scene.boundaries.push_back(freeBox("top", Vec3d(0.06, 0.26, 0.08), Vec3d(0.14, 0.34, 0.12), 1000.0));
  scene.boundaries.push_back(freeBox("pushed", Vec3d(0.2, 0.04, 0.0), Vec3d(0.28, 0.12, 0.06), 800.0));
  BoundaryConfig paddle;
  paddle.name = "paddle";
  paddle.type = ShapeType::Box;
  paddle.box = {Vec3d(0.06, 0.02, 0.02), Vec3d(0.1, 0.14, 0.1)};
  paddle.motion.linear_velocity = Vec3d(0.3, 0.0, 0.0);
  scene.boundaries.push_back(paddle);
  Simulation sim(scene);
  const std::size_t bottom = sim.bodyIndex("bottom"), top = sim.bodyIndex("top"), pushed = sim.bodyIndex("pushed");
  StackAndPush out;
  while (sim.time() < 1.0 - 1e-9)
  {
    EXPECT_FALSE(sim.step().unstable);
    const BodyInfo p = sim.body(sim.bodyIndex("paddle")), q = sim.body(pushed);
    const auto& x = sim.boundaryPositions();
    for (std::size_t i = p.first_particle; i < p.first_particle + p.num_particles; i += 3)
      for (std::size_t j = q.first_particle; j < q.first_particle + q.num_particles; ++j)
        out.closest = std::min(out.closest, double((x[i] - x[j]).norm()));
  }
  out.bottom = sim.body(bottom);
  out.top = sim.body(top);
  out.pushed = sim.body(pushed);
  out.time = sim.time();
  std::printf(
      "%s: stack: bottom at z %.5f (0.03), top at z %.5f (0.08), top's speed %.2e m/s; pushed box at x %.5f "
      "(paddle front at %.5f), z %.5f (0.03), closest particles %.4f m (spacing %.3f m)\n",
      toString(model), out.bottom.center_of_mass.z(), out.top.center_of_mass.z(), out.top.com_velocity.norm(),
      out.pushed.center_of_mass.x(), 0.1 + 0.3 * out.time, out.pushed.center_of_mass.z(), out.closest, s);
  return out;
}
}  // namespace

TEST(FreeBody, StacksAndIsPushedByAScriptedPaddleWithoutPassingThrough)
{
  // Bullet's contacts (the default): every height and the pushed box's place on the geometry.
  const double s = 0.02;
  const StackAndPush r = stackAndPush(s, ContactModel::Bullet);
  EXPECT_NEAR(r.bottom.center_of_mass.z(), 0.03, 0.005 * s);
  EXPECT_NEAR(r.top.center_of_mass.z(), 0.08, 0.005 * s);
  EXPECT_LT(r.top.com_velocity.norm(), 1e-3);
  // The pushed box's back face at the paddle's front, within 0.2 mm, and on the floor.
  EXPECT_NEAR(r.pushed.center_of_mass.x() - 0.04, 0.1 + 0.3 * r.time, 0.01 * s);
  EXPECT_NEAR(r.pushed.center_of_mass.z(), 0.03, 0.005 * s);
  EXPECT_GT(r.closest, 0.5 * s);
}

TEST(FreeBody, StacksAndIsPushedWithParticleContacts)
{
  const double s = 0.02;
  const StackAndPush r = stackAndPush(s, ContactModel::Particles);
  // The stack rests: each box on the one below within the nesting of aligned layers.
  EXPECT_NEAR(r.bottom.center_of_mass.z(), 0.03, 0.1 * s);
  EXPECT_NEAR(r.top.center_of_mass.z(), 0.08, 0.1 * s);
  EXPECT_LT(r.top.com_velocity.norm(), 1e-3);
  // The pushed box is ahead of the paddle (its back face at the paddle's front) and still on the
  // floor; the two layers never came closer than half a spacing.
  EXPECT_GT(r.pushed.center_of_mass.x() - 0.04, 0.1 + 0.3 * r.time - 0.3 * s);
  // Sliding, its bottom layer rides over the floor's: offset by half a spacing along the motion,
  // a pair of particles one spacing apart is sqrt(3)/2 s high, 0.13 s below resting (0.137 s here).
  EXPECT_NEAR(r.pushed.center_of_mass.z(), 0.03 - 0.07 * s, 0.08 * s);
  EXPECT_GT(r.closest, 0.5 * s);
}

TEST(FreeBody, AStartOverlappingAWallOrABodyIsWarnedAbout)
{
  // Bodies that only touch (one on the floor, one against it side by side) pass; one across the
  // floor, two overlapping, one outside the tank are named (they would be thrown clear or fall).
  SceneConfig s = test::waterTank(0.02, Vec3d(0.6, 0.4, 0.4), 0.1);
  s.boundaries.push_back(freeBox("resting", Vec3d(0.1, 0.1, 0.0), Vec3d(0.2, 0.2, 0.1), 800.0));
  s.boundaries.push_back(freeBox("beside", Vec3d(0.2, 0.1, 0.0), Vec3d(0.3, 0.2, 0.1), 800.0));
  {
    Simulation sim(s);
    EXPECT_TRUE(sim.startWarnings().empty()) << sim.startWarnings().front();
  }
  s.boundaries.push_back(freeBox("sunk", Vec3d(0.4, 0.1, -0.05), Vec3d(0.5, 0.2, 0.05), 800.0));
  s.boundaries.push_back(freeBox("into", Vec3d(0.25, 0.1, 0.0), Vec3d(0.35, 0.2, 0.1), 800.0));
  s.boundaries.push_back(freeBox("away", Vec3d(0.8, 0.1, 0.1), Vec3d(0.9, 0.2, 0.2), 800.0));
  s.domain.max.x() = 1.0;
  Simulation sim(s);
  const std::vector<std::string>& w = sim.startWarnings();
  const auto said = [&](const std::string& a, const std::string& b) {
    for (const std::string& line : w)
      if (line.find(a) != std::string::npos && line.find(b) != std::string::npos) return true;
    return false;
  };
  EXPECT_TRUE(said("'sunk' starts across the wall of 'tank'", "outside it"));
  EXPECT_TRUE(said("'into' starts overlapping 'beside'", "inside it"));
  EXPECT_TRUE(said("'beside' starts overlapping 'into'", "inside it"));
  EXPECT_TRUE(said("'away' starts outside every container", ""));
  EXPECT_FALSE(said("'resting'", ""));
  EXPECT_EQ(w.size(), 4u);
}

TEST(FreeBody, ABodyTooLightForTheCouplingIsWarnedAbout)
{
  // 5 kg/m^3 (a unit slip, grams for kilograms) is named with its mean density; 50 kg/m^3 (a
  // foam float) and a mass given for the same box at 12 kg/m^3 are not.
  SceneConfig s = test::waterTank(0.02, Vec3d(0.4, 0.4, 0.4), 0.1);
  s.boundaries.push_back(freeBox("foam", Vec3d(0.05, 0.05, 0.1), Vec3d(0.15, 0.15, 0.15), 50.0));
  s.boundaries.push_back(freeBox("grams", Vec3d(0.2, 0.2, 0.1), Vec3d(0.3, 0.3, 0.15), 5.0));
  BoundaryConfig given = freeBox("given", Vec3d(0.2, 0.05, 0.1), Vec3d(0.3, 0.15, 0.15), 0.0);
  given.dynamic.density = 0.0;
  given.dynamic.mass = 12.0 * 0.1 * 0.1 * 0.05;  // kg
  s.boundaries.push_back(given);
  Simulation sim(s);
  const std::vector<std::string>& w = sim.startWarnings();
  ASSERT_EQ(w.size(), 1u) << w.front();
  EXPECT_NE(w[0].find("free body 'grams'"), std::string::npos) << w[0];
  EXPECT_NE(w[0].find("mean density of 5 kg/m^3"), std::string::npos) << w[0];
  EXPECT_NE(w[0].find("boundaries[2].dynamic"), std::string::npos) << w[0];
}

TEST(FreeBody, LeavingTheDomainIsSaidOnce)
{
  // A free body off the tank falls out of the domain (which removes water, not bodies): one
  // notice in the step its centre of mass leaves, none before or after.
  SceneConfig s = test::waterTank(0.02, Vec3d(0.3, 0.3, 0.3), 0.06);
  s.domain = {Vec3d(-0.1, -0.1, -0.1), Vec3d(0.8, 0.4, 0.4)};
  s.boundaries.push_back(freeBox("dropped", Vec3d(0.5, 0.1, 0.1), Vec3d(0.6, 0.2, 0.2), 800.0));
  Simulation sim(s);
  std::vector<double> said;  // s, times of the notices
  for (int k = 0; k < 400; ++k)
  {
    const StepReport rep = sim.step();
    for (const std::string& n : rep.notices)
    {
      EXPECT_NE(n.find("free body 'dropped' left the domain"), std::string::npos) << n;
      said.push_back(rep.time);
    }
  }
  ASSERT_EQ(said.size(), 1u);
  // Released at rest with its centre 0.25 m above the domain's floor: it leaves after
  // sqrt(2 * 0.25 / g) = 0.226 s, to within a step.
  EXPECT_NEAR(said[0], std::sqrt(2.0 * 0.25 / 9.81), 0.002);
}
