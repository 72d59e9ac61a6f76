// The DFSPH pressure solver, compiled once per boundary pressure method (see dfsph_solver.h).
// Equation numbers refer to docs/method.md.

#include "fluid_sim/core/dfsph_solver.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>

// The solver passes four pairs at a time with AVX-512 in float (FLUID_SIM_QUAD_PAIRS below).
#if defined(__AVX512F__) && !defined(FLUID_SIM_USE_DOUBLE)
#define FLUID_SIM_QUAD_PAIRS 1
#include <immintrin.h>
#endif

#include "fluid_sim/core/parallel.h"

namespace fluid_sim
{
namespace
{
#ifdef FLUID_SIM_QUAD_PAIRS
// The solver's passes four pairs at a time (float, AVX-512): each pair's padded Vec4 in one
// 128-bit lane of a 512-bit register, loaded in place (no gather instruction: on this project's
// CPU a 16-lane gather of x, y, z arrays made the passes slower, docs/performance.md). A row's
// pairs then add up in four lane sums, joined at the row's end, and the pairs after the last
// whole four one by one: another order of the same sums than the one-pair loop, whose single
// accumulator chained every pair's add to the last (3 cycles each) and took 12 instructions per
// pair. Deterministic: the order depends only on the row. (The masked forms of the intrinsics,
// all lanes set: GCC 12's unmasked ones warn of an uninitialised operand.)

/// Vec4s `base[j[0..3]]` as the four 128-bit lanes of one register.
inline __m512 loadFourVec4(const Vec4* base, const Index* j)
{
  __m512 r = _mm512_zextps128_ps512(_mm_load_ps(base[j[0]].data()));
  const __mmask16 all = 0xFFFF;
  r = _mm512_maskz_insertf32x4(all, r, _mm_load_ps(base[j[1]].data()), 1);
  r = _mm512_maskz_insertf32x4(all, r, _mm_load_ps(base[j[2]].data()), 2);
  return _mm512_maskz_insertf32x4(all, r, _mm_load_ps(base[j[3]].data()), 3);
}

/// Four scalars, each repeated over its 128-bit lane.
inline __m512 spreadFour(__m128 c)
{
  return _mm512_maskz_permutexvar_ps(
      __mmask16(0xFFFF), _mm512_setr_epi32(0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 2, 3, 3, 3, 3), _mm512_zextps128_ps512(c));
}

/// The four lanes' sum as one Vec4, (lane 0 + lane 2) + (lane 1 + lane 3).
inline __m128 sumLanes(__m512 v)
{
  const __mmask16 all = 0xFFFF;
  const __m512 halves = _mm512_add_ps(v, _mm512_maskz_shuffle_f32x4(all, v, v, 0x4E));  // lanes 2, 3, 0, 1
  return _mm512_maskz_extractf32x4_ps(__mmask8(0xF),
                                      _mm512_add_ps(halves, _mm512_maskz_shuffle_f32x4(all, halves, halves, 0xB1)), 0);
}
#endif

template <class Method>
class DfsphSolver final : public PressureSolver
{
public:
  DfsphSolver(const BoundaryPressureInputs& in, FluidParticles& fluid)
      : in_(in)
      , scene_(in.scene)
      , fluid_(fluid)
      , bodies_(in.bodies)
      , ff_(in.neighbors.fluid_fluid)
      , fb_(in.neighbors.fluid_boundary)
      , rho0_(in.constants.rho0)
      , mass_(in.constants.mass)
      , method_(in)
      , reference_diagonal_(referenceDiagonal())
  {
  }

  void buildBoundaryLists() override
  {
    method_.buildLists();
  }

  void computeDensityAndDiagonal() override
  {
    pressure_passes_ = 0;  // a new step
    densityDiagonalAndRate();
    method_.prepare();
    if constexpr (Method::kExtrapolated) extrapolationFeedback();
  }

  void divergenceSolve(double dt, StepReport& rep, BodyWrenches& wrenches) override
  {
    const std::size_t n = fluid_.size();
    // Eq. A5: only compression counts (the free surface is not pulled in). The density rate is
    // the one of densityDiagonalAndRate(): the velocities have not changed since.
    parallelFor(n, [&](std::size_t i) { source_[i] = -std::max(density_rate_[i], Real(0)) / Real(dt); });
    const bool from_zero = startingPressure(fluid_.p_divergence, false);
    rep.divergence_iterations =
        solve(fluid_.p_divergence, dt, false, scene_.solver.divergence_error, scene_.solver.min_divergence_iterations,
              from_zero, rep.divergence_error, rep.divergence_converged);
    parallelFor(n, [&](std::size_t i) { fluid_.v[i] += Real(dt) * a4_[i].template head<3>(); });  // v*
    accumulateWrenches(fluid_.p_divergence, wrenches);
  }

  void densitySolve(double dt, StepReport& rep, BodyWrenches& wrenches) override
  {
    const std::size_t n = fluid_.size();
    computeDensityRate();  // with v**
    // Eq. A6.
    const Real inv_dt = Real(1.0 / dt), inv_dt2 = Real(1.0 / (dt * dt));
    parallelFor(n, [&](std::size_t i) { source_[i] = (rho0_ - fluid_.rho[i]) * inv_dt2 - density_rate_[i] * inv_dt; });
    const bool from_zero = startingPressure(fluid_.p_density, true);
    density_residual_max_.clear();
    rep.density_iterations = solve(fluid_.p_density, dt, true, scene_.solver.density_error,
                                   scene_.solver.min_iterations, from_zero, rep.density_error, rep.density_converged);
    accumulateWrenches(fluid_.p_density, wrenches);
  }

  void integrate(double dt) override
  {
    const std::size_t n = fluid_.size();
    // Eq. A16 (symplectic Euler).
    parallelFor(n, [&](std::size_t i) {
      fluid_.v[i] += Real(dt) * a4_[i].template head<3>();
      fluid_.x[i] += Real(dt) * fluid_.v[i];
    });
    // Output: the pressure that acted on each particle over the step is the sum of both solves'.
    const bool divergence = scene_.solver.divergence_solve;
    fluid_.p_total.resize(n);
    parallelFor(n, [&](std::size_t i) {
      fluid_.p_total[i] = fluid_.p_density[i] + (divergence ? fluid_.p_divergence[i] : Real(0));
    });
  }

  ForceScratch forceScratch() override
  {
    // Between the solves: v4_ is padded again by the density solve's density rate, a4_ written by
    // its first a^p, and p_over_rho2_ by that a^p too (the divergence solve's wrenches, its last
    // reader, are added before the non-pressure forces).
    return ForceScratch{v4_, a4_, p_over_rho2_};
  }

  double boundaryPressureWork() const override
  {
    // sum_i m wall_dv_i . v_i(t + dt): the displacement of the step is dt v(t + dt).
    return double(mass_) *
           parallelSum(fluid_.size(), [&](std::size_t i) { return double(wall_dv_[i].dot(fluid_.v[i])); });
  }

  Real wallPressure(std::size_t i, Index b) const override
  {
    return method_.contactPressure(b, fluid_.p_density[i]);
  }

  void report(StepReport& rep) const override
  {
    method_.report(rep, bodies_);
    rep.feedback_ratio_min = feedback_ratio_min_;
    rep.feedback_ratio_max = feedback_ratio_max_;
    rep.pressure_passes = pressure_passes_;
    rep.density_residual_max = density_residual_max_;
  }

