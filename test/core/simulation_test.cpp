#include "fluid_sim/core/simulation.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "fluid_sim/core/bodies.h"
#include "fluid_sim/core/fluid_particles.h"
#include "fluid_sim/core/kernel.h"
#include "fluid_sim/core/neighborhoods.h"

#include "small_scene.h"

using namespace fluid_sim;

namespace
{
using fluid_sim::test::errorKey;
using fluid_sim::test::smallScene;

}  // namespace

TEST(SceneValidation, BadValuesNameTheirKey)
{
  SceneConfig s = smallScene();
  s.spacing = -0.01;
  EXPECT_EQ(errorKey(s), "spacing");

  s = smallScene();
  s.fluid.clear();
  EXPECT_EQ(errorKey(s), "fluid");

  s = smallScene();
  s.fluid[0].box.max.x() = 5.0;
  EXPECT_EQ(errorKey(s), "fluid[0].box");

  s = smallScene();
  s.solver.density_error = 0;
  EXPECT_EQ(errorKey(s), "solver.density_error");

  s = smallScene();
  BoundaryConfig b;
  b.name = "ball";
  b.type = ShapeType::Sphere;
  b.sphere.radius = -1;
  s.boundaries.push_back(b);
  EXPECT_EQ(errorKey(s), "boundaries[0].sphere.radius");
}

TEST(Simulation, FluidInsideSolidsOrOutsideContainersIsRemovedAndCounted)
{
  SceneConfig s = smallScene();
  BoundaryConfig ball;
  ball.name = "ball";
  ball.type = ShapeType::Sphere;
  ball.sphere = {Vec3d(0.1, 0.1, 0.1), 0.06};
  s.boundaries.push_back(ball);
  Simulation sim(s);
  EXPECT_EQ(sim.initialFluidParticles() + sim.removedAtStart(), 64u);
  EXPECT_GT(sim.removedAtStart(), 0u);
  for (const Vec3& x : sim.positions()) EXPECT_GE((x.cast<double>() - Vec3d(0.1, 0.1, 0.1)).norm(), 0.06);
}

TEST(Simulation, WaterFallingOutOfTheDomainIsRemovedStepByStepAndCounted)
{
  // No container: the block falls out through the domain's floor (0.2 m below it). Steps where
  // nothing leaves remove nothing (and make no mask); the others remove exactly the particles
  // below the floor, and the counts add up.
  SceneConfig s = test::smallScene();
  Simulation sim(s);
  const std::size_t start = sim.numFluidParticles();
  std::size_t removed = 0, quiet_steps = 0, removing_steps = 0;
  while (sim.time() < 0.6 && sim.numFluidParticles() > 0)
  {
    const std::size_t before = sim.numFluidParticles();
    const StepReport rep = sim.step();
    ASSERT_FALSE(rep.unstable) << rep.reason;
    EXPECT_EQ(sim.numFluidParticles() + rep.removed, before);
    (rep.removed == 0 ? quiet_steps : removing_steps) += 1;
    removed += rep.removed;
    for (const Vec3& x : sim.positions()) ASSERT_GE(x.z(), Real(-0.2));
  }
  EXPECT_GT(quiet_steps, 0u);
  EXPECT_GT(removing_steps, 0u);
  EXPECT_EQ(removed, start);  // 0.2 m of free fall take 0.2 s: all of it has left by 0.6 s
  EXPECT_EQ(sim.removedTotal(), start);
}

TEST(Neighborhoods, AFluidQueryReachesOneCellEachWayAtEverySpacing)
{
  // The fluid grid's cells are the kernel support h: a query visits 3 x 3 x 3 cells. With cells
  // of 2 s in double and h rounded to float, spacings where the float rounds up (0.0305, 0.017,
  // 0.016 m, ...) reached two cells each way, 125 cells, and searched 2-3x as long.
  for (double s : {0.031, 0.0305, 0.025, 0.017, 0.016, 0.014, 0.012, 0.0101, 0.01, 0.0099, 0.02, 0.011})
  {
    SceneConfig scene = test::smallScene();
    scene.spacing = s;
    const CubicKernel kernel(Real(2.0 * s));
    const Neighborhoods nb(scene, kernel);
    EXPECT_EQ(nb.fluidGrid().reachFor(kernel.support()), 1) << "spacing " << s;
  }
}

TEST(Simulation, ExplicitParticlesAreAddedAsTheyAreWithoutThoseTheLatticeOrTheStepWouldDrop)
{
  SceneConfig s = smallScene();  // a lattice block of 4 x 4 x 4 first
  BoundaryConfig ball;
  ball.name = "ball";
  ball.type = ShapeType::Sphere;
  ball.sphere = {Vec3d(0.4, 0.4, 0.4), 0.06};
  s.boundaries.push_back(ball);
  FluidBlockConfig saved;
  saved.particles = ExplicitParticles();
  saved.particles->positions = {Vec3d(0.31, 0.0, 0.02), Vec3d(0.4, 0.4, 0.42), Vec3d(0.3, -0.1, 0.55),
                                Vec3d(0.1, 0.1, 0.61), Vec3d(0.5, 0.2, 0.0)};
  saved.particles->velocities = {Vec3d(1, 2, 3), Vec3d(0, 0, 0), Vec3d(-0.5, 0, 0), Vec3d(0, 0, 0), Vec3d(0, 0, 9)};
  s.fluid.push_back(saved);
  Simulation sim(s);
  // Dropped: the second (in the ball) and the fourth (outside the domain, max 0.6).
  EXPECT_EQ(sim.removedAtStart(), 2u);
  ASSERT_EQ(sim.numFluidParticles(), 64u + 3u);
  const std::size_t kept[] = {0, 2, 4};
  for (std::size_t k = 0; k < 3; ++k)
  {
    // In their order, after the lattice, exactly (no lattice), with their own velocities.
    EXPECT_EQ(sim.positions()[64 + k], saved.particles->positions[kept[k]].cast<Real>()) << k;
    EXPECT_EQ(sim.velocities()[64 + k], saved.particles->velocities[kept[k]].cast<Real>()) << k;
  }
  EXPECT_EQ(sim.densities()[64], Real(s.rest_density));
  // The mass of a lattice particle: the state must come from a run at the same spacing.
  EXPECT_EQ(sim.particleMass(), Real(s.rest_density * s.spacing * s.spacing * s.spacing));
}

