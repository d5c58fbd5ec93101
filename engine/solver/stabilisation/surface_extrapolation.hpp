// SolverSettings::surface_extrapolation: free- and traction-surface particles take
// their tangential velocity gradient from the virtual half-step velocities, whose
// stencil lies inside: the gradient a row reads of a tangential rate that changes across
// the surface (bending) is that rate at some depth, not at the surface. Here the
// tangential block is moved to the surface to first order. A field that grows with the
// depth, v_l = B_lm t_m.r (n.r) (r = x - x_I, B_lm = d_n d_m v_l), reads in the row as
//   d_k v_l (row) = B_lm M_km,  M_km = sum_v V_v Gn_Iv,k r_m (r . n)  (BoundaryParticles::
// normal_moment, in the frame; zero at I, so the surface value lacks it), and with the
// traction-free rate d_n v_l + d_l v_n = 0 (sigma_nl = 0 along the surface)
// B_lm = -d_l d_m v_n = -H_lm:
//   d_k v_l (surface) = d_k v_l (row) + (H M^T)_lk,
// H_lm = d_l d_m v_n the tangential difference of the neighbouring surface particles'
// half-step gradients d_k v_n. On the lattice M = m I with m the row's effective depth
// (-0.60 dx on a 2D face at alpha 1.2, cubic spline); until 2026-11-28 m was the
// virtual stencil's centroid depth (-1.0 dx there), and the extrapolation overshot: the
// oscillating plate's surface bending stress 24 % above the line through the inner rows
// (dx = 0.004 m), its elastic energy 31 % above the initial at the first turning point
// (docs/notes/2026-11-28-surface-depth-and-free-corners.md).
#pragma once

#include "engine/solver/state.hpp"

#include <Eigen/LU>

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace tsph {

template <int Dim>
struct SurfaceExtrapolation {
  using Vec = Vector<Dim>;
  using Mat = Matrix<Dim>;
  /// 3D: the least ratio of the tangential stencil's principal moments (its extent
  /// squared across over along) for the Hessian to be fitted; a full face has about 1.
  static constexpr double kMinMomentRatio = 0.1;

  /// SolverSettings::surface_extrapolation: velocity_dt(l, k) = d v'_l / d t_k, l, k
  /// tangential, moved from the row's depth to the particle,
  ///   += (H M^T)_lk,  H_kl = d_k d_l v_n  (least squares over the neighbouring surface
  /// particles with the same normal: sum_j (g_j - g_i)_k dx_m = H_km sum_j dx_k dx_m,
  /// g = tangential gradient of v_n at n+1/2). No neighbour: no correction.
  static void apply(const SolverState<Dim>& state, std::size_t b, std::uint32_t i, const Mat& frame, double t_new,
                    Mat& velocity_dt) {
    const Vec& n = state.boundary.normal[b];
    const Mat moment = frame.transpose() * state.boundary.normal_moment[b] * frame;  // M_km in the frame
    // Zero traction at I and at every neighbour used (a loaded face, where
    // d_t sigma_nl need not vanish, is left as it is).
    auto unloaded = [&](std::size_t slot, std::uint32_t particle) {
      const auto& c = state.boundaries[static_cast<std::size_t>(state.real.boundary[particle])];
      return c.kind == BoundaryCondition<Dim>::Kind::traction &&
             c.prescribed(state.initial_position_of(particle), state.boundary.profile[slot], t_new).squaredNorm() == 0.0;
    };
    if (!unloaded(b, i)) return;
    // A rank-deficient half-step gradient (a corner at alpha 0.6, where the missing
    // direction reads as zero) is no sample of d_t v_n: neither extrapolated nor used as
    // a neighbour (the plate's free-end corners made its Hessian, and so the end face's
    // strain rate, wrong by O(grad v / dx): the plate 6 x too stiff at alpha 0.6).
    if (!state.boundary.full_rank_gradient[b]) return;
    const Vec frame_normal = frame.col(0);  // the conditions' normal (CharacteristicBoundary::condition_normal)
    auto g_of = [&](std::size_t slot) {  // grad_t v_n at n+1/2, in the frame
      return Vec(frame.transpose() * (state.boundary.half_velocity_gradient[slot].transpose() * frame_normal));
    };
    const Vec gi = g_of(b);
    Mat moments = Mat::Zero(), differences = Mat::Zero();
    const PointsView<Dim> real_points = points_of<Dim>(state.real);
    for (std::uint32_t j : state.lists.real_from_real.neighbors(i)) {
      if (!state.within_support(real_points, i, real_points, j)) continue;  // skin pairs
      const std::int32_t bj = state.boundary.slot[j];
      if (bj < 0 || !state.boundary.on_surface[static_cast<std::size_t>(bj)] ||
          state.boundary.normal[static_cast<std::size_t>(bj)].dot(n) < 0.999)
        continue;
      if (!unloaded(static_cast<std::size_t>(bj), j) || !state.boundary.full_rank_gradient[static_cast<std::size_t>(bj)])
        continue;
      const Vec gj = g_of(static_cast<std::size_t>(bj));
      const Vec dx = frame.transpose() * (state.real.position_of(j) - state.real.position_of(i));
      for (int k = 1; k < Dim; ++k)
        for (int m = 1; m < Dim; ++m) {
          differences(k, m) += (gj[k] - gi[k]) * dx[m];
          moments(k, m) += dx[k] * dx[m];
        }
    }
    if constexpr (Dim == 2) {
      if (moments(1, 1) > 0.0) {
        velocity_dt(1, 1) += differences(1, 1) / moments(1, 1) * moment(1, 1);
      }
    } else if constexpr (Dim == 3) {
      const Eigen::Matrix2d a = moments.template block<2, 2>(1, 1);
      // The tangential neighbours must span both directions: on an edge (and next to
      // one, where the normals tilt) the particles of the same normal lie on a line, and
      // once the body has moved, that line's moment matrix is rank one up to round-off
      // (det 1e-12..1e-8 of trace^2 in the twisting column); its inverse then blows the
      // extrapolation up (the column diverged in one step). Skip unless the smaller
      // principal moment is at least kMinMomentRatio of the larger (none: no neighbour).
      const double half_trace = 0.5 * a.trace();
      const double spread = std::sqrt(std::max(0.0, half_trace * half_trace - a.determinant()));
      if (!(half_trace > 0.0 && half_trace - spread >= kMinMomentRatio * (half_trace + spread))) return;
      const Eigen::Matrix2d hessian = differences.template block<2, 2>(1, 1) * a.inverse();
      const Eigen::Matrix2d symmetric = 0.5 * (hessian + hessian.transpose());
      velocity_dt.template block<2, 2>(1, 1) += symmetric * moment.template block<2, 2>(1, 1).transpose();
    }
  }
};

}  // namespace tsph
