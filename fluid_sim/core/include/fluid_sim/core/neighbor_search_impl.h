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
  auto& block_used = out.scratch_used;
  block_used.resize(std::max(block_used.size(), blocks));
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, blocks, 1), [&](const tbb::blocked_range<std::size_t>& rb) {
    for (std::size_t b = rb.begin(); b != rb.end(); ++b)
    {
      auto& bi = block_index[b];
      auto& bf = block_factor[b];
      std::size_t used = 0;
      const std::size_t i_end = std::min(n, (b + 1) * kBlock);
      for (std::size_t i = b * kBlock; i < i_end; ++i)
      {
        const Vec3 xi = queries[i];
        const std::size_t row_start = used;
        grid.forEachRange(xi, reach, [&](Index begin, Index end) {
          const std::size_t len = end - begin;
          if (bi.size() < used + len)
          {
            bi.resize(std::max(2 * bi.size(), used + len + 256));
            bf.resize(bi.size());
          }
          Index* out_j = bi.data();
          Real* out_d2 = bf.data();
          // Branch-free compaction: every candidate is written, only hits advance the cursor.
          // Once the particles are disordered the hit test is a coin toss for the branch
          // predictor; with a branch the search took 3x longer late in a dam break than on the
          // initial lattice at the same candidate count.
          for (Index k = begin; k < end; ++k)
          {
            const Real d2 = (xi - sorted_points[k]).squaredNorm();
            const Index j = ids.empty() ? k : ids[k];
            out_j[used] = j;
            out_d2[used] = d2;
            used += std::size_t((d2 < r2max) & !(skip_self & (j == Index(i))));
          }
        });
        // Factors for the hits only (r^2 is overwritten by the factor in place).
        for (std::size_t k = row_start; k < used; ++k) bf[k] = pairFactor(bf[k]);
        out.offset[i + 1] = Index(used - row_start);
      }
      block_used[b] = used;
    }
  });
  for (std::size_t i = 0; i < n; ++i) out.offset[i + 1] += out.offset[i];
  out.index.resize(out.offset[n]);
  out.factor.resize(out.offset[n]);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, blocks, 1), [&](const tbb::blocked_range<std::size_t>& rb) {
    for (std::size_t b = rb.begin(); b != rb.end(); ++b)
    {
      const std::size_t start = out.offset[b * kBlock];
      std::copy_n(block_index[b].begin(), block_used[b], out.index.begin() + start);
      std::copy_n(block_factor[b].begin(), block_used[b], out.factor.begin() + start);
    }
  });
}

}  // namespace fluid_sim
