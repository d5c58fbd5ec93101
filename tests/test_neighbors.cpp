// Neighbour searches (neighbor/): the cell list produces exactly the brute-force CSR
// list (same offsets, same indices, same order) in 1, 2 and 3 dimensions, for random
// and lattice points, radii exactly on lattice distances, empty and degenerate sets,
// far-away queries and tiny radii; rows are sorted, the result does not depend on the
// thread count, and invalid input is rejected.
#include "engine/lattice.hpp"
#include "neighbor/brute_force.hpp"
#include "neighbor/cell_list.hpp"
#include "neighbor/kd_tree.hpp"
#include "neighbor/neighbor_search.hpp"
#include "neighbor/spatial_order.hpp"

#include <gtest/gtest.h>

#include "tests/typed_dimensions.hpp"

#include <omp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace tsph {
namespace {

/// Coordinates in structure-of-arrays form; `points_of` reads its `position`.
template <int Dim>
struct Points {
  std::array<std::vector<double>, Dim> position;

  std::size_t size() const { return position[0].size(); }
  void add(const Eigen::Matrix<double, Dim, 1>& x) {
    for (int d = 0; d < Dim; ++d) position[d].push_back(x[d]);
  }
  PointsView<Dim> view() const { return points_of<Dim>(*this); }
};

/// `count` points uniform in [low, high]^Dim.
template <int Dim>
Points<Dim> random_points(std::size_t count, double low, double high, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uniform(low, high);
  Points<Dim> points;
  for (std::size_t i = 0; i < count; ++i) {
    Eigen::Matrix<double, Dim, 1> x;
    for (int d = 0; d < Dim; ++d) x[d] = uniform(rng);
    points.add(x);
  }
  return points;
}

/// A CSR list is well formed: offsets start at 0, never decrease, end at the pair
/// count, and every row is strictly increasing with indices below `source_count`.
void expect_well_formed(const NeighborList& list, std::size_t query_count,
                        std::size_t source_count) {
  ASSERT_EQ(list.query_count(), query_count);
  EXPECT_FALSE(list.wide());  // 32-bit row starts: the pairs fit
  EXPECT_EQ(list.row_begin(0), 0u);
  EXPECT_EQ(list.row_begin(query_count), list.indices.size());
  for (std::size_t i = 0; i < query_count; ++i) {
    ASSERT_LE(list.row_begin(i), list.row_begin(i + 1));
    const auto row = list.neighbors(i);
    for (std::size_t k = 0; k < row.size(); ++k) {
      EXPECT_LT(row[k], source_count);
      if (k > 0) {
        EXPECT_LT(row[k - 1], row[k]) << "row " << i << " is not sorted";
      }
    }
  }
}

/// The cell list, through both entry points, and the kd-tree equal brute force exactly.
template <int Dim>
NeighborList expect_cell_list_matches_brute_force(const PointsView<Dim>& query,
                                                  const PointsView<Dim>& source, double radius) {
  const NeighborList reference = brute_force_neighbors<Dim>(query, source, radius);
  expect_well_formed(reference, query.count, source.count);
  const NeighborList convenience = cell_list_neighbors<Dim>(query, source, radius);
  const CellList<Dim> cells(source, radius);
  EXPECT_EQ(cells.radius(), radius);
  const NeighborList queried = cells.query(query);
  EXPECT_EQ(convenience.offsets, reference.offsets) << "radius " << radius;
  EXPECT_EQ(convenience.indices, reference.indices) << "radius " << radius;
  EXPECT_TRUE(queried == reference) << "radius " << radius;
  const NeighborList tree = kd_tree_neighbors<Dim>(query, source, radius);
  EXPECT_TRUE(tree == reference) << "kd-tree, radius " << radius;
  // The kd-tree in 1 to 5 slabs (trees built concurrently): the same list.
  for (std::size_t slabs : {1, 2, 3, 5}) {
    const KdTree<Dim> sliced(source, radius, slabs);
    EXPECT_EQ(sliced.slab_count(), std::min(slabs, source.count)) << slabs << " slabs";
    EXPECT_TRUE(sliced.query(query) == reference) << "kd-tree, " << slabs << " slabs, radius " << radius;
  }
  // Rows for every third query point only: those equal the reference, the rest are empty.
  std::vector<std::uint32_t> rows;
  for (std::size_t i = 0; i < query.count; i += 3) rows.push_back(static_cast<std::uint32_t>(i));
  const NeighborList subset = cells.query_subset(query, rows, false);
  EXPECT_TRUE(KdTree<Dim>(source, radius, 3).query_subset(query, rows, false) == subset)
      << "kd-tree subset, radius " << radius;
  for (NeighborSearch kind : {NeighborSearch::cell_list, NeighborSearch::kd_tree}) {
    const NeighborSearcher<Dim> searcher(kind, source, radius);
    EXPECT_EQ(searcher.kind(), kind);
    EXPECT_TRUE(searcher.query(query) == reference) << to_string(kind);
    EXPECT_TRUE(searcher.query_subset(query, rows, false) == subset) << to_string(kind);
  }
  EXPECT_EQ(subset.query_count(), query.count);
  for (std::size_t i = 0; i < query.count; ++i) {
    const auto row = subset.neighbors(i);
    const std::vector<std::uint32_t> got(row.begin(), row.end());
    std::vector<std::uint32_t> want;
    if (i % 3 == 0) want.assign(reference.neighbors(i).begin(), reference.neighbors(i).end());
    EXPECT_EQ(got, want) << "subset row " << i << ", radius " << radius;
  }
  return reference;
}

template <class DimConstant>
class NeighborTest : public ::testing::Test {};

using tsph::testing::Dimensions;
using tsph::testing::DimName;
TYPED_TEST_SUITE(NeighborTest, Dimensions, DimName);

// Random query and source sets (different sets, the query box larger than the source
// box) at several radii: identical lists, and a non-trivial number of pairs.
TYPED_TEST(NeighborTest, RandomPointsMatchBruteForce) {
  constexpr int dim = TypeParam::value;
  const auto source = random_points<dim>(500, 0.0, 1.0, 1);
  const auto query = random_points<dim>(300, -0.1, 1.1, 2);
  for (double radius : {0.05, 0.13, 0.3}) {
    const NeighborList list =
        expect_cell_list_matches_brute_force<dim>(query.view(), source.view(), radius);
    if (radius > 0.2) {
      EXPECT_GT(list.pair_count(), 10 * query.size());  // not vacuous
    }
  }
}

// On a lattice of spacing dx = 0.25 (exact in binary), the radius equal to dx puts the
// axis neighbours exactly on the radius: they are included (distance <= radius), and
// each interior node has exactly 2 Dim + 1 neighbours, itself included. Radii of 1.2
// and 2.4 spacings, and a non-dyadic spacing, also agree with brute force.
TYPED_TEST(NeighborTest, LatticePointsOnTheRadiusAreIncluded) {
  constexpr int dim = TypeParam::value;
  LatticeBox<dim> box;
  box.spacing = 0.25;
  for (int d = 0; d < dim; ++d) {
    box.lower[d] = -1.0 + 0.5 * d;  // negative coordinates exercise floor() of negatives
    box.node_count[d] = dim == 3 ? 6 : 9;
  }
  const auto lattice = make_real_lattice(box, 1.0);
  const PointsView<dim> points = points_of<dim>(lattice);

  const NeighborList on_radius =
      expect_cell_list_matches_brute_force<dim>(points, points, box.spacing);
  // Node 0 and node 1 (next along axis 0) are exactly dx apart.
  ASSERT_EQ(points.point(1)[0] - points.point(0)[0], box.spacing);
  const auto row0 = on_radius.neighbors(0);
  EXPECT_TRUE(std::find(row0.begin(), row0.end(), 1u) != row0.end());
  const auto row1 = on_radius.neighbors(1);
  EXPECT_TRUE(std::find(row1.begin(), row1.end(), 0u) != row1.end());
  // Every node: 1 + (number of axis neighbours inside the box).
  for (std::size_t i = 0; i < points.count; ++i) {
    std::size_t expected = 1;
    for (int d = 0; d < dim; ++d) {
      const double x = points.point(i)[d];
      const double upper = box.lower[d] + static_cast<double>(box.node_count[d] - 1) * box.spacing;
      expected += (x > box.lower[d]) + (x < upper);
    }
    EXPECT_EQ(on_radius.neighbors(i).size(), expected) << "node " << i;
  }
  for (double factor : {1.2, 2.4})
    expect_cell_list_matches_brute_force<dim>(points, points, factor * box.spacing);

  // A spacing that binary floating point does not represent exactly.
  box.spacing = 0.1;
  const auto inexact = make_real_lattice(box, 1.0);
  const PointsView<dim> inexact_points = points_of<dim>(inexact);
  for (double factor : {1.0, 1.2, 2.4})
    expect_cell_list_matches_brute_force<dim>(inexact_points, inexact_points, factor * box.spacing);
  // Virtual (cell-centre) points against the real nodes: at 0.5 dx per axis.
  const auto centres = make_virtual_lattice(box, 1.0);
  for (double factor : {1.0, 1.2, 2.4})
    expect_cell_list_matches_brute_force<dim>(points_of<dim>(centres), inexact_points,
                                              factor * box.spacing);
}

// Pairs exactly one radius apart (exact in binary) placed across every nearby cell
// boundary: p sweeps a neighbourhood of each multiple of the radius, q = p + radius. A
// cell list whose cells were even slightly smaller than the radius would put p and q
// two cells apart for some p and miss the pair.
TYPED_TEST(NeighborTest, PairsExactlyOnTheRadiusAcrossCellBoundaries) {
  constexpr int dim = TypeParam::value;
  using Vec = Eigen::Matrix<double, dim, 1>;
  const double radius = 0.25;
  const double grain = std::ldexp(1.0, -40);  // p on a 2^-40 grid: p + radius is exact
  Points<dim> points;
  points.add(Vec::Zero());  // pins the lower corner of the grid at the origin
  for (int k = 1; k <= 8; ++k)
    for (int step = -60; step <= 60; ++step) {
      Vec p = Vec::Zero();
      p[0] = std::round(k * radius * (1.0 + 1e-4 * step) / grain) * grain;
      Vec q = p;
      q[0] += radius;
      points.add(p);
      points.add(q);
    }
  const NeighborList list =
      expect_cell_list_matches_brute_force<dim>(points.view(), points.view(), radius);
  for (std::size_t i = 1; i < points.size(); i += 2) {
    const auto row = list.neighbors(i);
    EXPECT_TRUE(std::binary_search(row.begin(), row.end(), static_cast<std::uint32_t>(i + 1)))
        << "pair at x = " << points.position[0][i];
  }
}

// No source points: every row is empty, and the offsets still have one entry per row.
TYPED_TEST(NeighborTest, EmptySourceGivesEmptyRows) {
  constexpr int dim = TypeParam::value;
  const Points<dim> source;
  const auto query = random_points<dim>(10, 0.0, 1.0, 3);
  const NeighborList list =
      expect_cell_list_matches_brute_force<dim>(query.view(), source.view(), 0.5);
  EXPECT_EQ(list.offsets, std::vector<std::uint32_t>(11, 0));
  EXPECT_TRUE(list.indices.empty());
}

// No query points: a list with zero rows ({0} offsets).
TYPED_TEST(NeighborTest, EmptyQueryGivesNoRows) {
  constexpr int dim = TypeParam::value;
  const auto source = random_points<dim>(10, 0.0, 1.0, 4);
  const Points<dim> query;
  const NeighborList list =
      expect_cell_list_matches_brute_force<dim>(query.view(), source.view(), 0.5);
  EXPECT_EQ(list.query_count(), 0u);
  EXPECT_EQ(list.offsets, std::vector<std::uint32_t>{0});
  EXPECT_TRUE(list.indices.empty());
  // Both sets empty.
  const NeighborList none =
      expect_cell_list_matches_brute_force<dim>(query.view(), query.view(), 0.5);
  EXPECT_EQ(none.query_count(), 0u);
}

// One source particle (a zero-size bounding box): found from itself, from a point at
// exactly the radius, not from one just beyond.
TYPED_TEST(NeighborTest, SingleParticle) {
  constexpr int dim = TypeParam::value;
  using Vec = Eigen::Matrix<double, dim, 1>;
  Points<dim> source;
  const Vec x = Vec::Constant(0.75);
  source.add(x);
  Points<dim> query;
  query.add(x);
  Vec on = x;
  on[0] += 0.5;  // exactly 0.5 away
  query.add(on);
  Vec beyond = x;
  beyond[dim - 1] -= 0.5000001;
  query.add(beyond);
  const NeighborList list =
      expect_cell_list_matches_brute_force<dim>(query.view(), source.view(), 0.5);
  EXPECT_EQ(list.offsets, (std::vector<std::uint32_t>{0, 1, 2, 2}));
  EXPECT_EQ(list.indices, (std::vector<std::uint32_t>{0, 0}));
}

// Query points far outside the source bounding box (beyond the grid, even by more than
// the int64 range of cell indices) find nothing; points just outside it, within the
// radius of a source point, are still found.
TYPED_TEST(NeighborTest, QueriesOutsideTheSourceBox) {
  constexpr int dim = TypeParam::value;
  using Vec = Eigen::Matrix<double, dim, 1>;
  const auto source = random_points<dim>(200, 0.0, 1.0, 5);
  Points<dim> query;
  for (double far : {3.0, -3.0, 1e6, -1e6, 1e20, -1e20, 1e300}) {
    Vec x = Vec::Constant(0.5);
    x[dim - 1] = far;
    query.add(x);
    query.add(Vec::Constant(far));
  }
  const std::size_t far_count = query.size();
  // Just outside each face, by less than the radius.
  for (int d = 0; d < dim; ++d) {
    Vec x = Vec::Constant(0.5);
    x[d] = -0.05;
    query.add(x);
    x[d] = 1.05;
    query.add(x);
  }
  const NeighborList list =
      expect_cell_list_matches_brute_force<dim>(query.view(), source.view(), 0.2);
  for (std::size_t i = 0; i < far_count; ++i) EXPECT_TRUE(list.neighbors(i).empty()) << i;
  for (std::size_t i = far_count; i < query.size(); ++i)
    EXPECT_FALSE(list.neighbors(i).empty()) << i;
}

// A radius tiny compared with the box: the cell list caps its cell count (a few cells
// per point) and must still find every pair. Close pairs are planted so that the lists
// are not all trivially {i}.
TYPED_TEST(NeighborTest, TinyRadiusWithCappedCellCount) {
  constexpr int dim = TypeParam::value;
  using Vec = Eigen::Matrix<double, dim, 1>;
  const double radius = 1e-4;
  auto source = random_points<dim>(1000, 0.0, 1.0, 6);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  for (std::size_t i = 0; i < 300; ++i) {  // a partner within ~0.6 radius of point i
    Vec x = source.view().point(i);
    for (int d = 0; d < dim; ++d) x[d] += 0.6 / std::sqrt(double(dim)) * radius * uniform(rng);
    source.add(x);
  }
  const CellList<dim> cells(source.view(), radius);
  EXPECT_LE(cells.cell_count(), 4 * static_cast<std::int64_t>(source.size()) + 64);
  EXPECT_GE(cells.cell_count(), 1);
  const NeighborList list =
      expect_cell_list_matches_brute_force<dim>(source.view(), source.view(), radius);
  EXPECT_GE(list.pair_count(), source.size() + 2 * 300);  // self pairs + planted pairs
}

// The same set as query and source: row i contains i itself, and the relation is
// symmetric (j in row i exactly when i in row j).
TYPED_TEST(NeighborTest, SameSetIncludesSelfAndIsSymmetric) {
  constexpr int dim = TypeParam::value;
  const auto points = random_points<dim>(400, -2.0, 3.0, 8);
  const double radius = dim == 1 ? 0.05 : 0.6;
  const NeighborList list =
      expect_cell_list_matches_brute_force<dim>(points.view(), points.view(), radius);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const auto row = list.neighbors(i);
    EXPECT_TRUE(std::binary_search(row.begin(), row.end(), static_cast<std::uint32_t>(i)));
    for (std::uint32_t j : row) {
      const auto back = list.neighbors(j);
      EXPECT_TRUE(std::binary_search(back.begin(), back.end(), static_cast<std::uint32_t>(i)))
          << i << " -> " << j;
    }
  }
  EXPECT_GT(list.pair_count(), 2 * points.size());
}

