// Corrected SPH operators between a query point and a set of source particles
// (docs/method.md section 2): the normalised kernel for interpolation and the corrected
// gradient. Both are computed per query point from its CSR neighbour row, for any
// pair of sets (real -> virtual, virtual -> real) or within one set.
//
//  * Gradient (Bonet & Lok 1999, eq. 23 there): Gn_IJ = L_I grad_I W_IJ with
//      L_I = [ sum_J V_J grad_I W_IJ (x) (x_J - x_I) ]^-1,
//    so that sum_J V_J (f_J - f_I) Gn_IJ is exact for linear f. The matrix is
//    symmetric positive semi-definite for kernels with W' <= 0; where it is singular
//    or ill-conditioned (isolated point, collinear neighbours) the pseudo-inverse is
//    used instead, which is still exact along the directions the stencil spans, and
//    the occurrence is counted.
//  * Interpolation: `shepard` is the Shepard-normalised kernel of the seed,
//      Wn_IJ = W_IJ / sum_K V_K W_IK (exact for constants);
//    `linear` adds the first-moment correction of Liu et al. (RKPM) / Bonet & Lok's
//    "corrected kernel", W~_IJ = W_IJ (a + b . (x_J - x_I)), exact for linear fields
//    whatever the particle volumes. Where the moment matrix of a `linear` stencil is
//    singular (one neighbour, collinear neighbours) Shepard is used and counted.
//
// Weights are returned with the source volume V_J folded in, so that an interpolant
// is sum_J value[J] f_J and a gradient is sum_J gradient[J] (f_J - f_I).
#pragma once

#include "kernels/simd.hpp"
#include "kernels/smoothing_kernels.hpp"
#include "neighbor/neighbor_list.hpp"

#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <span>
#include <string_view>
#include <vector>

namespace tsph {

enum class InterpolationKind { shepard, linear };

inline std::string_view to_string(InterpolationKind kind) {
  return kind == InterpolationKind::shepard ? "shepard" : "linear";
}

/// Ill-conditioning threshold on the infinity-norm condition number of the
/// (dimensionless) correction and moment matrices.
inline constexpr double kMaxConditionNumber = 1e10;
/// Smallest det / prod(diagonal) of a correction or moment matrix taken as regular.
inline constexpr double kMinHadamardRatio = 1e-10;

/// What happened while computing one stencil; summed into run counters.
struct StencilStatus {
  bool no_neighbors = false;             ///< kernel sum is zero: nothing to interpolate
  bool interpolation_fallback = false;   ///< `linear` fell back to Shepard
  bool gradient_fallback = false;        ///< correction matrix inverted by pseudo-inverse
  double weight_squares = 0.0;           ///< sum_J Wn_IJ^2 of the interpolation weights
};

/// Per-neighbour weights of one query point, sized to its row; reused between queries
/// (scratch, one per thread: capacity is kept, so the loops allocate almost nothing).
/// Structure of arrays padded to a whole number of packs (kernels/simd.hpp) with zero
/// weights: entries k < size() belong to the row, the rest are 0.
template <int Dim>
struct StencilWeights {
  PackBuffer value;                     ///< V_J Wn_IJ
  std::array<PackBuffer, Dim> gradient;  ///< component d of V_J Gn_IJ
  std::array<PackBuffer, Dim> offset;    ///< component d of x_J - x_I (scratch)

  std::size_t size() const { return count_; }
  Eigen::Matrix<double, Dim, 1> gradient_of(std::size_t k) const {
    Eigen::Matrix<double, Dim, 1> g;
    for (int d = 0; d < Dim; ++d) g[d] = gradient[d][k];
    return g;
  }
  /// Sizes the buffers to at least padded_size(n); they only grow (no zero-fill of a
  /// row that is shorter than the last one). Called once a stencil row: the check
  /// inline, the growth (rare) out of line.
  [[gnu::always_inline]] void resize(std::size_t n) {
    count_ = n;
    const std::size_t padded = padded_size(n);
    if (value.size() < padded) [[unlikely]] grow(padded);
  }

