// The outward normals of the boundary particles and the surface/interior decision
// (docs/method.md section 4): kernel normals -sum_J V_J grad W_IJ, replaced by the face
// normal where the particle's neighbours under its condition lie on a plane.
#pragma once

#include "engine/solver/state.hpp"
#include "kernels/simd.hpp"
#include "kernels/smoothing_kernels.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace tsph {

/// Orthonormal frame whose first column is the unit vector n.
template <int Dim>
Matrix<Dim> normal_frame(const Vector<Dim>& n) {
  Matrix<Dim> frame;
  frame.col(0) = n;
  if constexpr (Dim == 2) {
    frame(0, 1) = -n[1];
    frame(1, 1) = n[0];
  } else if constexpr (Dim == 3) {
    int axis = 0;  // the coordinate axis least aligned with n
    for (int d = 1; d < 3; ++d)
      if (std::abs(n[d]) < std::abs(n[axis])) axis = d;
    Vector<3> e = Vector<3>::Unit(axis);
    const Vector<3> t1 = (e - e.dot(n) * n).normalized();
    frame.col(1) = t1;
    frame.col(2) = n.cross(t1);
  }
  return frame;
}

/// A particle is on a surface when none of its real neighbours lies within 60 degrees
/// of the outward kernel normal -sum_J V_J grad W_IJ (cosine below this value).
inline constexpr double kSurfaceCosine = 0.5;

/// A further symmetry plane of a boundary particle (symmetry_planes.hpp) acts where it
/// crosses the particle's own face: their normals more than 25 degrees apart, and more
/// than 25 degrees from an earlier further plane (sine above this value).
inline constexpr double kSameFaceCosine = 0.906;  // cos 25 degrees
inline constexpr double kCrossingSine = 0.423;    // sin 25 degrees

/// The in-plane (Dim x Dim) part of a stress vector as a tensor.
template <int Dim>
Matrix<Dim> in_plane(const StressVector<Dim>& s) {
  return to_tensor<Dim>(s).template topLeftCorner<Dim, Dim>();
}
/// Directional derivative (a . grad) of the stress tensor, in-plane part.
template <int Dim>
Matrix<Dim> directional(const std::array<Vector<Dim>, stress_component_count<Dim>>& gradient, const Vector<Dim>& a) {
  StressVector<Dim> s;
  for (int m = 0; m < stress_component_count<Dim>; ++m) s[m] = gradient[m].dot(a);
  return in_plane<Dim>(s);
}

template <int Dim>
struct BoundaryNormals {
  using Vec = Vector<Dim>;
  using Mat = Matrix<Dim>;

  /// The boundary normals n = -sum_J V_J grad_I W_IJ / |.| (they point out of the body)
  /// from the real set at its current positions (x^n), and at the first build the
  /// surface/interior decision; rows filtered to the support (within_support).
  static void compute(SolverState<Dim>& state) {
    const PointsView<Dim> real_points = points_of<Dim>(state.real);
    visit_kernel<Dim>(state.settings.kernel, [&](const auto& kernel) {
      const bool first_build = !state.lists.surface_decided;
      if (first_build) state.boundary.on_surface.assign(state.boundary.particle.size(), 1);
      for (std::size_t b = 0; b < state.boundary.particle.size(); ++b) {
        const std::uint32_t i = state.boundary.particle[b];
        const Vec sum = current_kernel_gradient_sum(state, kernel, real_points, i);
        const double norm = sum.norm();
        const Vec kernel_normal = norm > 0.0 ? Vec(-sum / norm) : Vec(Vec::Unit(0));
        if (first_build) {
          // On a surface no neighbour lies within 60 degrees of the outward normal; inside,
          // some neighbour always does (a lattice has one every 90 degrees or closer).
          // Decided in the initial configuration: at the start of a run it is the current
          // one, and a run continued from a checkpoint decides as the run did (its
          // deformed body would make the flattened face of an impact "inside").
          const bool on_surface = surface_at_start(state, kernel, i);
          state.boundary.on_surface[b] = on_surface;
          const auto& condition = state.boundaries[static_cast<std::size_t>(state.real.boundary[i])];
          if (!on_surface && condition.kind != BoundaryCondition<Dim>::Kind::velocity)
            throw std::invalid_argument(
                "boundary condition '" + condition.name + "': real particle " +
                std::to_string(state.real.id[i]) + " is inside the body (no free surface there); a " +
                (condition.kind == BoundaryCondition<Dim>::Kind::traction ? "traction" : "symmetry plane") +
                " applies only to surface particles: shrink the region to the surface");
        }
        // Further symmetry planes (symmetry_planes.hpp): each one's normal from the
        // particles that keep to it, then the own normal made orthogonal to them (the
        // kernel normal of a particle on a plane leans across it: its mirror neighbours
        // are missing). A plane on the particle's own face (a punch on part of a
        // symmetry face: normals within 25 degrees), or one that repeats an earlier
        // plane, is left out for this step (normal 0: the projection does nothing), so
        // the later condition wins there as it does without further planes.
        Vec normal = face_normal(state, i, kernel_normal, state.real.boundary[i]);
        for (std::size_t e = 0; e < 2; ++e) {
          state.boundary.extra_normal[b][e] = Vec::Zero();
          const std::int32_t k = state.boundary.extra_plane[b][e];
          if (k < 0) continue;
          Vec m = face_normal(state, i, kernel_normal, k);
          for (std::size_t f = 0; f < e; ++f)
            m -= m.dot(state.boundary.extra_normal[b][f]) * state.boundary.extra_normal[b][f];
          if (m.norm() < kCrossingSine || std::abs(normal.dot(m)) > m.norm() * kSameFaceCosine) continue;
          state.boundary.extra_normal[b][e] = m.normalized();
        }
        for (std::size_t e = 0; e < 2; ++e) {
          const Vec& m = state.boundary.extra_normal[b][e];
          const Vec off_plane = normal - normal.dot(m) * m;
          if (off_plane.norm() > 1e-3) normal = off_plane.normalized();
        }
        state.boundary.normal[b] = normal;
      }
    });
    state.lists.surface_decided = true;
  }

