// Cell-list neighbour search: source points binned in a regular grid of cells no
// smaller than half the radius, so that the neighbours of a query point lie in the
// 5^Dim cells around its own. Half-radius cells test 6.25 r^2 (2D) or 15.6 r^3 (3D)
// of candidates per query instead of 9 r^2 or 27 r^3 with radius-sized cells (the
// ball is 3.14 r^2, 4.19 r^3): fewer distance tests (bench/RESULTS.md). The source
// coordinates are copied in cell order, so the candidates of a row of 5 cells along
// axis 0 are one contiguous range. Produces the CSR NeighborList of neighbor_list.hpp.
#pragma once

#include "engine/parallel.hpp"
#include "neighbor/neighbor_list.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

namespace tsph {

template <int Dim>
class CellList {
 public:
  /// Bins `source` in cells of side >= radius. The source arrays must outlive the
  /// CellList (it keeps a view, not a copy).
  CellList(const PointsView<Dim>& source, double radius) : source_(source), radius_(radius) {
    validate_search_input(source, source, radius);
    build();
  }

  double radius() const { return radius_; }
  std::int64_t cell_count() const { return total_cells_; }

  /// All source points within `radius` of each query point, rows sorted.
  NeighborList query(const PointsView<Dim>& points) const {
    validate_finite_points(points, "query");  // the source was checked when indexed
    return query_rows(points, points.count, [](std::size_t i) { return i; }, false);
  }

  /// Rows only for the query points listed in `rows` (increasing or not); the other
  /// rows are empty. With `exclude_self`, source j == query i is left out (for a set
  /// queried against itself). The list still has one row per query point, so that it
  /// is indexed like the full list.
  NeighborList query_subset(const PointsView<Dim>& points, std::span<const std::uint32_t> rows,
                            bool exclude_self) const {
    validate_subset_query(points, rows);
    return query_rows(points, rows.size(), [rows](std::size_t k) { return std::size_t{rows[k]}; },
                      exclude_self);
  }

 private:
  /// Two passes over the rows (count, then fill), each row written by one thread.
  template <class RowOf>
  NeighborList query_rows(const PointsView<Dim>& points, std::size_t row_count, RowOf row_of,
                          bool exclude_self) const {
    std::vector<std::uint32_t> counts(points.count + 1, 0);  // counts[i + 1]: row i
    const double radius2 = radius_ * radius_;
    parallel_for(row_count, [&](std::size_t k) {
      const std::size_t i = row_of(k);
      std::uint64_t found = 0;
      for_each_range(points, i, [&](const Eigen::Matrix<double, Dim, 1>& x, std::uint32_t begin,
                                    std::uint32_t end) { found += count_within(x, begin, end); });
      // The point itself, if it is a source within the radius (always, for a set
      // queried against itself), is the one left out.
      if (exclude_self && found > 0 && i < source_.count &&
          squared_distance(points, i, source_, i) <= radius2)
        --found;
      counts[i + 1] = static_cast<std::uint32_t>(found);  // at most the source count (32-bit indices)
    });
    NeighborList list = NeighborList::from_row_counts(std::move(counts));
    parallel_for(row_count, [&](std::size_t k) {
      const std::size_t i = row_of(k);
      std::uint32_t* row = list.indices.data() + list.row_begin(i);
      std::size_t n = 0;
      visit_candidates(points, i, [&](std::uint32_t j) {
        if (!(exclude_self && j == i)) row[n++] = j;
      });
      // Sources are numbered in cell order within a cell; a lattice numbered with axis 0
      // fastest comes out nearly sorted, where insertion sort is linear.
      if (!std::is_sorted(row, row + n)) std::sort(row, row + n);
    });
    return list;
  }