/// Restores the OpenMP thread count on scope exit.
class ThreadCountGuard {
 public:
  ThreadCountGuard() : saved_(omp_get_max_threads()) {}
  ~ThreadCountGuard() { omp_set_num_threads(saved_); }

 private:
  int saved_;
};

// The list does not depend on the number of OpenMP threads.
TYPED_TEST(NeighborTest, IdenticalWithOneAndTwoThreads) {
  constexpr int dim = TypeParam::value;
  const ThreadCountGuard guard;
  const auto source = random_points<dim>(600, 0.0, 1.0, 9);
  const auto query = random_points<dim>(500, 0.0, 1.0, 10);
  const double radius = 0.15;
  omp_set_num_threads(1);
  const NeighborList one = cell_list_neighbors<dim>(query.view(), source.view(), radius);
  omp_set_num_threads(2);
  const NeighborList two = cell_list_neighbors<dim>(query.view(), source.view(), radius);
  EXPECT_TRUE(one == two);
  EXPECT_TRUE(two == brute_force_neighbors<dim>(query.view(), source.view(), radius));
}

// A radius that is zero, negative, NaN or infinite, and a NaN or infinite coordinate in
// the query or source set, are rejected by every search with std::invalid_argument.
TYPED_TEST(NeighborTest, InvalidInputThrows) {
  constexpr int dim = TypeParam::value;
  const auto source = random_points<dim>(20, 0.0, 1.0, 11);
  const auto query = random_points<dim>(20, 0.0, 1.0, 12);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  for (double radius : {0.0, -0.0, -0.1, nan, inf}) {
    SCOPED_TRACE("radius " + std::to_string(radius));
    EXPECT_THROW(brute_force_neighbors<dim>(query.view(), source.view(), radius),
                 std::invalid_argument);
    EXPECT_THROW(cell_list_neighbors<dim>(query.view(), source.view(), radius),
                 std::invalid_argument);
    EXPECT_THROW(CellList<dim>(source.view(), radius), std::invalid_argument);
  }
  for (double bad : {nan, inf, -inf}) {
    for (int d = 0; d < dim; ++d) {
      SCOPED_TRACE("coordinate " + std::to_string(d) + " = " + std::to_string(bad));
      auto bad_query = query;
      bad_query.position[d][7] = bad;
      EXPECT_THROW(brute_force_neighbors<dim>(bad_query.view(), source.view(), 0.2),
                   std::invalid_argument);
      EXPECT_THROW(cell_list_neighbors<dim>(bad_query.view(), source.view(), 0.2),
                   std::invalid_argument);
      const CellList<dim> cells(source.view(), 0.2);
      EXPECT_THROW(cells.query(bad_query.view()), std::invalid_argument);

      auto bad_source = source;
      bad_source.position[d][0] = bad;
      EXPECT_THROW(brute_force_neighbors<dim>(query.view(), bad_source.view(), 0.2),
                   std::invalid_argument);
      EXPECT_THROW(cell_list_neighbors<dim>(query.view(), bad_source.view(), 0.2),
                   std::invalid_argument);
      EXPECT_THROW(CellList<dim>(bad_source.view(), 0.2), std::invalid_argument);
    }
  }
}

