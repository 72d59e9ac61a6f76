#pragma once
// The wall guard (scene key solver.wall_guard; docs/method.md, Eq. A31): a step may not carry a
// fluid particle into a wall's particle layer. The pressure solve alone holds the water off a
// wall, and a particle that one step carries far enough past the layer is through it (water
// sinking through a curved mesh container's floor under a sideways load, with every boundary
// method; still water through a mesh cylinder's floor with mirroring). The guard measures how
// close a particle is to the walls by the part of its kernel the boundary particles fill,
//
//     c(x) = sum_b V_b W(x - x_b)       (unit-less; Eq. A31, the walls' share of Eq. A1 / rho0),
//
// smooth across the samples of a layer, larger in a corner, and the same at any sample spacing
// (Eq. A3's volumes). A step may end a particle where c is at most c_max, c of a flat layer at
// the guard distance (0.5 spacings: the solid's surface), or at most what it was at the start of
// the step; otherwise the particle is moved back along -grad c until it is, and its velocity
// towards the wall relative to the wall is taken away (an inelastic stop), the momentum going to
// the walls' wrenches. Particles that keep their distance are not touched: a scene whose water
// stays off its walls runs bit for bit as without the guard.

#include <cstddef>
#include <vector>

#include "fluid_sim/core/bodies.h"
#include "fluid_sim/core/fluid_particles.h"
#include "fluid_sim/core/kernel.h"
#include "fluid_sim/core/neighbor_search.h"
#include "fluid_sim/core/types.h"

namespace fluid_sim
{
/// What apply() did in one step.
struct WallGuardReport
{
  std::size_t particles = 0;  // fluid particles whose step was shortened
  double max_shift = 0.0;     // m, the largest correction of a position
};

class WallGuard
{
public:
  /// At x(t), before the positions move: the guard distance `distance` (m, from a flat layer; 0 =
  /// off, and apply() then does nothing) and the step's fluid-boundary lists (rows: fluid
  /// particles; W per pair). Stores, for every fluid particle with boundary neighbours, the most
  /// its c may be at the end of the step: max(c_max, c(x_i(t))).
  void prepare(double distance, double spacing, const CubicKernel& kernel, const FluidParticles& fluid,
               const BodySet& bodies, const NeighborLists& fluid_boundary);

  /// After x(t + dt) = x(t) + dt v(t + dt), with the lists prepare() was given: c at the new
  /// position, with every boundary particle of the lists moved by dt v_b (and, for a step that
  /// ended clear of the walls, at points of its path every 0.25 spacings, to catch one that passed
  /// over a layer). A particle above its limit there is moved along n = -grad c / |grad c| to
  /// where c is at the limit (regula falsi; at most as far as the step moved it relative to the
  /// walls), and its velocity's component along -n relative to the walls' (their velocities
  /// weighted by V_b W) is removed. The momentum taken from the fluid, m dv, is the walls':
  /// -m dv / dt split over the boundary particles by their shares V_b grad W_ib . n of the push,
  /// each added to its body as a force at it (N; torque about the body origin, N m).
  WallGuardReport apply(double dt, const CubicKernel& kernel, FluidParticles& fluid, const BodySet& bodies, Real mass,
                        BodyWrenches& wrenches, const NeighborLists& fluid_boundary);

private:
  // The wall-adjacent particles of this step, as prepare() found them.
  std::vector<Index> particle_;  // fluid particle index
  std::vector<Real> limit_;      // unit-less: the most c may be after the step
  std::vector<Vec3> start_;      // m, x_i(t)
  // Per particle of particle_, filled by apply(): velocity change (m/s), zero where untouched.
  std::vector<Vec3> dv_;
  std::vector<Real> shift_;   // m, how far the guard moved it (0: untouched)
  std::vector<Vec3> normal_;  // unit-less, the wall normal the guard acted along
  double spacing_ = 0.0;      // m
};

}  // namespace fluid_sim
