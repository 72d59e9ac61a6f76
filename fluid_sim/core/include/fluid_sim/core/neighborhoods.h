#pragma once
// The step's neighbourhoods (phase 1 of the step, docs/method.md): the fluid sorted by grid cell,
// then the fluid-fluid and fluid-boundary lists within the kernel support h = 2 s, each pair with
// (dW/dr)/r of the cubic spline (Eq. A18), the fluid-boundary pairs also with W(r). The
// boundary-fluid lists that the pressure extrapolations need are built by those methods from
// fluidGrid().

#include <cmath>
#include <cstdint>
#include <vector>

#include "fluid_sim/core/bodies.h"
#include "fluid_sim/core/fluid_particles.h"
#include "fluid_sim/core/kernel.h"
#include "fluid_sim/core/neighbor_search.h"
#include "fluid_sim/core/scene_config.h"

namespace fluid_sim
{
/// Pairs per call of fluidPairWeights (a row of the fluid-fluid lists holds about 28).
constexpr Index kWeightChunk = 64;

/// W(r) (1/m^3, Eq. A18) of `count` (at most kWeightChunk) fluid-fluid pairs (i, j[t]) into w[t],
/// bit for bit the values the search computed: the fluid-fluid lists keep no W (4 B per pair,
/// 114 B per fluid particle at 1 M, docs/performance.md); the density takes the search's sum per
/// row, and XSPH, once per step, computes the pairs' W here. `xi` is x_i (m); `points` the sorted
/// fluid as the search read it (its x, y, z arrays when it has them, else its positions). The
/// gathers come first, then the square roots and polynomials as one loop the compiler vectorises.
inline void fluidPairWeights(const CubicKernel& kernel, const Vec3& xi, const GridPoints& points, const Index* j,
                             Index count, Real* w)
{
  if (points.soa != nullptr)
  {
    // As the search's vector path: candidate minus query, x, y, z arrays (gathers).
    const Real* const px = points.soa;
    const Real* const py = px + points.count;
    const Real* const pz = py + points.count;
    for (Index t = 0; t < count; ++t)
      w[t] = pairSquaredDistance(px[j[t]] - xi.x(), py[j[t]] - xi.y(), pz[j[t]] - xi.z());
  }
  else
    for (Index t = 0; t < count; ++t)
    {
      const Vec3 r = xi - points.sorted[j[t]];
      w[t] = pairSquaredDistance(r.x(), r.y(), r.z());
    }
  for (Index t = 0; t < count; ++t) w[t] = kernel.W(std::sqrt(w[t]));
}

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

  NeighborLists fluid_fluid;     // rows: fluid particles; entries: fluid particles (not itself); no weight
  NeighborLists fluid_boundary;  // rows: fluid particles; entries: boundary particles; weight W (1/m^3)

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
    std::vector<Index> members;  // boundary particle indices of the group's bodies
    std::vector<Vec3> gathered;  // m, their positions in member order (kept only by a group rebuilt every step)
    // The sorted positions in the one form the search reads (kSearchReadsCoordinateArrays).
    std::vector<Vec3> sorted;                   // m, in grid order (inside the grid only), or empty
    std::vector<Real> soa;                      // m, the same as x, y, z arrays, or empty
    std::vector<Index> ids;                     // boundary particle index of each sorted point
    std::uint64_t version = ~std::uint64_t(0);  // BodySet version the arrays were built from
    /// Sorts the members' positions `x` by the grid. `keep_gathered`: keep the gathering array's
    /// and the grid's per-point storage for the next rebuild (a moving group, every step) instead
    /// of freeing them (the static walls, once: 20 B per wall particle).
    void rebuild(const std::vector<Vec3>& x, std::uint64_t new_version, bool keep_gathered);
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
