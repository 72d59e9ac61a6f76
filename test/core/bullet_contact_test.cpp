// Contacts by Bullet (bullet_contacts.h, contacts.model: bullet; docs/method.md, Eqs. A26b, A27)
// on dry bodies, stepped as Simulation steps them without fluid (BodySet::poseMoving, then
// BodySet::stepFree): exact rest heights, a stack at rest, Coulomb friction on an incline, a
// kinematic paddle that pushes without overlap, a fast ball stopped by a thin wall.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "fluid_sim/core/bodies.h"
#include "fluid_sim/core/bullet_contacts.h"
#include "fluid_sim/core/rigid_dynamics.h"
#include "fluid_sim/core/simulation.h"

using namespace fluid_sim;

namespace
{
constexpr double kG = 9.81;    // m/s^2
constexpr double kDt = 0.001;  // s
constexpr double kS = 0.02;    // m, spacing

BoundaryConfig box(const std::string& name, const Vec3d& size, const Vec3d& centre, double density = 0.0,
                   const Eigen::Quaterniond& rotation = Eigen::Quaterniond::Identity())
{
  BoundaryConfig b;
  b.name = name;
  b.type = ShapeType::Box;
  b.box = {-0.5 * size, 0.5 * size};
  b.pose.translation = centre;
  b.pose.rotation = rotation;
  if (density > 0.0)
  {
    b.dynamic.enabled = true;
    b.dynamic.density = density;
  }
  return b;
}

/// A box tank, floor at z = 0, inner corner at the origin.
BoundaryConfig tankBox(const Vec3d& size)
{
  BoundaryConfig t = box("tank", size, 0.5 * size);
  t.inside = true;
  return t;
}

/// Bodies without fluid, stepped as Simulation::Impl::advance() steps them.
struct Dry
{
  SceneConfig scene;
  BodySet bodies;
  BulletContacts contacts;
  double t = 0.0;  // s

  Dry(const std::vector<BoundaryConfig>& boundaries, double friction = 0.5)
      : scene(sceneOf(boundaries, friction)), bodies(scene), contacts(bodies, scene.spacing, scene.contacts)
  {
  }
  static SceneConfig sceneOf(const std::vector<BoundaryConfig>& boundaries, double friction)
  {
    SceneConfig s;
    s.spacing = kS;
    s.gravity = Vec3d(0, 0, -kG);
    s.contacts.friction = friction;
    s.boundaries = boundaries;
    return s;
  }
  void step()
  {
    bodies.poseMoving(t);
    bodies.stepFree(kDt, scene.gravity, contacts);
    t += kDt;
  }
};
}  // namespace

TEST(BulletContacts, BoxRestsOnTheFloorAtItsExactHeight)
{
  // 8 x 8 x 4 cm, 2000 kg/m^3, dropped from 2 cm above the floor of a box tank.
  Dry d({tankBox(Vec3d(0.4, 0.4, 0.4)), box("block", Vec3d(0.08, 0.08, 0.04), Vec3d(0.21, 0.19, 0.04), 2000.0)});
  double late_speed = 0.0;  // m/s, largest after 0.5 s
  while (d.t < 1.0 - 1e-9)
  {
    d.step();
    if (d.t > 0.5) late_speed = std::max(late_speed, d.bodies[1].v_com.norm());
  }
  const Body& b = d.bodies[1];
  std::printf(
      "box: centre of mass at z %.6f m (0.02), speed after 0.5 s <= %.2e m/s, contact force %.4f N (m g %.4f), "
      "tank's %.4f N\n",
      b.centerOfMass().z(), late_speed, b.contact_force.z(), b.mass * kG, d.bodies[0].contact_force.z());
  EXPECT_NEAR(b.centerOfMass().z(), 0.02, 0.005 * kS);  // 0.1 mm (measured: 0.000 mm)
  EXPECT_LT(late_speed, 1e-4);
  EXPECT_NEAR(b.contact_force.z(), b.mass * kG, 1e-3 * b.mass * kG);
  EXPECT_NEAR(d.bodies[0].contact_force.z(), -b.mass * kG, 1e-2 * b.mass * kG);  // the reaction on the tank
  // Nothing pushes it sideways; Bullet's four contact points, solved one after another in single
  // precision, move it by 11 um while it lands (the particle contacts: below 1e-6 m).
  EXPECT_NEAR(b.centerOfMass().x(), 0.21, 0.0025 * kS);
  EXPECT_GT(d.contacts.contacts(), 0u);
}