// Finite source coordinates whose bounding-box extent overflows (upper - lower = inf,
// e.g. -1e308 and 1e308) once made CellList::build loop forever (the cell count was
// NaN); it is now refused with a clear error.
TEST(CellList, OverflowingBoundingBoxIsRefused) {
  std::vector<double> x = {-1e308, 1e308};
  PointsView<1> points;
  points.count = 2;
  points.coordinate[0] = x.data();
  EXPECT_THROW(cell_list_neighbors<1>(points, points, 1.0), std::invalid_argument);
}

// A set queried against itself for a few rows without the point itself (the
// boundary particles' same-set list of the stepper); a row out of range is refused.
TYPED_TEST(NeighborTest, SubsetOfSameSetExcludesSelf) {
  constexpr int dim = TypeParam::value;
  const Points<dim> points = random_points<dim>(300, -1.0, 1.0, 41);
  const double radius = dim == 1 ? 0.05 : dim == 2 ? 0.2 : 0.4;
  const NeighborList reference = brute_force_neighbors<dim>(points.view(), points.view(), radius);
  const std::vector<std::uint32_t> rows = {299, 0, 17, 150};
  const CellList<dim> cells(points.view(), radius);
  const NeighborList subset = cells.query_subset(points.view(), rows, true);
  expect_well_formed(subset, points.size(), points.size());
  std::size_t filled = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    std::vector<std::uint32_t> want;
    if (std::find(rows.begin(), rows.end(), i) != rows.end())
      for (std::uint32_t j : reference.neighbors(i))
        if (j != i) want.push_back(j);
    const auto row = subset.neighbors(i);
    EXPECT_EQ(std::vector<std::uint32_t>(row.begin(), row.end()), want) << "row " << i;
    filled += want.size();
  }
  EXPECT_GT(filled, 0u);
  const std::vector<std::uint32_t> bad = {300};
  EXPECT_THROW(cells.query_subset(points.view(), bad, true), std::invalid_argument);
  const KdTree<dim> tree(points.view(), radius, 2);
  EXPECT_TRUE(tree.query_subset(points.view(), rows, true) == subset);
  EXPECT_THROW(tree.query_subset(points.view(), bad, true), std::invalid_argument);
}

