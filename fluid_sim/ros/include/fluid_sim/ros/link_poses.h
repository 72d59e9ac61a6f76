#pragma once
// tf lookup of link poses: the tf buffer and listener, the wait for every link at start, and
// the robot links as bodies of the simulation, posed from tf before each step.

#include <atomic>
#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <ros/node_handle.h>
#include <ros/time.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include "fluid_sim/core/simulation.h"
#include "fluid_sim/ros/node_parameters.h"

namespace fluid_sim
{
namespace ros_bridge
{
class LinkPoses
{
public:
  /// Poses are looked up in opt.fixed_frame. `opt` is read once by the node before any call
  /// below and must outlive this object.
  explicit LinkPoses(const NodeOptions& opt);

  /// Starts listening to tf (subscribes through `nh`).
  void listen(ros::NodeHandle& nh);

  /// Pose of `link` in the fixed frame at `stamp` (ros::Time(0): the newest); nullopt if tf
  /// cannot give it or gives a NaN or infinite one, with the reason in `why`.
  std::optional<Pose> lookup(const std::string& link, const ros::Time& stamp, std::string* why);

  /// Waits until tf knows every one of `links` in the fixed frame; their poses go into `poses`.
  /// Throws StartupError after opt.tf_wait_timeout s (0 = wait for ever). False if ROS shut
  /// down or `stopping` became true meanwhile. The poses are taken at one instant, returned in
  /// `stamp` (see posesAtOneInstant).
  bool waitFor(const std::vector<std::string>& links, const std::atomic<bool>& stopping,
               std::map<std::string, Pose>& poses, ros::Time& stamp);

  /// The links become bodies of `sim` (looked up by name), last posed at `poses`.
  void attach(const Simulation& sim, const std::vector<std::string>& links, const std::map<std::string, Pose>& poses);

  /// The emitters fixed in a tf frame (scene key emitters[i].frame) become posed from tf, their
  /// nozzles placed at `poses` (frame -> fixed frame) now; a frame missing there is looked up
  /// (newest), else the nozzle stays at its scene pose with a warning.
  void attachEmitters(Simulation& sim, const std::map<std::string, Pose>& poses);

  /// For a rebuild: the poses of every link and emitter frame at one instant (posesAtOneInstant),
  /// returned in `stamp`; where tf cannot give that, each one's newest pose, or its last one where
  /// tf has none, and a zero `stamp`.
  std::map<std::string, Pose> newestPoses(ros::Time& stamp);

  /// Replaces `poses` (one per frame of `frames`, each tf's newest) by the poses at the newest
  /// instant at which tf knows every one of them, the oldest of their newest stamps, and returns
  /// that instant; zero (poses unchanged) when the frames are all static or tf cannot give one of
  /// them there. Why: each frame's newest pose has its own stamp, a few ms (a publisher's period)
  /// before now; the simulation's first step poses the links at the build's instant, so the water
  /// must be placed around the poses of that very instant. With each link's newest pose and now
  /// as their instant, a fast link started off the hole the water was placed around: the demo with
  /// its robot 4 times as fast (scripts/node_speed.py) went NaN in its second step in 3 of 6 starts.
  ros::Time posesAtOneInstant(const std::vector<std::string>& frames, std::map<std::string, Pose>& poses);

  /// The first link whose newest pose in tf is older than `stamp` (tf has not got there yet: its
  /// publisher is late or has stopped), with that pose's stamp in `newest` (zero if tf has no
  /// pose of it at all); "" if every link's pose at `stamp` can come (or can never come: the
  /// instant is older than tf keeps, where poseBodies takes the newest).
  std::string notYetAt(const ros::Time& stamp, ros::Time* newest);
  /// Poses every link body of `sim` for the step starting now. `stamp`: ROS time of the
  /// simulated instant, or ros::Time(0) for the newest poses. `jump`: place without deriving
  /// velocities. A link tf does not know stays where it was (with a throttled warning).
  void poseBodies(Simulation& sim, const ros::Time& stamp, bool jump);

