// Neighbour-list build, cell list against kd-tree: real -> virtual query on a 2D or 3D
// lattice (the half-step list), in query points per second. Real time (OpenMP).
#include "engine/lattice.hpp"
#include "engine/parallel.hpp"
#include "neighbor/cell_list.hpp"
#include "neighbor/kd_tree.hpp"
#include "neighbor/neighbor_search.hpp"

#include <benchmark/benchmark.h>

#include <array>
#include <cmath>
#include <vector>

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

// Clustered sets, where the cell list's grid gets sparse: 4^Dim blobs (lattices of
// spacing 1, particles / 4^Dim points each) on a coarse grid of pitch `gap` x the blob
// side (gap 1: one uniform lattice). Query: the set against itself, radius 2.4 (alpha
// 1.2). Counters: ideal cells per point (cells_per_point, the "auto" statistic) and
// pairs per query. Arguments: particles, gap, threads.
template <int Dim>
std::array<std::vector<double>, Dim> clustered_points(std::int64_t particles, std::int64_t gap) {
  const std::int64_t blobs_per_axis = 4;
  std::int64_t blobs = 1;
  for (int d = 0; d < Dim; ++d) blobs *= blobs_per_axis;
  const auto side = std::max<std::int64_t>(
      2, std::llround(std::pow(static_cast<double>(particles) / static_cast<double>(blobs), 1.0 / Dim)));
  std::array<std::vector<double>, Dim> x;
  std::int64_t per_blob = 1;
  for (int d = 0; d < Dim; ++d) per_blob *= side;
  for (std::int64_t b = 0; b < blobs; ++b)
    for (std::int64_t p = 0; p < per_blob; ++p) {
      std::int64_t bb = b, pp = p;
      for (int d = 0; d < Dim; ++d) {
        const auto blob_index = bb % blobs_per_axis, node = pp % side;
        bb /= blobs_per_axis;
        pp /= side;
        x[d].push_back(static_cast<double>(blob_index * gap * side + node));
      }
    }
  return x;
}

template <int Dim, bool KdTreeSearch>
void BM_ClusteredBuild(benchmark::State& state) {
  const int before = thread_count();
  set_thread_count(static_cast<int>(state.range(2)));
  const auto x = clustered_points<Dim>(state.range(0), state.range(1));
  PointsView<Dim> points;
  points.count = x[0].size();
  for (int d = 0; d < Dim; ++d) points.coordinate[d] = x[d].data();
  const double radius = 2.4;
  std::size_t pairs = 0;
  for (auto _ : state) {
    const NeighborList list = KdTreeSearch ? KdTree<Dim>(points, radius).query(points)
                                           : CellList<Dim>(points, radius).query(points);
    pairs = list.pair_count();
    benchmark::DoNotOptimize(list.indices.data());
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(points.count));
  state.counters["pairs_per_query"] = static_cast<double>(pairs) / static_cast<double>(points.count);
  state.counters["cells_per_point"] = cells_per_point(points, radius);
  set_thread_count(before);
}

#define TSPH_CLUSTER_BENCHMARK(DIM, TREE, GAPS)                                    \
  BENCHMARK(BM_ClusteredBuild<DIM, TREE>)                                          \
      ->ArgNames({"particles", "gap", "threads"})                                  \
      ->ArgsProduct({{100'000}, GAPS, {1, 2}})                                     \
      ->UseRealTime()                                                              \
      ->Unit(benchmark::kMillisecond);

TSPH_CLUSTER_BENCHMARK(2, false, benchmark::CreateRange(1, 256, 2))
TSPH_CLUSTER_BENCHMARK(2, true, benchmark::CreateRange(1, 256, 2))
TSPH_CLUSTER_BENCHMARK(3, false, benchmark::CreateRange(1, 64, 2))
TSPH_CLUSTER_BENCHMARK(3, true, benchmark::CreateRange(1, 64, 2))

// Kd-tree build alone: one tree (serial) or one per slab, slabs built concurrently.
// Arguments: particles, slabs, threads.
template <int Dim>
void BM_KdTreeBuild(benchmark::State& state) {
  const int before = thread_count();
  set_thread_count(static_cast<int>(state.range(2)));
  const auto real = make_real_lattice(box_for<Dim>(state.range(0)), 1.0);
  const auto source = points_of<Dim>(real);
  for (auto _ : state) {
    KdTree<Dim> tree(source, 2.4, static_cast<std::size_t>(state.range(1)));
    benchmark::DoNotOptimize(&tree);
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(source.count));
  set_thread_count(before);
}
BENCHMARK(BM_KdTreeBuild<2>)->ArgNames({"particles", "slabs", "threads"})
    ->Args({1'000'000, 1, 1})->Args({1'000'000, 2, 2})->UseRealTime()->Unit(benchmark::kMillisecond);
BENCHMARK(BM_KdTreeBuild<3>)->ArgNames({"particles", "slabs", "threads"})
    ->Args({1'000'000, 1, 1})->Args({1'000'000, 2, 2})->UseRealTime()->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
