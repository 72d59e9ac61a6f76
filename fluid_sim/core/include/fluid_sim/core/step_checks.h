#pragma once
// What the step checks after moving the particles (phase 7 of docs/method.md), and the next time
// step (Eq. A15): non-finite states and blow-ups are reported in the StepReport (never thrown,
// never hidden), particles that left the domain are removed.

#include <cstddef>
#include <limits>
#include <string>

#include "fluid_sim/core/bodies.h"
#include "fluid_sim/core/fluid_particles.h"
#include "fluid_sim/core/neighborhoods.h"
#include "fluid_sim/core/scene_config.h"
#include "fluid_sim/core/simulation.h"

namespace fluid_sim
{
/// No particle: checkStability() found the step stable.
inline constexpr std::size_t kNoParticle = std::numeric_limits<std::size_t>::max();

/// Fills rep.max_speed (m/s) and rep.kinetic_energy (J, particle mass `mass` in kg) and, when the
/// state is non-finite, the mean density error exceeds stability.max_density_error or the fastest
/// particle crosses more than stability.max_cfl spacings in the step `dt` (s), sets rep.unstable
/// and rep.reason. Returns the particle the reason is about (the first non-finite one, the
/// densest one, the fastest one), or kNoParticle when the step is stable.
std::size_t checkStability(const FluidParticles& fluid, const SceneConfig& scene, Real mass, double dt,
                           StepReport& rep);

/// Where particle i of a blow-up was, for its report: its position at the start of the step `dt`
/// (s), x - dt v, while that lies in `domain`, else the mean of its boundary neighbours' (m), and
/// its neighbours then (the step's lists, in the same particle order): how many fluid particles
/// and, per body, how many boundary particles, most first, named as in the scene. A particle with
/// few fluid neighbours and two bodies close by is water pinched between them (docs/method.md,
/// Eqs. A4c and A4d).
std::string describeParticle(std::size_t i, double dt, const AxisBox& domain, const FluidParticles& fluid,
                             const Neighborhoods& neighbors, const BodySet& bodies);

/// Whether the position x (m) lies in the box [lo, hi] (m, in Real as the particles are): the
/// domain test of removeOutsideDomain(), which the initial fill of explicit particles shares so that
/// a particle the step would keep is kept.
inline bool insideBox(const Vec3& x, const Vec3& lo, const Vec3& hi)
{
  return (x.array() >= lo.array()).all() && (x.array() <= hi.array()).all();
}

/// Removes the particles outside scene.domain; returns how many.
std::size_t removeOutsideDomain(FluidParticles& fluid, const AxisBox& domain);

/// Eq. A15: the next time step, s: the fixed one, or lambda s / max|v| clamped to [min, max],
/// the largest speed that of the fluid's particles or `body_speed` (m/s, the moving bodies',
/// BodySet::maxSpeedAhead), whichever is larger.
double computeTimeStep(const TimeStepConfig& ts, const FluidParticles& fluid, const Vec3& gravity, double spacing,
                       double body_speed);

}  // namespace fluid_sim
