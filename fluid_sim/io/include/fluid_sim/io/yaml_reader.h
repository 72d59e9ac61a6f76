#pragma once
// Strict reading of YAML against a schema, for any schema (the scene file's is in scene_loader.cpp):
// required and optional keys, typed values (numbers, integers, booleans, strings, fixed-length
// lists, 3-vectors, enum names), checks on values (ranges), and rejection of every key the schema
// does not ask for, with the nearest known key as a suggestion ("did you mean 'spacing'?").
//
// Every error is a ConfigError whose key() is the dotted path of the value at fault
// ("boundaries[1].sphere.radius") and whose message ends with " (line N)" when the value was read
// from text (not for values built in code, such as a --set override). The caller names the file
// (SceneError). Uses yaml-cpp types: include this header only where yaml-cpp is linked.

#include <yaml-cpp/yaml.h>

#include <array>
#include <cstddef>
#include <initializer_list>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "fluid_sim/core/types.h"
#include "fluid_sim/io/message_names.h"

namespace fluid_sim
{
namespace io
{
namespace yaml
{
/// A YAML value and its dotted key path ("boundaries[1].sphere.radius"), for messages.
struct Entry
{
  YAML::Node node;
  std::string key;
};

/// "parent.name" ("name" at the top level).
std::string childKey(const std::string& parent, const std::string& name);
/// "parent[index]".
std::string indexKey(const std::string& parent, std::size_t index);

/// " (line N)" for a node read from text (N counts from 1); "" for a node built in code.
std::string lineOf(const YAML::Node& node);

/// What a node holds, for messages: "'text'" for a scalar, "a list of N", "a map" or "nothing".
std::string describe(const YAML::Node& node);

/// Parses YAML text. Throws ConfigError with an empty key and the message "YAML syntax error at
/// line L, column C: <reason>".
YAML::Node parse(const std::string& text);

/// Throws ConfigError(e.key, "expected <expected>, got <describe(e.node)> (line N)").
[[noreturn]] void typeError(const Entry& e, const std::string& expected);

/// A check on a value already read, such as a range: unless `ok`, throws ConfigError(e.key,
/// requirement + " (line N)"), e.g. requirement "must be a whole number >= 1".
void checkValue(const Entry& e, bool ok, const std::string& requirement);

/// A scalar of type T: double ("a number"), int ("an integer"), bool ("true or false") or
/// std::string ("a string"); anything else is a typeError naming what was expected.
template <typename T>
T readScalar(const Entry& e);

/// A list of exactly N scalars of type T; else typeError(e, expected). A bad item is named by its
/// index ("gravity[2]").
template <typename T, std::size_t N>
std::array<T, N> readArray(const Entry& e, const std::string& expected)
{
  if (!e.node.IsSequence() || e.node.size() != N) typeError(e, expected);
  std::array<T, N> out;
  for (std::size_t i = 0; i < N; ++i) out[i] = readScalar<T>({e.node[i], indexKey(e.key, i)});
  return out;
}

/// [x, y, z] ("a 3-vector [x, y, z]").
Vec3d readVec3(const Entry& e);

/// readScalar() or readVec3() into `out`, by the type of `out`.
void readInto(const Entry& e, double& out);
void readInto(const Entry& e, int& out);
void readInto(const Entry& e, bool& out);
void readInto(const Entry& e, std::string& out);
void readInto(const Entry& e, Vec3d& out);

/// One of `values`, written as name_of(value) names it; else ConfigError(e.key, "unknown value
/// '<text>' (expected a, b or c) (line N)").
template <typename E, typename NameOf>
E readEnum(const Entry& e, std::initializer_list<E> values, NameOf name_of)
{
  const std::string name = readScalar<std::string>(e);
  std::vector<std::string> names;
  for (E value : values)
  {
    if (name == name_of(value)) return value;
    names.emplace_back(name_of(value));
  }
  throw ConfigError(e.key, "unknown value '" + name + "' (expected " + joinNames(names, " or ") + ")" + lineOf(e.node));
}

/// Calls f(item) for every item of a list, each named "key[i]"; a null value ("fluid:" with nothing
/// below) is an empty list; anything else is a typeError ("a list").
template <typename F>
void forEachItem(const Entry& e, F&& f)
{
  if (e.node.IsNull()) return;
  if (!e.node.IsSequence()) typeError(e, "a list");
  for (std::size_t i = 0; i < e.node.size(); ++i) f(Entry{e.node[i], indexKey(e.key, i)});
}

/// Reads one YAML map strictly. Every key asked for (through has, get, require or read, present or
/// not) becomes known; finish() rejects any other key, naming it and suggesting the nearest known
/// key. A null value ("solver:" with nothing below) is an empty map. The constructor rejects a
/// value that is not a map, duplicate keys and keys that are not plain names.
class MapReader
{
public:
  explicit MapReader(const Entry& e);

  /// Whether the map has the key `name` (which becomes known).
  bool has(const std::string& name);

  /// The value at `name`, or nothing if the key is absent.
  std::optional<Entry> get(const std::string& name);

  /// The value at `name`; ConfigError(key.name, "missing (line of the map)") if it is absent.
  Entry require(const std::string& name);

  /// Reads an optional value with readInto(); leaves `out` (the default) alone if the key is absent.
  template <typename T>
  void read(const std::string& name, T& out)
  {
    if (auto e = get(name)) readInto(*e, out);
  }

  /// Throws for the first key (in file order) that was never asked for: ConfigError(key.name,
  /// "unknown key (did you mean 'x'?) (line N)"), or "(known keys: a, b, c)" when none is close.
  void finish() const;

private:
  const YAML::Node& constNode() const  // const access: operator[] must not insert keys
  {
    return entry_.node;
  }
  std::string hint(const std::string& name) const;

  Entry entry_;
  std::set<std::string> known_;  // keys asked for, sorted
};

}  // namespace yaml
}  // namespace io
}  // namespace fluid_sim
