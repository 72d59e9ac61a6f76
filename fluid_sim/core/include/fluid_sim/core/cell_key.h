#pragma once
// Integer cell coordinates of a point in a cubic hash grid, and their hash: the sparse grids that
// sampling (boundary_sampling) and mesh welding (io's mesh loader) keep in unordered maps.

#include <cmath>
#include <cstddef>
#include <cstdint>

#include "fluid_sim/core/types.h"

namespace fluid_sim
{
struct CellKey
{
  long long x, y, z;  // cell index along each axis: floor(coordinate / cell size)
  bool operator==(const CellKey& o) const
  {
    return x == o.x && y == o.y && z == o.z;
  }
};

/// Spatial hash of Teschner et al. (2003): large primes, combined with xor. Multiplied as unsigned
/// 64-bit numbers: a key far from the origin wraps around (defined) instead of overflowing a signed
/// product (undefined); keys whose products fit give the same hash either way.
struct CellKeyHash
{
  std::size_t operator()(const CellKey& k) const
  {
    return std::size_t(std::uint64_t(k.x) * 73856093ULL ^ std::uint64_t(k.y) * 19349663ULL ^
                       std::uint64_t(k.z) * 83492791ULL);
  }
};

/// Largest cell index cellKeyOf() returns (2^62): beyond it a double does not convert to a long
/// long, and key +- 1 (the neighbouring cells) must not overflow either.
constexpr double kMaxCellIndex = 4611686018427387904.0;

/// floor(coordinate / cell), saturated at +-kMaxCellIndex (NaN at -kMaxCellIndex): every point gets
/// a cell, a point too far out for an index shares the outermost cell with the others as far out.
inline long long cellIndexOf(double coordinate, double cell)
{
  const double index = std::floor(coordinate / cell);
  if (!(index > -kMaxCellIndex)) return -static_cast<long long>(kMaxCellIndex);
  if (!(index < kMaxCellIndex)) return static_cast<long long>(kMaxCellIndex);
  return static_cast<long long>(index);
}

/// The cell of point p (m) in a grid of cubic cells of side `cell` (m).
inline CellKey cellKeyOf(const Vec3d& p, double cell)
{
  return {cellIndexOf(p.x(), cell), cellIndexOf(p.y(), cell), cellIndexOf(p.z(), cell)};
}

}  // namespace fluid_sim
