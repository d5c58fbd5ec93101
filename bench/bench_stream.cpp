// Memory bandwidth of this machine, STREAM-like (McCalpin's triad a = b + s c over
// arrays far larger than the caches), for the roofline estimates of bench/RESULTS.md.
// Bytes counted as STREAM does: 24 per element (read b and c, write a; the
// write-allocate read of a is not counted). 1 and 2 threads (more: bench/thread_axis.hpp),
// through parallel_for.
#include "bench/thread_axis.hpp"
#include "engine/parallel.hpp"

#include <benchmark/benchmark.h>

#include <vector>

namespace {

using namespace tsph;

void BM_Triad(benchmark::State& state) {
  const int before = thread_count();
  set_thread_count(static_cast<int>(state.range(1)));
  const auto n = static_cast<std::size_t>(state.range(0));
  std::vector<double> a(n), b(n, 1.0), c(n, 2.0);
  const double s = 3.0;
  parallel_for(n, [&](std::size_t i) { a[i] = 0.0; });  // first touch by the owning thread
  for (auto _ : state) {
    parallel_for(n, [&](std::size_t i) { a[i] = b[i] + s * c[i]; });
    benchmark::DoNotOptimize(a.data());
    benchmark::ClobberMemory();
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * 24 * n));
  state.counters["threads"] = static_cast<double>(state.range(1));
  set_thread_count(before);
}
BENCHMARK(BM_Triad)
    ->ArgNames({"elements", "threads"})
    ->ArgsProduct({{1 << 24}, tsph::bench::thread_axis()})
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
