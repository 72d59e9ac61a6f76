#pragma once
// A scratch directory for one test, removed with everything in it when the test ends.

#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
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

/// Exit code and output of one fluid_sim_run invocation.
struct RunResult
{
  int exit_code = -1;
  std::string out;  // stdout
  std::string err;  // stderr
};

#ifdef FLUID_SIM_RUN
/// Runs "cd dir && [env] fluid_sim_run <args>" (env: e.g. "ROS_PACKAGE_PATH='...' ") and collects
/// its exit code and output.
inline RunResult runRunner(const TempDir& dir, const std::string& args, const std::string& env = "")
{
  const std::string command =
      "cd '" + dir.path().string() + "' && " + env + "'" FLUID_SIM_RUN "' " + args + " > run.stdout 2> run.stderr";
  const int status = std::system(command.c_str());
  RunResult r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = readFile(dir.file("run.stdout"));
  r.err = readFile(dir.file("run.stderr"));
  return r;
}
#endif

}  // namespace test
}  // namespace fluid_sim