  /// sum_J V_J grad_I W_IJ over i's real row at the current positions, with the real
  /// set's volumes (the kernel normal's sum, every step): kernel_gradient_sum over the
  /// row, kLanes pairs at a time with the kernel's branch-free slope (kernels/simd.hpp).
  /// A pair beyond the support (a list with a skin) has a zero gradient, so no pair is
  /// left out. Before (2026-12-07) a scalar loop with a support test per pair: 5.5 % of
  /// the twisting column's instructions.
  template <class Kernel>
  [[gnu::always_inline]] static Vec current_kernel_gradient_sum_in_packs(const PointsView<Dim>& points,
                                                                         const double* volume, std::uint32_t i,
                                                                         std::span<const std::uint32_t> row, double h) {
    const std::size_t n = row.size();
    const std::size_t padded = padded_size(n);
    const double inverse_h = 1.0 / h;
    const double slope_factor = Kernel::slope_factor(h);
    std::array<Pack, Dim> sum{};
    for (std::size_t k = 0; k < padded; k += kLanes) {
      std::array<std::uint32_t, kLanes> j;
      for (std::size_t l = 0; l < kLanes; ++l) j[l] = k + l < n ? row[k + l] : row[0];
      Pack weight = load_indexed_pack(volume, j);
      for (std::size_t l = n > k ? n - k : 0; l < kLanes; ++l) weight[l] = 0.0;
      std::array<Pack, Dim> offset;  // x_I - x_J
      Pack r2{};
      for (int d = 0; d < Dim; ++d) {
        offset[d] = points.coordinate[d][i] - load_indexed_pack(points.coordinate[d], j);
        r2 += offset[d] * offset[d];
      }
      const Pack q = square_root(r2) * inverse_h;
      const Pack s = weight * (slope_factor * Kernel::slope_over_q(q));
      for (int d = 0; d < Dim; ++d) sum[d] += s * offset[d];
    }
    const auto total = lane_sums(sum);
    Vec result;
    for (int d = 0; d < Dim; ++d) result[d] = total[d];
    return result;
  }
  template <class Kernel>
  static Vec current_kernel_gradient_sum_sse2(const PointsView<Dim>& points, const double* volume, std::uint32_t i,
                                              std::span<const std::uint32_t> row, double h) {
    return current_kernel_gradient_sum_in_packs<Kernel>(points, volume, i, row, h);
  }
  template <class Kernel>
  TSPH_TARGET_AVX2 static Vec current_kernel_gradient_sum_avx2(const PointsView<Dim>& points, const double* volume,
                                                               std::uint32_t i, std::span<const std::uint32_t> row,
                                                               double h) {
    return current_kernel_gradient_sum_in_packs<Kernel>(points, volume, i, row, h);
  }
  template <class Kernel>
  static Vec current_kernel_gradient_sum(const SolverState<Dim>& state, const Kernel&, const PointsView<Dim>& points,
                                         std::uint32_t i) {
    const auto row = state.lists.real_from_real.neighbors(i);
    const double h = state.settings.smoothing_length;
    if (simd_path() == SimdPath::avx2)
      return current_kernel_gradient_sum_avx2<Kernel>(points, state.real.volume.data(), i, row, h);
    return current_kernel_gradient_sum_sse2<Kernel>(points, state.real.volume.data(), i, row, h);
  }

