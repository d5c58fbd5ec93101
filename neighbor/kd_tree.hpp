// Kd-tree neighbour search on nanoflann, producing the same CSR NeighborList as the
// cell list (rows sorted, points exactly on the radius included).
//
// nanoflann's L2 metric takes and returns *squared* distances, and its radius result
// set keeps d2 < r2 (strict). We search with a slightly enlarged squared radius and then
// keep exactly the points with squared_distance <= r^2, computed by the one function
// every search shares, so that kd-tree, cell list and brute force agree bit for bit.
// The tree is built serially (nanoflann); queries run in parallel.
#pragma once

#include "engine/parallel.hpp"
#include "neighbor/neighbor_list.hpp"

#include <nanoflann.hpp>

#include <algorithm>
#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

namespace tsph {

template <int Dim>
class KdTree {
 public:
  /// Indexes `source` (a view: the arrays must outlive the tree).
  KdTree(const PointsView<Dim>& source, double radius)
      : adaptor_{source}, radius_(radius) {
    validate_search_input(source, source, radius);
    if (source.count > 0)
      index_ = std::make_unique<Index>(Dim, adaptor_, nanoflann::KDTreeSingleIndexAdaptorParams(16));
  }

  // nanoflann keeps a reference to adaptor_: a copied or moved tree would dangle.
  KdTree(const KdTree&) = delete;
  KdTree& operator=(const KdTree&) = delete;
  KdTree(KdTree&&) = delete;
  KdTree& operator=(KdTree&&) = delete;

  double radius() const { return radius_; }

  /// All source points within `radius` of each query point, rows sorted.
  NeighborList query(const PointsView<Dim>& points) const {
    validate_search_input(points, adaptor_.points, radius_);
    NeighborList list;
    list.offsets.assign(points.count + 1, 0);
    std::vector<std::vector<std::uint32_t>> rows(points.count);
    const double radius2 = radius_ * radius_;
    const double search2 = radius2 * (1.0 + 1e-12);
    if (index_)
      parallel_for(points.count, [&](std::size_t i) {
        double x[Dim];
        for (int d = 0; d < Dim; ++d) x[d] = points.coordinate[d][i];
        std::vector<std::pair<std::uint32_t, double>> matches;
        index_->radiusSearch(x, search2, matches, nanoflann::SearchParams(32, 0.0f, false));
        auto& row = rows[i];
        row.reserve(matches.size());
        for (const auto& match : matches)
          if (squared_distance(points, i, adaptor_.points, match.first) <= radius2)
            row.push_back(match.first);
        std::sort(row.begin(), row.end());
      });
    for (std::size_t i = 0; i < points.count; ++i)
      list.offsets[i + 1] = list.offsets[i] + rows[i].size();
    list.indices.resize(list.offsets.back());
    parallel_for(points.count, [&](std::size_t i) {
      std::copy(rows[i].begin(), rows[i].end(), list.indices.begin() + static_cast<std::ptrdiff_t>(list.offsets[i]));
    });
    return list;
  }

 private:
  /// nanoflann's dataset concept over the SoA coordinates.
  struct Adaptor {
    PointsView<Dim> points;
    std::size_t kdtree_get_point_count() const { return points.count; }
    double kdtree_get_pt(std::size_t i, std::size_t d) const { return points.coordinate[d][i]; }
    template <class BoundingBox>
    bool kdtree_get_bbox(BoundingBox&) const { return false; }
  };
  using Index = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, Adaptor>,
                                                    Adaptor, Dim, std::uint32_t>;

  Adaptor adaptor_;
  double radius_;
  std::unique_ptr<Index> index_;
};

/// Convenience: all `source` points within `radius` of each `query` point.
template <int Dim>
NeighborList kd_tree_neighbors(const PointsView<Dim>& query, const PointsView<Dim>& source,
                               double radius) {
  return KdTree<Dim>(source, radius).query(query);
}

}  // namespace tsph
