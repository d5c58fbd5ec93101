// Which neighbour search builds the CSR lists: the cell list or the kd-tree, both
// producing the same NeighborList (tests/test_neighbors.cpp), and the rule that picks
// one for a point set ("auto", SolverSettings::neighbor_search, case key
// solver.neighbor_search).
//
// The rule (measured, bench/RESULTS.md "kd-tree or cell list"): with one radius for
// the whole set, the cell list tests about 2 (2D) or 3.7 (3D) candidates per neighbour
// whatever the density, and is 2-7x faster than the kd-tree on every set whose
// bounding box it can grid in cells of radius / 2. It degrades only when that grid
// would need more than 4 cells per point (a set spread thinly over a large box:
// fragments far apart, a few clusters): its cells are then enlarged, and every query
// tests the points of the enlarged cells. The kd-tree does not care. So "auto" takes
// the kd-tree when the bounding box holds more than kKdTreeCellsPerPoint cells of
// radius / 2 per point: the crossover measured on clustered sets lies at about 100
// (2D) to 150 (3D); far above it the kd-tree is up to 6.8x (2D) and 1.25x (3D) faster.
#pragma once

#include "engine/parallel.hpp"
#include "neighbor/cell_list.hpp"
#include "neighbor/kd_tree.hpp"
#include "neighbor/neighbor_list.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

namespace tsph {

enum class NeighborSearch { automatic, cell_list, kd_tree };

inline std::string_view to_string(NeighborSearch search) {
  return search == NeighborSearch::automatic ? "auto"
         : search == NeighborSearch::cell_list ? "cell_list"
                                               : "kd_tree";
}

inline std::optional<NeighborSearch> parse_neighbor_search(std::string_view name) {
  if (name == "auto") return NeighborSearch::automatic;
  if (name == "cell_list") return NeighborSearch::cell_list;
  if (name == "kd_tree") return NeighborSearch::kd_tree;
  return std::nullopt;
}

/// Cells of side radius / 2 (the cell list's ideal) in the bounding box of `points`,
/// per point: about 0.7 (2D) or 0.6 (3D) for a lattice at alpha 1.2, growing with the
/// empty space in the box.
template <int Dim>
double cells_per_point(const PointsView<Dim>& points, double radius) {
  if (points.count == 0) return 0.0;
  // Bounding box, one block per thread (min and max are exact: any blocks give it).
  using Box = std::array<double, 2 * Dim>;  // lower, then upper
  std::vector<Box> block_box(static_cast<std::size_t>(std::max(1, thread_count())));
  const std::size_t blocks = parallel_blocks(points.count, [&](std::size_t b, std::size_t begin,
                                                               std::size_t end) {
    Box box;
    for (int d = 0; d < Dim; ++d) {
      box[d] = std::numeric_limits<double>::infinity();
      box[Dim + d] = -std::numeric_limits<double>::infinity();
    }
    for (std::size_t i = begin; i < end; ++i)
      for (int d = 0; d < Dim; ++d) {
        box[d] = std::min(box[d], points.coordinate[d][i]);
        box[Dim + d] = std::max(box[Dim + d], points.coordinate[d][i]);
      }
    block_box[b] = box;
  });
  std::array<double, Dim> lower, upper;
  lower.fill(std::numeric_limits<double>::infinity());
  upper.fill(-std::numeric_limits<double>::infinity());
  for (std::size_t b = 0; b < blocks; ++b)
    for (int d = 0; d < Dim; ++d) {
      lower[d] = std::min(lower[d], block_box[b][d]);
      upper[d] = std::max(upper[d], block_box[b][Dim + d]);
    }
  double cells = 1.0;
  for (int d = 0; d < Dim; ++d) cells *= std::floor((upper[d] - lower[d]) / (0.5 * radius)) + 1.0;
  return cells / static_cast<double>(points.count);
}

/// Above this many ideal cells per point "auto" takes the kd-tree (bench/RESULTS.md).
inline constexpr double kKdTreeCellsPerPoint = 128.0;

/// The search "auto" resolves to for this source set; other choices are returned as is.
template <int Dim>
NeighborSearch resolve_neighbor_search(NeighborSearch requested, const PointsView<Dim>& source,
                                       double radius) {
  if (requested != NeighborSearch::automatic) return requested;
  return cells_per_point(source, radius) > kKdTreeCellsPerPoint ? NeighborSearch::kd_tree
                                                                : NeighborSearch::cell_list;
}

/// The search structure over one source set, either kind, with the queries the solver
/// uses.
template <int Dim>
class NeighborSearcher {
 public:
  NeighborSearcher(NeighborSearch requested, const PointsView<Dim>& source, double radius)
      : kind_(resolve_neighbor_search(requested, source, radius)) {
    if (kind_ == NeighborSearch::kd_tree)
      tree_ = std::make_unique<KdTree<Dim>>(source, radius);
    else
      cells_.emplace(source, radius);
  }

  /// cell_list or kd_tree (never automatic).
  NeighborSearch kind() const { return kind_; }

  NeighborList query(const PointsView<Dim>& points) const {
    return tree_ ? tree_->query(points) : cells_->query(points);
  }
  NeighborList query_subset(const PointsView<Dim>& points, std::span<const std::uint32_t> rows,
                            bool exclude_self) const {
    return tree_ ? tree_->query_subset(points, rows, exclude_self)
                 : cells_->query_subset(points, rows, exclude_self);
  }

 private:
  NeighborSearch kind_;
  std::optional<CellList<Dim>> cells_;
  std::unique_ptr<KdTree<Dim>> tree_;
};

}  // namespace tsph
