// Brute-force neighbour search: O(N_query * N_source), the reference the fast
// searches are tested against.
#pragma once

#include "neighbor/neighbor_list.hpp"

namespace tsph {

template <int Dim>
NeighborList brute_force_neighbors(const PointsView<Dim>& query,
                                   const PointsView<Dim>& source, double radius) {
  validate_search_input(query, source, radius);
  const double radius2 = radius * radius;
  std::vector<std::uint32_t> counts(query.count + 1, 0), indices;
  for (std::size_t i = 0; i < query.count; ++i)
    for (std::size_t j = 0; j < source.count; ++j)
      if (squared_distance(query, i, source, j) <= radius2) {
        indices.push_back(static_cast<std::uint32_t>(j));
        ++counts[i + 1];
      }
  NeighborList list = NeighborList::from_row_counts(std::move(counts));
  list.indices = std::move(indices);
  return list;
}

}  // namespace tsph
