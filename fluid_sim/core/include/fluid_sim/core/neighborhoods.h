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

private:
  const CubicKernel& kernel_;
  Real support_;  // m, h
  UniformGrid fluid_grid_, boundary_grid_;
  std::vector<Vec3> boundary_sorted_;                   // m, boundary particles in boundary_grid_'s cell order
  std::uint64_t boundary_version_ = ~std::uint64_t(0);  // BodySet::positionsVersion() of boundary_grid_
};

}  // namespace fluid_sim
