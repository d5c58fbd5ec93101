// The one place where OpenMP pragmas live (STYLE.md: "OpenMP pragmas live in one
// header"). Loops elsewhere call these helpers with a lambda for the body.
//
// Determinism: every helper gives each index to exactly one thread and every
// reduction here is over integers or is done in a fixed order after the loop, so
// results do not depend on the thread count.
#pragma once

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

/// Runs `body(i)` for i in [0, n) and returns the sum of its integer results
/// (used to count fallbacks and rejected points; integer sums are exact).
template <class Body>
std::int64_t parallel_count(std::size_t n, Body&& body) {
  const auto count = static_cast<std::int64_t>(n);
  std::int64_t total = 0;
#pragma omp parallel for schedule(static) reduction(+ : total)
  for (std::int64_t i = 0; i < count; ++i) total += body(static_cast<std::size_t>(i));
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

/// Exclusive prefix sum in place: counts[i] becomes the sum of counts[0..i), and the
/// returned value is the total. Serial: it is a tiny fraction of any loop it feeds.
template <class T>
T exclusive_scan_in_place(std::vector<T>& counts) {
  T running = 0;
  for (T& c : counts) {
    const T here = c;
    c = running;
    running += here;
  }
  return running;
}

}  // namespace tsph
