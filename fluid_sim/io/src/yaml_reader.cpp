// Strict YAML reading for any schema: typed values, key checks and their messages (see yaml_reader.h).
#include "fluid_sim/io/yaml_reader.h"

namespace fluid_sim
{
namespace io
{
namespace yaml
{
std::string childKey(const std::string& parent, const std::string& name)
{
  return parent.empty() ? name : parent + "." + name;
}

std::string indexKey(const std::string& parent, std::size_t index)
{
  return parent + "[" + std::to_string(index) + "]";
}

std::string lineOf(const YAML::Node& node)
{
  const YAML::Mark mark = node.Mark();
  return mark.is_null() ? std::string() : " (line " + std::to_string(mark.line + 1) + ")";
}

std::string describe(const YAML::Node& node)
{
  switch (node.Type())
  {
    case YAML::NodeType::Scalar:
      return "'" + node.Scalar() + "'";
    case YAML::NodeType::Sequence:
      return "a list of " + std::to_string(node.size());
    case YAML::NodeType::Map:
      return "a map";
    default:
      return "nothing";
  }
}

YAML::Node parse(const std::string& text)
{
  try
  {
    return YAML::Load(text);
  }
  catch (const YAML::ParserException& ex)
  {
    throw ConfigError("", "YAML syntax error at line " + std::to_string(ex.mark.line + 1) + ", column " +
                              std::to_string(ex.mark.column + 1) + ": " + ex.msg);
  }
}

void typeError(const Entry& e, const std::string& expected)
{
  throw ConfigError(e.key, "expected " + expected + ", got " + describe(e.node) + lineOf(e.node));
}

void checkValue(const Entry& e, bool ok, const std::string& requirement)
{
  if (!ok) throw ConfigError(e.key, requirement + lineOf(e.node));
}

// ------------------------------------------------------------------------------------ values

namespace
{
template <typename T>
const char* expectedName();
template <>
const char* expectedName<double>()
{
  return "a number";
}
template <>
const char* expectedName<int>()
{
  return "an integer";
}
template <>
const char* expectedName<bool>()
{
  return "true or false";
}
template <>
const char* expectedName<std::string>()
{
  return "a string";
}
}  // namespace

template <typename T>
T readScalar(const Entry& e)
{
  if (e.node.IsScalar())
  {
    try
    {
      return e.node.as<T>();
    }
    catch (const YAML::BadConversion&)
    {
    }
  }
  typeError(e, expectedName<T>());
}

template double readScalar<double>(const Entry&);
template int readScalar<int>(const Entry&);
template bool readScalar<bool>(const Entry&);
template std::string readScalar<std::string>(const Entry&);

Vec3d readVec3(const Entry& e)
{
  const auto a = readArray<double, 3>(e, "a 3-vector [x, y, z]");
  return Vec3d(a[0], a[1], a[2]);
}

void readInto(const Entry& e, double& out)
{
  out = readScalar<double>(e);
}
void readInto(const Entry& e, int& out)
{
  out = readScalar<int>(e);
}
void readInto(const Entry& e, bool& out)
{
  out = readScalar<bool>(e);
}
void readInto(const Entry& e, std::string& out)
{
  out = readScalar<std::string>(e);
}
void readInto(const Entry& e, Vec3d& out)
{
  out = readVec3(e);
}

// ------------------------------------------------------------------------------------ maps

MapReader::MapReader(const Entry& e) : entry_(e)
{
  if (entry_.node.IsNull()) return;
  if (!entry_.node.IsMap()) typeError(entry_, "a map");
  std::set<std::string> seen;
  for (const auto& item : entry_.node)
  {
    if (!item.first.IsScalar()) throw ConfigError(entry_.key, "keys must be plain names" + lineOf(item.first));
    if (!seen.insert(item.first.Scalar()).second)
      throw ConfigError(childKey(entry_.key, item.first.Scalar()), "duplicate key" + lineOf(item.first));
  }
}

bool MapReader::has(const std::string& name)
{
  known_.insert(name);
  return entry_.node.IsMap() && static_cast<bool>(constNode()[name]);
}

std::optional<Entry> MapReader::get(const std::string& name)
{
  if (!has(name)) return std::nullopt;
  return Entry{constNode()[name], childKey(entry_.key, name)};
}

Entry MapReader::require(const std::string& name)
{
  if (auto e = get(name)) return *e;
  throw ConfigError(childKey(entry_.key, name), "missing" + lineOf(entry_.node));
}

void MapReader::finish() const
{
  if (!entry_.node.IsMap()) return;
  for (const auto& item : entry_.node)
  {
    const std::string name = item.first.Scalar();
    if (known_.count(name) == 0)
      throw ConfigError(childKey(entry_.key, name), "unknown key" + hint(name) + lineOf(item.first));
  }
}

std::string MapReader::hint(const std::string& name) const
{
  const std::vector<std::string> known(known_.begin(), known_.end());
  const std::string best = closestName(name, known, 3);  // suggest only close matches
  if (!best.empty()) return " (did you mean '" + best + "'?)";
  return " (known keys: " + joinNames(known) + ")";
}

}  // namespace yaml
}  // namespace io
}  // namespace fluid_sim
