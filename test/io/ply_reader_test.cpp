// The particle-frame reader (ply_reader.h): it reads back exactly what the runner's writer
// writes, ascii too, and refuses every malformed file with a message naming the file and the fault.

#include "fluid_sim/io/ply_reader.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "fluid_sim/io/ply_writer.h"
#include "temp_dir.h"

namespace fluid_sim
{
namespace
{
/// The message of the ConfigError readPlyFrame(path) throws ("" if none).
std::string errorOf(const std::string& path)
{
  try
  {
    io::readPlyFrame(path);
  }
  catch (const ConfigError& e)
  {
    EXPECT_EQ(e.key(), path);
    return e.what();
  }
  return "";
}

/// readPlyFrame(path) fails with a message that names the file and contains `detail`.
void expectError(const std::string& path, const std::string& detail)
{
  const std::string what = errorOf(path);
  EXPECT_EQ(what.rfind(path + ": ", 0), 0u) << what;
  EXPECT_NE(what.find(detail), std::string::npos) << "expected '" << detail << "' in: " << what;
}

void putLittleEndian(std::string& out, const void* value, std::size_t size)
{
  std::uint64_t bits = 0;
  std::memcpy(&bits, value, size);
  for (std::size_t k = 0; k < size; ++k) out.push_back(static_cast<char>((bits >> (8 * k)) & 0xffu));
}

// A frame as the writer writes it: 3 particles with values that are not round in binary.
struct Frame
{
  std::vector<Vec3> x = {Vec3(Real(0.1), Real(0.2), Real(0.3)), Vec3(-1, Real(2.5e-7), 3),
                         Vec3(Real(4.1), 5, Real(-6.5))};
  std::vector<Vec3> v = {Vec3(1, 0, Real(-0.7)), Vec3(0, -2, Real(1e-9)), Vec3(Real(0.25), Real(0.5), Real(0.75))};
  std::vector<Real> p = {0, Real(981.5), Real(1.0e5)};
  std::vector<Real> rho = {1000, Real(1001.25), 999};

