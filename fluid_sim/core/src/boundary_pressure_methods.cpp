// The pressure extrapolations' per-step work (see boundary_pressure_methods.h): which boundary
// particles take part, their fit neighbourhoods and coefficients, and p_b in every iteration.

#include "fluid_sim/core/boundary_pressure_methods.h"

#include <algorithm>
#include <cmath>

#include "fluid_sim/core/boundary_pressure.h"
#include "fluid_sim/core/parallel.h"

namespace fluid_sim
{
ExtrapolatedBoundaryPressure::ExtrapolatedBoundaryPressure(const BoundaryPressureInputs& in, Real fit_radius)
    : in_(in)
    , inv_rho0_sq_(Real(1) / (in.constants.rho0 * in.constants.rho0))
    , fit_radius_(fit_radius)
    , xb_(in.bodies.x)
    , volume_(in.bodies.volume)
    , pb_(in.bodies.numParticles(), Real(0))
    , constant_(in.bodies.numParticles(), Real(0))
    , is_active_(new std::atomic<std::uint8_t>[in.bodies.numParticles()])
{
}

void ExtrapolatedBoundaryPressure::buildLists()
{
  const FluidParticles& fluid = in_.fluid;
  const NeighborLists& fb = in_.neighbors.fluid_boundary;
  const std::size_t nb = in_.bodies.numParticles();
  // A boundary particle is active when a fluid particle lists it. Many fluid particles list the
  // same one: the flags are atomics (relaxed stores of the same value, no data race).
  for (std::size_t b = 0; b < nb; ++b) is_active_[b].store(0, std::memory_order_relaxed);
  parallelFor(fluid.size(), [&](std::size_t i) {
    for (Index k = fb.offset[i]; k < fb.offset[i + 1]; ++k) is_active_[fb.index[k]].store(1, std::memory_order_relaxed);
  });
  active_.clear();
  for (std::size_t b = 0; b < nb; ++b)
    if (is_active_[b].load(std::memory_order_relaxed)) active_.push_back(Index(b));
  queries_.resize(active_.size());
  for (std::size_t k = 0; k < active_.size(); ++k) queries_[k] = xb_[active_[k]];
  const CubicKernel fit_kernel(fit_radius_);
  auto weight = [&fit_kernel](Real d2) -> Real { return fit_kernel.W(std::sqrt(d2)); };
  static const std::vector<Index> kIdentity;  // the sorted fluid is in grid order
  buildNeighborLists(queries_, in_.neighbors.fluidGrid(), fluid.x, kIdentity, fit_radius_, false, NoPairValue{}, weight,
                     fit_lists_);
  coefficients_.resize(fit_lists_.pairs());
}

void ExtrapolatedBoundaryPressure::extrapolate(const std::vector<Real>& p, bool density_solve, bool with_constant)
{
  const SolverConfig& solver = in_.scene.solver;
  const bool limit = solver.limit_boundary_pressure;
  const bool clamp = density_solve && solver.clamp_boundary_pressure;
  const Real rho0 = in_.constants.rho0;
  const Vec3 gravity = in_.constants.gravity;
  const std::vector<Vec3>& ab = in_.bodies.a;
  // Eq. A11 (solver.limit_boundary_pressure): p_b within [min p_f, max p_f] +- rho0 |g - a_b| 5 s
  // (Pa). The hydrostatic difference between the wall and its nearest water is about 1 s; the
  // rest is margin for the pressure noise of a converged solve (docs/method_notes.md).
  const Real reach = Real(5.0 * in_.scene.spacing) * rho0;  // kg/m^2
  parallelRanges(active_.size(), 512, [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t q = r.begin(); q != r.end(); ++q)
    {
      const Index b = active_[q];
      Real value = with_constant ? constant_[b] : Real(0);
      const Index begin = fit_lists_.offset[q], end = fit_lists_.offset[q + 1];
      if (begin == end)
      {
        pb_[b] = 0;  // no fluid neighbour within the fit radius
        continue;
      }
      Real lo = p[fit_lists_.index[begin]], hi = lo;
      for (Index k = begin; k < end; ++k)
      {
        const Real pf = p[fit_lists_.index[k]];
        value += coefficients_[k] * pf;  // Eq. 3 / Eq. 15 as sum_f c_bf p_f
        lo = std::min(lo, pf);
        hi = std::max(hi, pf);
      }
      if (limit)
      {
        const Real widen = reach * (gravity - ab[b]).norm();
        value = std::clamp(value, lo - widen, hi + widen);
      }
      pb_[b] = clamp ? std::max(value, Real(0)) : value;
    }
  });
}

