// Spatial ordering of a point set: the permutation that sorts the points by the cell of
// a regular grid (cells of side `cell_size`, axis 0 fastest) and, within a cell, by
// index. Applied through ParticleSet::permute before a run, it puts particles that are
// neighbours in space near each other in memory, so that the gathers of the half-steps
// hit the caches (bench/RESULTS.md measures what a disordered set costs).
#pragma once

#include "neighbor/neighbor_list.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace tsph {

/// `order[k]` = index of the point that goes to position k (ParticleSet::permute's
/// convention). Stable: points of one cell keep their relative order.
template <int Dim>
std::vector<std::uint32_t> cell_order(const PointsView<Dim>& points, double cell_size) {
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
      throw std::invalid_argument("cell order: the points span more than the largest double "
                                  "along axis " + std::to_string(d));
  // Cells no smaller than needed to keep their number within 4 per point.
  double size = cell_size;
  const double max_cells = 4.0 * static_cast<double>(points.count) + 64.0;
  std::array<std::uint64_t, Dim> cells{};
  for (;;) {
    double total = 1.0;
    for (int d = 0; d < Dim; ++d) total *= std::floor((upper[d] - lower[d]) / size) + 1.0;
    if (total <= max_cells) break;
    size *= 2.0;
  }
  for (int d = 0; d < Dim; ++d)
    cells[d] = static_cast<std::uint64_t>(std::floor((upper[d] - lower[d]) / size)) + 1;
  std::vector<std::uint64_t> key(points.count);
  for (std::size_t i = 0; i < points.count; ++i) {
    std::uint64_t k = 0;
    for (int d = Dim - 1; d >= 0; --d)
      k = k * cells[d] + std::min<std::uint64_t>(
                             cells[d] - 1, static_cast<std::uint64_t>(std::floor(
                                               (points.coordinate[d][i] - lower[d]) / size)));
    key[i] = k;
  }
  std::vector<std::uint32_t> order(points.count);
  for (std::size_t i = 0; i < points.count; ++i) order[i] = static_cast<std::uint32_t>(i);
  std::stable_sort(order.begin(), order.end(),
                   [&key](std::uint32_t a, std::uint32_t b) { return key[a] < key[b]; });
  return order;
}

}  // namespace tsph
