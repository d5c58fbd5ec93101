// How the stepper builds its neighbour lists and orders its particles does not change
// its results: the kd-tree and the cell list, a transposed or a searched full-step list,
// give bitwise identical updated-Lagrangian runs; a set given in random order is sorted
// (SolverSettings::spatial_order) into the lattice order, after which the run is
// bitwise that of the lattice, and into Morton order, after which it agrees with the
// lattice run particle by particle (by id) to round-off.
#include "engine/lattice.hpp"
#include "engine/parallel.hpp"
#include "engine/region.hpp"
#include "engine/taylor_sph.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>
#include <vector>

namespace tsph {
namespace {

constexpr double kDensity = 2000.0;
constexpr double kYoung = 8e7;

/// A block held at x = 0, a traction ramp at the far face, free elsewhere (no
/// condition), with a smooth initial velocity; updated Lagrangian, alpha 1.2, surface
/// filter on. `shuffle` permutes both sets at random before the solver sees them.
template <int Dim>
struct Block {
  LatticeBox<Dim> box;
  ParticleSet<Dim> real, virtual_particles;
  std::vector<BoundaryCondition<Dim>> conditions;

  explicit Block(std::int64_t nodes, bool shuffle) {
    box.spacing = 0.01;
    for (int d = 0; d < Dim; ++d) box.node_count[d] = nodes;
    real = make_real_lattice(box, kDensity);
    virtual_particles = make_virtual_lattice(box, kDensity);
    Vector<Dim> far = box.lower;
    far[0] += static_cast<double>(nodes - 1) * box.spacing;
    assign_boundary(real, Region<Dim>::half_space("clamp", box.lower, -Vector<Dim>::Unit(0)), 0, 1e-9);
    assign_boundary(real, Region<Dim>::half_space("end", far, Vector<Dim>::Unit(0)), 1, 1e-9);
    for (std::size_t i = 0; i < real.size(); ++i)
      for (int d = 0; d < Dim; ++d)
        real.velocity[d][i] = 0.05 * std::sin(30.0 * real.position[0][i] + d) *
                              std::cos(20.0 * real.position[Dim - 1][i]);
    // Shear load along the last axis, ramped up over 1 ms.
    auto ramp = [] {
      if constexpr (Dim == 2)
        return std::array<TimeFunction, 2>{TimeFunction::constant(0.0), TimeFunction::linear_ramp(1e4, 0.0, 1e-3)};
      else
        return std::array<TimeFunction, 3>{TimeFunction::constant(0.0), TimeFunction::constant(0.0),
                                           TimeFunction::linear_ramp(1e4, 0.0, 1e-3)};
    }();
    conditions = {BoundaryCondition<Dim>::fixed("clamp"), BoundaryCondition<Dim>::traction(ramp, "end")};
    if (shuffle) {
      std::mt19937_64 rng(7);
      for (ParticleSet<Dim>* set : {&real, &virtual_particles}) {
        std::vector<std::uint32_t> order(set->size());
        for (std::size_t i = 0; i < order.size(); ++i) order[i] = static_cast<std::uint32_t>(i);
        std::shuffle(order.begin(), order.end(), rng);
        set->permute(order);
      }
    }
  }

