// Kinematics and virtual motion (docs/method.md section 3): the displacements, and in
// updated Lagrangian the motion of both sets, in two halves around the full step (the
// midpoint configuration x^{n+1/2}, then x^{n+1}). The virtual particles move with
// their half-step velocity and are put back at their material points by the half step
// (half_step.hpp, place_at_material_point).
#pragma once

#include "engine/parallel.hpp"
#include "engine/solver/boundary/symmetry_planes.hpp"
#include "engine/solver/neighbor_lists.hpp"
#include "engine/solver/state.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace tsph {

template <int Dim>
struct Motion {
  using Vec = Vector<Dim>;
  /// The first half of the step's motion, before the full step: in updated Lagrangian
  /// both sets to the midpoint (and the lists searched again there if the skin no
  /// longer covers the motion), in small strain the first half of the displacement.
  static void first_half(SolverState<Dim>& state, double dt) {
    if (state.positions_move()) {
      move_to_midpoint(state, dt);  // and begin_displacement's update
      // The half step's virtual values; the real set only moved (the half step reads it).
      MirrorPlanes<Dim>::refresh(state, MirrorPlanes<Dim>::Fields::motion, MirrorPlanes<Dim>::Fields::evolving);
      if (state.skin_distance() > 0.0 && NeighborLists<Dim>::outdated(state, dt))
        NeighborLists<Dim>::search(state);  // lists used at the midpoint
    } else {
      begin_displacement(state, dt);
      // The half step's virtual values; the real set's u (the hourglass stiffness).
      MirrorPlanes<Dim>::refresh(state, MirrorPlanes<Dim>::Fields::motion, MirrorPlanes<Dim>::Fields::evolving);
    }
  }

  /// The second half, after the stability check: displacements, and in updated
  /// Lagrangian the positions and the lists (kept while the skin covers the motion).
  static void second_half(SolverState<Dim>& state, double dt) {
    move(state, dt);
    MirrorPlanes<Dim>::keep_on_planes(state);
    MirrorPlanes<Dim>::refresh(state, MirrorPlanes<Dim>::Fields::motion);  // the normals read the moved ghosts
    if (state.positions_move()) NeighborLists<Dim>::update_after_move(state, dt);
  }

  /// Step 1b (updated Lagrangian): both sets to the midpoint configuration x^{n+1/2},
  /// where the full step takes the velocity gradient L^{n+1/2} (midpoint rule,
  /// L^{n+1/2} dt = d(x^{n+1} - x^n) / d x^{n+1/2}): virtual particles by dt/2 v^{n+1/2}
  /// (half their straight path), real ones by dt/2 v^n (a predictor; their position
  /// enters the full step's kernel weights only, not its linear exactness). Taken at
  /// x^n instead, the gradient of v^{n+1/2} misses the half step's own motion: in a
  /// rigid rotation whose stress carries the centripetal acceleration, v^{n+1/2} =
  /// (omega J - dt/2 omega^2) (x^n - c) has divergence -omega^2 dt, a spurious
  /// compression that grew the pressure linearly in time (docs/notes/2026-11-23-objectivity-and-momentum.md). In the
  /// midpoint configuration its gradient is skew to O(dt^2). A non-finite velocity
  /// leaves its particle where it is (the stability monitor reports it). The real set's pass
  /// also makes begin_displacement's update (the same increment dt/2 v^n).
  static void move_to_midpoint(SolverState<Dim>& state, double dt) {
    const double half_dt = 0.5 * dt;
    parallel_for(state.real.size(), [&](std::size_t i) {
      for (int d = 0; d < Dim; ++d)
        if (std::isfinite(state.real.velocity[d][i])) {
          state.real.position[d][i] += half_dt * state.real.velocity[d][i];
          state.real.displacement[d][i] += half_dt * state.real.velocity[d][i];
        }
    });
    parallel_for(state.virtual_.size(), [&](std::size_t i) {
      for (int d = 0; d < Dim; ++d)
        if (std::isfinite(state.virtual_.velocity[d][i]))
          state.virtual_.position[d][i] += half_dt * state.virtual_.velocity[d][i];
    });
  }

  /// Step 1b in small strain (updated Lagrangian: move_to_midpoint): the first half of
  /// the displacement update u^{n+1} = u^n + dt/2 (v^n + v^{n+1}), u += dt/2 v^n, made
  /// before the full step overwrites v^n, so that v^n need not be stored (Dim doubles
  /// per real particle; memory). The hourglass stiffness reads u^n + dt/2 v^n from here.
  static void begin_displacement(SolverState<Dim>& state, double dt) {
    const double half_dt = 0.5 * dt;
    parallel_for(state.real.size(), [&](std::size_t i) {
      for (int d = 0; d < Dim; ++d) state.real.displacement[d][i] += half_dt * state.real.velocity[d][i];
    });
  }

