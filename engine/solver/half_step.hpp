// Seed eq. (3), the half step real -> virtual: U^n interpolated to every virtual
// particle with the normalised kernel, then U_v^{n+1/2} = U_v^n + dt/2 (S_v^n - div F),
// the divergence from sum_r V_r (F_r^n - F_v^n) . Gn_vr (docs/method.md section 3). In
// updated Lagrangian the virtual particles are put back at their material points here.
#pragma once

#include "engine/parallel.hpp"
#include "engine/solver/state.hpp"
#include "engine/solver/stencil_evaluation.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <span>

namespace tsph {

template <int Dim>
struct HalfStep {
  using Vec = Vector<Dim>;
  using Mat = Matrix<Dim>;
  using Eval = StencilEvaluation<Dim>;
  using LocalState = typename Eval::LocalState;
  using StepScratch = typename Eval::StepScratch;
  static constexpr int stress_count = stress_component_count<Dim>;

  /// Updated Lagrangian: the virtual particles move with their half-step velocity and are
  /// put back at their material points at the half step of every
  /// kMaterialPointInterval-th step (steps 0, 8, ...): the drift is slow.
  static constexpr std::int64_t kMaterialPointInterval = 8;

  /// The half step's counters, and the largest move of place_at_material_point.
  struct HalfStepCounts : StencilCounts {
    double largest_shift = 0.0;
    HalfStepCounts& operator+=(const StencilStatus& status) {
      StencilCounts::operator+=(status);
      return *this;
    }
    HalfStepCounts& operator+=(const HalfStepCounts& other) {
      StencilCounts::operator+=(other);
      largest_shift = std::max(largest_shift, other.largest_shift);
      return *this;
    }
  };


  /// Seed eq. (3): real -> virtual, U_v^{n+1/2} = U_v^n + dt/2 (S - div F).
  template <class Kernel, class Model>
  static void apply(SolverState<Dim>& state, const Kernel& kernel, const Model& model, double dt) {
    const ParticleView<Dim> source = state.real.view();
    const ParticleView<Dim> target = state.virtual_.view();
    const PointsView<Dim> source_points = points_of<Dim>(state.real);
    const double h = state.settings.smoothing_length;
    const double half_dt = 0.5 * dt;
    const bool objective = state.objective_rates(), compressible = state.density_follows();
    const bool plastic = state.material.plastic();
    // The drift it removes is slow (the 2D cantilever: 1e-5 dx per step), so every
    // kMaterialPointInterval-th step is enough; each costs ~15 % of a 2D step (callgrind).
    const bool to_material_point =
        state.positions_move() && state.counters.steps % kMaterialPointInterval == 0;
    const bool reference = state.reference_kernel();  // SolverSettings::kernel_configuration
    const PointsView<Dim> target_reference = reference ? initial_points_of<Dim>(state.virtual_) : PointsView<Dim>{};
    const bool driven = state.driven();  // SolverState::driven_condition
    const PointsView<Dim> target_initial = driven ? initial_points_of<Dim>(state.virtual_) : PointsView<Dim>{};
    const double half_time = state.time + half_dt;
    KernelFactorCache& factors = state.half_kernel_factors;
    const bool cached = state.use_kernel_factors(factors, state.lists.virtual_from_real);
    const HalfStepCounts shifts = parallel_for_with_scratch<StepScratch, HalfStepCounts>(
        target.count, [&](std::size_t q, StepScratch& scratch, HalfStepCounts& counts) {
          StencilWeights<Dim>& w = scratch.weights;
          const auto nb = state.lists.virtual_from_real.neighbors(q);
          ReferenceStencil<Dim> row_reference =
              reference ? SolverState<Dim>::reference_stencil(target_reference.point(q), state.real) : ReferenceStencil<Dim>{};
          if (cached) factors.attach(row_reference, q);
          const StencilStatus status =
              compute_stencil<Dim>(kernel, h, target.position_of(q), source_points,
                                   source.volume, nb, state.settings.interpolation, w, simd_path(),
                                   reference ? &row_reference : nullptr);
          counts += status;
          if (status.no_neighbors) return;  // isolated: keeps its values (counted)
          const LocalState s = Eval::evaluate(source, nb, w, scratch.gathered);
          const StressUpdate<Dim> update{s.stress, s.stress, s.velocity_gradient, half_dt, objective, true};
          const StressVector<Dim> stress =
              plastic ? plastic_stress(state, update, nb, w) : model.update_stress(update);
          for (int m = 0; m < stress_count; ++m) target.stress[m][q] = stress[m];
          if (driven) {  // the prescribed v^{n+1/2} at the virtual particle's material point
            const Vec v = state.driven_velocity(target_initial.point(q), half_time);
            for (int d = 0; d < Dim; ++d) target.velocity[d][q] = v[d];
          } else {
            for (int d = 0; d < Dim; ++d)
              target.velocity[d][q] =
                  s.velocity[d] + half_dt * (s.stress_divergence[d] / s.density +
                                             state.settings.body_force[d] -
                                             state.settings.damping * s.velocity[d]);
          }
          const double density =
              compressible ? s.density * exp_of_small(-half_dt * s.velocity_gradient.trace()) : s.density;
          target.density[q] = density;
          target.volume[q] = target.mass[q] / density;
          if (to_material_point && !status.gradient_fallback)
            counts.largest_shift = std::max(counts.largest_shift, place_at_material_point(state, q, nb, w));
        });
    state.add(shifts);
    if (cached) factors.mark_filled();
    state.lists.virtual_path_bound += shifts.largest_shift;  // the lists' skin check (NeighborLists::outdated)
  }

