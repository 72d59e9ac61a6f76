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
  findActive();
  if (fit_radius_ == in_.constants.kernel.support())
  {
    // A fit over the kernel support (SPH's always, MLS's at its default radius of 2 spacings)
    // has exactly the pairs of the fluid-boundary lists, from the same r^2 (the search's distance
    // test negates the difference, which squares to the same value) and so the same W: their
    // transpose, without a second search. Bit-identical to the search; at 33 k (MLS) the fit
    // search took 2.3 % of a step and looking each pair up in its fit row another 2.8 %
    // (docs/performance.md).
    transposeBoundaryLists();
  }
  else
    searchFitLists();
  coefficients_.resize(fit_lists_.pairs());
}

void ExtrapolatedBoundaryPressure::findActive()
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
  row_of_.resize(nb);  // read only for active particles: no reset needed
  for (std::size_t k = 0; k < active_.size(); ++k) row_of_[active_[k]] = Index(k);
}

void ExtrapolatedBoundaryPressure::searchFitLists()
{
  fb_to_fit_.clear();  // feedbackVector() then looks each pair up in its fit row
  queries_.resize(active_.size());
  for (std::size_t k = 0; k < active_.size(); ++k) queries_[k] = xb_[active_[k]];
  const CubicKernel fit_kernel(fit_radius_);
  auto weight = [&fit_kernel](Real d2) -> Real { return fit_kernel.W(std::sqrt(d2)); };
  // The sorted fluid with the coordinate arrays the step's search already made.
  buildNeighborLists(queries_, std::vector<GridPoints>{in_.neighbors.fluidPoints(in_.fluid)}, fit_radius_, false,
                     NoPairValue{}, weight, fit_lists_);
}

void ExtrapolatedBoundaryPressure::transposeBoundaryLists()
{
  const NeighborLists& fb = in_.neighbors.fluid_boundary;
  const std::size_t n = in_.fluid.size(), rows = active_.size(), pairs = fb.pairs();
  // A counting sort by row in kTransposeChunks fixed ranges of the fluid: each range counts its
  // pairs per row, and fills its own slots of each row, the ranges in order, so every row comes
  // out in ascending fluid order (fb's rows are the fluid in ascending order) with no sort and no
  // atomics, and the same for any thread count.
  const std::size_t chunks = std::min<std::size_t>(kTransposeChunks, std::max<std::size_t>(n, 1));
  const std::size_t per_chunk = (n + chunks - 1) / chunks;
  transpose_slot_.assign(chunks * rows, 0);  // per chunk and row: its count, then its next slot
  tbb::parallel_for(std::size_t(0), chunks, [&](std::size_t c) {
    Index* const count = transpose_slot_.data() + c * rows;
    const std::size_t i_end = std::min(n, (c + 1) * per_chunk);
    for (std::size_t i = c * per_chunk; i < i_end; ++i)
      for (Index k = fb.offset[i]; k < fb.offset[i + 1]; ++k) ++count[row_of_[fb.index[k]]];
  });
  fit_lists_.offset.resize(rows + 1);
  fit_lists_.offset[0] = 0;
  for (std::size_t q = 0; q < rows; ++q)
  {
    Index next = fit_lists_.offset[q];
    for (std::size_t c = 0; c < chunks; ++c)
    {
      const Index count = transpose_slot_[c * rows + q];
      transpose_slot_[c * rows + q] = next;
      next += count;
    }
    fit_lists_.offset[q + 1] = next;
  }
  fit_lists_.index.resize(pairs);
  fit_lists_.weight.resize(pairs);
  fit_lists_.grad_factor.clear();
  fit_lists_.weight_sum.clear();
  fb_to_fit_.resize(pairs);
  tbb::parallel_for(std::size_t(0), chunks, [&](std::size_t c) {
    Index* const slot = transpose_slot_.data() + c * rows;
    const std::size_t i_end = std::min(n, (c + 1) * per_chunk);
    for (std::size_t i = c * per_chunk; i < i_end; ++i)
      for (Index k = fb.offset[i]; k < fb.offset[i + 1]; ++k)
      {
        const Index e = slot[row_of_[fb.index[k]]]++;
        fit_lists_.index[e] = Index(i);
        fit_lists_.weight[e] = fb.weight[k];
        fb_to_fit_[k] = e;
      }
  });
}

