// One scene boundary into its layer of boundary particles: the shape's surface moved half a fluid
// spacing into the solid (or out of a container) and sampled by the primitive or mesh sampler, the
// particle count validate() checks before sampling, and the inside test that clears the fluid
// lattice from solids. The samplers are primitive_sampling.cpp, mesh_sampling.cpp and
// mesh_offset.cpp; the particle volumes boundary_volume.cpp.

#include "fluid_sim/core/boundary_sampling.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <tuple>
#include <utility>

#include "fluid_sim/core/cell_key.h"
#include "fluid_sim/core/mesh_inside_index.h"

namespace fluid_sim
{
namespace
{
/// Reorders points along cells of size `cell` (m; z slowest, x fastest) for memory locality.
void sortByCell(std::vector<Vec3d>& points, double cell)
{
  std::vector<std::pair<std::tuple<long long, long long, long long>, std::size_t>> keys(points.size());
  for (std::size_t i = 0; i < points.size(); ++i)
  {
    const CellKey k = cellKeyOf(points[i], cell);
    keys[i] = {{k.z, k.y, k.x}, i};
  }
  std::sort(keys.begin(), keys.end());
  std::vector<Vec3d> out(points.size());
  for (std::size_t i = 0; i < keys.size(); ++i) out[i] = points[keys[i].second];
  points.swap(out);
}
}  // namespace

double estimateBoundaryParticles(const BoundaryConfig& b, double s, double fluid_spacing)
{
  // The primitives count exactly what sampleBoundary() makes, from their sizes alone.
  if (!(s > 0.0)) return std::numeric_limits<double>::infinity();
  const double grow = b.inside ? 0.5 * fluid_spacing : -0.5 * fluid_spacing;  // m
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
      // A box too large for doubles: inf - inf would be NaN, which no budget check refuses by name.
      if (std::isinf(all)) return std::numeric_limits<double>::infinity();
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

std::string estimateText(double estimate)
{
  if (std::abs(estimate) <= 1e15) return std::to_string(std::llround(estimate));
  std::ostringstream os;
  os << estimate;
  return os.str();
}

std::vector<Vec3d> sampleBoundary(const BoundaryConfig& b, double s, double fluid_spacing)
{
  // Half a fluid spacing into the solid, or out of a container (docs/method_notes.md, boundary
  // particles).
  const double half = 0.5 * fluid_spacing;      // m
  const double grow = b.inside ? half : -half;  // m, outward
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

}  // namespace fluid_sim
