// Spatial ordering of a point set: the permutation that sorts the points by the cell of
// a regular grid (cells of side `cell_size`), the cells taken row by row (cell_order,
// axis 0 fastest) or along the Z curve (morton_order: the bits of the cell coordinates
// interleaved, so that nearby cells are near in every direction, not only along axis 0),
// and within a cell by index. Applied through ParticleSet::permute before a run, it puts particles that are
// neighbours in space near each other in memory, so that the gathers of the half-steps
// hit the caches (bench/RESULTS.md measures what a disordered set costs).
#pragma once

#include "neighbor/neighbor_list.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace tsph {

/// `order[k]` = index of the point that goes to position k (ParticleSet::permute's
/// convention). Stable: points of one cell keep their relative order.
/// The order SolverSettings::spatial_order sorts the particle sets into.
enum class SpatialOrder { none, cells, morton };

inline std::string_view to_string(SpatialOrder order) {
  return order == SpatialOrder::none ? "none" : order == SpatialOrder::cells ? "cells" : "morton";
}

namespace detail {

/// Cell coordinates of every point on a grid of cells no smaller than `cell_size`,
/// enlarged (doubled) until there are at most 4 cells per point, or `max_cells_per_axis`
/// along an axis. Calls key_of(cells_per_axis, cell coordinates) per point and returns
/// the permutation sorting the points by that key (stable).
template <int Dim, class KeyOf>
std::vector<std::uint32_t> order_by_cell(const PointsView<Dim>& points, double cell_size,
                                         double max_cells_per_axis, KeyOf key_of, const char* what) {
  validate_search_input(points, points, cell_size);
  if (points.count == 0) return {};
  std::array<double, Dim> lower, upper;
  lower.fill(std::numeric_limits<double>::infinity());
  upper.fill(-std::numeric_limits<double>::infinity());
  for (std::size_t i = 0; i < points.count; ++i)
    for (int d = 0; d < Dim; ++d) {
      lower[d] = std::min(lower[d], points.coordinate[d][i]);
      upper[d] = std::max(upper[d], points.coordinate[d][i]);
    }
  for (int d = 0; d < Dim; ++d)
    if (!std::isfinite(upper[d] - lower[d]))
      throw std::invalid_argument(std::string(what) + ": the points span more than the largest double "
                                  "along axis " + std::to_string(d));
  // Cells no smaller than needed to keep their number within 4 per point.
  double size = cell_size;
  const double max_cells = 4.0 * static_cast<double>(points.count) + 64.0;
  std::array<std::uint64_t, Dim> cells{};
  for (;;) {
    double total = 1.0, widest = 0.0;
    for (int d = 0; d < Dim; ++d) {
      const double along = std::floor((upper[d] - lower[d]) / size) + 1.0;
      total *= along;
      widest = std::max(widest, along);
    }
    if (total <= max_cells && widest <= max_cells_per_axis) break;
    size *= 2.0;
  }
  for (int d = 0; d < Dim; ++d)
    cells[d] = static_cast<std::uint64_t>(std::floor((upper[d] - lower[d]) / size)) + 1;
  std::vector<std::uint64_t> key(points.count);
  for (std::size_t i = 0; i < points.count; ++i) {
    std::array<std::uint64_t, Dim> c;
    for (int d = 0; d < Dim; ++d)
      c[d] = std::min<std::uint64_t>(
          cells[d] - 1,
          static_cast<std::uint64_t>(std::floor((points.coordinate[d][i] - lower[d]) / size)));
    key[i] = key_of(cells, c);
  }
  std::vector<std::uint32_t> order(points.count);
  for (std::size_t i = 0; i < points.count; ++i) order[i] = static_cast<std::uint32_t>(i);
  std::stable_sort(order.begin(), order.end(),
                   [&key](std::uint32_t a, std::uint32_t b) { return key[a] < key[b]; });
  return order;
}

}  // namespace detail

/// `order[k]` = index of the point that goes to position k (ParticleSet::permute's
/// convention). Stable: points of one cell keep their relative order.
template <int Dim>
std::vector<std::uint32_t> cell_order(const PointsView<Dim>& points, double cell_size) {
  return detail::order_by_cell<Dim>(
      points, cell_size, std::numeric_limits<double>::infinity(),
      [](const std::array<std::uint64_t, Dim>& cells, const std::array<std::uint64_t, Dim>& c) {
        std::uint64_t k = 0;
        for (int d = Dim - 1; d >= 0; --d) k = k * cells[d] + c[d];
        return k;
      },
      "cell order");
}

/// Morton (Z-order) key: bit b of cell coordinate d goes to bit Dim b + d.
template <int Dim>
std::uint64_t morton_key(const std::array<std::uint64_t, Dim>& c) {
  constexpr int bits = 64 / Dim;
  std::uint64_t key = 0;
  for (int b = 0; b < bits; ++b)
    for (int d = 0; d < Dim; ++d) key |= ((c[d] >> b) & 1u) << (Dim * b + d);
  return key;
}

/// Like cell_order, the cells taken along the Z curve (morton_key). Cells are enlarged
/// if needed so that each axis has at most 2^(64 / Dim) of them.
template <int Dim>
std::vector<std::uint32_t> morton_order(const PointsView<Dim>& points, double cell_size) {
  return detail::order_by_cell<Dim>(
      points, cell_size, std::ldexp(1.0, 64 / Dim),
      [](const std::array<std::uint64_t, Dim>&, const std::array<std::uint64_t, Dim>& c) {
        return morton_key<Dim>(c);
      },
      "Morton order");
}

/// cell_order or morton_order (an empty order for SpatialOrder::none).
template <int Dim>
std::vector<std::uint32_t> spatial_order(SpatialOrder kind, const PointsView<Dim>& points,
                                         double cell_size) {
  if (kind == SpatialOrder::cells) return cell_order<Dim>(points, cell_size);
  if (kind == SpatialOrder::morton) return morton_order<Dim>(points, cell_size);
  return {};
}

}  // namespace tsph