TEST(SceneValidation, ExplicitParticlesNameTheirKey)
{
  SceneConfig s = smallScene();
  s.fluid[0].particles = ExplicitParticles{{Vec3d(0.1, 0.1, 0.1)}, {Vec3d::Zero()}};
  EXPECT_EQ(errorKey(s), "fluid[0]");  // a box too
  s.fluid[0].box = AxisBox();
  EXPECT_EQ(errorKey(s), "<no error>");
  s.fluid[0].velocity = Vec3d(1, 0, 0);
  EXPECT_EQ(errorKey(s), "fluid[0]");  // a box's velocity too
  s.fluid[0].velocity = Vec3d::Zero();

  s.fluid[0].particles->velocities.push_back(Vec3d::Zero());
  EXPECT_EQ(errorKey(s), "fluid[0].particles");  // 1 position, 2 velocities
  s.fluid[0].particles = ExplicitParticles();
  EXPECT_EQ(errorKey(s), "fluid[0].particles");  // empty
  s.fluid[0].particles = ExplicitParticles{{Vec3d(0.1, 0.1, 0.1), Vec3d(0.1, 0.1, std::nan(""))}, {}};
  s.fluid[0].particles->velocities.resize(2, Vec3d::Zero());
  EXPECT_EQ(errorKey(s), "fluid[0].particles");
  s.fluid[0].particles->positions[1].z() = 0.2;
  s.fluid[0].particles->velocities[0].x() = INFINITY;
  EXPECT_EQ(errorKey(s), "fluid[0].particles");
  s.fluid[0].particles->velocities[0].x() = 0.0;
  EXPECT_EQ(errorKey(s), "<no error>");

  // Particles outside the domain are dropped, not refused; with none left the fill says so.
  s.fluid[0].particles->positions = {Vec3d(5, 5, 5), Vec3d(-5, 0, 0)};
  EXPECT_EQ(errorKey(s), "fluid");
}

TEST(Simulation, FreeFallLeavesTheDomainAndIsCountedNotNaN)
{
  SceneConfig s = smallScene();
  s.time_step.fixed = 0.005;
  Simulation sim(s);
  const std::size_t n = sim.numFluidParticles();
  std::size_t removed = 0;
  // A free block falls 0.2-0.4 m to the domain's floor in about 0.3 s.
  for (int k = 0; k < 100 && sim.numFluidParticles() > 0; ++k)
  {
    const StepReport r = sim.step();
    ASSERT_FALSE(r.unstable) << r.reason;
    removed += r.removed;
    for (const Vec3& x : sim.positions()) ASSERT_TRUE(x.allFinite());
  }
  EXPECT_EQ(sim.numFluidParticles(), 0u);
  EXPECT_EQ(removed, n);
  EXPECT_EQ(sim.removedTotal(), n);
}

TEST(Simulation, ABlowUpIsNamedAndItsSpeedIsNotZero)
{
  // Gravity beyond float's range: every velocity is infinite after one step. The report says so,
  // and its largest speed is NaN, not the 0 a maximum over NaN gives (stats.csv read 0 beside it).
  if (sizeof(Real) != sizeof(float)) GTEST_SKIP() << "the double build holds 1e39; the blow-up needs float's range";
  SceneConfig s = smallScene();
  s.gravity = Vec3d(0, 0, -1e39);  // m/s^2, finite in double, not in float
  Simulation sim(s);
  StepReport r;
  for (int k = 0; k < 3 && !r.unstable; ++k) r = sim.step();
  ASSERT_TRUE(r.unstable);
  EXPECT_NE(r.reason.find("non-finite position or velocity"), std::string::npos) << r.reason;
  EXPECT_TRUE(std::isnan(r.max_speed)) << r.max_speed;
}

TEST(Simulation, ScriptedRotationMovesBoundaryParticlesRigidly)
{
  SceneConfig s = smallScene();
  BoundaryConfig paddle;
  paddle.name = "paddle";
  paddle.type = ShapeType::Box;
  paddle.box = {Vec3d(0.3, 0.0, 0.0), Vec3d(0.4, 0.1, 0.1)};
  paddle.motion.angular_velocity = Vec3d(0, 0, M_PI);  // half a turn per second
  paddle.motion.about = Vec3d(0.35, 0.05, 0.05);
  s.boundaries.push_back(paddle);
  s.time_step.fixed = 0.005;
  Simulation sim(s);
  const std::vector<Vec3> start = sim.boundaryPositions();
  while (sim.time() < 1.0 - 1e-9) sim.step();
  sim.step();  // poses are applied at the start of a step: this one poses at t = 1 s
  const BodyInfo info = sim.body(0);
  EXPECT_TRUE(info.moving);
  EXPECT_NEAR(info.angular_velocity.z(), M_PI, 1e-9);
  // After half a turn about the box's centre, every particle is mirrored through the centre in x, y.
  const Vec3 c(Real(0.35), Real(0.05), Real(0.05));
  for (std::size_t k = 0; k < start.size(); ++k)
  {
    const Vec3 expected(2 * c.x() - start[k].x(), 2 * c.y() - start[k].y(), start[k].z());
    EXPECT_LT((sim.boundaryPositions()[k] - expected).norm(), 1e-4) << k;
  }
}

