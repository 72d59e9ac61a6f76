#include "fluid_sim/ros/link_poses.h"

#include <algorithm>
#include <sstream>

#include <ros/console.h>
#include <tf2/exceptions.h>

#include "fluid_sim/ros/fluid_sim_node.h"
#include "fluid_sim/ros/messages.h"

namespace fluid_sim
{
namespace ros_bridge
{
LinkPoses::LinkPoses(const NodeOptions& opt) : opt_(opt) {}

void LinkPoses::listen(ros::NodeHandle& nh)
{
  listener_ = std::make_unique<tf2_ros::TransformListener>(buffer_, nh);
}

std::optional<Pose> LinkPoses::lookup(const std::string& link, const ros::Time& stamp, std::string* why)
{
  try
  {
    const Pose pose = toPose(buffer_.lookupTransform(opt_.fixed_frame, link, stamp).transform);
    // tf2 refuses NaN on input but not infinity, and interpolating infinities gives NaN: such a
    // pose counts as none (the link keeps its last good one).
    if (!pose.translation.allFinite() || !pose.rotation.coeffs().allFinite())
    {
      if (why)
      {
        std::ostringstream os;
        os << "the transform is not finite (translation [" << pose.translation.x() << ", " << pose.translation.y()
           << ", " << pose.translation.z() << "], rotation (w " << pose.rotation.w() << ", x " << pose.rotation.x()
           << ", y " << pose.rotation.y() << ", z " << pose.rotation.z() << "))";
        *why = os.str();
      }
      return std::nullopt;
    }
    return pose;
  }
  catch (const tf2::TransformException& e)
  {
    if (why) *why = e.what();
    return std::nullopt;
  }
}

bool LinkPoses::waitFor(const std::vector<std::string>& links, const std::atomic<bool>& stopping,
                        std::map<std::string, Pose>& poses, ros::Time& stamp)
{
  stamp = ros::Time();
  const ros::WallTime start = ros::WallTime::now();
  ros::WallTime last_note = start;
  bool noted = false;
  while (ros::ok() && !stopping)
  {
    std::vector<std::string> missing;
    std::string why;
    for (const std::string& link : links)
    {
      if (poses.count(link)) continue;
      if (auto p = lookup(link, ros::Time(0), &why))
        poses[link] = *p;
      else
        missing.push_back(link);
    }
    if (missing.empty())
    {
      if (noted) ROS_INFO("tf now has every link; starting");
      stamp = posesAtOneInstant(links, poses);
      return true;
    }
    const double waited = (ros::WallTime::now() - start).toSec();
    std::ostringstream list;
    for (std::size_t k = 0; k < missing.size(); ++k) list << (k ? ", " : "") << missing[k];
    if (opt_.tf_wait_timeout > 0.0 && waited > opt_.tf_wait_timeout)
      throw StartupError("tf: no transform from '" + opt_.fixed_frame + "' to link(s) " + list.str() + " after " +
                         std::to_string(opt_.tf_wait_timeout) + " s (~tf_wait_timeout); last error: " + why);
    if (!noted || (ros::WallTime::now() - last_note).toSec() > 5.0)
    {
      ROS_WARN(
          "waiting for tf: no transform yet from fixed frame '%s' to link(s) %s (is robot_state_publisher "
          "running and the fixed frame connected to the robot?) [%s]",
          opt_.fixed_frame.c_str(), list.str().c_str(), why.c_str());
      last_note = ros::WallTime::now();
      noted = true;
    }
    ros::WallDuration(0.05).sleep();
  }
  return false;
}

void LinkPoses::attach(const Simulation& sim, const std::vector<std::string>& links,
                       const std::map<std::string, Pose>& poses)
{
  links_.clear();
  history_.clear();  // a new build: a new time line
  for (const std::string& link : links)
  {
    LinkBody lb;
    lb.link = link;
    lb.index = sim.bodyIndex(link);
    lb.last_pose = poses.at(link);
    links_.push_back(lb);
  }
}

void LinkPoses::poseEmitter(Simulation& sim, EmitterFrame& ef, const Pose& frame_pose)
{
  // Nozzle -> fixed frame = (tf frame -> fixed frame) * (nozzle -> tf frame).
  Pose world;
  world.rotation = frame_pose.rotation * ef.offset.rotation;
  world.translation = frame_pose.apply(ef.offset.translation);
  sim.setEmitterPose(ef.index, world);
  ef.last_pose = frame_pose;
}

void LinkPoses::attachEmitters(Simulation& sim, const std::map<std::string, Pose>& poses)
{
  emitter_frames_.clear();
  history_.clear();  // its samples hold one pose per frame
  const std::vector<EmitterConfig>& emitters = sim.scene().emitters;
  for (std::size_t i = 0; i < emitters.size(); ++i)
  {
    if (emitters[i].frame.empty()) continue;
    EmitterFrame ef;
    ef.frame = emitters[i].frame;
    ef.index = i;
    ef.offset = emitters[i].pose;
    std::optional<Pose> p;
    if (auto it = poses.find(ef.frame); it != poses.end()) p = it->second;
    std::string why;
    if (!p) p = lookup(ef.frame, ros::Time(0), &why);
    if (p)
      poseEmitter(sim, ef, *p);
    else
    {
      ROS_WARN("tf: no pose of emitter frame '%s' (%s); emitter '%s' stays at its scene pose until tf has one",
               ef.frame.c_str(), why.c_str(), emitters[i].name.c_str());
      // The scene's pose read as a pose in the fixed frame.
      ef.last_pose = Pose();
      poseEmitter(sim, ef, Pose());
    }
    emitter_frames_.push_back(ef);
  }
}

ros::Time LinkPoses::posesAtOneInstant(const std::vector<std::string>& frames, std::map<std::string, Pose>& poses)
{
  ros::Time common;  // the oldest non-zero newest stamp
  for (const std::string& frame : frames)
  {
    const std::optional<ros::Time> at = newestStamp(frame);
    if (!at) return ros::Time();
    if (!at->isZero() && (common.isZero() || *at < common)) common = *at;
  }
  if (common.isZero()) return common;
  std::map<std::string, Pose> at_common;
  for (const std::string& frame : frames)
  {
    std::optional<Pose> p = lookup(frame, common, nullptr);
    if (!p) return ros::Time();
    at_common[frame] = *p;
  }
  for (auto& [frame, pose] : at_common) poses[frame] = pose;
  return common;
}

std::map<std::string, Pose> LinkPoses::newestPoses(ros::Time& stamp)
{
  std::map<std::string, Pose> poses;
  std::vector<std::string> frames;
  for (const LinkBody& lb : links_)
  {
    std::string why;
    auto p = lookup(lb.link, ros::Time(0), &why);
    poses[lb.link] = p ? *p : lb.last_pose;
    frames.push_back(lb.link);
  }
  for (const EmitterFrame& ef : emitter_frames_)
  {
    std::string why;
    auto p = lookup(ef.frame, ros::Time(0), &why);
    poses[ef.frame] = p ? *p : ef.last_pose;
    frames.push_back(ef.frame);
  }
  stamp = posesAtOneInstant(frames, poses);
  return poses;
}

std::optional<ros::Time> LinkPoses::newestStamp(const std::string& frame)
{
  try
  {
    // The newest instant the whole chain fixed frame -> frame is known at (zero: all static).
    return buffer_.lookupTransform(opt_.fixed_frame, frame, ros::Time(0)).header.stamp;
  }
  catch (const tf2::TransformException&)
  {
    return std::nullopt;
  }
}

std::string LinkPoses::notYetAt(const ros::Time& stamp, ros::Time* newest)
{
  for (const LinkBody& lb : links_)
  {
    const std::optional<ros::Time> at = newestStamp(lb.link);
    if (!at || (!at->isZero() && *at < stamp))
    {
      *newest = at ? *at : ros::Time();
      return lb.link;
    }
  }
  return "";
}

void LinkPoses::poseBodies(Simulation& sim, const ros::Time& stamp, bool jump)
{
  // An instant the node's own record covers is taken from it (keepHistory): tf may no longer
  // hold it.
  const bool recorded = !stamp.isZero() && historyCovers(stamp);
  for (std::size_t k = 0; k < links_.size(); ++k)
  {
    LinkBody& lb = links_[k];
    std::string why;
    std::optional<Pose> p = recorded ? std::optional<Pose>(historyPose(k, stamp)) : lookup(lb.link, stamp, &why);
    if (!p && !stamp.isZero())
    {
      // tf has nothing at that instant (usually: nothing newer yet); take the newest.
      ROS_WARN_THROTTLE(5.0, "tf: no pose of '%s' at %.3f (%s); using the newest one", lb.link.c_str(), stamp.toSec(),
                        why.c_str());
      p = lookup(lb.link, ros::Time(0), &why);
    }
    if (!p)
    {
      ROS_WARN_THROTTLE(5.0, "tf: no pose of '%s' (%s); it stays where it was", lb.link.c_str(), why.c_str());
      p = lb.last_pose;
    }
    // Every link's pose every step, changed or not: the core derives velocities from consecutive
    // poses, so a link that stops has zero velocity at once (a body at rest given the same pose
    // again costs nothing there).
    sim.setBodyPose(lb.index, *p, jump);
    lb.last_pose = *p;
  }
  // Nozzles fixed in tf frames, at the same instant (a nozzle has no velocity of its own to
  // derive: the water leaves at its exit velocity).
  for (std::size_t k = 0; k < emitter_frames_.size(); ++k)
  {
    EmitterFrame& ef = emitter_frames_[k];
    std::string why;
    std::optional<Pose> p =
        recorded ? std::optional<Pose>(historyPose(links_.size() + k, stamp)) : lookup(ef.frame, stamp, &why);
    if (!p && !stamp.isZero()) p = lookup(ef.frame, ros::Time(0), &why);
    if (!p)
    {
      ROS_WARN_THROTTLE(5.0, "tf: no pose of emitter frame '%s' (%s); the nozzle stays where it was", ef.frame.c_str(),
                        why.c_str());
      continue;
    }
    poseEmitter(sim, ef, *p);
  }
}

std::vector<std::string> LinkPoses::historyFrames() const
{
  std::vector<std::string> frames;
  for (const LinkBody& lb : links_) frames.push_back(lb.link);
  for (const EmitterFrame& ef : emitter_frames_) frames.push_back(ef.frame);
  return frames;
}

bool LinkPoses::posesHoldAtAnyInstant()
{
  for (const std::string& frame : historyFrames())
  {
    const std::optional<ros::Time> at = newestStamp(frame);
    if (!at || !at->isZero()) return false;
  }
  return true;
}

void LinkPoses::keepHistory(const ros::Time& needed, const ros::Time& now)
{
  if (opt_.pose_history <= 0.0 || needed.isZero() || now.isZero()) return;
  const double lag = (now - needed).toSec();  // s of ROS time
  if (history_.empty() ? lag < kHistoryStartLag : lag < kHistoryStopLag)
  {
    history_.clear();  // caught up: tf holds what the simulation needs
    return;
  }
  // Drop what the simulation no longer needs: samples before `needed` but the last one before it
  // (an interpolation's left end), and anything older than the record is to keep.
  const ros::Time oldest_kept = now - ros::Duration(std::min(opt_.pose_history, now.toSec()));
  while (history_.size() >= 2 && (history_[1].stamp <= needed || history_[0].stamp < oldest_kept)) history_.pop_front();
  if (history_.size() == 1 && history_[0].stamp < oldest_kept) history_.clear();

  const std::vector<std::string> frames = historyFrames();
  if (frames.empty()) return;
  // Up to the newest instant tf knows every frame at; none when they are all static (their
  // poses hold at any instant, tf keeps them for good).
  ros::Time newest;  // the oldest non-zero newest stamp
  for (const std::string& frame : frames)
  {
    const std::optional<ros::Time> at = newestStamp(frame);
    if (!at) return;  // a frame tf does not know (now): record nothing until it does
    if (!at->isZero() && (newest.isZero() || *at < newest)) newest = *at;
  }
  if (newest.isZero()) return;
  // On a grid of kHistoryInterval from the first recorded instant: from `needed` (no later than
  // what the oldest kept sample may be) when the record is empty, else after its newest sample.
  const ros::Duration interval(kHistoryInterval);
  ros::Time next = history_.empty() ? std::max(needed, oldest_kept) : history_.back().stamp + interval;
  while (next <= newest)
  {
    HistorySample sample;
    sample.stamp = next;
    for (const std::string& frame : frames)
    {
      std::optional<Pose> p = lookup(frame, next, nullptr);
      if (!p)
      {
        // Gone from tf already (the record started, or resumed, too late for this instant) or
        // not finite there: a gap in the record would interpolate across it, so the record
        // restarts from the next instant tf gives every frame at.
        history_.clear();
        break;
      }
      sample.poses.push_back(*p);
    }
    if (sample.poses.size() == frames.size()) history_.push_back(std::move(sample));
    next += interval;
  }
}

bool LinkPoses::historyCovers(const ros::Time& stamp) const
{
  return !history_.empty() && history_.front().stamp <= stamp && stamp <= history_.back().stamp;
}

ros::Time LinkPoses::historyBegin() const
{
  return history_.empty() ? ros::Time() : history_.front().stamp;
}

ros::Time LinkPoses::historyEnd() const
{
  return history_.empty() ? ros::Time() : history_.back().stamp;
}

Pose LinkPoses::historyPose(std::size_t k, const ros::Time& stamp) const
{
  // The first sample after `stamp` (the record is in time order); the one before it is the left
  // end of the interpolation.
  auto after = std::upper_bound(history_.begin(), history_.end(), stamp,
                                [](const ros::Time& t, const HistorySample& s) { return t < s.stamp; });
  if (after == history_.begin()) return history_.front().poses[k];
  if (after == history_.end()) return history_.back().poses[k];
  const HistorySample& a = *(after - 1);
  const HistorySample& b = *after;
  const double u = (stamp - a.stamp).toSec() / (b.stamp - a.stamp).toSec();
  Pose pose;
  pose.translation = (1.0 - u) * a.poses[k].translation + u * b.poses[k].translation;
  pose.rotation = a.poses[k].rotation.slerp(u, b.poses[k].rotation);
  return pose;
}

}  // namespace ros_bridge
}  // namespace fluid_sim
