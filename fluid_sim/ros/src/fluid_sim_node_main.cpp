// fluid_sim_node: loads, builds, spins (README "The ROS node"). Exit codes: 0 done (or shut
// down), 1 bad configuration (the error names it) or a solver / publisher thread that stopped on
// an exception (logged with ROS_FATAL, naming the cause), 3 the simulation became unstable in a
// run with ~stop_after.
#include <atomic>
#include <cstdio>

#include <ros/ros.h>

#include "fluid_sim/ros/fluid_sim_node.h"

int main(int argc, char** argv)
{
  ros::init(argc, argv, "fluid_sim");
  ros::NodeHandle nh, pnh("~");
  std::atomic<int> code{0};
  fluid_sim::ros_bridge::FluidSimNode node(nh, pnh);
  node.onFinished([&code](int c) {
    code = c;
    ros::requestShutdown();
  });
  // Service and dynamic_reconfigure callbacks; the node steps and publishes in its own threads.
  ros::AsyncSpinner spinner(2);
  spinner.start();
  try
  {
    if (!node.start()) return 0;  // shut down while waiting for tf
  }
  catch (const std::exception& e)
  {
    ROS_FATAL("fluid_sim: %s", e.what());
    std::fprintf(stderr, "fluid_sim: error: %s\n", e.what());
    return 1;
  }
  catch (...)
  {
    ROS_FATAL("fluid_sim: start-up stopped on an exception that is not a std::exception");
    return 1;
  }
  ros::waitForShutdown();
  node.stop();
  return code;
}