  /// sum_J V_J grad_I W_IJ over the pairs (i, j) of i's real row that `keep` accepts, at
  /// `points` (-: the kernel normal's direction).
  template <class Kernel, class VolumeOf, class Keep>
  static Vec kernel_gradient_sum(const SolverState<Dim>& state, const Kernel& kernel, const PointsView<Dim>& points,
                                 std::uint32_t i, VolumeOf volume_of, Keep keep) {
    const Vec x = points.point(i);
    Vec sum = Vec::Zero();
    for (std::uint32_t j : state.lists.real_from_real.neighbors(i))
      if (keep(j)) sum += volume_of(j) * kernel_gradient<Dim>(kernel, Vec(x - points.point(j)), state.settings.smoothing_length);
    return sum;
  }

  /// The pairs (i, j) of i's real row within the support 2h in the initial configuration
  /// (the rows hold them at the start of a run, and with the reference kernel): what the
  /// decisions made once at the first build read (surface_at_start, FreeEdge::classify).
  static auto within_at_start(const SolverState<Dim>& state, std::uint32_t i) {
    const PointsView<Dim> initial = initial_points_of<Dim>(state.real);
    const double radius = state.support_radius();
    return [initial, radius, i](std::uint32_t j) {
      return squared_distance<Dim>(initial, i, initial, j) <= radius * radius;
    };
  }

  /// kernel_gradient_sum in the initial configuration: at X, with the initial volumes
  /// m / rho0, over the pairs within_at_start.
  template <class Kernel>
  static Vec initial_kernel_gradient_sum(const SolverState<Dim>& state, const Kernel& kernel, std::uint32_t i) {
    const double density0 = state.material.elastic().reference_density();
    return kernel_gradient_sum(
        state, kernel, initial_points_of<Dim>(state.real), i,
        [&](std::uint32_t j) { return state.real.mass[j] / density0; }, within_at_start(state, i));
  }

  /// Whether real particle i lies on a surface in the initial configuration: its kernel
  /// normal there (initial_kernel_gradient_sum), and no neighbour within 60 degrees of it
  /// (the pairs within_at_start).
  template <class Kernel>
  static bool surface_at_start(const SolverState<Dim>& state, const Kernel& kernel, std::uint32_t i) {
    const PointsView<Dim> initial = initial_points_of<Dim>(state.real);
    const Vec x0 = initial.point(i);
    const auto within = within_at_start(state, i);
    const Vec sum = initial_kernel_gradient_sum(state, kernel, i);
    const double norm = sum.norm();
    if (!(norm > 0.0)) return false;
    const Vec normal = -sum / norm;
    double most_outward = -1.0;
    for (std::uint32_t j : state.lists.real_from_real.neighbors(i)) {
      if (!within(j)) continue;
      const Vec offset = initial.point(j) - x0;
      most_outward = std::max(most_outward, offset.dot(normal) / offset.norm());
    }
    return most_outward < kSurfaceCosine;
  }

  /// Whether `condition` is a free surface: a traction condition that is zero at all times.
  static bool free_surface(const SolverState<Dim>& state, std::int32_t condition) {
    if (condition < 0 || static_cast<std::size_t>(condition) >= state.boundaries.size()) return false;
    const auto& c = state.boundaries[static_cast<std::size_t>(condition)];
    return c.kind == BoundaryCondition<Dim>::Kind::traction && c.prescribes_zero();
  }

