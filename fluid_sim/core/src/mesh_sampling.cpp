// Boundary samples on a triangle mesh (sampleMeshSurface) and its area. Three passes write into
// one set of samples, each keeping a candidate only if no sample lies within 0.66 s, and a fourth
// moves some of them:
//  1. edges and corners: the feature edges (borders, and creases sharper than 30 degrees), each
//     divided evenly into pieces <= s, ends included, as the box primitive samples its edges;
//  2. face lattices: on every planar patch (neighbouring triangles within 0.5 degrees), a lattice
//     of spacing <= s stretched to fit the patch, aligned with its border; a box face gets exactly
//     the box primitive's lattice;
//  3. the fill: candidates on rows 0.05 s apart, points <= 0.1 s apart along them (every surface
//     point lies within 0.071 s of one), kept where they are still farther than 0.66 s from every
//     sample, except inside a lattice cell whose four corners are all samples (every point of such
//     a cell lies within 0.71 s of a corner).
// So no surface point is farther than max(0.71 s, 0.66 s + 0.071 s) < 0.74 s from a sample.
// Samples closer than a lattice spacing (fill points near slanted borders) are kept few on
// purpose: the boundary volumes V_b = gamma / sum W (Eq. A3, docs/method.md) of a locally denser
// layer came out weaker at concave folds (a mesh tank's floor lost particles near its walls;
// 0.66 s measured better than 0.62 s or 0.5 s).
//  4. the ragged borders: the fill's samples and the lattice nodes near a lattice's ragged border
//     move apart on the surface as a soft-sphere gas (Eq. A32), never closer than 0.66 s to
//     another sample, so that the holes and clusters the fill leaves beside a curved rim even out
//     (relaxFreeSamples). It moves no sample of a mesh whose patches hold whole lattices (boxes);
//     the coverage above is then measured, not guaranteed (every test mesh: within 0.72 s).
// Deterministic (fixed orders); time and memory about linear in the area: the grid holds samples
// only, and the sample that rejected the previous candidate is tried first. The offset surface
// that sampleBoundary() samples for a closed mesh is offsetMesh() (mesh_offset.cpp).

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <tuple>
#include <unordered_map>
#include <unordered_set>

#include "fluid_sim/core/boundary_sampling.h"
#include "fluid_sim/core/cell_key.h"
#include "fluid_sim/core/parallel.h"

namespace fluid_sim
{
namespace
{
/// Pieces of at most s an edge or a patch is divided into: ceil(length / s), less this slack.
/// Mesh files hold float32 coordinates (STL by its format, the others through assimp), so a 0.3 m
/// tank wall offset by half a spacing reads 0.32000001 m: at 2 cm that is 16.0000006 spacings,
/// and without the slack 17 pieces of 1.88 cm, a denser layer than the box primitive's 16 of
/// 2 cm (1,736 particles for its 1,538). A piece at most 0.1 % longer than s changes nothing.
constexpr double kPieceSlack = 1e-3;

// ------------------------------------------------------------------------------------ the mesh

/// Unit normals of the triangles that have an area; the others are skipped by every pass.
struct TriangleNormals
{
  std::vector<Vec3d> normal;   // unit-less, per triangle, as wound; zero for a degenerate one
  std::vector<char> valid;     // per triangle: 1 if it has an area
  std::size_t degenerate = 0;  // number of triangles without an area
};

/// a x b, out of line on purpose: with -march=native GCC fuses a*b - c*d into a multiply-add and
/// picks which product to fuse by context. Inlined into the small normals loop it picks otherwise
/// than it did while the sampler was one large function, and the samples would move in the last
/// bits. Out of line it computes as Eigen's out-of-line cross product did before (bit-identical
/// samples; checked on every shipped mesh).
template <typename A, typename B>
[[gnu::noinline]] Vec3d crossProduct(const Eigen::MatrixBase<A>& a, const Eigen::MatrixBase<B>& b)
{
  return a.cross(b);
}

TriangleNormals triangleNormals(const TriangleMesh& mesh)
{
  const std::size_t num_triangles = mesh.triangles.size();
  TriangleNormals out;
  out.normal.assign(num_triangles, Vec3d::Zero());
  out.valid.assign(num_triangles, 0);
  for (std::size_t t = 0; t < num_triangles; ++t)
  {
    const auto& tri = mesh.triangles[t];
    const Vec3d& a = mesh.vertices[tri[0]];
    const Vec3d n = crossProduct(mesh.vertices[tri[1]] - a, mesh.vertices[tri[2]] - a);
    const double longest = std::max({(mesh.vertices[tri[1]] - a).norm(), (mesh.vertices[tri[2]] - a).norm(),
                                     (mesh.vertices[tri[2]] - mesh.vertices[tri[1]]).norm()});
    if (!(n.norm() > 1e-12 * longest * longest) || !std::isfinite(n.norm()))
    {
      ++out.degenerate;
      continue;
    }
    out.normal[t] = n.normalized();
    out.valid[t] = 1;
  }
  return out;
}

/// The undirected edges of the valid triangles, in order of first appearance, and the valid
/// triangles along each (two on a closed manifold surface, one on a border).
class EdgeTable
{
public:
  EdgeTable(const TriangleMesh& mesh, const std::vector<char>& valid)
  {
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
    {
      if (!valid[t]) continue;
      for (int k = 0; k < 3; ++k)
      {
        const int i = mesh.triangles[t][k], j = mesh.triangles[t][(k + 1) % 3];
        const auto [it, inserted] = index_.emplace(key(i, j), ends_.size());
        if (inserted)
        {
          ends_.push_back({std::min(i, j), std::max(i, j)});
          triangles_.emplace_back();
        }
        triangles_[it->second].push_back(std::uint32_t(t));
      }
    }
  }

