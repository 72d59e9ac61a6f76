#pragma once
// Publishers of the node's topics (particles, boundary_particles, contact_wrenches,
// wrench/<body>, free_bodies, stats, and the scene's instruments: regions/<region>, probes) and of the scene bodies'
// and free bodies' tf frames, and their thread. The solver thread fills a Frame between steps and hands it over; the
// publisher thread turns it into messages (through the converter, messages.h). A slow publisher drops frames; it never
// blocks the solver. The free surface (`surface`) is made from the frames' positions in a thread of its own
// (surface_publisher.h), at its own rate.

#include <atomic>
#include <condition_variable>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <ros/node_handle.h>
#include <ros/publisher.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_ros/transform_broadcaster.h>

#include "fluid_msgs/ContactWrenchArray.h"
#include "fluid_msgs/FreeBodyArray.h"
#include "fluid_msgs/ProbeArray.h"
#include "fluid_msgs/RegionState.h"
#include "fluid_msgs/SinkArray.h"
#include "fluid_msgs/SolverStats.h"
#include "fluid_msgs/Spill.h"
#include "fluid_sim/core/simulation.h"
#include "fluid_sim/ros/messages.h"
#include "fluid_sim/ros/node_parameters.h"
#include "fluid_sim/ros/ros_names.h"
#include "fluid_sim/ros/surface_publisher.h"

namespace fluid_sim
{
namespace ros_bridge
{
/// What the publisher thread turns into messages (copied out by the solver between steps).
struct Frame
{
  ros::Time stamp;  // the simulated instant in ROS time (tf-coupled), else when the frame was taken
  FluidSnapshot fluid;
  bool boundary_valid = false;                                   // the boundary cloud below is to be published
  std::vector<Vec3> boundary;                                    // m, fixed frame
  std::vector<Real> boundary_pressure;                           // Pa
  std::vector<std::pair<std::size_t, std::size_t>> body_ranges;  // (first, count) per body
  fluid_msgs::ContactWrenchArray wrenches;
  std::vector<Pose> body_poses;           // body -> fixed frame (m), per body (moving scene bodies go on tf)
  fluid_msgs::FreeBodyArray free_bodies;  // the free bodies' state; no bodies for a scene without any
  fluid_msgs::SolverStats stats;
  // The instruments (scene keys regions, probes), measured when the frame was taken; empty for a
  // scene without them.
  std::vector<fluid_msgs::RegionState> regions;  // per region, in the scene's order
  fluid_msgs::ProbeArray probes;
  bool spill_valid = false;  // the scene has a spill key
  fluid_msgs::Spill spill;
  fluid_msgs::SinkArray sinks;  // what each sink drained so far; no sinks for a scene without any
};

/// The wrenches published: per body, the mean over a window of simulated time (body frame). One
/// step's pressure force jitters by about a third of its mean on a submerged body, so a message
/// that averaged only the few steps since the last one (a node running fast, publishing often)
/// was not a force a controller could use; the window (`~wrench_window`, s) makes each message
/// the mean over the same span of simulated time at any real-time factor and publish rate. Each
/// step's wrench acts over its dt: the mean is time-weighted, and the oldest step in the window
/// counts for the part of its dt inside it (a boxcar filter in simulated time). A message never
/// averages less than the steps since the previous one, so a window shorter than the frame
/// interval (0 included) gives the mean since the last message.
class WrenchMeans
{
public:
  /// Forgets every step; `bodies` bodies from now on.
  void reset(std::size_t bodies);

  /// The window, s of simulated time (>= 0); takes effect at the next message.
  void setWindow(double seconds)
  {
    window_ = seconds;
  }
  double window() const
  {
    return window_;
  }

  /// Adds the wrenches of the step of length `dt` (s) just taken by `sim`.
  void add(const Simulation& sim, double dt);
  /// The same with the step's wrenches given: per body, force (N) and torque (N m) in the body
  /// frame and the largest boundary pressure (Pa); bodies beyond the vectors' sizes count as zero.
  void add(double dt, const std::vector<Vec3d>& force, const std::vector<Vec3d>& torque,
           const std::vector<double>& max_pressure);

  /// The means as messages, one per body of `sim` (the last step's wrench if no step was added
  /// since the reset).
  void take(const Simulation& sim, std::vector<fluid_msgs::ContactWrench>& out);

