// Further symmetry planes of a boundary particle (issue 16: the Taylor bar's quarter
// model). A particle carries one condition (ParticleSet::boundary); where a symmetry
// plane's region also holds particles that a later condition of the case took (the
// axis where two planes meet, a free surface or a wall crossing the plane), those
// particles keep to that plane as well (BoundaryCondition::also_on_plane,
// BoundaryParticles::extra_plane). Their own condition is applied first (the
// characteristic treatment along its normal, or the prescribed velocity); then, for each
// further plane of unit normal m, what the mirror image across it requires:
//   v . m = w . m          (w the plane's velocity: 0 for a fixed plane, a wall's),
//   sigma m = (m . sigma m) m   (no shear traction on the plane),
// by projection: v -= (v . m - w . m) m, sigma <- P sigma P + (m . sigma m) m m^T with
// P = I - m m^T. With m orthogonal to the particle's own normal n, the projection keeps
// what the own condition imposed (n . sigma t = 0 for t orthogonal to n stays zero).
// The normals follow the particles (boundary/normals.hpp); the motion keeps to the
// planes (kinematics.hpp), the hourglass stiffness's force acts along them
// (stabilisation/hourglass_stiffness.hpp), and the energy ledger books their power.
#pragma once

#include "engine/solver/state.hpp"

namespace tsph {

template <int Dim>
struct SymmetryPlanes {
  using Vec = Vector<Dim>;
  using Mat = Matrix<Dim>;

  /// Whether boundary slot b keeps to a further plane (one whose normal is 0 this step,
  /// on the particle's own face, is left out: boundary/normals.hpp; its projection is
  /// the identity).
  static bool any(const SolverState<Dim>& state, std::size_t b) { return state.boundary.extra_plane[b][0] >= 0; }

  /// The velocity of the further plane e (0 or 1) of slot b at time t, along its normal
  /// (w . m; the plane's prescribed velocity is uniform).
  static double normal_speed(const SolverState<Dim>& state, std::size_t b, int e, double t) {
    const auto k = static_cast<std::size_t>(state.boundary.extra_plane[b][static_cast<std::size_t>(e)]);
    const BoundaryCondition<Dim>& plane = state.boundaries[k];
    const Vec w = plane.prescribed(state.initial_position_of(state.boundary.particle[b]), Vec::Ones(), t);
    return w.dot(state.boundary.extra_normal[b][static_cast<std::size_t>(e)]);
  }

  /// Projects a velocity onto each further plane of slot b: v . m = w . m.
  static void project_velocity(const SolverState<Dim>& state, std::size_t b, double t, Vec& velocity) {
    for (int e = 0; e < 2 && state.boundary.extra_plane[b][static_cast<std::size_t>(e)] >= 0; ++e) {
      const Vec& m = state.boundary.extra_normal[b][static_cast<std::size_t>(e)];
      velocity -= (velocity.dot(m) - normal_speed(state, b, e, t)) * m;
    }
  }

  /// No shear traction on the plane of unit normal m: sigma <- P sigma P + (m . sigma m)
  /// m m^T with P = I - m m^T (an in-plane stress and its normal, or both in 3 x 3).
  template <class Tensor, class Normal>
  static void remove_shear_traction(const Normal& m, Tensor& stress) {
    const Tensor projector = Tensor::Identity() - m * m.transpose();
    const double normal_stress = m.dot(stress * m);
    stress = projector * stress * projector + normal_stress * (m * m.transpose());
  }
  /// The same on a stress in the particle arrays' layout (sigma_zz of 2D kept).
  static void remove_shear_traction(const Vec& m, StressVector<Dim>& stress) {
    Eigen::Vector3d normal = Eigen::Vector3d::Zero();
    normal.template head<Dim>() = m;
    Eigen::Matrix3d tensor = to_tensor<Dim>(stress);
    remove_shear_traction(normal, tensor);
    stress = from_tensor<Dim>(tensor);
  }

  /// Projects a velocity and an in-plane stress onto each further plane of slot b (see
  /// the file comment).
  static void project(const SolverState<Dim>& state, std::size_t b, double t, Vec& velocity, Mat& stress) {
    project_velocity(state, b, t, velocity);
    for (int e = 0; e < 2 && state.boundary.extra_plane[b][static_cast<std::size_t>(e)] >= 0; ++e)
      remove_shear_traction(state.boundary.extra_normal[b][static_cast<std::size_t>(e)], stress);
  }

  /// The projection applied to real particle i's stored velocity and stress (slot b).
  static void project_particle(SolverState<Dim>& state, std::size_t b, std::uint32_t i, double t) {
    Vec velocity = state.velocity_of(i);
    StressVector<Dim> stress = SolverState<Dim>::stress_of(state.real, i);
    Mat in_plane_stress = to_tensor<Dim>(stress).template topLeftCorner<Dim, Dim>();
    project(state, b, t, velocity, in_plane_stress);
    for (int r = 0; r < Dim; ++r)
      for (int c = r; c < Dim; ++c) stress[stress_index<Dim>(r, c)] = in_plane_stress(r, c);
    for (int d = 0; d < Dim; ++d) state.real.velocity[d][i] = velocity[d];
    for (int m = 0; m < stress_component_count<Dim>; ++m) state.real.stress[m][i] = stress[m];
  }

  /// Removes the components of a force (or a move) along each further plane's normal.
  static void along_planes(const SolverState<Dim>& state, std::size_t b, Vec& vector) {
    for (int e = 0; e < 2 && state.boundary.extra_plane[b][static_cast<std::size_t>(e)] >= 0; ++e) {
      const Vec& m = state.boundary.extra_normal[b][static_cast<std::size_t>(e)];
      vector -= vector.dot(m) * m;
    }
  }
};

}  // namespace tsph
