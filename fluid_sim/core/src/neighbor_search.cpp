#include "fluid_sim/core/neighbor_search.h"

#include <tbb/parallel_for.h>

#include <cmath>

namespace fluid_sim
{
UniformGrid::UniformGrid(const Vec3d& min, const Vec3d& max, double cell_size, int margin)
    : cell_(cell_size), inv_cell_(1.0 / cell_size)
{
  origin_ = min - Vec3d::Constant(margin * cell_size);
  for (int k = 0; k < 3; ++k) dims_[k] = int(std::ceil((max[k] - min[k]) * inv_cell_)) + 2 * margin + 1;
  // The cells (4 B each, 2.9 M of them over bench_dam_break's domain at 1 M fluid particles) are
  // allocated by the first build(): a grid that is never built (the moving bodies' grid of a
  // scene without moving bodies) costs nothing.
}

void UniformGrid::build(const std::vector<Vec3>& points)
{
  const std::size_t n = points.size();
  cell_of_point_.resize(n);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4096), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) cell_of_point_[i] = cellOf(points[i]);
  });
  // Counting sort (stable, so equal cells keep their relative order and the result is
  // deterministic). cell_start_ doubles as the histogram and, placing the points from the last to
  // the first, as the cursor: each cell's entry counts down from the cell's end to its start. A
  // separate cursor array was a copy of cell_start_ per build (4 B per cell, 2.8 MB at 195 k
  // particles, the same again for the static boundary's grid).
  const std::size_t num_cells = std::size_t(dims_[0]) * dims_[1] * dims_[2];
  if (cell_start_.size() != num_cells + 1)
    cell_start_.assign(num_cells + 1, 0);
  else
    std::fill(cell_start_.begin(), cell_start_.end(), 0);
  std::size_t outside = 0;
  for (std::size_t i = 0; i < n; ++i)
  {
    const Index c = cell_of_point_[i];
    if (c == kOutside)
      ++outside;
    else
      ++cell_start_[c];
  }
  for (std::size_t c = 1; c < num_cells; ++c) cell_start_[c] += cell_start_[c - 1];  // end of cell c
  num_inside_ = n - outside;
  cell_start_[num_cells] = Index(num_inside_);
  order_.resize(n);
  std::size_t next_outside = n;
  for (std::size_t i = n; i-- > 0;)
  {
    const Index c = cell_of_point_[i];
    if (c == kOutside)
      order_[--next_outside] = Index(i);
    else
      order_[--cell_start_[c]] = Index(i);
  }
}

void toCoordinateArrays(const std::vector<Vec3>& points, std::vector<Real>& soa)
{
  const std::size_t m = points.size();
  soa.resize(3 * m);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, m, 4096), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t k = r.begin(); k != r.end(); ++k)
    {
      soa[k] = points[k].x();
      soa[m + k] = points[k].y();
      soa[2 * m + k] = points[k].z();
    }
  });
}

}  // namespace fluid_sim
