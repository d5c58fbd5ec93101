// Corrected SPH operators between a query point and a set of source particles
// (DESIGN.md section 2): the normalised kernel for interpolation and the corrected
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

#include "kernels/smoothing_kernels.hpp"
#include "neighbor/neighbor_list.hpp"

#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include <array>
#include <cmath>
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
};

/// Per-neighbour weights of one query point, sized to its row; reused between queries
/// (scratch, one per thread: capacity is kept, so the loops allocate almost nothing).
template <int Dim>
struct StencilWeights {
  std::vector<double> value;                   ///< V_J Wn_IJ
  std::vector<Eigen::Matrix<double, Dim, 1>> gradient;  ///< V_J Gn_IJ
  std::vector<Eigen::Matrix<double, Dim, 1>> scaled_offset;  ///< (x_J - x_I) / h

  void resize(std::size_t n) {
    value.resize(n);
    gradient.resize(n);
    scaled_offset.resize(n);
  }
};

/// Inverse of a small symmetric positive semi-definite matrix, with `ok` false when it
/// is singular or ill-conditioned. Two tests, both needed: det / prod(diagonal)
/// (Hadamard's ratio, 1 for a diagonal matrix, round-off for a rank-deficient one,
/// whose cofactors are round-off too, so that the explicit inverse of a rank-1 matrix
/// can look well scaled), and the infinity-norm condition number of the inverse.
template <int N>
Eigen::Matrix<double, N, N> checked_inverse(const Eigen::Matrix<double, N, N>& m, bool& ok) {
  Eigen::Matrix<double, N, N> inverse;
  ok = false;
  const double norm = m.cwiseAbs().rowwise().sum().maxCoeff();
  if (!(norm > 0.0) || !std::isfinite(norm)) return inverse.setZero();
  const double diagonal_product = m.diagonal().prod();
  const double det = m.determinant();
  if (!(diagonal_product > 0.0) || !(det > kMinHadamardRatio * diagonal_product))
    return inverse.setZero();
  inverse = m.inverse();
  const double condition = norm * inverse.cwiseAbs().rowwise().sum().maxCoeff();
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

/// Computes the interpolation and gradient weights of query point `x_query` over its
/// neighbour row. `source_volume[J]` is V_J = m_J / rho_J.
template <int Dim, class Kernel>
StencilStatus compute_stencil(const Kernel& kernel, double h,
                              const Eigen::Matrix<double, Dim, 1>& x_query,
                              const PointsView<Dim>& source, const double* source_volume,
                              std::span<const std::uint32_t> neighbors,
                              InterpolationKind interpolation, StencilWeights<Dim>& weights) {
  using Vec = Eigen::Matrix<double, Dim, 1>;
  using Mat = Eigen::Matrix<double, Dim, Dim>;
  using Moments = Eigen::Matrix<double, Dim + 1, Dim + 1>;
  StencilStatus status;
  const std::size_t n = neighbors.size();
  weights.resize(n);

  // Pass 1: kernel values, raw gradients and the moment sums.
  // The moment sums are accumulated as scalars (upper triangles), which the compiler
  // keeps in registers; the matrices are filled after the loop.
  Mat correction = Mat::Zero();  // sum_J V_J grad_I W_IJ (x) (x_J - x_I)
  double kernel_sum = 0.0;       // sum_J V_J W_IJ
  Vec first_moment = Vec::Zero();  // sum_J V_J W_IJ d_J, d_J = (x_J - x_I) / h
  Mat second_moment = Mat::Zero();  // sum_J V_J W_IJ d_J d_J^T (upper triangle)
  for (std::size_t k = 0; k < n; ++k) {
    const std::uint32_t j = neighbors[k];
    Vec offset;  // x_J - x_I
    for (int d = 0; d < Dim; ++d) offset[d] = source.coordinate[d][j] - x_query[d];
    const double r = offset.norm();
    const double volume = source_volume[j];
    const double w = volume * kernel.value(r, h);
    // grad_I W(x_I - x_J) = W'(r) (x_I - x_J) / r
    const Vec grad = r > 0.0 ? Vec((-volume * kernel.derivative(r, h) / r) * offset) : Vec::Zero();
    const Vec scaled = offset / h;
    weights.value[k] = w;
    weights.gradient[k] = grad;
    weights.scaled_offset[k] = scaled;
    for (int a = 0; a < Dim; ++a)
      for (int b = 0; b < Dim; ++b) correction(a, b) += grad[a] * offset[b];
    kernel_sum += w;
    for (int a = 0; a < Dim; ++a) {
      first_moment[a] += w * scaled[a];
      for (int b = a; b < Dim; ++b) second_moment(a, b) += w * scaled[a] * scaled[b];
    }
  }
  // [1; d] [1; d]^T weighted by V_J W_IJ.
  Moments moments;
  moments(0, 0) = kernel_sum;
  for (int a = 0; a < Dim; ++a) {
    moments(0, a + 1) = moments(a + 1, 0) = first_moment[a];
    for (int b = a; b < Dim; ++b)
      moments(a + 1, b + 1) = moments(b + 1, a + 1) = second_moment(a, b);
  }

  // Interpolation weights.
  if (!(kernel_sum > 0.0)) {
    status.no_neighbors = true;
    for (std::size_t k = 0; k < n; ++k) weights.value[k] = 0.0;
  } else {
    bool linear_ok = false;
    if (interpolation == InterpolationKind::linear) {
      const Moments inverse = checked_inverse<Dim + 1>(moments, linear_ok);
      if (linear_ok) {
        // Coefficients (a, b) with moments * (a, b) = e_0: reproduces 1 and x.
        const Eigen::Matrix<double, Dim + 1, 1> coefficients = inverse.col(0);
        const double a = coefficients[0];
        const Vec b = coefficients.template tail<Dim>();
        for (std::size_t k = 0; k < n; ++k)
          weights.value[k] *= a + b.dot(weights.scaled_offset[k]);
      } else {
        status.interpolation_fallback = true;
      }
    }
    if (!linear_ok) {
      const double inverse_sum = 1.0 / kernel_sum;
      for (std::size_t k = 0; k < n; ++k) weights.value[k] *= inverse_sum;
    }
  }

  // Gradient weights: L_I grad_I W_IJ.
  bool inverse_ok = false;
  Mat inverse = checked_inverse<Dim>(correction, inverse_ok);
  if (!inverse_ok) {
    inverse = symmetric_pseudo_inverse<Dim>(correction);
    status.gradient_fallback = n > 0;
  }
  for (std::size_t k = 0; k < n; ++k) weights.gradient[k] = inverse * weights.gradient[k];
  return status;
}

}  // namespace tsph
