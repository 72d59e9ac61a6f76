#include "fluid_sim/io/mesh_topology.h"

#include <algorithm>
#include <array>
#include <map>
#include <numeric>
#include <unordered_map>
#include <utility>
#include <vector>

#include "fluid_sim/core/cell_key.h"

namespace fluid_sim
{
namespace io
{
namespace
{
/// Vertices closer than this fraction of the mesh's bounding-box diagonal are one vertex for the
/// topology: CAD exports leave seams of float rounding (1e-7 m on a 0.3 m tank made it "open",
/// and it lost a fifth of its water to the fill's outside test). A thousandth of a spacing or
/// less at any size the budgets allow; the geometry itself is not moved.
constexpr double kWeld = 1e-5;
/// Vertices on the rim of a hole (a border edge after the weld above) are joined with others on a
/// rim within this fraction of the diagonal, when no edge joins them already: a seam between two
/// separately exported faces (1e-5 m on a 0.3 m tank left it open). A gap so narrow is a
/// ten-thousandth of the mesh's size: at any spacing that samples the mesh with more than a few
/// particles across, no water passes it.
constexpr double kSeamWeld = 1e-4;

/// The mesh as topology sees it: near vertices joined, zero-area triangles left out (a sliver
/// does not make a hole), each kept triangle with its index in mesh.triangles.
struct TopologyView
{
  std::vector<std::array<int, 3>> triangles;
  std::vector<std::size_t> source;
};

int findRoot(std::vector<int>& parent, int k)
{
  while (parent[k] != k) k = parent[k] = parent[parent[k]];
  return k;
}

/// Joins the vertices within `tol` (m) of each other among `candidates` (indices into
/// mesh.vertices), through a hash grid of cells of the tolerance (each vertex against those in
/// its cell and the 26 around it), unless `allowed` says no.
template <typename Allowed>
void weld(const TriangleMesh& mesh, const std::vector<int>& candidates, double tol, std::vector<int>& parent,
          const Allowed& allowed)
{
  if (!(tol > 0.0)) return;
  std::unordered_map<CellKey, std::vector<int>, CellKeyHash> grid;
  for (int i : candidates) grid[cellKeyOf(mesh.vertices[i], tol)].push_back(i);
  for (int i : candidates)
  {
    const CellKey key = cellKeyOf(mesh.vertices[i], tol);
    for (long long dz = -1; dz <= 1; ++dz)
      for (long long dy = -1; dy <= 1; ++dy)
        for (long long dx = -1; dx <= 1; ++dx)
        {
          const auto it = grid.find({key.x + dx, key.y + dy, key.z + dz});
          if (it == grid.end()) continue;
          for (int j : it->second)
            if (j > i && (mesh.vertices[j] - mesh.vertices[i]).norm() <= tol && allowed(i, j))
              parent[findRoot(parent, j)] = findRoot(parent, i);
        }
  }
}

/// The kept triangles with their corners' joined vertices.
void joinedTriangles(const TriangleMesh& mesh, std::vector<int>& parent, TopologyView& view)
{
  const int n = static_cast<int>(mesh.vertices.size());
  view.triangles.clear();
  view.source.clear();
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
  {
    const auto& tri = mesh.triangles[t];
    if (tri[0] < 0 || tri[1] < 0 || tri[2] < 0 || tri[0] >= n || tri[1] >= n || tri[2] >= n) continue;
    const std::array<int, 3> j = {findRoot(parent, tri[0]), findRoot(parent, tri[1]), findRoot(parent, tri[2])};
    if (j[0] == j[1] || j[1] == j[2] || j[2] == j[0]) continue;
    if (zeroArea(mesh.vertices[tri[0]], mesh.vertices[tri[1]], mesh.vertices[tri[2]])) continue;
    view.triangles.push_back(j);
    view.source.push_back(t);
  }
}

TopologyView topologyView(const TriangleMesh& mesh)
{
  TopologyView view;
  const int n = static_cast<int>(mesh.vertices.size());
  if (n == 0) return view;
  const AxisBox bounds = boundsOf(mesh.vertices);
  const double diagonal = (bounds.max - bounds.min).norm();  // m
  std::vector<int> parent(n);
  std::iota(parent.begin(), parent.end(), 0);
  std::vector<int> all(n);
  std::iota(all.begin(), all.end(), 0);
  weld(mesh, all, kWeld * diagonal, parent, [](int, int) { return true; });
  joinedTriangles(mesh, parent, view);

  // A seam: rim vertices (on an edge of one triangle) near other rim vertices. Two vertices an
  // edge already joins are never joined (that would fold the edge away, not close a gap).
  std::map<std::pair<int, int>, int> uses;
  for (const auto& t : view.triangles)
    for (int k = 0; k < 3; ++k) ++uses[{std::min(t[k], t[(k + 1) % 3]), std::max(t[k], t[(k + 1) % 3])}];
  std::vector<int> rim;
  for (const auto& [edge, count] : uses)
    if (count == 1)
    {
      rim.push_back(edge.first);
      rim.push_back(edge.second);
    }
  if (rim.empty()) return view;
  std::sort(rim.begin(), rim.end());
  rim.erase(std::unique(rim.begin(), rim.end()), rim.end());
  std::vector<int> seam_parent = parent;
  bool joined = false;
  weld(mesh, rim, kSeamWeld * diagonal, seam_parent, [&](int i, int j) {
    const int a = findRoot(parent, i), b = findRoot(parent, j);
    if (a == b || uses.count({std::min(a, b), std::max(a, b)})) return false;
    joined = true;
    return true;
  });
  if (joined) joinedTriangles(mesh, seam_parent, view);
  return view;
}

/// Directed edge (a, b) -> how often a triangle runs along it (from vertex a to vertex b).
std::map<std::pair<int, int>, int> directedEdges(const std::vector<std::array<int, 3>>& triangles)
{
  std::map<std::pair<int, int>, int> directed;
  for (const auto& t : triangles)
    for (int k = 0; k < 3; ++k) ++directed[{t[k], t[(k + 1) % 3]}];
  return directed;
}

/// Closed: every edge run as often one way as the other (a closed, consistently oriented surface;
/// where more than two triangles meet at an edge, as two cubes sharing one, it still encloses).
bool balanced(const std::vector<std::array<int, 3>>& triangles)
{
  if (triangles.empty()) return false;
  const std::map<std::pair<int, int>, int> directed = directedEdges(triangles);
  for (const auto& [edge, count] : directed)
  {
    const auto twin = directed.find({edge.second, edge.first});
    if (twin == directed.end() || twin->second != count) return false;
  }
  return true;
}
}  // namespace

bool zeroArea(const Vec3d& a, const Vec3d& b, const Vec3d& c)
{
  const double longest = std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()});
  return !((b - a).cross(c - a).norm() > 1e-12 * longest * longest);
}

