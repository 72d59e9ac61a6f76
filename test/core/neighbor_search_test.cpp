#include "fluid_sim/core/neighbor_search.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <random>

using namespace fluid_sim;

namespace
{
std::vector<Vec3> randomPoints(std::size_t n, unsigned seed)
{
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-0.5, 0.3);  // negative coordinates on purpose
  std::vector<Vec3> pts;
  for (std::size_t i = 0; i < n; ++i) pts.push_back(Vec3(Real(u(rng)), Real(u(rng)), Real(u(rng))));
  for (std::size_t i = 0; i < n / 20; ++i) pts.push_back(pts[i * 7 % n]);  // exact duplicates
  return pts;
}

std::vector<std::vector<Index>> bruteForce(const std::vector<Vec3>& q, const std::vector<Vec3>& pts, Real r,
                                           bool skip_self)
{
  std::vector<std::vector<Index>> out(q.size());
  for (std::size_t i = 0; i < q.size(); ++i)
    for (std::size_t j = 0; j < pts.size(); ++j)
      if ((q[i] - pts[j]).squaredNorm() < r * r && !(skip_self && i == j)) out[i].push_back(Index(j));
  return out;
}

/// The points inside `grid` in its sorted order (grid.build(pts) done).
std::vector<Vec3> inGridOrder(const UniformGrid& grid, const std::vector<Vec3>& pts)
{
  std::vector<Vec3> sorted(grid.numInside());
  for (std::size_t k = 0; k < sorted.size(); ++k) sorted[k] = pts[grid.order()[k]];
  return sorted;
}

std::vector<std::vector<Index>> rowsOf(const NeighborLists& lists)
{
  std::vector<std::vector<Index>> out(lists.rows());
  for (std::size_t i = 0; i < lists.rows(); ++i)
  {
    out[i].assign(lists.index.begin() + lists.offset[i], lists.index.begin() + lists.offset[i + 1]);
    std::sort(out[i].begin(), out[i].end());
  }
  return out;
}
}  // namespace

TEST(NeighborSearch, SelfQueryEqualsBruteForceAfterSorting)
{
  std::vector<Vec3> pts = randomPoints(3000, 1);
  const Real r = Real(0.06);
  UniformGrid grid(Vec3d(-0.5, -0.5, -0.5), Vec3d(0.3, 0.3, 0.3), r, 1);
  grid.build(pts);
  // Re-sort the points into grid order (as the simulation does) and rebuild.
  std::vector<Vec3> sorted(pts.size());
  for (std::size_t k = 0; k < pts.size(); ++k) sorted[k] = pts[grid.order()[k]];
  grid.build(sorted);
  for (std::size_t k = 0; k < sorted.size(); ++k)
    ASSERT_EQ(grid.order()[k], k) << "sorting a sorted set must be the identity";
  NeighborLists lists;
  buildNeighborLists(
      sorted, grid, sorted, {}, r, true, [](Real d2) { return d2; }, NoPairValue{}, lists);
  EXPECT_EQ(rowsOf(lists), bruteForce(sorted, sorted, r, true));
  // Factors are the ones the callback produced for that pair.
  for (std::size_t i = 0; i < lists.rows(); ++i)
    for (Index k = lists.offset[i]; k < lists.offset[i + 1]; ++k)
      EXPECT_FLOAT_EQ(lists.grad_factor[k], (sorted[i] - sorted[lists.index[k]]).squaredNorm());
}

