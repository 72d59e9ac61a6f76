#include "fluid_sim/core/boundary_sampling.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <unordered_map>
#include <unordered_set>

#include <Eigen/Eigenvalues>

#include "fluid_sim/core/kernel.h"
#include "fluid_sim/core/mesh_inside_index.h"
#include "fluid_sim/core/neighbor_search.h"

namespace fluid_sim
{
namespace
{
int divisions(double length, double s)
{
  return length <= 0.0 ? 0 : std::max(1, int(std::ceil(length / s - 1e-9)));
}

/// Orthonormal basis (u, v) perpendicular to unit vector a.
void perpendicularBasis(const Vec3d& a, Vec3d& u, Vec3d& v)
{
  const Vec3d helper = std::abs(a.x()) < 0.9 ? Vec3d::UnitX() : Vec3d::UnitY();
  u = a.cross(helper).normalized();
  v = a.cross(u);
}

/// Integer key of a cell for hashing (cell edge `cell`).
struct CellKey
{
  long long x, y, z;
  bool operator==(const CellKey& o) const
  {
    return x == o.x && y == o.y && z == o.z;
  }
};
struct CellKeyHash
{
  std::size_t operator()(const CellKey& k) const
  {
    return std::size_t(k.x * 73856093LL ^ k.y * 19349663LL ^ k.z * 83492791LL);
  }
};
CellKey keyOf(const Vec3d& p, double cell)
{
  return {(long long)std::floor(p.x() / cell), (long long)std::floor(p.y() / cell),
          (long long)std::floor(p.z() / cell)};
}

/// Accepted samples in a hash grid whose cells are twice the largest query radius: a ball of that
/// radius overlaps only the 2 x 2 x 2 cells nearest to its centre.
class SampleGrid
{
public:
  explicit SampleGrid(double max_radius) : cell_(2.0 * max_radius) {}
  /// True if a sample lies closer than sqrt(r2) (<= max_radius) to p; then `hint` is that sample.
  bool near(const Vec3d& p, double r2, Vec3d& hint) const
  {
    const CellKey k = keyOf(p, cell_);
    // The neighbour on the side of the cell's centre that p lies on, per axis.
    const long long sx = p.x() - (k.x + 0.5) * cell_ < 0.0 ? -1 : 1;
    const long long sy = p.y() - (k.y + 0.5) * cell_ < 0.0 ? -1 : 1;
    const long long sz = p.z() - (k.z + 0.5) * cell_ < 0.0 ? -1 : 1;
    for (long long dz = 0; dz <= 1; ++dz)
      for (long long dy = 0; dy <= 1; ++dy)
        for (long long dx = 0; dx <= 1; ++dx)
        {
          const auto it = cells_.find({k.x + dx * sx, k.y + dy * sy, k.z + dz * sz});
          if (it == cells_.end()) continue;
          for (const Vec3d& q : it->second)
            if ((q - p).squaredNorm() < r2)
            {
              hint = q;
              return true;
            }
        }
    return false;
  }
  void add(const Vec3d& p)
  {
    cells_[keyOf(p, cell_)].push_back(p);
  }

private:
  double cell_;
  std::unordered_map<CellKey, std::vector<Vec3d>, CellKeyHash> cells_;
};

/// Calls f(point, unit normal, triangle index) for candidate points on every non-degenerate triangle: rows
/// parallel to the triangle's longest edge, `row` apart, each with points at most `step` apart
/// including both ends. Because the angles at the longest edge are acute, every point of the
/// triangle projects onto the row below it, so it lies within sqrt(row^2 + (step/2)^2) of a
/// candidate; the work per triangle is O(area / (row step) + edge / step), also for slivers.
/// Returns the number of degenerate (zero-area) triangles skipped.
template <typename F>
std::size_t forEachCandidate(const TriangleMesh& mesh, double step, double row, F&& f)
{
  std::size_t degenerate = 0;
  for (std::size_t index = 0; index < mesh.triangles.size(); ++index)
  {
    const auto& t = mesh.triangles[index];
    const Vec3d corner[3] = {mesh.vertices[t[0]], mesh.vertices[t[1]], mesh.vertices[t[2]]};
    int longest = 0;
    double longest_length = -1.0;
    for (int k = 0; k < 3; ++k)
    {
      const double length = (corner[(k + 1) % 3] - corner[k]).norm();
      if (length > longest_length)
      {
        longest_length = length;
        longest = k;
      }
    }
    const Vec3d& a = corner[longest];
    const Vec3d& b = corner[(longest + 1) % 3];
    const Vec3d& c = corner[(longest + 2) % 3];
    // The normal of the triangle as wound (a, b, c is a rotation of the original order).
    const Vec3d n = (b - a).cross(c - a);
    const double twice_area = n.norm();
    if (!(longest_length > 0.0) || !(twice_area > 1e-12 * longest_length * longest_length) ||
        !std::isfinite(twice_area))
    {
      ++degenerate;
      continue;
    }
    const Vec3d unit_n = n / twice_area;
    const double height = twice_area / longest_length;
    const int rows = std::max(1, int(std::ceil(height / row - 1e-9)));
    for (int r = 0; r <= rows; ++r)
    {
      const double tr = double(r) / rows;
      const Vec3d from = a + tr * (c - a), to = b + tr * (c - b);
      const int steps = int(std::ceil((1.0 - tr) * longest_length / step - 1e-9));
      if (steps <= 0)
      {
        f(from, unit_n, index);
        continue;
      }
      for (int i = 0; i <= steps; ++i) f(from + (to - from) * (double(i) / steps), unit_n, index);
    }
  }
  return degenerate;
}
}  // namespace

std::vector<Vec3d> sampleBoxSurface(const AxisBox& box, double s)
{
  const Vec3d ext = (box.max - box.min).cwiseMax(0.0);
  const int n[3] = {divisions(ext.x(), s), divisions(ext.y(), s), divisions(ext.z(), s)};
  std::vector<Vec3d> out;
  // Every lattice point with at least one index on a face: each surface point exactly once.
  for (int k = 0; k <= n[2]; ++k)
    for (int j = 0; j <= n[1]; ++j)
      for (int i = 0; i <= n[0]; ++i)
      {
        const bool on_face = i == 0 || i == n[0] || j == 0 || j == n[1] || k == 0 || k == n[2];
        if (!on_face) continue;
        const Vec3d f(n[0] ? double(i) / n[0] : 0.0, n[1] ? double(j) / n[1] : 0.0, n[2] ? double(k) / n[2] : 0.0);
        out.push_back(box.min + ext.cwiseProduct(f));
      }
  return out;
}

std::vector<Vec3d> sampleSphereSurface(const Vec3d& center, double radius, double s)
{
  std::vector<Vec3d> out;
  if (radius <= 0.0)
  {
    out.push_back(center);
    return out;
  }
  const double area_per_point = std::sqrt(3.0) / 2.0 * s * s;  // hexagonal packing at spacing s
  const int n = std::max(1, int(std::ceil(4.0 * M_PI * radius * radius / area_per_point)));
  const double golden = M_PI * (3.0 - std::sqrt(5.0));
  for (int k = 0; k < n; ++k)
  {
    const double z = 1.0 - (2.0 * k + 1.0) / n;
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    const double phi = golden * k;
    out.push_back(center + radius * Vec3d(r * std::cos(phi), r * std::sin(phi), z));
  }
  return out;
}

std::vector<Vec3d> sampleCylinderSurface(const CylinderShape& cyl, double s)
{
  const Vec3d a = cyl.axis.normalized();
  Vec3d u, v;
  perpendicularBasis(a, u, v);
  std::vector<Vec3d> out;
  const double r = std::max(cyl.radius, 0.0);
  const double len = std::max(cyl.length, 0.0);
  const int n_ax = divisions(len, s);
  const int n_th = std::max(3, int(std::ceil(2.0 * M_PI * r / s)));
  for (int k = 0; k <= n_ax; ++k)
  {
    const double t = n_ax ? -0.5 * len + len * double(k) / n_ax : 0.0;
    // Alternate rings are rotated half a step: a staggered lattice closes gaps between rings.
    const double shift = (k % 2) * 0.5;
    for (int i = 0; i < n_th; ++i)
    {
      const double th = 2.0 * M_PI * (i + shift) / n_th;
      out.push_back(cyl.center + a * t + r * (std::cos(th) * u + std::sin(th) * v));
    }
  }
  // Caps: concentric rings inside the outermost side ring, plus the centre.
  const int n_r = divisions(r, s);
  for (int side = -1; side <= 1; side += 2)
  {
    const Vec3d c = cyl.center + a * (0.5 * len * side);
    out.push_back(c);
    for (int k = 1; k < n_r; ++k)
    {
      const double rk = r * double(k) / n_r;
      const int m = std::max(3, int(std::ceil(2.0 * M_PI * rk / s)));
      for (int i = 0; i < m; ++i)
      {
        const double th = 2.0 * M_PI * (i + 0.5 * (k % 2)) / m;
        out.push_back(c + rk * (std::cos(th) * u + std::sin(th) * v));
      }
    }
  }
  return out;
}

std::vector<Vec3d> sampleMeshSurface(const TriangleMesh& mesh, double s, double offset, std::size_t* degenerate)
{
  // Three passes into one hash grid of samples, each keeping a candidate only if no sample lies
  // within 0.66 s (so no two samples are closer):
  //  1. feature edges (borders, and creases sharper than 30 degrees), each divided evenly into
  //     pieces <= s, ends included: corners and edges are sampled as the box primitive samples them;
  //  2. on every planar patch (neighbouring triangles within 0.5 degrees), a lattice of spacing
  //     <= s stretched to fit the patch's extent, aligned with the border direction that most of
  //     its border runs along or across (ties: nearest a body axis): a box face gets exactly the
  //     primitive's lattice;
  //  3. a fill: candidates on rows 0.05 s apart, points <= 0.1 s apart along them (every surface
  //     point lies within 0.071 s of one), keeping those still farther than 0.66 s from every
  //     sample, except inside a lattice cell whose four corners are all samples (every point of
  //     such a cell lies within 0.71 s of a corner).
  // So no surface point is farther than max(0.71 s, 0.66 s + 0.071 s) < 0.74 s from a sample.
  // Samples closer than a lattice spacing (fill points near slanted borders) are kept few on
  // purpose: the boundary volumes V_b = gamma / sum W of a locally denser layer came out weaker
  // at concave folds (a mesh tank's floor lost particles near its walls; 0.66 s measured better
  // than 0.62 s or 0.5 s). Deterministic (fixed orders); time and memory about linear in the area:
  // the grid holds samples only, and the sample that rejected the previous candidate is tried first.
  const double min_dist = 0.66 * s;
  const double r2 = min_dist * min_dist;
  const std::size_t num_triangles = mesh.triangles.size();
  std::vector<Vec3d> normal(num_triangles, Vec3d::Zero());
  std::vector<char> valid(num_triangles, 0);
  std::size_t skipped = 0;
  for (std::size_t t = 0; t < num_triangles; ++t)
  {
    const auto& tri = mesh.triangles[t];
    const Vec3d& a = mesh.vertices[tri[0]];
    const Vec3d n = (mesh.vertices[tri[1]] - a).cross(mesh.vertices[tri[2]] - a);
    const double longest = std::max({(mesh.vertices[tri[1]] - a).norm(), (mesh.vertices[tri[2]] - a).norm(),
                                     (mesh.vertices[tri[2]] - mesh.vertices[tri[1]]).norm()});
    if (!(n.norm() > 1e-12 * longest * longest) || !std::isfinite(n.norm()))
    {
      ++skipped;
      continue;
    }
    normal[t] = n.normalized();
    valid[t] = 1;
  }
  if (degenerate) *degenerate = skipped;

  // Undirected edges and the valid triangles along them, in order of first appearance.
  std::unordered_map<std::uint64_t, std::size_t> edge_index;
  std::vector<std::array<int, 2>> edges;
  std::vector<std::vector<std::uint32_t>> edge_triangles;
  for (std::size_t t = 0; t < num_triangles; ++t)
  {
    if (!valid[t]) continue;
    for (int k = 0; k < 3; ++k)
    {
      const int i = mesh.triangles[t][k], j = mesh.triangles[t][(k + 1) % 3];
      const std::uint64_t key = (std::uint64_t(std::uint32_t(std::min(i, j))) << 32) | std::uint32_t(std::max(i, j));
      const auto [it, inserted] = edge_index.emplace(key, edges.size());
      if (inserted)
      {
        edges.push_back({std::min(i, j), std::max(i, j)});
        edge_triangles.emplace_back();
      }
      edge_triangles[it->second].push_back(std::uint32_t(t));
    }
  }
  const double crease = std::cos(30.0 * M_PI / 180.0), flat = std::cos(0.5 * M_PI / 180.0);

  std::vector<Vec3d> out;
  SampleGrid grid(min_dist);
  Vec3d hint = Vec3d::Constant(std::numeric_limits<double>::infinity());
  /// Keeps p unless a sample lies within min_dist; true if it was kept.
  const auto offer = [&](const Vec3d& p, const Vec3d& n) {
    if ((p - hint).squaredNorm() < r2 || grid.near(p, r2, hint)) return false;
    grid.add(p);
    hint = p;
    out.push_back(p + offset * n);
    return true;
  };

  // Pass 1: feature edges.
  for (std::size_t e = 0; e < edges.size(); ++e)
  {
    const auto& tris = edge_triangles[e];
    const bool feature = tris.size() != 2 || normal[tris[0]].dot(normal[tris[1]]) < crease;
    if (!feature) continue;
    const Vec3d& a = mesh.vertices[edges[e][0]];
    const Vec3d& b = mesh.vertices[edges[e][1]];
    const int pieces = std::max(1, int(std::ceil((b - a).norm() / s - 1e-9)));
    for (int i = 0; i <= pieces; ++i) offer(a + (b - a) * (double(i) / pieces), normal[tris[0]]);
  }

  // Pass 2: planar patches, each with its own lattice. A patch grows from its first triangle
  // across manifold edges to triangles whose normal is within 0.5 degrees of the first one's and
  // whose corners lie within 0.01 s of its plane (so a finely tessellated curved surface does not
  // chain into one "plane").
  const auto edgeOf = [&](int i, int j) -> std::size_t {
    return edge_index.at((std::uint64_t(std::uint32_t(std::min(i, j))) << 32) | std::uint32_t(std::max(i, j)));
  };
  std::vector<std::int64_t> patch_id(num_triangles, -1);
  std::vector<std::vector<std::uint32_t>> patches;
  const double plane_tol = 0.01 * s;
  for (std::size_t seed = 0; seed < num_triangles; ++seed)
  {
    if (!valid[seed] || patch_id[seed] >= 0) continue;
    const std::int64_t id = static_cast<std::int64_t>(patches.size());
    patches.emplace_back();
    std::vector<std::uint32_t>& patch = patches.back();
    const Vec3d n0 = normal[seed];
    const Vec3d a0 = mesh.vertices[mesh.triangles[seed][0]];
    patch_id[seed] = id;
    patch.push_back(std::uint32_t(seed));
    for (std::size_t next = 0; next < patch.size(); ++next)  // breadth first; `patch` is the queue
    {
      const auto& tri = mesh.triangles[patch[next]];
      for (int k = 0; k < 3; ++k)
      {
        const auto& tris = edge_triangles[edgeOf(tri[k], tri[(k + 1) % 3])];
        if (tris.size() != 2) continue;
        const std::uint32_t w = tris[0] == patch[next] ? tris[1] : tris[0];
        if (patch_id[w] >= 0 || normal[w].dot(n0) <= flat) continue;
        bool coplanar = true;
        for (int c = 0; c < 3 && coplanar; ++c)
          coplanar = std::abs((mesh.vertices[mesh.triangles[w][c]] - a0).dot(n0)) <= plane_tol;
        if (!coplanar) continue;
        patch_id[w] = id;
        patch.push_back(w);
      }
    }
  }
  // Each patch's lattice, and which of its nodes are samples (for the fill).
  struct Lattice
  {
    Vec3d origin, u, v;
    double lo[2], step[2];
    std::unordered_set<std::uint64_t> present;  // node (i, j) as (i << 32 | j), offset by 2^31
  };
  std::vector<Lattice> lattices(patches.size());
  std::vector<std::uint32_t> patch_of(num_triangles, 0);
  const auto nodeKey = [](long long i, long long j) {
    return (std::uint64_t(std::uint32_t(i + (1LL << 31))) << 32) | std::uint32_t(j + (1LL << 31));
  };
  for (std::size_t pi = 0; pi < patches.size(); ++pi)
  {
    const auto& patch = patches[pi];
    Lattice& lattice = lattices[pi];
    for (std::uint32_t t : patch) patch_of[t] = std::uint32_t(pi);
    // Frame: u along a border edge, chosen so that as much of the border as possible runs along u
    // or across it (then the lattice meets those borders as the box primitive's lattice meets its
    // edges); ties go to the direction nearest a body axis, then to the longer edge. Without a
    // border (cannot happen for a planar patch of a valid mesh), the longest edge. v = n x u.
    const Vec3d n = normal[patch[0]];
    struct BorderEdge
    {
      int from, to;
      double length;
    };
    std::vector<BorderEdge> border;
    BorderEdge longest{mesh.triangles[patch[0]][0], mesh.triangles[patch[0]][1], -1.0};
    for (std::uint32_t t : patch)
      for (int k = 0; k < 3; ++k)
      {
        const int i = mesh.triangles[t][k], j = mesh.triangles[t][(k + 1) % 3];
        const auto& tris = edge_triangles[edgeOf(i, j)];
        const double length = (mesh.vertices[j] - mesh.vertices[i]).norm();
        if (tris.size() != 2 || patch_id[tris[0]] != patch_id[tris[1]]) border.push_back({i, j, length});
        if (length > longest.length) longest = {i, j, length};
      }
    std::stable_sort(border.begin(), border.end(),
                     [](const BorderEdge& a, const BorderEdge& b) { return a.length > b.length; });
    const double total_border = std::accumulate(border.begin(), border.end(), 0.0,
                                                [](double sum, const BorderEdge& e) { return sum + e.length; });
    BorderEdge chosen = border.empty() ? longest : border.front();
    double best_score = -1.0, best_axis = -1.0;
    for (std::size_t c = 0; c < std::min<std::size_t>(border.size(), 32); ++c)
    {
      const Vec3d d = (mesh.vertices[border[c].to] - mesh.vertices[border[c].from]) / border[c].length;
      double score = 0.0;
      for (const auto& e : border)
      {
        const double cosine = std::abs(d.dot(mesh.vertices[e.to] - mesh.vertices[e.from])) / e.length;
        if (cosine > 0.99996 || cosine < 0.0087) score += e.length;  // within 0.5 degrees
      }
      const double axis = d.cwiseAbs().maxCoeff();
      const double tol = 1e-5 * total_border;  // lengths read from float files differ in the 7th digit
      if (score > best_score + tol || (score > best_score - tol && axis > best_axis + 1e-12))
      {
        best_score = score;
        best_axis = axis;
        chosen = border[c];
      }
    }
    Vec3d origin = mesh.vertices[chosen.from];
    Vec3d u = (mesh.vertices[chosen.to] - mesh.vertices[chosen.from]).normalized();
    u = (u - u.dot(n) * n).normalized();
    const Vec3d v = n.cross(u);
    double lo[2] = {0.0, 0.0}, hi[2] = {0.0, 0.0};
    for (std::uint32_t t : patch)
      for (int k = 0; k < 3; ++k)
      {
        const Vec3d d = mesh.vertices[mesh.triangles[t][k]] - origin;
        lo[0] = std::min(lo[0], d.dot(u));
        hi[0] = std::max(hi[0], d.dot(u));
        lo[1] = std::min(lo[1], d.dot(v));
        hi[1] = std::max(hi[1], d.dot(v));
      }
    double step[2];
    for (int k = 0; k < 2; ++k) step[k] = (hi[k] - lo[k]) / std::max(1, int(std::ceil((hi[k] - lo[k]) / s - 1e-9)));
    lattice.origin = origin;
    lattice.u = u;
    lattice.v = v;
    for (int k = 0; k < 2; ++k)
    {
      lattice.lo[k] = lo[k];
      lattice.step[k] = step[k];
    }
    if (!(step[0] > 0.0) || !(step[1] > 0.0)) continue;
    const double eps = 1e-9 * s;
    for (std::uint32_t t : patch)
    {
      double q[3][2];
      for (int k = 0; k < 3; ++k)
      {
        const Vec3d d = mesh.vertices[mesh.triangles[t][k]] - origin;
        q[k][0] = d.dot(u);
        q[k][1] = d.dot(v);
      }
      const double area2 = (q[1][0] - q[0][0]) * (q[2][1] - q[0][1]) - (q[2][0] - q[0][0]) * (q[1][1] - q[0][1]);
      const int i0 = int(std::ceil((std::min({q[0][0], q[1][0], q[2][0]}) - lo[0]) / step[0] - 1e-9));
      const int i1 = int(std::floor((std::max({q[0][0], q[1][0], q[2][0]}) - lo[0]) / step[0] + 1e-9));
      const int j0 = int(std::ceil((std::min({q[0][1], q[1][1], q[2][1]}) - lo[1]) / step[1] - 1e-9));
      const int j1 = int(std::floor((std::max({q[0][1], q[1][1], q[2][1]}) - lo[1]) / step[1] + 1e-9));
      const Vec3d& a = mesh.vertices[mesh.triangles[t][0]];
      for (int j = j0; j <= j1; ++j)
        for (int i = i0; i <= i1; ++i)
        {
          const double x = lo[0] + i * step[0], y = lo[1] + j * step[1];
          // Inside (or on the border of) the triangle: all three edge functions of the triangle's sign.
          bool inside = true;
          for (int k = 0; k < 3 && inside; ++k)
          {
            const double* p0 = q[k];
            const double* p1 = q[(k + 1) % 3];
            const double side = (p1[0] - p0[0]) * (y - p0[1]) - (x - p0[0]) * (p1[1] - p0[1]);
            inside = (area2 > 0.0 ? side : -side) >= -eps * std::hypot(p1[0] - p0[0], p1[1] - p0[1]);
          }
          if (!inside) continue;
          Vec3d p = origin + x * u + y * v;
          p -= (p - a).dot(normal[t]) * normal[t];  // onto the triangle's own plane
          Vec3d coincident;
          if (offer(p, normal[t]) || grid.near(p, 1e-12 * s * s, coincident)) lattice.present.insert(nodeKey(i, j));
        }
    }
  }

  // Pass 3: fill what the lattices left open (seams, slanted borders, curved surfaces).
  // Neighbouring candidates mostly fall in the same lattice cell: remember the last cell's answer.
  std::int64_t last_patch = -1;
  long long last_i = 0, last_j = 0;
  bool last_complete = false;
  forEachCandidate(mesh, 0.1 * s, 0.05 * s, [&](const Vec3d& p, const Vec3d& n, std::size_t t) {
    if ((p - hint).squaredNorm() < r2) return;  // the cheapest rejection first
    const Lattice& lattice = lattices[patch_of[t]];
    if (!lattice.present.empty() && lattice.step[0] > 0.0 && lattice.step[1] > 0.0)
    {
      const Vec3d d = p - lattice.origin;
      const long long i = (long long)std::floor((d.dot(lattice.u) - lattice.lo[0]) / lattice.step[0]);
      const long long j = (long long)std::floor((d.dot(lattice.v) - lattice.lo[1]) / lattice.step[1]);
      if (std::int64_t(patch_of[t]) != last_patch || i != last_i || j != last_j)
      {
        const auto& present = lattice.present;
        last_patch = patch_of[t];
        last_i = i;
        last_j = j;
        last_complete = present.count(nodeKey(i, j)) && present.count(nodeKey(i + 1, j)) &&
                        present.count(nodeKey(i, j + 1)) && present.count(nodeKey(i + 1, j + 1));
      }
      if (last_complete) return;  // inside a complete lattice cell
    }
    offer(p, n);
  });
  return out;
}

TriangleMesh offsetMesh(const TriangleMesh& mesh, double offset)
{
  // Each vertex moves by the d that best satisfies d . n_f = offset for the faces around it
  // (weighted by the face's angle at the vertex): d = offset n on a flat patch, the mitred corner
  // offset * (n1 + n2 + n3) at a box corner. Directions the faces do not constrain (the tangent
  // plane of a flat patch) get no motion: the pseudo-inverse drops eigenvalues below 1 % of the
  // largest. |d| is capped at 3 |offset| (sharp spikes).
  TriangleMesh out;
  out.vertices = mesh.vertices;
  out.triangles = mesh.triangles;
  if (offset == 0.0) return out;
  std::vector<Mat3d> a(mesh.vertices.size(), Mat3d::Zero());
  std::vector<Vec3d> b(mesh.vertices.size(), Vec3d::Zero());
  for (const auto& t : mesh.triangles)
  {
    const Vec3d n = (mesh.vertices[t[1]] - mesh.vertices[t[0]]).cross(mesh.vertices[t[2]] - mesh.vertices[t[0]]);
    const double length = n.norm();
    if (!(length > 0.0) || !std::isfinite(length)) continue;
    const Vec3d unit = n / length;
    for (int k = 0; k < 3; ++k)
    {
      const Vec3d e1 = mesh.vertices[t[(k + 1) % 3]] - mesh.vertices[t[k]];
      const Vec3d e2 = mesh.vertices[t[(k + 2) % 3]] - mesh.vertices[t[k]];
      const double angle = std::atan2(e1.cross(e2).norm(), e1.dot(e2));  // rad, at vertex t[k]
      a[t[k]] += angle * unit * unit.transpose();
      b[t[k]] += angle * offset * unit;
    }
  }
  for (std::size_t i = 0; i < out.vertices.size(); ++i)
  {
    const Eigen::SelfAdjointEigenSolver<Mat3d> eig(a[i]);
    const double largest = eig.eigenvalues().maxCoeff();
    if (!(largest > 0.0)) continue;
    Vec3d d = Vec3d::Zero();
    for (int k = 0; k < 3; ++k)
      if (eig.eigenvalues()[k] > 0.01 * largest)
        d += eig.eigenvectors().col(k) * (eig.eigenvectors().col(k).dot(b[i]) / eig.eigenvalues()[k]);
    const double cap = 3.0 * std::abs(offset);
    if (d.norm() > cap) d *= cap / d.norm();
    out.vertices[i] += d;
  }
  return out;
}

double meshArea(const TriangleMesh& mesh)
{
  double area = 0.0;
  for (const auto& t : mesh.triangles)
  {
    const Vec3d& a = mesh.vertices[t[0]];
    area += 0.5 * (mesh.vertices[t[1]] - a).cross(mesh.vertices[t[2]] - a).norm();
  }
  return area;
}

double estimateBoundaryParticles(const BoundaryConfig& b, double s, double fluid_spacing)
{
  // The primitives count exactly what sampleBoundary() makes, from their sizes alone.
  if (!(s > 0.0)) return std::numeric_limits<double>::infinity();
  const double grow = b.inside ? 0.5 * fluid_spacing : -0.5 * fluid_spacing;
  // divisions() in double: a huge body at a tiny spacing must not overflow an int.
  const auto pieces = [s](double length) { return length <= 0.0 ? 0.0 : std::max(1.0, std::ceil(length / s - 1e-9)); };
  switch (b.type)
  {
    case ShapeType::Box:
    {
      const Vec3d mid = 0.5 * (b.box.min + b.box.max);
      const Vec3d lo = (b.box.min - Vec3d::Constant(grow)).cwiseMin(mid);
      const Vec3d hi = (b.box.max + Vec3d::Constant(grow)).cwiseMax(mid);
      double all = 1.0, interior = 1.0;
      for (int k = 0; k < 3; ++k)
      {
        const double n = pieces(std::max(0.0, hi[k] - lo[k]));
        all *= n + 1.0;
        interior *= std::max(0.0, n - 1.0);
      }
      return all - interior;
    }
    case ShapeType::Sphere:
    {
      const double r = std::max(0.0, b.sphere.radius + grow);
      return r <= 0.0 ? 1.0 : std::max(1.0, std::ceil(4.0 * M_PI * r * r / (std::sqrt(3.0) / 2.0 * s * s)));
    }
    case ShapeType::Cylinder:
    {
      const double r = std::max(0.0, b.cylinder.radius + grow);
      const double len = std::max(0.0, b.cylinder.length + 2.0 * grow);
      double count = (pieces(len) + 1.0) * std::max(3.0, std::ceil(2.0 * M_PI * r / s));
      const double rings = pieces(r);
      if (rings > 1e7) return std::numeric_limits<double>::infinity();
      for (int side = 0; side < 2; ++side)
      {
        count += 1.0;
        for (int k = 1; k < int(rings); ++k) count += std::max(3.0, std::ceil(2.0 * M_PI * (r * k / rings) / s));
      }
      return count;
    }
    case ShapeType::Mesh:
      // Measured 1.0-1.8 samples per s^2 (box faces 1.0, fine tessellations 1.5-1.8); the packing
      // bound for a minimum distance of 0.66 s is 2.65.
      return 2.0 * meshArea(b.mesh) / (s * s);
  }
  return 0.0;
}

std::vector<Vec3d> sampleBoundary(const BoundaryConfig& b, double s, double fluid_spacing)
{
  // Half a fluid spacing into the solid, or out of a container (METHOD.md engineering choice).
  const double half = 0.5 * fluid_spacing;
  const double grow = b.inside ? half : -half;
  std::vector<Vec3d> pts;
  switch (b.type)
  {
    case ShapeType::Box:
    {
      AxisBox box = b.box;
      box.min -= Vec3d::Constant(grow);
      box.max += Vec3d::Constant(grow);
      const Vec3d mid = 0.5 * (b.box.min + b.box.max);
      box.min = box.min.cwiseMin(mid);
      box.max = box.max.cwiseMax(mid);
      pts = sampleBoxSurface(box, s);
      break;
    }
    case ShapeType::Sphere:
      pts = sampleSphereSurface(b.sphere.center, std::max(0.0, b.sphere.radius + grow), s);
      break;
    case ShapeType::Cylinder:
    {
      CylinderShape c = b.cylinder;
      c.radius = std::max(0.0, c.radius + grow);
      c.length = std::max(0.0, c.length + 2.0 * grow);
      pts = sampleCylinderSurface(c, s);
      break;
    }
    case ShapeType::Mesh:
    {
      // Outward normals assumed (closed meshes); open meshes lie on their surface. The offset
      // surface is sampled (not the samples offset), so that the layer has no gaps along edges.
      const double offset = (b.mesh_offset == SurfaceOffset::None || !b.mesh_closed) ? 0.0 : grow;
      pts = sampleMeshSurface(offset == 0.0 ? b.mesh : offsetMesh(b.mesh, offset), s, 0.0);
      break;
    }
  }
  sortByCell(pts, 2.0 * fluid_spacing);
  return pts;
}

bool insideShape(const BoundaryConfig& b, const Vec3d& p)
{
  switch (b.type)
  {
    case ShapeType::Box:
      return (p.array() > b.box.min.array()).all() && (p.array() < b.box.max.array()).all();
    case ShapeType::Sphere:
      return (p - b.sphere.center).squaredNorm() < b.sphere.radius * b.sphere.radius;
    case ShapeType::Cylinder:
    {
      const Vec3d a = b.cylinder.axis.normalized();
      const Vec3d d = p - b.cylinder.center;
      const double t = d.dot(a);
      return std::abs(t) < 0.5 * b.cylinder.length && (d - t * a).squaredNorm() < b.cylinder.radius * b.cylinder.radius;
    }
    case ShapeType::Mesh:
    {
      if (!b.mesh_closed) return false;
      const auto& index = b.mesh.inside_index;
      return (index && index->matches(b.mesh) ? index->winding(b.mesh, p) : windingNumber(b.mesh, p)) > 0;
    }
  }
  return false;
}

double flatLayerVolumeFactor(double spacing, double support)
{
  // gamma = s^3 * sum over a square lattice of spacing s in a plane of W(r): then a flat layer of
  // spacing s gets V_b = s^3, the volume of the fluid layer it stands in for.
  const CubicKernel kernel{Real(support)};
  const int reach = int(std::ceil(support / spacing));
  double sum = 0.0;
  for (int j = -reach; j <= reach; ++j)
    for (int i = -reach; i <= reach; ++i) sum += kernel.W(Real(spacing * std::sqrt(double(i * i + j * j))));
  return spacing * spacing * spacing * sum;
}

std::vector<Real> boundaryVolumes(const std::vector<Vec3d>& points, double support, double gamma)
{
  std::vector<Real> volumes(points.size(), Real(0));
  if (points.empty()) return volumes;
  Vec3d lo = points[0], hi = points[0];
  for (const auto& p : points)
  {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  // Local frame around the bounding box centre keeps float coordinates precise.
  const Vec3d centre = 0.5 * (lo + hi);
  std::vector<Vec3> local(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) local[i] = (points[i] - centre).cast<Real>();
  UniformGrid grid(lo - centre, hi - centre, support, 1);
  grid.build(local);
  std::vector<Vec3> sorted(local.size());
  for (std::size_t k = 0; k < local.size(); ++k) sorted[k] = local[grid.order()[k]];
  const CubicKernel kernel{Real(support)};
  const Real h2 = Real(support * support);
  for (std::size_t i = 0; i < local.size(); ++i)
  {
    double sum = 0.0;
    grid.forEachRange(local[i], 1, [&](Index begin, Index end) {
      for (Index k = begin; k < end; ++k)
      {
        const Real d2 = (local[i] - sorted[k]).squaredNorm();
        if (d2 < h2) sum += kernel.W(std::sqrt(d2));
      }
    });
    volumes[i] = Real(gamma / sum);  // sum > 0: it includes the point itself
  }
  return volumes;
}

void sortByCell(std::vector<Vec3d>& points, double cell)
{
  std::vector<std::pair<std::tuple<long long, long long, long long>, std::size_t>> keys(points.size());
  for (std::size_t i = 0; i < points.size(); ++i)
  {
    const CellKey k = keyOf(points[i], cell);
    keys[i] = {{k.z, k.y, k.x}, i};
  }
  std::sort(keys.begin(), keys.end());
  std::vector<Vec3d> out(points.size());
  for (std::size_t i = 0; i < keys.size(); ++i) out[i] = points[keys[i].second];
  points.swap(out);
}

}  // namespace fluid_sim