  const std::vector<Real>& boundaryPressures() const override
  {
    return method_.boundaryPressures();
  }

private:
  /// |A_i| (Eq. A4) of a particle in a full cubic lattice without boundary: the scale of the
  /// diagonal, for the lone-particle guard.
  double referenceDiagonal() const
  {
    const CubicKernel& kernel = in_.constants.kernel;
    const Real s = in_.constants.spacing;
    Vec3 g = Vec3::Zero();
    double sq = 0.0, density = mass_ * kernel.W0();
    for (int k = -2; k <= 2; ++k)
      for (int j = -2; j <= 2; ++j)
        for (int i = -2; i <= 2; ++i)
        {
          if (i == 0 && j == 0 && k == 0) continue;
          const Vec3 r = Vec3(Real(i), Real(j), Real(k)) * s;
          const Vec3 gw = kernel.gradW(r);
          g += mass_ * gw;
          sq += double(mass_) * mass_ * gw.squaredNorm();
          density += mass_ * kernel.W(r);
        }
    return (g.squaredNorm() + sq) / (density * density);
  }

  /// Eqs. A1, A4 and A2 in one pass over the pairs (the divergence solve needs the density rate
  /// next): density (kg/m^3), diagonal A_i, boundary gradient sum grad_b (kg/m^4) and density rate
  /// with the current velocities (kg/m^3/s).
  void densityDiagonalAndRate()
  {
    const std::size_t n = fluid_.size();
    diagonal_.resize(n);
    density_rate_.resize(n);
    grad_b_.resize(n);
    // The extrapolations keep gsum_i for Eq. A4b in a4_, which holds nothing until the divergence
    // solve's first a^p (12 B per particle less than an array of its own).
    if constexpr (Method::kExtrapolated) a4_.resize(n);
    if constexpr (kWallOnlyStart) wall_zone_.resize(n);
    source_.resize(n);
    wall_dv_.assign(n, Vec3::Zero());  // a new step: the wall-work record restarts at zero
#ifdef FLUID_SIM_QUAD_PAIRS
    fluid_grad_.resize(n);
    // Between the first and the last particle in cell order: inside the fluid's bounding box.
    if (n > 0) lane_origin_ = Real(0.5) * (fluid_.x.front() + fluid_.x.back());
#endif
    padPositions();
    padVelocities();
    const Real w0 = in_.constants.kernel.W0();
    const std::vector<Vec3>& xb = bodies_.x;
    const std::vector<Vec3>& vb = rateWallVelocities();
    const std::vector<Real>& Vb = bodies_.volume;
    parallelFor(n, [&](std::size_t i) {
      const Vec3 xi = fluid_.x[i], vi = fluid_.v[i];
      const Vec4 xi4 = x4_[i], vi4 = v4_[i];
      // Eq. A1: the fluid neighbours' sum of W comes from the search (the lists store no W).
      Real density = mass_ * (w0 + ff_.weight_sum[i]);
      Vec4 gf4 = Vec4::Zero(), sq4 = Vec4::Zero(), rate4 = Vec4::Zero();
      Index k = ff_.offset[i];
      const Index end = ff_.offset[i + 1];
#ifdef FLUID_SIM_QUAD_PAIRS
      {
        // Four pairs at a time (FLUID_SIM_QUAD_PAIRS): g = grad_factor (x_i - x_j) per lane.
        const __m512 xi16 = _mm512_maskz_broadcast_f32x4(__mmask16(0xFFFF), _mm_load_ps(xi4.data()));
        const __m512 vi16 = _mm512_maskz_broadcast_f32x4(__mmask16(0xFFFF), _mm_load_ps(vi4.data()));
        __m512 gacc = _mm512_setzero_ps(), sqacc = _mm512_setzero_ps(), racc = _mm512_setzero_ps();
        for (; k + 4 <= end; k += 4)
        {
          const Index* const j = ff_.index.data() + k;
          const __m512 g = _mm512_mul_ps(spreadFour(_mm_loadu_ps(ff_.grad_factor.data() + k)),
                                         _mm512_sub_ps(xi16, loadFourVec4(x4_.data(), j)));
          gacc = _mm512_add_ps(gacc, g);
          sqacc = _mm512_fmadd_ps(g, g, sqacc);
          racc = _mm512_fmadd_ps(_mm512_sub_ps(vi16, loadFourVec4(v4_.data(), j)), g, racc);
        }
        _mm_store_ps(gf4.data(), sumLanes(gacc));
        _mm_store_ps(sq4.data(), sumLanes(sqacc));
        _mm_store_ps(rate4.data(), sumLanes(racc));
      }
#endif
      for (; k < end; ++k)
      {
        const Index j = ff_.index[k];
        const Vec4 g = ff_.grad_factor[k] * (xi4 - x4_[j]);
        gf4 += g;
        sq4 += g.cwiseProduct(g);
        rate4 += (vi4 - v4_[j]).cwiseProduct(g);
      }
      const Vec3 gf = gf4.template head<3>();
#ifdef FLUID_SIM_QUAD_PAIRS
      fluid_grad_[i] = gf;
#endif
      const Real sq = sq4.sum();
      Real rate = mass_ * rate4.sum();
      Vec3 gb = Vec3::Zero();
      for (Index k = fb_.offset[i]; k < fb_.offset[i + 1]; ++k)
      {
        const Index b = fb_.index[k];
        const Vec3 r = xi - xb[b];
        const Real psi = rho0_ * Vb[b];  // kg: the boundary particle's rest mass (Akinci)
        density += psi * fb_.weight[k];
        const Vec3 g = (psi * fb_.grad_factor[k]) * r;
        gb += g;
        rate += (vi - vb[b]).dot(g);
      }
      fluid_.rho[i] = density;
      density_rate_[i] = rate;
      grad_b_[i] = gb;
      if constexpr (kWallOnlyStart)
      {
        // Where a density solve from zero first has a^p != 0 (the wall term of the hydrostatic
        // constant, solve()): i's own wall neighbours, or a fluid neighbour's. The row's indices
        // are still in cache; the first hit ends the scan.
        bool zone = fb_.offset[i] != fb_.offset[i + 1];
        for (Index k = ff_.offset[i]; !zone && k < ff_.offset[i + 1]; ++k)
        {
          const Index j = ff_.index[k];
          zone = fb_.offset[j] != fb_.offset[j + 1];
        }
        wall_zone_[i] = zone;
      }
      const Vec3 gsum = mass_ * gf + gb;
      if constexpr (Method::kExtrapolated) a4_[i] << gsum, Real(0);
      diagonal_[i] = -(gsum.squaredNorm() + mass_ * mass_ * sq) / (density * density);
      method_.addDiagonalFeedback(diagonal_[i], gb, gsum);
      if (-diagonal_[i] < 1e-6 * reference_diagonal_) diagonal_[i] = 0;  // lone particle: no pressure
    });
  }

  /// Eq. A4d: next to a wall whose pressure is extrapolated, from a solve's second sweep on, |A_i|
  /// is taken no smaller than this fraction of a full neighbourhood's. Where the wall gradients
  /// cancel and few fluid neighbours are left (a particle between two walls, or pressed into one)
  /// A_i is small, a Jacobi step p_i += omega r_i / A_i long, and the neighbours' equations lean
  /// on p_i through the walls' fits more than its own does: Jacobi diverged there over tens of
  /// sweeps (the squeeze of Eq. A4c, 0.02 s later, at A_i = 7 % with a positive ratio; floors of
  /// 0.05 to 0.3 all held). The floor only shortens such steps; the solution the sweeps converge
  /// to does not depend on the diagonal. The first sweep keeps the full step, the pressure the
  /// particle's own equation asks for: most solves end after the two minimum sweeps, and a
  /// particle thrown against a wall needs that pressure at once (floored from the first sweep,
  /// validation case 6's drum at 1.8-2.0 ms and washing machine at 2.6-3.0 ms, MLS and SPH, let a
  /// particle through a wall in 11 of 36 runs; unfloored 2, floored from the second sweep 3).
  static constexpr double kWallDiagonalFloor = 0.1;
  static constexpr int kWallFloorFromSweep = 1;  // 0-based: the floor acts from the second sweep on

