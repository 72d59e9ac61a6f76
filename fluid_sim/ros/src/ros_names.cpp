#include "fluid_sim/ros/ros_names.h"

#include <map>

#include "fluid_sim/ros/fluid_sim_node.h"

namespace fluid_sim
{
namespace ros_bridge
{
namespace
{
bool asciiLetter(char c)
{
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z');
}
bool asciiDigit(char c)
{
  return c >= '0' && c <= '9';
}
}  // namespace

std::string rosBaseName(const std::string& name)
{
  std::string out;
  out.reserve(name.size() + 1);
  for (const char c : name)
  {
    // UTF-8 continuation bytes (10xxxxxx) belong to the character already replaced.
    if ((static_cast<unsigned char>(c) & 0xC0u) == 0x80u) continue;
    out += (asciiLetter(c) || asciiDigit(c) || c == '_') ? c : '_';
  }
  // roscpp refuses a name whose first character is not a letter (graph resource names).
  if (out.empty() || !asciiLetter(out[0])) out.insert(out.begin(), '_');
  return out;
}

std::vector<BodyTopic> bodyTopics(const Simulation& sim, const std::set<std::string>& free_links)
{
  std::vector<BodyTopic> topics;
  std::map<std::string, std::string> owner;  // topic -> body name
  for (std::size_t k = 0; k < sim.numBodies(); ++k)
  {
    const BodyInfo b = sim.body(k);
    BodyTopic t;
    t.name = b.name;
    t.topic = "wrench/" + rosBaseName(b.name);
    bool from_tf = false;
    for (const BoundaryConfig& c : sim.scene().boundaries)
      if (c.name == b.name) from_tf = c.externally_posed;
    t.scene_body = !from_tf;
    // A free link keeps its link name: it is the robot's frame, only the node moves it now.
    t.frame = from_tf || free_links.count(b.name) ? b.name : kSceneBodyFramePrefix + b.name;
    t.moving = t.scene_body && b.moving;
    t.free = b.free;
    const auto [it, inserted] = owner.emplace(t.topic, b.name);
    if (!inserted)
      throw StartupError(
          "bodies '" + it->second + "' and '" + b.name + "' would both publish their wrench on " + t.topic +
          " (characters other than letters, digits and '_' become '_' in topic names): " + "rename one of them");
    topics.push_back(std::move(t));
  }
  return topics;
}

}  // namespace ros_bridge
}  // namespace fluid_sim
