// --set key.path=value on a scene's YAML tree (see scene_overrides.h).
#include "fluid_sim/io/scene_overrides.h"

#include <optional>

#include "fluid_sim/core/types.h"
#include "fluid_sim/io/yaml_reader.h"

namespace fluid_sim
{
namespace io
{
namespace
{
/// One step of a key path: a map key, or a list index when `index` is set.
struct PathStep
{
  std::string name;
  std::optional<std::size_t> index;
};

std::vector<PathStep> parseKeyPath(const std::string& key)
{
  std::vector<PathStep> steps;
  std::size_t i = 0;
  const auto malformed = [&]() { return ConfigError(key, "malformed key path in --set (expected e.g. a.b[1].c)"); };
  while (i < key.size())
  {
    const std::size_t end = key.find_first_of(".[]", i);
    const std::string name = key.substr(i, end == std::string::npos ? std::string::npos : end - i);
    if (name.empty()) throw malformed();
    steps.push_back({name, std::nullopt});
    i = end == std::string::npos ? key.size() : end;
    while (i < key.size() && key[i] == '[')
    {
      const std::size_t close = key.find(']', i);
      const std::string digits = key.substr(i + 1, close == std::string::npos ? 0 : close - i - 1);
      if (close == std::string::npos || digits.empty() || digits.find_first_not_of("0123456789") != std::string::npos)
        throw malformed();
      // No scene list has a billion entries; a longer number would overflow std::stoul (which
      // throws std::out_of_range, not a ConfigError).
      if (digits.size() > 9) throw ConfigError(key, "list index " + digits + " in --set is out of range");
      steps.push_back({"", std::stoul(digits)});
      i = close + 1;
    }
    if (i < key.size())
    {
      if (key[i] != '.' || i + 1 == key.size()) throw malformed();
      ++i;
    }
  }
  if (steps.empty()) throw malformed();
  return steps;
}

/// A deep copy built node by node: the copy carries no marks, so messages do not cite the line
/// of the --set value as if it were a line of the scene file.
YAML::Node copyWithoutMarks(const YAML::Node& node)
{
  switch (node.Type())
  {
    case YAML::NodeType::Scalar:
      return YAML::Node(node.Scalar());
    case YAML::NodeType::Sequence:
    {
      YAML::Node out(YAML::NodeType::Sequence);
      for (const auto& item : node) out.push_back(copyWithoutMarks(item));
      return out;
    }
    case YAML::NodeType::Map:
    {
      YAML::Node out(YAML::NodeType::Map);
      for (const auto& item : node) out[copyWithoutMarks(item.first)] = copyWithoutMarks(item.second);
      return out;
    }
    default:
      return YAML::Node(YAML::NodeType::Null);
  }
}

}  // namespace

SceneOverride parseOverride(const std::string& text)
{
  const std::size_t eq = text.find('=');
  if (eq == std::string::npos || eq == 0) throw ConfigError("", "--set '" + text + "': expected key.path=value");
  SceneOverride o{text, text.substr(0, eq), {}};
  try
  {
    o.value = copyWithoutMarks(YAML::Load(text.substr(eq + 1)));
  }
  catch (const YAML::Exception& ex)
  {
    throw ConfigError(o.key, "cannot parse the value of --set " + text + ": " + ex.msg);
  }
  return o;
}

void applyOverride(YAML::Node& root, const SceneOverride& o)
{
  const std::vector<PathStep> steps = parseKeyPath(o.key);
  YAML::Node node = root;  // a handle into the tree; reset() moves it, operator= would assign
  std::string path;
  for (std::size_t i = 0; i < steps.size(); ++i)
  {
    const PathStep& step = steps[i];
    YAML::Node child;
    if (!step.index)
    {
      if (node.IsDefined() && !node.IsMap() && !node.IsNull())  // undefined: a key just created
        throw ConfigError(path, "is " + yaml::describe(node) + ", not a map; cannot set " + o.key);
      path = yaml::childKey(path, step.name);
      child.reset(node[step.name]);
    }
    else
    {
      if (!node.IsSequence())
        throw ConfigError(path,
                          (node.IsDefined() ? "is " + yaml::describe(node) + ", not a list" : "is not in the scene") +
                              "; cannot set " + o.key);
      path = yaml::indexKey(path, *step.index);
      if (*step.index >= node.size())
        throw ConfigError(path, "index out of range (the list has " + std::to_string(node.size()) + " entries)");
      child.reset(node[*step.index]);
    }
    if (i + 1 < steps.size())
    {
      node.reset(child);
      continue;
    }
    child = o.value;
    // A time step is either fixed or adaptive: setting one mode drops the other's keys.
    if (o.key == "time_step.fixed")
      for (const char* name : {"cfl", "min", "max"}) node.remove(name);
    else if (o.key == "time_step.cfl")
      node.remove("fixed");
  }
}

std::string overrideNote(const std::vector<SceneOverride>& applied, const std::string& key)
{
  const auto within = [](const std::string& inner, const std::string& outer) {
    return inner.compare(0, outer.size(), outer) == 0 &&
           (inner.size() == outer.size() || inner[outer.size()] == '.' || inner[outer.size()] == '[');
  };
  for (auto it = applied.rbegin(); it != applied.rend(); ++it)
    if (!key.empty() && (within(key, it->key) || within(it->key, key))) return " (after --set " + it->text + ")";
  return "";
}

}  // namespace io
}  // namespace fluid_sim