  /// SolverSettings::material_velocity_motion: the real particles from the midpoint to
  /// x^{n+1} = x^n + dt v^{n+1/2}, v^{n+1/2} the virtual half-step velocity interpolated
  /// at the particle (written by the full step into state.next_position). At rest that
  /// velocity vanishes where the stress is steady (grad v^{n+1/2} = 0 and the clamp), while
  /// the real particle's own v carries -dt/2 div sigma / rho: the trapezoid moved the body
  /// at that speed, a shear the stress never saw (at the 2D cantilever's tip the sections
  /// turned 3.4 degrees less than the axis at rest, 41 x 5;
  /// docs/notes/2026-11-25-large-deflection.md). Particles with a prescribed velocity,
  /// and those whose stencil was empty, take the trapezoid, dt/2 v^{n+1}. The skin's
  /// path bound gets the largest move made here.
  static void place_real_at_next_position(SolverState<Dim>& state, double dt) {
    // In parallel blocks (it was the step's one serial pass over the particles: issue 17,
    // docs/performance.md), each keeping its largest move, combined in block order.
    std::vector<double> block_largest(static_cast<std::size_t>(std::max(1, thread_count())), 0.0);
    const std::size_t blocks =
        parallel_blocks(state.real.size(), [&](std::size_t block, std::size_t begin, std::size_t end) {
          double largest = 0.0;
          for (std::size_t i = begin; i < end; ++i) {
            bool trapezoid = !std::isfinite(state.next_position[0][i]);
            bool on_plane = false;  // a symmetry plane: the move keeps to the plane
            const std::int32_t slot = state.boundary.slot[i];
            if (slot >= 0 && !trapezoid) {
              const auto kind = state.condition_of(i).kind;
              trapezoid = kind == BoundaryCondition<Dim>::Kind::velocity;
              on_plane = kind == BoundaryCondition<Dim>::Kind::symmetry;
            }
            const auto b = static_cast<std::size_t>(slot);
            const bool further_planes = slot >= 0 && !trapezoid && SymmetryPlanes<Dim>::any(state, b);
            if (on_plane || further_planes) {
              // Along each plane (its own, and the further ones: symmetry_planes.hpp) as the
              // material, across it as the (moving) wall, whose velocity at n+1 the
              // particle has.
              Vec step;
              for (int d = 0; d < Dim; ++d) step[d] = state.next_position[d][i] - state.real.position[d][i];
              const Vec v = state.velocity_of(i);
              const auto keep_to = [&](const Vec& n) { step -= (step.dot(n) - 0.5 * dt * n.dot(v)) * n; };
              if (on_plane) keep_to(state.boundary.normal[b]);
              if (further_planes)
                for (std::size_t e = 0; e < 2 && state.boundary.extra_plane[b][e] >= 0; ++e)
                  keep_to(state.boundary.extra_normal[b][e]);
              for (int d = 0; d < Dim; ++d) state.next_position[d][i] = state.real.position[d][i] + step[d];
            }
            double moved = 0.0;
            for (int d = 0; d < Dim; ++d) {
              const double next = trapezoid ? state.real.position[d][i] + 0.5 * dt * state.real.velocity[d][i]
                                            : state.next_position[d][i];
              moved += (next - state.real.position[d][i]) * (next - state.real.position[d][i]);
              state.real.position[d][i] = next;
            }
            largest = moved > largest ? moved : largest;
          }
          block_largest[block] = largest;
        });
    double largest = 0.0;
    for (std::size_t block = 0; block < blocks; ++block)
      largest = block_largest[block] > largest ? block_largest[block] : largest;
    state.lists.real_move_bound = std::sqrt(largest);
  }

  /// Step 5: displacements with the mean of v^n and v^{n+1} (the second half, dt/2
  /// v^{n+1}; begin_displacement added dt/2 v^n); in updated-Lagrangian mode the real
  /// particles move so, the virtual ones with v^{n+1/2}: both sets are at the midpoint
  /// configuration (move_to_midpoint), so the real ones take the second half dt/2
  /// v^{n+1}, the virtual ones dt/2 v^{n+1/2} (and their displacement, if carried,
  /// dt v^{n+1/2}).
  static void move(SolverState<Dim>& state, double dt) {
    const bool moving = state.positions_move();
    const double half_dt = 0.5 * dt;
    parallel_for(state.real.size(), [&](std::size_t i) {
      for (int d = 0; d < Dim; ++d) {
        state.real.displacement[d][i] += half_dt * state.real.velocity[d][i];
        if (moving && !state.moves_with_material_velocity()) state.real.position[d][i] += half_dt * state.real.velocity[d][i];
      }
    });
    if (state.moves_with_material_velocity()) place_real_at_next_position(state, dt);
    const bool virtual_displacement = state.virtual_.carries(state.virtual_.displacement);
    if (moving) {
      parallel_for(state.virtual_.size(), [&](std::size_t i) {
        for (int d = 0; d < Dim; ++d) {
          if (virtual_displacement) state.virtual_.displacement[d][i] += dt * state.virtual_.velocity[d][i];
          state.virtual_.position[d][i] += half_dt * state.virtual_.velocity[d][i];
        }
      });
    }
  }
};

}  // namespace tsph
