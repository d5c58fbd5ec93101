// The stable time step of a deformed body (updated Lagrangian; case key time.adaptive).
// The step's limit is the time a p-wave takes to cross the smallest current spacing,
//   dt_max = min_q  dx lambda_min(F_q) / c_p(rho_q),
// over the virtual particles q, with F_q the deformation gradient of q's neighbourhood
// and lambda_min its smallest principal stretch (a flattened cell: the impact face of a
// Taylor bar is compressed to a twentieth of its length), rho_q = rho0 / det F_q.
// F_q is the least-squares fit of the real particles' current positions to their initial
// ones over q's row, those within the support 2h of q in the initial configuration:
// F = A B^-1 with A = sum_J dx_J dX_J^T, B = sum_J dX_J dX_J^T, dX_J = X_J - mean X,
// dx_J = x_J - mean x: exact for every affine motion. It reads the real particles alone
// (not where the virtual ones have drifted) and no kernel, and the row is cut in the
// initial configuration (not by the list's skin), so the limit is a function of the real
// positions: a restart from a checkpoint takes the steps the uninterrupted run took
// (tests/tsph_restart_checks.sh).
#pragma once

#include "engine/parallel.hpp"
#include "engine/solver/state.hpp"
#include "kernels/simd.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace tsph {

template <int Dim>
struct StableTimeStep {
  using Vec = Vector<Dim>;
  using Mat = Matrix<Dim>;

  /// Where the limit is set: the virtual particle, its smallest stretch and its J.
  struct Limit {
    double time_step = std::numeric_limits<double>::infinity();  ///< dx lambda_min / c_p (no CFL factor)
    std::uint32_t particle = 0;  ///< the virtual particle that sets it (its index)
    double stretch = 1.0;        ///< lambda_min(F) there
    double jacobian = 1.0;       ///< det F there
    /// The smaller limit; ties to the lower index, so the result is independent of the
    /// order the threads finish in.
    Limit& operator+=(const Limit& other) {
      if (other.time_step < time_step || (other.time_step == time_step && other.particle < particle)) *this = other;
      return *this;
    }
  };
  struct NoScratch {};

  /// The sums of one virtual row over its real neighbours within the support in the
  /// initial configuration: their count, sum X, sum x, sum x X^T and sum X X^T (X, x the
  /// initial and current offsets from the origins given).
  struct RowMoments {
    double count = 0.0;
    Vec reference_sum = Vec::Zero(), current_sum = Vec::Zero();
    Mat current = Mat::Zero(), reference = Mat::Zero();
  };

