#pragma once
// A scratch directory for one test, removed with everything in it when the test ends.

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

namespace fluid_sim
{
namespace test
{
class TempDir
{
public:
  TempDir()
  {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    const std::string name = std::string("fluid_sim_") + (info ? info->test_suite_name() : "test") + "_" +
                             (info ? info->name() : "dir") + "_" + std::to_string(::getpid());
    path_ = std::filesystem::temp_directory_path() / name;
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~TempDir()
  {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  const std::filesystem::path& path() const
  {
    return path_;
  }
  /// path()/name as a string.
  std::string file(const std::string& name) const
  {
    return (path_ / name).string();
  }
  /// Writes `text` to path()/name and returns that path.
  std::string write(const std::string& name, const std::string& text) const
  {
    std::ofstream(file(name)) << text;
    return file(name);
  }

private:
  std::filesystem::path path_;
};

/// The whole file as a string.
inline std::string readFile(const std::string& path)
{
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

}  // namespace test
}  // namespace fluid_sim
