// Every input the fuzz harnesses found a crash, hang or oversized allocation with (test/fuzz/
// regressions/<harness>/, minimised), fed through the same entry point as the harness
// (test/fuzz/fuzz_targets.h), in the regular build. Each must be refused with a ConfigError or
// accepted, never crash or throw anything else. An input with a sidecar "<input>.expected" must
// end the way it says: the error message contains its first line, or, if that line is "accepted",
// the input is accepted.

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>
#include <string>
#include <typeinfo>
#include <vector>

#include "../fuzz/fuzz_targets.h"

namespace fs = std::filesystem;
using fluid_sim::fuzz::runMesh;

namespace
{
using Entry = std::function<std::string(const std::uint8_t*, std::size_t)>;

const std::map<std::string, Entry>& harnesses()
{
  static const std::map<std::string, Entry> map = {
      {"scene", fluid_sim::fuzz::runScene},
      {"urdf", fluid_sim::fuzz::runUrdf},
      {"mesh_stl", [](const std::uint8_t* d, std::size_t n) { return runMesh(d, n, ".stl"); }},
      {"mesh_obj", [](const std::uint8_t* d, std::size_t n) { return runMesh(d, n, ".obj"); }},
      {"mesh_dae", [](const std::uint8_t* d, std::size_t n) { return runMesh(d, n, ".dae"); }},
      {"mesh_ply", [](const std::uint8_t* d, std::size_t n) { return runMesh(d, n, ".ply"); }},
      {"ply_frame", fluid_sim::fuzz::runPlyFrame},
      {"package_xml", fluid_sim::fuzz::runPackageXml},
  };
  return map;
}

std::string readAll(const fs::path& path)
{
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

const fs::path kRegressions = fs::path(FLUID_SIM_SOURCE_DIR) / "test/fuzz/regressions";

/// Runs every input of one harness's folder; returns how many there were.
int replay(const std::string& harness)
{
  const Entry& entry = harnesses().at(harness);
  std::vector<fs::path> inputs;
  for (const auto& item : fs::directory_iterator(kRegressions / harness))
    if (item.path().extension() != ".expected") inputs.push_back(item.path());
  std::sort(inputs.begin(), inputs.end());
  for (const fs::path& input : inputs)
  {
    SCOPED_TRACE(input.string());
    const std::string bytes = readAll(input);
    std::string error;
    try
    {
      error = entry(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
    }
    catch (const std::exception& e)
    {
      ADD_FAILURE() << "threw " << typeid(e).name() << " instead of a ConfigError: " << e.what();
      continue;
    }
    fs::path expected_file = input;
    expected_file += ".expected";
    if (!fs::exists(expected_file)) continue;
    std::string expected = readAll(expected_file);
    expected = expected.substr(0, expected.find('\n'));
    if (expected == "accepted")
      EXPECT_EQ(error, "") << "expected the input to be accepted";
    else
      EXPECT_NE(error.find(expected), std::string::npos)
          << "expected an error containing \"" << expected << "\", got \"" << error << "\"";
  }
  return static_cast<int>(inputs.size());
}
}  // namespace

TEST(FuzzRegressions, EveryHarnessFolderIsKnown)
{
  for (const auto& item : fs::directory_iterator(kRegressions))
    EXPECT_EQ(harnesses().count(item.path().filename().string()), 1u) << item.path();
}

TEST(FuzzRegressions, EveryInputIsRefusedWithANamedErrorOrAccepted)
{
  int inputs = 0;
  for (const auto& item : fs::directory_iterator(kRegressions))
    if (harnesses().count(item.path().filename().string()) == 1) inputs += replay(item.path().filename().string());
  EXPECT_GT(inputs, 0);
}
