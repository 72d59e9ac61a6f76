#pragma once
// The initial fluid: the scene's fluid blocks as cell-centred lattices at the particle spacing,
// without the points that fall inside a solid body, outside a container or too close to an open
// shell (a cup, a paddle).

#include <cstddef>

#include "fluid_sim/core/bodies.h"
#include "fluid_sim/core/fluid_particles.h"
#include "fluid_sim/core/scene_config.h"

namespace fluid_sim
{
/// Appends the particles of every block of scene.fluid to `fluid` (at rest density, zero
/// pressure, the block's velocity). Returns the number of lattice points left out. Throws
/// ConfigError (key `fluid`) when no particle remains.
std::size_t fillFluid(const SceneConfig& scene, const BodySet& bodies, FluidParticles& fluid);

}  // namespace fluid_sim