TEST(NeighborSearch, SecondValuePerPairComesFromItsOwnFunction)
{
  // The simulation stores W(r) beside grad W(r)/r; both must belong to the same pair, also after
  // a rebuild with fewer pairs (the staging buffers are reused) and across block boundaries.
  const std::vector<Vec3> pts = randomPoints(3000, 4);
  const Real r = Real(0.06);
  UniformGrid grid(Vec3d(-0.5, -0.5, -0.5), Vec3d(0.3, 0.3, 0.3), r, 1);
  grid.build(pts);
  const std::vector<Vec3> sorted = inGridOrder(grid, pts);
  NeighborLists lists;
  // First without a second function, so that the staging already exists when weights start.
  buildNeighborLists(
      sorted, grid, sorted, {}, r, true, [](Real d2) { return d2; }, NoPairValue{}, lists);
  EXPECT_TRUE(lists.weight.empty());
  for (Real radius : {r, Real(0.7) * r})
  {
    buildNeighborLists(
        sorted, grid, sorted, {}, radius, true, [](Real d2) { return d2; }, [](Real d2) { return Real(2) * d2 + 1; },
        lists);
    EXPECT_EQ(rowsOf(lists), bruteForce(sorted, sorted, radius, true));
    ASSERT_EQ(lists.weight.size(), lists.pairs());
    for (std::size_t i = 0; i < lists.rows(); ++i)
      for (Index k = lists.offset[i]; k < lists.offset[i + 1]; ++k)
      {
        const Real d2 = (sorted[i] - sorted[lists.index[k]]).squaredNorm();
        EXPECT_FLOAT_EQ(lists.grad_factor[k], d2);
        EXPECT_FLOAT_EQ(lists.weight[k], Real(2) * d2 + 1);
      }
  }
  // Built again without a second function, the lists carry none.
  buildNeighborLists(
      sorted, grid, sorted, {}, r, true, [](Real d2) { return d2; }, NoPairValue{}, lists);
  EXPECT_TRUE(lists.weight.empty());
  // Weights alone (the boundary-fluid lists of the pressure extrapolation): no factors.
  buildNeighborLists(
      sorted, grid, sorted, {}, r, true, NoPairValue{}, [](Real d2) { return Real(3) * d2; }, lists);
  EXPECT_EQ(rowsOf(lists), bruteForce(sorted, sorted, r, true));
  EXPECT_TRUE(lists.grad_factor.empty());
  ASSERT_EQ(lists.weight.size(), lists.pairs());
  for (std::size_t i = 0; i < lists.rows(); ++i)
    for (Index k = lists.offset[i]; k < lists.offset[i + 1]; ++k)
      EXPECT_FLOAT_EQ(lists.weight[k], Real(3) * (sorted[i] - sorted[lists.index[k]]).squaredNorm());
}

TEST(NeighborSearch, CrossQueryWithIdsAndLargerRadiusEqualsBruteForce)
{
  const std::vector<Vec3> pts = randomPoints(2000, 2);
  const std::vector<Vec3> queries = randomPoints(500, 3);
  const Real cell = Real(0.04);
  UniformGrid grid(Vec3d(-0.5, -0.5, -0.5), Vec3d(0.3, 0.3, 0.3), cell, 1);
  grid.build(pts);
  const std::vector<Vec3> sorted = inGridOrder(grid, pts);
  for (Real r : {Real(0.04), Real(0.06), Real(0.03)})  // 1.5 cells needs a reach of 2
  {
    NeighborLists lists;
    buildNeighborLists(
        queries, grid, sorted, grid.order(), r, false, [](Real) { return Real(1); }, NoPairValue{}, lists);
    EXPECT_EQ(rowsOf(lists), bruteForce(queries, pts, r, false)) << "radius " << r;
  }
}