  /// Eq. A4b: p_b = sum_f c_bf p_f depends on p_i through c_bi, so the wall term of a_i changes
  /// by -F_i p_i/rho0^2 with F_i = sum_b psi_b c_bi grad W_ib, and D_i (Eq. A7) by
  /// -(F_i . gsum_i)/rho0^2 per Pa: the diagonal with the feedback is A_i - F_i . gsum_i/rho0^2.
  /// Measured always (the ratio of the two diagonals goes to the step report). Where the ratio is
  /// not positive (Eq. A4c) p_i, with the walls' answer to it, no longer removes i's compression:
  /// a Jacobi step along A_i would grow p_i without bound (the particle squeezed between a free
  /// body and a tank wall in the 1.1 cm robot scene: A_i 0.9 % of a full neighbourhood's, ratio
  /// -2.4, 3e8 Pa after 60 sweeps and the water blown up in that step), and the clamped local
  /// problem's answer is p_i = 0, so the particle is held at zero as a lone one is. With
  /// solver.diagonal_feedback the diagonal becomes min(A_i, A_i - F_i . gsum_i/rho0^2): the
  /// feedback only ever shortens a Jacobi step (where c_bi > 0 makes the true diagonal larger);
  /// where it would lengthen one (c_bi < 0, ratio < 1; measured down to -2.8 in the cylinder dam
  /// break) using it made MLS blow up at 6 of 8 time steps with a 3-spacing fit and at all 8 with
  /// a 2-spacing one (docs/method_notes.md).
  void extrapolationFeedback()
  {
    const std::size_t n = fluid_.size();
    const bool use = scene_.solver.diagonal_feedback;
    const Real inv_rho0_sq = Real(1) / (rho0_ * rho0_);
    const Real floor = Real(kWallDiagonalFloor * reference_diagonal_);  // 1/m^2, Eq. A4d
    // The ratios' extremes as a reduction (min and max are exact in any order): no array. The
    // particles Eq. A4d floors are listed in index order (the joins keep the chunks' order).
    struct Range
    {
      double min = 1.0, max = 1.0;
      std::vector<Index> floored;
    };
    const Range range = parallelDeterministicSum(
        n, Range{},
        [&](const tbb::blocked_range<std::size_t>& r, Range& acc) {
          for (std::size_t i = r.begin(); i != r.end(); ++i)
          {
            if (fb_.offset[i] == fb_.offset[i + 1] || diagonal_[i] == 0) continue;
            const Vec3 f = method_.feedbackVector(i, fluid_.x[i]);       // kg/m^4
            const Vec3 gsum = a4_[i].template head<3>();                 // kg/m^4, from densityDiagonalAndRate()
            const Real with = diagonal_[i] - f.dot(gsum) * inv_rho0_sq;  // 1/m^2 (as A_i)
            const double ratio = double(Real(with / diagonal_[i]));
            acc.min = std::min(acc.min, ratio);
            acc.max = std::max(acc.max, ratio);
            if (use) diagonal_[i] = std::min(diagonal_[i], with);
            if (!(ratio > 0.0))
              diagonal_[i] = 0;  // Eq. A4c: no pressure (sweep() skips it)
            else if (-diagonal_[i] < floor)
              acc.floored.push_back(Index(i));  // Eq. A4d, from the second sweep of each solve
          }
        },
        [](Range& left, const Range& right) {
          left.min = std::min(left.min, right.min);
          left.max = std::max(left.max, right.max);
          left.floored.insert(left.floored.end(), right.floored.begin(), right.floored.end());
        });
    feedback_ratio_min_ = range.min;
    feedback_ratio_max_ = range.max;
    floored_.clear();
    for (const Index i : range.floored) floored_.push_back({i, diagonal_[i]});
  }

  /// The boundary velocities v_b of the density rate (Eq. A2), m/s: the bodies' own, or zeros
  /// with the diagnostic solver.wall_velocity_in_density_rate = false, which takes the wall's
  /// motion out of the density rate only (positions, forces and p_b stay as they are). For a wall
  /// sliding along itself (a container turning about its axis) the continuous term is zero and
  /// what the discrete one adds is the drag under study (docs/method_notes.md, turning container).
  const std::vector<Vec3>& rateWallVelocities()
  {
    if (scene_.solver.wall_velocity_in_density_rate) return bodies_.v;
    still_wall_.assign(bodies_.v.size(), Vec3::Zero());
    return still_wall_;
  }

  /// x4 = x padded: a neighbour's vector is then one packed load, and a subtraction and a
  /// multiply-add are one instruction each instead of three (m).
  void padPositions()
  {
    x4_.resize(fluid_.size());
    parallelFor(fluid_.size(), [&](std::size_t i) { x4_[i] << fluid_.x[i], Real(0); });
  }

  /// v4 = v padded (m/s); with FLUID_SIM_QUAD_PAIRS the padding lane holds v.(x - o) (m^2/s) for
  /// fluidDivergence().
  void padVelocities()
  {
    v4_.resize(fluid_.size());
    parallelFor(fluid_.size(), [&](std::size_t i) { v4_[i] << fluid_.v[i], laneDot(i, fluid_.v[i]); });
  }

  /// What a padded field f's padding lane holds for particle i: f_i.(x_i - o), o = lane_origin_
  /// (fluidDivergence()), or zero without FLUID_SIM_QUAD_PAIRS.
  Real laneDot(std::size_t i, const Vec3& f) const
  {
#ifdef FLUID_SIM_QUAD_PAIRS
    return f.dot(fluid_.x[i] - lane_origin_);
#else
    (void)i;
    (void)f;
    return Real(0);
#endif
  }

  /// sum_j grad_factor_ij (f_i - f_j) . (x_i - x_j) over i's fluid neighbours, for a padded
  /// per-particle field f: the fluid part of Eq. A2 (f = v, 1/(m^3 s)) and of Eq. A7 (f = a^p,
  /// 1/(m^3 s^2)), per unit particle mass. Component-wise products summed over the pairs, the
  /// three components added once at the end. Reads f_j and x_j of every pair: for a field whose
  /// padding lane is not f.(x - o) (Gauss-Seidel's a^p, changed pair by pair; a build without
  /// FLUID_SIM_QUAD_PAIRS).
  Real fluidDivergenceDirect(std::size_t i, const Vec4Array& f) const
  {
    const Vec4 xi = x4_[i], fi = f[i];
    Vec4 sum = Vec4::Zero();
    Index k = ff_.offset[i];
    const Index end = ff_.offset[i + 1];
#ifdef FLUID_SIM_QUAD_PAIRS
    {
      // Four pairs at a time (FLUID_SIM_QUAD_PAIRS): grad_factor (f_i - f_j) * (x_i - x_j) per lane.
      const __m512 xi16 = _mm512_maskz_broadcast_f32x4(__mmask16(0xFFFF), _mm_load_ps(xi.data()));
      const __m512 fi16 = _mm512_maskz_broadcast_f32x4(__mmask16(0xFFFF), _mm_load_ps(fi.data()));
      __m512 acc = _mm512_setzero_ps();
      for (; k + 4 <= end; k += 4)
      {
        const Index* const j = ff_.index.data() + k;
        const __m512 dx = _mm512_sub_ps(xi16, loadFourVec4(x4_.data(), j));
        const __m512 df = _mm512_sub_ps(fi16, loadFourVec4(f.data(), j));
        const __m512 g = spreadFour(_mm_loadu_ps(ff_.grad_factor.data() + k));
        acc = _mm512_fmadd_ps(g, _mm512_mul_ps(df, dx), acc);
      }
      _mm_store_ps(sum.data(), sumLanes(acc));
    }
#endif
    for (; k < end; ++k)
    {
      const Index j = ff_.index[k];
      sum += ff_.grad_factor[k] * (fi - f[j]).cwiseProduct(xi - x4_[j]);
    }
    return sum.sum();
  }

