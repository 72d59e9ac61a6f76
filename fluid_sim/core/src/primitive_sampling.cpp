// Boundary samples on the primitive shapes, in the shape's frame: the face lattice of a box, the
// Fibonacci lattice of a sphere, and the staggered rings of a closed cylinder. Declared in
// boundary_sampling.h.

#include <algorithm>
#include <cmath>

#include "fluid_sim/core/boundary_sampling.h"

namespace fluid_sim
{
namespace
{
/// Number of equal pieces, each at most s long, that divide `length` (m); 0 for no length.
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
  const double area_per_point = std::sqrt(3.0) / 2.0 * s * s;  // m^2, hexagonal packing at spacing s
  const int n = std::max(1, int(std::ceil(4.0 * M_PI * radius * radius / area_per_point)));
  const double golden = M_PI * (3.0 - std::sqrt(5.0));  // rad, the golden angle
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
  // Side: rings along the axis, both ends included.
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

}  // namespace fluid_sim