  /// The node's own record of the links' (and emitter frames') poses, for a simulation that falls
  /// far behind ROS time (parameter pose_history). tf keeps 60 s; a simulation that is further
  /// behind would find its links' past poses gone. While the simulation is behind by more than
  /// kHistoryStartLag, this records every frame's pose from `needed` (the instant the links were
  /// last posed at, or will be next) on, every kHistoryInterval of ROS time up to the newest
  /// instant tf knows every frame at, and poseBodies() takes poses at instants it covers from it.
  /// Samples older than `needed` (but the one before it) and than `now` - opt.pose_history are
  /// dropped; the record is cleared once the simulation is within kHistoryStopLag of ROS time.
  /// Nothing is recorded with pose_history 0, or when every frame is static.
  void keepHistory(const ros::Time& needed, const ros::Time& now);

  /// True if the record holds instants on both sides of `stamp` (poseBodies() uses it there).
  bool historyCovers(const ros::Time& stamp) const;

  /// True when there is no link or emitter frame to pose, or tf has every one of them only as
  /// static transforms: their poses hold at any instant, so how far the simulation is behind ROS
  /// time does not matter for posing them. False while a frame is unknown to tf.
  bool posesHoldAtAnyInstant();

  /// The recorded instants, oldest first (zero each when there is no record).
  ros::Time historyBegin() const;
  ros::Time historyEnd() const;

  static constexpr double kHistoryInterval = 0.01;  // s of ROS time between recorded poses
  static constexpr double kHistoryStartLag = 10.0;  // s: recording starts this far behind, well within tf's 60 s
  static constexpr double kHistoryStopLag = 5.0;    // s: the record is cleared once the lag is below this

  /// The tf buffer (tests fill it directly).
  tf2_ros::Buffer& buffer()
  {
    return buffer_;
  }

  /// Number of links posed from tf (emitter frames not counted).
  std::size_t size() const
  {
    return links_.size();
  }

private:
  /// The newest instant tf knows the whole chain fixed frame -> `frame` at (zero: all static);
  /// nullopt when it does not know the chain.
  std::optional<ros::Time> newestStamp(const std::string& frame);

  /// One body the node poses from tf.
  struct LinkBody
  {
    std::string link;
    std::size_t index = 0;  // in the simulation
    Pose last_pose;         // link -> fixed frame (m), last given to the simulation
  };

  /// An emitter whose nozzle is fixed in a tf frame.
  struct EmitterFrame
  {
    std::string frame;
    std::size_t index = 0;  // in the simulation's emitters
    Pose offset;            // nozzle frame -> tf frame (the scene's pose)
    Pose last_pose;         // tf frame -> fixed frame, last used
  };
  void poseEmitter(Simulation& sim, EmitterFrame& ef, const Pose& frame_pose);

  /// The frames of the record, links first, then emitter frames (the order of a sample's poses).
  std::vector<std::string> historyFrames() const;

  /// The pose of frame k of the record at `stamp` (historyCovers(stamp) holds): tf's own
  /// interpolation between the recorded samples on either side (linear translation, slerp).
  Pose historyPose(std::size_t k, const ros::Time& stamp) const;

  /// One sample of the record: every frame's pose at one instant.
  struct HistorySample
  {
    ros::Time stamp;
    std::vector<Pose> poses;  // frame -> fixed frame (m), in historyFrames() order
  };

  const NodeOptions& opt_;
  std::vector<EmitterFrame> emitter_frames_;
  tf2_ros::Buffer buffer_{ros::Duration(60.0)};
  std::unique_ptr<tf2_ros::TransformListener> listener_;
  std::vector<LinkBody> links_;
  std::deque<HistorySample> history_;  // oldest first, kHistoryInterval apart
};

}  // namespace ros_bridge
}  // namespace fluid_sim
