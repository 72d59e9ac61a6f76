#pragma once
// Template implementation of buildNeighborLists (included from neighbor_search.h).

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <vector>

namespace fluid_sim
{
template <class PairFactor>
void buildNeighborLists(const std::vector<Vec3>& queries, const UniformGrid& grid,
                        const std::vector<Vec3>& sorted_points, const std::vector<Index>& ids, Real radius,
                        bool skip_self, PairFactor&& pairFactor, NeighborLists& out)
{
  const std::size_t n = queries.size();
  constexpr std::size_t kBlock = 512;
  const std::size_t blocks = (n + kBlock - 1) / kBlock;
  out.offset.assign(n + 1, 0);
  const Real r2max = radius * radius;
  const int reach = int(std::ceil(double(radius) / grid.cellSize() - 1e-9));
  // One pass over candidates per block into block-local lists, then one copy into the CSR rows:
  // a single distance test per candidate instead of a count pass plus a fill pass.
  auto& block_index = out.scratch_index;
  auto& block_factor = out.scratch_factor;
  if (block_index.size() < blocks)
  {
    block_index.resize(blocks);
    block_factor.resize(blocks);
  }
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, blocks, 1), [&](const tbb::blocked_range<std::size_t>& rb) {
    for (std::size_t b = rb.begin(); b != rb.end(); ++b)
    {
      auto& bi = block_index[b];
      auto& bf = block_factor[b];
      bi.clear();
      bf.clear();
      const std::size_t i_end = std::min(n, (b + 1) * kBlock);
      for (std::size_t i = b * kBlock; i < i_end; ++i)
      {
        const Vec3 xi = queries[i];
        Index count = 0;
        grid.forEachRange(xi, reach, [&](Index begin, Index end) {
          for (Index k = begin; k < end; ++k)
          {
            const Vec3 d = xi - sorted_points[k];
            const Real d2 = d.squaredNorm();
            if (d2 >= r2max) continue;
            const Index j = ids.empty() ? k : ids[k];
            if (skip_self && j == i) continue;
            bi.push_back(j);
            bf.push_back(pairFactor(d, d2));
            ++count;
          }
        });
        out.offset[i + 1] = count;
      }
    }
  });
  for (std::size_t i = 0; i < n; ++i) out.offset[i + 1] += out.offset[i];
  out.index.resize(out.offset[n]);
  out.factor.resize(out.offset[n]);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, blocks, 1), [&](const tbb::blocked_range<std::size_t>& rb) {
    for (std::size_t b = rb.begin(); b != rb.end(); ++b)
    {
      const std::size_t start = out.offset[b * kBlock];
      std::copy(block_index[b].begin(), block_index[b].end(), out.index.begin() + start);
      std::copy(block_factor[b].begin(), block_factor[b].end(), out.factor.begin() + start);
    }
  });
}

}  // namespace fluid_sim
