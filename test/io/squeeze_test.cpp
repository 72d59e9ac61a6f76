// A floating box squeezed towards a tank wall by the paddle robot (test/fixtures/squeeze): the
// MLS density solve's guards for a particle between two walls (docs/method.md, Eqs. A4c, A4d).
// Without them the solve diverged in the first step (A4c) or 0.02 s later (A4d).

#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

#include "fluid_sim/core/simulation.h"
#include "fluid_sim/io/scene_loader.h"

namespace fluid_sim
{
namespace
{
TEST(Squeeze, AParticleBetweenABoxAndATankWallDoesNotBlowUpTheMlsSolve)
{
  // The robot's meshes are package://fluid_sim/...: this source tree is the package.
  ::setenv("ROS_PACKAGE_PATH", FLUID_SIM_SOURCE_DIR, 1);
  const SceneConfig scene = io::loadScene(FLUID_SIM_SOURCE_DIR "/test/fixtures/squeeze/scene.yaml");
  Simulation sim(scene);
  // 2,577 in the file; 2 lie past a wall's surface and are dropped as lattice points would be.
  ASSERT_EQ(sim.numFluidParticles(), 2575u);
  int steps = 0;
  double first_ratio = 1.0;
  while (sim.time() < 0.1 - 1e-9)
  {
    const StepReport rep = sim.step();
    ++steps;
    if (steps == 1) first_ratio = rep.feedback_ratio_min;
    ASSERT_FALSE(rep.unstable) << "step " << steps << " at t = " << sim.time() << " s: " << rep.reason;
    EXPECT_TRUE(rep.density_converged) << "step " << steps << ": density error " << rep.density_error << " after "
                                       << rep.density_iterations << " sweeps";
    EXPECT_TRUE(rep.divergence_converged) << "step " << steps << ": divergence error " << rep.divergence_error;
    EXPECT_LT(rep.max_speed, 5.0) << "step " << steps;  // m/s; the paddle's tip moves at 0.4
  }
  // The case A4c is for: a particle whose own pressure, with the walls' answer, adds to its
  // compression (measured -2.62 in the first step).
  EXPECT_LE(first_ratio, 0.0);
  std::printf("squeeze: %d steps to 0.1 s, first step's feedback ratio %.3f\n", steps, first_ratio);
}
}  // namespace
}  // namespace fluid_sim
