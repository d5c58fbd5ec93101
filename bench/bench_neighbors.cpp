// Neighbour-list build, cell list against kd-tree: real -> virtual query on a 2D or 3D
// lattice (the half-step list), in query points per second. Real time (OpenMP).
#include "engine/lattice.hpp"
#include "engine/parallel.hpp"
#include "neighbor/cell_list.hpp"
#include "neighbor/kd_tree.hpp"

#include <benchmark/benchmark.h>

#include <cmath>

namespace {

using namespace tsph;

template <int Dim>
LatticeBox<Dim> box_for(std::int64_t particles) {
  LatticeBox<Dim> box;
  box.spacing = 1.0;
  const auto side = static_cast<std::int64_t>(std::llround(std::pow(static_cast<double>(particles), 1.0 / Dim)));
  for (int d = 0; d < Dim; ++d) box.node_count[d] = side;
  return box;
}

// Arguments: particles, alpha x 10, threads; template: Dim, kd-tree or cell list.
template <int Dim, bool KdTreeSearch>
void BM_NeighborBuild(benchmark::State& state) {
  const int before = thread_count();
  set_thread_count(static_cast<int>(state.range(2)));
  const auto box = box_for<Dim>(state.range(0));
  const auto real = make_real_lattice(box, 1.0);
  const auto virtual_particles = make_virtual_lattice(box, 1.0);
  const double radius = 2.0 * 0.1 * static_cast<double>(state.range(1)) * box.spacing;
  const auto source = points_of<Dim>(real);
  const auto query = points_of<Dim>(virtual_particles);
  std::size_t pairs = 0;
  for (auto _ : state) {
    const NeighborList list = KdTreeSearch ? KdTree<Dim>(source, radius).query(query)
                                           : CellList<Dim>(source, radius).query(query);
    pairs = list.pair_count();
    benchmark::DoNotOptimize(list.indices.data());
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(query.count));
  state.counters["pairs_per_query"] = static_cast<double>(pairs) / static_cast<double>(query.count);
  set_thread_count(before);
}

#define TSPH_NEIGHBOR_BENCHMARK(DIM, TREE, SIZES)                                  \
  BENCHMARK(BM_NeighborBuild<DIM, TREE>)                                           \
      ->ArgNames({"particles", "alpha10", "threads"})                              \
      ->ArgsProduct({SIZES, {6, 12}, {1, 2}})                                      \
      ->UseRealTime()                                                              \
      ->Unit(benchmark::kMillisecond);

TSPH_NEIGHBOR_BENCHMARK(2, false, benchmark::CreateRange(10'000, 1'000'000, 10))
TSPH_NEIGHBOR_BENCHMARK(2, true, benchmark::CreateRange(10'000, 1'000'000, 10))
TSPH_NEIGHBOR_BENCHMARK(3, false, benchmark::CreateRange(10'000, 1'000'000, 10))
TSPH_NEIGHBOR_BENCHMARK(3, true, benchmark::CreateRange(10'000, 1'000'000, 10))

}  // namespace

BENCHMARK_MAIN();