  /// The same sum as fluidDivergenceDirect() from one load per pair: with g_ij = grad_factor_ij,
  ///   sum_j g_ij (f_i - f_j).(x_i - x_j) = f_i . G_i - [(x_i - o) . sum_j g_ij f_j - sum_j g_ij f_j.(x_j - o)],
  /// G_i = sum_j grad W_ij (fluid_grad_, once per step), f_j.(x_j - o) in f's padding lane
  /// (laneDot()). Each pair then costs f_j's 16 bytes instead of f_j's and x_j's: the sweep's
  /// divergence pass took a fifth less time (docs/performance.md). The bracket cancels to the
  /// size of one term: it loses about |x - o| / h float steps, and o lies inside the fluid's
  /// extent, so that loss does not grow with the scene's distance from the world origin (with o
  /// at the world origin, 40 m away, it was still 1e-4 of the stopping tolerance's source).
  Real fluidDivergence(std::size_t i, const Vec4Array& f) const
  {
#ifdef FLUID_SIM_QUAD_PAIRS
    Index k = ff_.offset[i];
    const Index end = ff_.offset[i + 1];
    Vec4 sum;  // sum_j g_ij f_j, then sum_j g_ij f_j.(x_j - o)
    {
      __m512 acc = _mm512_setzero_ps();
      for (; k + 4 <= end; k += 4)
        acc = _mm512_fmadd_ps(spreadFour(_mm_loadu_ps(ff_.grad_factor.data() + k)),
                              loadFourVec4(f.data(), ff_.index.data() + k), acc);
      _mm_store_ps(sum.data(), sumLanes(acc));
    }
    for (; k < end; ++k) sum += ff_.grad_factor[k] * f[ff_.index[k]];
    const Vec3 fi = f[i].template head<3>();
    return fi.dot(fluid_grad_[i]) - ((fluid_.x[i] - lane_origin_).dot(sum.template head<3>()) - sum[3]);
#else
    return fluidDivergenceDirect(i, f);
#endif
  }

  /// Eq. A2 with the current velocities, kg/m^3/s.
  void computeDensityRate()
  {
    padVelocities();
    const std::vector<Vec3>& xb = bodies_.x;
    const std::vector<Vec3>& vb = rateWallVelocities();
    const std::vector<Real>& Vb = bodies_.volume;
    parallelFor(fluid_.size(), [&](std::size_t i) {
      const Vec3 xi = fluid_.x[i], vi = fluid_.v[i];
      Real rate = mass_ * fluidDivergence(i, v4_);
      for (Index k = fb_.offset[i]; k < fb_.offset[i + 1]; ++k)
      {
        const Index b = fb_.index[k];
        rate += rho0_ * Vb[b] * fb_.grad_factor[k] * (vi - vb[b]).dot(xi - xb[b]);
      }
      density_rate_[i] = rate;
    });
  }

  /// Whether the density (or divergence) solve starts from the previous step's guess: the density
  /// solve with solver.warm_start, the divergence solve only with solver.warm_start_divergence too.
  /// From its cold start the divergence solve converged in as many iterations per step (1.00-1.02
  /// in bench_dam_break at 33 k and 195 k, 1.00 in the demo's scene), and a solve from zero makes
  /// its first iteration without the passes over the pairs (docs/performance.md, "The warm start's
  /// divergence solve").
  bool warmStarted(bool density_solve) const
  {
    return scene_.solver.warm_start && (density_solve || scene_.solver.warm_start_divergence);
  }

  /// Eq. A10: the first guess of a solve whose source and diagonal are set, non-zero only where
  /// the water is compressing now (s_i < 0) and is at or above rest density. Cold (no
  /// solver.warm_start; with it, the divergence solve unless solver.warm_start_divergence): one
  /// unrelaxed Jacobi step from zero there, p_i = s_i / A_i (Eq. A8 with
  /// omega = 1 and D_i = 0), which needs no pair pass (solver.cold_start: jacobi), or zero
  /// everywhere (solver.cold_start: zero, the paper's start and the default: with the Jacobi step
  /// the full validation's 1 m MLS column blew up and its submerged cube read 9 % more buoyancy,
  /// docs/method_notes.md, Still water). Warm: the previous step's
  /// pressure there (solver.warm_start_guess: previous) or half of it plus the Jacobi step (damped,
  /// Eq. A10b). Elsewhere a particle starts from zero: a guess on a particle that has left the
  /// bulk (a splash, with one or two neighbours, a density near 0.3 rho0 and a tiny diagonal)
  /// accelerates it and its neighbours by p/rho^2 before the two minimum iterations can bring it
  /// down. With the plain previous pressure the dam breaks blew up for every boundary method
  /// (docs/method_notes.md); with the Jacobi step on every particle a splash particle at 0.32 rho0
  /// got 121 kPa and the cup test's water went non-finite in the next step (seeded at or above
  /// 0.5 rho0 still, at or above 0.9 rho0 not). Returns whether the guess is zero everywhere.
  bool startingPressure(std::vector<Real>& p, bool density_solve)
  {
    const bool warm = warmStarted(density_solve);
    if (!warm && scene_.solver.cold_start == ColdStart::Zero)
    {
      std::fill(p.begin(), p.end(), Real(0));
      return true;
    }
    // Where A10 holds: p_i = keep p_i(previous step) + step s_i / A_i, the Jacobi step (A10a)
    // scaled by `step`; keep, step = 0, 1 cold (A10a), 1, 0 warm previous (A10), 1/2, 1 warm
    // damped (A10b). A_i < 0 (Eq. A4), so s_i < 0 gives s_i / A_i > 0; a lone particle (A_i = 0)
    // takes no Jacobi step.
    Real keep = 0, step = 1;
    if (warm)
    {
      // Damped: the previous pressure alone is a lagging (integrating) feedback on the water's
      // compression: in still water it swings from step to step (0.17-2.6 of its mean at 3-4 s
      // in a 22-layer tank) and the water jitters (rms 3-4 cm/s); the Jacobi step responds to the
      // compression and its rate now, and the half keeps what a few sweeps cannot rebuild (three
      // quarters of it, or half of it with half the Jacobi step, still swung: docs/method_notes.md,
      // Still water).
      const bool damped = scene_.solver.warm_start_guess == WarmStartGuess::Damped;
      keep = damped ? Real(0.5) : Real(1);
      step = damped ? Real(1) : Real(0);
    }
    parallelFor(p.size(), [&](std::size_t i) {
      // A particle held at zero (a lone one, Eq. A4c) keeps no pressure from the last step either.
      const bool seeded = source_[i] < 0 && fluid_.rho[i] >= rho0_ && diagonal_[i] != 0;
      const Real jacobi = (step != 0 && diagonal_[i] != 0) ? source_[i] / diagonal_[i] : Real(0);
      p[i] = seeded ? keep * p[i] + step * jacobi : Real(0);
    });
    // A guess can be zero everywhere too (still water below rest density, the first step).
    return parallelMax(p.size(), [&](std::size_t i) { return p[i] != Real(0) ? 1.0 : 0.0; }) == 0.0;
  }

  /// Eq. 1 where every fluid pressure is zero (a density solve from zero with SPH's hydrostatic
  /// constant in p_b, solve()): every fluid pair's term m (kappa_i + kappa_j) grad W_ij is zero,
  /// so a^p is the wall term alone, summed over the fluid-boundary pairs only (m/s^2). The same
  /// values as computePressureAcceleration() gives for p = 0, bit for bit: its fluid sum adds
  /// only zeros to +0. Not a pass over the fluid pairs (not counted in pressure_passes_). Like a
  /// skipped evaluation from zero (solve()), it leaves p_over_rho2_ alone: nothing reads it before
  /// the next evaluation writes it.
  void computeWallAcceleration(const std::vector<Real>& p)
  {
    const std::size_t n = fluid_.size();
    a4_.resize(n);
    parallelFor(n, [&](std::size_t i) {
      Vec3 acc = Vec3::Zero();
      Vec3 unused = Vec3::Zero();
      method_.template addWallAcceleration<false>(i, fluid_.x[i], Real(0), p[i], grad_b_[i], Real(0), acc, unused);
      a4_[i] << acc, laneDot(i, acc);
    });
  }