TEST(BulletContacts, ABodyBesideAContainerInATankLandsOnTheFloor)
{
  // A closed cup (a box container) standing in a tank, a cube dropped 5 cm beside it. The cup's
  // walls were 10 cm slabs reaching 10 cm beyond it: the cube rested at z = 0.22, in mid-air.
  BoundaryConfig cup = box("cup", Vec3d(0.1, 0.1, 0.1), Vec3d(0.25, 0.15, 0.05));
  cup.inside = true;
  const BoundaryConfig cube = box("cube", Vec3d(0.04, 0.04, 0.04), Vec3d(0.35, 0.15, 0.3), 1000.0);
  Dry d({tankBox(Vec3d(0.5, 0.3, 0.4)), cup, cube});
  while (d.t < 0.6 - 1e-9) d.step();
  const Vec3d c = d.bodies[2].centerOfMass();
  std::printf("cube beside the cup at (%.4f, %.4f, %.4f)\n", c.x(), c.y(), c.z());
  // On the floor, at most a wall's thickness (a spacing) off the cup's outside (x 0.3 + 0.02).
  EXPECT_NEAR(c.z(), 0.02, 0.005 * kS);
  EXPECT_GT(c.x(), 0.3 + kS);
}

TEST(BulletContacts, BallAndCylinderRestAtTheirExactHeights)
{
  BoundaryConfig ball;
  ball.name = "ball";
  ball.type = ShapeType::Sphere;
  ball.sphere = {Vec3d::Zero(), 0.03};
  ball.pose.translation = Vec3d(0.1, 0.1, 0.04);
  ball.dynamic.enabled = true;
  ball.dynamic.density = 1500.0;
  // A cylinder lying along y (its axis turned in the body frame), centre off the body origin,
  // and one standing on its end.
  BoundaryConfig roll;
  roll.name = "cylinder";
  roll.type = ShapeType::Cylinder;
  roll.cylinder = {Vec3d(0.01, 0.0, 0.0), Vec3d::UnitY(), 0.025, 0.1};
  roll.pose.translation = Vec3d(0.25, 0.2, 0.03);
  roll.dynamic.enabled = true;
  roll.dynamic.density = 1500.0;
  BoundaryConfig stand = roll;
  stand.name = "standing";
  stand.cylinder = {Vec3d::Zero(), Vec3d::UnitZ(), 0.025, 0.06};
  stand.pose.translation = Vec3d(0.1, 0.3, 0.035);
  Dry d({tankBox(Vec3d(0.4, 0.4, 0.4)), ball, roll, stand});
  while (d.t < 0.6 - 1e-9) d.step();
  std::printf(
      "ball at z %.6f (0.03), cylinder at z %.6f (0.025), speeds %.2e, %.2e m/s, cylinder's omega %.2e "
      "rad/s\n",
      d.bodies[1].centerOfMass().z(), d.bodies[2].centerOfMass().z(), d.bodies[1].v_com.norm(),
      d.bodies[2].v_com.norm(), d.bodies[2].omega.norm());
  std::printf("standing cylinder at z %.6f (0.03), speed %.2e m/s\n", d.bodies[3].centerOfMass().z(),
              d.bodies[3].v_com.norm());
  EXPECT_NEAR(d.bodies[1].centerOfMass().z(), 0.03, 0.005 * kS);
  EXPECT_NEAR(d.bodies[2].centerOfMass().z(), 0.025, 0.01 * kS);  // 0.11 mm low: it rolls (below)
  EXPECT_NEAR(d.bodies[3].centerOfMass().z(), 0.03, 0.005 * kS);
  EXPECT_LT(d.bodies[1].v_com.norm(), 1e-4);
  EXPECT_LT(d.bodies[3].v_com.norm(), 1e-3);  // 3.5e-4 m/s: its end face meets the floor at changing points
  // The lying cylinder stays where it landed. Without the rolling resistance (contacts.
  // rolling_resistance 0) Bullet sets it rolling by itself, at 5.3 rad/s (13 cm/s) by 0.6 s.
  EXPECT_LT(d.bodies[2].omega.norm(), 1e-3);
  EXPECT_LT(d.bodies[2].v_com.norm(), 1e-3);
  EXPECT_NEAR(d.bodies[2].centerOfMass().x(), 0.26, 0.025 * kS);  // 0.5 mm
}

