#pragma once
// The non-pressure accelerations of the step (phase 4 of docs/method.md): gravity and, only when
// the scene enables it, viscosity, artificial (Eq. A13) or XSPH (Eq. A14), with its wall term and
// the reaction of that wall term on the bodies.

#include <vector>

#include "fluid_sim/core/bodies.h"
#include "fluid_sim/core/fluid_constants.h"
#include "fluid_sim/core/fluid_particles.h"
#include "fluid_sim/core/neighborhoods.h"
#include "fluid_sim/core/scene_config.h"

namespace fluid_sim
{
/// Per-particle work arrays for NonPressureForces::apply(), which resizes and overwrites them; they
/// carry nothing into or out of it. The pressure solver lends its own, free between its two
/// solves, so the forces hold no arrays (32 B per particle less at the step's peak).
struct ForceScratch
{
  Vec4Array& v4;              // m/s, v* padded (XSPH)
  Vec4Array& dv;              // m/s, the viscosity's velocity change of the step, padded
  std::vector<Real>& volume;  // m^3, m_j/rho_j per particle
};

class NonPressureForces
{
public:
  /// `viscosity` is read at every apply() (it may change between steps).
  NonPressureForces(const ViscosityConfig& viscosity, const FluidConstants& constants);

  /// v** = v* + dt a^np for every fluid particle (dt in s). Adds the boundary viscosity's
  /// reaction on the bodies to `wrenches`. Works in `scratch`.
  void apply(double dt, FluidParticles& fluid, const Neighborhoods& neighbors, const BodySet& bodies,
             BodyWrenches& wrenches, ForceScratch scratch);

private:
  const ViscosityConfig& viscosity_;
  const FluidConstants& constants_;
};

}  // namespace fluid_sim