  /// Eq. 1 with the method's boundary term: a^p from the pressures p into a4 (m/s^2). With
  /// kRecordWall (the final evaluation of a solve) it also adds wall_dt (s) times the p_b part of
  /// the wall term to wall_dv (the wall-work diagnostic).
  template <bool kRecordWall = false>
  void computePressureAcceleration(const std::vector<Real>& p, Real wall_dt = 0)
  {
    const std::size_t n = fluid_.size();
    ++pressure_passes_;
    p_over_rho2_.resize(n);
    parallelFor(n, [&](std::size_t i) {
      const Real kappa = p[i] / (fluid_.rho[i] * fluid_.rho[i]);
      p_over_rho2_[i] = kappa;
#ifdef FLUID_SIM_QUAD_PAIRS
      // kappa_i also rides in x4's padding lane, so that the four-pair loop below reads a
      // neighbour's position and kappa in one 16-byte load instead of a second, scalar gather.
      // The lane is free: fluidDivergence() reads no x_j, and the density pass and Gauss-Seidel's
      // updates, which do, run with it at zero (padPositions(), solveGaussSeidel()).
      x4_[i][3] = kappa;
#endif
    });
    a4_.resize(n);
    parallelFor(n, [&](std::size_t i) {
      const Vec3 xi = fluid_.x[i];
      const Real ki = p_over_rho2_[i];  // Pa m^6/kg^2 = m^5/(kg s^2)
      const Vec4 xi4 = x4_[i];
      Vec4 acc4 = Vec4::Zero();
      Index k = ff_.offset[i];
      const Index end = ff_.offset[i + 1];
#ifdef FLUID_SIM_QUAD_PAIRS
      {
        // Four pairs at a time (FLUID_SIM_QUAD_PAIRS): m (kappa_i + kappa_j) grad_factor (x_i - x_j) per lane.
        const __m512 xi16 = _mm512_maskz_broadcast_f32x4(__mmask16(0xFFFF), _mm_load_ps(xi4.data()));
        const __m512 ki16 = _mm512_set1_ps(ki), m16 = _mm512_set1_ps(mass_);
        __m512 acc = _mm512_setzero_ps();
        for (; k + 4 <= end; k += 4)
        {
          const Index* const j = ff_.index.data() + k;
          const __m512 xj = loadFourVec4(x4_.data(), j);                           // x_j, y_j, z_j, kappa_j per lane
          const __m512 kj = _mm512_maskz_permute_ps(__mmask16(0xFFFF), xj, 0xFF);  // kappa_j over its lane
          const __m512 c = _mm512_mul_ps(_mm512_mul_ps(m16, _mm512_add_ps(ki16, kj)),
                                         spreadFour(_mm_loadu_ps(ff_.grad_factor.data() + k)));
          acc = _mm512_fmadd_ps(c, _mm512_sub_ps(xi16, xj), acc);  // the padding lane: c (kappa_i - kappa_j), unused
        }
        _mm_store_ps(acc4.data(), _mm_sub_ps(_mm_setzero_ps(), sumLanes(acc)));
      }
#endif
      for (; k < end; ++k)
      {
        const Index j = ff_.index[k];
        acc4 -= (mass_ * (ki + p_over_rho2_[j]) * ff_.grad_factor[k]) * (xi4 - x4_[j]);
      }
      Vec3 acc = acc4.template head<3>();
      method_.template addWallAcceleration<kRecordWall>(i, xi, ki, p[i], grad_b_[i], wall_dt, acc, wall_dv_[i]);
      a4_[i] << acc, laneDot(i, acc);
    });
  }

  /// What a Jacobi sweep sums over the particles: the stopping error's terms (Eq. A9, relative)
  /// and the largest active residual |s_i - D_i| dt^2/rho0.
  struct SweepFigures
  {
    double error = 0.0, max_residual = 0.0;
  };

  /// One relaxed Jacobi sweep: D_i (Eq. A7), p_i += omega (s_i - D_i)/A_i (Eq. A8), extrapolated
  /// with the Chebyshev weight (Eq. A8a; 1 = none). Returns the stopping error (Eq. A9) of the
  /// pressures before this update. `zero_acceleration`: a^p is zero everywhere (from zero, see
  /// solve()), so every D_i is zero and the sweep needs no pass over the pairs.
  double jacobiUpdate(std::vector<Real>& p, double dt, bool clamp_p, Real weight, bool zero_acceleration,
                      bool wall_only = false)
  {
    const std::size_t n = fluid_.size();
    const Real omega = Real(scene_.solver.omega);
    const Real dt2_over_rho0 = Real(dt * dt / rho0_);
    // Any first guess but zero can be too high somewhere, and so can an extrapolated sweep
    // (Eq. A8a, weights above 1): then |residual| counts (sweep()).
    // (clamp_p: the density solve.)
    const bool guessed =
        warmStarted(clamp_p) || scene_.solver.cold_start == ColdStart::Jacobi || scene_.solver.chebyshev_rho > 0;
    // The sweep is itself the reduction of its two figures, the error sum (Eq. A9) and the largest
    // active residual, in the chunks and order of parallelSum: the same sums as from per-particle
    // arrays, without the arrays (8 B per particle).
    const SweepFigures figures = parallelDeterministicSum(
        n, SweepFigures{},
        [&](const tbb::blocked_range<std::size_t>& range, SweepFigures& acc) {
          if (zero_acceleration)
            for (std::size_t i = range.begin(); i != range.end(); ++i)
              sweep<true>(i, p, clamp_p, omega, weight, dt2_over_rho0, guessed, acc);
          else if (wall_only)  // a^p = 0 outside the wall zone: D_i = 0 there without the pairs
            for (std::size_t i = range.begin(); i != range.end(); ++i)
            {
              if (wall_zone_[i])
                sweep<false>(i, p, clamp_p, omega, weight, dt2_over_rho0, guessed, acc);
              else
                sweep<true>(i, p, clamp_p, omega, weight, dt2_over_rho0, guessed, acc);
            }
          else
            for (std::size_t i = range.begin(); i != range.end(); ++i)
              sweep<false>(i, p, clamp_p, omega, weight, dt2_over_rho0, guessed, acc);
        },
        [](SweepFigures& left, const SweepFigures& right) {
          left.error += right.error;
          left.max_residual = std::max(left.max_residual, right.max_residual);
        });
    if (clamp_p)  // the density solve: its largest residual per iteration for the step report
      density_residual_max_.push_back(float(figures.max_residual));
    return figures.error / double(std::max<std::size_t>(n, 1));
  }