  std::size_t size() const
  {
    return ends_.size();
  }
  /// Vertex indices of edge e, smaller first.
  const std::array<int, 2>& ends(std::size_t e) const
  {
    return ends_[e];
  }
  /// The triangles along edge e, in index order.
  const std::vector<std::uint32_t>& triangles(std::size_t e) const
  {
    return triangles_[e];
  }
  /// The triangles along the edge between vertices i and j, which must be an edge of a valid triangle.
  const std::vector<std::uint32_t>& trianglesAlong(int i, int j) const
  {
    return triangles_[index_.at(key(i, j))];
  }

private:
  static std::uint64_t key(int i, int j)
  {
    return (std::uint64_t(std::uint32_t(std::min(i, j))) << 32) | std::uint32_t(std::max(i, j));
  }

  std::unordered_map<std::uint64_t, std::size_t> index_;  // key(i, j) -> edge
  std::vector<std::array<int, 2>> ends_;
  std::vector<std::vector<std::uint32_t>> triangles_;
};

// --------------------------------------------------------------------------------- the samples

/// Accepted samples in a hash grid whose cells are twice the largest query radius: a ball of that
/// radius overlaps only the 2 x 2 x 2 cells nearest to its centre.
class SampleGrid
{
public:
  explicit SampleGrid(double max_radius) : cell_(2.0 * max_radius) {}
  /// True if a sample lies closer than sqrt(r2) (<= max_radius) to p; then `hint` is that sample.
  bool near(const Vec3d& p, double r2, Vec3d& hint) const
  {
    const CellKey k = cellKeyOf(p, cell_);
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
    cells_[cellKeyOf(p, cell_)].push_back(p);
  }

private:
  double cell_;  // m, cell edge
  std::unordered_map<CellKey, std::vector<Vec3d>, CellKeyHash> cells_;
};

/// The samples kept so far by the passes, in the order they were kept.
class SampleSet
{
public:
  /// Samples at least 0.66 s (m) apart, each stored moved by `offset` (m) along its normal.
  SampleSet(double s, double offset)
      : s_(s), offset_(offset), min_dist_(0.66 * s), r2_(min_dist_ * min_dist_), grid_(min_dist_)
  {
  }

  /// Where a sample came from: which pass, and for the lattices and the fill its triangle (and
  /// so its patch) and for a lattice its node; relaxFreeSamples() moves the fill's samples and
  /// the lattice nodes at a lattice's ragged border.
  struct Origin
  {
    enum Kind : char
    {
      kEdge,
      kLattice,
      kFill
    } kind = kEdge;
    std::int64_t triangle = -1;  // the triangle it was offered on (lattice, fill)
    std::uint64_t node = 0;      // latticeNode(i, j) (lattice)
  };

