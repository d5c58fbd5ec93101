// The one neighbour-list format (docs/architecture.md, docs/conventions.md "One neighbour-list
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

/// Row starts are 32-bit while the pair count fits in 32 bits (4 B per row instead of
/// 8: 12 B per real particle with the skin's lists; bench/RESULTS.md, Memory), 64-bit
/// beyond (wide_offsets); one predictable branch per row read.
struct NeighborList {
  std::vector<std::uint32_t> offsets{0};    ///< row starts, size query_count() + 1; empty if wide()
  std::vector<std::uint64_t> wide_offsets;  ///< the row starts of a list of 2^32 pairs or more
  std::vector<std::uint32_t> indices;       ///< source indices, row by row

  bool wide() const { return !wide_offsets.empty(); }
  std::size_t query_count() const { return (wide() ? wide_offsets.size() : offsets.size()) - 1; }
  std::size_t pair_count() const { return indices.size(); }
  /// Index into `indices` of row i's first entry (i = query_count(): the pair count).
  std::uint64_t row_begin(std::size_t i) const { return wide() ? wide_offsets[i] : offsets[i]; }
  std::span<const std::uint32_t> neighbors(std::size_t i) const {
    if (wide()) return {indices.data() + wide_offsets[i], indices.data() + wide_offsets[i + 1]};
    return {indices.data() + offsets[i], indices.data() + offsets[i + 1]};
  }
  bool operator==(const NeighborList&) const = default;

  /// The list whose row i holds counts[i + 1] entries (counts[0] = 0, one count per
  /// row after it): the counts become the row starts (their prefix sums, in place while
  /// the pair count is at most `narrow_limit`, else 64-bit; tests lower the limit), and
  /// `indices` is sized for the pairs, for the caller to fill row i from row_begin(i).
  static NeighborList from_row_counts(std::vector<std::uint32_t> counts,
                                      std::uint64_t narrow_limit = UINT32_MAX) {
    if (counts.empty()) counts.push_back(0);
    std::uint64_t pairs = 0;
    for (std::size_t i = 1; i < counts.size(); ++i) pairs += counts[i];
    NeighborList list;
    if (pairs <= narrow_limit && pairs <= UINT32_MAX) {
      counts[0] = 0;
      for (std::size_t i = 1; i < counts.size(); ++i) counts[i] += counts[i - 1];
      list.offsets = std::move(counts);
    } else {
      list.offsets.clear();
      list.wide_offsets.resize(counts.size());
      list.wide_offsets[0] = 0;
      for (std::size_t i = 1; i < counts.size(); ++i) list.wide_offsets[i] = list.wide_offsets[i - 1] + counts[i];
      std::vector<std::uint32_t>().swap(counts);
    }
    list.indices.resize(pairs);
    return list;
  }
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

/// The same view of a set's initial positions X (the reference configuration).
template <int Dim, class HasPositions>
PointsView<Dim> initial_points_of(const HasPositions& set) {
  PointsView<Dim> view;
  view.count = set.initial_position[0].size();
  for (int d = 0; d < Dim; ++d) view.coordinate[d] = set.initial_position[d].data();
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
/// `narrow_limit`: as in NeighborList::from_row_counts.
inline NeighborList transpose(const NeighborList& list, std::size_t source_count,
                              std::uint64_t narrow_limit = UINT32_MAX) {
  const std::size_t rows = list.query_count();
  if (source_count > std::size_t{UINT32_MAX} || rows > std::size_t{UINT32_MAX})
    throw std::invalid_argument("transpose: more points than 32-bit indices hold");
  const std::size_t blocks = static_cast<std::size_t>(std::max(1, thread_count()));
  // counts[j + 1] counts source j (a row of the result).
  std::vector<std::uint32_t> counts(source_count + 1, 0);
  const std::uint32_t* indices = list.indices.data();
  const std::size_t pairs = list.indices.size();
  parallel_for(blocks, [&](std::size_t b) {
    const std::uint32_t first = static_cast<std::uint32_t>(source_count * b / blocks);
    const std::uint32_t span = static_cast<std::uint32_t>(source_count * (b + 1) / blocks) - first;
    for (std::size_t k = 0; k < pairs; ++k) {
      const std::uint32_t j = indices[k];
      if (j - first < span) ++counts[j + 1];  // first <= j < first + span (unsigned)
    }
  });
  NeighborList result = NeighborList::from_row_counts(std::move(counts), narrow_limit);
  if (result.pair_count() != pairs)  // an index no block owns: not below source_count
    throw std::invalid_argument("transpose: an index is not below the source count " +
                                std::to_string(source_count));
  // Fill, with the row starts as the cursor of each row j (it ends at row j + 1's
  // start), then shift the row starts back by one row.
  std::uint32_t* out = result.indices.data();
  auto fill = [&](auto* cursor) {
    parallel_for(blocks, [&](std::size_t b) {
      const std::uint32_t first = static_cast<std::uint32_t>(source_count * b / blocks);
      const std::uint32_t span = static_cast<std::uint32_t>(source_count * (b + 1) / blocks) - first;
      for (std::size_t i = 0; i < rows; ++i)
        for (const std::uint32_t j : list.neighbors(i))
          if (j - first < span) out[cursor[j]++] = static_cast<std::uint32_t>(i);
    });
    for (std::size_t j = source_count; j > 0; --j) cursor[j] = cursor[j - 1];
    cursor[0] = 0;
  };
  if (result.wide()) fill(result.wide_offsets.data());
  else fill(result.offsets.data());
  return result;
}

}  // namespace tsph
