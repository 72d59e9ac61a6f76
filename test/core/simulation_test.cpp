#include "fluid_sim/core/simulation.h"

#include <gtest/gtest.h>

using namespace fluid_sim;

namespace
{
SceneConfig smallScene()
{
  SceneConfig s;
  s.spacing = 0.05;
  s.domain = {Vec3d(-0.2, -0.2, -0.2), Vec3d(0.6, 0.6, 0.6)};
  FluidBlockConfig f;
  f.box = {Vec3d(0, 0, 0), Vec3d(0.2, 0.2, 0.2)};
  s.fluid.push_back(f);
  return s;
}

std::string errorKey(const SceneConfig& s)
{
  try
  {
    Simulation sim(s);
  }
  catch (const ConfigError& e)
  {
    return e.key();
  }
  return "<no error>";
}
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

TEST(Simulation, ExternalPosesGiveVelocities)
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
  Simulation sim(s);
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