  std::string write(const test::TempDir& dir, const std::string& name) const
  {
    const std::string path = dir.file(name);
    io::writePly(path, x, v, p, rho);
    return path;
  }
};

TEST(PlyReader, ReadsBackWhatTheWriterWrites)
{
  test::TempDir dir;
  const Frame f;
  const io::PlyFrame read = io::readPlyFrame(f.write(dir, "000007.ply"));
  ASSERT_EQ(read.positions.size(), 3u);
  ASSERT_EQ(read.velocities.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k)
    {
      // The file holds float32: exact for a float build, the float rounding for a double build.
      EXPECT_EQ(read.positions[i][k], double(static_cast<float>(f.x[i][k]))) << i << " " << k;
      EXPECT_EQ(read.velocities[i][k], double(static_cast<float>(f.v[i][k]))) << i << " " << k;
    }

  io::writePly(dir.file("empty.ply"), {}, {}, {}, {});
  EXPECT_TRUE(io::readPlyFrame(dir.file("empty.ply")).positions.empty());
}

TEST(PlyReader, AsciiWithPropertiesInAnyOrderAndOfAnyFloatType)
{
  test::TempDir dir;
  const std::string path = dir.write("a.ply",
                                     "ply\r\n"
                                     "format ascii 1.0\r\n"
                                     "comment time 0.25\r\n"
                                     "obj_info from a script\r\n"
                                     "element vertex 2\r\n"
                                     "property double vz\r\n"
                                     "property uchar red\r\n"
                                     "property float64 x\r\n"
                                     "property float32 y\r\n"
                                     "property float z\r\n"
                                     "property float vx\r\n"
                                     "property double vy\r\n"
                                     "end_header\r\n"
                                     "6 255 1 2 3 4 5\r\n"
                                     "-0.125 0 0.1 0.2 0.3 0.4 0.5\r\n"
                                     "\n");
  const io::PlyFrame f = io::readPlyFrame(path);
  ASSERT_EQ(f.positions.size(), 2u);
  EXPECT_EQ(f.positions[0], Vec3d(1, 2, 3));
  EXPECT_EQ(f.velocities[0], Vec3d(4, 5, 6));
  EXPECT_EQ(f.positions[1], Vec3d(0.1, 0.2, 0.3));  // ascii values are read as doubles
  EXPECT_EQ(f.velocities[1], Vec3d(0.4, 0.5, -0.125));
}

TEST(PlyReader, BinaryWithPropertiesInAnyOrderAndOfAnyFloatType)
{
  // vx (double), an int property, then x y z (float), vy vz (double): offsets 0, 8, 12, 16, 20, 24, 32.
  std::string data =
      "ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty double vx\nproperty int id\n"
      "property float x\nproperty float y\nproperty float z\nproperty float64 vy\nproperty double vz\nend_header\n";
  for (int i = 0; i < 2; ++i)
  {
    const double vx = 0.1 * (i + 1), vy = -0.2, vz = 1e-300;
    const std::int32_t id = 7;
    const float x = 1.5f + i, y = -2.25f, z = 0.1f;
    putLittleEndian(data, &vx, 8);
    putLittleEndian(data, &id, 4);
    putLittleEndian(data, &x, 4);
    putLittleEndian(data, &y, 4);
    putLittleEndian(data, &z, 4);
    putLittleEndian(data, &vy, 8);
    putLittleEndian(data, &vz, 8);
  }
  test::TempDir dir;
  const io::PlyFrame f = io::readPlyFrame(dir.write("b.ply", data));
  ASSERT_EQ(f.positions.size(), 2u);
  EXPECT_EQ(f.positions[1], Vec3d(2.5, -2.25, double(0.1f)));
  EXPECT_EQ(f.velocities[0], Vec3d(0.1, -0.2, 1e-300));
  EXPECT_EQ(f.velocities[1], Vec3d(0.2, -0.2, 1e-300));
}

TEST(PlyReader, MissingOrTruncatedFilesNameTheFileAndTheFault)
{
  test::TempDir dir;
  expectError(dir.file("none.ply"), "no such file");
  expectError(dir.path().string(), "is a directory");
  expectError(dir.write("empty.ply", ""), "empty file");
  expectError(dir.write("text.ply", "solid cube\nfacet normal 0 0 1\n"), "not a PLY file");

  const std::string whole = test::readFile(Frame().write(dir, "whole.ply"));
  const std::size_t header = whole.find("end_header\n") + 11;
  expectError(dir.write("no_end.ply", whole.substr(0, header - 11)), "no end_header line");
  // 3 vertices of 32 bytes; the last one cut short by a byte.
  expectError(
      dir.write("short.ply", whole.substr(0, whole.size() - 1)),
      "truncated: the header announces 3 vertices of 32 bytes, the file has 95 bytes of data (2 whole vertices)");
  expectError(dir.write("long.ply", whole + "x"), "1 byte after the 3 vertices the header announces");
  std::string fewer = whole;
  fewer.replace(fewer.find("element vertex 3"), 16, "element vertex 2");
  expectError(dir.write("fewer.ply", fewer), "32 bytes after the 2 vertices");

  const std::string ascii_header =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "property float vx\nproperty float vy\nproperty float vz\nend_header\n";
  // Too few characters for 3 rows of 6 values at all; then 2 long rows.
  expectError(dir.write("a_short.ply", ascii_header + "0 0 0 0 0 0\n"),
              "truncated: the header announces 3 vertices of 6 values, the data has only 12 characters");
  const std::string row = "0.0000000 0.0000000 0.0000000 0.0000000 0.0000000 0.0000000\n";
  expectError(dir.write("a_two.ply", ascii_header + row + row), "truncated: the data ends after 2 of the 3 vertices");
  expectError(dir.write("a_long.ply", ascii_header + "0 0 0 0 0 0\n1 1 1 1 1 1\n2 2 2 2 2 2\n3 3 3 3 3 3\n"),
              "more data after the 3 vertices");
  expectError(dir.write("a_row.ply", ascii_header + "0 0 0 0 0 0\n1 1 1 1 1\n2 2 2 2 2 2 2\n"),
              "vertex 1 (line 12): 5 values, the header declares 6 properties");
  expectError(dir.write("a_word.ply", ascii_header + "0 0 0 0 0 0\n1 1 1 1 1,5 1\n2 2 2 2 2 2\n"),
              "vertex 1 (line 12): '1,5' is not a number (property 'vy')");
}

TEST(PlyReader, HeadersThatAreNotAParticleFrameAreRefused)
{
  test::TempDir dir;
  const auto header = [](const std::string& format, const std::string& properties) {
    return "ply\nformat " + format + " 1.0\nelement vertex 0\n" + properties + "end_header\n";
  };
  const std::string xyz = "property float x\nproperty float y\nproperty float z\n";
  const std::string vel = "property float vx\nproperty float vy\nproperty float vz\n";
  EXPECT_EQ(errorOf(dir.write("ok.ply", header("ascii", xyz + vel))), "");

  expectError(dir.write("be.ply", header("binary_big_endian", xyz + vel)),
              "header line 2: format 'binary_big_endian' is not supported");
  expectError(dir.write("v2.ply", "ply\nformat ascii 2.0\nend_header\n"),
              "header line 2: expected 'format <kind> 1.0'");
  expectError(dir.write("nofmt.ply", "ply\nelement vertex 0\n" + xyz + vel + "end_header\n"), "no format line");
  expectError(dir.write("novert.ply", "ply\nformat ascii 1.0\nend_header\n"), "no element vertex");
  expectError(dir.write("novz.ply", header("ascii", xyz + "property float vx\nproperty float vy\n")),
              "the vertex element has no property 'vz' (a particle frame needs x y z vx vy vz)");
  expectError(dir.write("int.ply", header("ascii", xyz + "property float vx\nproperty int vy\nproperty float vz\n")),
              "property 'vy' is of type 'int'; expected float (or double)");
  expectError(dir.write("type.ply", header("ascii", xyz + vel + "property real pressure\n")),
              "header line 10: property 'pressure' has an unknown type 'real'");
  expectError(dir.write("twice.ply", header("ascii", xyz + vel + "property float x\n")),
              "header line 10: property 'x' is declared twice");
  expectError(dir.write("list.ply", header("ascii", xyz + vel + "property list uchar int vertex_indices\n")),
              "list property 'vertex_indices'");
  expectError(dir.write("face.ply", header("ascii", xyz + vel + "element face 0\n")),
              "header line 10: element 'face': a particle frame has one element, vertex");
  expectError(dir.write("count.ply", "ply\nformat ascii 1.0\nelement vertex -3\n" + xyz + vel + "end_header\n"),
              "header line 3: the vertex count '-3' is not a whole number >= 0");
  expectError(dir.write("keyword.ply", "ply\nformat ascii 1.0\nelemnt vertex 0\nend_header\n"),
              "header line 3: unknown keyword 'elemnt'");
}

TEST(PlyReader, NonFiniteValuesAreRefusedNamingTheVertex)
{
  test::TempDir dir;
  Frame f;
  f.v[2].y() = std::numeric_limits<Real>::infinity();
  expectError(f.write(dir, "inf.ply"), "vertex 2 has a non-finite vy (inf)");
  f = Frame();
  f.x[1].z() = std::numeric_limits<Real>::quiet_NaN();
  expectError(f.write(dir, "nan.ply"), "vertex 1 has a non-finite z (nan)");
  // Pressure and density are not used, so theirs do not matter.
  f = Frame();
  f.p[0] = std::numeric_limits<Real>::quiet_NaN();
  EXPECT_EQ(errorOf(f.write(dir, "p_nan.ply")), "");

  const std::string ascii =
      "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
      "property float vx\nproperty float vy\nproperty float vz\nend_header\n0 0 0 nan 0 0\n";
  expectError(dir.write("a_nan.ply", ascii), "vertex 0 has a non-finite vx (nan)");
}

}  // namespace
}  // namespace fluid_sim
