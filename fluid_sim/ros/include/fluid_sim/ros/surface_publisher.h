#pragma once
// The free surface on the topic `surface` (visualization_msgs/Marker, TRIANGLE_LIST, fixed frame;
// core surface.h makes the mesh with OpenVDB): at its own rate, `~surface_rate` (Hz; 0 = off, the
// default), in a thread of its own. The publisher thread offers it the positions of every frame
// it publishes; when a surface is due, they are copied and the surface thread reconstructs and
// publishes them, so that neither the solver nor the other topics ever wait for a mesh. A surface
// still being made when the next one is due makes that one wait in its place (the newest
// positions win); none is made while the rate is 0 or nobody subscribes, and none is published
// after the rate was set to 0.

#include <atomic>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <ros/node_handle.h>
#include <ros/publisher.h>
#include <ros/time.h>

#include "fluid_sim/core/surface.h"
#include "fluid_sim/core/types.h"
#include "fluid_sim/ros/node_parameters.h"

namespace fluid_sim
{
namespace ros_bridge
{
class SurfacePublisher
{
public:
  /// Markers are in opt.fixed_frame; the rate starts at opt.surface_rate (advertise()). `opt` is
  /// read once by the node before any call below and must outlive this object. The
  /// reconstruction's options (lengths in spacings) are the core's defaults.
  explicit SurfacePublisher(const NodeOptions& opt) : opt_(opt) {}
  /// Stops and joins the surface thread (a joinable thread must not be destroyed).
  ~SurfacePublisher();
  SurfacePublisher(const SurfacePublisher&) = delete;
  SurfacePublisher& operator=(const SurfacePublisher&) = delete;

  /// Advertises `surface` in `nh` (the node's namespace) whatever the rate: advertising costs
  /// nothing, and a rate set later by dynamic_reconfigure then needs no new topic. `spacing` (m)
  /// is the scene's; the reconstruction's lengths scale with it. The rate starts at
  /// opt.surface_rate.
  void advertise(ros::NodeHandle& nh, double spacing);

  /// Surfaces per second of the frames' stamps (Hz; 0 = off); from any thread, at once. Off, it
  /// also drops positions offered and not yet taken, and a surface being made when it was
  /// switched off is not published: nothing comes out after the call returns.
  void setRate(double hz);

  /// From the publisher thread, with every frame it publishes: if a surface is due (rate > 0, a
  /// subscriber, 1 / rate or more since the stamp of the last one offered; a stamp that went back,
  /// after a reset or a jump of ROS time, starts afresh), copies `positions` (m, fixed frame) for
  /// the surface thread. Takes a lock only to hand them over, never for a reconstruction.
  void offer(const ros::Time& stamp, const std::vector<Vec3>& positions);

  /// Starts the surface thread; `on_failure` is called (after ROS_FATAL) if something thrown
  /// there ends it.
  void start(std::function<void(const std::string&)> on_failure);
  /// Tells the surface thread to end (a surface being made is finished first).
  void requestStop();
  /// Waits for the surface thread to end.
  void join();

private:
  void run();

  const NodeOptions& opt_;
  double spacing_ = 0.0;  // m
  SurfaceOptions options_;
  ros::Publisher pub_;
  std::atomic<double> rate_{0.0};  // Hz
  ros::Time last_offer_;           // stamp of the last positions taken (publisher thread only)

  // The publisher thread swaps positions into `pending_`; the surface thread swaps them out.
  std::mutex mutex_;
  std::condition_variable cv_;
  std::vector<Vec3> pending_;
  ros::Time pending_stamp_;
  bool ready_ = false;
  std::atomic<bool> stopping_{false};
  std::thread thread_;
};

}  // namespace ros_bridge
}  // namespace fluid_sim
