// SolverSettings::conservative_momentum: the momentum update in conservative (weak,
// Galerkin) form instead of the corrected divergence for every real particle without a
// velocity condition or a non-zero traction,
//   m_I dv_I/dt = -sum_v V_v sigma_v^{n+1/2} . D_vI,
// D_vI the weight of I in the half step's corrected gradient at v (sum_I D_vI = 0), so
// that every virtual particle's forces sum to zero: linear momentum is conserved to
// round-off without external loads, and free surfaces are natural (zero traction).
#pragma once

#include "engine/parallel.hpp"
#include "engine/solver/boundary/symmetry_planes.hpp"
#include "engine/solver/state.hpp"
#include "engine/solver/stencil_evaluation.hpp"

#include <array>
#include <cstdint>
#include <vector>

namespace tsph {

template <int Dim>
class ConservativeMomentum {
 public:
  using Vec = Vector<Dim>;

  /// Part 1, after the half step and Motion::first_half (updated Lagrangian: in the
  /// midpoint configuration, about which the forces then exert no torque): v^n, and the weights D_vJ = G_vJ - Wn_vJ sum_K G_vK of the half step's
  /// corrected gradient (grad f)_v = sum_J D_vJ f_J (configuration n), per pair of
  /// state.lists.virtual_from_real, and the transposed pair list (rows: real particles, entries:
  /// pair indices in increasing virtual order, so the sums are deterministic).
  template <class Kernel>
  void store_weights(SolverState<Dim>& state, const Kernel& kernel) {
    const PointsView<Dim> source_points = points_of<Dim>(state.real);
    const ParticleView<Dim> target = state.virtual_.view();
    for (int d = 0; d < Dim; ++d) previous_velocity_[d] = state.real.velocity[d];  // v^n
    momentum_weight_.resize(state.lists.virtual_from_real.pair_count());
    parallel_for_with_scratch<StencilWeights<Dim>, StencilCounts>(
        target.count, [&](std::size_t q, StencilWeights<Dim>& w, StencilCounts&) {
          const auto nb = state.lists.virtual_from_real.neighbors(q);
          const std::size_t first = state.lists.virtual_from_real.row_begin(q);
          const StencilStatus status =
              compute_stencil<Dim>(kernel, state.settings.smoothing_length, target.position_of(q),
                                   source_points, state.real.volume.data(), nb,
                                   state.settings.interpolation, w);
          Vec sum = Vec::Zero();
          for (std::size_t k = 0; k < nb.size(); ++k) sum += w.gradient_of(k);
          for (std::size_t k = 0; k < nb.size(); ++k)
            momentum_weight_[first + k] =
                status.no_neighbors ? Vec(Vec::Zero()) : Vec(w.gradient_of(k) - w.value[k] * sum);
        });
    momentum_pair_offsets_.assign(state.real.size() + 1, 0);
    for (std::uint32_t j : state.lists.virtual_from_real.indices) ++momentum_pair_offsets_[j + 1];
    for (std::size_t i = 0; i < state.real.size(); ++i)
      momentum_pair_offsets_[i + 1] += momentum_pair_offsets_[i];
    momentum_pair_.resize(state.lists.virtual_from_real.pair_count());
    momentum_pair_virtual_.resize(state.lists.virtual_from_real.pair_count());
    std::vector<std::uint64_t> fill(momentum_pair_offsets_.begin(), momentum_pair_offsets_.end() - 1);
    for (std::size_t q = 0; q < state.virtual_.size(); ++q)
      for (std::uint64_t p = state.lists.virtual_from_real.row_begin(q); p < state.lists.virtual_from_real.row_begin(q + 1); ++p) {
        const std::uint64_t slot = fill[state.lists.virtual_from_real.indices[p]]++;
        momentum_pair_[slot] = p;
        momentum_pair_virtual_[slot] = static_cast<std::uint32_t>(q);
      }
  }

