#pragma once
// The constants of a scene's fluid, derived once from its configuration.

#include "fluid_sim/core/kernel.h"
#include "fluid_sim/core/scene_config.h"
#include "fluid_sim/core/types.h"

namespace fluid_sim
{
struct FluidConstants
{
  explicit FluidConstants(const SceneConfig& scene)
      : spacing(Real(scene.spacing))
      , support(Real(2.0 * scene.spacing))
      , rho0(Real(scene.rest_density))
      , mass(Real(scene.rest_density * scene.spacing * scene.spacing * scene.spacing))
      , kernel(Real(2.0 * scene.spacing))
      , gravity(scene.gravity.cast<Real>())
  {
  }

  Real spacing;        // m, particle spacing s
  Real support;        // m, kernel support h = 2 s
  Real rho0;           // kg/m^3, rest density
  Real mass;           // kg, of one fluid particle, rho0 s^3
  CubicKernel kernel;  // Eq. A18, support h
  Vec3 gravity;        // m/s^2
};

}  // namespace fluid_sim