// "auto": the cell list for a lattice, the kd-tree for a few small clusters far apart
// in a large box (more than kKdTreeCellsPerPoint cells of radius / 2 per point); both
// give the brute-force list.
TYPED_TEST(NeighborTest, AutomaticChoiceFollowsTheCellsPerPoint) {
  constexpr int dim = TypeParam::value;
  LatticeBox<dim> box;
  for (int d = 0; d < dim; ++d) box.node_count[d] = 6;
  box.spacing = 1.0;
  const ParticleSet<dim> lattice = make_real_lattice(box, 1.0);
  const double radius = 2.4;
  EXPECT_LT(cells_per_point<dim>(points_of<dim>(lattice), radius), 1.0);
  EXPECT_EQ((NeighborSearcher<dim>(NeighborSearch::automatic, points_of<dim>(lattice), radius).kind()),
            NeighborSearch::cell_list);
  // Two copies of the lattice, 1e4 spacings apart along every axis.
  Points<dim> clusters;
  for (double shift : {0.0, 1e4})
    for (std::size_t i = 0; i < lattice.size(); ++i) {
      Eigen::Matrix<double, dim, 1> x = lattice.position_of(i);
      x.array() += shift;
      clusters.add(x);
    }
  EXPECT_GT(cells_per_point<dim>(clusters.view(), radius), kKdTreeCellsPerPoint);
  const NeighborSearcher<dim> chosen(NeighborSearch::automatic, clusters.view(), radius);
  EXPECT_EQ(chosen.kind(), NeighborSearch::kd_tree);
  EXPECT_TRUE(chosen.query(clusters.view()) ==
              brute_force_neighbors<dim>(clusters.view(), clusters.view(), radius));
  EXPECT_EQ(parse_neighbor_search("auto"), NeighborSearch::automatic);
  EXPECT_EQ(parse_neighbor_search("kd_tree"), NeighborSearch::kd_tree);
  EXPECT_EQ(parse_neighbor_search("cell_list"), NeighborSearch::cell_list);
  EXPECT_FALSE(parse_neighbor_search("octree").has_value());
}