  /// Particle i's part of jacobiUpdate(): D_i, the pressure update, and its error and residual
  /// figures added to `acc`. kZeroAcceleration: a^p = 0 everywhere, D_i = 0 without the pairs.
  template <bool kZeroAcceleration>
  void sweep(std::size_t i, std::vector<Real>& p, bool clamp_p, Real omega, Real weight, Real dt2_over_rho0,
             bool guessed, SweepFigures& acc)
  {
    Real div = 0;
    if constexpr (!kZeroAcceleration)
    {
      div = mass_ * fluidDivergence(i, a4_);
      div += a4_[i].template head<3>().dot(grad_b_[i]);  // boundary particles are not accelerated by the fluid
    }
    const Real residual = div - source_[i];
    // residual > 0: compression left. A first guess can also be too high (a stale warm-start
    // pressure on a particle that no longer needs it; an unrelaxed Jacobi step that overshoots)
    // and then residual < 0 is an error too, so wherever a pressure acts its |residual| counts;
    // from zero the iteration approaches from below and the positive part is the error (DFSPH's
    // measure).
    const Real counted = (guessed && p[i] != 0) ? std::abs(residual) : std::max(residual, Real(0));
    acc.error += double(Real(counted * dt2_over_rho0));
    const Real now = p[i];
    if (diagonal_[i] != 0)
    {
      Real next = now - omega * residual / diagonal_[i];
      // Eq. A8a: p^(k+1) = w (A8's update of p^k - p^(k-1)) + p^(k-1), before the clamp.
      if (weight != Real(1)) next = weight * (next - p_before_[i]) + p_before_[i];
      p[i] = clamp_p ? std::max(next, Real(0)) : next;
    }
    if (!p_before_.empty()) p_before_[i] = now;  // p^(k-1) of the next sweep (Eq. A8a)
    // The residual figure counts where the constraint is active: compression left, or a
    // pressure acting. A particle below rest density with its pressure clamped at zero (the free
    // surface, a splash) has a residual no pressure can or should remove; counted, it hid every
    // other residual (a surface particle missing its upper neighbour plane, 0.15 rho0 short,
    // gave 0.1495 at every iteration of every step).
    if (clamp_p)
      acc.max_residual =
          std::max(acc.max_residual, double((residual > 0 || p[i] > 0) ? std::abs(residual) * dt2_over_rho0 : Real(0)));
  }

  /// Iterates a solve; on return a4 holds the final pressure acceleration, with p_b recomputed
  /// from the final p. `from_zero`: the guess p is zero everywhere. Returns the iterations; writes
  /// error and convergence.
  int solve(std::vector<Real>& p, double dt, bool density_solve, double tol, int min_it, bool from_zero, double& error,
            bool& converged)
  {
    const int max_it = scene_.solver.max_iterations;
    const double rho = scene_.solver.chebyshev_rho;
    if (rho > 0)
      p_before_.resize(p.size());
    else
      p_before_.clear();  // sweep() keeps p^(k-1) only when the array is there
    double weight = 1.0;  // Eq. A8a's omega_k: 1 = the plain sweep (A8)
    int it = 0;
    error = 0.0;
    converged = false;
    // Eq. A8b in the density solve, after the first kJacobiSweepsFirst sweeps (below).
    const bool gauss_seidel = density_solve && scene_.solver.sweep == SweepOrder::GaussSeidel;
    while (it < max_it)
    {
      if (gauss_seidel && it == kJacobiSweepsFirst)
        return solveGaussSeidel(p, dt, density_solve, tol, min_it, it, error, converged);
      if (it == kWallFloorFromSweep)  // Eq. A4d: A_i is negative, the floor its fraction of A_full's
        for (const FlooredDiagonal& f : floored_) diagonal_[f.i] = -Real(kWallDiagonalFloor * reference_diagonal_);
      // From zero, where the method's p_b is then zero too (vanishesAtZero), every term of Eq. 1
      // is zero: a^p = 0 without the pass over the pairs, and the sweep needs none either (D_i = 0,
      // Eq. A7), so the first iteration is the O(n) update p_i = omega s_i / A_i (Eq. A8, clamped
      // at zero in the density solve). A divergence solve's single iteration then makes one pass
      // over the pairs instead of three, a density solve's two three instead of five. Nothing reads
      // p_b, a4_ or p_over_rho2_ before the next evaluation writes them, so neither the
      // extrapolation nor the pass is made.
      const bool zero_acceleration = it == 0 && from_zero && method_.vanishesAtZero(density_solve);
      // From zero where p_b does not vanish (SPH's density solve: the hydrostatic constant), a^p
      // is the wall term alone, non-zero only next to a wall, and D_i (Eq. A7) non-zero only in
      // the wall zone (densityDiagonalAndRate()): the first iteration sums the fluid-boundary
      // pairs and the zone's rows, not every pair twice. Bit-identical to the full evaluation.
      bool wall_only = false;
      if constexpr (kWallOnlyStart) wall_only = it == 0 && from_zero && !zero_acceleration;
      if (!zero_acceleration)
      {
        method_.extrapolate(p, density_solve);
        if (wall_only)
          computeWallAcceleration(p);
        else
          computePressureAcceleration(p);
      }
      if (rho > 0)  // Eq. A8a: the weights of Chebyshev's semi-iteration for the radius rho
      {
        const int delay = scene_.solver.chebyshev_delay;
        weight = it < delay ? 1.0 : it == delay ? 2.0 / (2.0 - rho * rho) : 4.0 / (4.0 - rho * rho * weight);
      }
      error = jacobiUpdate(p, dt, density_solve, Real(weight), zero_acceleration, wall_only);
      ++it;
      if (it >= min_it && error <= tol)
      {
        converged = true;
        break;
      }
    }
    for (const FlooredDiagonal& f : floored_) diagonal_[f.i] = f.diagonal;  // the next solve starts unfloored
    method_.extrapolate(p, density_solve);
    computePressureAcceleration<true>(p, Real(dt));  // the final a^p, also recording the wall term
    return it;
  }

  /// Eq. A8b's sweep order. The fluid grid's cells are the support h wide and ordered x fastest,
  /// so a row of cells along x is one contiguous range of the sorted fluid. A unit is 2 x 2 such
  /// rows (2h in y and z, the whole grid in x), coloured by the parity of its (y, z) unit
  /// coordinates. Two units of one colour are a unit, 2h, apart: no particle of one is a
  /// neighbour of a particle of the other or shares a neighbour with it, so the units of a colour
  /// are swept at once (each writes a^p only within h of its own particles) and the result does
  /// not depend on the threads. Whole rows rather than small blocks: a sweep then reads x and a^p
  /// along a few rows at a time, as memory holds them (2 x 2 x 2-cell blocks took 1.6 times as
  /// long per sweep, their neighbours' x and a^p read from all over memory eight times a sweep).
  struct GsUnit
  {
    std::array<Index, 4> begin, end;  // its four rows' ranges of the sorted fluid
  };
  static constexpr int kGsColours = 4;
  /// The density solve's first sweeps stay Jacobi's (A8) with solver.sweep: gauss_seidel. From zero
  /// the first needs no pass over the pairs, and most solves end after the two minimum sweeps,
  /// which cost Jacobi three passes (two and the final a^p) and Gauss-Seidel five and a half.
  static constexpr int kJacobiSweepsFirst = 2;

  /// The units of this step's sorted fluid, colour by colour (gs_units_, gs_colour_begin_): a scan
  /// over the grid's (y, z) rows, not over the particles.
  void buildGaussSeidelUnits()
  {
    const UniformGrid& g = in_.neighbors.fluidGrid();
    const int nx = g.dim(0), ny = g.dim(1), nz = g.dim(2);
    std::array<std::vector<GsUnit>, kGsColours> colours;
    std::size_t covered = 0;
    for (int uz = 0; 2 * uz < nz; ++uz)
      for (int uy = 0; 2 * uy < ny; ++uy)
      {
        GsUnit unit;
        std::size_t count = 0;
        for (int r = 0; r < 4; ++r)
        {
          const int y = 2 * uy + (r & 1), z = 2 * uz + (r >> 1);
          const std::pair<Index, Index> range =
              (y < ny && z < nz) ? g.rowRange(0, nx - 1, y, z) : std::pair<Index, Index>{0, 0};
          unit.begin[r] = range.first;
          unit.end[r] = range.second;
          count += range.second - range.first;
        }
        if (count == 0) continue;
        colours[(uy & 1) | ((uz & 1) << 1)].push_back(unit);
        covered += count;
      }
    // The grid of the step's sort holds every fluid particle (they are removed on leaving the
    // domain, which the grid covers): a particle no unit holds would never be updated.
    if (covered != fluid_.size())
      throw std::logic_error("Gauss-Seidel sweep: the fluid grid holds " + std::to_string(covered) + " of " +
                             std::to_string(fluid_.size()) + " fluid particles");
    gs_units_.clear();
    for (int c = 0; c < kGsColours; ++c)
    {
      gs_colour_begin_[c] = gs_units_.size();
      gs_units_.insert(gs_units_.end(), colours[c].begin(), colours[c].end());
    }
    gs_colour_begin_[kGsColours] = gs_units_.size();
    gs_unit_figures_.resize(gs_units_.size());
  }

