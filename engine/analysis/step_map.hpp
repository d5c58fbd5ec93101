// The one-step map of the stepper as a matrix, for its spectrum (tools/tsph_spectrum.cpp):
// an analysis of the solver that runs its public stages (TaylorSph::advance_fields,
// advance_positions), the same sequence as TaylorSph::step.
//
// With particles held in place (small strain) one step is affine in the state of the
// real particles, U = (stress, velocity[, displacement]) per particle:
//     U^{n+1} = G U^n + f(t_n),
// the virtual particles' values being recomputed from the real ones every step (they
// carry no state). Column k of G is step(e_k) - step(0); f is step(0). A creep at
// constant speed under damping is a fixed point U* = G U* + f with a non-zero velocity,
// or an eigenvalue 1 of G that the load excites; an eigenvalue above 1 in modulus is
// an instability.
//
// Units: stress is divided by the P-wave impedance Z = rho c_p (so every stress and
// velocity unknown is a velocity) and displacement by dt, so that G is well scaled; the
// eigenvalues do not depend on this.
#pragma once

#include "engine/taylor_sph.hpp"

#include <Eigen/Dense>

#include <stdexcept>
#include <string>
#include <vector>

namespace tsph {

/// What one unknown of the state vector is.
struct StepMapUnknown {
  std::uint32_t particle = 0;  ///< real particle index
  enum class Field { stress, velocity, displacement } field = Field::stress;
  int component = 0;  ///< stress index (stress_index) or spatial direction
};

template <int Dim>
struct StepMapLayout {
  std::vector<StepMapUnknown> unknowns;
  double stress_unit = 1.0;        ///< Z = rho c_p (Pa per unit of the scaled stress)
  double displacement_unit = 1.0;  ///< dt (m per unit of the scaled displacement)
};

/// The unknowns: the stress components that evolve (plane stress leaves sigma_zz = 0
/// out), the velocity, and the displacement where a force depends on it (the hourglass
/// stiffness).
template <int Dim>
StepMapLayout<Dim> step_map_layout(const TaylorSph<Dim>& solver, double dt) {
  StepMapLayout<Dim> layout;
  const auto& material = solver.material();
  layout.stress_unit = material.reference_density() * material.p_wave_speed(material.reference_density());
  layout.displacement_unit = dt;
  int stresses = stress_component_count<Dim>;
  if constexpr (Dim == 2)
    if (material.plane_mode() == PlaneMode::plane_stress) stresses = 3;
  const bool with_displacement = solver.settings().hourglass_stiffness > 0.0;
  for (std::uint32_t i = 0; i < solver.real().size(); ++i) {
    for (int m = 0; m < stresses; ++m) layout.unknowns.push_back({i, StepMapUnknown::Field::stress, m});
    for (int d = 0; d < Dim; ++d) layout.unknowns.push_back({i, StepMapUnknown::Field::velocity, d});
    if (with_displacement)
      for (int d = 0; d < Dim; ++d) layout.unknowns.push_back({i, StepMapUnknown::Field::displacement, d});
  }
  return layout;
}

namespace detail {
template <int Dim>
double& unknown_ref(ParticleSet<Dim>& set, const StepMapUnknown& u) {
  switch (u.field) {
    case StepMapUnknown::Field::stress: return set.stress[u.component][u.particle];
    case StepMapUnknown::Field::velocity: return set.velocity[u.component][u.particle];
    default: return set.displacement[u.component][u.particle];
  }
}
template <int Dim>
double unit_of(const StepMapLayout<Dim>& layout, const StepMapUnknown& u) {
  return u.field == StepMapUnknown::Field::stress         ? layout.stress_unit
         : u.field == StepMapUnknown::Field::displacement ? layout.displacement_unit
                                                           : 1.0;
}
}  // namespace detail

/// Applies one step at time t to the state `in` (scaled units) and returns the state at
/// t + dt. Every real field not in the layout is zeroed first. The solver's clock is
/// left at t.
template <int Dim>
Eigen::VectorXd apply_step(TaylorSph<Dim>& solver, const StepMapLayout<Dim>& layout,
                           const Eigen::VectorXd& in, double t, double dt) {
  ParticleSet<Dim>& real = solver.state().real;
  for (auto& field : real.stress) std::fill(field.begin(), field.end(), 0.0);
  for (auto& field : real.velocity) std::fill(field.begin(), field.end(), 0.0);
  for (auto& field : real.displacement) std::fill(field.begin(), field.end(), 0.0);
  for (std::size_t k = 0; k < layout.unknowns.size(); ++k)
    detail::unknown_ref(real, layout.unknowns[k]) = in[static_cast<Eigen::Index>(k)] *
                                                    detail::unit_of(layout, layout.unknowns[k]);
  solver.set_time(t);
  // One step without the stability check (a unit vector is no physical state): the
  // stages of TaylorSph::step in its order.
  solver.advance_fields(dt);
  solver.advance_positions(dt);
  solver.set_time(t);
  Eigen::VectorXd out(in.size());
  for (std::size_t k = 0; k < layout.unknowns.size(); ++k)
    out[static_cast<Eigen::Index>(k)] =
        detail::unknown_ref(real, layout.unknowns[k]) / detail::unit_of(layout, layout.unknowns[k]);
  return out;
}

/// G, column by column: G e_k = step(e_k) - step(0) at time t (small strain only: with
/// moving particles the step is not affine in U).
template <int Dim>
Eigen::MatrixXd assemble_step_map(TaylorSph<Dim>& solver, const StepMapLayout<Dim>& layout,
                                  double t, double dt) {
  if (solver.settings().kinematics != Kinematics::small_strain)
    throw std::invalid_argument("step map: needs small_strain kinematics (fixed particles)");
  const auto n = static_cast<Eigen::Index>(layout.unknowns.size());
  Eigen::MatrixXd map(n, n);
  Eigen::VectorXd state = Eigen::VectorXd::Zero(n);
  const Eigen::VectorXd offset = apply_step(solver, layout, state, t, dt);
  for (Eigen::Index k = 0; k < n; ++k) {
    state[k] = 1.0;
    map.col(k) = apply_step(solver, layout, state, t, dt) - offset;
    state[k] = 0.0;
  }
  return map;
}

}  // namespace tsph
