// package://, file:// and relative file names, and the ROS-free package search.

#include "fluid_sim/io/resource_resolver.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "fluid_sim/core/types.h"
#include "temp_dir.h"

namespace fluid_sim
{
namespace
{
namespace fs = std::filesystem;
using io::resolveResource;

const std::string kFixtures = FLUID_SIM_SOURCE_DIR "/test/fixtures";

std::string errorOf(const std::string& uri, const std::string& base, const io::PackageResolver& packages)
{
  try
  {
    resolveResource(uri, base, packages);
  }
  catch (const ConfigError& e)
  {
    return e.what();
  }
  return "";
}

/// Sets an environment variable for one scope.
class ScopedEnv
{
public:
  ScopedEnv(const char* name, const std::string& value) : name_(name)
  {
    if (const char* old = std::getenv(name)) old_ = old, had_ = true;
    ::setenv(name, value.c_str(), 1);
  }
  ~ScopedEnv()
  {
    if (had_)
      ::setenv(name_, old_.c_str(), 1);
    else
      ::unsetenv(name_);
  }

private:
  const char* name_;
  std::string old_;
  bool had_ = false;
};

TEST(ResourceResolver, PathsAndFileUris)
{
  const io::PackageResolver none;
  EXPECT_EQ(resolveResource("/abs/mesh.stl", "/base", none), "/abs/mesh.stl");
  EXPECT_EQ(resolveResource("meshes/a.stl", "/base/urdf", none), "/base/urdf/meshes/a.stl");
  EXPECT_EQ(resolveResource("../meshes/a.stl", "/base/urdf", none), "/base/meshes/a.stl");
  EXPECT_EQ(resolveResource("a.stl", "", none), "a.stl");
  EXPECT_EQ(resolveResource("file:///abs/a.stl", "/base", none), "/abs/a.stl");
  EXPECT_EQ(resolveResource("file://rel/a.stl", "/base", none), "/base/rel/a.stl");
  // Percent escapes are decoded (a CAD export's "my part.stl" arrives as my%20part.stl) and a
  // localhost authority names this machine.
  EXPECT_EQ(resolveResource("file:///abs/my%20part%2Bv2.stl", "/base", none), "/abs/my part+v2.stl");
  EXPECT_EQ(resolveResource("file://localhost/abs/a.stl", "/base", none), "/abs/a.stl");
  EXPECT_NE(errorOf("file:///abs/50%.stl", "", none).find("malformed percent escape '%.s'"), std::string::npos)
      << errorOf("file:///abs/50%.stl", "", none);
  EXPECT_NE(errorOf("file:///abs/a%2", "", none).find("malformed percent escape"), std::string::npos);
  // A plain path is a file name, not a URI: its % stays.
  EXPECT_EQ(resolveResource("/abs/100%.stl", "/base", none), "/abs/100%.stl");
  EXPECT_NE(errorOf("http://example.com/a.stl", "", none).find("unsupported URI scheme"), std::string::npos);
  EXPECT_NE(errorOf("", "", none).find("empty file name"), std::string::npos);
}

TEST(ResourceResolver, PackageUrisGoThroughTheInjectedResolver)
{
  const io::PackageResolver packages = [](const std::string& name) {
    return name == "robot_description" ? std::string("/opt/robot") : std::string();
  };
  EXPECT_EQ(resolveResource("package://robot_description/meshes/arm.dae", "/ignored", packages),
            "/opt/robot/meshes/arm.dae");
  const std::string unknown = errorOf("package://nope/meshes/arm.dae", "", packages);
  EXPECT_NE(unknown.find("package://nope/meshes/arm.dae: unknown package 'nope'"), std::string::npos) << unknown;
  EXPECT_NE(unknown.find("ROS_PACKAGE_PATH"), std::string::npos) << unknown;
  EXPECT_NE(errorOf("package://robot_description", "", packages).find("malformed"), std::string::npos);
  EXPECT_NE(errorOf("package://x/a.stl", "", io::PackageResolver()).find("no package resolver"), std::string::npos);
}

TEST(ResourceResolver, DefaultResolverFindsTheFixturePackageInGivenFolders)
{
  const io::PackageResolver packages = io::defaultPackageResolver({kFixtures});
  EXPECT_EQ(fs::path(packages("fluid_sim_test_pkg")), fs::path(kFixtures + "/fluid_sim_test_pkg").lexically_normal());
  EXPECT_EQ(packages("no_such_package"), "");
  const std::string mesh = resolveResource("package://fluid_sim_test_pkg/meshes/unit_cube.stl", "", packages);
  EXPECT_TRUE(fs::exists(mesh)) << mesh;
  EXPECT_EQ(io::packageNameOf(kFixtures + "/fluid_sim_test_pkg/package.xml"), "fluid_sim_test_pkg");
}

TEST(ResourceResolver, PackageXmlIsParsedAsXml)
{
  test::TempDir dir;
  // A long comment: the regular expression that stripped comments recursed once per character
  // and overflowed the stack (a crash while crawling ROS_PACKAGE_PATH).
  const std::string long_comment = "<?xml version=\"1.0\"?>\n<!-- " + std::string(2000000, 'x') +
                                   " -->\n<package format=\"2\">\n  <name>long_comment_pkg</name>\n</package>\n";
  EXPECT_EQ(io::packageNameOf(dir.write("a.xml", long_comment)), "long_comment_pkg");
  // Example tags in comments and nested <name>s are not the package's name.
  const std::string tricky = R"(<?xml version="1.0"?>
<!-- copy me: <package><name>template</name></package> -->
<package format="3">
  <export><name>not_this</name></export>
  <name>
    real_name
  </name>
</package>
)";
  EXPECT_EQ(io::packageNameOf(dir.write("b.xml", tricky)), "real_name");
  // Not a package manifest, or not XML: no name (the crawler skips it).
  EXPECT_EQ(io::packageNameOf(dir.write("c.xml", "<robot><name>r</name></robot>")), "");
  EXPECT_EQ(io::packageNameOf(dir.write("d.xml", "<package><name>unclosed</package>")), "");
  EXPECT_EQ(io::packageNameOf(dir.write("e.xml", std::string(100000, '<'))), "");
  std::string deep = "<package><name>deep</name>";
  for (int k = 0; k < 100000; ++k) deep += "<a>";
  EXPECT_EQ(io::packageNameOf(dir.write("f.xml", deep)), "");
}

TEST(ResourceResolver, DefaultResolverSearchesRosPackagePathRecursively)
{
  test::TempDir dir;
  // ws/src/group/pkg_a (two levels down), ws/src/pkg_b with a commented-out name first, an ignored
  // folder, and a nested package inside pkg_a that rospack would not see.
  const fs::path src = dir.path() / "ws" / "src";
  fs::create_directories(src / "group" / "pkg_a" / "nested");
  fs::create_directories(src / "pkg_b");
  fs::create_directories(src / "ignored" / "pkg_c");
  dir.write("ws/src/group/pkg_a/package.xml", "<package><name>pkg_a</name></package>");
  dir.write("ws/src/group/pkg_a/nested/package.xml", "<package><name>nested</name></package>");
  dir.write("ws/src/pkg_b/package.xml", "<package><!-- <name>old</name> -->\n  <name> pkg_b </name></package>");
  dir.write("ws/src/ignored/CATKIN_IGNORE", "");
  dir.write("ws/src/ignored/pkg_c/package.xml", "<package><name>pkg_c</name></package>");
  const ScopedEnv env("ROS_PACKAGE_PATH", "/nonexistent:" + src.string());
  const io::PackageResolver packages = io::defaultPackageResolver();
  EXPECT_EQ(packages("pkg_a"), (src / "group" / "pkg_a").string());
  EXPECT_EQ(packages("pkg_b"), (src / "pkg_b").string());
  EXPECT_EQ(packages("old"), "");
  EXPECT_EQ(packages("nested"), "");
  EXPECT_EQ(packages("pkg_c"), "");
  // The depth bound: one level is not enough to reach group/pkg_a.
  EXPECT_EQ(io::defaultPackageResolver({src.string()}, 1)("pkg_a"), "");
  EXPECT_EQ(io::defaultPackageResolver({src.string()}, 2)("pkg_a"), (src / "group" / "pkg_a").string());
}

TEST(ResourceResolver, EnclosingPackageOfAFile)
{
  EXPECT_EQ(fs::path(io::enclosingPackageFolder(kFixtures + "/fluid_sim_test_pkg/urdf/shapes.urdf")),
            fs::path(kFixtures + "/fluid_sim_test_pkg"));
  EXPECT_EQ(fs::path(io::enclosingPackageFolder(kFixtures + "/fluid_sim_test_pkg/urdf")),
            fs::path(kFixtures + "/fluid_sim_test_pkg"));
}

}  // namespace
}  // namespace fluid_sim
