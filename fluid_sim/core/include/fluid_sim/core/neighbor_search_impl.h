#pragma once
// Template implementation of buildNeighborLists (included from neighbor_search.h).

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <type_traits>
#include <utility>
#include <vector>

#if defined(__AVX512F__)
#include <immintrin.h>
#endif

namespace fluid_sim
{
template <class PairGradFactor, class PairWeight>
void buildNeighborLists(const std::vector<Vec3>& queries, const UniformGrid& grid,
                        const std::vector<Vec3>& sorted_points, const std::vector<Index>& ids, Real radius,
                        bool skip_self, PairGradFactor&& pairGradFactor, PairWeight&& pairWeight, NeighborLists& out)
{
  GridPoints source;
  source.grid = &grid;
  source.sorted = sorted_points.data();
  source.ids = ids.empty() ? nullptr : ids.data();
  source.count = sorted_points.size();
  buildNeighborLists(queries, std::vector<GridPoints>{source}, radius, skip_self,
                     std::forward<PairGradFactor>(pairGradFactor), std::forward<PairWeight>(pairWeight), out);
}

/// The candidates of one grid cell's queries (the points within reach of the cell), gathered
/// into one run for the vector search: positions (m) and indices.
struct CellCandidates
{
  Index cell = UniformGrid::kOutside;  // the queries' cell, kOutside = none gathered
  std::size_t count = 0;
  std::size_t next_query = ~std::size_t(0);  // the query whose cell was looked up ahead ...
  Index next_cell = UniformGrid::kOutside;   // ... and that cell
  std::vector<Real> x, y, z;
  std::vector<Index> id;
  void reserve(std::size_t size)
  {
    if (x.size() >= size) return;
    const std::size_t grown = std::max(2 * x.size(), size + 64);
    x.resize(grown);
    y.resize(grown);
    z.resize(grown);
    id.resize(grown);
  }
};

template <class PairGradFactor, class PairWeight>
void buildNeighborLists(const std::vector<Vec3>& queries, const std::vector<GridPoints>& sources, Real radius,
                        bool skip_self, PairGradFactor&& pairGradFactor, PairWeight&& pairWeight, NeighborLists& out)
{
  constexpr bool kFactor = !std::is_same_v<std::decay_t<PairGradFactor>, NoPairValue>;
  constexpr bool kRowSum = IsRowSum<std::decay_t<PairWeight>>::value;  // W summed per row, not stored
  constexpr bool kWeight = !std::is_same_v<std::decay_t<PairWeight>, NoPairValue> && !kRowSum;  // W per pair
  // W is staged per block when stored, per kValueRows rows when only summed (a few KB).
  constexpr bool kStage = kWeight || kRowSum;
  static_assert(kFactor || kWeight || kRowSum, "buildNeighborLists: ask for at least one value per pair");
  (void)pairGradFactor;
  (void)pairWeight;
  // The per-pair value function, whether its values are stored or summed per row.
  auto weightOf = [&pairWeight](Real d2) -> Real {
    if constexpr (kRowSum)
      return pairWeight.f(d2);
    else if constexpr (kWeight)
      return pairWeight(d2);
    else
      return d2;  // not called
  };
  (void)weightOf;
  const std::size_t n = queries.size();
  constexpr std::size_t kBlock = 512;
  // Blocks are searched a wave at a time into one staging slot each and copied into the rows
  // once the wave's row offsets are known: the staging holds one wave (64 blocks, about 12 MB at
  // 30 pairs per query), not every block of the step. Staging per block held as much as the
  // rows themselves plus its growth slack, and each block kept the largest list it ever held
  // (at 195 k particles, 115 MB against 70 MB of rows: 587 B per fluid particle), and the copy
  // read it back from memory instead of cache. 64, not 32: with 32 the 33 k dam break's 64 blocks
  // ran as two waves and its search took 1.07x as long on a quiet machine (0.2 ms per step);
  // with 64 it is one wave, as fast as before, and the 195 k peak is 482 instead of 461 B per
  // fluid particle (769 before the waves; docs/performance.md).
  constexpr std::size_t kWave = 64;
  constexpr std::size_t kValueRows = 64;  // rows whose pairs' values are computed in one loop
  const std::size_t blocks = (n + kBlock - 1) / kBlock;
  const std::size_t slots = std::min(blocks, kWave);
  // Every row's count is written below, so the offsets need no clearing; resize (not assign)
  // keeps their storage when n changes from step to step (the fit lists' n, the active boundary
  // particles, grew by a few in 3 of 4 steps and assign reallocated them each time).
  out.offset.resize(n + 1);
  out.offset[0] = 0;
  const Real r2max = radius * radius;
  // Cells within reach of a query's cell, per set (the sets' grids may differ).
  std::vector<int> reach(sources.size());
  for (std::size_t s = 0; s < sources.size(); ++s) reach[s] = sources[s].grid->reachFor(radius);
  // One pass over candidates per block into slot-local lists, then one copy into the CSR rows:
  // a single distance test per candidate instead of a count pass plus a fill pass. The factor
  // staging first holds r^2 (m^2) of every hit.
  auto& block_index = out.scratch_index;
  auto& block_factor = out.scratch_factor;
  auto& block_weight = out.scratch_weight;
  if (block_index.size() < slots)
  {
    block_index.resize(slots);
    block_factor.resize(slots);
  }
  if (kStage && block_weight.size() < slots) block_weight.resize(slots);
  auto& block_used = out.scratch_used;
  block_used.resize(std::max(block_used.size(), slots));
  constexpr bool kVector = kSearchReadsCoordinateArrays;
  // The vector path reads the points as x, y, z arrays (one range's distances are then a vector
  // loop): a set that does not bring its own has them made here. The scalar path reads the
  // sorted positions directly and needs no copy.
  std::vector<const Real*> soa_of(sources.size(), nullptr);
  if constexpr (kVector)
  {
    if (out.scratch_soa.size() < sources.size()) out.scratch_soa.resize(sources.size());
    for (std::size_t s = 0; s < sources.size(); ++s)
    {
      soa_of[s] = sources[s].soa;
      if (soa_of[s] == nullptr)
      {
        std::vector<Real>& soa = out.scratch_soa[s];
        const std::size_t m = sources[s].count;
        soa.resize(3 * m);
        const Vec3* const pts = sources[s].sorted;
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, m, 4096), [&](const tbb::blocked_range<std::size_t>& r) {
          for (std::size_t k = r.begin(); k != r.end(); ++k)
          {
            soa[k] = pts[k].x();
            soa[m + k] = pts[k].y();
            soa[2 * m + k] = pts[k].z();
          }
        });
        soa_of[s] = soa.data();
      }
    }
  }
  constexpr std::size_t kSlack = 16;  // the vector path stores whole vectors past the cursor
  if constexpr (!kFactor) out.grad_factor.clear();
  if constexpr (!kWeight) out.weight.clear();
  if constexpr (kRowSum)
    out.weight_sum.resize(n);
  else
    out.weight_sum.clear();
  // The rows' arrays keep their storage from build to build and are cut to this build's pairs at
  // the end. The last build's rows are dead here: when they leave less than 1/16 of room for
  // growth, the arrays are freed and then allocated with 1/4 of room, so that growing copies no
  // dead rows and never holds the old and the new arrays at once (growing by resize in the first
  // step after the fill's relaxation did both: 48 instead of 44 MB, the peak of a 33 k run).
  // Steady or slowly growing pair counts allocate nothing.
  auto makeRoom = [](auto& values, std::size_t last) {
    if (values.capacity() >= last + last / 16) return;
    std::decay_t<decltype(values)>().swap(values);
    values.reserve(last + last / 4);
  };
  const std::size_t last_pairs = out.index.size();
  makeRoom(out.index, last_pairs);
  if constexpr (kFactor) makeRoom(out.grad_factor, last_pairs);
  if constexpr (kWeight) makeRoom(out.weight, last_pairs);
  // Each array is checked on its own: a build without weights leaves `weight` empty beside a
  // full `index`.
  auto growRows = [&](std::size_t size) {
    if (out.index.size() < size) out.index.resize(size);
    if constexpr (kFactor)
      if (out.grad_factor.size() < size) out.grad_factor.resize(size);
    if constexpr (kWeight)
      if (out.weight.size() < size) out.weight.resize(size);
  };
  for (std::size_t w0 = 0; w0 < blocks; w0 += kWave)
  {
    const std::size_t w1 = std::min(blocks, w0 + kWave);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(w0, w1, 1), [&](const tbb::blocked_range<std::size_t>& rb) {
      for (std::size_t b = rb.begin(); b != rb.end(); ++b)
      {
        const std::size_t slot = b - w0;
        auto& bi = block_index[slot];
        auto& bf = block_factor[slot];
        // The weight staging follows the index staging's size (it may have been grown by an
        // earlier build without weights); below they grow together.
        if constexpr (kWeight)
          if (block_weight[slot].size() < bi.size()) block_weight[slot].resize(bi.size());
        std::size_t used = 0;
        // Room in the staging for `len` more candidates past the cursor (every candidate is
        // written; the vector path stores whole vectors, kSlack past the last).
        // A slot grows by a quarter, reserved exactly (resize alone doubles a vector's capacity):
        // the staging is kept from step to step, and doubling left up to twice a wave's pairs
        // resident (at 1 M particles 8 MB, 8 B per fluid particle, docs/performance.md).
        auto stageRoom = [&](std::size_t len) {
          if (bi.size() >= used + len + kSlack) return;
          const std::size_t size = std::max(bi.size() + bi.size() / 4, used + len + kSlack + 256);
          auto grow = [size](auto& v) {
            v.reserve(size);
            v.resize(size);
          };
          grow(bi);
          grow(bf);
          if constexpr (kWeight) grow(block_weight[slot]);
        };
        const std::size_t i_end = std::min(n, (b + 1) * kBlock);
        std::vector<CellCandidates> cell_candidates(kVector ? sources.size() : 0);
        // Values for the hits of the rows [row_from, row_to), r^2 overwritten by the factor in
        // place: one loop over kValueRows rows' pairs, not one per row (a row's ~28 pairs left
        // the vector loop's start, its masked end and its exit as most of the work: the values
        // took 34 % of the fluid-fluid search, docs/performance.md). The row sums' staging holds
        // those rows only (a few KB, from its index 0); stored weights are staged per block.
        std::size_t row_from = b * kBlock, pair_from = 0;
        auto finishRows = [&](std::size_t row_to) {
          const std::size_t w_base = kRowSum ? pair_from : 0;
          if constexpr (kRowSum)
            if (block_weight[slot].size() < used - pair_from) block_weight[slot].resize(2 * (used - pair_from));
          if constexpr (kStage && kFactor)
          {
            Real* const bw = block_weight[slot].data();
            for (std::size_t k = pair_from; k < used; ++k)
            {
              const Real d2 = bf[k];
              bw[k - w_base] = weightOf(d2);
              bf[k] = pairGradFactor(d2);
            }
          }
          else if constexpr (kStage)
          {
            Real* const bw = block_weight[slot].data();
            for (std::size_t k = pair_from; k < used; ++k) bw[k - w_base] = weightOf(bf[k]);
          }
          else
          {
            for (std::size_t k = pair_from; k < used; ++k) bf[k] = pairGradFactor(bf[k]);
          }
          if constexpr (kRowSum)  // each row in its own order, one add per pair on values still in cache
          {
            const Real* const bw = block_weight[slot].data();
            std::size_t k = 0;
            for (std::size_t i = row_from; i < row_to; ++i)
            {
              Real sum = 0;
              for (const std::size_t row_end = k + out.offset[i + 1]; k < row_end; ++k) sum += bw[k];
              out.weight_sum[i] = sum;
            }
          }
          row_from = row_to;
          pair_from = used;
        };
        for (std::size_t i = b * kBlock; i < i_end; ++i)
        {
          const Vec3 xi = queries[i];
          const std::size_t row_start = used;
          const Index self = skip_self ? Index(i) : ~Index(0);
#if defined(__AVX512F__)
          // Candidates [begin, end) of x, y, z arrays against query i, with their indices from
          // `ids` (nullptr: the position itself). 16 candidates at a time: distances, a hit
          // mask, and the hits compressed in registers and stored as whole vectors (the memory
          // form of vpcompress is slow on some cores); the cursor advances by the number of hits.
          auto scanVector = [&](const float* px, const float* py, const float* pz, const Index* ids, Index begin,
                                Index end) {
            if constexpr (kVector)  // float only: a double build compiles no vector code
            {
              stageRoom(end - begin);
              Index* const out_j = bi.data();
              Real* const out_d2 = bf.data();
              const __m512 qx = _mm512_set1_ps(xi.x()), qy = _mm512_set1_ps(xi.y()), qz = _mm512_set1_ps(xi.z());
              const __m512 r2v = _mm512_set1_ps(r2max);
              const __m512i lane = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
              const __m512i selfv = _mm512_set1_epi32(int(self));
              for (Index k = begin; k < end; k += 16)
              {
                const unsigned left = end - k;
                const __mmask16 valid = left >= 16 ? __mmask16(0xFFFF) : __mmask16((1u << left) - 1u);
                const __m512 dx = _mm512_sub_ps(_mm512_maskz_loadu_ps(valid, px + k), qx);
                const __m512 dy = _mm512_sub_ps(_mm512_maskz_loadu_ps(valid, py + k), qy);
                const __m512 dz = _mm512_sub_ps(_mm512_maskz_loadu_ps(valid, pz + k), qz);
                const __m512 d2 = _mm512_fmadd_ps(dz, dz, _mm512_fmadd_ps(dy, dy, _mm512_mul_ps(dx, dx)));
                const __m512i j =
                    ids ? _mm512_maskz_loadu_epi32(valid, ids + k) : _mm512_add_epi32(_mm512_set1_epi32(int(k)), lane);
                const __mmask16 hit =
                    _mm512_mask_cmp_ps_mask(valid, d2, r2v, _CMP_LT_OQ) & __mmask16(~_mm512_cmpeq_epi32_mask(j, selfv));
                _mm512_storeu_si512(out_j + used, _mm512_maskz_compress_epi32(hit, j));
                _mm512_storeu_ps(out_d2 + used, _mm512_maskz_compress_ps(hit, d2));
                used += std::size_t(_mm_popcnt_u32(hit));
              }
            }
          };
          (void)scanVector;
#endif
          for (std::size_t s = 0; s < sources.size(); ++s)
          {
            const GridPoints& src = sources[s];
            const Index* const id = src.ids;
#if defined(__AVX512F__)
            if constexpr (kVector)
            {
              // Queries of one cell share their candidates (the cells within reach). When this
              // query and the next are in one cell, the candidates are gathered once into one
              // contiguous run (x, y, z, index) and every query of the cell scans that: whole
              // 16-lane blocks instead of each row's tail, and one loop of one length for the
              // cell instead of a loop per row. The same candidates in the same order: the same
              // lists. A query whose neighbour in the query order lies in another cell (the MLS
              // fits' boundary queries, mostly) reads the rows in place.
              const std::size_t m = src.count;
              const float* const px = soa_of[s];
              const float* const py = px + m;
              const float* const pz = py + m;
              CellCandidates& cc = cell_candidates[s];
              const Index cell = cc.next_query == i ? cc.next_cell : src.grid->cellOf(xi);
              if (cell == UniformGrid::kOutside) continue;  // forEachRange visits nothing either
              if (cell != cc.cell)
              {
                cc.cell = UniformGrid::kOutside;
                cc.next_query = i + 1;
                cc.next_cell = i + 1 < i_end ? src.grid->cellOf(queries[i + 1]) : UniformGrid::kOutside;
                if (cc.next_cell == cell)
                {
                  cc.cell = cell;
                  cc.count = 0;
                  // Only the candidates within reach of some point of the cell (about 3/4 of the
                  // 27 cells' points): the distance to the cell's box below the radius, the box
                  // widened against rounding by 1e-4 cells and 16 float steps of its coordinates
                  // (far from the origin a float's step outgrows the first). Kept in order: the
                  // same hits.
                  const Vec3d corner = src.grid->cellMin(cell);
                  const double margin =
                      1e-4 * src.grid->cellSize() + 1e-6 * (corner.cwiseAbs().maxCoeff() + src.grid->cellSize());
                  const Vec3d lo = corner - Vec3d::Constant(margin);
                  const Vec3d hi = lo + Vec3d::Constant(src.grid->cellSize() + 2 * margin);
                  const __m512 lox = _mm512_set1_ps(float(lo.x())), loy = _mm512_set1_ps(float(lo.y())),
                               loz = _mm512_set1_ps(float(lo.z()));
                  const __m512 hix = _mm512_set1_ps(float(hi.x())), hiy = _mm512_set1_ps(float(hi.y())),
                               hiz = _mm512_set1_ps(float(hi.z()));
                  const __m512 zero = _mm512_setzero_ps(), r2v = _mm512_set1_ps(r2max);
                  const __m512i lane = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
                  // max with every lane set (GCC 12's unmasked form warns of an uninitialised operand)
                  auto max = [](__m512 a, __m512 b) { return _mm512_maskz_max_ps(__mmask16(0xFFFF), a, b); };
                  src.grid->forEachRange(xi, reach[s], [&](Index begin, Index end) {
                    cc.reserve(cc.count + (end - begin) + 16);
                    for (Index k = begin; k < end; k += 16)
                    {
                      const unsigned left = end - k;
                      const __mmask16 valid = left >= 16 ? __mmask16(0xFFFF) : __mmask16((1u << left) - 1u);
                      const __m512 x = _mm512_maskz_loadu_ps(valid, px + k);
                      const __m512 y = _mm512_maskz_loadu_ps(valid, py + k);
                      const __m512 z = _mm512_maskz_loadu_ps(valid, pz + k);
                      // Per axis, how far the point lies outside the box (0 inside).
                      const __m512 gx = max(zero, max(_mm512_sub_ps(lox, x), _mm512_sub_ps(x, hix)));
                      const __m512 gy = max(zero, max(_mm512_sub_ps(loy, y), _mm512_sub_ps(y, hiy)));
                      const __m512 gz = max(zero, max(_mm512_sub_ps(loz, z), _mm512_sub_ps(z, hiz)));
                      const __m512 g2 = _mm512_fmadd_ps(gz, gz, _mm512_fmadd_ps(gy, gy, _mm512_mul_ps(gx, gx)));
                      const __mmask16 keep = _mm512_mask_cmp_ps_mask(valid, g2, r2v, _CMP_LT_OQ);
                      const __m512i j = id ? _mm512_maskz_loadu_epi32(valid, id + k)
                                           : _mm512_add_epi32(_mm512_set1_epi32(int(k)), lane);
                      _mm512_storeu_ps(cc.x.data() + cc.count, _mm512_maskz_compress_ps(keep, x));
                      _mm512_storeu_ps(cc.y.data() + cc.count, _mm512_maskz_compress_ps(keep, y));
                      _mm512_storeu_ps(cc.z.data() + cc.count, _mm512_maskz_compress_ps(keep, z));
                      _mm512_storeu_si512(cc.id.data() + cc.count, _mm512_maskz_compress_epi32(keep, j));
                      cc.count += std::size_t(_mm_popcnt_u32(keep));
                    }
                  });
                }
              }
              if (cc.cell == cell)
                scanVector(cc.x.data(), cc.y.data(), cc.z.data(), cc.id.data(), 0, Index(cc.count));
              else
                src.grid->forEachRange(xi, reach[s],
                                       [&](Index begin, Index end) { scanVector(px, py, pz, id, begin, end); });
              continue;
            }
#endif
            src.grid->forEachRange(xi, reach[s], [&](Index begin, Index end) {
              stageRoom(end - begin);
              Index* const out_j = bi.data();
              Real* const out_d2 = bf.data();
              // Branch-free compaction: every candidate is written, only hits advance the cursor.
              // Once the particles are disordered the hit test is a coin toss for the branch
              // predictor; with a branch the search took 3x longer late in a dam break than on the
              // initial lattice at the same candidate count.
              for (Index k = begin; k < end; ++k)
              {
                const Vec3 d = xi - src.sorted[k];
                const Real d2 = pairSquaredDistance(d.x(), d.y(), d.z());
                const Index j = id ? id[k] : k;
                out_j[used] = j;
                out_d2[used] = d2;
                used += std::size_t((d2 < r2max) & (j != self));
              }
            });
          }
          out.offset[i + 1] = Index(used - row_start);
          if (i + 1 - row_from == kValueRows || i + 1 == i_end) finishRows(i + 1);
        }
        block_used[slot] = used;
      }
    });
    // The wave's rows follow the rows before it: offsets from counts, then the copy.
    const std::size_t row_begin = w0 * kBlock, row_end = std::min(n, w1 * kBlock);
    for (std::size_t i = row_begin; i < row_end; ++i) out.offset[i + 1] += out.offset[i];
    growRows(out.offset[row_end]);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(w0, w1, 1), [&](const tbb::blocked_range<std::size_t>& rb) {
      for (std::size_t b = rb.begin(); b != rb.end(); ++b)
      {
        const std::size_t slot = b - w0;
        const std::size_t start = out.offset[b * kBlock];
        std::copy_n(block_index[slot].begin(), block_used[slot], out.index.begin() + start);
        if constexpr (kFactor)
          std::copy_n(block_factor[slot].begin(), block_used[slot], out.grad_factor.begin() + start);
        if constexpr (kWeight) std::copy_n(block_weight[slot].begin(), block_used[slot], out.weight.begin() + start);
      }
    });
  }
  const std::size_t pairs = out.offset[n];
  out.index.resize(pairs);
  if constexpr (kFactor) out.grad_factor.resize(pairs);
  if constexpr (kWeight) out.weight.resize(pairs);
}

}  // namespace fluid_sim
