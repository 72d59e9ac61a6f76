// The OBJ writer (obj_writer.h): a surface mesh written and read back, by a plain parser (every
// value bit for bit, every index) and by assimp (readMeshFile: a closed, outward mesh of the same
// volume); an empty mesh; the file names.

#include <gtest/gtest.h>

#include <array>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "fluid_sim/core/surface.h"
#include "fluid_sim/io/mesh_loader.h"
#include "fluid_sim/io/obj_writer.h"
#include "temp_dir.h"

namespace fluid_sim
{
namespace
{
/// A mesh made by the core: the surface of a 4 x 3 x 2 lattice block at 2 cm.
SurfaceMesh blockSurface()
{
  std::vector<Vec3> p;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 2; ++k) p.push_back(Vec3(Real(0.02 * (i + 0.5)), Real(0.02 * (j + 0.5)), Real(0.02 * k)));
  return reconstructSurface(p, 0.02);
}

/// The `v` and `f` lines of an OBJ file (f as 0-based indices); anything else is counted.
struct ParsedObj
{
  std::vector<Vec3> vertices;
  std::vector<std::array<Index, 3>> triangles;
  int comments = 0;
  int other = 0;
};
ParsedObj parse(const std::string& text)
{
  ParsedObj obj;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line))
  {
    std::istringstream l(line);
    std::string tag;
    l >> tag;
    if (tag == "v")
    {
      double x, y, z;
      l >> x >> y >> z;
      obj.vertices.emplace_back(Real(x), Real(y), Real(z));
    }
    else if (tag == "f")
    {
      long a, b, c;
      l >> a >> b >> c;
      obj.triangles.push_back({Index(a - 1), Index(b - 1), Index(c - 1)});
    }
    else if (tag == "#")
      ++obj.comments;
    else
      ++obj.other;
  }
  return obj;
}
}  // namespace

TEST(ObjWriter, MeshRoundTripsExactly)
{
  test::TempDir dir;
  const SurfaceMesh mesh = blockSurface();
  ASSERT_GT(mesh.triangles.size(), 100u);
  const std::string path = dir.file(io::surfaceFileName(3));
  io::writeObj(path, mesh);
  EXPECT_FALSE(std::filesystem::exists(path + ".tmp"));

  const ParsedObj obj = parse(test::readFile(path));
  EXPECT_EQ(obj.comments, 1);
  EXPECT_EQ(obj.other, 0);
  ASSERT_EQ(obj.vertices.size(), mesh.vertices.size());
  ASSERT_EQ(obj.triangles.size(), mesh.triangles.size());
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i)
    ASSERT_EQ(obj.vertices[i], mesh.vertices[i]) << "vertex " << i << " not read back bit for bit";
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i) ASSERT_EQ(obj.triangles[i], mesh.triangles[i]) << i;
}

TEST(ObjWriter, AssimpReadsAClosedOutwardMeshOfTheSameVolume)
{
  test::TempDir dir;
  const SurfaceMesh mesh = blockSurface();
  const std::string path = dir.file("surface.obj");
  io::writeObj(path, mesh);
  const io::MeshFile read = io::readMeshFile(path);
  EXPECT_TRUE(read.closed);
  EXPECT_EQ(read.border_edges, 0u);
  EXPECT_EQ(read.mesh.triangles.size(), mesh.triangles.size());
  // The volume assimp's copy encloses, by the same divergence sum: equal, and positive (the
  // triangles' order, counter-clockwise from outside, survived).
  SurfaceMesh back;
  for (const Vec3d& v : read.mesh.vertices) back.vertices.push_back(v.cast<Real>());
  for (const auto& t : read.mesh.triangles) back.triangles.push_back({Index(t[0]), Index(t[1]), Index(t[2])});
  EXPECT_GT(enclosedVolume(mesh), 0.0);
  EXPECT_NEAR(enclosedVolume(back), enclosedVolume(mesh), 1e-6 * enclosedVolume(mesh));
}

TEST(ObjWriter, EmptyMeshIsACommentOnly)
{
  test::TempDir dir;
  const std::string path = dir.file("empty.obj");
  io::writeObj(path, SurfaceMesh());
  const ParsedObj obj = parse(test::readFile(path));
  EXPECT_EQ(obj.comments, 1);
  EXPECT_TRUE(obj.vertices.empty());
  EXPECT_TRUE(obj.triangles.empty());
}

TEST(ObjWriter, FileNamesMatchTheFrames)
{
  EXPECT_EQ(io::surfaceFileName(0), "000000.obj");
  EXPECT_EQ(io::surfaceFileName(42), "000042.obj");
  EXPECT_THROW(io::writeObj("/nonexistent_dir_fluid_sim/x.obj", SurfaceMesh()), std::runtime_error);
}

}  // namespace fluid_sim
