// The step's neighbour lists (see neighborhoods.h).

#include "fluid_sim/core/neighborhoods.h"

#include <cmath>

namespace fluid_sim
{
Neighborhoods::Neighborhoods(const SceneConfig& scene, const CubicKernel& kernel)
    : kernel_(kernel)
    , support_(kernel.support())
    // Grid cells of the kernel support h (m): a query visits 9 rows of 3 cells, ~24 candidates
    // each, long enough for the vector path of buildNeighborLists. With cells of one spacing
    // (25 rows of ~5) the search took 6.5 instead of 4.4 ms per step in bench_dam_break. The cell
    // is h as the search's radius holds it (a float), not 2 s in double: where the float rounds
    // up (s = 0.0305, 0.017 m, ...) h / (2 s) came out a hair above 1, every query reached two
    // cells each way (125 cells instead of 27) and the search took 2-3x as long
    // (docs/performance.md).
    , fluid_grid_(scene.domain.min, scene.domain.max, double(kernel.support()), 2)
    , static_group_(fluid_grid_)
    , moving_group_(fluid_grid_)
{
}

void Neighborhoods::BoundaryGroup::rebuild(const std::vector<Vec3>& x, std::uint64_t new_version, bool keep_gathered)
{
  gathered.resize(members.size());
  for (std::size_t k = 0; k < members.size(); ++k) gathered[k] = x[members[k]];
  grid.build(gathered);
  const std::size_t inside = grid.numInside();  // points outside the grid are never visited
  ids.resize(inside);
  for (std::size_t k = 0; k < inside; ++k) ids[k] = members[grid.order()[k]];
  if constexpr (kSearchReadsCoordinateArrays)
  {
    soa.resize(3 * inside);
    for (std::size_t k = 0; k < inside; ++k)
    {
      const Vec3& p = gathered[grid.order()[k]];
      soa[k] = p.x();
      soa[inside + k] = p.y();
      soa[2 * inside + k] = p.z();
    }
  }
  else
  {
    sorted.resize(inside);
    for (std::size_t k = 0; k < inside; ++k) sorted[k] = gathered[grid.order()[k]];
  }
  if (!keep_gathered)
  {
    std::vector<Vec3>().swap(gathered);
    grid.releasePointArrays();  // ids and the sorted positions hold what the searches need
  }
  version = new_version;
}

GridPoints Neighborhoods::BoundaryGroup::points() const
{
  GridPoints p;
  p.grid = &grid;
  p.sorted = sorted.empty() ? nullptr : sorted.data();
  p.soa = soa.empty() ? nullptr : soa.data();
  p.ids = ids.data();
  p.count = ids.size();  // the points inside the grid, in either form
  return p;
}

GridPoints Neighborhoods::fluidPoints(const FluidParticles& fluid) const
{
  GridPoints p;
  p.grid = &fluid_grid_;
  p.sorted = fluid.x.data();
  p.soa = kSearchReadsCoordinateArrays && fluid_soa_.size() == 3 * fluid.size() ? fluid_soa_.data() : nullptr;
  p.count = fluid.size();
  return p;
}

void Neighborhoods::sortFluid(FluidParticles& fluid)
{
  fluid_grid_.build(fluid.x);
  fluid.reorder(fluid_grid_.order());
}

void Neighborhoods::build(const FluidParticles& fluid, const BodySet& bodies)
{
  const CubicKernel& kern = kernel_;
  // grad W(r) = grad_factor * r (1/m^5) per pair, read in every pass of both solves. W(r) (1/m^3)
  // per pair only for the fluid-boundary pairs; of the fluid-fluid W the density (Eq. A1) needs
  // only each row's sum, which the search adds up while the values are at hand, and XSPH, once per
  // step, computes them again (fluidPairWeights): storing them cost 4 B per pair, 114 B per fluid
  // particle at 1 M (docs/performance.md).
  auto gradFactor = [&kern](Real d2) -> Real { return kern.gradFactor(std::sqrt(d2)); };
  auto weight = [&kern](Real d2) -> Real { return kern.W(std::sqrt(d2)); };
  // After the sort the grid's sorted positions are the particle indices themselves; the search
  // reads them as x, y, z arrays or straight from fluid.x.
  if constexpr (kSearchReadsCoordinateArrays) toCoordinateArrays(fluid.x, fluid_soa_);
  buildNeighborLists(fluid.x, std::vector<GridPoints>{fluidPoints(fluid)}, support_, true, gradFactor, rowSum(weight),
                     fluid_fluid);
  if (bodies.numParticles() == 0)
  {
    fluid_boundary.offset.assign(fluid.size() + 1, 0);
    fluid_boundary.index.clear();
    fluid_boundary.grad_factor.clear();
    fluid_boundary.weight.clear();
    return;
  }
  if (grouped_bodies_ != bodies.size())
  {
    // Bodies keep their kind for the simulation's life: the member lists are made once.
    static_group_.members.clear();
    moving_group_.members.clear();
    for (const Body& body : bodies.bodies())
    {
      std::vector<Index>& members = body.moving ? moving_group_.members : static_group_.members;
      for (std::size_t k = 0; k < body.local.size(); ++k) members.push_back(Index(body.offset + k));
    }
    static_group_.version = moving_group_.version = ~std::uint64_t(0);
    grouped_bodies_ = bodies.size();
  }
  // Each group is sorted again only when one of its bodies wrote new positions: static walls
  // once, a moving robot link every step it moves, without the walls.
  // A group without members is never built: its grid's cells are not even allocated.
  if (!static_group_.members.empty() && static_group_.version != bodies.staticVersion())
    static_group_.rebuild(bodies.x, bodies.staticVersion(), false);
  if (!moving_group_.members.empty() && moving_group_.version != bodies.movingVersion())
    moving_group_.rebuild(bodies.x, bodies.movingVersion(), true);
  std::vector<GridPoints> sources;
  if (!static_group_.members.empty()) sources.push_back(static_group_.points());
  if (!moving_group_.members.empty()) sources.push_back(moving_group_.points());
  buildNeighborLists(fluid.x, sources, support_, false, gradFactor, weight, fluid_boundary);
}

}  // namespace fluid_sim