  /// Eq. A8b for particle i: D_i (Eq. A7) from the current a^p, p_i updated by Eq. A8 with the
  /// full step (omega = 1; next to a wall solver.omega), clamped in the density solve, and the
  /// change dp at once carried into a^p (Eq. 1): a_j += m dkappa grad W_ij for every fluid
  /// neighbour j, a_i -= m dkappa sum_j grad W_ij and its wall term's own part, dkappa = dp/rho_i^2.
  /// Adds i's stopping-error term (Eq. A9) and residual figure to `acc`.
  void gaussSeidelUpdate(std::size_t i, std::vector<Real>& p, bool clamp_p, Real omega_wall, Real dt2_over_rho0,
                         SweepFigures& acc)
  {
    Vec4* const a = a4_.data();
    const Vec4* const x = x4_.data();
    const Index* const idx = ff_.index.data();
    const Real* const gf = ff_.grad_factor.data();
    const Index begin = ff_.offset[i], end = ff_.offset[i + 1];
    const Vec4 xi4 = x[i], ai4 = a[i];
    // Eq. A7.
    Real div = mass_ * fluidDivergenceDirect(i, a4_) + ai4.template head<3>().dot(grad_b_[i]);
    const Real residual = div - source_[i];
    const Real now = p[i];
    // As after a first guess (Eq. A9): where a pressure acts, |residual| counts (a full step can
    // overshoot); elsewhere the compression left.
    const Real counted = now != 0 ? std::abs(residual) : std::max(residual, Real(0));
    acc.error += double(Real(counted * dt2_over_rho0));
    Real next = now;
    if (diagonal_[i] != 0)
    {
      // Next to a wall the relaxed step of Eq. A8: there A_i leaves out how the walls' p_b answer
      // p_i (Eq. A4b), and the full step overshot (the floating-box test's draft 0.932 of
      // Archimedes' against the converged solve's 0.946; relaxed there 0.945).
      const Real omega = fb_.offset[i] != fb_.offset[i + 1] ? omega_wall : Real(1);
      next = now - omega * residual / diagonal_[i];
      if (clamp_p) next = std::max(next, Real(0));
    }
    if (clamp_p)
      acc.max_residual =
          std::max(acc.max_residual, double((residual > 0 || next > 0) ? std::abs(residual) * dt2_over_rho0 : Real(0)));
    const Real dp = next - now;
    if (dp == 0) return;
    p[i] = next;
    const Real dk = dp / (fluid_.rho[i] * fluid_.rho[i]);  // m^5/(kg s^2)
    const Real mdk = mass_ * dk;
    Vec4 g4 = Vec4::Zero();  // sum_j grad W_ij, 1/m^4 (padding lane 0)
    Index k = begin;
#ifdef FLUID_SIM_QUAD_PAIRS
    {
      // Four pairs at a time (FLUID_SIM_QUAD_PAIRS), each neighbour's a^p added lane by lane.
      const __m512 xi16 = _mm512_maskz_broadcast_f32x4(__mmask16(0xFFFF), _mm_load_ps(xi4.data()));
      const __m512 m16 = _mm512_set1_ps(mdk);
      const __mmask8 lane = 0xF;
      __m512 gacc = _mm512_setzero_ps();
      for (; k + 4 <= end; k += 4)
      {
        const Index* const j = idx + k;
        const __m512 g = _mm512_mul_ps(spreadFour(_mm_loadu_ps(gf + k)), _mm512_sub_ps(xi16, loadFourVec4(x, j)));
        gacc = _mm512_add_ps(gacc, g);
        const __m512 t = _mm512_mul_ps(m16, g);
        _mm_store_ps(a[j[0]].data(), _mm_add_ps(_mm_load_ps(a[j[0]].data()), _mm512_maskz_extractf32x4_ps(lane, t, 0)));
        _mm_store_ps(a[j[1]].data(), _mm_add_ps(_mm_load_ps(a[j[1]].data()), _mm512_maskz_extractf32x4_ps(lane, t, 1)));
        _mm_store_ps(a[j[2]].data(), _mm_add_ps(_mm_load_ps(a[j[2]].data()), _mm512_maskz_extractf32x4_ps(lane, t, 2)));
        _mm_store_ps(a[j[3]].data(), _mm_add_ps(_mm_load_ps(a[j[3]].data()), _mm512_maskz_extractf32x4_ps(lane, t, 3)));
      }
      _mm_store_ps(g4.data(), sumLanes(gacc));
    }
#endif
    for (; k < end; ++k)
    {
      const Index j = idx[k];
      const Vec4 g = gf[k] * (xi4 - x[j]);
      g4 += g;
      a[j] += mdk * g;
    }
    Vec3 own = -(mdk * g4.template head<3>());
    method_.addOwnWallChange(dk, dp, grad_b_[i], own);
    a[i].template head<3>() += own;
  }

  /// One sweep of Eq. A8b, colour by colour; returns the stopping error (Eq. A9) of the residuals
  /// as each particle met them. Figures are summed per unit and then over the units in their
  /// order: the same sums for any thread count.
  double gaussSeidelSweep(std::vector<Real>& p, double dt, bool clamp_p)
  {
    const Real dt2_over_rho0 = Real(dt * dt / rho0_);
    const Real omega_wall = Real(scene_.solver.omega);
    for (int c = 0; c < kGsColours; ++c)
      tbb::parallel_for(tbb::blocked_range<std::size_t>(gs_colour_begin_[c], gs_colour_begin_[c + 1], 1),
                        [&](const tbb::blocked_range<std::size_t>& r) {
                          for (std::size_t u = r.begin(); u != r.end(); ++u)
                          {
                            SweepFigures figures;
                            for (int row = 0; row < 4; ++row)
                              for (Index i = gs_units_[u].begin[row]; i < gs_units_[u].end[row]; ++i)
                                gaussSeidelUpdate(i, p, clamp_p, omega_wall, dt2_over_rho0, figures);
                            gs_unit_figures_[u] = figures;
                          }
                        });
    SweepFigures total;
    for (const SweepFigures& f : gs_unit_figures_)
    {
      total.error += f.error;
      total.max_residual = std::max(total.max_residual, f.max_residual);
    }
    if (clamp_p) density_residual_max_.push_back(float(total.max_residual));
    return total.error / double(std::max<std::size_t>(fluid_.size(), 1));
  }