TEST(NeighborSearch, RowsOverTheSortedPointsListThemInAscendingOrder)
{
  // The extrapolations look a fluid particle up in a boundary particle's fit row by bisection
  // (ExtrapolatedBoundaryPressure::feedbackVector): a row over points in grid order, indexed by
  // their position there, must list them in ascending order, for queries in any order (the
  // boundary queries) and in cell order (the runs shared by a cell's queries), at a reach of one
  // cell and of two.
  const std::vector<Vec3> pts = randomPoints(3000, 6);
  const Real cell = Real(0.05);
  UniformGrid grid(Vec3d(-0.5, -0.5, -0.5), Vec3d(0.3, 0.3, 0.3), cell, 1);
  grid.build(pts);
  const std::vector<Vec3> sorted = inGridOrder(grid, pts);
  grid.build(sorted);
  const std::vector<Vec3> scattered = randomPoints(700, 7);
  for (const std::vector<Vec3>* queries : {&scattered, &sorted})
    for (Real r : {cell, Real(1.5) * cell})
    {
      NeighborLists lists;
      buildNeighborLists(
          *queries, grid, sorted, {}, r, false, NoPairValue{}, [](Real d2) { return d2; }, lists);
      std::size_t pairs = 0;
      for (std::size_t i = 0; i < lists.rows(); ++i)
      {
        const auto first = lists.index.begin() + lists.offset[i], last = lists.index.begin() + lists.offset[i + 1];
        EXPECT_TRUE(std::adjacent_find(first, last, std::greater_equal<Index>()) == last)
            << "row " << i << " of " << lists.rows() << ", radius " << r;
        pairs += std::size_t(last - first);
      }
      EXPECT_GT(pairs, 2 * lists.rows()) << "the rows must hold enough pairs to show an order";
    }
}

TEST(NeighborSearch, RowsStayRightOverSeveralWavesAndAChangingQueryCount)
{
  // The search stages one wave of blocks at a time (64 blocks of 512 queries) and reuses its
  // staging and rows from build to build: with 70,000 queries the rows span three waves, and
  // rebuilding with fewer, then more queries must leave no row of an earlier build behind (the
  // fit lists' query count changes every step).
  const std::vector<Vec3> pts = randomPoints(2000, 7);
  const Real r = Real(0.06);
  UniformGrid grid(Vec3d(-0.5, -0.5, -0.5), Vec3d(0.3, 0.3, 0.3), r, 1);
  grid.build(pts);
  const std::vector<Vec3> sorted = inGridOrder(grid, pts);
  NeighborLists lists;
  for (std::size_t count : {70000u, 9000u, 68000u})
  {
    const std::vector<Vec3> queries = randomPoints(count, unsigned(count));
    buildNeighborLists(
        queries, grid, sorted, grid.order(), r, false, [](Real d2) { return d2; }, [](Real d2) { return Real(2) * d2; },
        lists);
    ASSERT_EQ(lists.rows(), queries.size());
    ASSERT_EQ(lists.offset.back(), lists.pairs());
    ASSERT_EQ(lists.grad_factor.size(), lists.pairs());
    ASSERT_EQ(lists.weight.size(), lists.pairs());
    EXPECT_EQ(rowsOf(lists), bruteForce(queries, pts, r, false)) << count << " queries";
    for (std::size_t i = 0; i < lists.rows(); ++i)
      for (Index k = lists.offset[i]; k < lists.offset[i + 1]; ++k)
      {
        const Real d2 = (queries[i] - pts[lists.index[k]]).squaredNorm();
        ASSERT_FLOAT_EQ(lists.grad_factor[k], d2) << "row " << i;
        ASSERT_FLOAT_EQ(lists.weight[k], Real(2) * d2) << "row " << i;
      }
  }
}

TEST(NeighborSearch, PointsOutsideTheGridAreIgnoredNotCrashing)
{
  std::vector<Vec3> pts = {Vec3(0, 0, 0), Vec3(Real(0.01), 0, 0), Vec3(5, 5, 5), Vec3(NAN, 0, 0)};
  UniformGrid grid(Vec3d(-0.1, -0.1, -0.1), Vec3d(0.1, 0.1, 0.1), 0.04, 1);
  grid.build(pts);
  EXPECT_EQ(grid.numInside(), 2u);
  EXPECT_EQ(grid.cellOf(pts[2]), UniformGrid::kOutside);
  EXPECT_EQ(grid.cellOf(pts[3]), UniformGrid::kOutside);
}

