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
class NonPressureForces
{
public:
  /// `viscosity` is read at every apply() (it may change between steps).
  NonPressureForces(const ViscosityConfig& viscosity, const FluidConstants& constants);

  /// v** = v* + dt a^np for every fluid particle (dt in s). Adds the boundary viscosity's
  /// reaction on the bodies to `wrenches`.
  void apply(double dt, FluidParticles& fluid, const Neighborhoods& neighbors, const BodySet& bodies,
             BodyWrenches& wrenches);

private:
  const ViscosityConfig& viscosity_;
  const FluidConstants& constants_;
  std::vector<Vec3> dv_;      // m/s, velocity change of the step from viscosity (scratch)
  std::vector<Real> volume_;  // m^3, m_j/rho_j per particle (scratch)
  std::vector<Eigen::Matrix<Real, 4, 1>, Eigen::aligned_allocator<Eigen::Matrix<Real, 4, 1>>> v4_;  // m/s, padded
};

}  // namespace fluid_sim
