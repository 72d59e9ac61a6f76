// Stability checks, removal and the time step (see step_checks.h).

#include "fluid_sim/core/step_checks.h"

#include <algorithm>
#include <limits>
#include <map>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "fluid_sim/core/parallel.h"

namespace fluid_sim
{
std::size_t checkStability(const FluidParticles& fluid, const SceneConfig& scene, Real mass, double dt, StepReport& rep)
{
  const std::size_t n = fluid.size();
  const std::vector<Vec3>& x = fluid.x;
  const std::vector<Vec3>& v = fluid.v;
  const double nonfinite =
      parallelSum(n, [&](std::size_t i) { return (x[i].allFinite() && v[i].allFinite()) ? 0.0 : 1.0; });
  rep.max_speed = parallelMax(n, [&](std::size_t i) { return v[i].norm(); });
  rep.kinetic_energy = 0.5 * double(mass) * parallelSum(n, [&](std::size_t i) { return double(v[i].squaredNorm()); });
  // The particle a reason is about: found by a serial scan, only for a step that is reported.
  const auto first = [&](auto&& better) {
    std::size_t best = kNoParticle;
    for (std::size_t i = 0; i < n; ++i)
      if (best == kNoParticle || better(i, best)) best = i;
    return best;
  };
  if (nonfinite > 0)
  {
    // A maximum over NaN speeds compares false and read 0 in stats.csv beside the blow-up.
    rep.max_speed = std::numeric_limits<double>::quiet_NaN();
    rep.unstable = true;
    rep.reason = std::to_string(std::size_t(nonfinite)) + " particles with non-finite position or velocity";
    for (std::size_t i = 0; i < n; ++i)
      if (!x[i].allFinite() || !v[i].allFinite()) return i;
    return kNoParticle;
  }
  if (rep.density_error > scene.stability.max_density_error)
  {
    std::ostringstream os;
    os << "mean density error " << rep.density_error << " above stability.max_density_error "
       << scene.stability.max_density_error;
    rep.unstable = true;
    rep.reason = os.str();
    return first([&](std::size_t i, std::size_t best) { return fluid.rho[i] > fluid.rho[best]; });
  }
  if (rep.max_speed * dt > scene.stability.max_cfl * scene.spacing)
  {
    std::ostringstream os;
    os << "max speed " << rep.max_speed << " m/s moves " << rep.max_speed * dt / scene.spacing
       << " spacings per step, above stability.max_cfl " << scene.stability.max_cfl;
    rep.unstable = true;
    rep.reason = os.str();
    return first([&](std::size_t i, std::size_t best) { return v[i].squaredNorm() > v[best].squaredNorm(); });
  }
  return kNoParticle;
}

std::string describeParticle(std::size_t i, double dt, const AxisBox& domain, const FluidParticles& fluid,
                             const Neighborhoods& neighbors, const BodySet& bodies)
{
  // The step's lists belong to the particles in this order (sorted at the step's start; nothing
  // is removed before the check).
  const NeighborLists& ff = neighbors.fluid_fluid;
  const NeighborLists& fb = neighbors.fluid_boundary;
  if (i >= fluid.size() || i + 1 >= ff.offset.size() || i + 1 >= fb.offset.size()) return "";
  std::ostringstream os;
  // Eq. A16 backwards (the wall guard may have moved it a little): where the step took it from.
  const Vec3d start = fluid.x[i].cast<double>() - dt * fluid.v[i].cast<double>();
  std::map<std::size_t, std::size_t> per_body;
  Vec3d walls = Vec3d::Zero();
  for (Index k = fb.offset[i]; k < fb.offset[i + 1]; ++k)
  {
    ++per_body[bodies.body_of[fb.index[k]]];
    walls += bodies.x[fb.index[k]].cast<double>();
  }
  const Index wall_count = fb.offset[i + 1] - fb.offset[i];
  if (start.allFinite() && domain.contains(start))
    os << "the particle that started the step at " << vectorText(start) << " m";
  else if (wall_count > 0)
    os << "the particle that started the step next to the boundary particles around " << vectorText(walls / wall_count)
       << " m";
  else
    os << "the particle";
  const Index fluid_count = ff.offset[i + 1] - ff.offset[i];
  os << " had " << fluid_count << " fluid neighbour" << (fluid_count == 1 ? "" : "s");
  if (per_body.empty()) return os.str() + " and no boundary neighbour";
  std::vector<std::pair<std::size_t, std::size_t>> counts(per_body.begin(), per_body.end());  // (body, count)
  std::stable_sort(counts.begin(), counts.end(), [](const auto& a, const auto& b) { return a.second > b.second; });
  os << " and boundary particles of ";
  for (std::size_t k = 0; k < counts.size(); ++k)
  {
    if (k > 0) os << (k + 1 == counts.size() ? " and " : ", ");
    os << "'" << bodies[counts[k].first].config.name << "' (" << counts[k].second << ")";
  }
  return os.str();
}

std::size_t removeOutsideDomain(FluidParticles& fluid, const AxisBox& domain)
{
  const Vec3 lo = domain.min.cast<Real>(), hi = domain.max.cast<Real>();
  const std::size_t n = fluid.size();
  // Counted first: in most steps nothing leaves, and then no mask (1 B per particle) is made.
  const double outside = parallelSum(n, [&](std::size_t i) { return insideBox(fluid.x[i], lo, hi) ? 0.0 : 1.0; });
  if (outside == 0.0) return 0;
  std::vector<std::uint8_t> inside(n);
  parallelFor(n, [&](std::size_t i) { inside[i] = insideBox(fluid.x[i], lo, hi); });
  return fluid.keepIf(inside);
}

double computeTimeStep(const TimeStepConfig& ts, const FluidParticles& fluid, const Vec3& gravity, double spacing,
                       double body_speed)
{
  if (!ts.adaptive) return ts.fixed;
  const double vmax = parallelMax(fluid.size(), [&](std::size_t i) { return fluid.v[i].norm(); });  // m/s
  // At rest the gravity-driven speed after one max step bounds it. A moving body counts too: a
  // plunger at 5-8 m/s into still water (whose own speed allowed the longest step) moved 1-2
  // spacings into it per step and blew it up in its first steps of contact.
  const double speed = std::max({vmax, body_speed, gravity.norm() * ts.max});
  return std::clamp(ts.cfl * spacing / std::max(speed, 1e-12), ts.min, ts.max);
}

}  // namespace fluid_sim