  void build() {
    // Bounding box: one block of points per thread, combined afterwards (min and max
    // are exact, so the result does not depend on the blocks).
    const std::size_t max_blocks = static_cast<std::size_t>(std::max(1, thread_count()));
    std::vector<Eigen::Matrix<double, Dim, 1>> block_lower(max_blocks), block_upper(max_blocks);
    const std::size_t blocks = parallel_blocks(source_.count, [&](std::size_t b, std::size_t begin,
                                                                  std::size_t end) {
      Eigen::Matrix<double, Dim, 1> low, high;
      low.setConstant(std::numeric_limits<double>::infinity());
      high.setConstant(-std::numeric_limits<double>::infinity());
      for (std::size_t i = begin; i < end; ++i)
        for (int d = 0; d < Dim; ++d) {
          low[d] = std::min(low[d], source_.coordinate[d][i]);
          high[d] = std::max(high[d], source_.coordinate[d][i]);
        }
      block_lower[b] = low;
      block_upper[b] = high;
    });
    lower_.setConstant(std::numeric_limits<double>::infinity());
    Eigen::Matrix<double, Dim, 1> upper;
    upper.setConstant(-std::numeric_limits<double>::infinity());
    for (std::size_t b = 0; b < blocks; ++b) {
      lower_ = lower_.cwiseMin(block_lower[b]);
      upper = upper.cwiseMax(block_upper[b]);
    }
    if (source_.count == 0) {
      lower_.setZero();
      upper.setZero();
    }
    for (int d = 0; d < Dim; ++d)
      if (!std::isfinite(upper[d] - lower_[d]))
        throw std::invalid_argument("neighbour search: the points span more than the largest "
                                    "double along axis " + std::to_string(d));
    // Cells slightly larger than radius / kReach: a point exactly on the radius then
    // lies at most kReach cells away even after the rounding of the binning.
    cell_size_ = radius_ * (1.0 + 1e-9) / kReach;
    // Keep the grid within a few cells per point (a tiny radius in a large box).
    // (Cell numbers are 32-bit, like the point indices.)
    const double max_cells = std::min(4.0 * static_cast<double>(source_.count) + 64.0,
                                      static_cast<double>(UINT32_MAX) - 1.0);
    for (;;) {
      double cells = 1.0;
      for (int d = 0; d < Dim; ++d) cells *= std::floor((upper[d] - lower_[d]) / cell_size_) + 1.0;
      if (cells <= max_cells) break;
      cell_size_ *= 2.0;
      reach_ = 1;  // cells at least as large as the radius
    }
    total_cells_ = 1;
    for (int d = 0; d < Dim; ++d) {
      cells_per_axis_[d] =
          static_cast<std::int64_t>(std::floor((upper[d] - lower_[d]) / cell_size_)) + 1;
      total_cells_ *= cells_per_axis_[d];
    }
    // Counting sort of the source points by cell; keeps increasing index order within
    // each cell. In parallel without per-thread histograms: each thread owns a range of
    // cells, and counts, then places, only the points of its range, reading the points
    // in index order (so the order within a cell is the index order, whatever the
    // thread count).
    const auto cells = static_cast<std::size_t>(total_cells_);
    cell_start_.assign(cells + 1, 0);
    std::vector<std::uint32_t> cell_of(source_.count);
    parallel_for(source_.count, [&](std::size_t j) {
      cell_of[j] = static_cast<std::uint32_t>(linear_cell(cell_coordinates(source_.point(j))));
    });
    std::uint32_t* start = cell_start_.data();
    const std::uint32_t* cell = cell_of.data();
    const std::size_t count = source_.count;
    parallel_blocks(cells, [&](std::size_t, std::size_t first, std::size_t last) {
      const auto low = static_cast<std::uint32_t>(first), span = static_cast<std::uint32_t>(last - first);
      for (std::size_t j = 0; j < count; ++j)
        if (cell[j] - low < span) ++start[std::size_t{cell[j]} + 1];  // (unsigned) in range
    });
    for (std::size_t c = 0; c < cells; ++c) cell_start_[c + 1] += cell_start_[c];
    sorted_source_.resize(source_.count);
    {
      // start[c] is the fill cursor of cell c (it ends at cell c + 1's start); shifted
      // back afterwards.
      std::uint32_t* sorted = sorted_source_.data();
      parallel_blocks(cells, [&](std::size_t, std::size_t first, std::size_t last) {
        const auto low = static_cast<std::uint32_t>(first), span = static_cast<std::uint32_t>(last - first);
        for (std::size_t j = 0; j < count; ++j)
          if (cell[j] - low < span) sorted[start[cell[j]]++] = static_cast<std::uint32_t>(j);
      });
      for (std::size_t c = cells; c > 0; --c) cell_start_[c] = cell_start_[c - 1];
      cell_start_[0] = 0;
    }
    // Coordinates in cell order: the candidates of a row of cells are contiguous.
    for (int d = 0; d < Dim; ++d) sorted_coordinate_[d].resize(source_.count);
    parallel_for(source_.count, [&](std::size_t k) {
      for (int d = 0; d < Dim; ++d)
        sorted_coordinate_[d][k] = source_.coordinate[d][sorted_source_[k]];
    });
  }

  std::array<std::int64_t, Dim> cell_coordinates(const Eigen::Matrix<double, Dim, 1>& x) const {
    std::array<std::int64_t, Dim> c;
    for (int d = 0; d < Dim; ++d) {
      // Clamped before the cast: a query far outside the grid must not overflow.
      const double cell = std::floor((x[d] - lower_[d]) / cell_size_);
      c[d] = static_cast<std::int64_t>(
          std::clamp(cell, -4.0, static_cast<double>(cells_per_axis_[d]) + 3.0));
    }
    return c;
  }
  std::int64_t linear_cell(const std::array<std::int64_t, Dim>& c) const {
    std::int64_t index = 0;
    for (int d = Dim - 1; d >= 0; --d) index = index * cells_per_axis_[d] + c[d];
    return index;
  }

