#pragma once
// Uniform-grid neighbour search over a fixed, dense grid covering the scene domain.
// Cells are ordered x-fastest, so the three cells of a row along x are one contiguous range of
// sorted points: a query visits 9 ranges instead of 27 cells.

#include <cmath>
#include <type_traits>
#include <utility>
#include <vector>

#include "fluid_sim/core/types.h"

namespace fluid_sim
{
class UniformGrid
{
public:
  static constexpr Index kOutside = ~Index(0);

  /// Covers [min, max] (m) plus `margin` cells on every side; cell edge `cell_size` (m).
  UniformGrid(const Vec3d& min, const Vec3d& max, double cell_size, int margin = 1);

  /// Linear cell index of `p`, or kOutside. Inline: the search asks it once per query and point set.
  Index cellOf(const Vec3& p) const
  {
    const double fx = (double(p.x()) - origin_.x()) * inv_cell_;
    const double fy = (double(p.y()) - origin_.y()) * inv_cell_;
    const double fz = (double(p.z()) - origin_.z()) * inv_cell_;
    // The negated comparisons also reject NaN.
    if (!(fx >= 0 && fy >= 0 && fz >= 0 && fx < dims_[0] && fy < dims_[1] && fz < dims_[2])) return kOutside;
    return Index(int(fx) + std::size_t(dims_[0]) * (int(fy) + std::size_t(dims_[1]) * int(fz)));
  }

  /// Frees the last build's per-point arrays (order() is then empty until the next build); the
  /// cells stay as built. For a point set sorted once whose order was copied out (the static
  /// walls: 8 B per wall particle).
  void releasePointArrays()
  {
    std::vector<Index>().swap(cell_of_point_);
    std::vector<Index>().swap(order_);
  }

  /// Counting sort of `points` by cell. Afterwards `order()[k]` is the index (into `points`) of the
  /// k-th point in cell order, and cellRange(c) gives the range of k for cell c. Points outside
  /// the grid are put last and belong to no cell.
  void build(const std::vector<Vec3>& points);

  const std::vector<Index>& order() const
  {
    return order_;
  }
  std::size_t numInside() const
  {
    return num_inside_;
  }
  double cellSize() const
  {
    return cell_;
  }
  /// Cells a query must visit each way to find every point closer than `radius` (m).
  int reachFor(Real radius) const
  {
    return int(std::ceil(double(radius) / cell_ - 1e-9));
  }

  /// The lower corner (m) of cell `cell` (a linear index as cellOf gives it).
  Vec3d cellMin(Index cell) const
  {
    const std::size_t c = cell, nx = std::size_t(dims_[0]), ny = std::size_t(dims_[1]);
    return origin_ + cell_ * Vec3d(double(c % nx), double(c / nx % ny), double(c / (nx * ny)));
  }

  /// Cells along each axis (x, y, z); cells are ordered x fastest, then y, then z.
  int dim(int axis) const
  {
    return dims_[axis];
  }

  /// The sorted points of cells x0..x1 (inclusive) of the row (y, z), as [first, second): one
  /// contiguous range, since cells are ordered x fastest. Only after build().
  std::pair<Index, Index> rowRange(int x0, int x1, int y, int z) const
  {
    const std::size_t row = std::size_t(dims_[0]) * (std::size_t(y) + std::size_t(dims_[1]) * z);
    return {cell_start_[row + x0], cell_start_[row + x1 + 1]};
  }

  /// Calls f(begin, end) for each contiguous range (in sorted order) of points in the cells within
  /// `reach` cells of p's cell. Nothing when p is outside the grid or the grid was never built.
  template <class F>
  void forEachRange(const Vec3& p, int reach, F&& f) const
  {
    if (cell_start_.empty()) return;
    const double fx = (double(p.x()) - origin_.x()) * inv_cell_;
    const double fy = (double(p.y()) - origin_.y()) * inv_cell_;
    const double fz = (double(p.z()) - origin_.z()) * inv_cell_;
    if (!(fx >= 0 && fy >= 0 && fz >= 0)) return;
    const int ix = int(fx), iy = int(fy), iz = int(fz);
    if (ix >= dims_[0] || iy >= dims_[1] || iz >= dims_[2]) return;
    const int x0 = std::max(ix - reach, 0), x1 = std::min(ix + reach, dims_[0] - 1);
    const int y0 = std::max(iy - reach, 0), y1 = std::min(iy + reach, dims_[1] - 1);
    const int z0 = std::max(iz - reach, 0), z1 = std::min(iz + reach, dims_[2] - 1);
    for (int z = z0; z <= z1; ++z)
      for (int y = y0; y <= y1; ++y)
      {
        const auto [begin, end] = rowRange(x0, x1, y, z);
        if (begin < end) f(begin, end);
      }
  }

private:
  Vec3d origin_;
  double cell_, inv_cell_;
  int dims_[3];
  std::vector<Index> cell_start_;  // size cells + 1 once built, empty before
  std::vector<Index> cell_of_point_;
  std::vector<Index> order_;
  std::size_t num_inside_ = 0;
};

/// Compressed rows of neighbours: row i holds index[offset[i] .. offset[i+1]) and, per pair, up to
/// two kernel values computed from the squared distance by the functions the builder was given:
/// `grad_factor`, (dW/dr)/r (1/m^5) so that grad W(x_i - x_j) = grad_factor * (x_i - x_j), and
/// `weight`, W(r) (1/m^3). Either is empty when the builder was not asked for it.
struct NeighborLists
{
  std::vector<Index> offset;  // size rows + 1
  std::vector<Index> index;
  std::vector<Real> grad_factor;  // 1/m^5, empty unless built with a PairGradFactor
  std::vector<Real> weight;       // 1/m^3, empty unless built with a PairWeight
  std::vector<Real> weight_sum;   // per row: the sum of its pairs' weights (1/m^3), empty unless built with a RowSum
  // Per-block staging reused from step to step (kept here so that rebuilding allocates nothing).
  std::vector<std::vector<Index>> scratch_index;
  std::vector<std::vector<Real>> scratch_factor;
  std::vector<std::vector<Real>> scratch_weight;
  std::vector<std::size_t> scratch_used;       // entries in use per block
  std::vector<std::vector<Real>> scratch_soa;  // per point set without its own: x, y, z arrays

