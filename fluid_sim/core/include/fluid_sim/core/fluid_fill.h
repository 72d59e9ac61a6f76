#pragma once
// The initial fluid: the scene's fluid blocks as cell-centred lattices at the particle spacing,
// or as the explicit particles of a saved state, without the points that fall inside a solid
// body, outside a container or too close to an open shell (a cup, a paddle), and without explicit
// particles outside the domain.

#include <cstddef>

#include "fluid_sim/core/bodies.h"
#include "fluid_sim/core/fluid_particles.h"
#include "fluid_sim/core/scene_config.h"

namespace fluid_sim
{
/// Appends the particles of every block of scene.fluid to `fluid`, in block order (at rest
/// density, zero pressure; a box's lattice with the block's velocity, explicit particles in their
/// order with their own velocities). Returns the number of lattice points and explicit particles
/// left out. Throws ConfigError (key `fluid`) when no particle remains.
std::size_t fillFluid(const SceneConfig& scene, const BodySet& bodies, FluidParticles& fluid);

}  // namespace fluid_sim
