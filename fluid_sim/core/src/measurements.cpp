// Instruments: regions (water volume, mass, mean velocity inside), probes (SPH interpolation at a
// point) and spill, read from the fluid state between steps (measurements.h).

#include "fluid_sim/core/measurements.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <unordered_map>
#include <unordered_set>
#include <utility>

#include "fluid_sim/core/boundary_sampling.h"
#include "fluid_sim/core/kernel.h"
#include "fluid_sim/core/mesh_inside_index.h"
#include "fluid_sim/core/neighbor_search.h"
#include "fluid_sim/core/parallel.h"
#include "fluid_sim/core/simulation.h"

namespace fluid_sim
{
RegionTest::RegionTest(const RegionConfig& r, const Pose& pose, const BoundaryConfig* body_shape)
    : shape(r.shape)
    , world_to_local(pose.rotation.toRotationMatrix().transpose())
    , translation(pose.translation)
    , min(r.box.min)
    , max(r.box.max)
    , center(r.sphere.center)
    , radius2(r.sphere.radius * r.sphere.radius)
    , body(body_shape)
{
}

bool RegionTest::contains(const Vec3d& p) const
{
  switch (shape)
  {
    case RegionShape::Sphere:
      return (p - center).squaredNorm() <= radius2;
    case RegionShape::Box:
    {
      const Vec3d local = world_to_local * (p - translation);
      return (local.array() >= min.array()).all() && (local.array() <= max.array()).all();
    }
    case RegionShape::Body:
      return insideShape(*body, world_to_local * (p - translation));
  }
  return false;
}

namespace
{
/// Most cells of a probe grid (4 bytes each): probes spread over a large domain get coarser cells
/// instead of a grid of the domain's size at the kernel support.
constexpr double kMaxProbeGridCells = 4.0e6;

/// A primitive's volume, m^3.
double shapeVolume(const BoundaryConfig& b)
{
  switch (b.type)
  {
    case ShapeType::Box:
      return (b.box.max - b.box.min).prod();
    case ShapeType::Sphere:
      return 4.0 / 3.0 * M_PI * std::pow(b.sphere.radius, 3);
    case ShapeType::Cylinder:
      return M_PI * b.cylinder.radius * b.cylinder.radius * b.cylinder.length;
    case ShapeType::Mesh:
      return std::abs(enclosedVolume(b.mesh));
  }
  return 0.0;
}

/// Union-find root of `i` with path halving.
std::size_t findRoot(std::vector<std::size_t>& parent, std::size_t i)
{
  while (parent[i] != i) i = parent[i] = parent[parent[i]];
  return i;
}

/// Per-region sums of one chunk of particles.
struct RegionSums
{
  std::vector<std::size_t> count;  // particles inside each region
  std::vector<Vec3d> velocity;     // m/s, summed over them
  std::size_t spill = 0;           // particles outside every region and below spill.below
};
}  // namespace

bool wetness(double fluid_support, double wall_support)
{
  return fluid_support > 0.0 && 2.0 * fluid_support + wall_support >= 1.0;
}

double enclosedVolume(const TriangleMesh& mesh)
{
  double six_v = 0.0;  // m^3, six times the volume
  for (const auto& t : mesh.triangles) six_v += mesh.vertices[t[0]].dot(mesh.vertices[t[1]].cross(mesh.vertices[t[2]]));
  return six_v / 6.0;
}

TriangleMesh closeOpenings(const TriangleMesh& mesh)
{
  TriangleMesh out;
  out.vertices = mesh.vertices;
  out.triangles = mesh.triangles;
  // Directed edges a -> b of the triangles; a border edge has no twin b -> a.
  const auto key = [](std::uint64_t a, std::uint64_t b) { return (a << 32) | b; };
  std::unordered_set<std::uint64_t> edges;
  for (const auto& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) edges.insert(key(std::uint32_t(t[k]), std::uint32_t(t[(k + 1) % 3])));
  std::vector<std::pair<int, int>> border;
  for (const auto& t : mesh.triangles)
    for (int k = 0; k < 3; ++k)
    {
      const int a = t[k], b = t[(k + 1) % 3];
      if (!edges.count(key(std::uint32_t(b), std::uint32_t(a)))) border.emplace_back(a, b);
    }
  if (!border.empty())
  {
    // Openings: border edges joined through shared vertices. Each gets a fan from the centroid
    // of its vertices; the fan runs each border edge backwards (b, a, c), so it is the edge's twin.
    std::vector<std::size_t> parent(mesh.vertices.size());
    for (std::size_t i = 0; i < parent.size(); ++i) parent[i] = i;
    for (const auto& [a, b] : border) parent[findRoot(parent, a)] = findRoot(parent, b);
    std::unordered_map<std::size_t, Vec3d> sum;     // m, per opening
    std::unordered_map<std::size_t, double> count;  // vertices, per opening
    std::unordered_set<int> counted;
    for (const auto& [a, b] : border)
      for (int v : {a, b})
        if (counted.insert(v).second)
        {
          const std::size_t root = findRoot(parent, v);
          sum.try_emplace(root, Vec3d::Zero()).first->second += mesh.vertices[v];
          count[root] += 1.0;
        }
    std::unordered_map<std::size_t, int> centroid;  // opening -> index of its centroid vertex
    for (const auto& [root, s] : sum)
    {
      centroid[root] = int(out.vertices.size());
      out.vertices.push_back(s / count[root]);
    }
    for (const auto& [a, b] : border) out.triangles.push_back({b, a, centroid[findRoot(parent, a)]});
  }
  if (enclosedVolume(out) < 0.0)
    for (auto& t : out.triangles) std::swap(t[1], t[2]);
  return out;
}

Measurements::Measurements(const Simulation& sim)
    : regions_(sim.scene().regions)
    , probes_(sim.scene().probes)
    , spill_(sim.scene().spill)
    , domain_(sim.scene().domain)
    , support_(2.0 * sim.scene().spacing)
    , mass_(sim.scene().rest_density * std::pow(sim.scene().spacing, 3))
    , rho0_(sim.scene().rest_density)
{
  const SceneConfig& scene = sim.scene();
  capacity_.resize(regions_.size());
  body_index_.assign(regions_.size(), 0);
  body_shape_.resize(regions_.size());
  for (std::size_t k = 0; k < regions_.size(); ++k)
  {
    const RegionConfig& r = regions_[k];
    switch (r.shape)
    {
      case RegionShape::Box:
        capacity_[k] = (r.box.max - r.box.min).prod();
        break;
      case RegionShape::Sphere:
        capacity_[k] = 4.0 / 3.0 * M_PI * std::pow(r.sphere.radius, 3);
        break;
      case RegionShape::Body:
      {
        std::size_t index = scene.boundaries.size();
        for (std::size_t b = 0; b < scene.boundaries.size(); ++b)
          if (scene.boundaries[b].name == r.body) index = b;
        if (index == scene.boundaries.size())
        {
          std::string names;
          for (const BoundaryConfig& b : scene.boundaries) names += (names.empty() ? "" : ", ") + b.name;
          throw ConfigError(
              "regions[" + std::to_string(k) + "].body",
              "no boundary body named '" + r.body + "' (bodies: " + (names.empty() ? "none" : names) + ")");
        }
        body_index_[k] = index;
        BoundaryConfig shape = scene.boundaries[index];
        const bool was_closed = shape.type != ShapeType::Mesh || shape.mesh_closed;
        if (shape.type == ShapeType::Cylinder) shape.cylinder.axis.normalize();
        if (shape.type == ShapeType::Mesh)
        {
          // The inside test (insideShape) wants a closed, outward mesh; an open one (a cup) is
          // closed over its rim, a closed one is only oriented (its normals may point inward).
          shape.mesh = closeOpenings(shape.mesh);
          shape.mesh_closed = true;
        }
        capacity_[k] = shapeVolume(shape);  // the geometric inside
        // A container's particle layer lies half a spacing outside its surface (boundary_sampling),
        // and its water reaches the surface itself: the tank rostest's URDF box lost 2 of 432
        // particles at the geometric walls. Counted up to the layer, as the sampler grows the
        // shape (not for open meshes or offset none, whose layer is on the surface).
        const double grow = 0.5 * scene.spacing;  // m
        if (shape.inside && was_closed) switch (shape.type)
          {
            case ShapeType::Box:
              shape.box.min -= Vec3d::Constant(grow);
              shape.box.max += Vec3d::Constant(grow);
              break;
            case ShapeType::Sphere:
              shape.sphere.radius += grow;
              break;
            case ShapeType::Cylinder:
              shape.cylinder.radius += grow;
              shape.cylinder.length += 2.0 * grow;
              break;
            case ShapeType::Mesh:
              if (shape.mesh_offset == SurfaceOffset::Auto) shape.mesh = offsetMesh(shape.mesh, grow);
              break;
          }
        if (shape.type == ShapeType::Mesh) buildInsideIndex(shape.mesh);
        body_shape_[k] = std::move(shape);
        break;
      }
    }
  }
}

Measurements::~Measurements() = default;

bool Measurements::empty() const
{
  return regions_.empty() && probes_.empty() && !spill_.enabled;
}

MeasurementReport Measurements::evaluate(const Simulation& sim, bool probes)
{
  MeasurementReport out;
  out.time = sim.time();
  if (empty()) return out;
  if (!regions_.empty() || spill_.enabled) measureRegions(sim, out);
  if (probes && !probes_.empty()) measureProbes(sim, out);
  return out;
}

MeasurementReport Measurements::evaluateProbes(const Simulation& sim)
{
  MeasurementReport out;
  out.time = sim.time();
  if (!probes_.empty()) measureProbes(sim, out);
  return out;
}

void Measurements::measureRegions(const Simulation& sim, MeasurementReport& out) const
{
  std::vector<RegionTest> tests;
  tests.reserve(regions_.size());
  for (std::size_t k = 0; k < regions_.size(); ++k)
  {
    const RegionConfig& r = regions_[k];
    if (r.shape == RegionShape::Body)
      tests.emplace_back(r, sim.body(body_index_[k]).pose, &body_shape_[k]);  // where the body is now
    else
      tests.emplace_back(r, r.pose, nullptr);
  }
  const std::size_t nr = regions_.size();
  const std::vector<Vec3>& x = sim.positions();
  const std::vector<Vec3>& v = sim.velocities();

  RegionSums zero;
  zero.count.assign(nr, 0);
  zero.velocity.assign(nr, Vec3d::Zero());
  const RegionSums sums = parallelDeterministicSum(
      x.size(), zero,
      [&](const tbb::blocked_range<std::size_t>& range, RegionSums& acc) {
        for (std::size_t i = range.begin(); i != range.end(); ++i)
        {
          const Vec3d p = x[i].cast<double>();
          bool inside_any = false;
          for (std::size_t k = 0; k < nr; ++k)
            if (tests[k].contains(p))
            {
              inside_any = true;
              ++acc.count[k];
              acc.velocity[k] += v[i].cast<double>();
            }
          if (spill_.enabled && !inside_any && p.z() < spill_.below) ++acc.spill;
        }
      },
      [&](RegionSums& left, const RegionSums& right) {
        for (std::size_t k = 0; k < nr; ++k)
        {
          left.count[k] += right.count[k];
          left.velocity[k] += right.velocity[k];
        }
        left.spill += right.spill;
      });

  // Volume = count * m / rho0, the volume each particle carries at rest density, not
  // sum m / rho_f: rho_f is the SPH sum, which falls short wherever the kernel is cut (about
  // 0.5 rho0 on the free surface, less in a splash), so m / rho_f would count a surface particle
  // up to twice. In the bulk the solver holds rho_f within its density tolerance (0.1 %) of rho0.
  const double particle_volume = mass_ / rho0_;  // m^3
  out.regions.resize(nr);
  for (std::size_t k = 0; k < nr; ++k)
  {
    RegionMeasurement& m = out.regions[k];
    m.name = regions_[k].name;
    m.particles = sums.count[k];
    m.volume = double(m.particles) * particle_volume;
    m.mass = double(m.particles) * mass_;
    m.capacity = capacity_[k];
    m.fill_fraction = m.capacity > 0.0 ? m.volume / m.capacity : 0.0;
    m.mean_velocity = m.particles > 0 ? Vec3d(sums.velocity[k] / double(m.particles)) : Vec3d::Zero();
  }
  out.spill.enabled = spill_.enabled;
  out.spill.below = spill_.below;
  if (spill_.enabled)
  {
    out.spill.particles = sums.spill;
    out.spill.volume = double(sums.spill) * particle_volume;
    out.spill.mass = double(sums.spill) * mass_;
  }
}

void Measurements::measureProbes(const Simulation& sim, MeasurementReport& out)
{
  if (!fluid_grid_)
  {
    // One grid around all probes, grown by the support: every particle within reach of a probe
    // is in it. Cells of the support, so that the 27 cells around a probe's cell hold them all.
    Vec3d lo = probes_.front().position, hi = lo;
    for (const ProbeConfig& p : probes_)
    {
      lo = lo.cwiseMin(p.position);
      hi = hi.cwiseMax(p.position);
    }
    lo -= Vec3d::Constant(support_);
    hi += Vec3d::Constant(support_);
    double cell = support_;  // m
    const double volume = (hi - lo + Vec3d::Constant(3.0 * cell)).prod();
    if (volume / (cell * cell * cell) > kMaxProbeGridCells) cell = std::cbrt(volume / kMaxProbeGridCells);
    fluid_grid_ = std::make_unique<UniformGrid>(lo, hi, cell);
    boundary_grid_ = std::make_unique<UniformGrid>(lo, hi, cell);
  }
  const std::vector<Vec3>& x = sim.positions();
  const std::vector<Vec3>& v = sim.velocities();
  const std::vector<Real>& p = sim.pressures();
  const std::vector<Vec3>& xb = sim.boundaryPositions();
  const std::vector<Real>& vb = sim.boundaryVolumes();
  fluid_grid_->build(x);
  boundary_grid_->build(xb);

  const CubicKernel kernel{Real(support_)};
  const double h2 = support_ * support_;         // m^2
  const double particle_volume = mass_ / rho0_;  // m^3
  out.probes.resize(probes_.size());
  for (std::size_t k = 0; k < probes_.size(); ++k)
  {
    ProbeMeasurement& m = out.probes[k];
    m.name = probes_[k].name;
    m.position = probes_[k].position;
    const Vec3 q = m.position.cast<Real>();
    // Sums of W (1/m^3), p W (Pa/m^3) and v W over the fluid neighbours; all fluid particles
    // carry the same volume m/rho0, so the Shepard weights V_f W reduce to W.
    double w_sum = 0.0, pw_sum = 0.0;
    Vec3d vw_sum = Vec3d::Zero();
    const std::vector<Index>& order = fluid_grid_->order();
    fluid_grid_->forEachRange(q, 1, [&](Index begin, Index end) {
      for (Index s = begin; s < end; ++s)
      {
        const Index i = order[s];
        const Real r2 = (x[i] - q).squaredNorm();
        if (r2 >= h2) continue;
        const double w = kernel.W(std::sqrt(r2));
        w_sum += w;
        pw_sum += w * p[i];
        vw_sum += w * v[i].cast<double>();
      }
    });
    double wall_sum = 0.0;  // sum_b V_b W, unit-less
    const std::vector<Index>& border = boundary_grid_->order();
    boundary_grid_->forEachRange(q, 1, [&](Index begin, Index end) {
      for (Index s = begin; s < end; ++s)
      {
        const Index b = border[s];
        const Real r2 = (xb[b] - q).squaredNorm();
        if (r2 >= h2) continue;
        wall_sum += double(vb[b]) * kernel.W(std::sqrt(r2));
      }
    });
    m.fluid_support = particle_volume * w_sum;
    m.wall_support = wall_sum;
    // As the solver sums it (Eq. A1): fluid mass plus the walls' rest mass psi_b = rho0 V_b.
    m.density = mass_ * w_sum + rho0_ * wall_sum;
    m.wet = wetness(m.fluid_support, m.wall_support);
    if (m.wet)
    {
      m.pressure = pw_sum / w_sum;
      m.velocity = vw_sum / w_sum;
    }
  }
}

}  // namespace fluid_sim