  /// Conservative momentum, part 2, after the boundary conditions: for every real
  /// particle without a velocity condition or a non-zero prescribed traction,
  ///   v_I^{n+1} = v_I^n + dt (F_I / m_I + b - c v_I^n),
  ///   F_I = -sum_v V_v^{n+1/2} sigma_v^{n+1/2} . D_vI.
  /// sum_I D_vI = 0 for every v, so sum_I F_I = 0 (linear momentum exact without loads);
  /// sum_I v_I . F_I = -sum_v V_v sigma_v : (grad v)_v (the stress power at the virtual
  /// particles). A free surface is natural: its particles collect the flux the bulk
  /// sends them (zero traction). Their stress still comes from the characteristics.
  void apply(SolverState<Dim>& state, double dt, double t_new) {
    const ParticleView<Dim> source = state.virtual_.view();
    parallel_for(state.real.size(), [&](std::size_t i) {
      const std::int32_t b = state.boundary.slot[i];
      bool on_own_plane = false;  // a fixed symmetry plane (a moving wall keeps its boundary stage's velocity)
      if (b >= 0) {
        const auto& condition = state.boundaries[static_cast<std::size_t>(state.real.boundary[i])];
        if (condition.kind == BoundaryCondition<Dim>::Kind::velocity) return;
        const Vec traction =
            condition.prescribed(state.initial_position_of(i), state.boundary.profile[static_cast<std::size_t>(b)], t_new);
        if (traction.squaredNorm() > 0.0) return;  // a loaded surface keeps its characteristics
        on_own_plane = condition.kind == BoundaryCondition<Dim>::Kind::symmetry && state.boundary.on_surface[static_cast<std::size_t>(b)];
      }
      Vec force = Vec::Zero();
      for (std::uint64_t slot = momentum_pair_offsets_[i]; slot < momentum_pair_offsets_[i + 1]; ++slot) {
        const std::uint32_t q = momentum_pair_virtual_[slot];
        const Vec& weight = momentum_weight_[momentum_pair_[slot]];
        for (int a = 0; a < Dim; ++a)
          for (int l = 0; l < Dim; ++l)
            force[a] -= source.volume[q] * source.stress[stress_index<Dim>(a, l)][q] * weight[l];
      }
      Vec velocity;
      for (int d = 0; d < Dim; ++d)
        velocity[d] = previous_velocity_[d][i] + dt * (force[d] / state.real.mass[i] + state.settings.body_force[d] -
                                                       state.settings.damping * previous_velocity_[d][i]);
      // A particle on a fixed symmetry plane keeps v . n = 0 (the plane's reaction is not
      // among the virtual forces), and one on further planes keeps to them as well.
      if (b >= 0) {
        const auto slot = static_cast<std::size_t>(b);
        if (on_own_plane) velocity -= velocity.dot(state.boundary.normal[slot]) * state.boundary.normal[slot];
        if (SymmetryPlanes<Dim>::any(state, slot)) SymmetryPlanes<Dim>::project_velocity(state, slot, t_new, velocity);
      }
      for (int d = 0; d < Dim; ++d) state.real.velocity[d][i] = velocity[d];
      if (!state.damped_velocity[0].empty())  // the energy ledger's damping: this update's
        for (int d = 0; d < Dim; ++d) state.damped_velocity[d][i] = previous_velocity_[d][i];
    });
  }

 private:
  /// v^n of the real particles (the update starts from it; the full step overwrites it).
  std::array<std::vector<double>, Dim> previous_velocity_;
  std::vector<Vec> momentum_weight_;                  ///< D_vJ per pair of virtual_from_real
  std::vector<std::uint64_t> momentum_pair_offsets_;  ///< row starts, rows of real particles
  std::vector<std::uint64_t> momentum_pair_;          ///< pair index, row by real particle
  std::vector<std::uint32_t> momentum_pair_virtual_;  ///< its virtual particle
};

}  // namespace tsph
