#pragma once
// Publishers of the node's topics (particles, boundary_particles, contact_wrenches,
// wrench/<body>, free_bodies, stats, and the scene's instruments: regions/<region>, probes, spill, sinks, emitters) and
// of the scene bodies' and free bodies' tf frames, and their thread. The solver thread fills a Frame between steps and
// hands it over; the publisher thread turns it into messages (through the converter, messages.h). A slow publisher
// drops frames; it never blocks the solver. The free surface (`surface`) is made from the frames' positions in a thread
// of its own (surface_publisher.h), at its own rate.

#include <algorithm>
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
#include "fluid_msgs/EmitterArray.h"
#include "fluid_msgs/FreeBodyArray.h"
#include "fluid_msgs/ProbeArray.h"
#include "fluid_msgs/RegionState.h"
#include "fluid_msgs/SinkArray.h"
#include "fluid_msgs/SolverStats.h"
#include "fluid_msgs/Spill.h"
#include "fluid_sim/core/measurements.h"
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
  // False for the step that went unstable: its clouds and stats go out (to see what blew up), its
  // wrenches, body transforms, free bodies and instrument readings do not (the wrench topics read
  // 1e18 N there, which a controller listening to them alone would have acted on).
  bool valid = true;
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
  fluid_msgs::SinkArray sinks;        // what each sink drained so far; no sinks for a scene without any
  fluid_msgs::EmitterArray emitters;  // what each emitter released so far; none for a scene without any
};

/// The steps a boxcar mean over a window of simulated time uses (WrenchMeans, ProbeMeans). Each
/// step's sample acts over its dt: a mean is time-weighted, and the oldest step in the window
/// counts for the part of its dt inside it. A mean never covers less than the steps since the
/// previous one, so a window shorter than the frame interval (0 included) gives the mean since
/// the last message. Holds only the steps the next mean can need.
template <class Sample>
class StepWindow
{
public:
  /// Forgets every step.
  void clear()
  {
    steps_.clear();
    held_time_ = 0.0;
    since_take_ = 0;
  }
  /// The window, s of simulated time (>= 0); takes effect at the next mean.
  void setWindow(double seconds)
  {
    window_ = seconds;
  }
  double window() const
  {
    return window_;
  }
  /// Steps held.
  std::size_t size() const
  {
    return steps_.size();
  }

  /// The sample of a step of length `dt` (s) just taken.
  void add(double dt, Sample sample)
  {
    steps_.push_back({dt, std::move(sample)});
    held_time_ += dt;
    ++since_take_;
    dropOld();
  }

  /// Calls visit(weight, sample) for every step of the mean, newest first, the weight in s (the
  /// part of the step's dt inside the span averaged); returns their sum, the span covered (0
  /// without steps). The next mean starts from here.
  template <class Visit>
  double take(Visit&& visit)
  {
    // The span averaged: the window, or the steps since the last mean if they cover more.
    double since = 0.0;
    for (std::size_t i = steps_.size() - since_take_; i < steps_.size(); ++i) since += steps_[i].dt;
    const double span = std::max(window_, since);
    double covered = 0.0;  // s
    for (auto it = steps_.rbegin(); it != steps_.rend() && covered < span; ++it)
    {
      const double w = std::min(it->dt, span - covered);
      visit(w, it->sample);
      covered += w;
    }
    since_take_ = 0;
    dropOld();
    return covered;
  }

private:
  struct Step
  {
    double dt = 0.0;  // s
    Sample sample;
  };
  void dropOld()
  {
    // A step is needed while the newer ones cover less than the window, or while it has not been
    // in a mean yet.
    while (steps_.size() > since_take_ && held_time_ - steps_.front().dt >= window_)
    {
      held_time_ -= steps_.front().dt;
      steps_.pop_front();
    }
  }

  double window_ = 0.0;         // s of simulated time
  std::deque<Step> steps_;      // oldest first
  double held_time_ = 0.0;      // s, sum of steps_' dt
  std::size_t since_take_ = 0;  // steps added since the last mean (always kept)
};

/// The wrenches published: per body, the mean over a window of simulated time (body frame). One
/// step's pressure force jitters by about a third of its mean on a submerged body, so a message
/// that averaged only the few steps since the last one (a node running fast, publishing often)
/// was not a force a controller could use; the window (`~wrench_window`, s) makes each message
/// the mean over the same span of simulated time at any real-time factor and publish rate (a
/// StepWindow; the largest boundary pressure is the largest over the span, not a mean).
class WrenchMeans
{
public:
  /// Forgets every step; `bodies` bodies from now on.
  void reset(std::size_t bodies);

  /// The window, s of simulated time (>= 0); takes effect at the next message.
  void setWindow(double seconds)
  {
    steps_.setWindow(seconds);
  }
  double window() const
  {
    return steps_.window();
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
  struct Wrenches
  {
    std::vector<Vec3d> force, torque;  // N, N m, body frame, per body
    std::vector<double> max_pressure;  // Pa, per body
  };

  std::size_t bodies_ = 0;
  StepWindow<Wrenches> steps_;
};

/// The probes published: each reading the mean over a window of simulated time
/// (`~probe_window`, s), as the wrenches are (a StepWindow). One step's pressure at a probe in
/// water that has not come to rest swings by tens of percent from step to step (README,
/// Instruments), so a single step's reading was no figure to act on. Pressure, density,
/// velocity and both supports are time-weighted means of what the probe read each step (a dry
/// step reads pressure and velocity 0); the mean is wet by the wetness rule (core wetness())
/// applied to the mean supports, and a mean that is dry reads pressure and velocity 0, as a dry
/// step does.
class ProbeMeans
{
public:
  /// Forgets every step.
  void reset()
  {
    steps_.clear();
    last_.clear();
  }
  /// The window, s of simulated time (>= 0); takes effect at the next message.
  void setWindow(double seconds)
  {
    steps_.setWindow(seconds);
  }
  double window() const
  {
    return steps_.window();
  }
  /// The probes as read after a step of length `dt` (s), in the scene's order.
  void add(double dt, const std::vector<ProbeMeasurement>& probes);
  /// The means, one per probe (empty if no step was added since the last reset).
  std::vector<ProbeMeasurement> take();
  /// Steps held.
  std::size_t heldSteps() const
  {
    return steps_.size();
  }

private:
  /// What one probe read in one step (56 B; names and positions are kept once, in `last_`).
  struct Reading
  {
    double pressure = 0.0;           // Pa
    double density = 0.0;            // kg/m^3
    Vec3d velocity = Vec3d::Zero();  // m/s
    double fluid_support = 0.0;      // unit-less
    double wall_support = 0.0;       // unit-less
  };
  std::vector<ProbeMeasurement> last_;  // the probes' names and positions (their readings unused)
  StepWindow<std::vector<Reading>> steps_;
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
  ros::Publisher pub_emitters_;                  // emitters, for a scene with emitters
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
