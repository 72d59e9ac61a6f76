// The same scene gives bit-identical results whatever the number of threads: a user rerunning a
// scene, or the validation suite comparing methods, must not see a different dam break because
// the machine was busy.

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cstring>

#include "fluid_sim/core/simulation.h"

using namespace fluid_sim;

namespace
{
/// config/bench_dam_break.yaml at spacing 0.017 m (195,112 fluid particles): the smallest case
/// found where the chunking of TBB's default partitioner changed the results (with 1 and 3
/// threads they parted at step 119; two identical runs once parted at step 110). Dam breaks of
/// 8-64 k particles did not show it in 400 steps, so the test uses this size.
SceneConfig benchDamBreak()
{
  SceneConfig s;
  s.spacing = 0.017;
  s.domain = {Vec3d(-2.1, -0.85, -0.1), Vec3d(2.1, 0.85, 3.1)};
  s.time_step.fixed = 0.001;
  s.solver.boundary_pressure = BoundaryPressureMethod::Mls;
  s.solver.density_error = 0.0005;
  s.solver.divergence_error = 0.001;
  s.solver.min_iterations = 2;
  s.solver.max_iterations = 100;
  s.viscosity.model = ViscosityModel::Xsph;
  s.viscosity.coefficient = 0.01;
  FluidBlockConfig f;
  f.box = {Vec3d(-1.95, -0.5, 0.05), Vec3d(-0.95, 0.5, 1.05)};
  s.fluid.push_back(f);
  BoundaryConfig tank;
  tank.name = "tank";
  tank.type = ShapeType::Box;
  tank.box = {Vec3d(-2.0, -0.75, 0.0), Vec3d(2.0, 0.75, 3.0)};
  tank.inside = true;
  s.boundaries.push_back(tank);
  return s;
}

template <class T>
bool sameBits(const std::vector<T>& a, const std::vector<T>& b)
{
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0;
}
}  // namespace

TEST(Determinism, ThreadCountDoesNotChangeTheResult)
{
  const SceneConfig scene = benchDamBreak();
  Simulation one(scene), three(scene);
  ASSERT_EQ(one.numFluidParticles(), 195112u);
  for (int step = 1; step <= 125; ++step)
  {
    {
      tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
      one.step();
    }
    {
      // More threads than this machine's 2 cores: the scheduler preempts and steals often.
      tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 3);
      three.step();
    }
    ASSERT_TRUE(sameBits(one.velocities(), three.velocities())) << "velocities differ after step " << step;
    ASSERT_TRUE(sameBits(one.pressures(), three.pressures())) << "pressures differ after step " << step;
    ASSERT_TRUE(sameBits(one.positions(), three.positions())) << "positions differ after step " << step;
  }
}
