// Memory bandwidth of this machine, STREAM-like (McCalpin's triad a = b + s c over
// arrays far larger than the caches), for the roofline estimates of bench/RESULTS.md.
// Bytes counted as STREAM does: 24 per element (read b and c, write a; the
// write-allocate read of a is not counted). 1 and 2 threads (more: bench/thread_axis.hpp),
// through parallel_for.
//
// BM_CoreClock: the core's clock while it runs, from a chain of dependent integer adds
// (one cycle each on every x86 core since the Pentium 4; 8 adds an iteration, so the
// loop's own increment and branch run beside the chain). Its counter `Gcycles` (per
// second, so the clock in GHz) turns a time per particle-step into cycles, and with
// callgrind's instruction count into instructions per cycle, where a VM gives no
// hardware counters (perf stat: <not supported>). On a loaded machine read the CPU
// column: 8 x 2^26 cycles over the CPU time.
#include "bench/thread_axis.hpp"
#include "engine/parallel.hpp"

#include <benchmark/benchmark.h>

#include <cstdint>
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

#if defined(__x86_64__)
void BM_CoreClock(benchmark::State& state) {
  constexpr std::int64_t iterations = 1 << 26;
  std::uint64_t x = 0;
  for (auto _ : state) {
    for (std::int64_t i = 0; i < iterations; ++i) {
      // 8 dependent adds: 8 cycles an iteration whatever the issue width.
      asm volatile(
          "add $1, %0\n\tadd $1, %0\n\tadd $1, %0\n\tadd $1, %0\n\t"
          "add $1, %0\n\tadd $1, %0\n\tadd $1, %0\n\tadd $1, %0"
          : "+r"(x));
    }
    benchmark::DoNotOptimize(x);
  }
  // Cycles per second: 8 per iteration (the counter is divided by the real time).
  state.counters["Gcycles"] = benchmark::Counter(static_cast<double>(state.iterations()) * 8.0 *
                                                 static_cast<double>(iterations) * 1e-9,
                                             benchmark::Counter::kIsRate);
}
BENCHMARK(BM_CoreClock)->UseRealTime()->Unit(benchmark::kMillisecond);
#endif

}  // namespace

BENCHMARK_MAIN();