// Cell order: a permutation (every index once) that sorts by cell, axis 0 fastest; on a
// shuffled lattice with cells smaller than the spacing it gives back the lattice order.
TYPED_TEST(NeighborTest, CellOrderRestoresAShuffledLattice) {
  constexpr int dim = TypeParam::value;
  LatticeBox<dim> box;
  for (int d = 0; d < dim; ++d) box.node_count[d] = 7 + d;
  box.spacing = 0.1;
  ParticleSet<dim> set = make_real_lattice(box, 1.0);
  std::vector<std::uint32_t> shuffle(set.size());
  for (std::size_t i = 0; i < shuffle.size(); ++i) shuffle[i] = static_cast<std::uint32_t>(i);
  std::shuffle(shuffle.begin(), shuffle.end(), std::mt19937_64(3));
  set.permute(shuffle);
  const std::vector<std::uint32_t> order = cell_order<dim>(points_of<dim>(set), 0.06);
  std::vector<std::uint32_t> seen(order);
  std::sort(seen.begin(), seen.end());
  for (std::size_t i = 0; i < seen.size(); ++i) ASSERT_EQ(seen[i], i);
  set.permute(order);
  for (std::size_t i = 0; i < set.size(); ++i) EXPECT_EQ(set.id[i], i) << "position " << i;
  // Coarse cells: sorted by cell key, ties in their previous order (stable).
  const std::vector<std::uint32_t> coarse = cell_order<dim>(points_of<dim>(set), 0.25);
  auto cell_key = [&](std::uint32_t i) {
    std::int64_t key = 0;
    for (int d = dim - 1; d >= 0; --d)
      key = key * 1000 + static_cast<std::int64_t>(std::floor(set.position[d][i] / 0.25));
    return key;
  };
  for (std::size_t k = 1; k < coarse.size(); ++k) {
    const auto a = cell_key(coarse[k - 1]), b = cell_key(coarse[k]);
    EXPECT_TRUE(a < b || (a == b && coarse[k - 1] < coarse[k])) << "position " << k;
  }
  const PointsView<dim> none{};
  EXPECT_TRUE(cell_order<dim>(none, 1.0).empty());
  EXPECT_THROW(cell_order<dim>(points_of<dim>(set), 0.0), std::invalid_argument);
}