  /// Keeps p (with unit normal n) unless a sample lies within 0.66 s; true if it was kept.
  bool offer(const Vec3d& p, const Vec3d& n)
  {
    return offer(p, n, Origin{Origin::kEdge, -1, 0});
  }
  bool offer(const Vec3d& p, const Vec3d& n, const Origin& origin)
  {
    if (nearHint(p) || grid_.near(p, r2_, hint_)) return false;
    grid_.add(p);
    hint_ = p;
    points_.push_back(p);
    normals_.push_back(n);
    origins_.push_back(origin);
    return true;
  }
  /// True if the hint (the sample kept last, or the one that rejected the last candidate) lies
  /// within 0.66 s of p: neighbouring candidates are mostly rejected by the same sample, so the
  /// passes try it before the grid.
  bool nearHint(const Vec3d& p) const
  {
    return (p - hint_).squaredNorm() < r2_;
  }
  /// True if a sample lies at p (within 1e-6 s).
  bool coincides(const Vec3d& p) const
  {
    Vec3d coincident;
    return grid_.near(p, 1e-12 * s_ * s_, coincident);
  }
  std::size_t size() const
  {
    return points_.size();
  }
  /// m, on the surface (before the offset).
  const Vec3d& point(std::size_t k) const
  {
    return points_[k];
  }
  /// Moves sample k to p on a triangle with unit normal n (relaxFreeSamples()); the grid that
  /// offer() checks is not updated (the passes that offer are done by then).
  void moveTo(std::size_t k, const Vec3d& p, const Vec3d& n)
  {
    points_[k] = p;
    normals_[k] = n;
  }
  const Vec3d& normal(std::size_t k) const
  {
    return normals_[k];
  }
  const Origin& origin(std::size_t k) const
  {
    return origins_[k];
  }
  /// The samples, each moved by the offset along its normal.
  std::vector<Vec3d> take() const
  {
    std::vector<Vec3d> out(points_.size());
    for (std::size_t k = 0; k < points_.size(); ++k) out[k] = points_[k] + offset_ * normals_[k];
    return out;
  }

private:
  double s_;         // m, sample spacing
  double offset_;    // m, along the normal
  double min_dist_;  // m, smallest distance between two samples (0.66 s)
  double r2_;        // m^2, min_dist_ squared
  SampleGrid grid_;
  Vec3d hint_ = Vec3d::Constant(std::numeric_limits<double>::infinity());  // m, see nearHint()
  std::vector<Vec3d> points_;                                              // m, on the surface
  std::vector<Vec3d> normals_;                                             // unit-less
  std::vector<Origin> origins_;
};

// ------------------------------------------------------------------- pass 1: edges and corners

/// Offers the points of every feature edge (a border, or a crease sharper than 30 degrees),
/// divided evenly into pieces <= s (m; within kPieceSlack), both ends included.
void sampleFeatureEdges(const TriangleMesh& mesh, const TriangleNormals& faces, const EdgeTable& edges, double s,
                        SampleSet& samples)
{
  const double crease = std::cos(30.0 * M_PI / 180.0);
  for (std::size_t e = 0; e < edges.size(); ++e)
  {
    const auto& tris = edges.triangles(e);
    const bool feature = tris.size() != 2 || faces.normal[tris[0]].dot(faces.normal[tris[1]]) < crease;
    if (!feature) continue;
    const Vec3d& a = mesh.vertices[edges.ends(e)[0]];
    const Vec3d& b = mesh.vertices[edges.ends(e)[1]];
    const int pieces = std::max(1, int(std::ceil((b - a).norm() / s - kPieceSlack)));
    for (int i = 0; i <= pieces; ++i) samples.offer(a + (b - a) * (double(i) / pieces), faces.normal[tris[0]]);
  }
}

// --------------------------------------------------------------------- pass 2: face lattices

/// The planar patches of the mesh: each grows from its first triangle across manifold edges to
/// triangles whose normal is within 0.5 degrees of the first one's and whose corners lie within
/// 0.01 s of its plane (so that a finely tessellated curved surface does not chain into one
/// "plane").
struct PlanarPatches
{
  std::vector<std::vector<std::uint32_t>> triangles;  // per patch, in the order it grew
  std::vector<std::int64_t> id;                       // per triangle: its patch, -1 if degenerate
};

PlanarPatches planarPatches(const TriangleMesh& mesh, const TriangleNormals& faces, const EdgeTable& edges, double s)
{
  const std::size_t num_triangles = mesh.triangles.size();
  const double flat = std::cos(0.5 * M_PI / 180.0);
  const double plane_tol = 0.01 * s;  // m
  PlanarPatches patches;
  patches.id.assign(num_triangles, -1);
  for (std::size_t seed = 0; seed < num_triangles; ++seed)
  {
    if (!faces.valid[seed] || patches.id[seed] >= 0) continue;
    const std::int64_t id = static_cast<std::int64_t>(patches.triangles.size());
    patches.triangles.emplace_back();
    std::vector<std::uint32_t>& patch = patches.triangles.back();
    const Vec3d n0 = faces.normal[seed];
    const Vec3d a0 = mesh.vertices[mesh.triangles[seed][0]];
    patches.id[seed] = id;
    patch.push_back(std::uint32_t(seed));
    for (std::size_t next = 0; next < patch.size(); ++next)  // breadth first; `patch` is the queue
    {
      const auto& tri = mesh.triangles[patch[next]];
      for (int k = 0; k < 3; ++k)
      {
        const auto& tris = edges.trianglesAlong(tri[k], tri[(k + 1) % 3]);
        if (tris.size() != 2) continue;
        const std::uint32_t w = tris[0] == patch[next] ? tris[1] : tris[0];
        if (patches.id[w] >= 0 || faces.normal[w].dot(n0) <= flat) continue;
        bool coplanar = true;
        for (int c = 0; c < 3 && coplanar; ++c)
          coplanar = std::abs((mesh.vertices[mesh.triangles[w][c]] - a0).dot(n0)) <= plane_tol;
        if (!coplanar) continue;
        patches.id[w] = id;
        patch.push_back(w);
      }
    }
  }
  return patches;
}

/// A patch's lattice: nodes at origin + (lo[0] + i step[0]) u + (lo[1] + j step[1]) v.
struct Lattice
{
  Vec3d origin;                               // m, a corner of the patch's border
  Vec3d u, v;                                 // unit-less, in the patch's plane; v = n x u
  double lo[2];                               // m, the patch's extent along u and v from origin, lower end
  double step[2];                             // m, node spacing along u and v (<= s)
  std::unordered_set<std::uint64_t> present;  // nodes that are samples, as latticeNode(i, j)
};

/// Key of lattice node (i, j): (i << 32 | j), each offset by 2^31.
std::uint64_t latticeNode(long long i, long long j)
{
  return (std::uint64_t(std::uint32_t(i + (1LL << 31))) << 32) | std::uint32_t(j + (1LL << 31));
}

struct DirectedEdge
{
  int from, to;   // vertex indices
  double length;  // m
};

/// The edge the lattice's u axis runs along: a border edge of the patch, chosen so that as much of
/// the border as possible runs along u or across it (then the lattice meets those borders as the
/// box primitive's lattice meets its edges); ties go to the direction nearest a body axis, then to
/// the longer edge. Without a border (cannot happen for a planar patch of a valid mesh), the
/// longest edge.
DirectedEdge latticeAxisEdge(const TriangleMesh& mesh, const std::vector<std::uint32_t>& patch,
                             const PlanarPatches& patches, const EdgeTable& edges)
{
  std::vector<DirectedEdge> border;
  DirectedEdge longest{mesh.triangles[patch[0]][0], mesh.triangles[patch[0]][1], -1.0};
  for (std::uint32_t t : patch)
    for (int k = 0; k < 3; ++k)
    {
      const int i = mesh.triangles[t][k], j = mesh.triangles[t][(k + 1) % 3];
      const auto& tris = edges.trianglesAlong(i, j);
      const double length = (mesh.vertices[j] - mesh.vertices[i]).norm();
      if (tris.size() != 2 || patches.id[tris[0]] != patches.id[tris[1]]) border.push_back({i, j, length});
      if (length > longest.length) longest = {i, j, length};
    }
  std::stable_sort(border.begin(), border.end(),
                   [](const DirectedEdge& a, const DirectedEdge& b) { return a.length > b.length; });
  const double total_border = std::accumulate(border.begin(), border.end(), 0.0,
                                              [](double sum, const DirectedEdge& e) { return sum + e.length; });
  DirectedEdge chosen = border.empty() ? longest : border.front();
  double best_score = -1.0, best_axis = -1.0;
  for (std::size_t c = 0; c < std::min<std::size_t>(border.size(), 32); ++c)
  {
    const Vec3d d = (mesh.vertices[border[c].to] - mesh.vertices[border[c].from]) / border[c].length;
    double score = 0.0;  // m, border length along or across d
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
  return chosen;
}

/// The lattice of a patch with unit normal n: u along latticeAxisEdge(), spacing <= s (m) per axis,
/// stretched so that nodes fall on both ends of the patch's extent.
Lattice patchLattice(const TriangleMesh& mesh, const std::vector<std::uint32_t>& patch, const Vec3d& n,
                     const PlanarPatches& patches, const EdgeTable& edges, double s)
{
  const DirectedEdge axis = latticeAxisEdge(mesh, patch, patches, edges);
  const Vec3d origin = mesh.vertices[axis.from];
  Vec3d u = (mesh.vertices[axis.to] - mesh.vertices[axis.from]).normalized();
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
  Lattice lattice;
  lattice.origin = origin;
  lattice.u = u;
  lattice.v = v;
  for (int k = 0; k < 2; ++k)
  {
    lattice.lo[k] = lo[k];
    lattice.step[k] = (hi[k] - lo[k]) / std::max(1, int(std::ceil((hi[k] - lo[k]) / s - kPieceSlack)));
  }
  return lattice;
}

/// Offers the lattice nodes that lie in (or on the border of) the patch's triangles, each moved
/// onto its triangle's plane, and records in lattice.present the nodes that are samples (kept now,
/// or coinciding with one kept before, e.g. on a feature edge).
void sampleLattice(const TriangleMesh& mesh, const std::vector<std::uint32_t>& patch, const std::vector<Vec3d>& normal,
                   double s, Lattice& lattice, SampleSet& samples)
{
  const double* lo = lattice.lo;
  const double* step = lattice.step;
  // Nodes on a patch's border count within kNodeSlack (of a lattice step, and of s for the edge
  // test): a mesh file's float32 corners, scaled, put border nodes a few 1e-9 m outside the patch
  // (an L-shaped tank's STL at scale 1.6: a lattice step of 0.0200000008 m). Left out there, the
  // cells along the border counted as incomplete and the fill put a sample at each one's centre:
  // 66 extra particles along the inner floor edges, whose volumes (Eq. A3) fell to 0.56-0.66 s^3,
  // and single-term mirroring's weakened floor let most of the water through it.
  constexpr double kNodeSlack = 1e-6;
  const double eps = kNodeSlack * s;  // m
  for (std::uint32_t t : patch)
  {
    double q[3][2];  // m, the corners in lattice coordinates (u, v)
    for (int k = 0; k < 3; ++k)
    {
      const Vec3d d = mesh.vertices[mesh.triangles[t][k]] - lattice.origin;
      q[k][0] = d.dot(lattice.u);
      q[k][1] = d.dot(lattice.v);
    }
    const double area2 = (q[1][0] - q[0][0]) * (q[2][1] - q[0][1]) - (q[2][0] - q[0][0]) * (q[1][1] - q[0][1]);
    // The nodes of the triangle's bounding rectangle.
    const int i0 = int(std::ceil((std::min({q[0][0], q[1][0], q[2][0]}) - lo[0]) / step[0] - kNodeSlack));
    const int i1 = int(std::floor((std::max({q[0][0], q[1][0], q[2][0]}) - lo[0]) / step[0] + kNodeSlack));
    const int j0 = int(std::ceil((std::min({q[0][1], q[1][1], q[2][1]}) - lo[1]) / step[1] - kNodeSlack));
    const int j1 = int(std::floor((std::max({q[0][1], q[1][1], q[2][1]}) - lo[1]) / step[1] + kNodeSlack));
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
        Vec3d p = lattice.origin + x * lattice.u + y * lattice.v;
        p -= (p - a).dot(normal[t]) * normal[t];  // onto the triangle's own plane
        if (samples.offer(p, normal[t], {SampleSet::Origin::kLattice, std::int64_t(t), latticeNode(i, j)}) ||
            samples.coincides(p))
          lattice.present.insert(latticeNode(i, j));
      }
  }
}

// ---------------------------------------------------------------------------- pass 3: the fill

/// Calls f(point, unit normal, triangle index) for candidate points on every non-degenerate triangle: rows
/// parallel to the triangle's longest edge, `row` apart, each with points at most `step` apart
/// including both ends. Because the angles at the longest edge are acute, every point of the
/// triangle projects onto the row below it, so it lies within sqrt(row^2 + (step/2)^2) of a
/// candidate; the work per triangle is O(area / (row step) + edge / step), also for slivers.
/// Out of line for the same reason as crossProduct(): the normals it passes on stay bit-identical.
template <typename F>
[[gnu::noinline]] void forEachCandidate(const TriangleMesh& mesh, double step, double row, F&& f)
{
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
      continue;
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
}

/// Tells whether a point of a patch lies in a cell of the patch's lattice whose four corner nodes
/// are all samples (every point of such a cell lies within 0.71 s of a sample). Neighbouring
/// candidates mostly fall in the same cell: the last cell's answer is remembered.
class CompleteCells
{
public:
  explicit CompleteCells(const std::vector<Lattice>& lattices) : lattices_(lattices) {}