bool isClosedMesh(const TriangleMesh& mesh)
{
  return balanced(topologyView(mesh).triangles);
}

std::size_t borderEdges(const TriangleMesh& mesh)
{
  // Edges of one triangle only: the rim of a hole.
  const std::map<std::pair<int, int>, int> directed = directedEdges(topologyView(mesh).triangles);
  std::size_t border = 0;
  for (const auto& [edge, count] : directed)
    if (count == 1 && directed.find({edge.second, edge.first}) == directed.end()) ++border;
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
  TopologyView view = topologyView(mesh);
  const std::size_t nt = view.triangles.size();
  if (nt == 0) return false;
  // Each undirected edge's triangles (view index, and whether it runs the edge low -> high).
  std::map<std::pair<int, int>, std::vector<std::pair<std::size_t, bool>>> edges;
  for (std::size_t t = 0; t < nt; ++t)
    for (int k = 0; k < 3; ++k)
    {
      const int a = view.triangles[t][k], b = view.triangles[t][(k + 1) % 3];
      edges[{std::min(a, b), std::max(a, b)}].push_back({t, a < b});
    }
  // Parts, and one winding per part: a part is what its edges of exactly two triangles join
  // (parts that meet at an edge of more, as two cubes sharing one, stay apart), and a triangle
  // wound against its neighbour there (a CAD export's stray face) is turned to match it: two
  // triangles on an edge must run it in opposite directions.
  std::vector<int> component(nt, -1);
  std::vector<bool> flip(nt, false);
  int components = 0;
  for (std::size_t seed = 0; seed < nt; ++seed)
  {
    if (component[seed] >= 0) continue;
    std::vector<std::size_t> stack = {seed};
    component[seed] = components;
    while (!stack.empty())
    {
      const std::size_t t = stack.back();
      stack.pop_back();
      for (int k = 0; k < 3; ++k)
      {
        const int a = view.triangles[t][k], b = view.triangles[t][(k + 1) % 3];
        const auto& uses = edges[{std::min(a, b), std::max(a, b)}];
        if (uses.size() != 2) continue;
        const bool forward = (a < b) != flip[t];  // how t runs the edge, as it will be wound
        for (const auto& [u, u_forward] : uses)
        {
          if (u == t || component[u] >= 0) continue;
          component[u] = components;
          flip[u] = u_forward == forward;  // it must run the edge the other way
          stack.push_back(u);
        }
      }
    }
    ++components;
  }
  for (std::size_t t = 0; t < nt; ++t)
    if (flip[t])
    {
      std::swap(view.triangles[t][1], view.triangles[t][2]);
      std::swap(mesh.triangles[view.source[t]][1], mesh.triangles[view.source[t]][2]);
    }
  if (!balanced(view.triangles)) return false;
  // Outward: each part's enclosed volume positive (one part inside out is flipped alone, not the
  // whole mesh with it).
  std::vector<double> six_volume(components, 0.0);
  for (std::size_t t = 0; t < nt; ++t)
  {
    const auto& tri = mesh.triangles[view.source[t]];
    six_volume[component[t]] += mesh.vertices[tri[0]].dot(mesh.vertices[tri[1]].cross(mesh.vertices[tri[2]]));
  }
  for (std::size_t t = 0; t < nt; ++t)
    if (six_volume[component[t]] < 0.0) std::swap(mesh.triangles[view.source[t]][1], mesh.triangles[view.source[t]][2]);
  return true;
}

}  // namespace io
}  // namespace fluid_sim