 private:
  [[gnu::noinline]] void grow(std::size_t padded) {
    value.resize(padded);
    for (int d = 0; d < Dim; ++d) gradient[d].resize(padded), offset[d].resize(padded);
  }
  std::size_t count_ = 0;
};

/// Infinity norm (largest absolute row sum) of a small matrix, inline: Eigen's
/// cwiseAbs().rowwise().sum().maxCoeff() is an out-of-line call whose inlining the
/// compiler decides per translation unit (2.4 % of the 2D step's instructions when it
/// stopped inlining it, bench/RESULTS.md). NaN when any entry is not finite (Eigen's
/// maxCoeff skips a NaN row sum after the first row: an indefinite matrix could pass).
template <int N>
[[gnu::always_inline]] inline double infinity_norm(const Eigen::Matrix<double, N, N>& m) {
  // total: not finite when an entry is not, or when the row sums overflow (where the
  // callers' determinant test rejects the matrix anyway). The rows are summed left to
  // right (Eigen pairs them): the norm may differ from Eigen's in the last bit.
  double largest = 0.0, total = 0.0;
  for (int r = 0; r < N; ++r) {
    double row = 0.0;
    for (int c = 0; c < N; ++c) row += std::abs(m(r, c));
    total += row;
    largest = row > largest ? row : largest;
  }
  return std::isfinite(total) ? largest : std::numeric_limits<double>::quiet_NaN();
}

/// Inverse of a small symmetric positive semi-definite matrix, with `ok` false when it
/// is singular or ill-conditioned. Two tests, both needed: det / prod(diagonal)
/// (Hadamard's ratio, 1 for a diagonal matrix, round-off for a rank-deficient one,
/// whose cofactors are round-off too, so that the explicit inverse of a rank-1 matrix
/// can look well scaled), and the infinity-norm condition number of the inverse.
/// For N = 2 and 3 (the 2D and 3D correction matrices, the 2D moment matrix: one of
/// each per stencil row) the determinant and the inverse come from the cofactors of the
/// upper triangle in closed form (the matrix is symmetric: 3 of 4 and 6 of 9 cofactors),
/// one division; Eigen's general determinant() and inverse() cost 2.5x the instructions
/// (bench/RESULTS.md, "Per-row overheads"). Same tests, same results to round-off.
template <int N>
[[gnu::always_inline]] inline Eigen::Matrix<double, N, N> checked_inverse(const Eigen::Matrix<double, N, N>& m,
                                                                          bool& ok) {
  Eigen::Matrix<double, N, N> inverse;
  ok = false;
  const double norm = infinity_norm<N>(m);
  if (!(norm > 0.0) || !std::isfinite(norm)) return inverse.setZero();
  const double diagonal_product = m.diagonal().prod();
  if constexpr (N == 2 || N == 3) {
    // Cofactors c_ab of the symmetric matrix (upper triangle read), det = row 0 . c_0.
    double det = 0.0;
    if constexpr (N == 2) {
      inverse(0, 0) = m(1, 1);
      inverse(1, 1) = m(0, 0);
      inverse(0, 1) = inverse(1, 0) = -m(0, 1);
      det = m(0, 0) * m(1, 1) - m(0, 1) * m(0, 1);
    } else {
      inverse(0, 0) = m(1, 1) * m(2, 2) - m(1, 2) * m(1, 2);
      inverse(1, 1) = m(0, 0) * m(2, 2) - m(0, 2) * m(0, 2);
      inverse(2, 2) = m(0, 0) * m(1, 1) - m(0, 1) * m(0, 1);
      inverse(0, 1) = inverse(1, 0) = m(0, 2) * m(1, 2) - m(0, 1) * m(2, 2);
      inverse(0, 2) = inverse(2, 0) = m(0, 1) * m(1, 2) - m(0, 2) * m(1, 1);
      inverse(1, 2) = inverse(2, 1) = m(0, 1) * m(0, 2) - m(0, 0) * m(1, 2);
      det = m(0, 0) * inverse(0, 0) + m(0, 1) * inverse(0, 1) + m(0, 2) * inverse(0, 2);
    }
    if (!(diagonal_product > 0.0) || !(det > kMinHadamardRatio * diagonal_product))
      return inverse.setZero();
    const double inverse_det = 1.0 / det;  // a loop: Eigen's `*=` was an out-of-line call
    for (int r = 0; r < N; ++r)
      for (int c = 0; c < N; ++c) inverse(r, c) *= inverse_det;
  } else {
    const double det = m.determinant();
    if (!(diagonal_product > 0.0) || !(det > kMinHadamardRatio * diagonal_product))
      return inverse.setZero();
    inverse = m.inverse();
  }
  const double condition = norm * infinity_norm<N>(inverse);
  ok = std::isfinite(condition) && condition < kMaxConditionNumber;
  return inverse;
}

/// Moore-Penrose pseudo-inverse of a symmetric positive semi-definite matrix,
/// dropping eigenvalues below a relative threshold.
template <int N>
Eigen::Matrix<double, N, N> symmetric_pseudo_inverse(const Eigen::Matrix<double, N, N>& m) {
  const Eigen::Matrix<double, N, N> symmetric = 0.5 * (m + m.transpose());
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, N, N>> solver(symmetric);
  const auto& eigenvalues = solver.eigenvalues();
  const double largest = eigenvalues.cwiseAbs().maxCoeff();
  Eigen::Matrix<double, N, 1> inverted = Eigen::Matrix<double, N, 1>::Zero();
  if (largest > 0.0 && std::isfinite(largest))
    for (int k = 0; k < N; ++k)
      if (eigenvalues[k] > largest / kMaxConditionNumber) inverted[k] = 1.0 / eigenvalues[k];
  return solver.eigenvectors() * inverted.asDiagonal() * solver.eigenvectors().transpose();
}

/// Inverse of a small general matrix (the correction matrix of a reference-configuration
/// stencil, sum_J V_J grad_X W_IJ (x) (x_J - x_I), which is not symmetric), with `ok`
/// false when it is singular or ill-conditioned: |det| against the product of its row
/// norms (Hadamard's inequality: 1 for orthogonal rows, round-off for a rank-deficient
/// matrix) and the infinity-norm condition number, the thresholds of checked_inverse.
/// For N = 2 and 3 (one per stencil row with the reference kernel, the default of
/// updated Lagrangian) the adjugate in closed form, inlined: Eigen's out-of-line
/// determinant() and inverse() were 4.7 % of the 2D step's instructions.
template <int N>
[[gnu::always_inline]] inline Eigen::Matrix<double, N, N> checked_general_inverse(const Eigen::Matrix<double, N, N>& m,
                                                                                  bool& ok) {
  ok = false;
  const double norm = infinity_norm<N>(m);
  if (!(norm > 0.0) || !std::isfinite(norm)) return Eigen::Matrix<double, N, N>::Zero();
  const double row_norms = m.rowwise().norm().prod();
  Eigen::Matrix<double, N, N> inverse;
  double det = 0.0;
  if constexpr (N == 2) {
    inverse(0, 0) = m(1, 1);
    inverse(0, 1) = -m(0, 1);
    inverse(1, 0) = -m(1, 0);
    inverse(1, 1) = m(0, 0);
    det = m(0, 0) * m(1, 1) - m(0, 1) * m(1, 0);
  } else if constexpr (N == 3) {  // inverse(r, c) = cofactor(c, r)
    inverse(0, 0) = m(1, 1) * m(2, 2) - m(1, 2) * m(2, 1);
    inverse(1, 0) = m(1, 2) * m(2, 0) - m(1, 0) * m(2, 2);
    inverse(2, 0) = m(1, 0) * m(2, 1) - m(1, 1) * m(2, 0);
    inverse(0, 1) = m(0, 2) * m(2, 1) - m(0, 1) * m(2, 2);
    inverse(1, 1) = m(0, 0) * m(2, 2) - m(0, 2) * m(2, 0);
    inverse(2, 1) = m(0, 1) * m(2, 0) - m(0, 0) * m(2, 1);
    inverse(0, 2) = m(0, 1) * m(1, 2) - m(0, 2) * m(1, 1);
    inverse(1, 2) = m(0, 2) * m(1, 0) - m(0, 0) * m(1, 2);
    inverse(2, 2) = m(0, 0) * m(1, 1) - m(0, 1) * m(1, 0);
    det = m(0, 0) * inverse(0, 0) + m(0, 1) * inverse(1, 0) + m(0, 2) * inverse(2, 0);
  } else {
    det = m.determinant();
  }
  if (!(row_norms > 0.0) || !(std::abs(det) > kMinHadamardRatio * row_norms)) return Eigen::Matrix<double, N, N>::Zero();
  if constexpr (N == 2 || N == 3) {
    const double inverse_det = 1.0 / det;
    for (int r = 0; r < N; ++r)
      for (int c = 0; c < N; ++c) inverse(r, c) *= inverse_det;
  } else {
    inverse = m.inverse();
  }
  const double condition = norm * infinity_norm<N>(inverse);
  ok = std::isfinite(condition) && condition < kMaxConditionNumber;
  return inverse;
}

/// Moore-Penrose pseudo-inverse of a small general matrix, M+ = (M^T M)+ M^T with the
/// symmetric pseudo-inverse above (its eigenvalues, the squared singular values, below
/// the relative threshold dropped): the fallback of checked_general_inverse.
template <int N>
Eigen::Matrix<double, N, N> general_pseudo_inverse(const Eigen::Matrix<double, N, N>& m) {
  const Eigen::Matrix<double, N, N> normal = m.transpose() * m;
  return symmetric_pseudo_inverse<N>(normal) * m.transpose();
}

/// The reference configuration of a stencil (SolverSettings::kernel_configuration =
/// reference): the query's and the sources' initial positions X. The kernel and its raw
/// gradient are evaluated at X_J - X_I (the stencil is the one of the undeformed body,
/// whatever the deformation), the corrections at the current offsets x_J - x_I, so that
/// the weights stay exact for linear fields of the current configuration:
///   gradient  V_J Gn_IJ = M^-1 g_J,  g_J = V_J grad_X W(X_I - X_J),  M = sum_J g_J (x) (x_J - x_I),
///   so that sum_J (a . (x_J - x_I)) M^-1 g_J = M^-1 M a = a for every a (M is not
///   symmetric: the pseudo-inverse fallback is the general one);
///   interpolation: the moments of [1; x_J - x_I] weighted by W(|X_J - X_I|).
///   With `kernel_factors` the row's kernel factors value_factor W(q) and
///   -slope_factor W'(q) / q (functions of |X_J - X_I| alone) are read instead of
///   evaluated, kLanes values then kLanes slopes per pack; with `kernel_factors_out` they
///   are evaluated and stored there (engine/solver/kernel_factor_cache.hpp): the same
///   doubles either way.
template <int Dim>
struct ReferenceStencil {
  Eigen::Matrix<double, Dim, 1> query;  ///< X_I
  PointsView<Dim> source;               ///< X_J
  const double* kernel_factors = nullptr;
  double* kernel_factors_out = nullptr;
};

/// The body of compute_stencil, compiled once per instruction set (below).
template <int Dim, class Kernel, bool Reference = false>
[[gnu::always_inline]] inline StencilStatus compute_stencil_in_packs(
    double h, const Eigen::Matrix<double, Dim, 1>& x_query, const PointsView<Dim>& source,
    const double* source_volume, std::span<const std::uint32_t> neighbors,
    InterpolationKind interpolation, StencilWeights<Dim>& weights,
    const ReferenceStencil<Dim>* reference = nullptr) {
  using Mat = Eigen::Matrix<double, Dim, Dim>;
  using Moments = Eigen::Matrix<double, Dim + 1, Dim + 1>;
  constexpr int pairs = Dim * (Dim + 1) / 2;  // upper triangle (a <= b)
  // The correction matrix: its upper triangle (symmetric), or all of it (Reference).
  constexpr int correction_entries = Reference ? Dim * Dim : pairs;
  StencilStatus status;
  const std::size_t n = neighbors.size();
  weights.resize(n);
  const std::size_t padded = padded_size(n);

  // Pass 1, kLanes pairs at a time: kernel values, raw gradients
  // grad_I W(x_I - x_J) = -(W'(r) / r) (x_J - x_I), and the moment sums, one partial
  // sum per lane. With p_ab = o_a o_b (o = x_J - x_I) both matrices are symmetric:
  //   correction C = sum_J V_J grad_I W_IJ (x) o_J = sum_J s_J p_J, s_J = -V_J W'/r,
  //   moments: sum_J V_J W_IJ [1; o_J] [1; o_J]^T (scaled by 1/h after the loop).
  // The coordinates and volumes of each pack of neighbours are loaded straight into
  // lanes (load_indexed_pack; no gather buffer: bench/RESULTS.md, "Per-row overheads");
  // the padding lanes of the last pack read the first neighbour again with volume 0:
  // zero weight, zero gradient, zero moments. The offsets are kept for the linear pass.
  const double inverse_h = 1.0 / h;
  const double value_factor = Kernel::value_factor(h);
  const double slope_factor = Kernel::slope_factor(h);
  const std::uint32_t* const index = neighbors.data();
  std::array<double, Dim> x_i;  // a local copy: the stores below cannot alias it
  for (int d = 0; d < Dim; ++d) x_i[d] = x_query[d];
  std::array<double, Dim> reference_i{};
  if constexpr (Reference)
    for (int d = 0; d < Dim; ++d) reference_i[d] = reference->query[d];
  double* const value = weights.value.data();
  std::array<double*, Dim> offset, gradient;
  for (int d = 0; d < Dim; ++d) offset[d] = weights.offset[d].data(), gradient[d] = weights.gradient[d].data();
  // Partial sums, one array so that their lanes are summed four at a time (lane_sums):
  // [0] kernel sum, [1, 1 + Dim) first moments, then the upper triangles of the second
  // moments and of the correction matrix.
  constexpr int first_at = 1, second_at = 1 + Dim, correction_at = 1 + Dim + pairs;
  constexpr int sum_count = 1 + Dim + pairs + correction_entries;
  // In 3D the 16 (19 with Reference) partial sums do not fit in the 16 vector registers
  // with the pass's other values: accumulated in the pass they live on the stack, a load
  // and a store per sum and pack. There the pass stores the row's values, gradients and
  // offsets only, and two sweeps over them (in L1) sum the moments (10 sums) and the
  // correction matrix (9 or 6), each in registers; the same products in the same order
  // per lane (bench/RESULTS.md, "Moment sums in registers").
  constexpr bool split_sums = Dim == 3;
  std::array<Pack, split_sums ? 0 : sum_count> sum{};
  std::array<double, sum_count> total;
  for (std::size_t k = 0; k < padded; k += kLanes) {
    std::array<std::uint32_t, kLanes> j;
    Pack volume;
    if (k + kLanes <= n) {  // a full pack (all but the last of a row)
      for (std::size_t l = 0; l < kLanes; ++l) j[l] = index[k + l];
      volume = load_indexed_pack(source_volume, j);
    } else {
      for (std::size_t l = 0; l < kLanes; ++l) j[l] = k + l < n ? index[k + l] : index[0];
      volume = load_indexed_pack(source_volume, j);
      for (std::size_t l = n - k; l < kLanes; ++l) volume[l] = 0.0;
    }
    std::array<Pack, Dim> o;
    for (int d = 0; d < Dim; ++d) {
      o[d] = load_indexed_pack(source.coordinate[d], j) - x_i[d];
      store_pack(offset[d] + k, o[d]);
    }
    // The kernel's argument: the current offsets, or the reference ones (Reference).
    std::array<Pack, Dim> kernel_offset = o;
    if constexpr (Reference)
      for (int d = 0; d < Dim; ++d)
        kernel_offset[d] = load_indexed_pack(reference->source.coordinate[d], j) - reference_i[d];
    Pack value_term, slope_term;  // value_factor W(q), -slope_factor W'(q) / q
    if (Reference && reference->kernel_factors != nullptr) {
      value_term = load_pack(reference->kernel_factors + 2 * k);
      slope_term = load_pack(reference->kernel_factors + 2 * k + kLanes);
    } else {
      Pack r2 = kernel_offset[0] * kernel_offset[0];
      for (int d = 1; d < Dim; ++d) r2 += kernel_offset[d] * kernel_offset[d];
      const Pack q = square_root(r2) * inverse_h;
      value_term = value_factor * Kernel::shape(q);
      slope_term = -slope_factor * Kernel::slope_over_q(q);
      if (Reference && reference->kernel_factors_out != nullptr) {
        store_pack(reference->kernel_factors_out + 2 * k, value_term);
        store_pack(reference->kernel_factors_out + 2 * k + kLanes, slope_term);
      }
    }
    const Pack w = volume * value_term;
    const Pack s = volume * slope_term;
    store_pack(value + k, w);
    for (int d = 0; d < Dim; ++d) store_pack(gradient[d] + k, s * kernel_offset[d]);
    if constexpr (!split_sums) {
      sum[0] += w;
      int ab = 0;
      for (int a = 0; a < Dim; ++a) {
        sum[first_at + a] += w * o[a];
        for (int b = a; b < Dim; ++b, ++ab) {
          const Pack p = o[a] * o[b];
          sum[second_at + ab] += w * p;
          if constexpr (!Reference) sum[correction_at + ab] += s * p;
        }
        if constexpr (Reference)  // M_ab = sum_J s_J O_a o_b (O: reference, o: current offset)
          for (int b = 0; b < Dim; ++b) sum[correction_at + a * Dim + b] += (s * kernel_offset[a]) * o[b];
      }
    }
  }
  if constexpr (split_sums) {
    std::array<Pack, 1 + Dim + pairs> moment_sum{};
    for (std::size_t k = 0; k < padded; k += kLanes) {
      const Pack w = load_pack(value + k);
      std::array<Pack, Dim> o;
      for (int d = 0; d < Dim; ++d) o[d] = load_pack(offset[d] + k);
      moment_sum[0] += w;
      int ab = 0;
      for (int a = 0; a < Dim; ++a) {
        moment_sum[first_at + a] += w * o[a];
        for (int b = a; b < Dim; ++b, ++ab) moment_sum[second_at + ab] += w * (o[a] * o[b]);
      }
    }
    std::array<Pack, correction_entries> correction_sum{};
    for (std::size_t k = 0; k < padded; k += kLanes) {
      std::array<Pack, Dim> g, o;
      for (int d = 0; d < Dim; ++d) g[d] = load_pack(gradient[d] + k), o[d] = load_pack(offset[d] + k);
      int ab = 0;
      for (int a = 0; a < Dim; ++a) {
        if constexpr (Reference)  // M_ab = sum_J (s_J O_a) o_b, as in the pass above
          for (int b = 0; b < Dim; ++b) correction_sum[a * Dim + b] += g[a] * o[b];
        else  // C_ab = sum_J (s_J o_a) o_b, a <= b
          for (int b = a; b < Dim; ++b, ++ab) correction_sum[ab] += g[a] * o[b];
      }
    }
    const auto moments_total = lane_sums(moment_sum);
    const auto correction_total = lane_sums(correction_sum);
    std::copy(moments_total.begin(), moments_total.end(), total.begin());
    std::copy(correction_total.begin(), correction_total.end(), total.begin() + correction_at);
  } else {
    total = lane_sums(sum);
  }
  Moments moments;  // [1; d] [1; d]^T weighted by V_J W_IJ, d = o / h
  Mat correction_matrix;
  moments(0, 0) = total[0];
  int ab = 0;
  for (int a = 0; a < Dim; ++a) {
    moments(0, a + 1) = moments(a + 1, 0) = total[first_at + a] * inverse_h;
    for (int b = a; b < Dim; ++b, ++ab) {
      moments(a + 1, b + 1) = moments(b + 1, a + 1) = total[second_at + ab] * (inverse_h * inverse_h);
      if constexpr (!Reference) correction_matrix(a, b) = correction_matrix(b, a) = total[correction_at + ab];
    }
    if constexpr (Reference)
      for (int b = 0; b < Dim; ++b) correction_matrix(a, b) = total[correction_at + a * Dim + b];
  }

  // Interpolation weights: scale factors of the row, applied below.
  enum class Scale { zero, shepard, linear } scale = Scale::zero;
  double a = 0.0;  // linear: coefficients (a, b) with moments * (a, b) = e_0 (reproduces
  std::array<double, Dim> b_over_h{};  // 1 and x): W~_IJ = W_IJ (a + b . o_J / h)
  const double kernel_total = moments(0, 0);
  if (!(kernel_total > 0.0)) {
    status.no_neighbors = true;
  } else {
    if (interpolation == InterpolationKind::linear) {
      bool linear_ok = false;
      const Moments inverse = checked_inverse<Dim + 1>(moments, linear_ok);
      if (linear_ok) {
        scale = Scale::linear;
        a = inverse(0, 0);
        for (int d = 0; d < Dim; ++d) b_over_h[d] = inverse(d + 1, 0) * inverse_h;
      } else {
        status.interpolation_fallback = true;
      }
    }
    if (scale != Scale::linear) {
      scale = Scale::shepard;
      a = 1.0 / kernel_total;
    }
  }

  // Gradient weights: L_I grad_I W_IJ.
  bool inverse_ok = false;
  Mat inverse;
  if constexpr (Reference) {
    inverse = checked_general_inverse<Dim>(correction_matrix, inverse_ok);
    if (!inverse_ok) {
      inverse = general_pseudo_inverse<Dim>(correction_matrix);
      status.gradient_fallback = n > 0;
    }
  } else {
    inverse = checked_inverse<Dim>(correction_matrix, inverse_ok);
    if (!inverse_ok) {
      inverse = symmetric_pseudo_inverse<Dim>(correction_matrix);
      status.gradient_fallback = n > 0;
    }
  }
  // One pass over the row for both (they were two), and the weights' squared 2-norm.
  Pack squares{};
  for (std::size_t k = 0; k < padded; k += kLanes) {
    Pack w = load_pack(value + k);
    if (scale == Scale::linear) {
      Pack factor = broadcast(a);
      for (int d = 0; d < Dim; ++d) factor += b_over_h[d] * load_pack(offset[d] + k);
      w *= factor;
    } else {
      w = scale == Scale::shepard ? w * a : Pack{};
    }
    store_pack(value + k, w);
    squares += w * w;
    std::array<Pack, Dim> raw;
    for (int d = 0; d < Dim; ++d) raw[d] = load_pack(gradient[d] + k);
    for (int r = 0; r < Dim; ++r) {
      Pack g = inverse(r, 0) * raw[0];
      for (int c = 1; c < Dim; ++c) g += inverse(r, c) * raw[c];
      store_pack(gradient[r] + k, g);
    }
  }
  status.weight_squares = lane_sum(squares);
  return status;
}

template <int Dim, class Kernel, bool Reference>
StencilStatus compute_stencil_sse2(double h, const Eigen::Matrix<double, Dim, 1>& x_query,
                                   const PointsView<Dim>& source, const double* source_volume,
                                   std::span<const std::uint32_t> neighbors,
                                   InterpolationKind interpolation, StencilWeights<Dim>& weights,
                                   const ReferenceStencil<Dim>* reference) {
  return compute_stencil_in_packs<Dim, Kernel, Reference>(h, x_query, source, source_volume, neighbors,
                                                          interpolation, weights, reference);
}

template <int Dim, class Kernel, bool Reference>
TSPH_TARGET_AVX2 StencilStatus compute_stencil_avx2(
    double h, const Eigen::Matrix<double, Dim, 1>& x_query, const PointsView<Dim>& source,
    const double* source_volume, std::span<const std::uint32_t> neighbors,
    InterpolationKind interpolation, StencilWeights<Dim>& weights, const ReferenceStencil<Dim>* reference) {
  return compute_stencil_in_packs<Dim, Kernel, Reference>(h, x_query, source, source_volume, neighbors,
                                                          interpolation, weights, reference);
}

/// Computes the interpolation and gradient weights of query point `x_query` over its
/// neighbour row. `source_volume[J]` is V_J = m_J / rho_J. Runs the AVX2 build where the
/// CPU has it (simd_path(); the same results as the SSE2 build to round-off), unless
/// `path` names one. With `reference` the kernel is evaluated in the reference
/// configuration (ReferenceStencil).
template <int Dim, class Kernel>
StencilStatus compute_stencil(const Kernel&, double h, const Eigen::Matrix<double, Dim, 1>& x_query,
                              const PointsView<Dim>& source, const double* source_volume,
                              std::span<const std::uint32_t> neighbors,
                              InterpolationKind interpolation, StencilWeights<Dim>& weights,
                              SimdPath path = simd_path(), const ReferenceStencil<Dim>* reference = nullptr) {
  if (reference != nullptr) {
    if (path == SimdPath::avx2)
      return compute_stencil_avx2<Dim, Kernel, true>(h, x_query, source, source_volume, neighbors,
                                                     interpolation, weights, reference);
    return compute_stencil_sse2<Dim, Kernel, true>(h, x_query, source, source_volume, neighbors,
                                                   interpolation, weights, reference);
  }
  if (path == SimdPath::avx2)
    return compute_stencil_avx2<Dim, Kernel, false>(h, x_query, source, source_volume, neighbors,
                                                    interpolation, weights, nullptr);
  return compute_stencil_sse2<Dim, Kernel, false>(h, x_query, source, source_volume, neighbors,
                                                  interpolation, weights, nullptr);
}

}  // namespace tsph