  bool contain(std::uint32_t patch, const Vec3d& p)
  {
    if (patch >= lattices_.size()) return false;
    const Lattice& lattice = lattices_[patch];
    if (lattice.present.empty() || !(lattice.step[0] > 0.0) || !(lattice.step[1] > 0.0)) return false;
    const Vec3d d = p - lattice.origin;
    const long long i = (long long)std::floor((d.dot(lattice.u) - lattice.lo[0]) / lattice.step[0]);
    const long long j = (long long)std::floor((d.dot(lattice.v) - lattice.lo[1]) / lattice.step[1]);
    if (std::int64_t(patch) != last_patch_ || i != last_i_ || j != last_j_)
    {
      const auto& present = lattice.present;
      last_patch_ = patch;
      last_i_ = i;
      last_j_ = j;
      last_complete_ = present.count(latticeNode(i, j)) && present.count(latticeNode(i + 1, j)) &&
                       present.count(latticeNode(i, j + 1)) && present.count(latticeNode(i + 1, j + 1));
    }
    return last_complete_;
  }

private:
  const std::vector<Lattice>& lattices_;
  std::int64_t last_patch_ = -1;  // the cell asked about last: its patch and node (i, j)
  long long last_i_ = 0, last_j_ = 0;
  bool last_complete_ = false;
};

/// Offers dense candidates (forEachCandidate with points 0.1 s apart on rows 0.05 s apart) that
/// are not inside a complete lattice cell of their triangle's patch: what the lattices left open
/// (seams, slanted borders, curved surfaces).
void fillGaps(const TriangleMesh& mesh, const PlanarPatches& patches, const std::vector<Lattice>& lattices, double s,
              SampleSet& samples)
{
  // A triangle that is degenerate for the patches but not quite for forEachCandidate's test (the
  // two round differently at the 1e-12 threshold) is looked up in patch 0.
  const auto patchOf = [&](std::size_t t) { return std::uint32_t(patches.id[t] >= 0 ? patches.id[t] : 0); };
  CompleteCells complete(lattices);
  forEachCandidate(mesh, 0.1 * s, 0.05 * s, [&](const Vec3d& p, const Vec3d& n, std::size_t t) {
    if (samples.nearHint(p)) return;  // the cheapest rejection first
    if (complete.contain(patchOf(t), p)) return;
    samples.offer(p, n, {SampleSet::Origin::kFill, std::int64_t(t), 0});
  });
}

// ------------------------------------------------------------------ pass 4: the ragged borders

/// The triangle across each edge of a triangle over which a sample may walk: a smooth edge (two
/// valid triangles whose normals are within 30 degrees: not a feature edge, which pass 1
/// sampled); -1 across a feature edge. Found on first use and kept (a walk crosses few edges of a
/// large mesh, and the edge table's hash lookups are the walk's cost).
class SmoothNeighbours
{
public:
  SmoothNeighbours(const TriangleMesh& mesh, const TriangleNormals& faces, const EdgeTable& edges)
      : mesh_(mesh), faces_(faces), edges_(edges), across_(mesh.triangles.size(), {kUnknown, kUnknown, kUnknown})
  {
  }
  std::int64_t across(std::size_t t, int k)
  {
    std::int64_t& known = across_[t][k];
    if (known == kUnknown)
    {
      const auto& along = edges_.trianglesAlong(mesh_.triangles[t][k], mesh_.triangles[t][(k + 1) % 3]);
      const std::size_t next = along.size() == 2 ? (along[0] == t ? along[1] : along[0]) : t;
      const bool smooth = next != t && faces_.valid[next] && faces_.normal[next].dot(faces_.normal[t]) >= kCrease;
      known = smooth ? std::int64_t(next) : -1;
    }
    return known;
  }

private:
  static constexpr std::int64_t kUnknown = -2;
  const double kCrease = std::cos(30.0 * M_PI / 180.0);
  const TriangleMesh& mesh_;
  const TriangleNormals& faces_;
  const EdgeTable& edges_;
  std::vector<std::array<std::int64_t, 3>> across_;
};

/// The triangle that p (near the surface) lies in, walking from triangle `from` across the edge p
/// lies farthest beyond, over smooth edges only (SmoothNeighbours); -1 if the walk meets a feature
/// edge or goes on for 64 triangles (then p counts as off the surface). Within `tol` (m) of an
/// edge counts as in.
std::int64_t locateOnSmoothSurface(const TriangleMesh& mesh, const TriangleNormals& faces, SmoothNeighbours& neighbours,
                                   std::size_t from, const Vec3d& p, double tol)
{
  std::size_t t = from;
  for (int walk = 0; walk < 64; ++walk)
  {
    int worst = -1;
    double worst_side = -tol;
    for (int k = 0; k < 3; ++k)
    {
      const Vec3d& a = mesh.vertices[mesh.triangles[t][k]];
      const Vec3d edge = mesh.vertices[mesh.triangles[t][(k + 1) % 3]] - a;
      // n x edge points into a triangle wound counter-clockwise about n: side > 0 inside.
      const double side = faces.normal[t].cross(edge).dot(p - a) / edge.norm();
      if (side < worst_side)
      {
        worst_side = side;
        worst = k;
      }
    }
    if (worst < 0) return std::int64_t(t);
    const std::int64_t next = neighbours.across(t, worst);
    if (next < 0) return -1;
    t = std::size_t(next);
  }
  return -1;
}

/// Sample indices sorted by grid cell (cells of `cell` m, x fastest): the samples of a row of
/// cells along x are one range, found by binary search.
class SortedGrid
{
public:
  SortedGrid(const SampleSet& samples, double cell) : cell_(cell)
  {
    entries_.resize(samples.size());
    for (std::size_t k = 0; k < samples.size(); ++k)
      entries_[k] = {cellKeyOf(samples.point(k), cell), std::uint32_t(k)};
    std::sort(entries_.begin(), entries_.end(), [](const Entry& a, const Entry& b) {
      return std::tie(a.key.z, a.key.y, a.key.x, a.index) < std::tie(b.key.z, b.key.y, b.key.x, b.index);
    });
  }
  /// f(index) for the samples in the 3 x 3 x 3 cells around p's cell.
  template <typename F>
  void forNear(const Vec3d& p, F&& f) const
  {
    const CellKey c = cellKeyOf(p, cell_);
    for (long long dz = -1; dz <= 1; ++dz)
      for (long long dy = -1; dy <= 1; ++dy)
      {
        const long long y = c.y + dy, z = c.z + dz;
        auto it = std::lower_bound(entries_.begin(), entries_.end(), c.x - 1, [&](const Entry& e, long long x) {
          return std::tie(e.key.z, e.key.y, e.key.x) < std::tie(z, y, x);
        });
        for (; it != entries_.end() && it->key.z == z && it->key.y == y && it->key.x <= c.x + 1; ++it) f(it->index);
      }
  }

private:
  struct Entry
  {
    CellKey key;
    std::uint32_t index;
  };
  double cell_;
  std::vector<Entry> entries_;
};

/// Evens out the samples the lattices and the fill leave where a patch's border does not run
/// along its lattice (a polygon approximating a circle, a slanted border) and on curved surfaces.
/// There the fill puts samples wherever a gap is wider than 0.66 s, so the layer has holes up to
/// about 1.3 s wide beside clusters of samples 0.66 s apart, and the fluid feels a weaker wall over
/// the holes: half a spacing above the floor of a 32-facet mesh cylinder (r 8 s) the part of a
/// kernel its samples fill (sum_b V_b W, Eq. A31) was 0.887-1.065 of a flat layer's, lowest in the
/// ring next to the rim, and water under a sideways load was pressed through there (after this
/// pass: 0.97-1.02). The fill's samples and the lattice nodes within 3 nodes of a node missing from
/// their lattice move as a soft-sphere gas on the surface (Eq. A32, docs/method.md): each is pushed
/// by every sample within 1.5 s and within 30 degrees of its tangent plane, moves 0.2 s times the
/// push (at most 0.1 s) in that plane, and stays on the triangles reached over smooth edges (never
/// across a feature edge); a move that would bring it within 0.66 s of another sample (the passes'
/// smallest distance) or off the surface is halved, up to four times, then dropped. Edge samples
/// and the lattices' interiors stay, so the gas spreads into the holes between them; no sample is
/// added or removed. Until no move is longer than 0.005 s, at most 40 rounds. A mesh whose patches
/// hold whole lattices (boxes, an L-shaped tank) has nothing to move and is sampled bit for bit as
/// before. The pushes come from the positions at the start of a round (in parallel), the moves are
/// made in sample order: the result depends on nothing else.
void relaxFreeSamples(const TriangleMesh& mesh, const TriangleNormals& faces, const EdgeTable& edges,
                      const PlanarPatches& patches, const std::vector<Lattice>& lattices, double s, SampleSet& samples)
{
  using Origin = SampleSet::Origin;
  constexpr long long kBand = 3;  // lattice nodes this close (in nodes) to a missing one move too
  std::vector<std::uint32_t> movable;
  std::vector<std::int64_t> triangle;  // per movable sample, the triangle it lies in
  for (std::size_t k = 0; k < samples.size(); ++k)
  {
    const Origin& o = samples.origin(k);
    if (o.kind == Origin::kEdge || o.triangle < 0 || !faces.valid[std::size_t(o.triangle)]) continue;
    if (o.kind == Origin::kLattice)
    {
      const auto& present = lattices[std::size_t(patches.id[std::size_t(o.triangle)])].present;
      const long long i = (long long)(o.node >> 32) - (1LL << 31);
      const long long j = (long long)(o.node & 0xffffffffULL) - (1LL << 31);
      bool whole = true;
      for (long long dj = -kBand; dj <= kBand && whole; ++dj)
        for (long long di = -kBand; di <= kBand && whole; ++di) whole = present.count(latticeNode(i + di, j + dj)) > 0;
      if (whole) continue;
    }
    movable.push_back(std::uint32_t(k));
    triangle.push_back(o.triangle);
  }
  if (movable.empty()) return;

  constexpr int kMaxRounds = 40;
  const double reach = 1.5 * s;                      // m, Eq. A32's range
  const double gain = 0.2 * s;                       // m per unit push
  const double max_move = 0.1 * s;                   // m per round
  const double settled = 0.005 * s;                  // m: stop once every move is shorter
  const double tol = 1e-6 * s;                       // m, on a triangle's border counts as in it
  const double min_dist2 = (0.66 * s) * (0.66 * s);  // m^2, as SampleSet keeps them
  std::vector<Vec3d> move(movable.size());
  SmoothNeighbours neighbours(mesh, faces, edges);
  // Per movable sample, the samples within crowd_reach of it at a round's start (up to kMaxClose;
  // num_close_to > kMaxClose: more).
  constexpr int kMaxClose = 12;
  // A move and its projection onto the triangle it lands on stay within 2 max_move of the start,
  // another sample within max_move of its start: 0.66 s + 3 max_move bounds every pair that can
  // come within 0.66 s in a round.
  const double crowd_reach = 0.66 * s + 3 * max_move;  // m
  std::vector<std::uint32_t> close_to(movable.size() * kMaxClose);
  std::vector<int> num_close_to(movable.size());
  for (int round = 0; round < kMaxRounds; ++round)
  {
    const SortedGrid grid(samples, reach);
    const double longest = parallelMax(movable.size(), [&](std::size_t m) {
      const std::size_t k = movable[m];
      const Vec3d& p = samples.point(k);
      const Vec3d& n = faces.normal[std::size_t(triangle[m])];
      Vec3d push = Vec3d::Zero();  // Eq. A32
      std::uint32_t* close = &close_to[m * kMaxClose];
      int num_close = 0;
      grid.forNear(p, [&](std::uint32_t q) {
        if (q == k) return;
        const Vec3d d = p - samples.point(q);
        const double r = d.norm();
        if (r < crowd_reach)
        {
          if (num_close < kMaxClose)
            close[num_close++] = q;
          else
            num_close = kMaxClose + 1;  // too many to list: crowded() searches the grid
        }
        // Samples across a crease (more than 30 degrees out of the tangent plane: a wall meeting
        // this floor) do not push: the edge samples between them stand for that side.
        if (r < reach && r > 0.0 && std::abs(d.dot(n)) <= 0.5 * r) push += (1.0 - r / reach) / r * d;
      });
      push -= push.dot(n) * n;
      Vec3d d = gain * push;
      const double length = d.norm();
      if (length > max_move) d *= max_move / length;
      move[m] = d;
      num_close_to[m] = num_close;
      return std::min(length, max_move);
    });
    if (longest < settled) break;  // then no move would exceed `settled` either (moved <= proposed)
    // Only the samples within crowd_reach of a sample at the round's start can come within 0.66 s
    // of it: those listed above, or, where more than kMaxClose were, those in the grid's cells
    // around it (a sample is at most 0.1 s from where the grid put it).
    const auto crowded = [&](std::size_t m, const Vec3d& q) {
      const std::size_t k = movable[m];
      bool near = false;
      const auto check = [&](std::uint32_t other) {
        near = near || (other != k && (samples.point(other) - q).squaredNorm() < min_dist2);
      };
      if (num_close_to[m] > kMaxClose)
        grid.forNear(q, check);
      else
        std::for_each(&close_to[m * kMaxClose], &close_to[m * kMaxClose] + num_close_to[m], check);
      return near;
    };
    double moved = 0.0;  // m, the longest move made this round
    for (std::size_t m = 0; m < movable.size(); ++m)
    {
      const std::size_t k = movable[m];
      Vec3d d = move[m];
      for (int halving = 0; halving < 4; ++halving, d *= 0.5)
      {
        const Vec3d p = samples.point(k) + d;
        const std::int64_t t = locateOnSmoothSurface(mesh, faces, neighbours, std::size_t(triangle[m]), p, tol);
        if (t < 0) continue;
        const Vec3d& n = faces.normal[std::size_t(t)];
        const Vec3d q = p - (p - mesh.vertices[mesh.triangles[std::size_t(t)][0]]).dot(n) * n;
        if (crowded(m, q)) continue;
        samples.moveTo(k, q, n);
        triangle[m] = t;
        moved = std::max(moved, d.norm());
        break;
      }
    }
    if (moved < settled) break;
  }
}
}  // namespace

std::vector<Vec3d> sampleMeshSurface(const TriangleMesh& mesh, double s, double offset, std::size_t* degenerate)
{
  const TriangleNormals faces = triangleNormals(mesh);
  if (degenerate) *degenerate = faces.degenerate;
  const EdgeTable edges(mesh, faces.valid);
  SampleSet samples(s, offset);

  sampleFeatureEdges(mesh, faces, edges, s, samples);

  const PlanarPatches patches = planarPatches(mesh, faces, edges, s);
  std::vector<Lattice> lattices;
  lattices.reserve(patches.triangles.size());
  for (const auto& patch : patches.triangles)
  {
    lattices.push_back(patchLattice(mesh, patch, faces.normal[patch[0]], patches, edges, s));
    Lattice& lattice = lattices.back();
    if (lattice.step[0] > 0.0 && lattice.step[1] > 0.0) sampleLattice(mesh, patch, faces.normal, s, lattice, samples);
  }

  fillGaps(mesh, patches, lattices, s, samples);
  relaxFreeSamples(mesh, faces, edges, patches, lattices, s, samples);
  return samples.take();
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

}  // namespace fluid_sim
