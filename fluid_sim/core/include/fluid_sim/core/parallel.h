#pragma once
// Parallel loops and reductions of the step, all in fixed chunks so that every result is the same
// for any thread count and from run to run.
//
// With TBB's default (auto) partitioner the chunk boundaries follow work stealing, and the
// compiler's vectorised loop body and its scalar remainder need not round alike, so an element's
// result could change with the timing of the threads: two identical runs of bench_dam_break at
// 195 k particles parted at step 110, and 3 or 4 threads gave other results than 1 or 2
// (docs/method_notes.md). Every parallel loop over particles goes through these helpers.

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <cstddef>

namespace fluid_sim
{
/// Particles per chunk of the step's loops (fixed: deterministic reductions).
constexpr std::size_t kGrain = 1024;

/// body(range) over [0, n) in parallel, in chunks that depend on n and grain only.
template <class Body>
void parallelRanges(std::size_t n, std::size_t grain, Body&& body)
{
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, grain), body, tbb::simple_partitioner());
}

/// f(i) for i in [0, n) in parallel (fixed chunks, see parallelRanges).
template <class F>
void parallelFor(std::size_t n, F&& f)
{
  parallelRanges(n, kGrain, [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) f(i);
  });
}

/// Sum over [0, n) of f(i) in double, in an order that depends on n only.
template <class F>
double parallelSum(std::size_t n, F&& f)
{
  return tbb::parallel_deterministic_reduce(
      tbb::blocked_range<std::size_t>(0, n, kGrain), 0.0,
      [&](const tbb::blocked_range<std::size_t>& r, double acc) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) acc += f(i);
        return acc;
      },
      [](double a, double b) { return a + b; });
}

/// Largest f(i) over [0, n), at least 0 (max is exact in any order).
template <class F>
double parallelMax(std::size_t n, F&& f)
{
  return tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, n, kGrain), 0.0,
      [&](const tbb::blocked_range<std::size_t>& r, double acc) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) acc = std::max(acc, double(f(i)));
        return acc;
      },
      [](double a, double b) { return std::max(a, b); });
}

/// Sum over [0, n) of per-element contributions into an accumulator of type Acc (for example the
/// per-body wrenches): accumulate(range, acc) adds a chunk's contributions, join(left, right)
/// adds two partial sums. The chunks and the order of the joins depend on n only.
template <class Acc, class Accumulate, class Join>
Acc parallelDeterministicSum(std::size_t n, const Acc& zero, Accumulate&& accumulate, Join&& join)
{
  return tbb::parallel_deterministic_reduce(
      tbb::blocked_range<std::size_t>(0, n, kGrain), zero,
      [&](const tbb::blocked_range<std::size_t>& r, Acc acc) {
        accumulate(r, acc);
        return acc;
      },
      [&](Acc left, const Acc& right) {
        join(left, right);
        return left;
      });
}

}  // namespace fluid_sim