  /// Steps held (for tests: older steps than the window needs are dropped).
  std::size_t heldSteps() const
  {
    return steps_.size();
  }

private:
  struct Step
  {
    double dt = 0.0;                   // s
    std::vector<Vec3d> force, torque;  // N, N m, body frame, per body
    std::vector<double> max_pressure;  // Pa, per body
  };
  void dropOld();

  double window_ = 0.0;  // s of simulated time
  std::size_t bodies_ = 0;
  std::deque<Step> steps_;      // oldest first
  double held_time_ = 0.0;      // s, sum of steps_' dt
  std::size_t since_take_ = 0;  // steps added since the last message (always kept)
};

class Publishers
{
public:
  /// Clouds are in opt.fixed_frame. `opt` is read once by the node before any call below and
  /// must outlive this object.
  explicit Publishers(const NodeOptions& opt);
  /// Stops and joins the publisher thread (a joinable thread must not be destroyed).
  ~Publishers();
  Publishers(const Publishers&) = delete;
  Publishers& operator=(const Publishers&) = delete;

  /// Called once from the publisher thread if something thrown there ended it (after it was
  /// logged with ROS_FATAL), with the logged message.
  void onFailure(std::function<void(const std::string&)> callback)
  {
    on_failure_ = std::move(callback);
  }

  /// Advertises the topics in `nh` (the node's namespace, so that they are remapped as users
  /// expect), with one wrench topic per body, one regions/<name> topic per region of the scene
  /// and, for a scene with probes or a spill key, the probes and spill topics, free_bodies for a scene with free
  /// bodies, and publishes the frames of the scene bodies that do not move on /tf_static (their poses in `sim`).
  /// Moving scene bodies and free bodies (scene bodies or links) go on /tf with each frame. `surface` is advertised
  /// whatever ~surface_rate (see SurfacePublisher).
  void advertise(ros::NodeHandle& nh, const std::vector<BodyTopic>& bodies, const Simulation& sim);

  /// Most points in the particles cloud (0 = all); may change while running.
  void setMaxPoints(std::size_t max_points)
  {
    max_points_ = max_points;
  }

  /// Free-surface meshes per second (Hz; 0 = off); may change while running.
  void setSurfaceRate(double hz)
  {
    surface_.setRate(hz);
  }

  /// The frame the solver thread fills (its boundary_valid is false: set it with the cloud).
  Frame& back()
  {
    return back_;
  }

  /// Hands the filled back() to the publisher thread, replacing a frame it has not taken yet.
  void handOver();

  /// Publishes `stats` at once, from the calling thread (stats while paused).
  void publishStats(const fluid_msgs::SolverStats& stats)
  {
    pub_stats_.publish(stats);
  }

  /// Starts the publisher thread and the surface thread.
  void start();
  /// Tells the publisher thread to end once it has no frame left, the surface thread after the
  /// surface it is making.
  void requestStop();
  /// Waits for both threads to end (after requestStop, once no more frames come).
  void join();

private:
  void run();

  const NodeOptions& opt_;
  std::function<void(const std::string&)> on_failure_;
  std::atomic<std::size_t> max_points_{0};
  ros::Publisher pub_particles_, pub_boundary_, pub_wrenches_, pub_stats_;
  std::vector<ros::Publisher> pub_link_wrench_;  // per body, wrench/<name>
  std::vector<ros::Publisher> pub_regions_;      // per region, regions/<name>
  ros::Publisher pub_probes_;                    // probes, for a scene with probes
  ros::Publisher pub_spill_;                     // spill, for a scene with a spill key
  ros::Publisher pub_sinks_;                     // sinks, for a scene with sinks
  ros::Publisher pub_free_;                      // free_bodies, for a scene with free bodies
  std::vector<BodyTopic> bodies_;                // per body: topic and wrench frame
  std::unique_ptr<tf2_ros::TransformBroadcaster> tf_;
  std::unique_ptr<tf2_ros::StaticTransformBroadcaster> tf_static_;
  SurfacePublisher surface_{opt_};  // `surface`, offered the positions of every frame published

  // The solver fills `back_` and swaps it with `pending_`; the publisher swaps `pending_` with
  // `front_` and publishes from it.
  std::mutex mutex_;
  std::condition_variable cv_;
  Frame back_, pending_, front_;
  bool frame_ready_ = false;
  std::atomic<bool> stopping_{false};
  std::thread thread_;
};

}  // namespace ros_bridge
}  // namespace fluid_sim
