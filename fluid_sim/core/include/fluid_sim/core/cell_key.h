#pragma once
// Integer cell coordinates of a point in a cubic hash grid, and their hash: the sparse grids that
// sampling (boundary_sampling) and mesh welding (io's mesh loader) keep in unordered maps.

#include <cmath>
#include <cstddef>

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

/// Spatial hash of Teschner et al. (2003): large primes, combined with xor.
struct CellKeyHash
{
  std::size_t operator()(const CellKey& k) const
  {
    return std::size_t(k.x * 73856093LL ^ k.y * 19349663LL ^ k.z * 83492791LL);
  }
};

/// The cell of point p (m) in a grid of cubic cells of side `cell` (m).
inline CellKey cellKeyOf(const Vec3d& p, double cell)
{
  return {(long long)std::floor(p.x() / cell), (long long)std::floor(p.y() / cell),
          (long long)std::floor(p.z() / cell)};
}

}  // namespace fluid_sim
