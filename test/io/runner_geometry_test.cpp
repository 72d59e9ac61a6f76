// The headless runner (FLUID_SIM_RUN) with mesh and URDF boundaries: a good scene runs and prints
// the loader's warnings; every kind of bad geometry input exits with code 2 and a message naming
// the file (and the link and element).

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>

#include "temp_dir.h"

namespace fluid_sim
{
namespace
{
namespace fs = std::filesystem;

const std::string kFixtures = FLUID_SIM_SOURCE_DIR "/test/fixtures";

using test::RunResult;

/// Runs "cd dir && ROS_PACKAGE_PATH=<fixtures> fluid_sim_run <args>".
RunResult run(const test::TempDir& dir, const std::string& args)
{
  return test::runRunner(dir, args, "ROS_PACKAGE_PATH='" + std::string(kFixtures) + "' ");
}

/// A tiny tank scene (64 particles) with `boundary` (YAML list entries) added.
std::string scene(const std::string& boundary)
{
  return R"yaml(
spacing: 0.05
domain: {min: [-0.1, -0.1, -0.1], max: [0.5, 0.5, 0.6]}
time_step: {fixed: 0.002}
duration: 0.02
fluid:
  - box: {min: [0.05, 0.05, 0.05], max: [0.25, 0.25, 0.25]}
boundaries:
  - name: tank
    box: {min: [0, 0, 0], max: [0.4, 0.4, 0.5]}
    inside: true
)yaml" + boundary +
         "output: {frame_interval: 0}\n";
}

TEST(RunnerGeometry, UrdfAndMeshSceneRunsAndPrintsWarnings)
{
  test::TempDir dir;
  dir.write("scene.yaml",
            scene(R"yaml(  - urdf: {file: package://fluid_sim_test_pkg/urdf/shapes.urdf, links: [cup, part, marker]}
    pose: {xyz: [0.3, 0.3, 0.3]}
  - name: pyramid
    mesh: {file: package://fluid_sim_test_pkg/meshes/pyramid.obj, scale: 0.05}
    pose: {xyz: [0.3, 0.1, 0.05]}
)yaml"));
  const RunResult r = run(dir, "scene.yaml --threads 1");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("body     cup:"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("body     part:"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("body     pyramid:"), std::string::npos) << r.out;
  EXPECT_NE(r.err.find("warning: "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("shapes.urdf: link 'marker' has no collision geometry; skipped"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("shapes.urdf: link 'cup': not a closed surface"), std::string::npos) << r.err;
}

TEST(RunnerGeometry, BadGeometryExitsWithCodeTwo)
{
  test::TempDir dir;
  dir.write("garbage.xyz", "not a mesh");
  dir.write("empty.stl", "solid empty\nendsolid empty\n");
  {
    // A binary STL with one NaN coordinate.
    std::ofstream stl(dir.file("nan.stl"), std::ios::binary);
    stl << std::string(80, ' ');
    const std::uint32_t n = 1;
    stl.write(reinterpret_cast<const char*>(&n), 4);
    const float values[12] = {0, 0, 1, 0, 0, 0, 1, 0, 0, std::numeric_limits<float>::quiet_NaN(), 1, 0};
    stl.write(reinterpret_cast<const char*>(values), sizeof values);
    const std::uint16_t attribute = 0;
    stl.write(reinterpret_cast<const char*>(&attribute), 2);
  }
  dir.write("broken.urdf", "<robot name='r'><link name='a'>");
  dir.write("bad_mesh.urdf", R"(<robot name="r"><link name="arm"><collision name="shell">
    <geometry><mesh filename="missing.stl"/></geometry></collision></link></robot>)");
  const std::string urdf = "package://fluid_sim_test_pkg/urdf/shapes.urdf";
  const struct
  {
    std::string boundary;
    std::vector<std::string> expected;  // in stderr
  } cases[] = {
      {"  - mesh: {file: none.stl}\n", {"boundaries[1].mesh.file: none.stl", "no such file"}},
      {"  - mesh: {file: garbage.xyz}\n", {"garbage.xyz", "unknown mesh format"}},
      {"  - mesh: {file: empty.stl}\n", {"boundaries[1].mesh.file: empty.stl"}},
      {"  - mesh: {file: nan.stl}\n", {"nan.stl", "NaN or infinite vertex"}},
      {"  - urdf: {file: broken.urdf}\n", {"broken.urdf", "not a valid URDF"}},
      {"  - urdf: {file: bad_mesh.urdf}\n",
       {"bad_mesh.urdf: link 'arm', collision[0] ('shell') (URDF line 1): mesh missing.stl"}},
      {"  - urdf: {file: " + urdf + ", links: [paddle]}\n", {"unknown link 'paddle'", "shapes.urdf"}},
      {"  - urdf: {file: " + urdf + ", joint_positions: {elbow: 1}}\n", {"unknown joint 'elbow'", "shapes.urdf"}},
      {"  - mesh: {file: package://nowhere/a.stl}\n", {"unknown package 'nowhere'"}},
      {"  - mesh: {file: " + kFixtures +
           "/fluid_sim_test_pkg/meshes/unit_cube.stl, scale: 5}\n    sample_spacing: 0.001\n",
       {"boundary particles", "max_boundary_particles"}},
  };
  for (const auto& c : cases)
  {
    dir.write("bad.yaml", scene(c.boundary));
    const RunResult r = run(dir, "bad.yaml --threads 1");
    EXPECT_EQ(r.exit_code, 2) << c.boundary << r.err;
    EXPECT_NE(r.err.find("error: "), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("bad.yaml"), std::string::npos) << r.err;
    for (const auto& e : c.expected) EXPECT_NE(r.err.find(e), std::string::npos) << "'" << e << "' not in: " << r.err;
  }
}

}  // namespace
}  // namespace fluid_sim
