#pragma once
// The three ways to give a boundary particle b its pressure p_b in the pressure acceleration
// (Eq. 1 of docs/method.md), as types with one small interface that the DFSPH solver
// (dfsph_solver.h) is compiled for, one solver per method, chosen once when the simulation is
// built. No per-particle or per-pair code tests which method runs.
//
// The interface (every method has these members):
//   void buildLists()                    after the step's neighbour search: what it needs besides
//                                        the fluid-fluid and fluid-boundary lists
//   void prepare()                       once per step, after the densities: what stays fixed
//                                        during both solves (the extrapolation coefficients)
//   void addDiagonalFeedback(A, gb, g)   what p_b's dependence on p_i adds to the diagonal (Eq. A4)
//                                        where it is part of the method (mirroring)
//   kExtrapolated                        p_b = sum_f c_bf p_f with stored coefficients; then also
//     Vec3 feedbackVector(i, x_i)        sum_b psi_b c_bi grad W_ib (kg/m^4), for Eq. A4b
//   void extrapolate(p, density_solve)   p_b from the fluid pressures p, before each evaluation
//                                        of the pressure acceleration (both solves)
//   bool vanishesAtZero(density_solve)   whether p = 0 everywhere gives p_b = 0 everywhere, so that
//                                        the wall term, and with it a^p (Eq. 1), is zero
//   addWallAcceleration<kRecord>(...)    the boundary term of Eq. 1 for one fluid particle
//   addOwnWallChange(dk, dp, gb, acc)    its change when p_i alone changes (Gauss-Seidel, Eq. A8b)
//   addWallChange(i, x_i, pb_before, acc) its change from p_b = pb_before to the stored p_b (A8b)
//   Real wallPressure(b, p_i)            the p_b that fluid particle i sees at b (forces, Eq. A12)
//   Real contactPressure(b, p_i)         the pressure the wall bears there (contact statistics)
//   void report(StepReport&, bodies)     the method's counts for the step report
//   boundaryPressures()                  Pa, per boundary particle (output)

#include <atomic>
#include <memory>
#include <vector>

#include "fluid_sim/core/bodies.h"
#include "fluid_sim/core/fluid_constants.h"
#include "fluid_sim/core/fluid_particles.h"
#include "fluid_sim/core/neighborhoods.h"
#include "fluid_sim/core/scene_config.h"
#include "fluid_sim/core/simulation.h"

namespace fluid_sim
{
/// What every method reads: the scene (its solver settings may change between steps), the
/// fluid's constants, the particles and the step's neighbour lists.
struct BoundaryPressureInputs
{
  const SceneConfig& scene;
  const FluidConstants& constants;
  const FluidParticles& fluid;
  const BodySet& bodies;
  const Neighborhoods& neighbors;
};

/// Mirroring (Akinci 2012): the wall term of Eq. 1 with a pressure per fluid particle, nothing
/// stored per boundary particle.
///   kEq2 = false (`mirroring`, Eq. A19): p_b = 0, the single term (p_i/rho_i^2) grad_b: the force of the
///     wall's density constraint on i, as SPlisHSPlasH's DFSPH applies it to Akinci boundaries.
///     It is the adjoint of the wall part of the discrete divergence (A7), so it does no net work
///     on water at rest (docs/method_notes.md).
///   kEq2 = true (`mirroring_eq2`): the paper's Eq. 2, p_b = p_i, which adds (p_i/rho0^2) grad_b;
///     its p_b scales with p_i, so it adds to the diagonal, and along a wall where p_i grows with
///     depth the added term has a curl and pumps energy into the water.
template <bool kEq2>
class MirroredBoundaryPressure
{
public:
  static constexpr bool kExtrapolated = false;

  explicit MirroredBoundaryPressure(const BoundaryPressureInputs& in)
      : in_(in)
      , inv_rho0_sq_(Real(1) / (in.constants.rho0 * in.constants.rho0))
      , zero_(in.bodies.numParticles(), Real(0))
  {
  }

  void buildLists() {}
  void prepare() {}

  /// Eq. A4: p_b = p_i adds (p_i/rho0^2) grad_b to a_i, so the diagonal gains -grad_b . gsum / rho0^2
  /// (Eq. 2 only; the single term's p_b = 0 does not depend on p_i).
  void addDiagonalFeedback(Real& diagonal, const Vec3& grad_b, const Vec3& gsum) const
  {
    if constexpr (kEq2)
    {
      const Real rho0 = in_.constants.rho0;
      diagonal -= grad_b.dot(gsum) / (rho0 * rho0);
    }
  }