// The transpose of a query -> source list is the source -> query list of a search (same
// radius), with 1 and 2 threads; an index beyond the source count is refused.
TYPED_TEST(NeighborTest, TransposeEqualsTheSearchTheOtherWay) {
  constexpr int dim = TypeParam::value;
  const auto source = random_points<dim>(400, 0.0, 1.0, 51);
  const auto query = random_points<dim>(250, -0.1, 1.1, 52);
  const double radius = dim == 1 ? 0.02 : dim == 2 ? 0.12 : 0.25;
  const NeighborList forward = brute_force_neighbors<dim>(query.view(), source.view(), radius);
  const NeighborList backward = brute_force_neighbors<dim>(source.view(), query.view(), radius);
  ASSERT_GT(forward.pair_count(), 2 * query.size());
  const int before = thread_count();
  for (int threads : {1, 2}) {
    set_thread_count(threads);
    const NeighborList transposed = transpose(forward, source.size());
    EXPECT_TRUE(transposed == backward) << threads << " threads";
    EXPECT_TRUE(transpose(transposed, query.size()) == forward) << threads << " threads";
  }
  set_thread_count(before);
  EXPECT_TRUE(transpose(NeighborList{}, 3) == (NeighborList{{0, 0, 0, 0}, {}, {}}));
  EXPECT_THROW(transpose(forward, 10), std::invalid_argument);
}