namespace
{
/// A box paddle turning about (0.35, 0.05, 0.05) while translating, placed with a yaw.
BoundaryConfig scriptedPaddle()
{
  BoundaryConfig paddle;
  paddle.name = "paddle";
  paddle.type = ShapeType::Box;
  paddle.box = {Vec3d(-0.05, -0.05, -0.05), Vec3d(0.05, 0.05, 0.05)};
  paddle.pose = Pose::fromXyzRpy(Vec3d(0.3, 0.02, 0.04), Vec3d(0.1, 0, 0.3));
  paddle.motion.angular_velocity = Vec3d(0.5, 0, 2.0);  // rad/s
  paddle.motion.about = Vec3d(0.35, 0.05, 0.05);
  paddle.motion.linear_velocity = Vec3d(0.1, 0, -0.05);  // m/s
  return paddle;
}

/// Rotation vector (axis * angle, rad) of a rotation of less than half a turn.
Vec3d rotationVectorOf(const Eigen::Quaterniond& q)
{
  const Eigen::AngleAxisd aa(q.normalized());
  return aa.axis() * aa.angle();
}

struct BodyState
{
  Pose pose;
  Vec3d v, w, a, alpha;
};

BodyState stateAt(BodySet& bodies, double t)
{
  bodies.poseMoving(t);
  const Body& b = bodies[0];
  return {b.pose, b.v_origin, b.omega, b.a_origin, b.alpha};
}

/// Velocities are the derivatives of the pose, accelerations those of the velocities (central
/// differences over 2 us), at t0, t0 + step, ... up to t1 (s).
void expectVelocitiesAreThePosesDerivatives(BodySet& bodies, double t0, double t1, double step)
{
  const double h = 1e-6;  // s
  for (double t = t0; t <= t1 + 1e-12; t += step)
  {
    const BodyState m = stateAt(bodies, t - h);
    const BodyState p = stateAt(bodies, t + h);
    const BodyState st = stateAt(bodies, t);
    const Vec3d v_fd = (p.pose.translation - m.pose.translation) / (2 * h);
    const Vec3d w_fd = rotationVectorOf(p.pose.rotation * m.pose.rotation.conjugate()) / (2 * h);
    EXPECT_LT((v_fd - st.v).norm(), 1e-8) << "t = " << t;
    EXPECT_LT((w_fd - st.w).norm(), 1e-8) << "t = " << t;
    EXPECT_LT(((p.v - m.v) / (2 * h) - st.a).norm(), 1e-6) << "t = " << t;
    EXPECT_LT(((p.w - m.w) / (2 * h) - st.alpha).norm(), 1e-6) << "t = " << t;
  }
}
}  // namespace

TEST(Bodies, ScriptedMotionStartAndRampAreSmoothAndIntegrated)
{
  SceneConfig s = smallScene();
  BoundaryConfig paddle = scriptedPaddle();
  paddle.motion.start = 0.05;  // s
  paddle.motion.ramp = 0.1;    // s
  s.boundaries.push_back(paddle);
  validate(s);
  BodySet bodies(s);
  ASSERT_TRUE(bodies[0].moving);
  const Vec3d w_full = paddle.motion.angular_velocity;

  // Still at the initial pose up to the start.
  for (double t : {0.0, 0.02, 0.05})
  {
    const BodyState st = stateAt(bodies, t);
    EXPECT_EQ(st.pose.translation, paddle.pose.translation) << t;
    EXPECT_EQ(st.pose.rotation.coeffs(), paddle.pose.rotation.coeffs()) << t;
    EXPECT_EQ(st.v, Vec3d::Zero()) << t;
    EXPECT_EQ(st.w, Vec3d::Zero()) << t;
    EXPECT_EQ(st.a, Vec3d::Zero()) << t;
    EXPECT_EQ(st.alpha, Vec3d::Zero()) << t;
  }
  // Half way through the ramp: half the speed (r = 1/2), the highest angular acceleration (2 w / ramp).
  BodyState st = stateAt(bodies, 0.1);
  EXPECT_LT((st.w - 0.5 * w_full).norm(), 1e-12);
  EXPECT_LT((st.alpha - 2.0 * w_full / 0.1).norm(), 1e-9);
  // After the ramp: the configured velocities, no angular acceleration.
  for (double t : {0.16, 0.2, 0.4})
  {
    st = stateAt(bodies, t);
    EXPECT_LT((st.w - w_full).norm(), 1e-15) << t;
    EXPECT_EQ(st.alpha, Vec3d::Zero()) << t;
  }
  // The total angle turned after the ramp is |w| (t - start - ramp / 2).
  st = stateAt(bodies, 0.4);
  const double angle = (st.pose.rotation * paddle.pose.rotation.conjugate()).normalized().vec().norm();
  EXPECT_NEAR(2.0 * std::asin(angle), w_full.norm() * (0.4 - 0.05 - 0.05), 1e-12);

  // Velocities are the derivatives of the pose, accelerations those of the velocities (central
  // differences), everywhere: before, at and after the start and the end of the ramp.
  expectVelocitiesAreThePosesDerivatives(bodies, 0.0, 0.3, 0.0125);

  // The displacement is the integral of the reported velocity (Simpson over 0..0.3 s).
  const int n = 3000;
  const double dt = 0.3 / n;
  Vec3d integral = Vec3d::Zero();
  for (int k = 0; k <= n; ++k)
  {
    const double weight = (k == 0 || k == n) ? 1.0 : (k % 2 == 1 ? 4.0 : 2.0);
    integral += weight * stateAt(bodies, k * dt).v;
  }
  integral *= dt / 3.0;
  st = stateAt(bodies, 0.3);
  EXPECT_LT((integral - (st.pose.translation - paddle.pose.translation)).norm(), 1e-10);
}

TEST(Bodies, ScriptedMotionStopsSmoothlyAndStaysWhereItGot)
{
  // A paddle that sweeps and then stays (a scripted motion could not stop): ramps of 0.1 s up from
  // 0.05 s and down to 0.4 s, still afterwards at the pose it reached.
  SceneConfig s = smallScene();
  BoundaryConfig paddle = scriptedPaddle();
  paddle.motion.start = 0.05;  // s
  paddle.motion.ramp = 0.1;    // s
  paddle.motion.stop = 0.4;    // s
  s.boundaries.push_back(paddle);
  validate(s);
  BodySet bodies(s);
  const Vec3d w_full = paddle.motion.angular_velocity;
  // Full speed between the ramps; half speed half way down, the largest deceleration there.
  for (double t : {0.16, 0.2, 0.29}) EXPECT_LT((stateAt(bodies, t).w - w_full).norm(), 1e-15) << t;
  BodyState st = stateAt(bodies, 0.35);
  EXPECT_LT((st.w - 0.5 * w_full).norm(), 1e-12);
  EXPECT_LT((st.alpha + 2.0 * w_full / 0.1).norm(), 1e-9);
  // Still after the stop, at the pose of the whole sweep: turned by |w| (stop - start - ramp).
  const BodyState end = stateAt(bodies, 0.4);
  for (double t : {0.4, 0.5, 2.0})
  {
    st = stateAt(bodies, t);
    EXPECT_EQ(st.v, Vec3d::Zero()) << t;
    EXPECT_EQ(st.w, Vec3d::Zero()) << t;
    EXPECT_EQ(st.a, Vec3d::Zero()) << t;
    EXPECT_EQ(st.alpha, Vec3d::Zero()) << t;
    EXPECT_EQ(st.pose.translation, end.pose.translation) << t;
  }
  const double angle = (end.pose.rotation * paddle.pose.rotation.conjugate()).normalized().vec().norm();
  EXPECT_NEAR(2.0 * std::asin(angle), w_full.norm() * (0.4 - 0.05 - 0.1), 1e-12);
  // Velocities and accelerations are the pose's derivatives through the ramp down and the stop.
  expectVelocitiesAreThePosesDerivatives(bodies, 0.28, 0.42, 0.01);
  // The CFL speed ahead sees the motion while it runs and nothing once it has stopped.
  EXPECT_GT(bodies.maxSpeedAhead(0.3, 0.005), 0.0);
  EXPECT_EQ(bodies.maxSpeedAhead(0.4, 0.005), 0.0);
  // A stop that leaves no room for both ramps is refused, naming its key.
  s.boundaries[0].motion.stop = 0.2;
  EXPECT_EQ(errorKey(s), "boundaries[0].motion.stop");
}

