#pragma once
// The fluid_sim ROS node (also loaded as a nodelet, fluid_sim/FluidSimNodelet): poses URDF links
// from tf2, steps the simulation in its own thread, publishes clouds, wrenches and statistics
// from a second thread, and serves reset / pause / step and dynamic_reconfigure.
//
// Parameters, topics and services are documented in README.md ("The ROS node").

#include <functional>
#include <memory>
#include <stdexcept>
#include <string>

#include <ros/ros.h>

namespace fluid_sim
{
namespace ros_bridge
{
/// A configuration problem at start-up (missing robot_description, unknown link, missing mesh,
/// bad scene key, ...). what() names the parameter, link or file.
class StartupError : public std::runtime_error
{
public:
  using std::runtime_error::runtime_error;
};

class FluidSimNode
{
public:
  /// Topics and services go to `nh` (the node's namespace: for the node /fluid_sim/fluid_sim of
  /// launch/fluid_sim.launch, /fluid_sim/particles, ...), so that remapping `particles` works;
  /// the parameters and dynamic_reconfigure are read from and served in `pnh` (its private
  /// namespace, /fluid_sim/fluid_sim). tf and /clock are global names.
  FluidSimNode(ros::NodeHandle nh, ros::NodeHandle pnh);
  ~FluidSimNode();
  FluidSimNode(const FluidSimNode&) = delete;
  FluidSimNode& operator=(const FluidSimNode&) = delete;

  /// Reads the parameters, loads the URDF and the scene, waits until tf knows every link,
  /// builds the simulation, advertises and starts the solver and publisher threads.
  /// Throws StartupError. Returns false if ROS shut down (or stop() was called) while waiting.
  bool start();

  /// Stops the threads (idempotent). Called by the destructor.
  void stop();

  /// Called from the solver (or publisher) thread when the run ends by itself: `stop_after`
  /// reached (code 0), the simulation became unstable in a run with `stop_after` (code 3), or
  /// the solver or publisher thread stopped on an exception, logged with ROS_FATAL (code 1).
  void onFinished(std::function<void(int code)> callback);

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace ros_bridge
}  // namespace fluid_sim