/// The same rows whatever the width of the row starts.
void expect_same_rows(const NeighborList& a, const NeighborList& b) {
  ASSERT_EQ(a.query_count(), b.query_count());
  ASSERT_EQ(a.indices, b.indices);
  for (std::size_t i = 0; i <= a.query_count(); ++i) ASSERT_EQ(a.row_begin(i), b.row_begin(i)) << "row " << i;
}

// Row starts are 32-bit while the pair count fits, 64-bit beyond: with the limit
// lowered below the pair count (no test can hold 2^32 pairs) the list is wide, reads the
// same rows, and transposes to the same rows, from and to either width.
TYPED_TEST(NeighborTest, WideRowStartsHoldTheSameRows) {
  constexpr int dim = TypeParam::value;
  const auto source = random_points<dim>(300, 0.0, 1.0, 61);
  const auto query = random_points<dim>(200, -0.1, 1.1, 62);
  const double radius = dim == 1 ? 0.02 : dim == 2 ? 0.12 : 0.25;
  const NeighborList narrow = brute_force_neighbors<dim>(query.view(), source.view(), radius);
  ASSERT_FALSE(narrow.wide());
  ASSERT_GT(narrow.pair_count(), query.size());
  std::vector<std::uint32_t> counts(query.size() + 1, 0);
  for (std::size_t i = 0; i < query.size(); ++i) counts[i + 1] = static_cast<std::uint32_t>(narrow.neighbors(i).size());
  NeighborList wide = NeighborList::from_row_counts(counts, narrow.pair_count() - 1);
  ASSERT_TRUE(wide.wide());
  EXPECT_TRUE(wide.offsets.empty());
  ASSERT_EQ(wide.pair_count(), narrow.pair_count());
  wide.indices = narrow.indices;
  expect_same_rows(wide, narrow);
  EXPECT_FALSE(NeighborList::from_row_counts(counts, narrow.pair_count()).wide());  // at the limit: 32-bit
  const NeighborList backward = transpose(narrow, source.size());
  const NeighborList wide_backward = transpose(narrow, source.size(), 0);
  EXPECT_TRUE(wide_backward.wide());
  expect_same_rows(wide_backward, backward);
  expect_same_rows(transpose(wide, source.size()), backward);
  expect_same_rows(transpose(wide_backward, query.size(), 0), narrow);
  EXPECT_EQ(NeighborList::from_row_counts({}).query_count(), 0u);
}

