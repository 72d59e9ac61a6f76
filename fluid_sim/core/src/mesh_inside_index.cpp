// The inside test of closed triangle meshes: the winding number along a slightly skewed +x ray,
// by brute force (windingNumber) or over the triangles binned by their (y, z) footprint
// (MeshInsideIndex).

#include "fluid_sim/core/mesh_inside_index.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <utility>

namespace fluid_sim
{
namespace
{
// Skew of the ray against +x (y and z per unit x): small, and irrational-looking, so that a ray
// from a lattice point rarely passes exactly through a vertex or along an edge.
constexpr double kSkewY = 0.000123457;
constexpr double kSkewZ = 0.000234568;

/// +1 if the ray from p along dir leaves through triangle (a, b, c) (its normal along the ray),
/// -1 if it enters, 0 if it misses (Moeller-Trumbore).
int crossing(const Vec3d& a, const Vec3d& b, const Vec3d& c, const Vec3d& p, const Vec3d& dir)
{
  const Vec3d e1 = b - a, e2 = c - a;
  const Vec3d h = dir.cross(e2);
  const double det = e1.dot(h);  // = -dir . (e1 x e2)
  if (std::abs(det) < 1e-300) return 0;
  const double inv = 1.0 / det;
  const Vec3d sv = p - a;
  const double u = sv.dot(h) * inv;
  if (u < 0.0 || u > 1.0) return 0;
  const Vec3d qv = sv.cross(e1);
  const double v = dir.dot(qv) * inv;
  if (v < 0.0 || u + v > 1.0) return 0;
  if (e2.dot(qv) * inv <= 0.0) return 0;  // behind the start
  return det < 0.0 ? 1 : -1;
}

/// The bin of `coordinate` among n bins of width `bin` from `origin`, clamped to [0, n - 1] before
/// the conversion to int (the drift margin can reach far beyond the box, by far more bins than an
/// int counts when the mesh is flat).
int binOf(double coordinate, double origin, double bin, int n)
{
  const double b = std::floor((coordinate - origin) / bin);
  if (!(b > 0.0)) return 0;  // also NaN
  return b >= double(n - 1) ? n - 1 : int(b);
}

/// The ray direction of the inside test (unit, close to +x).
Vec3d insideRayDirection()
{
  return Vec3d(1.0, kSkewY, kSkewZ).normalized();
}
}  // namespace

int windingNumber(const TriangleMesh& mesh, const Vec3d& p)
{
  const Vec3d dir = insideRayDirection();
  int w = 0;
  for (const auto& t : mesh.triangles)
    w += crossing(mesh.vertices[t[0]], mesh.vertices[t[1]], mesh.vertices[t[2]], p, dir);
  return w;
}

MeshInsideIndex::MeshInsideIndex(const TriangleMesh& mesh)
    : num_vertices_(mesh.vertices.size()), num_triangles_(mesh.triangles.size())
{
  if (mesh.vertices.empty()) return;
  lo_ = hi_ = mesh.vertices[0];
  for (const auto& v : mesh.vertices)
  {
    lo_ = lo_.cwiseMin(v);
    hi_ = hi_.cwiseMax(v);
  }
  // About one triangle per bin on average, at most 512 x 512 bins.
  const double ey = std::max(hi_.y() - lo_.y(), 1e-12), ez = std::max(hi_.z() - lo_.z(), 1e-12);
  const double bins = std::clamp(double(num_triangles_), 1.0, 512.0 * 512.0);
  const double aspect = ey / ez;
  // Clamped before the conversion: a flat mesh (ez at its 1e-12 floor) has an aspect ratio far
  // beyond what an int holds.
  ny_ = int(std::clamp(std::ceil(std::sqrt(bins * aspect)), 1.0, 512.0));
  nz_ = int(std::clamp(std::ceil(bins / ny_), 1.0, 512.0));
  bin_y_ = ey / ny_;
  bin_z_ = ez / nz_;
  // A ray that starts at (y, z) drifts by up to skew * (x extent) before it leaves the box: a
  // triangle is filed in every bin from which a ray can reach its footprint.
  const double drift_y = kSkewY * (hi_.x() - lo_.x()) * 1.001 + 1e-12;
  const double drift_z = kSkewZ * (hi_.x() - lo_.x()) * 1.001 + 1e-12;
  const auto binRange = [](double lo, double hi, double origin, double bin, int n) {
    return std::pair<int, int>(binOf(lo, origin, bin, n), binOf(hi, origin, bin, n));
  };
  std::vector<std::uint32_t> count(std::size_t(ny_) * nz_ + 1, 0);
  std::vector<std::array<int, 4>> ranges(num_triangles_);
  for (std::size_t i = 0; i < num_triangles_; ++i)
  {
    const auto& t = mesh.triangles[i];
    const Vec3d& a = mesh.vertices[t[0]];
    const Vec3d& b = mesh.vertices[t[1]];
    const Vec3d& c = mesh.vertices[t[2]];
    const auto [y0, y1] =
        binRange(std::min({a.y(), b.y(), c.y()}) - drift_y, std::max({a.y(), b.y(), c.y()}), lo_.y(), bin_y_, ny_);
    const auto [z0, z1] =
        binRange(std::min({a.z(), b.z(), c.z()}) - drift_z, std::max({a.z(), b.z(), c.z()}), lo_.z(), bin_z_, nz_);
    ranges[i] = {y0, y1, z0, z1};
    for (int z = z0; z <= z1; ++z)
      for (int y = y0; y <= y1; ++y) ++count[std::size_t(z) * ny_ + y + 1];
  }
  for (std::size_t k = 1; k < count.size(); ++k) count[k] += count[k - 1];
  start_ = count;
  triangles_.resize(start_.back());
  for (std::size_t i = 0; i < num_triangles_; ++i)
  {
    const auto& r = ranges[i];
    for (int z = r[2]; z <= r[3]; ++z)
      for (int y = r[0]; y <= r[1]; ++y) triangles_[count[std::size_t(z) * ny_ + y]++] = std::uint32_t(i);
  }
}

bool MeshInsideIndex::matches(const TriangleMesh& mesh) const
{
  return mesh.vertices.size() == num_vertices_ && mesh.triangles.size() == num_triangles_;
}

int MeshInsideIndex::winding(const TriangleMesh& mesh, const Vec3d& p) const
{
  if (num_triangles_ == 0 || (p.array() < lo_.array()).any() || (p.array() > hi_.array()).any()) return 0;
  const int y = binOf(p.y(), lo_.y(), bin_y_, ny_);
  const int z = binOf(p.z(), lo_.z(), bin_z_, nz_);
  const std::size_t bin = std::size_t(z) * ny_ + y;
  const Vec3d dir = insideRayDirection();
  int w = 0;
  for (std::uint32_t k = start_[bin]; k < start_[bin + 1]; ++k)
  {
    const auto& t = mesh.triangles[triangles_[k]];
    w += crossing(mesh.vertices[t[0]], mesh.vertices[t[1]], mesh.vertices[t[2]], p, dir);
  }
  return w;
}

void buildInsideIndex(TriangleMesh& mesh)
{
  mesh.inside_index.reset();
  const auto n = static_cast<int>(mesh.vertices.size());
  for (const auto& t : mesh.triangles)
    for (int k : t)
      if (k < 0 || k >= n) return;  // validate() reports it
  mesh.inside_index = std::make_shared<const MeshInsideIndex>(mesh);
}

}  // namespace fluid_sim