void ExtrapolatedBoundaryPressure::extrapolate(const std::vector<Real>& p, bool density_solve, bool with_constant)
{
  const SolverConfig& solver = in_.scene.solver;
  const bool limit = solver.limit_boundary_pressure;
  const bool clamp = density_solve && solver.clamp_boundary_pressure;
  const Real rho0 = in_.constants.rho0;
  const Vec3 gravity = in_.constants.gravity;
  const std::vector<Vec3>& ab = in_.bodies.a;
  // Eq. A11 (solver.limit_boundary_pressure): p_b within [min p_f, max p_f] +- rho0 |g - a_b| r_fit
  // (Pa). Every neighbour f of the fit lies within r_fit of b, so in water whose pressure is
  // hydrostatic in the body's frame, p_b differs from each p_f by at most rho0 |g - a_b| r_fit:
  // the limit never binds there, and it stops a fit over few one-sided neighbours (a splash, an
  // impact) from predicting more than that.
  const Real reach = fit_radius_ * rho0;  // kg/m^2
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

namespace
{
struct CoefficientFigures
{
  double c_min = 0, c_max = 0, abs_sum_max = 0, abs_sum = 0;
  bool any = false;
};
}  // namespace

void ExtrapolatedBoundaryPressure::coefficientFigures()
{
  const CoefficientFigures f = parallelDeterministicSum(
      active_.size(), CoefficientFigures{},
      [&](const tbb::blocked_range<std::size_t>& r, CoefficientFigures& acc) {
        for (std::size_t q = r.begin(); q != r.end(); ++q)
        {
          double abs_sum = 0;
          for (Index k = fit_lists_.offset[q]; k < fit_lists_.offset[q + 1]; ++k)
          {
            const double c = coefficients_[k];
            acc.c_min = acc.any ? std::min(acc.c_min, c) : c;
            acc.c_max = acc.any ? std::max(acc.c_max, c) : c;
            acc.any = true;
            abs_sum += std::abs(c);
          }
          acc.abs_sum_max = std::max(acc.abs_sum_max, abs_sum);
          acc.abs_sum += abs_sum;
        }
      },
      [](CoefficientFigures& left, const CoefficientFigures& right) {
        if (right.any)
        {
          left.c_min = left.any ? std::min(left.c_min, right.c_min) : right.c_min;
          left.c_max = left.any ? std::max(left.c_max, right.c_max) : right.c_max;
          left.any = true;
        }
        left.abs_sum_max = std::max(left.abs_sum_max, right.abs_sum_max);
        left.abs_sum += right.abs_sum;
      });
  c_min_ = f.c_min;
  c_max_ = f.c_max;
  abs_sum_max_ = f.abs_sum_max;
  abs_sum_mean_ = active_.empty() ? 0.0 : f.abs_sum / double(active_.size());
}

void ExtrapolatedBoundaryPressure::reportCoefficients(StepReport& rep) const
{
  rep.coefficient_min = c_min_;
  rep.coefficient_max = c_max_;
  rep.coefficient_abs_sum_max = abs_sum_max_;
  rep.coefficient_abs_sum_mean = abs_sum_mean_;
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
  coefficientFigures();
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
  // Every entry is written below; resize keeps the storage while na (the active boundary
  // particles) creeps up, where assign reallocated it at each new largest na.
  fit_kind_.resize(na);
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
  coefficientFigures();
  fallbacks_ = reduced_ = 0;
  for (std::uint8_t k : fit_kind_)
  {
    fallbacks_ += k == std::uint8_t(MlsFit::Fallback);
    reduced_ += k == std::uint8_t(MlsFit::Reduced);
  }
}

}  // namespace fluid_sim
