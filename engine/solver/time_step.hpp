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
          Vec reference_mean = Vec::Zero(), current_mean = Vec::Zero();
          Mat current = Mat::Zero(), reference = Mat::Zero();  // sum x X^T, sum X X^T, then centred
          double count = 0.0;
          for (const std::uint32_t j : row) {
            Vec x, X;
            for (int d = 0; d < Dim; ++d) {
              x[d] = real.position[d][j] - current_origin[d];
              X[d] = real.initial_position[d][j] - reference_origin[d];
            }
            if (X.squaredNorm() > support * support) continue;
            reference_mean += X;
            current_mean += x;
            current.noalias() += x * X.transpose();
            reference.noalias() += X * X.transpose();
            count += 1.0;
          }
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
