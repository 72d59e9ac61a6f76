// Cell keys of the sparse hash grids (cell_key.h) for points far from the origin.
#include "fluid_sim/core/cell_key.h"

#include <gtest/gtest.h>

#include <limits>
#include <vector>

using namespace fluid_sim;

namespace
{
// Runtime values, so that the compiler cannot fold the conversions.
std::vector<double> farCoordinates()
{
  return {1e30, 1e19, std::numeric_limits<double>::max(), std::numeric_limits<double>::infinity()};
}
}  // namespace

TEST(CellKey, NearPointsKeepTheirFloor)
{
  const CellKey k = cellKeyOf(Vec3d(2.5, -0.5, -3.0), 1.0);
  EXPECT_EQ(k.x, 2);
  EXPECT_EQ(k.y, -1);
  EXPECT_EQ(k.z, -3);
}

TEST(CellKey, FarPointsSaturateOnTheirSide)
{
  // Beyond what a long long holds (the mesh loader's welding grid has cells of 1e-7 of the mesh's
  // size: a mesh 1 m across at 1e6 m has keys near 1e13, at 1e12 m beyond 2^63).
  for (double c : farCoordinates())
  {
    const CellKey k = cellKeyOf(Vec3d(c, -c, 0.0), 1e-7);
    EXPECT_EQ(k.x, static_cast<long long>(kMaxCellIndex)) << c;
    EXPECT_EQ(k.y, -static_cast<long long>(kMaxCellIndex)) << c;
    EXPECT_EQ(k.z, 0) << c;
    // Neighbouring cells (key +- 1) stay representable.
    EXPECT_LT(k.x, std::numeric_limits<long long>::max());
    EXPECT_GT(k.y, std::numeric_limits<long long>::min());
  }
  const CellKey nan = cellKeyOf(Vec3d::Constant(std::numeric_limits<double>::quiet_NaN()), 1.0);
  EXPECT_EQ(nan.x, -static_cast<long long>(kMaxCellIndex));
}

TEST(CellKey, HashOfNearKeysIsTheSignedFormula)
{
  // The hash is computed in unsigned (wrapping) arithmetic so that far keys do not overflow; where
  // the signed products fit it must give the same value (the grids' iteration order, and with it
  // the results, are unchanged).
  for (const CellKey k : {CellKey{-3, 5, 7}, CellKey{123456, -98765, 4321}, CellKey{-1, -1, -1}})
    EXPECT_EQ(CellKeyHash()(k), std::size_t(k.x * 73856093LL ^ k.y * 19349663LL ^ k.z * 83492791LL));
}
