#include "fluid_sim/io/obj_writer.h"

#include <cstdio>
#include <limits>

#include "fluid_sim/io/file_util.h"

namespace fluid_sim
{
namespace io
{
void writeObj(const std::string& path, const SurfaceMesh& mesh)
{
  // max_digits10 (9 for float, 17 for double): a value printed with it reads back bit for bit.
  constexpr int kDigits = std::numeric_limits<Real>::max_digits10;
  std::string data = "# fluid_sim free surface: " + std::to_string(mesh.vertices.size()) + " vertices, " +
                     std::to_string(mesh.triangles.size()) + " triangles, m; from " + std::to_string(mesh.particles) +
                     " particles\n";
  data.reserve(data.size() + 40 * mesh.vertices.size() + 24 * mesh.triangles.size());
  char line[128];
  for (const Vec3& v : mesh.vertices)
  {
    const int n = std::snprintf(line, sizeof line, "v %.*g %.*g %.*g\n", kDigits, double(v.x()), kDigits, double(v.y()),
                                kDigits, double(v.z()));
    data.append(line, static_cast<std::size_t>(n));
  }
  for (const auto& t : mesh.triangles)
  {
    // OBJ counts vertices from 1.
    const int n = std::snprintf(line, sizeof line, "f %lu %lu %lu\n", static_cast<unsigned long>(t[0]) + 1,
                                static_cast<unsigned long>(t[1]) + 1, static_cast<unsigned long>(t[2]) + 1);
    data.append(line, static_cast<std::size_t>(n));
  }
  writeFileAtomically(path, data);
}

std::string surfaceFileName(std::size_t frame_index)
{
  char name[32];
  std::snprintf(name, sizeof name, "%06zu.obj", frame_index);
  return name;
}

}  // namespace io
}  // namespace fluid_sim
