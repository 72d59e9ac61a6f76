#pragma once
// The DFSPH pressure solver (Bender & Koschier 2017, iterating on pressure as the paper does):
// densities, the Jacobi diagonal and density rates (Eqs. A1, A2, A4), the divergence solve
// (Eq. A5), the density solve (Eq. A6), both by relaxed Jacobi (Eqs. A7-A10; the density solve
// optionally by Gauss-Seidel sweeps from its third sweep on, Eq. A8b), the pressure
// acceleration with the boundary term (Eq. 1), the pressure part of the bodies' wrenches
// (Eq. A12) and the time integration (Eq. A16). One solver is compiled per boundary pressure
// method (boundary_pressure_methods.h); makePressureSolver picks it once.

#include <memory>
#include <vector>

#include "fluid_sim/core/bodies.h"
#include "fluid_sim/core/boundary_pressure_methods.h"
#include "fluid_sim/core/fluid_particles.h"
#include "fluid_sim/core/non_pressure_forces.h"
#include "fluid_sim/core/simulation.h"

namespace fluid_sim
{
/// The phases of the step that depend on the boundary pressure method.
class PressureSolver
{
public:
  virtual ~PressureSolver() = default;

  /// After the neighbour search: the method's own lists (the extrapolations' fit neighbourhoods).
  virtual void buildBoundaryLists() = 0;
  /// Densities rho_i (Eq. A1), diagonal A_i (Eq. A4), density rates (Eq. A2) with v(t); then what
  /// the boundary method keeps fixed through both solves (extrapolation coefficients).
  virtual void computeDensityAndDiagonal() = 0;
  /// Divergence solve (Eq. A5): v* = v + dt a^p. Adds the pressure forces to `wrenches`.
  virtual void divergenceSolve(double dt, StepReport& rep, BodyWrenches& wrenches) = 0;
  /// Density solve (Eq. A6) with the current velocities v**; leaves the final a^p for integrate().
  /// Adds the pressure forces to `wrenches`.
  virtual void densitySolve(double dt, StepReport& rep, BodyWrenches& wrenches) = 0;
  /// Work arrays the non-pressure forces may overwrite between the two solves (its own, free
  /// then): the forces need no arrays of their own (32 B per particle).
  virtual ForceScratch forceScratch() = 0;
  /// Eq. A16: v(t + dt) = v** + dt a^p, x(t + dt) = x + dt v(t + dt); p_total for output.
  virtual void integrate(double dt) = 0;
  /// J: the work the p_b part of the wall term did on the fluid in this step (diagnostic).
  virtual double boundaryPressureWork() const = 0;
  /// The p_b that fluid particle i sees at boundary particle b in the density solve (Pa).
  virtual Real wallPressure(std::size_t i, Index b) const = 0;
  /// The method's counts (active boundary particles, MLS fallbacks) for the step report.
  virtual void report(StepReport& rep) const = 0;
  /// Pa, per boundary particle, of the last density-solve extrapolation (zeros for mirroring).
  virtual const std::vector<Real>& boundaryPressures() const = 0;
};

/// The solver for scene.solver.boundary_pressure.
std::unique_ptr<PressureSolver> makePressureSolver(const BoundaryPressureInputs& in, FluidParticles& fluid);

}  // namespace fluid_sim