SphBoundaryPressure::SphBoundaryPressure(const BoundaryPressureInputs& in)
    : ExtrapolatedBoundaryPressure(in, in.constants.support)
{
}

void SphBoundaryPressure::prepare()
{
  const FluidParticles& fluid = in_.fluid;
  const Vec3 gravity = in_.constants.gravity;
  const std::vector<Vec3>& ab = in_.bodies.a;
  std::fill(constant_.begin(), constant_.end(), 0);
  parallelRanges(active_.size(), 256, [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t q = r.begin(); q != r.end(); ++q)
    {
      const Index b = active_[q];
      const Index begin = fit_lists_.offset[q];
      const int count = int(fit_lists_.offset[q + 1] - begin);
      const Index* idx = fit_lists_.index.data() + begin;
      auto pos = [&](int k) -> const Vec3& { return fluid.x[idx[k]]; };
      auto dens = [&](int k) { return fluid.rho[idx[k]]; };
      // Eq. 3: weights W_bf, constant (g - a_b) . sum_f rho_f (x_b - x_f) W_bf / sum W.
      sphCoefficients(xb_[b], count, pos, dens, fit_lists_.weight.data() + begin, Vec3(gravity - ab[b]),
                      coefficients_.data() + begin, constant_[b]);
    }
  });
}

MlsBoundaryPressure::MlsBoundaryPressure(const BoundaryPressureInputs& in)
    : ExtrapolatedBoundaryPressure(in, Real(in.scene.solver.mls_fit_radius * in.scene.spacing))
{
}

void MlsBoundaryPressure::prepare()
{
  const FluidParticles& fluid = in_.fluid;
  const SolverConfig& solver = in_.scene.solver;
  const Real mass = in_.constants.mass;
  // constant_ stays zero for MLS (set at construction, never written): no per-step refill.
  const std::size_t na = active_.size();
  fit_kind_.assign(na, 0);
  parallelRanges(na, 256, [&](const tbb::blocked_range<std::size_t>& r) {
    std::vector<Real> w;
    for (std::size_t q = r.begin(); q != r.end(); ++q)
    {
      const Index b = active_[q];
      const Index begin = fit_lists_.offset[q];
      const int count = int(fit_lists_.offset[q + 1] - begin);
      const Index* idx = fit_lists_.index.data() + begin;
      auto pos = [&](int k) -> const Vec3& { return fluid.x[idx[k]]; };
      w.resize(count);
      // Eqs. 7-14 weight each neighbour by V_f W_bf (m^3 * 1/m^3).
      for (int k = 0; k < count; ++k) w[k] = fit_lists_.weight[begin + k] * (mass / fluid.rho[idx[k]]);
      const MlsFit fit = mlsCoefficients(xb_[b], count, pos, w.data(), solver.mls_fit_radius * in_.scene.spacing,
                                         solver.mls_eigen_tolerance, solver.mls_singular, coefficients_.data() + begin);
      fit_kind_[q] = std::uint8_t(fit);
    }
  });
  fallbacks_ = reduced_ = 0;
  for (std::uint8_t k : fit_kind_)
  {
    fallbacks_ += k == std::uint8_t(MlsFit::Fallback);
    reduced_ += k == std::uint8_t(MlsFit::Reduced);
  }
}

}  // namespace fluid_sim
