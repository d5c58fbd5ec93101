// SolverSettings::surface_extrapolation: free- and traction-surface particles take
// their tangential velocity gradient from the virtual half-step velocities, whose
// stencil lies a distance delta = n . (x_I - x_centroid) inside: the gradient of the
// row, not of the surface. Here the tangential block is extrapolated to the surface to
// first order,
//   d_k v_l (surface) = d_k v_l (row) + delta d_n d_k v_l,  d_n d_k v_l = -d_k d_l v_n,
// the last from the traction-free rate d_n v_l + d_l v_n = 0 (sigma_nl = 0 along the
// surface); d_k d_l v_n is the tangential difference of the neighbouring surface
// particles' half-step gradients d_k v_n.
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
  /// tangential, moved from the virtual stencil's centroid to the particle,
  ///   += -delta H_kl,  H_kl = d_k d_l v_n  (least squares over the neighbouring surface
  /// particles with the same normal: sum_j (g_j - g_i)_k dx_m = H_km sum_j dx_k dx_m,
  /// g = tangential gradient of v_n at n+1/2). No neighbour: no correction.
  static void apply(const SolverState<Dim>& state, std::size_t b, std::uint32_t i, const Mat& frame, double t_new,
                    Mat& velocity_dt) {
    const Vec& n = state.boundary.normal[b];
    const double delta = n.dot(state.boundary.stencil_offset[b]);
    if (!(delta > 0.0)) return;
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
    auto g_of = [&](std::size_t slot) {  // grad_t v_n at n+1/2, in the frame
      return Vec(frame.transpose() * (state.boundary.half_velocity_gradient[slot].transpose() * n));
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
        velocity_dt(1, 1) -= delta * differences(1, 1) / moments(1, 1);
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
      velocity_dt.template block<2, 2>(1, 1) -= delta * symmetric;
    }
  }
};

}  // namespace tsph