  /// Calls visit(j) for every source j with |x_i - x_j| <= radius (the distance of
  /// squared_distance, same order of operations), in increasing cell order. Cells
  /// adjacent along axis 0 are contiguous in the sorted arrays, so each of the
  /// 5^(Dim-1) rows of cells is one contiguous range.
  template <class Visit>
  void visit_candidates(const PointsView<Dim>& points, std::size_t i, Visit&& visit) const {
    const double radius2 = radius_ * radius_;
    for_each_range(points, i, [&](const Eigen::Matrix<double, Dim, 1>& x, std::uint32_t begin,
                                  std::uint32_t end) {
      for (std::uint32_t k = begin; k < end; ++k) {
        double d2 = 0.0;
        for (int d = 0; d < Dim; ++d) {
          const double delta = x[d] - sorted_coordinate_[d][k];
          d2 += delta * delta;
        }
        if (d2 <= radius2) visit(sorted_source_[k]);
      }
    });
  }

  /// Number of sorted sources in [begin, end) within the radius of x: the same test as
  /// visit_candidates, written without a branch so that the compiler vectorises it
  /// (-fopt-info-vec: "loop vectorized using 16 byte vectors").
  std::uint64_t count_within(const Eigen::Matrix<double, Dim, 1>& x, std::uint32_t begin,
                             std::uint32_t end) const {
    const double radius2 = radius_ * radius_;
    std::array<const double*, Dim> coordinate;
    for (int d = 0; d < Dim; ++d) coordinate[d] = sorted_coordinate_[d].data();
    // Counted in a double (exact up to 2^53): comparisons and sums then share one
    // vector type, which SSE2 needs to vectorise the loop.
    double found = 0.0;
    for (std::size_t k = begin; k < end; ++k) {
      double d2 = 0.0;
      for (int d = 0; d < Dim; ++d) {
        const double delta = x[d] - coordinate[d][k];
        d2 += delta * delta;
      }
      found += d2 <= radius2 ? 1.0 : 0.0;
    }
    return static_cast<std::uint64_t>(found);
  }

  /// Calls range(x_i, begin, end) for each row of cells along axis 0 around point i: the
  /// sorted sources [begin, end) of those cells, in increasing cell order.
  template <class Range>
  void for_each_range(const PointsView<Dim>& points, std::size_t i, Range&& range) const {
    if (source_.count == 0) return;
    const Eigen::Matrix<double, Dim, 1> x = points.point(i);
    const auto centre = cell_coordinates(x);
    std::array<std::int64_t, Dim> first, last;
    for (int d = 0; d < Dim; ++d) {
      first[d] = std::max<std::int64_t>(centre[d] - reach_, 0);
      last[d] = std::min<std::int64_t>(centre[d] + reach_, cells_per_axis_[d] - 1);
      if (first[d] > last[d]) return;  // the query point is far outside the grid
    }
    std::array<std::int64_t, Dim> c = first;
    for (;;) {
      c[0] = first[0];
      const auto begin = cell_start_[static_cast<std::size_t>(linear_cell(c))];
      c[0] = last[0];
      const auto end = cell_start_[static_cast<std::size_t>(linear_cell(c)) + 1];
      range(x, begin, end);
      int d = 1;
      while (d < Dim && ++c[d] > last[d]) {
        c[d] = first[d];
        ++d;
      }
      if (d >= Dim) break;
    }
  }

  /// Cells per radius: neighbours lie at most this many cells away.
  static constexpr std::int64_t kReach = 2;

  PointsView<Dim> source_;
  double radius_;
  std::int64_t reach_ = kReach;
  double cell_size_ = 0.0;
  Eigen::Matrix<double, Dim, 1> lower_;
  std::array<std::int64_t, Dim> cells_per_axis_{};
  std::int64_t total_cells_ = 0;
  std::vector<std::uint32_t> cell_start_;
  std::vector<std::uint32_t> sorted_source_;
  std::array<std::vector<double>, Dim> sorted_coordinate_;
};

/// Convenience: all `source` points within `radius` of each `query` point.
template <int Dim>
NeighborList cell_list_neighbors(const PointsView<Dim>& query, const PointsView<Dim>& source,
                                 double radius) {
  return CellList<Dim>(source, radius).query(query);
}

}  // namespace tsph
