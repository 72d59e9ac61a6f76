// The same scene gives bit-identical results whatever the number of threads: a user rerunning a
// scene, or the validation suite comparing methods, must not see a different dam break because
// the machine was busy. (Here rather than with the core tests because it reads the shipped
// benchmark scene.)

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cstring>
#include <string>

#include "fluid_sim/core/simulation.h"
#include "fluid_sim/io/scene_loader.h"

using namespace fluid_sim;

namespace
{
template <class T>
bool sameBits(const std::vector<T>& a, const std::vector<T>& b)
{
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0;
}

/// Runs config/bench_dam_break.yaml at `spacing` (m) with one thread and with three, step by
/// step, and compares every velocity, pressure and position bit for bit.
void expectSameResultWithOneAndThreeThreads(const std::string& spacing, std::size_t particles, int steps,
                                            const std::vector<std::string>& more_overrides = {})
{
  std::vector<std::string> overrides{"spacing=" + spacing};
  overrides.insert(overrides.end(), more_overrides.begin(), more_overrides.end());
  const SceneConfig scene = io::loadScene(FLUID_SIM_SOURCE_DIR "/config/bench_dam_break.yaml", overrides);
  Simulation one(scene), three(scene);
  ASSERT_EQ(one.numFluidParticles(), particles);
  for (int step = 1; step <= steps; ++step)
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
}  // namespace

TEST(Determinism, ThreadCountDoesNotChangeTheResult)
{
  // Every parallel loop of the step works on fixed chunks (256-1024 particles) and reduces
  // them in a fixed order, so any scene of many chunks shows a thread-count dependence if one
  // comes back: here 35-140 chunks per loop, through the dam's first steps.
  expectSameResultWithOneAndThreeThreads("0.03", 35937u, 100);
}

TEST(Determinism, GaussSeidelSweepsDoNotDependOnTheThreadCount)
{
  // Eq. A8b updates the particles in turn, the units of one colour at once on any thread
  // (dfsph_solver.cpp): the same pressures whichever thread swept which unit. Gauss-Seidel takes
  // over from a density solve's third sweep; at the scene's tolerance the dam's first 100 steps
  // end after two (2.00 per step), at 1e-5 they take 2.93.
  expectSameResultWithOneAndThreeThreads("0.03", 35937u, 100,
                                         {"solver.sweep=gauss_seidel", "solver.density_error=1e-5"});
}

// The case that found the partitioner's dependence (195,112 fluid particles, 125 steps; about
// 4 minutes here): with TBB's default partitioner, runs with 1 and 3 threads parted at step 119
// and two identical runs once at step 110, while dam breaks of 8-64 k particles did not show it
// in 400 steps. Too long for every test run; run it with
//   build/devel/lib/fluid_sim/determinism_test --gtest_also_run_disabled_tests --gtest_filter='*AtFullSize'
TEST(Determinism, DISABLED_ThreadCountDoesNotChangeTheResultAtFullSize)
{
  expectSameResultWithOneAndThreeThreads("0.017", 195112u, 125);
}
