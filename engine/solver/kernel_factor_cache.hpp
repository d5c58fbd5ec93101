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
// Memory: 16 B per pair and padding lane, for each of the two lists; used only where both
// fit in SolverSettings::kernel_cache_bytes (case key solver.kernel_cache_mb), else not at
// all (memory_estimate.hpp counts the smaller of the two).
#pragma once

#include "kernels/simd.hpp"
#include "neighbor/neighbor_list.hpp"

#include <cstddef>
#include <cstdint>
#include <vector>

namespace tsph {

class KernelFactorCache {
 public:
  /// Readies the cache for `list` searched at neighbour build `build` with smoothing
  /// length `h`: the same list and h as before keep what was stored; otherwise the
  /// layout is made anew (and nothing is stored yet). Returns whether the cache is used:
  /// false where its doubles would exceed `budget_doubles` (then it holds nothing).
  bool prepare(const NeighborList& list, std::int64_t build, double h, std::size_t budget_doubles) {
    if (build == build_ && h == h_ && list.pair_count() == pairs_ && list.query_count() == rows_)
      return used_;
    build_ = build;
    h_ = h;
    pairs_ = list.pair_count();
    rows_ = list.query_count();
    filled_ = false;
    std::size_t doubles = 0;
    for (std::size_t q = 0; q < rows_; ++q) doubles += 2 * padded_size(list.neighbors(q).size());
    used_ = doubles <= budget_doubles;
    row_start_.clear();
    factors_.clear();
    if (!used_) {
      row_start_.shrink_to_fit();
      factors_.shrink_to_fit();
      return false;
    }
    row_start_.resize(rows_ + 1);
    row_start_[0] = 0;
    for (std::size_t q = 0; q < rows_; ++q) row_start_[q + 1] = row_start_[q] + 2 * padded_size(list.neighbors(q).size());
    factors_.assign(doubles, 0.0);
    return true;
  }
  /// Whether every row's factors are stored (after the first pass over the list).
  bool filled() const { return filled_; }
  void mark_filled() { filled_ = used_; }
  /// Row q's factors: kLanes values then kLanes slopes per pack of its neighbours.
  const double* row(std::size_t q) const { return factors_.data() + row_start_[q]; }
  double* row_to_fill(std::size_t q) { return factors_.data() + row_start_[q]; }
  std::size_t rows() const { return rows_; }

 private:
  std::int64_t build_ = -2;  ///< SolverCounters::neighbor_builds at prepare (-2: never)
  double h_ = 0.0;
  std::size_t pairs_ = 0, rows_ = 0;
  bool used_ = false, filled_ = false;
  std::vector<std::size_t> row_start_;  ///< per row, into factors_ (rows + 1)
  std::vector<double> factors_;
};

}  // namespace tsph
