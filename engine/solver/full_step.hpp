// Seed eq. (4), the full step virtual -> real:
//   U_r^{n+1} = U_r^n + dt (S_r^{n+1/2} - div F^{n+1/2}),
// with F_r^{n+1/2} interpolated from the virtual neighbours (docs/method.md section 3). At
// the boundary particles it also keeps the virtual set's derivatives at n+1/2 that the
// boundary treatments read (BoundaryParticles::half_*).
#pragma once

#include "engine/parallel.hpp"
#include "engine/solver/neighbor_lists.hpp"
#include "engine/solver/state.hpp"
#include "engine/solver/stencil_evaluation.hpp"

#include <cstdint>
#include <limits>

namespace tsph {

template <int Dim>
struct FullStep {
  using Vec = Vector<Dim>;
  using Mat = Matrix<Dim>;
  using Eval = StencilEvaluation<Dim>;
  using LocalState = typename Eval::LocalState;
  using StepScratch = typename Eval::StepScratch;
  static constexpr int stress_count = stress_component_count<Dim>;

  /// Seed eq. (4): virtual -> real, U_r^{n+1} = U_r^n + dt (S^{n+1/2} - div F^{n+1/2}).
  template <class Kernel, class Model>
  static void apply(SolverState<Dim>& state, const Kernel& kernel, const Model& model, double dt) {
    const ParticleView<Dim> source = state.virtual_.view();
    const ParticleView<Dim> target = state.real.view();
    const PointsView<Dim> source_points = points_of<Dim>(state.virtual_);
    const PointsView<Dim> target_points = points_of<Dim>(state.real);
    const double h = state.settings.smoothing_length;
    const bool objective = state.objective_rates(), compressible = state.density_follows();
    NeighborLists<Dim>::prepare_full_step(state);  // without skin in updated Lagrangian: searched now
    const bool material_motion = state.moves_with_material_velocity();
    if (material_motion)
      for (auto& component : state.next_position) component.assign(target.count, std::numeric_limits<double>::quiet_NaN());
    state.add(parallel_for_with_scratch<StepScratch, StencilCounts>(
        target.count, [&](std::size_t r, StepScratch& scratch, StencilCounts& counts) {
          StencilWeights<Dim>& w = scratch.weights;
          const auto nb = state.lists.real_from_virtual.neighbors(r);
          const StencilStatus status =
              compute_stencil<Dim>(kernel, h, target.position_of(r), source_points,
                                   source.volume, nb, state.settings.interpolation, w);
          counts += status;
          if (status.no_neighbors) {
            if (const std::int32_t b = state.boundary.slot[r]; b >= 0) {  // no stale gradients
              state.boundary.half_velocity_gradient[static_cast<std::size_t>(b)].setZero();
              state.boundary.half_velocity[static_cast<std::size_t>(b)].setZero();
              state.boundary.gradient_sum[static_cast<std::size_t>(b)].setZero();
              for (auto& g : state.boundary.half_stress_gradient[static_cast<std::size_t>(b)]) g.setZero();
            }
            return;
          }
          const LocalState s = Eval::evaluate(source, nb, w, scratch.gathered);
          if (const std::int32_t b = state.boundary.slot[r]; b >= 0) {
            // Tangential derivatives at n+1/2 for the boundary conditions.
            state.boundary.half_velocity_gradient[static_cast<std::size_t>(b)] = s.velocity_gradient;
            state.boundary.half_velocity[static_cast<std::size_t>(b)] = s.velocity;
            Vec gradient_sum = Vec::Zero();  // sum_J V_J Gn_IJ: the gradient of a jump at I
            Vec centroid = Vec::Zero();  // of the virtual stencil (surface_extrapolation)
            std::size_t in_support = 0;  // a row with a skin also holds pairs beyond 2h
            for (std::size_t k = 0; k < nb.size(); ++k) {
              gradient_sum += w.gradient_of(k);
              if (!state.within_support(target_points, r, source_points, nb[k])) continue;
              centroid += state.virtual_.position_of(nb[k]);
              ++in_support;
            }
            state.boundary.gradient_sum[static_cast<std::size_t>(b)] = gradient_sum;
            state.boundary.stencil_offset[static_cast<std::size_t>(b)] =
                target.position_of(r) - centroid / static_cast<double>(in_support);
            state.boundary.half_stress_gradient[static_cast<std::size_t>(b)] =
                Eval::stress_gradient(source, nb, w, s.stress);
          }
          if (material_motion)  // x^{n+1} = x^n + dt v^{n+1/2}(x_r), from the midpoint x^n + dt/2 v_r^n
            for (int d = 0; d < Dim; ++d)
              state.next_position[d][r] = target.position[d][r] + dt * (s.velocity[d] - 0.5 * target.velocity[d][r]);
          StressVector<Dim> previous;  // sigma_r^n; the Jaumann terms rotate the interpolated s.stress
          for (int m = 0; m < stress_count; ++m) previous[m] = target.stress[m][r];
          const StressVector<Dim> stress = model.update_stress({previous, s.stress, s.velocity_gradient, dt, objective});
          for (int m = 0; m < stress_count; ++m) target.stress[m][r] = stress[m];
          for (int d = 0; d < Dim; ++d)
            target.velocity[d][r] +=
                dt * (s.stress_divergence[d] / s.density + state.settings.body_force[d] -
                      state.settings.damping * s.velocity[d]);
          if (compressible) {
            target.density[r] *= exp_of_small(-dt * s.velocity_gradient.trace());
            target.volume[r] = target.mass[r] / target.density[r];
          }
        }));
  }
};

}  // namespace tsph
