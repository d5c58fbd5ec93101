// Kd-tree neighbour search on nanoflann, producing the same CSR NeighborList as the
// cell list (rows sorted, points exactly on the radius included).
//
// nanoflann's L2 metric takes and returns *squared* distances, and its radius result
// set keeps d2 < r2 (strict). We search with a slightly enlarged squared radius and then
// keep exactly the points with squared_distance <= r^2, computed by the one function
// every search shares, so that kd-tree, cell list and brute force agree bit for bit.
//
// Parallel build: nanoflann 1.4.2 (Debian 12) builds one tree serially. We split the
// source points into slabs of equal count along the axis of largest extent (quantiles
// by nth_element) and build one tree per slab, concurrently (one slab per thread). A
// query searches every slab whose extent along that axis lies within the radius of the
// query point (one or two for a slab wider than the radius). Slab trees return slab-local
// indices, mapped back to source indices; rows are then filtered and sorted as before,
// so the list does not depend on the number of slabs (tested).
#pragma once

#include "engine/parallel.hpp"
#include "neighbor/neighbor_list.hpp"

#include <nanoflann.hpp>

#include <algorithm>
#include <cstdint>
#include <limits>
#include <memory>
#include <numeric>
#include <span>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace tsph {

template <int Dim>
class KdTree {
 public:
  /// Indexes `source` (a view: the arrays must outlive the tree) in `slab_count` trees
  /// built concurrently (0: one per OpenMP thread).
  KdTree(const PointsView<Dim>& source, double radius, std::size_t slab_count = 0)
      : source_(source), radius_(radius) {
    validate_search_input(source, source, radius);
    if (source.count == 0) return;
    if (slab_count == 0) slab_count = static_cast<std::size_t>(std::max(1, thread_count()));
    slab_count = std::min(slab_count, source.count);
    // The axis of largest extent.
    std::array<double, Dim> lower, upper;
    lower.fill(std::numeric_limits<double>::infinity());
    upper.fill(-std::numeric_limits<double>::infinity());
    for (std::size_t i = 0; i < source.count; ++i)
      for (int d = 0; d < Dim; ++d) {
        lower[d] = std::min(lower[d], source.coordinate[d][i]);
        upper[d] = std::max(upper[d], source.coordinate[d][i]);
      }
    axis_ = 0;
    for (int d = 1; d < Dim; ++d)
      if (upper[d] - lower[d] > upper[axis_] - lower[axis_]) axis_ = d;
    // Slabs of equal count: successive nth_element on the remaining range.
    std::vector<std::uint32_t> order(source.count);
    std::iota(order.begin(), order.end(), std::uint32_t{0});
    const double* along = source.coordinate[axis_];
    auto by_coordinate = [along](std::uint32_t a, std::uint32_t b) {
      return along[a] < along[b] || (along[a] == along[b] && a < b);
    };
    std::vector<std::size_t> cut(slab_count + 1, 0);
    for (std::size_t s = 1; s < slab_count; ++s) {
      cut[s] = source.count * s / slab_count;
      std::nth_element(order.begin() + static_cast<std::ptrdiff_t>(cut[s - 1]),
                       order.begin() + static_cast<std::ptrdiff_t>(cut[s]), order.end(), by_coordinate);
    }
    cut[slab_count] = source.count;
    slabs_.resize(slab_count);
    for (std::size_t s = 0; s < slab_count; ++s) {
      Slab& slab = slabs_[s];
      slab.adaptor.points = source;
      slab.adaptor.members.assign(order.begin() + static_cast<std::ptrdiff_t>(cut[s]),
                                  order.begin() + static_cast<std::ptrdiff_t>(cut[s + 1]));
      slab.lower = std::numeric_limits<double>::infinity();
      slab.upper = -std::numeric_limits<double>::infinity();
      for (std::uint32_t j : slab.adaptor.members) {
        slab.lower = std::min(slab.lower, along[j]);
        slab.upper = std::max(slab.upper, along[j]);
      }
    }
    // One tree per slab, built concurrently (nanoflann's constructor builds it).
    parallel_for(slab_count, [&](std::size_t s) {
      slabs_[s].index = std::make_unique<Index>(Dim, slabs_[s].adaptor,
                                                nanoflann::KDTreeSingleIndexAdaptorParams(16));
    });
  }

  // nanoflann keeps a reference to each slab's adaptor: a copied or moved tree would dangle.
  KdTree(const KdTree&) = delete;
  KdTree& operator=(const KdTree&) = delete;
  KdTree(KdTree&&) = delete;
  KdTree& operator=(KdTree&&) = delete;

