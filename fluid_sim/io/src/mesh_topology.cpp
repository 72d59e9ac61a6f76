#include "fluid_sim/io/mesh_topology.h"

#include <map>
#include <utility>

namespace fluid_sim
{
namespace io
{
namespace
{
/// Directed edge (a, b) -> how often a triangle runs along it (from vertex a to vertex b).
std::map<std::pair<int, int>, int> directedEdges(const TriangleMesh& mesh)
{
  std::map<std::pair<int, int>, int> directed;
  for (const auto& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) ++directed[{t[k], t[(k + 1) % 3]}];
  return directed;
}
}  // namespace

bool isClosedMesh(const TriangleMesh& mesh)
{
  if (mesh.triangles.empty()) return false;
  const std::map<std::pair<int, int>, int> directed = directedEdges(mesh);
  for (const auto& [edge, count] : directed)
  {
    if (count != 1) return false;  // two triangles wound the same way along one edge, or a repeated triangle
    const auto twin = directed.find({edge.second, edge.first});
    if (twin == directed.end()) return false;  // a border edge
  }
  return true;
}

std::size_t borderEdges(const TriangleMesh& mesh)
{
  const std::map<std::pair<int, int>, int> directed = directedEdges(mesh);
  std::size_t border = 0;
  for (const auto& [edge, count] : directed)
    if (directed.find({edge.second, edge.first}) == directed.end()) border += static_cast<std::size_t>(count);
  return border;
}

double signedVolume(const TriangleMesh& mesh)
{
  const auto n = static_cast<int>(mesh.vertices.size());
  double six_volume = 0.0;
  for (const auto& t : mesh.triangles)
  {
    if (t[0] < 0 || t[1] < 0 || t[2] < 0 || t[0] >= n || t[1] >= n || t[2] >= n) continue;  // reported by validate()
    const Vec3d& a = mesh.vertices[t[0]];
    const Vec3d& b = mesh.vertices[t[1]];
    const Vec3d& c = mesh.vertices[t[2]];
    six_volume += a.dot(b.cross(c));  // signed volume of the tetrahedron (0, a, b, c), times 6
  }
  return six_volume / 6.0;
}

bool orientOutward(TriangleMesh& mesh)
{
  if (!isClosedMesh(mesh)) return false;
  if (signedVolume(mesh) < 0.0)
    for (auto& t : mesh.triangles) std::swap(t[1], t[2]);
  return true;
}

}  // namespace io
}  // namespace fluid_sim