TEST(NeighborSearch, SeveralPointSetsEqualOneSearchOverTheirUnion)
{
  // The boundary is searched as two sets (bodies that never move, sorted once, and moving ones,
  // sorted again when they move), each with its own grid and ids into the common numbering: a
  // row must list exactly the union's neighbours, the first set's before the second's.
  const std::vector<Vec3> all = randomPoints(2500, 5);
  const std::vector<Vec3> queries = randomPoints(600, 6);
  const Real r = Real(0.05);
  struct Set
  {
    std::vector<Index> members;
    std::vector<Vec3> gathered, sorted;
    std::vector<Real> soa;
    std::vector<Index> ids;
    UniformGrid grid{Vec3d(-0.5, -0.5, -0.5), Vec3d(0.3, 0.3, 0.3), 0.05, 1};
  };
  Set sets[2];
  for (std::size_t j = 0; j < all.size(); ++j) sets[j % 3 == 0 ? 1 : 0].members.push_back(Index(j));
  std::vector<GridPoints> sources;
  for (Set& s : sets)
  {
    for (Index j : s.members) s.gathered.push_back(all[j]);
    s.grid.build(s.gathered);
    for (std::size_t k = 0; k < s.grid.numInside(); ++k)
    {
      s.sorted.push_back(s.gathered[s.grid.order()[k]]);
      s.ids.push_back(s.members[s.grid.order()[k]]);
    }
    toCoordinateArrays(s.sorted, s.soa);
    GridPoints p;
    p.grid = &s.grid;
    p.sorted = s.sorted.data();
    p.ids = s.ids.data();
    p.count = s.sorted.size();
    sources.push_back(p);
  }
  NeighborLists lists;
  for (bool with_soa : {false, true})  // arrays made by the search, or brought by the set
  {
    for (std::size_t k = 0; k < 2; ++k) sources[k].soa = with_soa ? sets[k].soa.data() : nullptr;
    buildNeighborLists(
        queries, sources, r, false, [](Real d2) { return d2; }, NoPairValue{}, lists);
    EXPECT_EQ(rowsOf(lists), bruteForce(queries, all, r, false));
    for (std::size_t i = 0; i < lists.rows(); ++i)
    {
      bool second = false;  // once the second set's entries begin, no first-set entry follows
      for (Index k = lists.offset[i]; k < lists.offset[i + 1]; ++k)
      {
        const bool in_second = lists.index[k] % 3 == 0;
        EXPECT_FALSE(second && !in_second) << "row " << i;
        second = second || in_second;
        EXPECT_FLOAT_EQ(lists.grad_factor[k], (queries[i] - all[lists.index[k]]).squaredNorm());
      }
    }
  }
}

