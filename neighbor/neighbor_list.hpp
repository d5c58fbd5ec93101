// The one neighbour-list format (DESIGN.md section 6, STYLE.md "One neighbour-list
// format"): compressed sparse rows. Row i lists, in increasing order, the indices of
// the source points within the search radius of query point i (distance <= radius,
// the points exactly on the radius included). Every search (cell list, brute force,
// and the kd-tree of a later issue) produces this and every loop consumes only this.
#pragma once

#include <Eigen/Core>

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>
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
  auto check = [](const PointsView<Dim>& points, const char* which) {
    for (std::size_t i = 0; i < points.count; ++i)
      for (int d = 0; d < Dim; ++d)
        if (!std::isfinite(points.coordinate[d][i]))
          throw std::invalid_argument(std::string("neighbour search: ") + which +
                                      " point " + std::to_string(i) + " has coordinate " +
                                      std::to_string(d) + " = " +
                                      std::to_string(points.coordinate[d][i]) +
                                      " (not finite)");
  };
  check(query, "query");
  check(source, "source");
}

}  // namespace tsph