TEST(Bodies, ScriptedMotionWithoutStartOrRampHasConstantVelocitiesThatArePoseDerivatives)
{
  // The paddle turns and translates at once: its origin's velocity is do/dt = w x (o - c - u t) + u,
  // not w x (o - c) + u (the arm excludes the translation so far).
  SceneConfig s = smallScene();
  const BoundaryConfig paddle = scriptedPaddle();  // no start, no ramp
  s.boundaries.push_back(paddle);
  BodySet bodies(s);
  const MotionConfig& m = paddle.motion;
  const double h = 1e-6;  // s
  for (double t : {0.0, 0.013, 0.25, 1.7})
  {
    const BodyState st = stateAt(bodies, t);
    const Eigen::Quaterniond rot(Eigen::AngleAxisd(m.angular_velocity.norm() * t, m.angular_velocity.normalized()));
    const Vec3d o = m.about + rot * (paddle.pose.translation - m.about) + m.linear_velocity * t;
    EXPECT_LT((st.pose.translation - o).norm(), 1e-14) << t;
    EXPECT_EQ(st.w, m.angular_velocity);
    EXPECT_EQ(st.alpha, Vec3d::Zero());
    EXPECT_LT((st.v - (m.angular_velocity.cross(o - m.about - m.linear_velocity * t) + m.linear_velocity)).norm(),
              1e-14)
        << t;
    if (t == 0.0) continue;  // the motion starts at t = 0: no central difference there
    const BodyState lo = stateAt(bodies, t - h);
    const BodyState hi = stateAt(bodies, t + h);
    EXPECT_LT(((hi.pose.translation - lo.pose.translation) / (2 * h) - st.v).norm(), 1e-8) << t;
    EXPECT_LT(((hi.v - lo.v) / (2 * h) - st.a).norm(), 1e-6) << t;
  }
}

TEST(Simulation, ScriptedBodyWaitsForItsStart)
{
  SceneConfig s = smallScene();
  BoundaryConfig paddle = scriptedPaddle();
  paddle.motion.start = 0.02;  // s
  s.boundaries.push_back(paddle);
  s.time_step.fixed = 0.005;
  Simulation sim(s);
  EXPECT_TRUE(sim.body(0).moving);
  const std::vector<Vec3> initial = sim.boundaryPositions();
  for (int k = 0; k < 4; ++k) sim.step();  // poses at 0 .. 0.015 s
  EXPECT_TRUE(sim.boundaryPositions() == initial);
  EXPECT_EQ(sim.body(0).linear_velocity, Vec3d::Zero());
  for (int k = 0; k < 3; ++k) sim.step();  // poses at 0.02 .. 0.03 s: moving
  EXPECT_FALSE(sim.boundaryPositions() == initial);
  EXPECT_EQ(sim.body(0).angular_velocity, paddle.motion.angular_velocity);
}

TEST(SceneValidation, MotionStartAndRampNameTheirKey)
{
  SceneConfig s = smallScene();
  s.boundaries.push_back(scriptedPaddle());
  s.boundaries[0].motion.start = -0.1;
  EXPECT_EQ(errorKey(s), "boundaries[0].motion.start");
  s.boundaries[0].motion.start = 0.0;
  s.boundaries[0].motion.ramp = std::nan("");
  EXPECT_EQ(errorKey(s), "boundaries[0].motion.ramp");
  s.boundaries[0].motion.ramp = -1.0;
  EXPECT_EQ(errorKey(s), "boundaries[0].motion.ramp");
}

namespace
{
/// A 10 cm box `pusher` posed by the caller (external), away from the fluid, fixed 10 ms steps.
SceneConfig externalPusherScene()
{
  SceneConfig s = smallScene();
  BoundaryConfig box;
  box.name = "pusher";
  box.type = ShapeType::Box;
  box.box = {Vec3d(-0.05, -0.05, -0.05), Vec3d(0.05, 0.05, 0.05)};
  box.externally_posed = true;
  s.boundaries.push_back(box);
  s.fluid[0].box = {Vec3d(0.3, 0.3, 0.3), Vec3d(0.5, 0.5, 0.5)};
  s.time_step.fixed = 0.01;
  return s;
}
}  // namespace

TEST(Simulation, ExternalPosesGiveVelocities)
{
  Simulation sim(externalPusherScene());
  const std::size_t idx = sim.bodyIndex("pusher");
  EXPECT_THROW(sim.bodyIndex("nope"), ConfigError);
  for (int k = 0; k < 5; ++k)
  {
    Pose pose;
    pose.translation = Vec3d(0.1 * sim.time(), 0, 0);  // 0.1 m/s along x
    sim.setBodyPose(idx, pose);
    sim.step();
  }
  EXPECT_NEAR(sim.body(idx).linear_velocity.x(), 0.1, 1e-9);
  EXPECT_NEAR(sim.body(idx).pose.translation.x(), 0.1 * 0.04, 1e-12);

  // A jump (after a pause or reset) places the body without a velocity spike.
  Pose far;
  far.translation = Vec3d(0.2, 0, 0);
  sim.setBodyPose(idx, far, true);
  sim.step();
  EXPECT_EQ(sim.body(idx).linear_velocity, Vec3d::Zero());
  EXPECT_NEAR(sim.body(idx).pose.translation.x(), 0.2, 1e-12);
}