  double radius() const { return radius_; }
  std::size_t slab_count() const { return slabs_.size(); }

  /// All source points within `radius` of each query point, rows sorted.
  NeighborList query(const PointsView<Dim>& points) const {
    validate_finite_points(points, "query");  // the source was checked when indexed
    return query_rows(points, points.count, [](std::size_t i) { return i; }, false);
  }

  /// Rows only for the query points listed in `rows`; the other rows are empty. With
  /// `exclude_self`, source j == query i is left out (CellList::query_subset's contract).
  NeighborList query_subset(const PointsView<Dim>& points, std::span<const std::uint32_t> rows,
                            bool exclude_self) const {
    validate_subset_query(points, rows);
    return query_rows(points, rows.size(), [rows](std::size_t k) { return std::size_t{rows[k]}; },
                      exclude_self);
  }

 private:
  template <class RowOf>
  NeighborList query_rows(const PointsView<Dim>& points, std::size_t row_count, RowOf row_of,
                          bool exclude_self) const {
    std::vector<std::vector<std::uint32_t>> rows(points.count);
    const double radius2 = radius_ * radius_;
    const double search2 = radius2 * (1.0 + 1e-12);
    const double reach = radius_ * (1.0 + 1e-9);
    if (!slabs_.empty())
      parallel_for(row_count, [&](std::size_t k) {
        const std::size_t i = row_of(k);
        double x[Dim];
        for (int d = 0; d < Dim; ++d) x[d] = points.coordinate[d][i];
        auto& row = rows[i];
        CandidateResult result{search2, {}};
        for (const Slab& slab : slabs_) {
          if (x[axis_] < slab.lower - reach || x[axis_] > slab.upper + reach) continue;
          result.found.clear();
          slab.index->radiusSearchCustomCallback(x, result, nanoflann::SearchParams(32, 0.0f, false));
          for (std::uint32_t local : result.found) {
            const std::uint32_t j = slab.adaptor.members[local];
            if (!(exclude_self && j == i) && squared_distance(points, i, source_, j) <= radius2)
              row.push_back(j);
          }
        }
        std::sort(row.begin(), row.end());
      });
    std::vector<std::uint32_t> counts(points.count + 1, 0);
    for (std::size_t i = 0; i < points.count; ++i) counts[i + 1] = static_cast<std::uint32_t>(rows[i].size());
    NeighborList list = NeighborList::from_row_counts(std::move(counts));
    parallel_for(points.count, [&](std::size_t i) {
      std::copy(rows[i].begin(), rows[i].end(), list.indices.begin() + static_cast<std::ptrdiff_t>(list.row_begin(i)));
    });
    return list;
  }

  /// nanoflann's dataset concept over the SoA coordinates of one slab's members.
  struct Adaptor {
    PointsView<Dim> points;
    std::vector<std::uint32_t> members;  ///< source indices of the slab
    std::size_t kdtree_get_point_count() const { return members.size(); }
    double kdtree_get_pt(std::size_t i, std::size_t d) const { return points.coordinate[d][members[i]]; }
    template <class BoundingBox>
    bool kdtree_get_bbox(BoundingBox&) const { return false; }
  };
  using Index = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, Adaptor>,
                                                    Adaptor, Dim, std::uint32_t>;
  /// nanoflann result-set concept: keeps the slab-local indices within the search
  /// radius (strictly, like nanoflann's own), without distances.
  struct CandidateResult {
    double search2;
    std::vector<std::uint32_t> found;
    std::size_t size() const { return found.size(); }
    bool full() const { return true; }
    double worstDist() const { return search2; }
    bool addPoint(double d2, std::uint32_t index) {
      if (d2 < search2) found.push_back(index);
      return true;
    }
  };
  struct Slab {
    Adaptor adaptor;
    double lower = 0.0, upper = 0.0;  ///< extent along axis_
    std::unique_ptr<Index> index;
  };

  PointsView<Dim> source_;
  double radius_;
  int axis_ = 0;
  std::vector<Slab> slabs_;
};

/// Convenience: all `source` points within `radius` of each `query` point.
template <int Dim>
NeighborList kd_tree_neighbors(const PointsView<Dim>& query, const PointsView<Dim>& source,
                               double radius) {
  return KdTree<Dim>(source, radius).query(query);
}

}  // namespace tsph