  void extrapolate(const std::vector<Real>&, bool) {}

  /// p_b = 0 (Eq. A19) or p_b = p_i (Eq. 2): zero with the fluid's pressures.
  static constexpr bool vanishesAtZero(bool)
  {
    return true;
  }

  /// Eq. A19 (p_b = 0, single term) or Eq. 2 (p_b = p_i): (p_i/rho_i^2 [+ p_i/rho0^2]) grad_b,
  /// with grad_b = sum_b psi_b grad W_ib (kg/m^4) and p_over_rho2 = p_i/rho_i^2. With kRecord
  /// also adds wall_dt (s) times the p_b part to wall_dv (m/s; the wall-work diagnostic).
  template <bool kRecord>
  void addWallAcceleration(std::size_t, const Vec3&, Real p_over_rho2, Real p_i, const Vec3& grad_b, Real wall_dt,
                           Vec3& acc, Vec3& wall_dv) const
  {
    if constexpr (kEq2)
    {
      acc -= (p_over_rho2 + p_i * inv_rho0_sq_) * grad_b;
      if constexpr (kRecord) wall_dv -= (wall_dt * p_i * inv_rho0_sq_) * grad_b;
    }
    else
      acc -= p_over_rho2 * grad_b;
  }

  /// The change of i's wall term when its own pressure changes by dp (Pa), dp_over_rho2 =
  /// dp/rho_i^2 (m^5/(kg s^2)), added to acc (m/s^2): the term is linear in p_i alone.
  void addOwnWallChange(Real dp_over_rho2, Real dp, const Vec3& grad_b, Vec3& acc) const
  {
    if constexpr (kEq2)
      acc -= (dp_over_rho2 + dp * inv_rho0_sq_) * grad_b;
    else
      acc -= dp_over_rho2 * grad_b;
  }

  /// No p_b is stored: nothing lags behind the fluid pressures (Gauss-Seidel sweeps).
  void addWallChange(std::size_t, const Vec3&, const std::vector<Real>&, Vec3&) const {}

  Real wallPressure(Index, Real p_i) const
  {
    if constexpr (kEq2)
      return p_i;
    else
      return 0;
  }

  /// The pressure the wall bears from i (contact statistics): p_i for both forms.
  Real contactPressure(Index, Real p_i) const
  {
    return p_i;
  }

  /// Mirroring keeps no list of active boundary particles: the contact counts of the bodies are
  /// the particles with a fluid neighbour.
  void report(StepReport& rep, const BodySet& bodies) const
  {
    std::size_t total = 0;
    for (const Body& b : bodies.bodies()) total += b.contact;
    rep.active_boundary = total;
  }

  const std::vector<Real>& boundaryPressures() const
  {
    return zero_;
  }

private:
  BoundaryPressureInputs in_;
  Real inv_rho0_sq_;        // m^6/kg^2
  std::vector<Real> zero_;  // Pa: mirroring stores no p_b
};

/// What both extrapolations share: p_b = constant_b + sum_f c_bf p_f over the fluid neighbours f
/// of each active boundary particle (one with a fluid neighbour within h), with the coefficients
/// fixed during both solves (positions do not change), so each iteration is one sparse product.
/// The limit (Eq. A11) and the clamp p_b >= 0 in the density solve apply to both.
class ExtrapolatedBoundaryPressure
{
public:
  static constexpr bool kExtrapolated = true;

  /// `fit_radius` (m): how far from b the fluid neighbours of the fit reach.
  ExtrapolatedBoundaryPressure(const BoundaryPressureInputs& in, Real fit_radius);

  /// The active boundary particles and their fluid neighbours within the fit radius, with
  /// W(r) of a cubic spline of that support per pair (1/m^3).
  void buildLists();

  void addDiagonalFeedback(Real&, const Vec3&, const Vec3&) const {}

  /// p_b for every active boundary particle from the fluid pressures `p` (Eq. 3 / Eq. 15); with
  /// `with_constant` (SPH's hydrostatic term, density solve only) adds constant_b; in the density
  /// solve clamps p_b >= 0 when solver.clamp_boundary_pressure is set.
  void extrapolate(const std::vector<Real>& p, bool density_solve, bool with_constant);

