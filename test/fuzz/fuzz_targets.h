#pragma once
// The parser entry points the fuzz harnesses (test/fuzz/fuzz_*.cpp, clang + libFuzzer) and the
// regression test (test/io/fuzz_regression_test.cpp, the regular build) feed bytes through, so
// that a saved crashing input is replayed through exactly the code that crashed.
//
// Each run*() returns "" for an input that was accepted and the error's what() for one that was
// refused with a ConfigError (the io layer's "clear, named error"). Anything else escaping (another
// exception type, a crash, a sanitizer report, a hang) is a bug the harness reports.
//
// Files: every input is written to a scratch folder made once per process under $TMPDIR (removed
// at exit). The scene and URDF harnesses resolve package:// URIs and relative paths into that
// folder, which holds copies of the repository's meshes and URDFs (meshes/, urdf/) and a particle
// frame (frame.ply), so that the fuzzer reaches mesh, URDF and frame loading through a scene
// without reading anything else; absolute paths in an input are read as given (read only, nothing
// is written outside the scratch folder).

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <system_error>
#include <vector>

#include "fluid_sim/core/types.h"
#include "fluid_sim/io/mesh_loader.h"
#include "fluid_sim/io/ply_reader.h"
#include "fluid_sim/io/resource_resolver.h"
#include "fluid_sim/io/scene_loader.h"
#include "fluid_sim/io/urdf_loader.h"

#ifndef FLUID_SIM_SOURCE_DIR
#error "FLUID_SIM_SOURCE_DIR (the repository root) must be defined"
#endif

namespace fluid_sim
{
namespace fuzz
{
namespace fs = std::filesystem;

/// The per-process scratch folder, made on first use with the repository's meshes and URDFs copied
/// into meshes/ and urdf/ (what package://<any>/meshes/... and relative names resolve to).
class Scratch
{
public:
  static const std::string& dir()
  {
    static Scratch scratch;
    return scratch.dir_;
  }
  ~Scratch()
  {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }

private:
  Scratch()
  {
    const char* tmp = std::getenv("TMPDIR");
    std::string pattern = std::string(tmp && *tmp ? tmp : "/tmp") + "/fluid_sim_fuzz_XXXXXX";
    std::vector<char> buffer(pattern.begin(), pattern.end());
    buffer.push_back('\0');
    if (!mkdtemp(buffer.data())) std::abort();
    dir_ = buffer.data();
    const fs::path source(FLUID_SIM_SOURCE_DIR);
    for (const char* sub : {"meshes", "urdf"}) fs::create_directories(fs::path(dir_) / sub);
    const auto copyAll = [&](const fs::path& from, const char* to, const std::string& ext) {
      std::error_code ec;
      for (const auto& entry : fs::directory_iterator(from, ec))
        if (entry.path().extension() == ext)
          fs::copy_file(entry.path(), fs::path(dir_) / to / entry.path().filename(),
                        fs::copy_options::overwrite_existing, ec);
    };
    copyAll(source / "meshes", "meshes", ".stl");
    copyAll(source / "test/fixtures/fluid_sim_test_pkg/meshes", "meshes", ".stl");
    copyAll(source / "test/fixtures/fluid_sim_test_pkg/meshes", "meshes", ".obj");
    copyAll(source / "test/fixtures/fluid_sim_test_pkg/meshes", "meshes", ".dae");
    copyAll(source / "test/fixtures/fluid_sim_test_pkg/meshes", "meshes", ".ply");
    copyAll(source / "urdf", "urdf", ".urdf");
    copyAll(source / "test/fixtures/fluid_sim_test_pkg/urdf", "urdf", ".urdf");
    // A saved state for `fluid: - particles: {file: frame.ply}`: three particles one spacing apart.
    std::ofstream(fs::path(dir_) / "frame.ply")
        << "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
           "property float vx\nproperty float vy\nproperty float vz\nend_header\n"
           "0 0 0 0 0 0\n0.02 0 0 0 0 -1\n0 0.02 0 0.5 0 0\n";
  }
  std::string dir_;
};

/// Writes `size` bytes to <scratch>/<name> and returns its path.
inline std::string writeInput(const std::string& name, const std::uint8_t* data, std::size_t size)
{
  const std::string path = Scratch::dir() + "/" + name;
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  return path;
}

/// Every package is the scratch folder.
inline io::PackageResolver scratchPackages()
{
  return [](const std::string&) { return Scratch::dir(); };
}

/// A scene: the bytes before the first NUL are the YAML text, the lines after it (split at NUL or
/// newline, at most 8, empty ones skipped) are --set overrides ("key.path=value").
inline std::string runScene(const std::uint8_t* data, std::size_t size)
{
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  const std::size_t split = bytes.find('\0');
  const std::string yaml = bytes.substr(0, split);
  std::vector<std::string> overrides;
  if (split != std::string::npos)
  {
    std::size_t pos = split + 1;
    while (pos <= bytes.size() && overrides.size() < 8)
    {
      std::size_t end = bytes.find_first_of(std::string("\0\n", 2), pos);
      if (end == std::string::npos) end = bytes.size();
      if (end > pos) overrides.push_back(bytes.substr(pos, end - pos));
      pos = end + 1;
    }
  }
  io::SceneLoadOptions options;
  options.packages = scratchPackages();
  options.base_dir = Scratch::dir();
  try
  {
    io::parseScene(yaml, Scratch::dir() + "/fuzz_scene.yaml", overrides, options);
  }
  catch (const ConfigError& e)
  {
    return e.what();
  }
  return "";
}

/// A URDF: parsed, posed at zero joint positions and turned into boundary bodies (mesh files
/// resolved into the scratch folder).
inline std::string runUrdf(const std::uint8_t* data, std::size_t size)
{
  const std::string xml(reinterpret_cast<const char*>(data), size);
  try
  {
    const io::UrdfRobot robot = io::parseUrdf(xml, "fuzz.urdf", Scratch::dir() + "/urdf");
    std::vector<std::string> warnings;
    io::linkPoses(robot, {}, Pose(), &warnings);
    io::UrdfBoundaryOptions options;
    options.spacing = 0.02;  // m, the default scene spacing
    options.packages = scratchPackages();
    io::urdfBoundaries(robot, options, &warnings);
  }
  catch (const ConfigError& e)
  {
    return e.what();
  }
  return "";
}

/// A mesh file of the format named by `extension` (".stl", ".obj", ".dae", ".ply").
inline std::string runMesh(const std::uint8_t* data, std::size_t size, const std::string& extension)
{
  const std::string path = writeInput("fuzz_mesh" + extension, data, size);
  try
  {
    io::readMeshFile(path);
  }
  catch (const ConfigError& e)
  {
    return e.what();
  }
  return "";
}

/// A particle frame (`fluid: - particles: {file: ...}`).
inline std::string runPlyFrame(const std::uint8_t* data, std::size_t size)
{
  const std::string path = writeInput("fuzz_frame.ply", data, size);
  try
  {
    io::readPlyFrame(path);
  }
  catch (const ConfigError& e)
  {
    return e.what();
  }
  return "";
}

/// A package.xml, as the package:// resolver reads it (its <name>); packageNameOf() reports no
/// errors, "" is its answer for a file without a name.
inline std::string runPackageXml(const std::uint8_t* data, std::size_t size)
{
  const std::string path = writeInput("package.xml", data, size);
  io::packageNameOf(path);
  return "";
}

}  // namespace fuzz
}  // namespace fluid_sim
