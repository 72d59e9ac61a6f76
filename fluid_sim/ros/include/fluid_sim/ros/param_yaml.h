#pragma once
// The node's private parameters (a scene loaded with <rosparam>) back into YAML text, so that
// the one strict scene loader (io/scene_loader) checks them exactly as it checks a scene file.

#include <set>
#include <string>

#include <xmlrpcpp/XmlRpcValue.h>

namespace fluid_sim
{
namespace ros_bridge
{
/// YAML flow text for a parameter value: structs as {k: v}, arrays as [a, b], strings quoted,
/// doubles with full precision. Throws std::invalid_argument for base64 and date-time values
/// (no scene key takes them).
std::string toYaml(const XmlRpc::XmlRpcValue& value);

/// The scene part of a private-parameter struct: every member whose name is not in `skip` (the
/// node's own settings), as a YAML mapping, one key per line.
std::string sceneYaml(const XmlRpc::XmlRpcValue& params, const std::set<std::string>& skip);

}  // namespace ros_bridge
}  // namespace fluid_sim