  TaylorSph<Dim> solver(const SolverSettings<Dim>& settings) {
    return TaylorSph<Dim>(real, virtual_particles, LinearElastic<Dim>(kYoung, 0.3, kDensity), settings,
                          conditions);
  }
};

template <int Dim>
SolverSettings<Dim> block_settings() {
  SolverSettings<Dim> settings;
  settings.smoothing_length = 1.2 * 0.01;
  settings.kinematics = Kinematics::updated_lagrangian;
  settings.hourglass_coefficient = 0.02;
  return settings;
}

template <int Dim>
double block_dt() {
  return 0.3 * 0.01 / std::sqrt(LinearElastic<Dim>(kYoung, 0.3, kDensity).p_wave_modulus() / kDensity);
}

/// Bitwise equality of positions, velocities and stresses, particle by particle.
template <int Dim>
void expect_identical(const ParticleSet<Dim>& a, const ParticleSet<Dim>& b, const std::string& what) {
  for (int d = 0; d < Dim; ++d) {
    EXPECT_EQ(a.position[d], b.position[d]) << what;
    EXPECT_EQ(a.velocity[d], b.velocity[d]) << what;
  }
  for (int m = 0; m < stress_component_count<Dim>; ++m) EXPECT_EQ(a.stress[m], b.stress[m]) << what;
  EXPECT_EQ(a.id, b.id) << what;
}

template <int Dim>
void check_searches_and_transposition(std::int64_t nodes, int steps) {
  Block<Dim> block(nodes, false);
  auto run = [&](NeighborSearch search, bool transpose_lists, int threads) {
    const int before = thread_count();
    set_thread_count(threads);
    SolverSettings<Dim> settings = block_settings<Dim>();
    settings.neighbor_search = search;
    settings.transpose_lists = transpose_lists;
    TaylorSph<Dim> solver = block.solver(settings);
    EXPECT_EQ(solver.neighbor_search_used(),
              search == NeighborSearch::kd_tree ? NeighborSearch::kd_tree : NeighborSearch::cell_list);
    for (int k = 0; k < steps; ++k) solver.step(block_dt<Dim>());
    set_thread_count(before);
    EXPECT_GT(solver.kinetic_energy(), 0.0);
    return solver.real();
  };
  const ParticleSet<Dim> reference = run(NeighborSearch::cell_list, false, 1);
  expect_identical(reference, run(NeighborSearch::cell_list, true, 1), "transposed, 1 thread");
  expect_identical(reference, run(NeighborSearch::cell_list, true, 2), "transposed, 2 threads");
  expect_identical(reference, run(NeighborSearch::kd_tree, true, 2), "kd-tree, transposed");
  expect_identical(reference, run(NeighborSearch::kd_tree, false, 2), "kd-tree, searched");
  expect_identical(reference, run(NeighborSearch::automatic, true, 2), "auto");
}

TEST(SolverNeighbors, SearchesAndTranspositionGiveIdenticalRuns2D) {
  check_searches_and_transposition<2>(16, 20);
}
TEST(SolverNeighbors, SearchesAndTranspositionGiveIdenticalRuns3D) {
  check_searches_and_transposition<3>(7, 6);
}

// The transposed full-step list equals the searched one in a small-strain run too (both
// lists kept); the particles do not move.
TEST(SolverNeighbors, SmallStrainListsAreTheSameTransposedOrSearched) {
  Block<2> block(12, false);
  SolverSettings<2> settings = block_settings<2>();
  settings.kinematics = Kinematics::small_strain;
  settings.transpose_lists = false;
  const TaylorSph<2> searched = block.solver(settings);
  settings.transpose_lists = true;
  const TaylorSph<2> transposed = block.solver(settings);
  EXPECT_TRUE(searched.real_from_virtual() == transposed.real_from_virtual());
  EXPECT_GT(transposed.real_from_virtual().pair_count(), 10 * transposed.real().size());
}

template <int Dim>
void check_sorting(std::int64_t nodes, int steps) {
  auto run = [&](bool shuffle, SpatialOrder order, std::int64_t expected_reorders) {
    Block<Dim> block(nodes, shuffle);
    SolverSettings<Dim> settings = block_settings<Dim>();
    settings.spatial_order = order;
    TaylorSph<Dim> solver = block.solver(settings);
    EXPECT_EQ(solver.counters().reorders, expected_reorders) << "shuffled " << shuffle;
    for (int k = 0; k < steps; ++k) solver.step(block_dt<Dim>());
    EXPECT_EQ(solver.counters().reorders, expected_reorders) << "no decay in an elastic run";
    return solver.real();
  };
  const ParticleSet<Dim> lattice = run(false, SpatialOrder::none, 0);
  // The lattice is already in cell order: kept as it is.
  expect_identical(lattice, run(false, SpatialOrder::cells, 0), "lattice, cell order");
  // A shuffled set is sorted back into the lattice order (cells of r / 4 < dx hold one
  // particle each, taken row by row): the same run, bit for bit.
  const ParticleSet<Dim> sorted = run(true, SpatialOrder::cells, 1);
  for (std::size_t i = 0; i < sorted.size(); ++i) ASSERT_EQ(sorted.id[i], i) << "position " << i;
  expect_identical(lattice, sorted, "shuffled, then sorted in cell order");
  // Morton order: another order, so sums run in another order: equal to round-off.
  const ParticleSet<Dim> morton = run(true, SpatialOrder::morton, 1);
  std::vector<std::size_t> at(morton.size());
  for (std::size_t k = 0; k < morton.size(); ++k) at[morton.id[k]] = k;
  bool reordered = false;
  double scale = 0.0;
  for (std::size_t i = 0; i < lattice.size(); ++i)
    for (int m = 0; m < stress_component_count<Dim>; ++m) scale = std::max(scale, std::abs(lattice.stress[m][i]));
  ASSERT_GT(scale, 0.0);
  for (std::size_t i = 0; i < lattice.size(); ++i) {
    reordered = reordered || at[i] != i;
    for (int d = 0; d < Dim; ++d)
      EXPECT_NEAR(morton.position[d][at[i]], lattice.position[d][i], 1e-14) << "particle " << i;
    for (int m = 0; m < stress_component_count<Dim>; ++m)
      EXPECT_NEAR(morton.stress[m][at[i]], lattice.stress[m][i], 1e-9 * scale) << "particle " << i;
  }
  EXPECT_TRUE(reordered);
}

TEST(SolverNeighbors, ShuffledSetIsSortedAndRunsAsTheLattice2D) { check_sorting<2>(16, 10); }
TEST(SolverNeighbors, ShuffledSetIsSortedAndRunsAsTheLattice3D) { check_sorting<3>(12, 3); }

TEST(SolverNeighbors, ReorderThresholdMustExceedOne) {
  Block<2> block(6, false);
  SolverSettings<2> settings = block_settings<2>();
  settings.spatial_order = SpatialOrder::cells;
  settings.reorder_threshold = 1.0;
  EXPECT_THROW(block.solver(settings), std::invalid_argument);
}

}  // namespace
}  // namespace tsph