  /// Eq. 1 with the stored p_b: sum_b psi_b p_b/rho0^2 grad W_ib, plus (p_i/rho_i^2) grad_b.
  template <bool kRecord>
  void addWallAcceleration(std::size_t i, const Vec3& xi, Real p_over_rho2, Real, const Vec3& grad_b, Real wall_dt,
                           Vec3& acc, Vec3& wall_dv) const
  {
    const Vec3 wall = wallSum(i, xi, [this](Index b) { return pb_[b]; });
    acc += wall - p_over_rho2 * grad_b;
    if constexpr (kRecord) wall_dv += wall_dt * wall;
  }

  /// The change of i's wall term when its own pressure changes (dp_over_rho2 = dp/rho_i^2): its
  /// p_b part waits for the next extrapolation (addWallChange), added to acc (m/s^2).
  void addOwnWallChange(Real dp_over_rho2, Real, const Vec3& grad_b, Vec3& acc) const
  {
    acc -= dp_over_rho2 * grad_b;
  }

  /// The change of i's wall term (Eq. 1's p_b part, m/s^2) from p_b = pb_before to the stored
  /// p_b, added to acc.
  void addWallChange(std::size_t i, const Vec3& xi, const std::vector<Real>& pb_before, Vec3& acc) const
  {
    acc += wallSum(i, xi, [&](Index b) { return pb_[b] - pb_before[b]; });
  }

  Real wallPressure(Index b, Real) const
  {
    return pb_[b];
  }

  Real contactPressure(Index b, Real) const
  {
    return pb_[b];
  }

  const std::vector<Real>& boundaryPressures() const
  {
    return pb_;
  }

  /// Eq. A4b: how fluid particle i's own pressure reaches its wall term through the
  /// extrapolation, sum_b psi_b c_bi grad W_ib over its boundary neighbours b (kg/m^4); c_bi = 0
  /// where i is not in b's fit. `xi` (m) is x_i.
  Vec3 feedbackVector(std::size_t i, const Vec3& xi) const
  {
    const NeighborLists& fb = in_.neighbors.fluid_boundary;
    const Real rho0 = in_.constants.rho0;
    Vec3 sum = Vec3::Zero();
    for (Index k = fb.offset[i]; k < fb.offset[i + 1]; ++k)
    {
      const Index b = fb.index[k];
      Real c = 0;
      if (!fb_to_fit_.empty())  // the fit lists are the transpose of fb: every pair has its entry
        c = coefficients_[fb_to_fit_[k]];
      else
      {
        // A fit row lists its fluid particles in ascending order (the search visits the sorted
        // fluid's cell ranges in order): i is found by bisection.
        const Index q = row_of_[b];
        const Index* const first = fit_lists_.index.data() + fit_lists_.offset[q];
        const Index* const last = fit_lists_.index.data() + fit_lists_.offset[q + 1];
        const Index* const at = std::lower_bound(first, last, Index(i));
        if (at != last && *at == Index(i)) c = coefficients_[std::size_t(at - fit_lists_.index.data())];
      }
      sum += (rho0 * volume_[b] * c * fb.grad_factor[k]) * (xi - xb_[b]);
    }
    return sum;
  }

protected:
  /// -sum_b psi_b (pb(b)/rho0^2) grad W_ib over i's boundary neighbours (m/s^2): Eq. 1's p_b part
  /// for the pressures pb(b) (Pa).
  template <class Pressure>
  Vec3 wallSum(std::size_t i, const Vec3& xi, Pressure&& pb) const
  {
    const NeighborLists& fb = in_.neighbors.fluid_boundary;
    const Real rho0 = in_.constants.rho0;
    Vec3 wall = Vec3::Zero();
    for (Index k = fb.offset[i]; k < fb.offset[i + 1]; ++k)
    {
      const Index b = fb.index[k];
      wall -= (rho0 * volume_[b] * pb(b) * inv_rho0_sq_ * fb.grad_factor[k]) * (xi - xb_[b]);
    }
    return wall;
  }

  /// buildLists()'s parts: the active boundary particles (active_, row_of_); then the fit lists
  /// (rows active_, entries in ascending fluid order, W of the fit radius per pair) from a search
  /// of their own, or as the transpose of the fluid-boundary lists (the same pairs and W when the
  /// fit radius is the kernel support), which also maps every fb pair to its entry (fb_to_fit_).
  void findActive();
  void searchFitLists();
  void transposeBoundaryLists();

