// The one neighbour-list format (DESIGN.md section 6, STYLE.md "One neighbour-list
// format"): compressed sparse rows. Row i lists, in increasing order, the indices of
// the source points within the search radius of query point i (distance <= radius,
// the points exactly on the radius included). Every search (cell list, brute force,
// and the kd-tree of a later issue) produces this and every loop consumes only this.
#pragma once

#include "engine/parallel.hpp"

#include <Eigen/Core>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace tsph {

struct NeighborList {
  std::vector<std::uint64_t> offsets{0};  ///< size query_count() + 1
  std::vector<std::uint32_t> indices;     ///< source indices, row by row

  std::size_t query_count() const { return offsets.size() - 1; }
  std::size_t pair_count() const { return indices.size(); }
  std::span<const std::uint32_t> neighbors(std::size_t i) const {
    return {indices.data() + offsets[i], indices.data() + offsets[i + 1]};
  }
  bool operator==(const NeighborList&) const = default;
};

/// Read-only view of point coordinates in structure-of-arrays form.
template <int Dim>
struct PointsView {
  std::array<const double*, Dim> coordinate{};
  std::size_t count = 0;

  Eigen::Matrix<double, Dim, 1> point(std::size_t i) const {
    Eigen::Matrix<double, Dim, 1> x;
    for (int d = 0; d < Dim; ++d) x[d] = coordinate[d][i];
    return x;
  }
};

/// Points of anything with a `position` array of Dim coordinate vectors.
template <int Dim, class HasPositions>
PointsView<Dim> points_of(const HasPositions& set) {
  PointsView<Dim> view;
  view.count = set.position[0].size();
  for (int d = 0; d < Dim; ++d) view.coordinate[d] = set.position[d].data();
  return view;
}

/// Squared distance, summed over d = 0..Dim-1 in that order. Every search uses this
/// one function so that points exactly on the radius are decided identically.
template <int Dim>
inline double squared_distance(const PointsView<Dim>& a, std::size_t i,
                               const PointsView<Dim>& b, std::size_t j) {
  double d2 = 0.0;
  for (int d = 0; d < Dim; ++d) {
    const double delta = a.coordinate[d][i] - b.coordinate[d][j];
    d2 += delta * delta;
  }
  return d2;
}

/// Throws, naming the first offending point, when a coordinate is not finite. The scan
/// runs in parallel (one block per thread); the message is found serially.
template <int Dim>
void validate_finite_points(const PointsView<Dim>& points, const char* which) {
  std::vector<char> bad(static_cast<std::size_t>(std::max(1, thread_count())), 0);
  const std::size_t blocks = parallel_blocks(points.count, [&](std::size_t b, std::size_t begin,
                                                               std::size_t end) {
    bool found = false;
    for (std::size_t i = begin; i < end; ++i)
      for (int d = 0; d < Dim; ++d) found |= !std::isfinite(points.coordinate[d][i]);
    bad[b] = found;
  });
  for (std::size_t b = 0; b < blocks; ++b) {
    if (!bad[b]) continue;
    for (std::size_t i = 0; i < points.count; ++i)
      for (int d = 0; d < Dim; ++d)
        if (!std::isfinite(points.coordinate[d][i]))
          throw std::invalid_argument(std::string("neighbour search: ") + which +
                                      " point " + std::to_string(i) + " has coordinate " +
                                      std::to_string(d) + " = " +
                                      std::to_string(points.coordinate[d][i]) +
                                      " (not finite)");
  }
}

/// Checks the query points of a subset query (CellList / KdTree::query_subset): finite
/// coordinates, and every listed row a valid query index.
template <int Dim>
void validate_subset_query(const PointsView<Dim>& points, std::span<const std::uint32_t> rows) {
  validate_finite_points(points, "query");  // the source was checked when indexed
  for (std::uint32_t i : rows)
    if (i >= points.count)
      throw std::invalid_argument("neighbour search: row " + std::to_string(i) + " of " +
                                  std::to_string(points.count) + " query points");
}

/// Checks the inputs every search shares: a positive finite radius, finite
/// coordinates, and counts that fit the 32-bit indices of the list.
template <int Dim>
void validate_search_input(const PointsView<Dim>& query, const PointsView<Dim>& source,
                           double radius) {
  if (!(radius > 0.0) || !std::isfinite(radius))
    throw std::invalid_argument("neighbour search: radius = " + std::to_string(radius) +
                                " must be positive and finite");
  if (source.count > std::size_t{UINT32_MAX})
    throw std::invalid_argument("neighbour search: " + std::to_string(source.count) +
                                " source points exceed the 32-bit index limit");
  validate_finite_points(query, "query");
  if (source.coordinate != query.coordinate || source.count != query.count)
    validate_finite_points(source, "source");  // (a set queried against itself: once)
}

/// The transposed list: row j of the result lists, in increasing order, the query
/// points i whose row in `list` holds source j. For a symmetric relation (one radius,
/// distance <= radius) this is exactly the list a search in the other direction gives
/// (tested), for two passes over the pairs instead of a search. In parallel without
/// scratch memory: each thread owns a contiguous range of sources (result rows), reads
/// every pair and counts, then fills, only the entries of its range, in row order; the
/// result does not depend on the thread count.
inline NeighborList transpose(const NeighborList& list, std::size_t source_count) {
  const std::size_t rows = list.query_count();
  if (source_count > std::size_t{UINT32_MAX} || rows > std::size_t{UINT32_MAX})
    throw std::invalid_argument("transpose: more points than 32-bit indices hold");
  const std::size_t blocks = static_cast<std::size_t>(std::max(1, thread_count()));
  NeighborList result;
  // offsets[j + 1] counts source j; after the prefix sum offsets[j] is row j's start.
  result.offsets.assign(source_count + 1, 0);
  std::uint64_t* offsets = result.offsets.data();
  const std::uint32_t* indices = list.indices.data();
  const std::size_t pairs = list.indices.size();
  parallel_for(blocks, [&](std::size_t b) {
    const std::uint32_t first = static_cast<std::uint32_t>(source_count * b / blocks);
    const std::uint32_t span = static_cast<std::uint32_t>(source_count * (b + 1) / blocks) - first;
    for (std::size_t k = 0; k < pairs; ++k) {
      const std::uint32_t j = indices[k];
      if (j - first < span) ++offsets[j + 1];  // first <= j < first + span (unsigned)
    }
  });
  for (std::size_t j = 0; j < source_count; ++j) result.offsets[j + 1] += result.offsets[j];
  if (result.offsets.back() != pairs)  // an index no block owns: not below source_count
    throw std::invalid_argument("transpose: an index is not below the source count " +
                                std::to_string(source_count));
  result.indices.resize(result.offsets.back());
  // Fill, with offsets[j] as the cursor of row j (it ends at row j + 1's start), then
  // shift the offsets back by one row.
  std::uint32_t* out = result.indices.data();
  parallel_for(blocks, [&](std::size_t b) {
    const std::uint32_t first = static_cast<std::uint32_t>(source_count * b / blocks);
    const std::uint32_t span = static_cast<std::uint32_t>(source_count * (b + 1) / blocks) - first;
    for (std::size_t i = 0; i < rows; ++i)
      for (std::uint64_t k = list.offsets[i]; k < list.offsets[i + 1]; ++k) {
        const std::uint32_t j = indices[k];
        if (j - first < span) out[offsets[j]++] = static_cast<std::uint32_t>(i);
      }
  });
  for (std::size_t j = source_count; j > 0; --j) result.offsets[j] = result.offsets[j - 1];
  result.offsets[0] = 0;
  return result;
}

}  // namespace tsph
