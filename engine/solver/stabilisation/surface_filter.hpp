// SolverSettings::hourglass_coefficient: the surface hourglass filter. Each step the
// velocity of every real particle on a traction (free or loaded) surface is relaxed
// towards the linear-corrected average of its real neighbours,
// v <- (1 - eps) v + eps vbar, exact for linear fields. Without it a surface particle
// can hold a steady velocity pattern that the virtual set cannot see (the real-particle
// checkerboard of docs/method.md section 5, fed by the characteristic relations).
#pragma once

#include "engine/parallel.hpp"
#include "engine/solver/boundary/symmetry_planes.hpp"
#include "engine/solver/state.hpp"
#include "engine/solver/stencil_evaluation.hpp"

#include <vector>

namespace tsph {

template <int Dim>
class SurfaceHourglassFilter {
 public:
  using Vec = Vector<Dim>;

  /// Step 4: hourglass control at free and loaded surfaces (see
  /// SolverSettings::hourglass_coefficient).
  template <class Kernel>
  void apply(SolverState<Dim>& state, const Kernel& kernel) {
    const ParticleView<Dim> set = state.real.view();
    const PointsView<Dim> points = points_of<Dim>(state.real);
    const double epsilon = state.settings.hourglass_coefficient;
    const std::size_t count = state.boundary.particle.size();
    filtered_velocity_.resize(count);
    state.add(parallel_for_with_scratch<StencilWeights<Dim>, StencilCounts>(
        count, [&](std::size_t b, StencilWeights<Dim>& w, StencilCounts& counts) {
          const std::uint32_t i = state.boundary.particle[b];
          const auto& condition = state.boundaries[static_cast<std::size_t>(state.real.boundary[i])];
          filtered_velocity_[b] = state.velocity_of(i);
          if (condition.kind != BoundaryCondition<Dim>::Kind::traction || !state.boundary.on_surface[b])
            return;  // prescribed velocities are not filtered
          const auto nb = state.lists.real_from_real.neighbors(i);
          const StencilStatus status =
              compute_stencil<Dim>(kernel, state.settings.smoothing_length, set.position_of(i), points,
                                   set.volume, nb, InterpolationKind::linear, w);
          counts += status;
          if (status.no_neighbors) return;
          Vec average = Vec::Zero();
          for (std::size_t k = 0; k < nb.size(); ++k)
            for (int d = 0; d < Dim; ++d) average[d] += w.value[k] * set.velocity[d][nb[k]];
          // Where the linear interpolation is singular (a corner at alpha 0.6: two real
          // neighbours) the Shepard average is the value at their centroid, dx / sqrt(2)
          // inside: carried to the particle with its real-set gradient at n (gradients_at_n),
          // so that the filter stays exact for linear fields there too. Before, it pulled a
          // spinning block's corners towards the slower centroid velocity, 2 % a step: the
          // block at alpha 0.6 lost angular momentum in proportion to the number of steps.
          if (status.interpolation_fallback) {
            Vec centroid = Vec::Zero();
            for (std::size_t k = 0; k < nb.size(); ++k) centroid += w.value[k] * set.position_of(nb[k]);
            average += state.boundary.velocity_gradient[b] * (set.position_of(i) - centroid);
          }
          filtered_velocity_[b] = (1.0 - epsilon) * state.velocity_of(i) + epsilon * average;
          if (SymmetryPlanes<Dim>::any(state, b)) {  // further planes keep v . m
            Vec change = filtered_velocity_[b] - state.velocity_of(i);
            SymmetryPlanes<Dim>::along_planes(state, b, change);
            filtered_velocity_[b] = state.velocity_of(i) + change;
          }
        }));
    for (std::size_t b = 0; b < count; ++b)
      for (int d = 0; d < Dim; ++d) state.real.velocity[d][state.boundary.particle[b]] = filtered_velocity_[b][d];
  }

 private:
  std::vector<Vec> filtered_velocity_;  ///< per boundary slot, written before it is read
};

}  // namespace tsph
