// The free surface as a triangle mesh (docs/method.md, Free-surface mesh, Eqs. A28-A30), by
// OpenVDB: ParticlesToLevelSet (the union of spheres, Eq. A28), tools::Filter (the smoothing,
// Eq. A29) and volumeToMesh (the zero level, Eq. A30). The only file of the project that includes
// OpenVDB's headers: they take long to compile, and the library is linked privately into the core,
// so nothing that uses the core sees it.

#include "fluid_sim/core/surface.h"
#include "fluid_sim/core/scene_config.h"  // numberText, vectorText

#include <openvdb/openvdb.h>
#include <openvdb/tools/Filter.h>
#include <openvdb/tools/ParticlesToLevelSet.h>
#include <openvdb/tools/VolumeToMesh.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>

namespace fluid_sim
{
namespace
{
/// What ParticlesToLevelSet reads the particles through (its ParticleList concept): positions in
/// m, world; every sphere has the same radius, given to rasterizeSpheres().
class ParticleList
{
public:
  using PosType = openvdb::Vec3R;

  explicit ParticleList(std::vector<openvdb::Vec3R> positions) : positions_(std::move(positions)) {}

  std::size_t size() const
  {
    return positions_.size();
  }
  void getPos(std::size_t n, openvdb::Vec3R& xyz) const
  {
    xyz = positions_[n];
  }

private:
  std::vector<openvdb::Vec3R> positions_;
};

[[noreturn]] void refuse(const std::string& message)
{
  throw ConfigError("surface", message);
}

void checkOptions(double spacing, const SurfaceOptions& o)
{
  // Written as !(in range) so that NaN is refused too.
  if (!(spacing > 0.0 && std::isfinite(spacing))) refuse("spacing = " + numberText(spacing) + " m: must be > 0");
  if (!(o.particle_radius >= 0.5 && o.particle_radius <= 5.0))
    refuse("particle_radius = " + numberText(o.particle_radius) + " spacings: out of range [0.5, 5]");
  // A sphere narrower than a voxel is not resolved (ParticlesToLevelSet leaves such spheres out:
  // every particle would vanish).
  if (!(o.voxel_size >= 0.05 && o.voxel_size <= o.particle_radius))
    refuse("voxel_size = " + numberText(o.voxel_size) +
           " spacings: out of range [0.05, particle_radius = " + numberText(o.particle_radius) + "]");
  if (!(o.drop_radius == 0.0 || (o.drop_radius >= 0.25 && o.drop_radius <= o.particle_radius)))
    refuse("drop_radius = " + numberText(o.drop_radius) +
           " spacings: must be 0 or in [0.25, particle_radius = " + numberText(o.particle_radius) + "]");
  if (o.smoothing_passes < 0 || o.smoothing_passes > 20)
    refuse("smoothing_passes = " + std::to_string(o.smoothing_passes) + ": out of range [0, 20]");
  if (!(o.adaptivity >= 0.0 && o.adaptivity <= 1.0))
    refuse("adaptivity = " + numberText(o.adaptivity) + ": out of range [0, 1]");
  if (!(o.max_voxels >= 1.0)) refuse("max_voxels = " + numberText(o.max_voxels) + ": must be >= 1");
}

/// OpenVDB's registry of grid and metadata types; idempotent and thread-safe, once per process.
void initializeOpenVdb()
{
  static const bool done = [] {
    openvdb::initialize();
    return true;
  }();
  (void)done;
}
}  // namespace

SurfaceMesh reconstructSurface(const std::vector<Vec3>& positions, double spacing, const SurfaceOptions& options)
{
  const auto start = std::chrono::steady_clock::now();
  checkOptions(spacing, options);
  SurfaceMesh mesh;
  mesh.voxel_size = options.voxel_size * spacing;            // m, dx
  mesh.particle_radius = options.particle_radius * spacing;  // m, r
  const double dx = mesh.voxel_size;
  const double r = mesh.particle_radius;
  // Narrow band, voxels each side of the zero level (OpenVDB's default). With r below 3 dx (the
  // defaults: r = 2.34 dx) every voxel inside the water is within it, so the smoothing (Eq. A29)
  // sees the distance field itself there, never a clamped value.
  constexpr double half_width = 3.0;

  std::vector<openvdb::Vec3R> points;
  points.reserve(positions.size());
  Vec3d lo = Vec3d::Constant(std::numeric_limits<double>::infinity());
  Vec3d hi = -lo;
  for (const Vec3& p : positions)
  {
    const Vec3d x = p.cast<double>();
    if (!x.allFinite())
    {
      ++mesh.skipped_particles;
      continue;
    }
    points.emplace_back(x.x(), x.y(), x.z());
    lo = lo.cwiseMin(x);
    hi = hi.cwiseMax(x);
  }
  mesh.particles = points.size();
  if (points.empty())
  {
    mesh.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    return mesh;
  }

  // The budget, before anything is allocated: the voxels of the box every sphere's stencil (r
  // plus the band) falls in, and OpenVDB's signed 32-bit voxel coordinates (kept within 2^30, so
  // the filters' stencils cannot overflow either).
  const double pad = r + half_width * dx;  // m
  double voxels = 1.0;
  for (int a = 0; a < 3; ++a) voxels *= std::ceil((hi[a] - lo[a] + 2.0 * pad) / dx) + 1.0;
  if (!(voxels <= options.max_voxels))
    refuse("the particles' bounding box " + vectorText(lo) + " to " + vectorText(hi) + " m needs " +
           numberText(voxels) + " voxels of " + numberText(dx) + " m, more than the budget of " +
           numberText(options.max_voxels) +
           " (SurfaceOptions::max_voxels; a particle far from the others, or a voxel too fine for the water)");
  const double far = std::max(lo.cwiseAbs().maxCoeff(), hi.cwiseAbs().maxCoeff()) + pad;  // m
  if (!(far / dx < 1073741824.0))
    refuse("a particle " + numberText(far) + " m from the origin is " + numberText(far / dx) + " voxels of " +
           numberText(dx) + " m away, beyond OpenVDB's coordinate range (2^30 voxels)");

  initializeOpenVdb();
  // Eq. A28: phi_0(x) = min_i |x - x_i| - r (m), the signed distance to the union of the spheres,
  // negative inside, sampled at the voxel centres (i dx, j dx, k dx) within the narrow band
  // (beyond it -3 dx inside, +3 dx outside).
  openvdb::FloatGrid::Ptr grid = openvdb::createLevelSet<openvdb::FloatGrid>(dx, half_width);
  {
    openvdb::tools::ParticlesToLevelSet<openvdb::FloatGrid> raster(*grid);
    raster.setRmin(1.0);  // voxels; checkOptions keeps r >= dx
    const ParticleList list(std::move(points));
    raster.rasterizeSpheres(list, r);
    raster.finalize(true);
  }
  // Eq. A29: phi = G * phi_0, OpenVDB's Gaussian filter (four passes of a 3-voxel box filter per
  // pass: sigma^2 = 8/3 dx^2, sigma = 1.63 dx = 0.54 s at dx = s/3) on the values. The union of
  // spheres is bumpy (dips between neighbouring particles, up to r - sqrt(r^2 - s^2/2) deep on a
  // face, and gaps at the lattice cells' corners inside when r < 0.87 s); the lattice's period s
  // is damped by exp(-2 pi^2 sigma^2 / s^2) = 0.003 per pass, a flat face stays flat. Not
  // LevelSetFilter: it re-normalises phi to a distance after every pass (measured: 1.8 s a pass
  // for the demo's 3,600 particles at dx = s/4, against 0.2 s for this one, on a loaded machine;
  // docs/method.md).
  // Eq. A29b: phi = min(G * phi_0, phi_0 + r - r_d), every particle at least a sphere of radius
  // r_d. The smoothing is wider than a lone particle's sphere (r = 2.3 voxels, sigma = 1.6): a
  // drop of one or two particles came out with no surface at all. r_d = 0.45 s stays below a
  // block's face (s/2 beyond its particles), so the water's faces are the smoothed ones.
  const double drop = options.drop_radius * spacing;  // m, r_d
  openvdb::FloatGrid::Ptr raw = drop > 0.0 && options.smoothing_passes > 0 ? grid->deepCopy() : nullptr;
  if (options.smoothing_passes > 0)
  {
    openvdb::tools::Filter<openvdb::FloatGrid> filter(*grid);
    filter.gaussian(1, options.smoothing_passes);
  }
  if (raw)
  {
    // The smoothing changes values, not which voxels are active: both grids have the same ones.
    const float lift = static_cast<float>(r - drop);  // m
    openvdb::FloatGrid::ConstAccessor before = raw->getConstAccessor();
    for (auto v = grid->beginValueOn(); v; ++v)
    {
      const float sphere = before.getValue(v.getCoord()) + lift;
      if (sphere < *v) v.setValue(sphere);
    }
  }

  std::vector<openvdb::Vec3s> vertices;
  std::vector<openvdb::Vec3I> triangles;
  std::vector<openvdb::Vec4I> quads;
  // Eq. A30: the surface phi = 0, one vertex per voxel cell it crosses (dual contouring).
  openvdb::tools::volumeToMesh(*grid, vertices, triangles, quads, 0.0, options.adaptivity);

  mesh.vertices.resize(vertices.size());
  for (std::size_t i = 0; i < vertices.size(); ++i)
    mesh.vertices[i] = Vec3(Real(vertices[i].x()), Real(vertices[i].y()), Real(vertices[i].z()));
  mesh.triangles.reserve(triangles.size() + 2 * quads.size());
  // volumeToMesh winds its polygons clockwise seen from outside (where phi > 0; measured:
  // surface_test, MeshIsClosedAndOrientedOutward); reversed here to the usual counter-clockwise
  // order, which gives outward right-handed normals (rviz lights a TRIANGLE_LIST by them).
  for (const openvdb::Vec3I& t : triangles) mesh.triangles.push_back({Index(t[0]), Index(t[2]), Index(t[1])});
  // A quad (a, b, c, d) as the triangles (a, b, c) and (a, c, d), reversed likewise.
  for (const openvdb::Vec4I& q : quads)
  {
    mesh.triangles.push_back({Index(q[0]), Index(q[2]), Index(q[1])});
    mesh.triangles.push_back({Index(q[0]), Index(q[3]), Index(q[2])});
  }
  mesh.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return mesh;
}

double enclosedVolume(const SurfaceMesh& mesh)
{
  double six_v = 0.0;  // m^3, six times the volume
  for (const auto& t : mesh.triangles)
  {
    const Vec3d a = mesh.vertices[t[0]].cast<double>();
    const Vec3d b = mesh.vertices[t[1]].cast<double>();
    const Vec3d c = mesh.vertices[t[2]].cast<double>();
    six_v += a.dot(b.cross(c));
  }
  return six_v / 6.0;
}

}  // namespace fluid_sim
