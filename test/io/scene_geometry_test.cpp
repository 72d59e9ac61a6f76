// Scene keys that bring in geometry from files: `mesh: {file, scale}` and
// `urdf: {file, links, joint_positions}`, the particle budget, warnings, and their errors.

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "fluid_sim/io/mesh_topology.h"
#include "fluid_sim/io/scene_loader.h"
#include "temp_dir.h"

namespace fluid_sim
{
namespace
{
namespace fs = std::filesystem;

const std::string kFixtures = FLUID_SIM_SOURCE_DIR "/test/fixtures";
const std::string kPackage = kFixtures + "/fluid_sim_test_pkg";

const std::string kBase = R"yaml(
spacing: 0.02
domain: {min: [-1, -1, -1], max: [1, 1, 1]}
fluid:
  - box: {min: [0.5, 0.5, 0.5], max: [0.6, 0.6, 0.6]}
)yaml";

io::SceneLoadOptions fixtureOptions()
{
  io::SceneLoadOptions o;
  o.packages = io::defaultPackageResolver({kFixtures});
  return o;
}

/// Loads `yaml` written to dir/scene.yaml; returns the error text ("" if it loaded).
std::string errorOf(const test::TempDir& dir, const std::string& yaml,
                    const io::SceneLoadOptions& options = fixtureOptions())
{
  try
  {
    io::loadScene(dir.write("scene.yaml", yaml), {}, options);
  }
  catch (const io::SceneError& e)
  {
    return e.what();
  }
  return "";
}

void expectError(const test::TempDir& dir, const std::string& yaml, const std::string& key,
                 const std::vector<std::string>& details)
{
  const std::string what = errorOf(dir, yaml);
  EXPECT_NE(what.find("scene.yaml: " + key + ": "), std::string::npos) << what;
  for (const auto& d : details) EXPECT_NE(what.find(d), std::string::npos) << "'" << d << "' not in: " << what;
}

const BoundaryConfig& byName(const SceneConfig& s, const std::string& name)
{
  for (const auto& b : s.boundaries)
    if (b.name == name) return b;
  throw std::runtime_error("no body " + name);
}

TEST(SceneGeometry, MeshFileWithScalePoseAndCommonKeys)
{
  test::TempDir dir;
  const std::string mesh = kPackage + "/meshes/unit_cube.stl";
  const SceneConfig s = io::loadScene(dir.write("scene.yaml", kBase + R"yaml(
boundaries:
  - name: tank
    mesh: {file: )yaml" + mesh + R"yaml(, scale: [0.4, 0.3, 0.5]}
    inside: true
    pose: {xyz: [-0.2, -0.15, -0.25]}
    sample_spacing: 0.01
  - mesh: {file: package://fluid_sim_test_pkg/meshes/pyramid.obj, scale: 0.1}
    motion: {angular_velocity: [0, 0, 1]}
)yaml"),
                                      {}, fixtureOptions());
  ASSERT_EQ(s.boundaries.size(), 2u);
  const BoundaryConfig& tank = s.boundaries[0];
  EXPECT_EQ(tank.type, ShapeType::Mesh);
  EXPECT_TRUE(tank.mesh_closed);
  EXPECT_TRUE(tank.inside);
  EXPECT_NEAR(io::signedVolume(tank.mesh), 0.4 * 0.3 * 0.5, 1e-9);
  EXPECT_TRUE(tank.pose.translation.isApprox(Vec3d(-0.2, -0.15, -0.25)));
  EXPECT_DOUBLE_EQ(tank.sample_spacing, 0.01);
  EXPECT_TRUE(tank.mesh.inside_index);
  const BoundaryConfig& pyramid = s.boundaries[1];
  EXPECT_EQ(pyramid.name, "mesh1");
  EXPECT_NEAR(io::signedVolume(pyramid.mesh), 0.001 / 3.0, 1e-12);
  EXPECT_DOUBLE_EQ(pyramid.motion.angular_velocity.z(), 1.0);
  EXPECT_TRUE(s.warnings.empty());
}

TEST(SceneGeometry, RelativeMeshPathsAreRelativeToTheSceneFile)
{
  test::TempDir dir;
  fs::create_directories(dir.path() / "scenes" / "meshes");
  fs::copy_file(kPackage + "/meshes/cup.stl", dir.file("scenes/meshes/cup.stl"));
  const std::string path = dir.write("scenes/scene.yaml", kBase + R"yaml(
boundaries:
  - name: cup
    mesh: {file: meshes/cup.stl}
)yaml");
  const SceneConfig s = io::loadScene(path);  // default resolver; relative to scenes/, not the working directory
  ASSERT_EQ(s.boundaries.size(), 1u);
  EXPECT_FALSE(s.boundaries[0].mesh_closed);
  // An open mesh used as a solid: allowed, and warned, naming the scene and the mesh.
  ASSERT_EQ(s.warnings.size(), 1u);
  EXPECT_NE(s.warnings[0].find("scene.yaml: boundaries[0] 'cup' (meshes/cup.stl): not a closed surface"),
            std::string::npos)
      << s.warnings[0];
  // offset: none says the thin shell is meant: no warning.
  const SceneConfig quiet = io::loadScene(dir.write("scenes/quiet.yaml", kBase + R"yaml(
boundaries:
  - name: cup
    mesh: {file: meshes/cup.stl}
    offset: none
)yaml"));
  EXPECT_TRUE(quiet.warnings.empty());
}

TEST(SceneGeometry, UrdfLinksAtJointPositions)
{
  test::TempDir dir;
  const SceneConfig s = io::loadScene(dir.write("scene.yaml", kBase + R"yaml(
boundaries:
  - name: tank
    box: {min: [-0.9, -0.9, -0.9], max: [0.9, 0.9, 0.9]}
    inside: true
  - urdf:
      file: package://fluid_sim_test_pkg/urdf/shapes.urdf
      links: [base, drum, ball, part, marker]
      joint_positions: {drum_joint: 0.5, ball_slide: 0.1}
    pose: {xyz: [0, 0, -0.5]}
    sample_spacing: 0.01
)yaml"),
                                      {}, fixtureOptions());
  ASSERT_EQ(s.boundaries.size(), 5u);  // tank + four links; 'marker' has no collision
  EXPECT_EQ(s.boundaries[1].name, "base");
  const BoundaryConfig& drum = byName(s, "drum");
  EXPECT_EQ(drum.type, ShapeType::Cylinder);
  EXPECT_TRUE(drum.pose.translation.isApprox(Vec3d(0.2, 0, -0.4)));
  const Vec3d drum_x = drum.pose.rotation * Vec3d::UnitX();
  EXPECT_NEAR(std::atan2(drum_x.y(), drum_x.x()), 0.5, 1e-9);
  const BoundaryConfig& ball = byName(s, "ball");
  EXPECT_TRUE(ball.pose.translation.isApprox(Vec3d(0.2 + 0.1 * std::cos(0.5), 0.1 * std::sin(0.5), -0.3)));
  EXPECT_DOUBLE_EQ(ball.sample_spacing, 0.01);
  EXPECT_EQ(byName(s, "part").type, ShapeType::Mesh);
  bool noted = false;
  for (const auto& w : s.warnings)
    noted = noted || w.find("link 'marker' has no collision geometry") != std::string::npos;
  EXPECT_TRUE(noted);

  // The open cup is warned about as a solid, not with `offset: none` (the thin shell meant).
  const auto warnedOpen = [&](const std::string& extra) {
    const SceneConfig c = io::loadScene(
        dir.write("cup.yaml", kBase +
                                  "boundaries:\n  - urdf:\n      file: package://fluid_sim_test_pkg/urdf/shapes.urdf\n"
                                  "      links: [cup]\n" +
                                  extra),
        {}, fixtureOptions());
    for (const auto& w : c.warnings)
      if (w.find("link 'cup': not a closed surface") != std::string::npos) return true;
    return false;
  };
  EXPECT_TRUE(warnedOpen(""));
  EXPECT_FALSE(warnedOpen("    offset: none\n"));
}

TEST(SceneGeometry, UrdfFromRosPackagePathByDefault)
{
  test::TempDir dir;
  const char* old = std::getenv("ROS_PACKAGE_PATH");
  const std::string saved = old ? old : "";
  ::setenv("ROS_PACKAGE_PATH", kFixtures.c_str(), 1);
  const std::string yaml = kBase + R"yaml(
boundaries:
  - urdf: {file: package://fluid_sim_test_pkg/urdf/shapes.urdf, links: [cup]}
)yaml";
  SceneConfig s;
  EXPECT_NO_THROW(s = io::loadScene(dir.write("scene.yaml", yaml)));
  if (old)
    ::setenv("ROS_PACKAGE_PATH", saved.c_str(), 1);
  else
    ::unsetenv("ROS_PACKAGE_PATH");
  ASSERT_EQ(s.boundaries.size(), 1u);
  EXPECT_EQ(s.boundaries[0].name, "cup");
}

TEST(SceneGeometry, UnknownKeysLinksAndJointsAreErrors)
{
  test::TempDir dir;
  const std::string urdf = "package://fluid_sim_test_pkg/urdf/shapes.urdf";
  expectError(dir, kBase + "boundaries:\n  - urdf: {file: " + urdf + ", link: [base]}\n", "boundaries[0].urdf.link",
              {"unknown key", "did you mean 'links'"});
  expectError(dir, kBase + "boundaries:\n  - urdf: {file: " + urdf + ", links: [base, paddle]}\n",
              "boundaries[0].urdf.links[1]", {"unknown link 'paddle' in " + urdf, "shapes.urdf", "links: "});
  expectError(dir, kBase + "boundaries:\n  - urdf: {file: " + urdf + ", joint_positions: {elbow: 1}}\n",
              "boundaries[0].urdf.joint_positions.elbow", {"unknown joint 'elbow' in " + urdf, "drum_joint"});
  expectError(dir, kBase + "boundaries:\n  - urdf: {file: " + urdf + ", joint_positions: {part_mount: 1}}\n",
              "boundaries[0].urdf.joint_positions.part_mount", {"has no position to set"});
  expectError(dir, kBase + "boundaries:\n  - urdf: {file: " + urdf + "}\n    name: robot\n", "boundaries[0].name",
              {"named after its links"});
  expectError(dir, kBase + "boundaries:\n  - mesh: {file: a.stl, vertices: [], triangles: []}\n", "boundaries[0].mesh",
              {"either file or vertices"});
  expectError(dir, kBase + "boundaries:\n  - mesh: {file: a.stl, scale: [1, 0, 1]}\n", "boundaries[0].mesh.scale",
              {"not zero"});
  expectError(dir, kBase + "boundaries:\n  - mesh: {file: a.stl, sacle: 2}\n", "boundaries[0].mesh.sacle",
              {"unknown key", "did you mean 'scale'"});
}

TEST(SceneGeometry, BadFilesNameTheKeyAndTheFile)
{
  test::TempDir dir;
  expectError(dir, kBase + "boundaries:\n  - mesh: {file: meshes/none.stl}\n", "boundaries[0].mesh.file",
              {"meshes/none.stl (= " + dir.file("meshes/none.stl") + "): no such file"});
  dir.write("part.xyz", "hello");
  expectError(dir, kBase + "boundaries:\n  - mesh: {file: part.xyz}\n", "boundaries[0].mesh.file",
              {"part.xyz", "unknown mesh format '.xyz'"});
  dir.write("empty.stl", "solid empty\nendsolid empty\n");
  expectError(dir, kBase + "boundaries:\n  - mesh: {file: empty.stl}\n", "boundaries[0].mesh.file", {"empty.stl"});
  expectError(dir, kBase + "boundaries:\n  - mesh: {file: package://nowhere/a.stl}\n", "boundaries[0].mesh.file",
              {"unknown package 'nowhere'"});
  expectError(dir, kBase + "boundaries:\n  - urdf: {file: robot.urdf}\n", "boundaries[0].urdf.file",
              {"robot.urdf", "no such file"});
  dir.write("broken.urdf", "<robot name='r'><link name='a'>");
  expectError(dir, kBase + "boundaries:\n  - urdf: {file: broken.urdf}\n", "boundaries[0].urdf.file",
              {"broken.urdf", "not a valid URDF"});
  dir.write("bad_mesh.urdf", R"(<robot name="r"><link name="arm"><collision name="shell">
    <geometry><mesh filename="arm.stl"/></geometry></collision></link></robot>)");
  expectError(dir, kBase + "boundaries:\n  - urdf: {file: bad_mesh.urdf}\n", "boundaries[0].urdf",
              {"bad_mesh.urdf: link 'arm', collision[0] ('shell') (URDF line 1): mesh arm.stl", "no such file"});
}

TEST(SceneGeometry, ParticleBudgetIsCheckedBeforeSampling)
{
  test::TempDir dir;
  const std::string mesh = kPackage + "/meshes/unit_cube.stl";
  // A 1 m cube at 2 cm: 6 m^2 / (0.02 m)^2 * 2 = 30000 estimated particles.
  const std::string yaml = kBase + "boundaries:\n  - name: big\n    mesh: {file: " + mesh + "}\n";
  expectError(dir, "max_boundary_particles: 20000\n" + yaml, "boundaries[0]",
              {"'big' (its mesh spans 1 x 1 x 1 m) would need about 30000 boundary particles",
               "max_boundary_particles = 20000"});
  EXPECT_EQ(errorOf(dir, "max_boundary_particles: 40000\n" + yaml), "");
  // Primitives and URDF links too, and the default budget (2,000,000 per body).
  expectError(
      dir,
      kBase + "boundaries:\n  - box: {min: [-0.9, -0.9, -0.9], max: [0.9, 0.9, 0.9]}\n    sample_spacing: 0.0005\n",
      "boundaries[0]", {"boundary particles", "max_boundary_particles = 2000000"});
  expectError(
      dir,
      "max_boundary_particles: 100\n" + kBase +
          "boundaries:\n  - urdf: {file: package://fluid_sim_test_pkg/urdf/shapes.urdf, links: [base]}\n",
      "boundaries[0]",
      {"'base' (link 'base' of package://fluid_sim_test_pkg/urdf/shapes.urdf", "(URDF line 5)) would need about"});
  // A URDF link's meshes and their scales are named.
  expectError(dir,
              "max_boundary_particles: 10\n" + kBase +
                  "boundaries:\n  - urdf: {file: package://fluid_sim_test_pkg/urdf/shapes.urdf, links: [part]}\n",
              "boundaries[0]",
              {"'part' (its mesh spans",
               "(URDF line 24); meshes package://fluid_sim_test_pkg/meshes/pyramid.obj at "
               "scale 0.1 0.2 0.3) would need about"});
  // A mesh's size is said: a CAD export in millimetres read as metres is the usual cause.
  expectError(dir, "max_boundary_particles: 100\n" + yaml, "boundaries[0]",
              {"'big' (its mesh spans 1 x 1 x 1 m) would need", "scale 0.001"});
  expectError(dir, "max_boundary_particles: 0\n" + kBase, "max_boundary_particles", {"whole number >= 1"});
}

}  // namespace
}  // namespace fluid_sim