TEST(NeighborSearch, QueriesInCellOrderGetTheListsOfOneQueryAtATime)
{
  // Consecutive queries in one cell share their candidates (gathered once for the cell, with
  // AVX-512); a query searched alone reads the rows in place. Both must give the same rows, in
  // the same order, with the same values bit for bit: for a self search (skip_self, no ids) and
  // for two point sets with ids, with queries in cell order (runs of a cell, duplicates) and a
  // few outside the grid.
  const std::vector<Vec3> pts = randomPoints(3000, 11);
  const Real r = Real(0.06);
  UniformGrid grid(Vec3d(-0.5, -0.5, -0.5), Vec3d(0.3, 0.3, 0.3), r, 1);
  grid.build(pts);
  const std::vector<Vec3> sorted = inGridOrder(grid, pts);
  auto factor = [](Real d2) { return Real(1) / (d2 + Real(1e-3)); };
  auto weight = [](Real d2) { return d2 * d2; };
  auto expectSameRow = [](const NeighborLists& all, std::size_t i, const NeighborLists& one) {
    const std::size_t count = all.offset[i + 1] - all.offset[i];
    ASSERT_EQ(count, one.pairs()) << "row " << i;
    for (std::size_t k = 0; k < count; ++k)
    {
      ASSERT_EQ(all.index[all.offset[i] + k], one.index[k]) << "row " << i;
      ASSERT_EQ(all.grad_factor[all.offset[i] + k], one.grad_factor[k]) << "row " << i;  // bit for bit
      if (!one.weight.empty()) ASSERT_EQ(all.weight[all.offset[i] + k], one.weight[k]) << "row " << i;
    }
  };
  {
    // The fluid's self search: the sorted points are the queries (runs of about 2 per cell here).
    NeighborLists lists, single;
    buildNeighborLists(sorted, grid, sorted, {}, r, true, factor, NoPairValue{}, lists);
    EXPECT_EQ(rowsOf(lists), bruteForce(sorted, sorted, r, true));
    for (std::size_t i = 0; i < sorted.size(); i += 7)
    {
      // Alone, the query cannot skip itself by index (its index is 0 in a one-query build), so
      // its own position (distance 0) is the one extra entry, dropped here.
      buildNeighborLists(std::vector<Vec3>{sorted[i]}, grid, sorted, {}, r, false, factor, NoPairValue{}, single);
      NeighborLists without_self = single;
      without_self.index.clear();
      without_self.grad_factor.clear();
      for (std::size_t k = 0; k < single.pairs(); ++k)
        if (single.index[k] != Index(i))
        {
          without_self.index.push_back(single.index[k]);
          without_self.grad_factor.push_back(single.grad_factor[k]);
        }
      expectSameRow(lists, i, without_self);
    }
  }
  {
    // Two sets with ids (the walls as static and moving bodies), queries in cell order with
    // duplicates and a few outside the grid.
    std::vector<Vec3> queries;
    for (std::size_t k = 0; k < sorted.size(); k += 3)
    {
      queries.push_back(sorted[k]);
      if (k % 9 == 0) queries.push_back(sorted[k]);  // the same position twice in a row
      if (k % 300 == 0) queries.push_back(Vec3(5, 5, 5));
    }
    std::vector<Index> first, second;
    for (std::size_t k = 0; k < sorted.size(); ++k) (k % 4 == 0 ? second : first).push_back(Index(k));
    std::vector<Vec3> gathered[2];
    std::vector<Vec3> in_order[2];
    std::vector<Index> ids[2];
    UniformGrid grids[2] = {grid, grid};
    std::vector<GridPoints> sources;
    for (int s = 0; s < 2; ++s)
    {
      const std::vector<Index>& members = s == 0 ? first : second;
      for (Index j : members) gathered[s].push_back(sorted[j]);
      grids[s].build(gathered[s]);
      for (std::size_t k = 0; k < grids[s].numInside(); ++k)
      {
        in_order[s].push_back(gathered[s][grids[s].order()[k]]);
        ids[s].push_back(members[grids[s].order()[k]]);
      }
    }
    for (int s = 0; s < 2; ++s)
    {
      GridPoints p;
      p.grid = &grids[s];
      p.sorted = in_order[s].data();
      p.ids = ids[s].data();
      p.count = in_order[s].size();
      sources.push_back(p);
    }
    NeighborLists lists, single;
    buildNeighborLists(queries, sources, r, false, factor, weight, lists);
    EXPECT_EQ(rowsOf(lists), bruteForce(queries, sorted, r, false));
    for (std::size_t i = 0; i < queries.size(); i += 5)
    {
      buildNeighborLists(std::vector<Vec3>{queries[i]}, sources, r, false, factor, weight, single);
      expectSameRow(lists, i, single);
    }
  }
}

