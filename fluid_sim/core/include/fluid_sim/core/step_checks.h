#pragma once
// What the step checks after moving the particles (phase 7 of docs/method.md), and the next time
// step (Eq. A15): non-finite states and blow-ups are reported in the StepReport (never thrown,
// never hidden), particles that left the domain are removed.

#include "fluid_sim/core/fluid_particles.h"
#include "fluid_sim/core/scene_config.h"
#include "fluid_sim/core/simulation.h"

namespace fluid_sim
{
/// Fills rep.max_speed (m/s) and rep.kinetic_energy (J, particle mass `mass` in kg) and, when the
/// state is non-finite, the mean density error exceeds stability.max_density_error or the fastest
/// particle crosses more than stability.max_cfl spacings in the step `dt` (s), sets rep.unstable
/// and rep.reason.
void checkStability(const FluidParticles& fluid, const SceneConfig& scene, Real mass, double dt, StepReport& rep);

/// Removes the particles outside scene.domain; returns how many.
std::size_t removeOutsideDomain(FluidParticles& fluid, const AxisBox& domain);

/// Eq. A15: the next time step, s: the fixed one, or lambda s / max|v| clamped to [min, max].
double computeTimeStep(const TimeStepConfig& ts, const FluidParticles& fluid, const Vec3& gravity, double spacing);

}  // namespace fluid_sim