// Morton order: a permutation sorted by the interleaved bits of the cell coordinates;
// on a 4 x 4 (x 4) lattice with one node per cell it is the Z curve.
TYPED_TEST(NeighborTest, MortonOrderFollowsTheZCurve) {
  constexpr int dim = TypeParam::value;
  LatticeBox<dim> box;
  for (int d = 0; d < dim; ++d) box.node_count[d] = 4;
  box.spacing = 1.0;
  ParticleSet<dim> set = make_real_lattice(box, 1.0);
  std::vector<std::uint32_t> shuffle(set.size());
  for (std::size_t i = 0; i < shuffle.size(); ++i) shuffle[i] = static_cast<std::uint32_t>(i);
  std::shuffle(shuffle.begin(), shuffle.end(), std::mt19937_64(5));
  set.permute(shuffle);
  const std::vector<std::uint32_t> order = morton_order<dim>(points_of<dim>(set), 0.5);
  ASSERT_EQ(order.size(), set.size());
  set.permute(order);
  for (std::size_t k = 0; k < set.size(); ++k) {
    // Position k on the Z curve: de-interleave k's bits into cell coordinates.
    std::array<std::uint64_t, dim> c{};
    for (int b = 0; b < 2; ++b)
      for (int d = 0; d < dim; ++d) c[d] |= ((k >> (dim * b + d)) & 1u) << b;
    for (int d = 0; d < dim; ++d) EXPECT_EQ(set.position[d][k], static_cast<double>(c[d])) << "position " << k;
  }
  EXPECT_EQ(morton_key<2>({3, 0}), 5u);
  EXPECT_EQ(morton_key<2>({0, 3}), 10u);
  EXPECT_EQ(morton_key<3>({1, 1, 1}), 7u);
  EXPECT_TRUE(spatial_order<dim>(SpatialOrder::none, points_of<dim>(set), 1.0).empty());
  EXPECT_EQ(spatial_order<dim>(SpatialOrder::morton, points_of<dim>(set), 0.5),
            morton_order<dim>(points_of<dim>(set), 0.5));
}

}  // namespace
}  // namespace tsph
