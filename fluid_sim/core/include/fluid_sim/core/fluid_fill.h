#pragma once
// The initial fluid: the scene's fluid blocks as cell-centred lattices at the particle spacing,
// or as the explicit particles of a saved state, without the points that fall inside a solid
// body, outside every container (of a scene that has one) or too close to an open shell (a cup,
// a paddle), and without explicit particles outside the domain; lattice points too close to a
// wall's particles are trimmed (Eq. A21 of docs/method.md).

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "fluid_sim/core/bodies.h"
#include "fluid_sim/core/fluid_particles.h"
#include "fluid_sim/core/scene_config.h"

namespace fluid_sim
{
/// Where a particle of the initial fill comes from; the relaxation before t = 0 (Eq. A22) treats
/// each kind differently.
enum class FillKind : std::uint8_t
{
  Explicit = 0,         // a saved state's particle: never moved
  LatticeInterior = 1,  // a lattice point inside its block: driven to rest density from both sides
  LatticeFace = 2       // on its block's outer layer (a free surface or a block face): only pushed
};

/// What fillFluid() made.
struct FillResult
{
  std::size_t dropped = 0;            // lattice points and explicit particles left out (trimmed ones included)
  std::size_t trimmed = 0;            // of those, lattice points left out for being too close to a wall (Eq. A21)
  std::size_t overlapped = 0;         // of those, lattice points left out where an earlier block's water lies
  std::vector<std::string> warnings;  // blocks whose whole-spacing lattice leaves much of them empty
  std::vector<FillKind> kind;         // per particle appended, in order
};

/// Whether water cannot be at `pos` (m, world): inside a solid body, or, in a scene with
/// containers, inside none of them (open meshes, which have no inside, are not asked).
bool outsideTheWater(const Vec3d& pos, const BodySet& bodies);

/// The distance (m) below which a lattice point is too close to a boundary particle of a solid
/// or a container (Eq. A21): one spacing, less a rounding allowance of 10^-3 s so that a point
/// exactly one spacing from a flat wall's layer (the lattice's own distance there) is kept.
double trimDistance(double spacing);

/// Appends the particles of every block of scene.fluid to `fluid`, in block order (at rest
/// density, zero pressure; a box's lattice with the block's velocity, explicit particles in their
/// order with their own velocities). With scene.fill.trim, lattice points closer than
/// trimDistance() to a boundary particle of a solid or a container are left out too (never
/// explicit particles). Blocks that overlap make their union: a lattice point strictly inside an
/// earlier box block, within half a spacing of an earlier block's lattice particle or within 0.9
/// spacing of a saved state's particle is left out (counted in `overlapped`). Throws ConfigError
/// (key `fluid`) when no particle remains.
FillResult fillFluid(const SceneConfig& scene, const BodySet& bodies, FluidParticles& fluid);

}  // namespace fluid_sim
