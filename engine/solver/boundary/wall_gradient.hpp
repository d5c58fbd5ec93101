// SolverSettings::VelocityWall::wall_gradient: the stress of the particles on a
// prescribed-velocity surface by the bulk update (seed eq. 4) with the velocity
// gradient taken relative to the wall velocity, so that a virtual velocity that does not
// vanish at a fixed wall (a rigid rotation about the clamp) is a strain there and meets
// a stress; on a moving smooth wall (a footing) relative to its normal velocity only.
#pragma once

#include "engine/solver/boundary/symmetry_planes.hpp"
#include "engine/solver/state.hpp"

#include <cmath>

namespace tsph {

template <int Dim>
struct WallGradient {
  using Vec = Vector<Dim>;
  using Mat = Matrix<Dim>;
  static constexpr int stress_count = stress_component_count<Dim>;

  /// SolverSettings::VelocityWall::wall_gradient at a prescribed-velocity particle:
  /// sigma^{n+1} = sigma^n + dt D : grad v^{n+1/2} (seed eq. 4), with the gradient of the
  /// virtual half-step velocity relative to the prescribed v^{n+1/2} at the particle,
  ///     sum_J V_J (v_J - v_wall) Gn_IJ = grad v + (v(x_I) - v_wall) (x) sum_J V_J Gn_IJ,
  /// and v^{n+1} prescribed.
  template <class Model>
  static void apply(SolverState<Dim>& state, const Model& model, std::size_t b, std::uint32_t i, const BoundaryCondition<Dim>& condition,
                           double dt, double t_new) {
    const Vec wall_half = condition.prescribed(state.initial_position_of(i), state.boundary.profile[b], t_new - 0.5 * dt);
    const Mat gradient = state.boundary.half_velocity_gradient[b] +
                         (state.boundary.half_velocity[b] - wall_half) * state.boundary.gradient_sum[b].transpose();
    const StressVector<Dim>& previous = state.boundary.stress[b];
    (void)model;  // state.material
    const StressVector<Dim> stress = state.update_real_stress(i, {previous, previous, gradient, dt, state.objective_rates()}, true);
    for (int m = 0; m < stress_count; ++m) state.real.stress[m][i] = stress[m];
    const Vec v = condition.prescribed(state.initial_position_of(i), state.boundary.profile[b], t_new);
    for (int d = 0; d < Dim; ++d) state.real.velocity[d][i] = v[d];
    follow_density(state, b, i, dt, gradient.trace());
  }

  /// The same at a particle of a moving smooth wall (BoundaryCondition::moving_smooth_wall,
  /// a footing) of unit normal n: only the normal velocity is the wall's, w . n, so the
  /// gradient is taken relative to it along n alone,
  ///     grad v + ((v(x_I) - w) . n) n (x) sum_J V_J Gn_IJ,
  /// the stress updated elastically by the bulk rule, its shear traction on the plane
  /// removed (SymmetryPlanes::remove_shear_traction), and then (a plastic material)
  /// returned to the yield surface with the particle's state at n, as the characteristic
  /// relations' stress is: the plastic state books the stress that is kept. The velocity
  /// at n+1 is the full step's along the plane and the wall's across it.
  static void apply_smooth_wall(SolverState<Dim>& state, std::size_t b, std::uint32_t i,
                                const BoundaryCondition<Dim>& condition, double dt, double t_new) {
    const Vec& n = state.boundary.normal[b];
    const Vec wall_half = condition.prescribed(state.initial_position_of(i), state.boundary.profile[b], t_new - 0.5 * dt);
    const double relative = (state.boundary.half_velocity[b] - wall_half).dot(n);
    const Mat gradient =
        state.boundary.half_velocity_gradient[b] + relative * n * state.boundary.gradient_sum[b].transpose();
    const StressVector<Dim>& previous = state.boundary.stress[b];
    StressVector<Dim> stress = state.material.elastic().update_stress({previous, previous, gradient, dt, state.objective_rates()});
    SymmetryPlanes<Dim>::remove_shear_traction(n, stress);
    stress = state.return_real_stress(i, stress, dt);
    for (int m = 0; m < stress_count; ++m) state.real.stress[m][i] = stress[m];
    const Vec w = condition.prescribed(state.initial_position_of(i), state.boundary.profile[b], t_new);
    Vec v = state.velocity_of(i);
    v += (w.dot(n) - v.dot(n)) * n;
    for (int d = 0; d < Dim; ++d) state.real.velocity[d][i] = v[d];
    follow_density(state, b, i, dt, gradient.trace());
  }

 private:
  /// The density from the same velocity gradient (the full step's one-sided estimate is
  /// replaced, like the rest of the boundary state).
  static void follow_density(SolverState<Dim>& state, std::size_t b, std::uint32_t i, double dt, double divergence) {
    if (!state.density_follows()) return;
    state.real.density[i] = state.boundary.density[b] * std::exp(-dt * divergence);
    state.real.volume[i] = state.real.mass[i] / state.real.density[i];
  }
};

}  // namespace tsph