  /// The coefficient figures of the step report (smallest and largest c_bf, largest and mean
  /// sum_f |c_bf| over the active boundary particles), from the coefficients of prepare().
  void coefficientFigures();
  void reportCoefficients(StepReport& rep) const;

  BoundaryPressureInputs in_;
  Real inv_rho0_sq_;                                        // m^6/kg^2
  Real fit_radius_;                                         // m
  const std::vector<Vec3>& xb_;                             // m, boundary positions
  const std::vector<Real>& volume_;                         // m^3, V_b
  std::vector<Real> pb_;                                    // Pa, p_b of the last extrapolation (inactive: unchanged)
  std::vector<Real> constant_;                              // Pa, constant_b (SPH's hydrostatic term; else 0)
  std::vector<Index> active_;                               // the active boundary particles, ascending
  NeighborLists fit_lists_;                                 // rows: active_; entries: fluid particles; weight: W(r)
  std::vector<Real> coefficients_;                          // c_bf per entry of fit_lists_ (unit-less)
  std::unique_ptr<std::atomic<std::uint8_t>[]> is_active_;  // per boundary particle (scratch)
  std::vector<Index> row_of_;                               // per boundary particle: its row in active_ (active only)
  // Per fluid-boundary pair (fb's entries): its entry in fit_lists_, when those are fb's transpose
  // (transposeBoundaryLists()); empty when the fit lists come from a search of their own.
  std::vector<Index> fb_to_fit_;
  // The transpose's fixed fluid ranges (8: work for every core of a small machine, at 32 B of
  // counts per active boundary particle), and per range and row its count, then its next slot
  // (scratch).
  static constexpr std::size_t kTransposeChunks = 8;
  std::vector<Index> transpose_slot_;
  double c_min_ = 0, c_max_ = 0, abs_sum_max_ = 0, abs_sum_mean_ = 0;  // coefficientFigures()
  std::vector<Vec3> queries_;                                          // m, positions of active_ (scratch)
};

/// SPH extrapolation (Eq. 3, Adami 2012): c_bf = W_bf / sum W, and in the density solve the
/// hydrostatic constant (g - a_b) . sum_f rho_f (x_b - x_f) W_bf / sum W.
class SphBoundaryPressure : public ExtrapolatedBoundaryPressure
{
public:
  explicit SphBoundaryPressure(const BoundaryPressureInputs& in);
  void prepare();
  void extrapolate(const std::vector<Real>& p, bool density_solve)
  {
    ExtrapolatedBoundaryPressure::extrapolate(p, density_solve, density_solve);
  }
  /// The density solve's p_b carries the hydrostatic constant_b, non-zero at p = 0.
  static constexpr bool vanishesAtZero(bool density_solve)
  {
    return !density_solve;
  }
  void report(StepReport& rep, const BodySet&) const
  {
    rep.active_boundary = active_.size();
    reportCoefficients(rep);
  }
};

/// MLS extrapolation (Eqs. 4-16, the paper): a hyperplane fitted to the fluid pressures around b,
/// weighted by V_f W_bf over solver.mls_fit_radius spacings, evaluated at x_b.
class MlsBoundaryPressure : public ExtrapolatedBoundaryPressure
{
public:
  explicit MlsBoundaryPressure(const BoundaryPressureInputs& in);
  void prepare();
  void extrapolate(const std::vector<Real>& p, bool density_solve)
  {
    ExtrapolatedBoundaryPressure::extrapolate(p, density_solve, false);
  }
  /// Eq. 15 without a constant: sum_f c_bf p_f, zero at p = 0 (the limit, Eq. A11, keeps it there).
  static constexpr bool vanishesAtZero(bool)
  {
    return true;
  }
  void report(StepReport& rep, const BodySet&) const
  {
    rep.active_boundary = active_.size();
    reportCoefficients(rep);
    rep.mls_fallbacks = fallbacks_;
    rep.mls_reduced = reduced_;
  }

private:
  std::size_t fallbacks_ = 0;           // boundary particles on Eq. 16 this step
  std::size_t reduced_ = 0;             // boundary particles with a pseudo-inverse fit this step
  std::vector<std::uint8_t> fit_kind_;  // MlsFit per active particle (scratch)
};

}  // namespace fluid_sim
