// The kernel's factors of every pair of a half-step list, kept between steps while the
// kernel is evaluated in the reference configuration (SolverSettings::kernel_configuration
// = reference, the default in updated Lagrangian). There the kernel's argument is the
// initial distance |X_J - X_I|, fixed for as long as the list is, so the square root and
// the kernel's polynomials of a pair (perf, 2026-12-07: 40 % of compute_stencil's samples,
// itself 23-35 % of a 2D or 3D updated-Lagrangian step) are the same at every step. The
// first pass of compute_stencil (kernels/corrected_operators.hpp, ReferenceStencil) stores
// them, later passes read them: per pair value_factor W(q) and -slope_factor W'(q)/q, in
// packs of kLanes (a row padded like StencilWeights, its padding lanes as computed), the
// same doubles as computed, so the weights are the same bits with the cache or without
// (test KernelFactorCache.SameBitsWithAndWithout).
// Memory: 16 B per pair and padding lane, for each of the two lists, within
// SolverSettings::kernel_cache_bytes (case key solver.kernel_cache_mb) for both: each list
// caches its rows from the first on as far as its half of the budget goes, and the rows
// beyond evaluate their kernel at every step (a run of millions of particles caches a
// part; memory_estimate.hpp counts the smaller of the budget and the whole need).
#pragma once

#include "kernels/corrected_operators.hpp"
#include "kernels/simd.hpp"
#include "neighbor/neighbor_list.hpp"

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

namespace tsph {

class KernelFactorCache {
 public:
  /// Readies the cache for `list` searched at neighbour build `build` with smoothing
  /// length `h`: the same list and h as before keep what was stored; otherwise the
  /// layout is made anew (and nothing is stored yet). The rows from the first on, as many
  /// as fit in `budget_doubles` (rows(); the others evaluate their kernel at every step).
  /// Returns whether any row is cached.
  bool prepare(const NeighborList& list, std::int64_t build, double h, std::size_t budget_doubles) {
    if (build == build_ && h == h_ && list.pair_count() == pairs_ && list.query_count() == list_rows_)
      return rows_ > 0;
    build_ = build;
    h_ = h;
    pairs_ = list.pair_count();
    list_rows_ = list.query_count();
    filled_ = false;
    row_start_.assign(1, 0);
    for (std::size_t q = 0; q < list_rows_; ++q) {
      const std::size_t end = row_start_.back() + 2 * padded_size(list.neighbors(q).size());
      if (end > budget_doubles) break;
      row_start_.push_back(end);
    }
    rows_ = row_start_.size() - 1;
    // Not zero-filled: the first pass writes every double (whole packs, padding lanes too)
    // before any is read.
    factors_.reset();
    if (rows_ > 0) factors_ = std::make_unique_for_overwrite<double[]>(row_start_.back());
    else row_start_.shrink_to_fit();
    return rows_ > 0;
  }
  /// Gives row q's stencil its cached factors to read, or (before the first pass over
  /// the list is done) its place to store them; a row beyond rows() gets neither.
  /// Row q's factors: kLanes values then kLanes slopes per pack of its neighbours.
  template <int Dim>
  void attach(ReferenceStencil<Dim>& stencil, std::size_t q) {
    if (q >= rows_) return;
    double* row = factors_.get() + row_start_[q];
    if (filled_) stencil.kernel_factors = row;
    else stencil.kernel_factors_out = row;
  }
  /// After a pass over the list: every cached row's factors are stored.
  void mark_filled() { filled_ = rows_ > 0; }
  bool filled() const { return filled_; }
  std::size_t rows() const { return rows_; }

 private:
  std::int64_t build_ = -2;  ///< SolverCounters::neighbor_builds at prepare (-2: never)
  double h_ = 0.0;
  std::size_t pairs_ = 0, list_rows_ = 0, rows_ = 0;  ///< rows_: the rows cached
  bool filled_ = false;
  std::vector<std::size_t> row_start_;  ///< per row, into factors_ (rows + 1)
  std::unique_ptr<double[]> factors_;  ///< row_start_.back() doubles
};

}  // namespace tsph