TEST(Simulation, NonFiniteExternalPoseIsRefusedNamingTheBody)
{
  Simulation sim(externalPusherScene());
  const std::size_t idx = sim.bodyIndex("pusher");
  Pose good;
  good.translation = Vec3d(0.1, 0, 0);
  sim.setBodyPose(idx, good, true);
  sim.step();
  Pose nan_rotation = good;
  nan_rotation.rotation = Eigen::Quaterniond(NAN, 0, 0, 0);
  Pose inf_translation = good;
  inf_translation.translation.z() = INFINITY;
  for (const Pose& bad : {nan_rotation, inf_translation})
  {
    try
    {
      sim.setBodyPose(idx, bad);
      ADD_FAILURE() << "a non-finite pose was accepted";
    }
    catch (const std::invalid_argument& e)
    {
      EXPECT_NE(std::string(e.what()).find("body 'pusher'"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("not finite"), std::string::npos) << e.what();
    }
    sim.step();
    // The body keeps its last good pose, and so do its particles.
    EXPECT_EQ(sim.body(idx).pose.translation, good.translation);
    EXPECT_TRUE(sim.body(idx).pose.rotation.coeffs().allFinite());
    for (const Vec3& x : sim.boundaryPositions()) ASSERT_TRUE(x.allFinite());
  }
}

TEST(Simulation, ExternalBodyThatStopsHasZeroVelocityAtOnce)
{
  Simulation sim(externalPusherScene());
  const std::size_t idx = sim.bodyIndex("pusher");
  Pose pose;
  for (int k = 0; k < 5; ++k)
  {
    pose.translation = Vec3d(0.1 * sim.time(), 0, 0);  // 0.1 m/s along x
    sim.setBodyPose(idx, pose);
    sim.step();
  }
  ASSERT_NEAR(sim.body(idx).linear_velocity.x(), 0.1, 1e-9);
  // Held: the same pose again. The step after it sees the body still, not moving at 0.1 m/s.
  sim.setBodyPose(idx, pose);
  sim.step();
  EXPECT_EQ(sim.body(idx).linear_velocity, Vec3d::Zero());
  for (Index b = 0; b < Index(sim.boundaryVelocities().size()); ++b)
    EXPECT_EQ(sim.boundaryVelocities()[b], Vec3::Zero()) << b;
  // No pose at all for a step is the same: the body stays and is still.
  pose.translation.x() += 0.04;  // m: a move over one step, then no pose for the next
  sim.setBodyPose(idx, pose);
  sim.step();
  EXPECT_GT(sim.body(idx).linear_velocity.x(), 0.0);
  sim.step();  // no pose given
  EXPECT_EQ(sim.body(idx).linear_velocity, Vec3d::Zero());
  EXPECT_NEAR(sim.body(idx).pose.translation.x(), pose.translation.x(), 1e-15);
  for (Index b = 0; b < Index(sim.boundaryVelocities().size()); ++b)
    EXPECT_EQ(sim.boundaryVelocities()[b], Vec3::Zero()) << b;
}

TEST(Simulation, FluidOverlappingAnOpenShellIsClearedFromIt)
{
  // A thin open plate (two triangles, no inside) through the middle of a fluid block.
  SceneConfig s = smallScene();
  s.spacing = 0.02;
  BoundaryConfig plate;
  plate.name = "plate";
  plate.type = ShapeType::Mesh;
  plate.mesh.vertices = {Vec3d(-0.05, -0.05, 0.1), Vec3d(0.25, -0.05, 0.1), Vec3d(0.25, 0.25, 0.1),
                         Vec3d(-0.05, 0.25, 0.1)};
  plate.mesh.triangles = {{0, 1, 2}, {0, 2, 3}};
  plate.mesh_closed = false;
  s.boundaries.push_back(plate);
  // The lattice's clearing rule alone: relaxed (fill.relax, test/core/fill_test.cpp), the water
  // above would settle onto the plate and the water below, held by nothing, fall by up to two
  // spacings before t = 0, as it would after.
  s.fill.relax = false;
  Simulation sim(s);
  // The lattice layers at z = 0.09 and 0.11 lie half a spacing from the plate: both are dropped.
  EXPECT_EQ(sim.removedAtStart(), 2u * 10u * 10u);
  for (const Vec3& x : sim.positions())
    for (const Vec3& b : sim.boundaryPositions()) ASSERT_GE((x - b).norm(), 0.75 * 0.02 - 1e-6);
}

TEST(Simulation, SettingsChangeBetweenStepsAndBadOnesLeaveItUnchanged)
{
  SceneConfig s = smallScene();
  s.solver.min_iterations = 2;
  Simulation sim(s);
  sim.step();

  SolverConfig solver = sim.scene().solver;
  solver.min_iterations = 7;
  solver.density_error = 0.0005;
  ViscosityConfig visc;
  visc.model = ViscosityModel::Xsph;
  visc.coefficient = 0.1;
  sim.updateSettings(solver, visc, sim.scene().stability);
  EXPECT_EQ(sim.scene().solver.min_iterations, 7);
  EXPECT_EQ(sim.scene().viscosity.model, ViscosityModel::Xsph);
  // The new minimum takes effect in the next step.
  EXPECT_GE(sim.step().density_iterations, 7);

  SolverConfig bad = sim.scene().solver;
  bad.density_error = -1.0;
  try
  {
    sim.updateSettings(bad, visc, sim.scene().stability);
    FAIL() << "negative tolerance accepted";
  }
  catch (const ConfigError& e)
  {
    EXPECT_EQ(e.key(), "solver.density_error");
  }
  EXPECT_DOUBLE_EQ(sim.scene().solver.density_error, 0.0005);

  SolverConfig other_method = sim.scene().solver;
  other_method.boundary_pressure = BoundaryPressureMethod::Mirroring;
  EXPECT_THROW(sim.updateSettings(other_method, visc, sim.scene().stability), ConfigError);
  EXPECT_EQ(sim.scene().solver.boundary_pressure, BoundaryPressureMethod::Mls);
}

namespace
{
/// Water in a free-slip cylinder (radius 0.2 m) at 4 cm, turning about its vertical axis or not.
SceneConfig turningCylinder(double omega, bool wall_velocity_in_rate)
{
  SceneConfig s;
  s.spacing = 0.04;
  s.domain = {Vec3d(-0.3, -0.3, -0.1), Vec3d(0.3, 0.3, 0.4)};
  s.time_step.fixed = 0.002;
  s.fill.relax = false;  // the same lattice in both runs, and quick
  s.solver.wall_velocity_in_density_rate = wall_velocity_in_rate;
  FluidBlockConfig f;
  f.box = {Vec3d(-0.2, -0.2, 0.0), Vec3d(0.2, 0.2, 0.12)};
  s.fluid.push_back(f);
  BoundaryConfig c;
  c.name = "cylinder";
  c.type = ShapeType::Cylinder;
  c.cylinder.center = Vec3d(0, 0, 0.15);
  c.cylinder.axis = Vec3d(0, 0, 1);
  c.cylinder.radius = 0.2;
  c.cylinder.length = 0.3;
  c.inside = true;
  c.motion.angular_velocity = Vec3d(0, 0, omega);
  s.boundaries.push_back(c);
  return s;
}

std::vector<Vec3> positionsAfter(const SceneConfig& s, int steps)
{
  Simulation sim(s);
  for (int k = 0; k < steps; ++k) EXPECT_FALSE(sim.step().unstable);
  return sim.positions();
}
}  // namespace

TEST(Simulation, WallVelocityOutOfTheDensityRateChangesOnlyWallsThatMove)
{
  // Still walls have v_b = 0 either way: bit for bit the same run.
  EXPECT_EQ(positionsAfter(turningCylinder(0.0, true), 10), positionsAfter(turningCylinder(0.0, false), 10));
  // A turning wall's v_b is tangential; its discrete term in Eq. A2 is not zero, so leaving it
  // out changes the run (that difference is the density-rate term's share of the drag).
  const std::vector<Vec3> with = positionsAfter(turningCylinder(2.0, true), 10);
  const std::vector<Vec3> without = positionsAfter(turningCylinder(2.0, false), 10);
  ASSERT_EQ(with.size(), without.size());
  double diff = 0.0;
  for (std::size_t i = 0; i < with.size(); ++i) diff = std::max(diff, double((with[i] - without[i]).norm()));
  EXPECT_GT(diff, 1e-7) << "m, largest position difference after 10 steps";
}

TEST(Simulation, DensityResidualFigureLeavesOutTheFreeSurfaceNoPressureCanFill)
{
  // A lattice block in a box tank starts at rest density inside; its top layer lacks the plane
  // above it, 0.15 rho0 short, and its pressure stays clamped at zero. That residual is not the
  // solve's to remove: counted, it was the figure of every iteration (0.1495), hiding the ones
  // the figure is for. What is left in the first step is gravity's compression of one step,
  // g dt^2 / s = 5e-5 here, far below the 0.15.
  SceneConfig s;
  s.spacing = 0.02;
  s.domain = {Vec3d(-0.1, -0.1, -0.1), Vec3d(0.3, 0.3, 0.4)};
  s.time_step.fixed = 0.001;
  FluidBlockConfig f;
  f.box = {Vec3d(0, 0, 0), Vec3d(0.2, 0.2, 0.1)};
  s.fluid.push_back(f);
  BoundaryConfig tank;
  tank.name = "tank";
  tank.type = ShapeType::Box;
  tank.box = {Vec3d(0, 0, 0), Vec3d(0.2, 0.2, 0.3)};
  tank.inside = true;
  s.boundaries.push_back(tank);
  for (BoundaryPressureMethod m : {BoundaryPressureMethod::Mirroring, BoundaryPressureMethod::Mls})
  {
    s.solver.boundary_pressure = m;
    Simulation sim(s);
    const StepReport rep = sim.step();
    ASSERT_FALSE(rep.density_residual_max.empty());
    for (float r : rep.density_residual_max) EXPECT_LT(r, 0.01f) << "method " << int(m);
  }
}

TEST(Simulation, AutoSamplesMovingBodiesAtHalfTheSpacing)
{
  // The same box with sample_spacing auto still, turning, posed by the caller, and turning with
  // sample_spacing 0 (the default, the scene's spacing): auto samples a body that can move at
  // half the spacing, about 4 times as many particles on its surface.
  const auto count = [](const Vec3d& w, bool external, double sample_spacing) {
    SceneConfig s = smallScene();
    BoundaryConfig paddle;
    paddle.name = "paddle";
    paddle.type = ShapeType::Box;
    paddle.box = {Vec3d(0.3, 0.0, 0.0), Vec3d(0.5, 0.2, 0.2)};
    paddle.motion.angular_velocity = w;
    paddle.externally_posed = external;
    paddle.sample_spacing = sample_spacing;
    s.boundaries.push_back(paddle);
    return Simulation(s).boundaryPositions().size();
  };
  const std::size_t still = count(Vec3d::Zero(), false, kAutoSampleSpacing);
  const std::size_t turning = count(Vec3d(0, 0, 1), false, kAutoSampleSpacing);
  const std::size_t posed = count(Vec3d::Zero(), true, kAutoSampleSpacing);
  const std::size_t coarse = count(Vec3d(0, 0, 1), false, 0.0);
  EXPECT_EQ(coarse, still);
  EXPECT_EQ(posed, turning);
  EXPECT_GT(double(turning), 3.0 * double(still));
  EXPECT_LT(double(turning), 5.0 * double(still));
}

TEST(Simulation, SinksDrainTheWaterThatEntersThemAndCountIt)
{
  // The small fluid cube (5 cm spacing, 64 particles) falls onto a box sink under one half of it
  // and a sphere sink under the other: every particle ends in one of them, none inside after a step.
  SceneConfig s = smallScene();
  RegionConfig box;
  box.name = "drain";
  box.shape = RegionShape::Box;
  box.box = {Vec3d(-0.1, -0.1, -0.2), Vec3d(0.1, 0.1, -0.1)};  // in its frame
  box.pose.translation = Vec3d(0.05, 0.15, 0.0);               // under x < 0.15
  s.sinks.push_back(box);
  RegionConfig ball;
  ball.name = "funnel";
  ball.shape = RegionShape::Sphere;
  ball.sphere = {Vec3d(0.18, 0.1, -0.15), 0.13};
  s.sinks.push_back(ball);
  Simulation sim(s);
  const std::size_t n0 = sim.numFluidParticles();
  std::size_t drained = 0;
  while (sim.time() < 0.4 - 1e-9)
  {
    const StepReport r = sim.step();
    ASSERT_FALSE(r.unstable);
    drained += r.drained;
    for (const Vec3& x : sim.positions())
    {
      const Vec3d p = x.cast<double>() - box.pose.translation;
      EXPECT_FALSE((p.array() >= box.box.min.array()).all() && (p.array() <= box.box.max.array()).all());
      EXPECT_GT((x.cast<double>() - ball.sphere.center).norm(), ball.sphere.radius);
    }
  }
  const std::vector<SinkTotal>& totals = sim.sinkTotals();
  ASSERT_EQ(totals.size(), 2u);
  EXPECT_EQ(totals[0].name, "drain");
  EXPECT_GT(totals[0].particles, 0u);
  EXPECT_GT(totals[1].particles, 0u);
  EXPECT_EQ(totals[0].particles + totals[1].particles, drained);
  EXPECT_EQ(sim.numFluidParticles() + drained + sim.removedTotal(), n0);
  EXPECT_NEAR(totals[1].volume, double(totals[1].particles) * 0.05 * 0.05 * 0.05, 1e-12);
  EXPECT_NEAR(totals[1].mass, 1000.0 * totals[1].volume, 1e-9);

  // A body sink and a sink without a name are refused by key.
  s.sinks[1].shape = RegionShape::Body;
  s.sinks[1].body = "anything";
  EXPECT_THROW(
      {
        try
        {
          validate(s);
        }
        catch (const ConfigError& e)
        {
          EXPECT_NE(std::string(e.what()).find("sinks[1].body"), std::string::npos) << e.what();
          throw;
        }
      },
      ConfigError);
  s.sinks[1] = box;
  EXPECT_THROW(validate(s), ConfigError);  // duplicate name 'drain'
}

TEST(Neighborhoods, MovingBodyIsSortedAgainWithoutTheStaticWalls)
{
  // A tank that never moves and a scripted paddle: the paddle's motion writes only the moving
  // bodies' positions (the walls are sorted once), and every step's fluid-boundary lists are
  // still exactly the pairs within the support, walls and paddle.
  SceneConfig s = smallScene();
  s.domain = {Vec3d(-0.3, -0.3, -0.3), Vec3d(0.7, 0.7, 0.7)};
  BoundaryConfig tank;
  tank.name = "tank";
  tank.type = ShapeType::Box;
  tank.box = {Vec3d(-0.2, -0.2, -0.2), Vec3d(0.6, 0.6, 0.6)};
  tank.inside = true;
  s.boundaries.push_back(tank);
  BoundaryConfig paddle;
  paddle.name = "paddle";
  paddle.type = ShapeType::Box;
  paddle.box = {Vec3d(0.3, 0.0, 0.0), Vec3d(0.4, 0.1, 0.1)};
  paddle.motion.angular_velocity = Vec3d(0, 0, M_PI);
  paddle.motion.about = Vec3d(0.2, 0.2, 0.05);
  s.boundaries.push_back(paddle);
  BodySet bodies(s);
  ASSERT_FALSE(bodies[0].moving);
  ASSERT_TRUE(bodies[1].moving);
  const std::uint64_t walls = bodies.staticVersion();
  FluidParticles fluid;
  for (int i = 0; i < 16; ++i)
    for (int j = 0; j < 16; ++j)
      for (int k = 0; k < 8; ++k)
        fluid.add(Vec3(Real(-0.19 + 0.05 * i), Real(-0.19 + 0.05 * j), Real(-0.19 + 0.045 * k)), Vec3::Zero(),
                  Real(1000));
  const CubicKernel kernel(Real(2 * s.spacing));
  Neighborhoods nb(s, kernel);
  for (double t : {0.0, 0.1, 0.25, 0.6})
  {
    const std::uint64_t moving = bodies.movingVersion();
    bodies.poseMoving(t);
    EXPECT_EQ(bodies.staticVersion(), walls) << "t " << t;
    EXPECT_GT(bodies.movingVersion(), moving) << "t " << t;
    nb.sortFluid(fluid);
    nb.build(fluid, bodies);
    const Real h = kernel.support();
    std::size_t paddle_pairs = 0;
    for (std::size_t i = 0; i < fluid.size(); ++i)
    {
      std::vector<Index> expected, got(nb.fluid_boundary.index.begin() + nb.fluid_boundary.offset[i],
                                       nb.fluid_boundary.index.begin() + nb.fluid_boundary.offset[i + 1]);
      for (std::size_t b = 0; b < bodies.numParticles(); ++b)
        if ((fluid.x[i] - bodies.x[b]).squaredNorm() < h * h) expected.push_back(Index(b));
      std::sort(got.begin(), got.end());
      ASSERT_EQ(got, expected) << "t " << t << " particle " << i;
      for (Index b : got) paddle_pairs += bodies.body_of[b] == 1;
    }
    EXPECT_GT(paddle_pairs, 0u) << "the paddle must be in the water at t " << t;
  }
}

TEST(Simulation, ASolveFromZeroSkipsOnlyThePressurePassThatIsZero)
{
  // A solve evaluates a^p (Eq. 1, a pass over the pairs) once per iteration, before its Jacobi
  // sweep, and once at the end. From zero the first a^p is zero wherever the wall term vanishes
  // with the fluid's pressure, and that pass is skipped: mirroring and MLS in both solves, SPH in
  // the divergence solve. SPH's density solve has p_b = its hydrostatic constant at p = 0, and its
  // first a^p is that wall term alone, summed over the fluid-boundary pairs, not a pass over the
  // fluid pairs either. Neither changes a result (bit-identical: the shipped scenes' results by
  // scripts/result_hashes.py, 60 of 60 runs each time).
  // Per step of five: the a^p passes a step's two solves would make with every pass, less those
  // made ((iterations + 1) per solve, less pressure_passes).
  const auto skippedPasses = [](const SceneConfig& scene) {
    std::vector<int> skipped;
    Simulation sim(scene);
    for (int step = 0; step < 5; ++step)
    {
      const StepReport r = sim.step();
      EXPECT_FALSE(r.unstable) << r.reason;
      if (r.unstable) break;
      skipped.push_back((r.divergence_iterations + 1) + (r.density_iterations + 1) - r.pressure_passes);
    }
    return skipped;
  };
  for (BoundaryPressureMethod method : {BoundaryPressureMethod::Mirroring, BoundaryPressureMethod::MirroringEq2,
                                        BoundaryPressureMethod::SphExtrapolation, BoundaryPressureMethod::Mls})
  {
    SceneConfig scene = test::waterTank(0.02, Vec3d(0.2, 0.16, 0.2), 0.1);
    scene.solver.boundary_pressure = method;
    scene.solver.cold_start = ColdStart::Zero;
    scene.solver.warm_start = false;
    std::vector<int> skipped = skippedPasses(scene);
    ASSERT_EQ(skipped.size(), 5u) << toString(method);
    for (std::size_t step = 0; step < skipped.size(); ++step)
      EXPECT_EQ(skipped[step], 2) << toString(method) << ", step " << step;
    // Started from the Jacobi step, a guess is non-zero where the water is compressing (Eq. A10a),
    // and every pass is made.
    scene.solver.cold_start = ColdStart::Jacobi;
    skipped = skippedPasses(scene);
    ASSERT_EQ(skipped.size(), 5u) << toString(method);
    for (const int k : skipped) EXPECT_GE(k, 0);
    EXPECT_GT(std::count(skipped.begin(), skipped.end(), 0), 0) << toString(method);
    // With the warm start the divergence solve still starts cold (solver.warm_start_divergence
    // off), from zero here: its first pass is skipped in every step, whatever the density solve
    // does. With warm_start_divergence it starts from the previous step's pressure too, and some
    // step then makes every pass.
    scene.solver.cold_start = ColdStart::Zero;
    scene.solver.warm_start = true;
    scene.solver.warm_start_divergence = false;
    skipped = skippedPasses(scene);
    ASSERT_EQ(skipped.size(), 5u) << toString(method);
    for (std::size_t step = 0; step < skipped.size(); ++step)
      EXPECT_GE(skipped[step], 1) << toString(method) << ", step " << step;
    scene.solver.warm_start_divergence = true;
    skipped = skippedPasses(scene);
    ASSERT_EQ(skipped.size(), 5u) << toString(method);
    EXPECT_GT(std::count(skipped.begin(), skipped.end(), 0), 0) << toString(method);
  }
}

TEST(Simulation, ASceneFarFromTheOriginStepsAsAtTheOrigin)
{
  // The sweep's divergence (Eq. A7) and the density rate (Eq. A2) read each neighbour's field
  // with its dot product with x_j - o in one load (fluidDivergence in dfsph_solver.cpp), o a point
  // inside the fluid: the same sums as from x_i - x_j, whatever the scene's distance from the
  // world origin. A collapsing block at the origin and the same scene 40 m away must step alike:
  // the same iterations within one per step, the water's centre of mass on the same path within
  // 1 % of the spacing, its mean speed within 1 %. (Float positions 40 m away are 4e-6 m apart,
  // 2e-4 of the spacing: the two runs' paths part by about 1e-4 of the spacing. With o left out
  // on one side the sums are off by o . sum_j g_ij f_j and the shifted run blows up; with o at the
  // world origin they carry |x| / h times more rounding, which at 40 m is still 1e-4 of the
  // stopping tolerance's source and does not show here.)
  const double s = 0.02;
  const Vec3d offset(40.0, -25.0, 10.0);
  for (BoundaryPressureMethod method :
       {BoundaryPressureMethod::Mirroring, BoundaryPressureMethod::SphExtrapolation, BoundaryPressureMethod::Mls})
  {
    auto run = [&](const Vec3d& shift, std::vector<int>& iterations, std::vector<Vec3d>& centre,
                   std::vector<double>& speed) {
      SceneConfig scene = test::waterTank(s, Vec3d(0.4, 0.2, 0.3), 0.2);
      scene.fluid[0].box.max.x() = 0.16;  // a block at one end: it collapses and runs along the floor
      scene.solver.boundary_pressure = method;
      scene.domain.min += shift;
      scene.domain.max += shift;
      scene.boundaries[0].box.min += shift;
      scene.boundaries[0].box.max += shift;
      scene.fluid[0].box.min += shift;
      scene.fluid[0].box.max += shift;
      Simulation sim(scene);
      for (int step = 0; step < 80; ++step)
      {
        const StepReport r = sim.step();
        ASSERT_FALSE(r.unstable) << r.reason;
        iterations.push_back(r.density_iterations + r.divergence_iterations);
        Vec3d c = Vec3d::Zero(), v = Vec3d::Zero();
        for (const Vec3& x : sim.positions()) c += x.cast<double>() - shift;
        for (const Vec3& u : sim.velocities()) v += u.cast<double>();
        centre.push_back(c / double(sim.positions().size()));
        speed.push_back(v.norm() / double(sim.velocities().size()));
      }
    };
    std::vector<int> it0, it1;
    std::vector<Vec3d> c0, c1;
    std::vector<double> v0, v1;
    run(Vec3d::Zero(), it0, c0, v0);
    run(offset, it1, c1, v1);
    ASSERT_EQ(it0.size(), it1.size()) << toString(method);
    for (std::size_t k = 0; k < it0.size(); ++k)
    {
      EXPECT_LE(std::abs(it0[k] - it1[k]), 1) << toString(method) << ", step " << k;
      EXPECT_LT((c0[k] - c1[k]).norm(), 0.01 * s) << toString(method) << ", step " << k;
    }
    EXPECT_GT(v0.back(), 0.1) << toString(method);  // the block did collapse
    EXPECT_NEAR(v1.back(), v0.back(), 0.01 * v0.back()) << toString(method);
  }
}