TEST(NeighborSearch, PairSquaredDistanceGivesTheSearchsValueBitForBit)
{
  // The fluid-fluid lists store no W: the density pass and XSPH recompute it from the positions
  // with pairSquaredDistance, which must give exactly the r^2 the search saw (in the same order
  // of operations as its vector path), or densities would change with the storage choice.
  const std::vector<Vec3> pts = randomPoints(4000, 11);
  const Real r = Real(0.06);
  UniformGrid grid(Vec3d(-0.5, -0.5, -0.5), Vec3d(0.3, 0.3, 0.3), r, 1);
  grid.build(pts);
  const std::vector<Vec3> sorted = inGridOrder(grid, pts);
  GridPoints self;
  self.grid = &grid;
  self.sorted = sorted.data();
  self.count = sorted.size();
  std::vector<Real> soa;
  toCoordinateArrays(sorted, soa);
  if (kSearchReadsCoordinateArrays) self.soa = soa.data();
  NeighborLists lists;
  buildNeighborLists(
      sorted, std::vector<GridPoints>{self}, r, true, [](Real d2) { return d2; }, NoPairValue{}, lists);
  ASSERT_GT(lists.pairs(), 10000u);
  EXPECT_TRUE(lists.weight.empty());
  std::size_t differ = 0;
  for (std::size_t i = 0; i < lists.rows(); ++i)
    for (Index k = lists.offset[i]; k < lists.offset[i + 1]; ++k)
    {
      const Vec3 d = sorted[i] - sorted[lists.index[k]];
      differ += pairSquaredDistance(d.x(), d.y(), d.z()) != lists.grad_factor[k];
    }
  EXPECT_EQ(differ, 0u) << "of " << lists.pairs() << " pairs";
}

TEST(NeighborSearch, AGridNeverBuiltHoldsNoPoints)
{
  // A grid allocates its cells at its first build (a scene without moving bodies never builds
  // their grid): before that it is a valid, empty grid.
  UniformGrid grid(Vec3d(-0.5, -0.5, -0.5), Vec3d(0.3, 0.3, 0.3), 0.05, 1);
  int ranges = 0;
  grid.forEachRange(Vec3(0, 0, 0), 1, [&](Index, Index) { ++ranges; });
  EXPECT_EQ(ranges, 0);
  EXPECT_EQ(grid.numInside(), 0u);
  EXPECT_EQ(grid.cellOf(Vec3(0, 0, 0)) == UniformGrid::kOutside, false);
  grid.build({Vec3(0, 0, 0), Vec3(Real(0.01), 0, 0)});
  grid.forEachRange(Vec3(0, 0, 0), 1, [&](Index begin, Index end) { ranges += int(end - begin); });
  EXPECT_EQ(ranges, 2);
}

TEST(NeighborSearch, RowSumIsTheSumOfTheStoredValuesInRowOrder)
{
  // The density (Eq. A1) takes the fluid-fluid W summed per row by the search (RowSum) instead of
  // the stored values: the same rows, no per-pair array, and each sum equal to adding the values
  // a stored build gives, in row order, bit for bit. Three waves of blocks, rebuilt with fewer
  // queries (the staging holds 64 rows at a time).
  const std::vector<Vec3> pts = randomPoints(2000, 8);
  const Real r = Real(0.06);
  UniformGrid grid(Vec3d(-0.5, -0.5, -0.5), Vec3d(0.3, 0.3, 0.3), r, 1);
  grid.build(pts);
  const std::vector<Vec3> sorted = inGridOrder(grid, pts);
  auto w = [](Real d2) { return Real(1) / (Real(1) + d2); };
  NeighborLists stored, summed;
  for (std::size_t count : {70000u, 5000u})
  {
    const std::vector<Vec3> queries = randomPoints(count, unsigned(count + 1));
    buildNeighborLists(
        queries, grid, sorted, grid.order(), r, false, [](Real d2) { return d2; }, w, stored);
    buildNeighborLists(
        queries, grid, sorted, grid.order(), r, false, [](Real d2) { return d2; }, rowSum(w), summed);
    ASSERT_TRUE(summed.weight.empty());
    ASSERT_EQ(summed.weight_sum.size(), queries.size());
    ASSERT_EQ(summed.offset, stored.offset);
    ASSERT_EQ(summed.index, stored.index);
    std::size_t differ = 0;
    for (std::size_t i = 0; i < queries.size(); ++i)
    {
      Real sum = 0;
      for (Index k = stored.offset[i]; k < stored.offset[i + 1]; ++k) sum += stored.weight[k];
      differ += sum != summed.weight_sum[i];
    }
    EXPECT_EQ(differ, 0u) << count << " queries";
  }
}
