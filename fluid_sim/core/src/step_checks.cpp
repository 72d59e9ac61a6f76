// Stability checks, removal and the time step (see step_checks.h).

#include "fluid_sim/core/step_checks.h"

#include <algorithm>
#include <limits>
#include <sstream>
#include <string>

#include "fluid_sim/core/parallel.h"

namespace fluid_sim
{
void checkStability(const FluidParticles& fluid, const SceneConfig& scene, Real mass, double dt, StepReport& rep)
{
  const std::size_t n = fluid.size();
  const std::vector<Vec3>& x = fluid.x;
  const std::vector<Vec3>& v = fluid.v;
  const double nonfinite =
      parallelSum(n, [&](std::size_t i) { return (x[i].allFinite() && v[i].allFinite()) ? 0.0 : 1.0; });
  rep.max_speed = parallelMax(n, [&](std::size_t i) { return v[i].norm(); });
  rep.kinetic_energy = 0.5 * double(mass) * parallelSum(n, [&](std::size_t i) { return double(v[i].squaredNorm()); });
  if (nonfinite > 0)
  {
    // A maximum over NaN speeds compares false and read 0 in stats.csv beside the blow-up.
    rep.max_speed = std::numeric_limits<double>::quiet_NaN();
    rep.unstable = true;
    rep.reason = std::to_string(std::size_t(nonfinite)) + " particles with non-finite position or velocity";
  }
  else if (rep.density_error > scene.stability.max_density_error)
  {
    std::ostringstream os;
    os << "mean density error " << rep.density_error << " above stability.max_density_error "
       << scene.stability.max_density_error;
    rep.unstable = true;
    rep.reason = os.str();
  }
  else if (rep.max_speed * dt > scene.stability.max_cfl * scene.spacing)
  {
    std::ostringstream os;
    os << "max speed " << rep.max_speed << " m/s moves " << rep.max_speed * dt / scene.spacing
       << " spacings per step, above stability.max_cfl " << scene.stability.max_cfl;
    rep.unstable = true;
    rep.reason = os.str();
  }
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