TEST(BulletContacts, RollingResistanceSlowsARollingBallAtItsRate)
{
  // A ball r 3 cm rolling at 0.3 m/s on the floor: the rolling resistance's torque c r N about
  // the contact slows it at a = c r N r / I_contact = c g / (1 + 2/5) (solid sphere), 0.070 m/s^2
  // at c = 0.01; without it, it rolls on at constant speed.
  for (const double c : {0.0, 0.01})
  {
    BoundaryConfig ball;
    ball.name = "ball";
    ball.type = ShapeType::Sphere;
    ball.sphere = {Vec3d::Zero(), 0.03};
    ball.pose.translation = Vec3d(0.05, 0.2, 0.03);
    ball.dynamic.enabled = true;
    ball.dynamic.density = 1500.0;
    ball.dynamic.linear_velocity = Vec3d(0.3, 0, 0);
    ball.dynamic.angular_velocity = Vec3d(0, 0.3 / 0.03, 0);  // rolling without slipping
    SceneConfig s = Dry::sceneOf({tankBox(Vec3d(0.4, 0.4, 0.4)), ball}, 0.5);
    s.contacts.rolling_resistance = c;
    BodySet bodies(s);
    BulletContacts contacts(bodies, s.spacing, s.contacts);
    double v02 = 0.0;
    for (int i = 1; i <= 600; ++i)
    {
      bodies.poseMoving((i - 1) * kDt);
      bodies.stepFree(kDt, s.gravity, contacts);
      if (i == 200) v02 = bodies[1].v_com.x();
    }
    const double decel = (v02 - bodies[1].v_com.x()) / 0.4;  // m/s^2, over 0.2-0.6 s
    std::printf("rolling ball, c = %.2f: speed %.4f m/s at 0.6 s, deceleration %.4f m/s^2 (%.4f)\n", c,
                bodies[1].v_com.x(), decel, c * kG / 1.4);
    EXPECT_NEAR(decel, c * kG / 1.4, 0.1 * 0.01 * kG / 1.4);
    EXPECT_NEAR(bodies[1].centerOfMass().z(), 0.03, 0.005 * kS);
  }
}

TEST(BulletContacts, StackOfTwoBoxesRests)
{
  // 10 x 10 x 4 cm boxes, the upper one 5 mm off to the side, released 1 cm apart.
  Dry d({tankBox(Vec3d(0.4, 0.4, 0.4)), box("bottom", Vec3d(0.1, 0.1, 0.04), Vec3d(0.2, 0.2, 0.02), 1000.0),
         box("top", Vec3d(0.1, 0.1, 0.04), Vec3d(0.205, 0.2, 0.07), 1000.0)});
  double late_speed = 0.0;  // m/s, largest of either box over the last second
  while (d.t < 2.0 - 1e-9)
  {
    d.step();
    if (d.t > 1.0) late_speed = std::max({late_speed, d.bodies[1].v_com.norm(), d.bodies[2].v_com.norm()});
  }
  const Vec3d b = d.bodies[1].centerOfMass(), t = d.bodies[2].centerOfMass();
  std::printf(
      "stack: bottom at z %.6f (0.02), top at z %.6f (0.06), top's drift %.2e m, speed over the last s "
      "<= %.2e m/s\n",
      b.z(), t.z(), (t - Vec3d(0.205, 0.2, t.z())).norm(), late_speed);
  EXPECT_NEAR(b.z(), 0.02, 0.005 * kS);
  EXPECT_NEAR(t.z(), 0.06, 0.005 * kS);
  EXPECT_LT((t - Vec3d(0.205, 0.2, t.z())).norm(), 0.025 * kS);  // 0.5 mm in 2 s
  EXPECT_LT(late_speed, 1e-3);
}

