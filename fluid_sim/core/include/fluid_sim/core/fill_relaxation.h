#pragma once
// The relaxation of the initial lattice before t = 0 (docs/method.md, Initial fluid, Eqs. A22,
// A23): where a curved or tilted wall cuts the lattice, the trimmed fill (Eq. A21) leaves gaps of
// up to a spacing between the water and the wall, and the water would fall into them at t = 0 and
// slosh. A damped settling under gravity in pseudo-time, with the scene's own density solve, lets
// it settle into them before t = 0 and starts it from rest. Explicit particles (a saved state)
// stay where they are.

#include <vector>

#include "fluid_sim/core/bodies.h"
#include "fluid_sim/core/fluid_constants.h"
#include "fluid_sim/core/fluid_fill.h"
#include "fluid_sim/core/fluid_particles.h"
#include "fluid_sim/core/neighborhoods.h"
#include "fluid_sim/core/scene_config.h"
#include "fluid_sim/core/simulation.h"

namespace fluid_sim
{
/// The fraction of a spacing that gravity alone moves a particle in one pseudo-step from rest
/// (Eq. A22): the pseudo-step is tau = sqrt(kRelaxFall s / |g|) (7.8 ms at s = 3 cm). Measured in
/// the half-filled sphere of radius 0.5 m at spacing 3 cm (17 spacings deep): 0.05 diverged after
/// 20 pseudo-steps, 0.02 settles (docs/method_notes.md).
constexpr double kRelaxFall = 0.02;

/// The part of its pseudo-velocity a particle keeps from one pseudo-step to the next (Eq. A22):
/// a damped settling. Measured in the same sphere (mean speed at 0.1 s and 0.5 s after t = 0):
/// velocities zeroed each pseudo-step (0) settled in 72 pseudo-steps to 0.055 and 0.077 m/s, 0.8
/// in 132 to 0.017 and 0.033 m/s (0.9 in the 0.25 m sphere: 0.009 and 0.022 m/s, but it had not
/// settled after 150 pseudo-steps).
constexpr double kRelaxKeep = 0.8;

/// Eq. A23: the lattice's largest relative departure from rest density (Eq. A1 densities, in the
/// current order): |rho_i - rho0|/rho0 over interior lattice particles (with `under_too`; else
/// only the excess: without gravity nothing would move the water into a gap), (rho_i - rho0)^+/rho0
/// over those on a block's outer layer (a free surface is under rest density and stays so),
/// nothing for explicit particles.
double latticeDensityError(const std::vector<Real>& rho, const std::vector<FillKind>& kind, Real rho0, bool under_too);

/// Eq. A23: measures the lattice's departure from rest density and, beyond
/// scene.fill.relax_tolerance, relaxes it (Eq. A22) for at most scene.fill.relax_max_steps
/// pseudo-steps, with a pressure solver of its own for the scene's boundary method (`dt`, s, is the
/// pseudo-step without gravity). `kind` is the fill's, in the fill's order. Bodies are held still
/// at their pose at t = 0 (their particles' velocities and accelerations are zero during the
/// relaxation and restored afterwards). On return the particles are in the fill's order, explicit
/// ones bit for bit as they were, every particle has its initial velocity, rest density and zero
/// pressures; only the lattice particles' positions may have changed. Fills the density errors,
/// relaxed and relax_steps of `report`. With `measure_only` (fill.relax off) nothing is moved: the
/// error is measured, and beyond the tolerance `report.settled` is false.
void relaxFill(const SceneConfig& scene, const FluidConstants& constants, const std::vector<FillKind>& kind, double dt,
               FluidParticles& fluid, BodySet& bodies, Neighborhoods& neighbors, FillReport& report,
               bool measure_only = false);

}  // namespace fluid_sim
