// One Taylor-SPH step of the 1D bar (both half-steps and the boundary conditions),
// in real-particle-steps per second. Real time, since the loops run on OpenMP threads.
#include "engine/lattice.hpp"
#include "engine/parallel.hpp"
#include "engine/taylor_sph.hpp"

#include <benchmark/benchmark.h>

namespace {

using namespace tsph;

TaylorSph<1> make_bar(std::int64_t particles, double alpha) {
  LatticeBox<1> box;
  box.node_count = {particles};
  box.spacing = 1.0 / static_cast<double>(particles - 1);
  auto real = make_real_lattice(box, 2000.0);
  auto virtual_particles = make_virtual_lattice(box, 2000.0);
  real.boundary.front() = 0;
  real.boundary.back() = 1;
  for (std::size_t i = 0; i < real.size(); ++i) real.velocity[0][i] = std::sin(0.001 * static_cast<double>(i));
  SolverSettings<1> settings;
  settings.smoothing_length = alpha * box.spacing;
  return TaylorSph<1>(std::move(real), std::move(virtual_particles),
                      LinearElastic<1>(8e7, 0.0, 2000.0), settings,
                      {BoundaryCondition<1>::fixed("left"), BoundaryCondition<1>::free("right")});
}

// Arguments: particles, alpha x 10, threads.
void BM_Step1D(benchmark::State& state) {
  const int before = thread_count();
  set_thread_count(static_cast<int>(state.range(2)));
  auto solver = make_bar(state.range(0), 0.1 * static_cast<double>(state.range(1)));
  const double dt = 0.5 * solver.settings().smoothing_length / 200.0;
  for (auto _ : state) solver.step(dt);
  state.SetItemsProcessed(state.iterations() * state.range(0));
  state.counters["threads"] = static_cast<double>(state.range(2));
  set_thread_count(before);
}
BENCHMARK(BM_Step1D)
    ->ArgNames({"particles", "alpha10", "threads"})
    ->ArgsProduct({{10'000, 100'000, 1'000'000}, {6, 12}, {1, 2}})
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
