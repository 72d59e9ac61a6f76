#pragma once
// The runner's --set key.path=value overrides of a scene: parsing them, applying them to the
// scene's YAML tree before the schema reads it, and naming the override behind an error. The tree
// is read by the scene schema (scene_loader.cpp) afterwards, so an override meets the same checks
// as the file. Uses yaml-cpp types: include this header only where yaml-cpp is linked.

#include <yaml-cpp/yaml.h>

#include <string>
#include <vector>

namespace fluid_sim
{
namespace io
{
/// One --set key.path=value.
struct SceneOverride
{
  std::string text;  // as given
  std::string key;   // "boundaries[1].sphere.radius"
  YAML::Node value;  // parsed as YAML, without line marks (messages cite no scene line for it)
};

/// Parses "key.path=value". Throws ConfigError for a text without "key=" or a value that is not
/// YAML.
SceneOverride parseOverride(const std::string& text);

/// Sets o.value at o.key in the tree, creating missing map keys (the schema then rejects unknown
/// ones, as in the file). List indices must exist. Setting time_step.fixed drops
/// time_step.cfl/min/max; setting time_step.cfl drops time_step.fixed. Throws ConfigError for a
/// malformed key path ("a.b[1].c" expected), a path through a value that is not a map or a list,
/// and an index out of range.
void applyOverride(YAML::Node& root, const SceneOverride& o);

/// " (after --set <text>)" for the last of `applied` that set `key`, a key above it or a key below
/// it; "" if none did.
std::string overrideNote(const std::vector<SceneOverride>& applied, const std::string& key);

}  // namespace io
}  // namespace fluid_sim
