// The strict YAML reader on its own, with a small made-up schema (not the scene's): unknown keys
// and their suggestions, value types, checks on values, enum names, and the dotted keys and line
// numbers in the messages.
#include "fluid_sim/io/yaml_reader.h"

#include <gtest/gtest.h>

#include <string>

#include "fluid_sim/io/message_names.h"

namespace fluid_sim
{
namespace
{
using io::yaml::Entry;
using io::yaml::MapReader;

enum class Colour
{
  Red,
  Green,
  Blue
};

const char* colourName(Colour c)
{
  return c == Colour::Red ? "red" : c == Colour::Green ? "green" : "blue";
}

/// A made-up schema: pump {rate (number, > 0), stages (integer), on (bool), colour, outlet
/// (3-vector), label (string), nozzles (list of {diameter, angle})}.
struct Pump
{
  double rate = 1.0;  // m^3/s
  int stages = 1;
  bool on = false;
  Colour colour = Colour::Red;
  Vec3d outlet = Vec3d::Zero();  // m
  std::string label;
  std::vector<double> nozzle_diameters;  // m
};

Pump readPump(const std::string& text)
{
  const YAML::Node root = io::yaml::parse(text);
  MapReader top({root, ""});
  const Entry pump_entry = top.require("pump");
  top.finish();
  MapReader r(pump_entry);
  Pump p;
  if (auto rate = r.get("rate"))
  {
    p.rate = io::yaml::readScalar<double>(*rate);
    io::yaml::checkValue(*rate, p.rate > 0.0 && p.rate <= 10.0, "must be in (0, 10]");
  }
  r.read("stages", p.stages);
  r.read("on", p.on);
  if (auto colour = r.get("colour"))
    p.colour = io::yaml::readEnum(*colour, {Colour::Red, Colour::Green, Colour::Blue}, colourName);
  r.read("outlet", p.outlet);
  r.read("label", p.label);
  if (auto nozzles = r.get("nozzles"))
    io::yaml::forEachItem(*nozzles, [&](const Entry& item) {
      MapReader n(item);
      double d = 0.0;
      double angle = 0.0;  // rad
      io::yaml::readInto(n.require("diameter"), d);
      n.read("angle", angle);
      n.finish();
      p.nozzle_diameters.push_back(d);
    });
  r.finish();
  return p;
}

/// The error of reading `text`: its key and message ("" and "" if there was none).
struct Error
{
  std::string key;
  std::string message;
};

Error errorOf(const std::string& text)
{
  try
  {
    readPump(text);
  }
  catch (const ConfigError& e)
  {
    return {e.key(), e.message()};
  }
  return {};
}

TEST(YamlReader, ReadsEveryTypeAndKeepsDefaults)
{
  const Pump p = readPump(R"yaml(
pump:
  rate: 2.5
  stages: 3
  on: true
  colour: blue
  outlet: [1, 2, 3.5]
  label: main
  nozzles:
    - diameter: 0.01
    - {diameter: 0.02}
)yaml");
  EXPECT_DOUBLE_EQ(p.rate, 2.5);
  EXPECT_EQ(p.stages, 3);
  EXPECT_TRUE(p.on);
  EXPECT_EQ(p.colour, Colour::Blue);
  EXPECT_TRUE(p.outlet.isApprox(Vec3d(1, 2, 3.5)));
  EXPECT_EQ(p.label, "main");
  ASSERT_EQ(p.nozzle_diameters.size(), 2u);
  EXPECT_DOUBLE_EQ(p.nozzle_diameters[1], 0.02);

  const Pump defaults = readPump("pump:\n");  // a null map is an empty one
  EXPECT_DOUBLE_EQ(defaults.rate, 1.0);
  EXPECT_EQ(defaults.stages, 1);
  EXPECT_TRUE(defaults.nozzle_diameters.empty());
}

TEST(YamlReader, UnknownKeySuggestsTheNearestKnownOne)
{
  const Error e = errorOf("pump:\n  rate: 2\n  stagse: 2\n");
  EXPECT_EQ(e.key, "pump.stagse");
  EXPECT_EQ(e.message, "unknown key (did you mean 'stages'?) (line 3)");

  const Error top = errorOf("pump: {}\npumps: 1\n");
  EXPECT_EQ(top.key, "pumps");
  EXPECT_EQ(top.message, "unknown key (did you mean 'pump'?) (line 2)");
}

TEST(YamlReader, UnknownKeyFarFromEveryKnownOneListsThem)
{
  const Error e = errorOf("pump:\n  impeller: 4\n");
  EXPECT_EQ(e.key, "pump.impeller");
  EXPECT_EQ(e.message, "unknown key (known keys: colour, label, nozzles, on, outlet, rate, stages) (line 2)");
}

TEST(YamlReader, UnknownKeyInAListItemIsNamedByIndex)
{
  const Error e = errorOf("pump:\n  nozzles:\n    - diameter: 0.01\n    - {diameter: 0.02, angel: 0.1}\n");
  EXPECT_EQ(e.key, "pump.nozzles[1].angel");
  EXPECT_EQ(e.message, "unknown key (did you mean 'angle'?) (line 4)");
}

TEST(YamlReader, WrongTypeNamesWhatWasExpectedAndWhatCame)
{
  EXPECT_EQ(errorOf("pump:\n  rate: fast\n").message, "expected a number, got 'fast' (line 2)");
  EXPECT_EQ(errorOf("pump:\n  stages: 2.5\n").message, "expected an integer, got '2.5' (line 2)");
  EXPECT_EQ(errorOf("pump:\n  on: maybe\n").message, "expected true or false, got 'maybe' (line 2)");
  EXPECT_EQ(errorOf("pump:\n  label: [a, b]\n").message, "expected a string, got a list of 2 (line 2)");
  EXPECT_EQ(errorOf("pump:\n  outlet: [1, 2]\n").message, "expected a 3-vector [x, y, z], got a list of 2 (line 2)");
  EXPECT_EQ(errorOf("pump: 3\n").message, "expected a map, got '3' (line 1)");
  EXPECT_EQ(errorOf("pump:\n  nozzles: {diameter: 1}\n").message, "expected a list, got a map (line 2)");

  const Error item = errorOf("pump:\n  outlet: [1, 2, up]\n");
  EXPECT_EQ(item.key, "pump.outlet[2]");
  EXPECT_EQ(item.message, "expected a number, got 'up' (line 2)");
}

TEST(YamlReader, OutOfRangeValueFailsItsCheck)
{
  const Error zero = errorOf("pump:\n  stages: 2\n  rate: 0\n");
  EXPECT_EQ(zero.key, "pump.rate");
  EXPECT_EQ(zero.message, "must be in (0, 10] (line 3)");
  EXPECT_EQ(errorOf("pump: {rate: 11}\n").message, "must be in (0, 10] (line 1)");
  EXPECT_EQ(errorOf("pump: {rate: 10}\n").key, "");  // the bound itself is in range
}

TEST(YamlReader, EnumNamesTheValuesItKnows)
{
  const Error e = errorOf("pump:\n\n  colour: purple\n");
  EXPECT_EQ(e.key, "pump.colour");
  EXPECT_EQ(e.message, "unknown value 'purple' (expected red, green or blue) (line 3)");
}

TEST(YamlReader, MissingRequiredKeyCitesTheLineOfItsMap)
{
  const Error e = errorOf("pump:\n  nozzles:\n    - {}\n");
  EXPECT_EQ(e.key, "pump.nozzles[0].diameter");
  EXPECT_EQ(e.message, "missing (line 3)");
  EXPECT_EQ(errorOf("other: 1\n").key, "pump");
}

TEST(YamlReader, DuplicateAndNonScalarKeys)
{
  const Error dup = errorOf("pump:\n  rate: 1\n  rate: 2\n");
  EXPECT_EQ(dup.key, "pump.rate");
  EXPECT_EQ(dup.message, "duplicate key (line 3)");
  const Error complex = errorOf("pump:\n  [a, b]: 1\n");
  EXPECT_EQ(complex.key, "pump");
  EXPECT_EQ(complex.message, "keys must be plain names (line 2)");
}

TEST(YamlReader, SyntaxErrorNamesLineAndColumn)
{
  const Error e = errorOf("pump:\n  outlet: [1, 2, 3\n  rate: 1\n");
  EXPECT_EQ(e.key, "");
  EXPECT_EQ(e.message.rfind("YAML syntax error at line ", 0), 0u) << e.message;
  EXPECT_NE(e.message.find(", column "), std::string::npos) << e.message;
}

TEST(YamlReader, NodesBuiltInCodeHaveNoLine)
{
  YAML::Node built(YAML::NodeType::Map);
  built["rate"] = "slow";
  MapReader r({built, "pump"});
  try
  {
    double rate = 0.0;
    r.read("rate", rate);
    FAIL() << "no error";
  }
  catch (const ConfigError& e)
  {
    EXPECT_EQ(e.key(), "pump.rate");
    EXPECT_EQ(e.message(), "expected a number, got 'slow'");
  }
}

TEST(MessageNames, JoinAndClosest)
{
  EXPECT_EQ(io::joinNames({"a", "b", "c"}, " or "), "a, b or c");
  EXPECT_EQ(io::joinNames({"a", "b", "c"}), "a, b, c");
  EXPECT_EQ(io::joinNames({"a"}, " or "), "a");
  EXPECT_EQ(io::joinNames({}, ", ", "none"), "none");
  EXPECT_EQ(io::editDistance("spacin", "spacing"), 1u);
  EXPECT_EQ(io::editDistance("", "abc"), 3u);
  EXPECT_EQ(io::closestName("densty", {"density", "destiny"}, 3), "density");
  EXPECT_EQ(io::closestName("xyz", {"density"}, 3), "");
}

}  // namespace
}  // namespace fluid_sim
