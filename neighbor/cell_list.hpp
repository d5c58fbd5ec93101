// Cell-list neighbour search: source points binned in a regular grid of cells no
// smaller than the radius, so that the neighbours of a query point lie in the 3^Dim
// cells around its own. Produces the CSR NeighborList of neighbor_list.hpp.
#pragma once

#include "engine/parallel.hpp"
#include "neighbor/neighbor_list.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

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
    validate_search_input(points, source_, radius_);
    NeighborList list;
    list.offsets.assign(points.count + 1, 0);
    // Pass 1: count; pass 2: fill. Each row is written by one thread only.
    parallel_for(points.count, [&](std::size_t i) {
      std::uint64_t found = 0;
      visit_candidates(points, i, [&](std::uint32_t) { ++found; });
      list.offsets[i + 1] = found;
    });
    for (std::size_t i = 0; i < points.count; ++i) list.offsets[i + 1] += list.offsets[i];
    list.indices.resize(list.offsets.back());
    parallel_for(points.count, [&](std::size_t i) {
      std::uint32_t* row = list.indices.data() + list.offsets[i];
      std::size_t k = 0;
      visit_candidates(points, i, [&](std::uint32_t j) { row[k++] = j; });
      std::sort(row, row + k);
    });
    return list;
  }

 private:
  void build() {
    lower_.setConstant(std::numeric_limits<double>::infinity());
    Eigen::Matrix<double, Dim, 1> upper;
    upper.setConstant(-std::numeric_limits<double>::infinity());
    for (std::size_t i = 0; i < source_.count; ++i)
      for (int d = 0; d < Dim; ++d) {
        lower_[d] = std::min(lower_[d], source_.coordinate[d][i]);
        upper[d] = std::max(upper[d], source_.coordinate[d][i]);
      }
    if (source_.count == 0) {
      lower_.setZero();
      upper.setZero();
    }
    for (int d = 0; d < Dim; ++d)
      if (!std::isfinite(upper[d] - lower_[d]))
        throw std::invalid_argument("neighbour search: the points span more than the largest "
                                    "double along axis " + std::to_string(d));
    // Cells slightly larger than the radius: a point exactly on the radius then lies
    // at most one cell away even after the rounding of the binning.
    cell_size_ = radius_ * (1.0 + 1e-9);
    // Keep the grid within a few cells per point (a tiny radius in a large box).
    const double max_cells = 4.0 * static_cast<double>(source_.count) + 64.0;
    for (;;) {
      double cells = 1.0;
      for (int d = 0; d < Dim; ++d) cells *= std::floor((upper[d] - lower_[d]) / cell_size_) + 1.0;
      if (cells <= max_cells) break;
      cell_size_ *= 2.0;
    }
    total_cells_ = 1;
    for (int d = 0; d < Dim; ++d) {
      cells_per_axis_[d] =
          static_cast<std::int64_t>(std::floor((upper[d] - lower_[d]) / cell_size_)) + 1;
      total_cells_ *= cells_per_axis_[d];
    }
    // Counting sort of the source points by cell; keeps increasing index order
    // within each cell.
    cell_start_.assign(static_cast<std::size_t>(total_cells_) + 1, 0);
    std::vector<std::int64_t> cell_of(source_.count);
    for (std::size_t j = 0; j < source_.count; ++j) {
      cell_of[j] = linear_cell(cell_coordinates(source_.point(j)));
      ++cell_start_[static_cast<std::size_t>(cell_of[j]) + 1];
    }
    for (std::size_t c = 0; c < static_cast<std::size_t>(total_cells_); ++c)
      cell_start_[c + 1] += cell_start_[c];
    sorted_source_.resize(source_.count);
    std::vector<std::uint32_t> fill(cell_start_.begin(), cell_start_.end() - 1);
    for (std::size_t j = 0; j < source_.count; ++j)
      sorted_source_[fill[static_cast<std::size_t>(cell_of[j])]++] = static_cast<std::uint32_t>(j);
  }

  std::array<std::int64_t, Dim> cell_coordinates(const Eigen::Matrix<double, Dim, 1>& x) const {
    std::array<std::int64_t, Dim> c;
    for (int d = 0; d < Dim; ++d) {
      // Clamped before the cast: a query far outside the grid must not overflow.
      const double cell = std::floor((x[d] - lower_[d]) / cell_size_);
      c[d] = static_cast<std::int64_t>(
          std::clamp(cell, -2.0, static_cast<double>(cells_per_axis_[d]) + 1.0));
    }
    return c;
  }
  std::int64_t linear_cell(const std::array<std::int64_t, Dim>& c) const {
    std::int64_t index = 0;
    for (int d = Dim - 1; d >= 0; --d) index = index * cells_per_axis_[d] + c[d];
    return index;
  }

  /// Calls visit(j) for every source j with |x_i - x_j| <= radius, cell by cell.
  template <class Visit>
  void visit_candidates(const PointsView<Dim>& points, std::size_t i, Visit&& visit) const {
    if (source_.count == 0) return;
    const auto centre = cell_coordinates(points.point(i));
    std::array<std::int64_t, Dim> first, last;
    for (int d = 0; d < Dim; ++d) {
      first[d] = std::max<std::int64_t>(centre[d] - 1, 0);
      last[d] = std::min<std::int64_t>(centre[d] + 1, cells_per_axis_[d] - 1);
      if (first[d] > last[d]) return;  // the query point is far outside the grid
    }
    const double radius2 = radius_ * radius_;
    std::array<std::int64_t, Dim> c = first;
    for (;;) {
      const auto cell = static_cast<std::size_t>(linear_cell(c));
      for (std::uint32_t k = cell_start_[cell]; k < cell_start_[cell + 1]; ++k) {
        const std::uint32_t j = sorted_source_[k];
        if (squared_distance(points, i, source_, j) <= radius2) visit(j);
      }
      int d = 0;
      while (d < Dim && ++c[d] > last[d]) {
        c[d] = first[d];
        ++d;
      }
      if (d == Dim) break;
    }
  }

  PointsView<Dim> source_;
  double radius_;
  double cell_size_ = 0.0;
  Eigen::Matrix<double, Dim, 1> lower_;
  std::array<std::int64_t, Dim> cells_per_axis_{};
  std::int64_t total_cells_ = 0;
  std::vector<std::uint32_t> cell_start_;
  std::vector<std::uint32_t> sorted_source_;
};

/// Convenience: all `source` points within `radius` of each `query` point.
template <int Dim>
NeighborList cell_list_neighbors(const PointsView<Dim>& query, const PointsView<Dim>& source,
                                 double radius) {
  return CellList<Dim>(source, radius).query(query);
}

}  // namespace tsph
