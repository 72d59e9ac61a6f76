// ThreadSanitizer check of the solver loop's shared state (issue 12): the service threads
// (pause, step) and the solver thread. Built only with -DFLUID_SIM_TSAN_TESTS=ON: the ROS
// layer's sources are compiled again with -fsanitize=thread into this test (the core and io
// stay uninstrumented; TBB runs on one thread). A data race makes ThreadSanitizer report and
// the test exit non-zero. Before issue 12, paused_ was read without the lock in publishFrame
// and last_status_ written without it while the step service read it under it.
#include <chrono>
#include <thread>

#include <gtest/gtest.h>
#include <ros/time.h>
#include <tbb/global_control.h>

#include "fluid_sim/io/scene_loader.h"
#include "fluid_sim/ros/link_poses.h"
#include "fluid_sim/ros/publishers.h"
#include "fluid_sim/ros/solver_loop.h"

using namespace fluid_sim;
using namespace fluid_sim::ros_bridge;

TEST(SolverLoopRaces, PauseStepAndResumeFromServiceThreads)
{
  ros::Time::init();
  tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
  NodeOptions opt;
  opt.real_time_factor = 0.0;  // as fast as it can: no pacing against ROS time
  opt.publish_rate = 1000.0;   // a frame after (nearly) every step
  opt.publish_boundary = false;
  LinkPoses links(opt);
  Publishers publishers(opt);  // not advertised: frames are handed over and dropped
  SolverLoop loop(opt, links, publishers);
  loop.setScene(io::parseScene(R"yaml(
spacing: 0.05
domain: {min: [-0.1, -0.1, -0.1], max: [0.4, 0.4, 0.4]}
time_step: {fixed: 0.002}
fill: {relax: false}
fluid:
  - box: {min: [0, 0, 0], max: [0.2, 0.2, 0.2]}
boundaries:
  - box: {min: [0, 0, 0], max: [0.3, 0.3, 0.3]}
    inside: true
)yaml",
                               "race.yaml"),
                {});
  loop.build({}, ros::Time());
  loop.start();
  // The step service waits for its steps; the pause service resumes meanwhile, so the waiting
  // call returns while the solver runs on (and reads what the solver writes after each step).
  for (int k = 0; k < 60; ++k)
  {
    loop.pause(true);
    std::thread resume([&] {
      std::this_thread::sleep_for(std::chrono::microseconds(200 * (k % 5)));
      loop.pause(false);
    });
    const CommandResult r = loop.step(3);
    resume.join();
    EXPECT_GE(r.sim_time, 0.0);
    std::this_thread::sleep_for(std::chrono::milliseconds(2));  // running: frames read paused_
  }
  loop.requestStop();
  loop.join();
}

int main(int argc, char** argv)
{
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