  /// solve()'s density solve continued with Eq. A8b's sweeps from its sweep `it` on: a^p is kept
  /// up to date particle by particle instead of being evaluated once per sweep. The walls' p_b
  /// (SPH, MLS) follow the fluid pressures once per sweep, as in solve().
  int solveGaussSeidel(std::vector<Real>& p, double dt, bool density_solve, double tol, int min_it, int it,
                       double& error, bool& converged)
  {
    const std::size_t n = fluid_.size();
    buildGaussSeidelUnits();  // of this step's sort: the density solve runs once per step
    const int max_it = scene_.solver.max_iterations;
    // a^p of the pressures the Jacobi sweeps left, exactly.
    method_.extrapolate(p, density_solve);
    computePressureAcceleration(p);
    // The updates' neighbour vectors x_i - x_j need x4's padding lane at zero, where an
    // evaluation leaves kappa: their changes then leave a^p's padding lane as it is, and
    // fluidDivergenceDirect() multiplies it by x4's zero.
    parallelFor(n, [&](std::size_t i) { x4_[i][3] = Real(0); });
    // Eq. A4d's floors were set by solve()'s sweeps before this one; they are lifted below.
    static_assert(kWallFloorFromSweep < kJacobiSweepsFirst, "the Jacobi sweeps set Eq. A4d's floors");
    converged = false;
    while (it < max_it)
    {
      error = gaussSeidelSweep(p, dt, density_solve);
      ++it;
      ++pressure_passes_;  // a sweep updates a^p over every pair once
      if (it >= min_it && error <= tol)
      {
        converged = true;
        break;
      }
      if constexpr (Method::kExtrapolated)
      {
        // p_b from the swept pressures, and their change into the wall terms (Eq. 1).
        pb_before_ = method_.boundaryPressures();
        method_.extrapolate(p, density_solve);
        parallelFor(n, [&](std::size_t i) {
          if (fb_.offset[i] == fb_.offset[i + 1]) return;
          Vec3 change = Vec3::Zero();
          method_.addWallChange(i, fluid_.x[i], pb_before_, change);
          a4_[i].template head<3>() += change;
        });
      }
    }
    for (const FlooredDiagonal& f : floored_) diagonal_[f.i] = f.diagonal;  // the next solve starts unfloored
    method_.extrapolate(p, density_solve);
    computePressureAcceleration<true>(p, Real(dt));  // the final a^p, exact, also recording the wall term
    return it;
  }

  /// Eq. A12: adds the pressure forces of the last a^p evaluation (pressures p, and p_b) to the
  /// bodies' wrenches, by Newton's third law from the fluid side of each pair.
  void accumulateWrenches(const std::vector<Real>& p, BodyWrenches& wrenches)
  {
    const std::size_t nb = bodies_.size();
    if (nb == 0) return;
    const Real inv_rho0_sq = Real(1) / (rho0_ * rho0_);
    const std::vector<Vec3>& xb = bodies_.x;
    const std::vector<Real>& Vb = bodies_.volume;
    BodyWrenches total = parallelDeterministicSum(
        fluid_.size(), BodyWrenches(nb),
        [&](const tbb::blocked_range<std::size_t>& r, BodyWrenches& acc) {
          for (std::size_t i = r.begin(); i != r.end(); ++i)
          {
            if (fb_.offset[i] == fb_.offset[i + 1]) continue;
            const Real ki = p_over_rho2_[i];
            for (Index k = fb_.offset[i]; k < fb_.offset[i + 1]; ++k)
            {
              const Index b = fb_.index[k];
              const Real pb = method_.wallPressure(b, p[i]);
              // The force on b is minus the force on i from b.
              const Vec3 f =
                  (mass_ * rho0_ * Vb[b] * (ki + pb * inv_rho0_sq) * fb_.grad_factor[k]) * (fluid_.x[i] - xb[b]);
              const Index body = bodies_.body_of[b];
              const Vec3d fd = f.template cast<double>();
              acc.force[body] += fd;
              acc.torque[body] += (xb[b].template cast<double>() - bodies_[body].pose.translation).cross(fd);
            }
          }
        },
        [](BodyWrenches& left, const BodyWrenches& right) { left.add(right); });
    wrenches.add(total);
  }

  BoundaryPressureInputs in_;
  const SceneConfig& scene_;
  FluidParticles& fluid_;
  const BodySet& bodies_;
  const NeighborLists& ff_;  // fluid-fluid: grad_factor (1/m^5), weight W (1/m^3)
  const NeighborLists& fb_;  // fluid-boundary: the same
  Real rho0_;                // kg/m^3
  Real mass_;                // kg
  Method method_;
  double reference_diagonal_;  // 1/m^2, |A_i| of a full neighbourhood (Eq. A4)

  // Per-step scratch, in the order of the current (sorted) particles.
  std::vector<Real> diagonal_;      // 1/m^2, A_i of Eq. A4: D_i changes by A_i kg/m^3/s^2 per Pa of p_i
  std::vector<Real> density_rate_;  // kg/m^3/s, Eq. A2
  std::vector<Real> source_;        // kg/m^3/s^2, s_i of Eq. A5 or A6
  std::vector<Real> p_over_rho2_;   // p_i/rho_i^2 of the last a^p evaluation, m^5/(kg s^2)
  std::vector<Vec3> grad_b_;        // kg/m^4, sum_b psi_b grad W_ib
  int pressure_passes_ = 0;         // computePressureAcceleration() passes this step (StepReport)
  double feedback_ratio_min_ = 1.0, feedback_ratio_max_ = 1.0;  // A_i with Eq. A4b over A_i without
  std::vector<float> density_residual_max_;  // per density-solve iteration, the largest |s_i - D_i| dt^2/rho0
  // m, m/s, m/s^2: x, v and a^p padded to 4 components. Before the divergence solve a4_ holds
  // gsum_i = m sum_j grad W_ij + grad_b (kg/m^4, the extrapolations' Eq. A4b). x4_'s padding lane
  // is zero in the density pass and holds kappa_i = p_i/rho_i^2 of the last a^p evaluation after
  // it (computePressureAcceleration()); v4_'s and a4_'s padding lanes hold v.(x - o) and
  // a^p.(x - o) (laneDot(); zero without FLUID_SIM_QUAD_PAIRS), but for a4_'s gsum.
  Vec4Array x4_, v4_, a4_;
  // 1/m^4, G_i = sum_j grad W_ij over the fluid neighbours (fluidDivergence(); with
  // FLUID_SIM_QUAD_PAIRS only, 12 B per fluid particle), and the padding lanes' origin o (m).
  std::vector<Vec3> fluid_grad_;
  Vec3 lane_origin_ = Vec3::Zero();
  std::vector<Vec3> wall_dv_;     // m/s, this step's velocity change from the p_b wall term
  std::vector<Vec3> still_wall_;  // m/s, zeros (diagnostic: walls still in Eq. A2)
  std::vector<Real> p_before_;    // Pa, p^(k-1) of Eq. A8a: each sweep's pressures before it (Chebyshev only)
  // A method whose density-solve p_b does not vanish at p = 0 (SPH's hydrostatic constant) starts
  // such a solve from zero with the wall term alone (solve()); wall_zone_ (per particle, this
  // step) marks where that a^p reaches: a wall neighbour of i or of a fluid neighbour of i.
  static constexpr bool kWallOnlyStart = !Method::vanishesAtZero(true);
  std::vector<std::uint8_t> wall_zone_;
  struct FlooredDiagonal
  {
    Index i;        // particle
    Real diagonal;  // 1/m^2, its A_i without the floor
  };
  std::vector<FlooredDiagonal> floored_;  // the particles Eq. A4d floors from a solve's second sweep on
  // Eq. A8b (solver.sweep: gauss_seidel): this step's units, where each colour starts in them,
  // each unit's figures of the last sweep, and p_b before a sweep's extrapolation (Pa).
  std::vector<GsUnit> gs_units_;
  std::array<std::size_t, kGsColours + 1> gs_colour_begin_{};
  std::vector<SweepFigures> gs_unit_figures_;
  std::vector<Real> pb_before_;
};
}  // namespace

std::unique_ptr<PressureSolver> makePressureSolver(const BoundaryPressureInputs& in, FluidParticles& fluid)
{
  switch (in.scene.solver.boundary_pressure)
  {
    case BoundaryPressureMethod::Mirroring:
      return std::make_unique<DfsphSolver<MirroredBoundaryPressure<false>>>(in, fluid);
    case BoundaryPressureMethod::MirroringEq2:
      return std::make_unique<DfsphSolver<MirroredBoundaryPressure<true>>>(in, fluid);
    case BoundaryPressureMethod::SphExtrapolation:
      return std::make_unique<DfsphSolver<SphBoundaryPressure>>(in, fluid);
    case BoundaryPressureMethod::Mls:
      return std::make_unique<DfsphSolver<MlsBoundaryPressure>>(in, fluid);
  }
  throw ConfigError("solver.boundary_pressure", "unknown boundary pressure method");
}

}  // namespace fluid_sim