  /// The body of row_moments, compiled once per instruction set (kernels/simd.hpp):
  /// kLanes neighbours at a time, a neighbour beyond the support (and a padding lane)
  /// weighted 0. Before (2026-12-07) a scalar loop: 9.7 % of the quarter Taylor bar's
  /// instructions (R0 / 4).
  [[gnu::always_inline]] static RowMoments row_moments_in_packs(const ParticleSet<Dim>& real,
                                                                std::span<const std::uint32_t> row,
                                                                const Vec& reference_origin, const Vec& current_origin,
                                                                double support_squared) {
    constexpr int pairs = Dim * (Dim + 1) / 2;
    constexpr int reference_sum_at = 1, current_sum_at = 1 + Dim, current_at = 1 + 2 * Dim,
                  reference_at = 1 + 2 * Dim + Dim * Dim;
    std::array<Pack, 1 + 2 * Dim + Dim * Dim + pairs> sum{};
    const std::size_t n = row.size();
    const std::size_t padded = padded_size(n);
    const Pack one = broadcast(1.0);
    for (std::size_t k = 0; k < padded; k += kLanes) {
      std::array<std::uint32_t, kLanes> j;
      for (std::size_t l = 0; l < kLanes; ++l) j[l] = k + l < n ? row[k + l] : row[0];
      std::array<Pack, Dim> reference_offset, current_offset;
      Pack r2{};
      for (int d = 0; d < Dim; ++d) {
        reference_offset[d] = load_indexed_pack(real.initial_position[d].data(), j) - reference_origin[d];
        current_offset[d] = load_indexed_pack(real.position[d].data(), j) - current_origin[d];
        r2 += reference_offset[d] * reference_offset[d];
      }
      Pack weight = select(r2 <= broadcast(support_squared), one, Pack{});
      for (std::size_t l = n > k ? n - k : 0; l < kLanes; ++l) weight[l] = 0.0;
      sum[0] += weight;
      std::array<Pack, Dim> weighted_reference;
      for (int d = 0; d < Dim; ++d) {
        weighted_reference[d] = weight * reference_offset[d];
        sum[reference_sum_at + d] += weighted_reference[d];
        sum[current_sum_at + d] += weight * current_offset[d];
      }
      int ab = 0;
      for (int a = 0; a < Dim; ++a) {
        for (int b = 0; b < Dim; ++b) sum[current_at + a * Dim + b] += current_offset[a] * weighted_reference[b];
        for (int b = a; b < Dim; ++b, ++ab) sum[reference_at + ab] += weighted_reference[a] * reference_offset[b];
      }
    }
    const auto total = lane_sums(sum);
    RowMoments moments;
    moments.count = total[0];
    int ab = 0;
    for (int a = 0; a < Dim; ++a) {
      moments.reference_sum[a] = total[reference_sum_at + a];
      moments.current_sum[a] = total[current_sum_at + a];
      for (int b = 0; b < Dim; ++b) moments.current(a, b) = total[current_at + a * Dim + b];
      for (int b = a; b < Dim; ++b, ++ab) moments.reference(a, b) = moments.reference(b, a) = total[reference_at + ab];
    }
    return moments;
  }
  static RowMoments row_moments_sse2(const ParticleSet<Dim>& real, std::span<const std::uint32_t> row,
                                     const Vec& reference_origin, const Vec& current_origin, double support_squared) {
    return row_moments_in_packs(real, row, reference_origin, current_origin, support_squared);
  }
  TSPH_TARGET_AVX2 static RowMoments row_moments_avx2(const ParticleSet<Dim>& real, std::span<const std::uint32_t> row,
                                                      const Vec& reference_origin, const Vec& current_origin,
                                                      double support_squared) {
    return row_moments_in_packs(real, row, reference_origin, current_origin, support_squared);
  }

  /// The limit over every virtual particle with a full-rank row (a row whose initial
  /// offsets span fewer than Dim directions is skipped).
  static Limit compute(const SolverState<Dim>& state) {
    const auto& elastic = state.material.elastic();
    const double modulus = elastic.p_wave_modulus(), density0 = elastic.reference_density();
    const double dx = state.initial_spacing;
    const double support = state.support_radius();
    const ParticleSet<Dim>& real = state.real;
    const ParticleSet<Dim>& virt = state.virtual_;
    return parallel_for_with_scratch<NoScratch, Limit>(
        virt.size(), [&](std::size_t q, NoScratch&, Limit& limit) {
          const auto row = state.lists.virtual_from_real.neighbors(q);
          if (row.empty()) return;
          // Offsets from a point of the row (X_q; the row's first current position) keep
          // the sums well conditioned; the fit is centred below.
          Vec reference_origin, current_origin;
          for (int d = 0; d < Dim; ++d) {
            reference_origin[d] = virt.initial_position[d][q];
            current_origin[d] = real.position[d][row[0]];
          }
          const RowMoments sums = simd_path() == SimdPath::avx2
                                      ? row_moments_avx2(real, row, reference_origin, current_origin, support * support)
                                      : row_moments_sse2(real, row, reference_origin, current_origin, support * support);
          const double count = sums.count;
          Vec reference_mean = sums.reference_sum, current_mean = sums.current_sum;
          Mat current = sums.current, reference = sums.reference;
          if (count < Dim + 1) return;
          reference_mean /= count;
          current_mean /= count;
          current -= count * current_mean * reference_mean.transpose();
          reference -= count * reference_mean * reference_mean.transpose();
          const double scale = reference.trace();
          if (!(std::abs(reference.determinant()) > 1e-9 * std::pow(scale, Dim))) return;
          const Mat deformation = current * reference.inverse();  // F
          const double jacobian = deformation.determinant();
          Eigen::SelfAdjointEigenSolver<Mat> eigen;
          eigen.computeDirect(deformation.transpose() * deformation, Eigen::EigenvaluesOnly);
          const double stretch = std::sqrt(std::max(eigen.eigenvalues()[0], 0.0));
          const double density = jacobian > 0.0 ? density0 / jacobian : density0;
          const double time_step = dx * stretch / std::sqrt(modulus / density);
          limit += Limit{time_step, static_cast<std::uint32_t>(q), stretch, jacobian};
        });
  }
};

}  // namespace tsph
