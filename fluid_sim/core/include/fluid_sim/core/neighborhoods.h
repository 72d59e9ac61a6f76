#pragma once
// The step's neighbourhoods (phase 1 of the step, docs/method.md): the fluid sorted by grid cell,
// then the fluid-fluid and fluid-boundary lists within the kernel support h = 2 s, each pair with
// (dW/dr)/r and W(r) of the cubic spline (Eq. A18). The boundary-fluid lists that the pressure
// extrapolations need are built by those methods from fluidGrid().

#include <cstdint>
#include <vector>

#include "fluid_sim/core/bodies.h"
#include "fluid_sim/core/fluid_particles.h"
#include "fluid_sim/core/kernel.h"
#include "fluid_sim/core/neighbor_search.h"
#include "fluid_sim/core/scene_config.h"

namespace fluid_sim
{
class Neighborhoods
{
public:
  Neighborhoods(const SceneConfig& scene, const CubicKernel& kernel);

  /// Sorts the fluid by grid cell (every registered field together); the lists then run over
  /// neighbours that are close in memory. All particles must be inside the domain.
  void sortFluid(FluidParticles& fluid);

  /// Fluid-fluid and fluid-boundary lists for the current (sorted) positions.
  void build(const FluidParticles& fluid, const BodySet& bodies);

  /// The grid of the last sort: the fluid in cell order is the fluid itself (identity order).
  const UniformGrid& fluidGrid() const
  {
    return fluid_grid_;
  }

  NeighborLists fluid_fluid;     // rows: fluid particles; entries: fluid particles (not itself)
  NeighborLists fluid_boundary;  // rows: fluid particles; entries: boundary particles

  /// The sorted fluid as a point set for buildNeighborLists, with its coordinate arrays of this
  /// step (made once per step in build(), shared by every search against the fluid).
  GridPoints fluidPoints(const FluidParticles& fluid) const;

private:
  /// The boundary particles of one kind of body, sorted by their own grid: bodies that never
  /// move (static) are sorted once; moving ones (scripted, posed from outside, free) again only
  /// when one of them moved, and without the static ones.
  struct BoundaryGroup
  {
    explicit BoundaryGroup(const UniformGrid& grid) : grid(grid) {}
    UniformGrid grid;
    std::vector<Index> members;                 // boundary particle indices of the group's bodies
    std::vector<Vec3> gathered;                 // m, their positions in member order
    std::vector<Vec3> sorted;                   // m, in grid order (inside the grid only)
    std::vector<Real> soa;                      // m, sorted as x, y, z arrays
    std::vector<Index> ids;                     // boundary particle index of each sorted point
    std::uint64_t version = ~std::uint64_t(0);  // BodySet version the arrays were built from
    void rebuild(const std::vector<Vec3>& x, std::uint64_t new_version);
    GridPoints points() const;
  };

  const CubicKernel& kernel_;
  Real support_;  // m, h
  UniformGrid fluid_grid_;
  std::vector<Real> fluid_soa_;  // m, the sorted fluid's x, y, z arrays of this step
  BoundaryGroup static_group_, moving_group_;
  std::size_t grouped_bodies_ = ~std::size_t(0);  // bodies the groups' member lists were made for
};

}  // namespace fluid_sim