  std::size_t rows() const
  {
    return offset.empty() ? 0 : offset.size() - 1;
  }
  std::size_t pairs() const
  {
    return index.size();
  }
};

/// r^2 (m^2) of a pair from its coordinate differences (m), in the order of operations the
/// search's distance test uses: a pass that recomputes a kernel value from positions (the fluid
/// pairs' W, which the lists do not store) then gets the value the search would have stored.
inline Real pairSquaredDistance(Real dx, Real dy, Real dz)
{
#if defined(__FMA__)
  return std::fma(dz, dz, std::fma(dy, dy, dx * dx));  // as the AVX-512 path's two fused multiply-adds
#else
  return dx * dx + dy * dy + dz * dz;
#endif
}

/// Stands for "no such value per pair" in buildNeighborLists (the list's array stays empty).
struct NoPairValue
{
};

/// Asks buildNeighborLists for the sum of a value per pair over each row (out.weight_sum, in row
/// order) instead of the values themselves (out.weight stays empty): `f(r2) -> Real` from the
/// squared distance (m^2). The fluid-fluid W is read per pair by XSPH only, and summed per row by
/// the density (Eq. A1): storing it cost 4 B per pair (docs/performance.md).
template <class F>
struct RowSum
{
  F f;
};
template <class F>
RowSum<std::decay_t<F>> rowSum(F&& f)
{
  return RowSum<std::decay_t<F>>{std::forward<F>(f)};
}
template <class T>
struct IsRowSum : std::false_type
{
};
template <class F>
struct IsRowSum<RowSum<F>> : std::true_type
{
};

/// A set of points sorted by the cells of `grid`, as buildNeighborLists reads it: the positions in
/// grid order (`sorted`, m, `count` of them), optionally the same as x, y, z arrays (`soa`, 3 x
/// count, read by the AVX-512 path; nullptr = made from `sorted` by the search), and each sorted
/// point's index in the caller's numbering (`ids`, nullptr = identity).
struct GridPoints
{
  const UniformGrid* grid = nullptr;
  const Vec3* sorted = nullptr;
  const Real* soa = nullptr;
  const Index* ids = nullptr;
  std::size_t count = 0;
};

/// Whether buildNeighborLists reads a point set through its x, y, z arrays (`GridPoints::soa`, the
/// AVX-512 path for float) or through its sorted positions: a set that is kept from step to step
/// stores only the form the search reads (12 B per point).
#if defined(__AVX512F__)
inline constexpr bool kSearchReadsCoordinateArrays = std::is_same_v<Real, float>;
#else
inline constexpr bool kSearchReadsCoordinateArrays = false;
#endif

/// Fills `soa` (resized to 3 x points.size()) with the points' x, then y, then z coordinates (m).
void toCoordinateArrays(const std::vector<Vec3>& points, std::vector<Real>& soa);

/// Builds `out` for the `queries` against every point set in `sources` (a row lists the hits of
/// the first set, then of the second, ...), as the single-set form below. Sets whose points do not
/// move keep their grid and arrays from step to step: only the queries are searched again.
template <class PairGradFactor, class PairWeight>
void buildNeighborLists(const std::vector<Vec3>& queries, const std::vector<GridPoints>& sources, Real radius,
                        bool skip_self, PairGradFactor&& pairGradFactor, PairWeight&& pairWeight, NeighborLists& out);

/// Builds `out` for the `queries` against the points in `grid` (whose sorted positions are
/// `sorted_points`, i.e. points in grid order; `ids` maps a sorted position to the stored index, or
/// is empty for identity), all pairs closer than `radius` (m). `pairGradFactor(r2) -> Real` gives
/// out.grad_factor and `pairWeight(r2) -> Real` out.weight from the squared distance (m^2); either
/// may be NoPairValue{}, and pairWeight may be a RowSum (out.weight_sum). Computing them while r^2
/// is at hand spares later passes a square root and a position gather per pair. With `skip_self`,
/// query i never lists point i (queries and points are the same set, identity ids). Parallel over queries; the result
/// does not depend on the thread count.
template <class PairGradFactor, class PairWeight>
void buildNeighborLists(const std::vector<Vec3>& queries, const UniformGrid& grid,
                        const std::vector<Vec3>& sorted_points, const std::vector<Index>& ids, Real radius,
                        bool skip_self, PairGradFactor&& pairGradFactor, PairWeight&& pairWeight, NeighborLists& out);

}  // namespace fluid_sim

#include "fluid_sim/core/neighbor_search_impl.h"