  /// A plastic material's stress at n+1/2 of a virtual particle, with its state at n
  /// interpolated from its real row (used once; out of line: the elastic loop stays lean).
  [[gnu::noinline]] static StressVector<Dim> plastic_stress(const SolverState<Dim>& state, const StressUpdate<Dim>& update,
                                                            std::span<const std::uint32_t> nb, const StencilWeights<Dim>& w) {
    PlasticState at_n = state.interpolated_plastic_state(nb, w.value.data());
    return state.material.update_stress(update, at_n);
  }

  /// Puts virtual particle q back at the material point X_q it stands for, read from its
  /// half-step stencil w over the real row nb: with the interpolated initial coordinates
  /// Xbar = sum_J w_J X_J, the interpolated positions xbar = sum_J w_J x_J and the
  /// corrected gradient G = sum_J (X_J - Xbar) (x) grad w_J = dX/dx, it moves to
  /// x_q = xbar + G^{-1} (X_q - Xbar) (exact for every affine motion, rigid ones
  /// included). Moved by their half-step velocity alone the virtual particles drift from
  /// their cells once the body is at rest (v^{n+1/2} carries dt/2 div sigma / rho of the
  /// real stresses). Returns the distance moved (0 where G is singular: the particle stays).
  static double place_at_material_point(SolverState<Dim>& state, std::size_t q, std::span<const std::uint32_t> nb, const StencilWeights<Dim>& w) {
    const bool virtual_displacement = state.virtual_.carries(state.virtual_.displacement);
    Vec reference_mean = Vec::Zero(), position_mean = Vec::Zero();
    for (std::size_t k = 0; k < nb.size(); ++k) {
      const std::uint32_t j = nb[k];
      for (int d = 0; d < Dim; ++d) {
        reference_mean[d] += w.value[k] * state.real.initial_position[d][j];
        position_mean[d] += w.value[k] * state.real.position[d][j];
      }
    }
    Mat reference_gradient = Mat::Zero();  // dX/dx
    for (std::size_t k = 0; k < nb.size(); ++k) {
      const std::uint32_t j = nb[k];
      for (int a = 0; a < Dim; ++a) {
        const double dX = state.real.initial_position[a][j] - reference_mean[a];
        for (int b = 0; b < Dim; ++b) reference_gradient(a, b) += dX * w.gradient[b][k];
      }
    }
    const double determinant = reference_gradient.determinant();
    if (!(std::abs(determinant) > 1e-6)) return 0.0;
    Vec material;
    for (int d = 0; d < Dim; ++d) material[d] = state.virtual_.initial_position[d][q] - reference_mean[d];
    const Vec placed = position_mean + reference_gradient.inverse() * material;
    double moved = 0.0;
    for (int d = 0; d < Dim; ++d) {
      moved += (placed[d] - state.virtual_.position[d][q]) * (placed[d] - state.virtual_.position[d][q]);
      state.virtual_.position[d][q] = placed[d];
      if (virtual_displacement) state.virtual_.displacement[d][q] = placed[d] - state.virtual_.initial_position[d][q];
    }
    return std::sqrt(moved);
  }
};

}  // namespace tsph
