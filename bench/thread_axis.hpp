// The thread axis of the Google Benchmark programs: 1 and 2 (the 2-core machines the
// headline figures are quoted on), then the powers of two up to TSPH_BENCH_MAX_THREADS
// (and that number itself) when it is set, for scaling on larger nodes
// (docs/performance.md, "Beyond two cores").
#pragma once

#include <cstdint>
#include <cstdlib>
#include <vector>

namespace tsph::bench {

inline std::vector<std::int64_t> thread_axis() {
  std::vector<std::int64_t> counts{1, 2};
  if (const char* text = std::getenv("TSPH_BENCH_MAX_THREADS")) {
    const long most = std::strtol(text, nullptr, 10);
    for (std::int64_t t = 4; t <= most; t *= 2) counts.push_back(t);
    if (most > 2 && counts.back() != most) counts.push_back(most);
  }
  return counts;
}

}  // namespace tsph::bench
