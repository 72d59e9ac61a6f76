#include "fluid_sim/core/boundary_sampling.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "fluid_sim/core/kernel.h"
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

/// Ray parity along a fixed, slightly skewed direction (skewed so it rarely grazes edges).
bool insideClosedMesh(const TriangleMesh& mesh, const Vec3d& p)
{
  const Vec3d dir = Vec3d(1.0, 0.000123457, 0.000234568).normalized();
  int crossings = 0;
  for (const auto& t : mesh.triangles)
  {
    const Vec3d& a = mesh.vertices[t[0]];
    const Vec3d e1 = mesh.vertices[t[1]] - a, e2 = mesh.vertices[t[2]] - a;
    const Vec3d h = dir.cross(e2);
    const double det = e1.dot(h);
    if (std::abs(det) < 1e-300) continue;
    const double inv = 1.0 / det;
    const Vec3d sv = p - a;
    const double u = sv.dot(h) * inv;
    if (u < 0.0 || u > 1.0) continue;
    const Vec3d qv = sv.cross(e1);
    const double v = dir.dot(qv) * inv;
    if (v < 0.0 || u + v > 1.0) continue;
    if (e2.dot(qv) * inv > 0.0) ++crossings;
  }
  return crossings % 2 == 1;
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
  // A fine lattice (edge <= s/4) per triangle, then greedy thinning to min distance 0.6 s:
  // every fine point keeps a sample within 0.6 s, and fine points are within s/8 + of any surface
  // point, so the largest gap stays below 0.75 s (tested) without clumps closer than 0.6 s.
  const double fine = 0.25 * s;
  const double min_dist = 0.6 * s;
  std::size_t skipped = 0;
  std::vector<Vec3d> candidates;
  std::vector<Vec3d> normals;
  for (const auto& t : mesh.triangles)
  {
    const Vec3d& a = mesh.vertices[t[0]];
    const Vec3d& b = mesh.vertices[t[1]];
    const Vec3d& c = mesh.vertices[t[2]];
    const Vec3d nrm = (b - a).cross(c - a);
    const double max_edge = std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()});
    if (!(nrm.norm() > 1e-12 * max_edge * max_edge) || !(max_edge > 0.0))
    {
      ++skipped;
      continue;
    }
    const Vec3d unit_n = nrm.normalized();
    const int n = std::max(1, int(std::ceil(max_edge / fine)));
    for (int i = 0; i <= n; ++i)
      for (int j = 0; j <= n - i; ++j)
      {
        const double u = double(i) / n, v = double(j) / n;
        candidates.push_back(a + u * (b - a) + v * (c - a));
        normals.push_back(unit_n);
      }
  }
  if (degenerate) *degenerate = skipped;
  std::vector<Vec3d> out;
  std::unordered_map<CellKey, std::vector<std::size_t>, CellKeyHash> grid;
  const double md2 = min_dist * min_dist;
  for (std::size_t k = 0; k < candidates.size(); ++k)
  {
    const Vec3d& p = candidates[k];
    const CellKey key = keyOf(p, min_dist);
    bool close = false;
    for (long long dz = -1; dz <= 1 && !close; ++dz)
      for (long long dy = -1; dy <= 1 && !close; ++dy)
        for (long long dx = -1; dx <= 1 && !close; ++dx)
        {
          auto it = grid.find({key.x + dx, key.y + dy, key.z + dz});
          if (it == grid.end()) continue;
          for (std::size_t idx : it->second)
            if ((candidates[idx] - p).squaredNorm() < md2)
            {
              close = true;
              break;
            }
        }
    if (close) continue;
    grid[key].push_back(k);
    out.push_back(p + offset * normals[k]);
  }
  return out;
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
      // Outward normals assumed (closed meshes); open meshes lie on their surface.
      const double offset = (b.mesh_offset == SurfaceOffset::None || !b.mesh_closed) ? 0.0 : grow;
      pts = sampleMeshSurface(b.mesh, s, offset);
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
      return b.mesh_closed && insideClosedMesh(b.mesh, p);
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