namespace
{
/// A box 6 x 6 x 3 cm of 1000 kg/m^3 on a static plank tilted by `degrees` about y, released at
/// rest touching it; its acceleration down the slope (m/s^2) from its travel between 0.2 and
/// 0.6 s, and its travel over the whole 0.6 s (m).
std::pair<double, double> slide(double degrees, double mu)
{
  const double th = degrees * M_PI / 180.0;
  const Eigen::Quaterniond tilt(Eigen::AngleAxisd(th, Vec3d::UnitY()));
  const Vec3d normal = tilt * Vec3d::UnitZ(), down = tilt * Vec3d::UnitX();  // down the slope: +x turned
  // Plank 2 m x 0.3 m x 4 cm, its top face through the origin.
  const BoundaryConfig plank = box("plank", Vec3d(2.0, 0.3, 0.04), -0.02 * normal, 0.0, tilt);
  const BoundaryConfig block = box("block", Vec3d(0.06, 0.06, 0.03), -0.6 * down + 0.015 * normal, 1000.0, tilt);
  Dry d({plank, block}, mu);
  const Vec3d start = d.bodies[1].centerOfMass();
  double s02 = 0.0, v02 = 0.0;
  while (d.t < 0.6 - 1e-9)
  {
    d.step();
    if (std::abs(d.t - 0.2) < 0.5 * kDt)
    {
      s02 = (d.bodies[1].centerOfMass() - start).dot(down);
      v02 = d.bodies[1].v_com.dot(down);
    }
  }
  const double s06 = (d.bodies[1].centerOfMass() - start).dot(down);
  // s = s02 + v02 T + a T^2 / 2 over T = 0.4 s.
  const double T = 0.4;
  return {2.0 * (s06 - s02 - v02 * T) / (T * T), s06};
}
}  // namespace

TEST(BulletContacts, BoxOnAnInclineSlidesWithCoulombFrictionAndSticksBelowTheFrictionAngle)
{
  const double mu = 0.5;
  for (double degrees : {35.0, 45.0})
  {
    const double th = degrees * M_PI / 180.0;
    const double expected = kG * (std::sin(th) - mu * std::cos(th));
    const auto [a, travel] = slide(degrees, mu);
    std::printf("%.0f deg, mu %.1f: a = %.4f m/s^2 (g (sin - mu cos) = %.4f), travel %.4f m\n", degrees, mu, a,
                expected, travel);
    EXPECT_NEAR(a / expected, 1.0, 0.03);
  }
  // Below atan(mu) = 26.6 deg it sticks.
  const auto [a20, travel20] = slide(20.0, mu);
  std::printf("20 deg: a = %.2e m/s^2, travel %.2e m\n", a20, travel20);
  EXPECT_LT(std::abs(travel20), 1e-4);
  // Without friction: g sin.
  const auto [a0, travel0] = slide(20.0, 0.0);
  EXPECT_NEAR(a0 / (kG * std::sin(20.0 * M_PI / 180.0)), 1.0, 0.01);
}

