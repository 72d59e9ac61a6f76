#pragma once
// Names the node gives its bodies in ROS: the topic of each body's wrench (wrench/<name>, made a
// valid ROS name) and the tf frame its wrench is expressed in (a URDF link's own frame; for a
// scene body, a frame the node publishes itself).

#include <set>
#include <string>
#include <vector>

#include "fluid_sim/core/simulation.h"

namespace fluid_sim
{
namespace ros_bridge
{
/// Scene bodies (the scene's own boundaries, not tf frames) get a tf frame of this prefix and
/// their name, child of the fixed frame, which the node publishes: the tank `tank` is
/// `fluid_sim/tank`.
constexpr const char* kSceneBodyFramePrefix = "fluid_sim/";

/// `name` as a ROS base name: every character other than an ASCII letter, digit or '_' becomes
/// '_' (a multi-byte UTF-8 character becomes one '_'), and a leading '_' is added when the
/// result does not start with a letter ("my link" -> "my_link", "a-b" -> "a_b",
/// "2arm" -> "_2arm", "" -> "_"). A name that is already valid is returned unchanged.
std::string rosBaseName(const std::string& name);

/// How the node publishes one body of the simulation.
struct BodyTopic
{
  std::string name;         // the body's name (URDF link or scene body)
  std::string topic;        // its wrench topic, relative to the node's namespace: wrench/<rosBaseName(name)>
  std::string frame;        // tf frame of its wrench: the link, or kSceneBodyFramePrefix + name
  bool scene_body = false;  // not posed from tf: the node publishes `frame` itself
  bool moving = false;      // a scene body with scripted motion or a free body (its frame goes on /tf every frame)
  bool free = false;        // a free body (BodyInfo::free): it is on the free_bodies topic
};

/// One BodyTopic per body of `sim`, in body order. `free_links`: the URDF links that are free
/// bodies (~free_links); the simulation moves them, so the node publishes their frames itself,
/// under the link's own name (a scene body's is kSceneBodyFramePrefix + name). Throws
/// StartupError naming both bodies when two names give the same topic (e.g. "a-b" and "a b").
std::vector<BodyTopic> bodyTopics(const Simulation& sim, const std::set<std::string>& free_links = {});

}  // namespace ros_bridge
}  // namespace fluid_sim
