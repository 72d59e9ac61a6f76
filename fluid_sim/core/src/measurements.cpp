// Instruments: regions (water volume, mass, mean velocity inside), probes (SPH interpolation at a
// point) and spill, read from the fluid state between steps (measurements.h).

#include "fluid_sim/core/measurements.h"

#include <algorithm>
#include <cmath>

#include "fluid_sim/core/kernel.h"
#include "fluid_sim/core/neighbor_search.h"
#include "fluid_sim/core/parallel.h"
#include "fluid_sim/core/simulation.h"

namespace fluid_sim
{
namespace
{
/// Most cells of a probe grid (4 bytes each): probes spread over a large domain get coarser cells
/// instead of a grid of the domain's size at the kernel support.
constexpr double kMaxProbeGridCells = 4.0e6;

/// A region's inside test, with the box's rotation as a matrix (one per evaluation, not per particle).
struct RegionTest
{
  RegionShape shape;
  Mat3d world_to_local;  // R^T of the box's pose
  Vec3d translation;     // m, of the box's pose
  Vec3d min, max;        // m, the box in its frame
  Vec3d center;          // m, the sphere's
  double radius2;        // m^2, the sphere's squared radius

  explicit RegionTest(const RegionConfig& r)
      : shape(r.shape)
      , world_to_local(r.pose.rotation.toRotationMatrix().transpose())
      , translation(r.pose.translation)
      , min(r.box.min)
      , max(r.box.max)
      , center(r.sphere.center)
      , radius2(r.sphere.radius * r.sphere.radius)
  {
  }

  bool contains(const Vec3d& p) const
  {
    if (shape == RegionShape::Sphere) return (p - center).squaredNorm() <= radius2;
    const Vec3d local = world_to_local * (p - translation);
    return (local.array() >= min.array()).all() && (local.array() <= max.array()).all();
  }
};

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

Measurements::Measurements(const SceneConfig& scene)
    : regions_(scene.regions)
    , probes_(scene.probes)
    , spill_(scene.spill)
    , domain_(scene.domain)
    , support_(2.0 * scene.spacing)
    , mass_(scene.rest_density * scene.spacing * scene.spacing * scene.spacing)
    , rho0_(scene.rest_density)
{
}

Measurements::~Measurements() = default;

bool Measurements::empty() const
{
  return regions_.empty() && probes_.empty() && !spill_.enabled;
}

double Measurements::capacity(const RegionConfig& region)
{
  if (region.shape == RegionShape::Sphere) return 4.0 / 3.0 * M_PI * std::pow(region.sphere.radius, 3);
  return (region.box.max - region.box.min).prod();
}

bool Measurements::contains(const RegionConfig& region, const Vec3d& point)
{
  return RegionTest(region).contains(point);
}

MeasurementReport Measurements::evaluate(const Simulation& sim)
{
  MeasurementReport out;
  out.time = sim.time();
  if (empty()) return out;
  if (!regions_.empty() || spill_.enabled) measureRegions(sim, out);
  if (!probes_.empty()) measureProbes(sim, out);
  return out;
}

void Measurements::measureRegions(const Simulation& sim, MeasurementReport& out) const
{
  std::vector<RegionTest> tests;
  tests.reserve(regions_.size());
  for (const RegionConfig& r : regions_) tests.emplace_back(r);
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
    m.capacity = capacity(regions_[k]);
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