TEST(BulletContacts, KinematicPaddlePushesABoxWithoutOverlap)
{
  // A scripted paddle at 0.2 m/s along x meets a 6 cm box 5 cm ahead and pushes it for 1 s.
  BoundaryConfig paddle = box("paddle", Vec3d(0.02, 0.12, 0.08), Vec3d(0.05, 0.2, 0.05));
  paddle.motion.linear_velocity = Vec3d(0.2, 0, 0);
  Dry d({tankBox(Vec3d(0.6, 0.4, 0.4)), paddle, box("pushed", Vec3d(0.06, 0.06, 0.06), Vec3d(0.14, 0.2, 0.03), 800.0)});
  double overlap = 0.0;  // m, deepest: the paddle's front past the box's back
  double height_error = 0.0;
  while (d.t < 1.2 - 1e-9)
  {
    d.step();
    const double back = d.bodies[2].centerOfMass().x() - 0.03;
    // The paddle's front at d.t, its scripted pose (the next poseMoving() puts it there).
    const double front_now = 0.06 + 0.2 * d.t;
    overlap = std::max(overlap, front_now - back);
    height_error = std::max(height_error, std::abs(d.bodies[2].centerOfMass().z() - 0.03));
  }
  const double front_now = 0.06 + 0.2 * d.t;
  const double back = d.bodies[2].centerOfMass().x() - 0.03;
  std::printf(
      "paddle front %.5f m, box back %.5f m, deepest overlap %.2e m, height error <= %.2e m, pushed at "
      "%.4f m/s\n",
      front_now, back, overlap, height_error, d.bodies[2].v_com.x());
  EXPECT_LT(overlap, 0.01 * kS);           // 0.2 mm (measured in the bench: 0.00 mm)
  EXPECT_LT(back - front_now, 0.01 * kS);  // it is pushed, not thrown ahead
  EXPECT_NEAR(d.bodies[2].v_com.x(), 0.2, 0.01);
  EXPECT_LT(height_error, 0.005 * kS);  // it slides on the floor, not on bumps
}

TEST(BulletContacts, FastSmallBallDoesNotPassAThinWall)
{
  // A ball r 1 cm at 30 m/s (3 cm per step, more than the wall's 1 cm) from 6 starts that put the
  // last step before the wall at different distances from it.
  for (int k = 0; k < 6; ++k)
  {
    BoundaryConfig ball;
    ball.name = "ball";
    ball.type = ShapeType::Sphere;
    ball.sphere = {Vec3d::Zero(), 0.01};
    ball.pose.translation = Vec3d(-0.2 - 0.005 * k, 0.0, 0.0);
    ball.dynamic.enabled = true;
    ball.dynamic.density = 7800.0;
    ball.dynamic.linear_velocity = Vec3d(30.0, 0, 0);
    const BoundaryConfig wall = box("wall", Vec3d(0.01, 0.3, 0.3), Vec3d(0.005, 0, 0));
    Dry d({wall, ball});
    d.scene.gravity.setZero();
    double deepest = -1.0;  // m, the ball's front past the wall's face (x = 0)
    while (d.t < 0.05 - 1e-9)
    {
      d.step();
      deepest = std::max(deepest, d.bodies[1].centerOfMass().x() + 0.01);
    }
    std::printf("start %d: deepest %.2e m into the wall, final x %.4f m, v %.3f m/s\n", k, deepest,
                d.bodies[1].centerOfMass().x(), d.bodies[1].v_com.x());
    EXPECT_LT(deepest, 0.005);                        // never through (the wall is 1 cm thick): at most half of it
    EXPECT_LT(std::abs(d.bodies[1].v_com.x()), 3.0);  // no more than a tenth of its speed back (restitution 0)
    EXPECT_LT(d.bodies[1].centerOfMass().x(), 0.0);
  }
}

TEST(BulletContacts, FreeContainerOtherThanABoxIsRefusedByName)
{
  BoundaryConfig cup;
  cup.name = "cup";
  cup.type = ShapeType::Cylinder;
  cup.cylinder = {Vec3d::Zero(), Vec3d::UnitZ(), 0.05, 0.1};
  cup.inside = true;
  cup.dynamic.enabled = true;
  cup.dynamic.mass = 1.0;
  cup.dynamic.inertia = std::array<double, 6>{1e-3, 1e-3, 1e-3, 0, 0, 0};
  SceneConfig s;
  s.boundaries = {cup};
  const BodySet bodies(s);
  try
  {
    BulletContacts contacts(bodies, s.spacing, s.contacts);
    FAIL() << "no error";
  }
  catch (const ConfigError& e)
  {
    EXPECT_NE(std::string(e.what()).find("cup"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("particles"), std::string::npos) << e.what();
  }
}