  /// 3D: two conditions that are both free surfaces (a traction condition that is zero at
  /// all times) are one surface for the normals, so that naming part of a free surface
  /// apart (a column's "free end" beside its "free surface") changes nothing: a particle
  /// on the edge where they meet takes the kernel normal between the faces and the free
  /// edge's treatment (FreeEdge), as on an edge of one condition. Before, it took the
  /// normal of its own condition's face and the other face's zero traction was not
  /// imposed there: the twisting column at alpha 0.6, dx = 1/12, diverged at its free
  /// end's edges at step 149, and ran to its end with the two conditions as one
  /// (docs/notes/2026-12-07-split-free-surfaces.md). 2D keeps the condition's own face:
  /// its free corner takes the second face's normal from that frame (characteristics.hpp).
  static bool same_free_surface(const SolverState<Dim>& state, std::int32_t a, std::int32_t b) {
    return Dim == 3 && free_surface(state, a) && free_surface(state, b);
  }

  /// The normal of the face of condition `condition` at particle i: the direction of
  /// least spread of the particle and its neighbours on that face (principal
  /// components), oriented like `kernel_normal`. Where those particles do not lie on a
  /// (Dim-1)-plane (an edge between two faces of one condition, a lone particle) the
  /// kernel normal -sum V grad W is kept. Unlike the kernel normal, this gives the face
  /// normal at corners and next to them, where half volumes and the missing neighbours
  /// tilt the kernel sum. A particle is on the face when it carries the condition, or,
  /// for a symmetry plane, keeps to it as a further plane (symmetry_planes.hpp), or, in
  /// 3D, when both its condition and `condition` are free surfaces (same_free_surface).
  static Vec face_normal(const SolverState<Dim>& state, std::uint32_t i, const Vec& kernel_normal,
                         std::int32_t condition) {
    const PointsView<Dim> real_points = points_of<Dim>(state.real);
    return face_normal(state, real_points, i, kernel_normal, condition,
                       [&](std::uint32_t j) { return state.within_support(real_points, i, real_points, j); });
  }

  /// face_normal at `points` (the current positions, or the initial ones), with the
  /// pairs `within` accepts.
  template <class Within>
  static Vec face_normal(const SolverState<Dim>& state, const PointsView<Dim>& points, std::uint32_t i,
                         const Vec& kernel_normal, std::int32_t condition, Within within) {
    if constexpr (Dim == 1) {
      (void)state, (void)points, (void)i, (void)condition, (void)within;
      return kernel_normal;
    } else {
      const bool plane = state.boundaries[static_cast<std::size_t>(condition)].kind ==
                         BoundaryCondition<Dim>::Kind::symmetry;
      const bool merge_free = same_free_surface(state, condition, condition);  // a free face, in 3D
      const auto on_face = [&](std::uint32_t j) {
        if (state.real.boundary[j] == condition) return true;
        if (merge_free && free_surface(state, state.real.boundary[j])) return true;  // same_free_surface
        const std::int32_t b = state.boundary.slot[j];
        return plane && b >= 0 && state.boundary.keeps_extra_plane(static_cast<std::size_t>(b), condition);
      };
      // The spread about the mean of the particle and its face neighbours, summed over
      // their offsets o from x_i in one pass, with no list of points (2026-12-07: the
      // list, a heap allocation per call, and Eigen's iterative eigensolver were 8.1 % of
      // the twisting column's instructions): C = sum o o^T - (sum o)(sum o)^T / count.
      // The direct 3 x 3 eigensolver is accurate here: the normal's eigenvalue is used
      // only where it lies below a tenth of the others.
      const Vec x_i = points.point(i);
      Vec offset_sum = Vec::Zero();
      Mat second_moment = Mat::Zero();
      int count = 1;  // the particle itself, at offset 0
      for (std::uint32_t j : state.lists.real_from_real.neighbors(i))
        if (on_face(j) && within(j)) {
          const Vec o = points.point(j) - x_i;
          offset_sum += o;
          second_moment.noalias() += o * o.transpose();
          ++count;
        }
      if (count < Dim) return kernel_normal;
      const Mat covariance = second_moment - offset_sum * offset_sum.transpose() / static_cast<double>(count);
      Eigen::SelfAdjointEigenSolver<Mat> eigen;
      eigen.computeDirect(covariance);
      const auto& spread = eigen.eigenvalues();  // increasing
      if (!(spread[1] > 0.0) || spread[0] > 0.1 * spread[1]) return kernel_normal;
      Vec normal = eigen.eigenvectors().col(0);
      return normal.dot(kernel_normal) >= 0.0 ? normal : Vec(-normal);
    }
  }
};

}  // namespace tsph
