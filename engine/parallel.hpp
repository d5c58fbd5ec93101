// The one place where OpenMP pragmas live (docs/conventions.md: "OpenMP pragmas live in one
// header"). Loops elsewhere call these helpers with a lambda for the body.
//
// Determinism: every helper gives each index to exactly one thread and every
// reduction here is over integers or is done in a fixed order after the loop, so
// results do not depend on the thread count.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

#ifdef _OPENMP
#include <omp.h>
#endif

namespace tsph {

/// Runs `body(i)` for i in [0, n), statically partitioned over the OpenMP threads.
template <class Body>
void parallel_for(std::size_t n, Body&& body) {
  const auto count = static_cast<std::int64_t>(n);
#pragma omp parallel for schedule(static)
  for (std::int64_t i = 0; i < count; ++i) body(static_cast<std::size_t>(i));
}

/// Runs `body(i, scratch, counts)` for i in [0, n) with one default-constructed
/// `Scratch` per thread (reused buffers) and one `Counts` per thread, and returns the
/// sum of the per-thread counts. `Counts` must be an integer tally with `+=`, so the
/// total does not depend on the thread count. The per-thread tallies are kept in one
/// slot per thread and summed after the region, in thread order: no `omp critical`,
/// whose lazily created lock crashed libomp under ThreadSanitizer when two host
/// threads (`tsph validate --jobs 2`) entered the region at once (CI, stop 47).
template <class Scratch, class Counts, class Body>
Counts parallel_for_with_scratch(std::size_t n, Body&& body) {
  const auto count = static_cast<std::int64_t>(n);
  int slots = 1;
#ifdef _OPENMP
  slots = std::max(1, omp_get_max_threads());
#endif
  std::vector<Counts> per_thread(static_cast<std::size_t>(slots));
#pragma omp parallel num_threads(slots)
  {
    std::size_t slot = 0;
#ifdef _OPENMP
    slot = static_cast<std::size_t>(omp_get_thread_num());
#endif
    Scratch scratch;
    Counts local{};
#pragma omp for schedule(static)
    for (std::int64_t i = 0; i < count; ++i) body(static_cast<std::size_t>(i), scratch, local);
    per_thread[slot] = local;
  }
  Counts total{};
  for (const Counts& local : per_thread) total += local;
  return total;
}

/// Number of threads a parallel region would use.
inline int thread_count();

/// Splits [0, n) into one contiguous block per thread (block b: [n b / B, n (b + 1) / B))
/// and runs body(b, begin, end) for each block in parallel; returns B. For reductions
/// kept per block and combined in block order afterwards (deterministic).
template <class Body>
std::size_t parallel_blocks(std::size_t n, Body&& body) {
  int threads = 1;
#ifdef _OPENMP
  threads = omp_get_max_threads();
#endif
  const std::size_t blocks = static_cast<std::size_t>(threads > 0 ? threads : 1);
  parallel_for(blocks, [&](std::size_t b) { body(b, n * b / blocks, n * (b + 1) / blocks); });
  return blocks;
}

/// sum_i value(i) for i in [0, n), in fixed blocks of 4096 summed in order: the same
/// bits on any thread count (the blocks do not follow the threads).
template <class Value>
double deterministic_sum(std::size_t n, Value&& value) {
  constexpr std::size_t block = 4096;
  const std::size_t blocks = (n + block - 1) / block;
  std::vector<double> partial(blocks, 0.0);
  parallel_for(blocks, [&](std::size_t b) {
    double sum = 0.0;
    for (std::size_t i = b * block, end = std::min(n, (b + 1) * block); i < end; ++i) sum += value(i);
    partial[b] = sum;
  });
  double total = 0.0;
  for (double p : partial) total += p;
  return total;
}

/// Number of threads a parallel region would use.
inline int thread_count() {
#ifdef _OPENMP
  return omp_get_max_threads();
#else
  return 1;
#endif
}

/// Sets the number of threads used by later parallel regions (<= 0 leaves it as is).
inline void set_thread_count(int threads) {
#ifdef _OPENMP
  if (threads > 0) omp_set_num_threads(threads);
#else
  (void)threads;
#endif
}

}  // namespace tsph
