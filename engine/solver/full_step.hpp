// Seed eq. (4), the full step virtual -> real:
//   U_r^{n+1} = U_r^n + dt (S_r^{n+1/2} - div F^{n+1/2}),
// with F_r^{n+1/2} interpolated from the virtual neighbours (docs/method.md section 3). At
// the boundary particles it also keeps the virtual set's derivatives at n+1/2 that the
// boundary treatments read (BoundaryParticles::half_*).
#pragma once

#include "engine/parallel.hpp"
#include "engine/solver/neighbor_lists.hpp"
#include "engine/solver/stabilisation/volumetric_average.hpp"
#include "engine/solver/state.hpp"
#include "engine/solver/stencil_evaluation.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <array>
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

namespace tsph {

/// Updated Lagrangian: the largest squared 2-norm of a row's linear interpolation
/// weights, sum_J Wn_IJ^2 (StencilStatus::weight_squares), that the full step keeps
/// (FullStep::apply; a larger row takes Shepard's). Shepard's weights have at most 1. Measured 2026-11-26 over every row and step of the
/// rotating blocks (2D, 3D), the homogeneous block and the plate at alpha 1.2 and the
/// large-deflection beam at alpha 0.6: at most 6.4 (a cube's corner at alpha 1.2); the
/// nearly coplanar face rows of a moving cube at alpha 0.6: 1e3 to 5e8.
inline constexpr double kMaxInterpolationWeightSquares = 16.0;

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
    const double h = state.settings.smoothing_length;
    const bool objective = state.objective_rates(), compressible = state.density_follows();
    const bool plastic = state.material.plastic();  // the model's state: SolverState::update_real_stress
    NeighborLists<Dim>::prepare_full_step(state);  // without skin in updated Lagrangian: searched now
    const bool material_motion = state.moves_with_material_velocity();
    using Deficient = typename SolverSettings<Dim>::DeficientStencils;
    const Deficient deficient = state.positions_move() ? state.settings.deficient_stencils : Deficient::keep;
    if (material_motion)
      for (auto& component : state.next_position) component.assign(target.count, std::numeric_limits<double>::quiet_NaN());
    const bool volumetric_average = VolumetricAverage<Dim>::active(state);  // B-bar, after the loop
    // NaN: a row without neighbours, which the loop leaves (VolumetricAverage skips it).
    state.volumetric_rate.assign(volumetric_average ? target.count : 0, std::numeric_limits<double>::quiet_NaN());
    const bool book_damping = state.settings.energy_ledger && state.settings.damping > 0.0;
    for (auto& component : state.damped_velocity) component.assign(book_damping ? target.count : 0, 0.0);
    const bool reference = state.reference_kernel();  // SolverSettings::kernel_configuration
    // Not with mirror planes: widen() leaves out a mirror ghost's virtual neighbours (its
    // image has no row), so a widened row next to a plane is not the whole body's.
    const bool surface_motion_linear =
        state.settings.surface_motion == SolverSettings<Dim>::SurfaceMotion::linear && !state.mirror.active();
    const bool guard_interpolation =
        state.positions_move() && state.settings.interpolation == InterpolationKind::linear;
    KernelFactorCache& factors = state.full_kernel_factors;
    const bool cached = state.use_kernel_factors(factors, state.lists.real_from_virtual);
    state.add(parallel_for_with_scratch<StepScratch, StencilCounts>(
        target.count, [&](std::size_t r, StepScratch& scratch, StencilCounts& counts) {
          StencilWeights<Dim>& w = scratch.weights;
          std::span<const std::uint32_t> nb = state.lists.real_from_virtual.neighbors(r);
          ReferenceStencil<Dim> row_reference =
              reference ? SolverState<Dim>::reference_stencil(state.initial_position_of(r), state.virtual_)
                        : ReferenceStencil<Dim>{};
          // The cache's row is this list's row at h (the kernel factors do not depend on
          // the interpolation kind: the guarded recompute below reads them too; a widened
          // row is another stencil and evaluates its own).
          if (cached) factors.attach(row_reference, r);
          StencilStatus status = compute_stencil<Dim>(kernel, h, target.position_of(r), source_points,
                                                      source.volume, nb, state.settings.interpolation, w,
                                                      simd_path(), reference ? &row_reference : nullptr);
          // Updated Lagrangian: a row whose linear interpolation was singular in the lattice
          // (a 3D face at alpha 0.6: four coplanar virtual neighbours; Shepard there) becomes
          // regular once the body moves, with a tiny eigenvalue, and its weights grow as
          // 1 / (distance from the plane): checked_inverse's bounds pass them. The full step
          // starts from the interpolated stress, so such a row keeps Shepard's weights when
          // its linear weights' squared 2-norm exceeds kMaxInterpolationWeightSquares (or is
          // NaN; an empty or Shepard row is below). A guarded row is not widened
          // (deficient_stencils): widening recomputes a row with linear weights where it
          // finds no regular wider stencil.
          bool guarded = false;
          if (guard_interpolation && !(status.weight_squares <= kMaxInterpolationWeightSquares)) {
            status = compute_stencil<Dim>(kernel, h, target.position_of(r), source_points, source.volume, nb,
                                          InterpolationKind::shepard, w, simd_path(),
                                          reference ? &row_reference : nullptr);
            status.interpolation_fallback = true;
            guarded = true;
          }
          double h_row = h;  // the row's smoothing length: h, or that of a widened stencil
          // Interpolation alone deficient (an edge at alpha 0.6: two virtual neighbours
          // at one depth): the update keeps the row, the motion takes the widened one.
          const bool widen_motion = deficient == Deficient::widen_motion && status.interpolation_fallback &&
                                    !status.gradient_fallback && material_motion && !guarded;
          const bool widen_row =
              !guarded && (deficient == Deficient::widen ? status.gradient_fallback || status.interpolation_fallback
                                                         : deficient == Deficient::widen_motion && status.gradient_fallback);
          if (widen_row &&
              widen(state, kernel, r, target.position_of(r), source_points, source.volume, scratch, h_row, status)) {
            nb = scratch.wide_row;
            ++counts.widened;
          }
          counts += status;
          if (status.no_neighbors) {
            if (const std::int32_t b = state.boundary.slot[r]; b >= 0) {  // no stale gradients
              state.boundary.half_velocity_gradient[static_cast<std::size_t>(b)].setZero();
              state.boundary.half_velocity[static_cast<std::size_t>(b)].setZero();
              state.boundary.gradient_sum[static_cast<std::size_t>(b)].setZero();
              state.boundary.full_rank_gradient[static_cast<std::size_t>(b)] = 0;
              state.boundary.linear_half_row[static_cast<std::size_t>(b)] = 0;
              state.boundary.half_span[static_cast<std::size_t>(b)].setIdentity();  // its zero gradients are read as they are
              for (auto& g : state.boundary.half_stress_gradient[static_cast<std::size_t>(b)]) g.setZero();
            }
            return;
          }
          const LocalState s = Eval::evaluate(source, nb, w, scratch.gathered);
          // deficient_stencils = complete: a surface particle (not a held one) whose virtual
          // stencil spans fewer than Dim directions (alpha 0.6: a face's virtual neighbours
          // at one depth, a corner's one): the directions it spans (P) and the centroid of
          // its interpolation, whose value the Shepard weights give (complete_deficient_row).
          const std::int32_t slot = state.boundary.slot[r];
          const bool deficient_surface =
              deficient == Deficient::complete && slot >= 0 && (status.gradient_fallback || status.interpolation_fallback) &&
              state.boundary.on_surface[static_cast<std::size_t>(slot)] &&
              state.condition_of(r).kind != BoundaryCondition<Dim>::Kind::velocity;
          if (slot >= 0) {
            const auto b = slot;
            // Tangential derivatives at n+1/2 for the boundary conditions.
            state.boundary.half_velocity_gradient[static_cast<std::size_t>(b)] = s.velocity_gradient;
            state.boundary.full_rank_gradient[static_cast<std::size_t>(b)] = status.gradient_fallback ? 0 : 1;
            state.boundary.linear_half_row[static_cast<std::size_t>(b)] =
                status.gradient_fallback || status.interpolation_fallback ? 0 : 1;
            if (deficient == Deficient::complete) state.boundary.half_span[static_cast<std::size_t>(b)] = Mat::Identity();
            state.boundary.half_velocity[static_cast<std::size_t>(b)] = s.velocity;
            // The row's normal moment (surface_extrapolation only): sum_k G_k (x) r_k (r_k . n),
            // over every weight (a skin pair beyond 2h has a zero one).
            const bool extrapolate = state.settings.surface_extrapolation == Toggle::on;
            const Vec& normal = state.boundary.normal[static_cast<std::size_t>(b)];
            // Plain scalar sums (the Eigen temporaries of the former loop went through the
            // stack with a store-forwarding stall per pair: 4 % of the twisting column).
            std::array<double, Dim> g_sum{};  // sum_J V_J Gn_IJ: the gradient of a jump at I
            std::array<double, Dim * Dim> moment{};
            std::array<double, Dim> x_r;
            for (int d = 0; d < Dim; ++d) x_r[d] = target.position[d][r];
            for (std::size_t k = 0; k < nb.size(); ++k) {
              std::array<double, Dim> g;
              for (int d = 0; d < Dim; ++d) g[d] = w.gradient[d][k], g_sum[d] += g[d];
              if (!extrapolate) continue;
              std::array<double, Dim> offset;
              double along = 0.0;  // offset . n
              for (int d = 0; d < Dim; ++d) {
                offset[d] = source.position[d][nb[k]] - x_r[d];
                along += offset[d] * normal[d];
              }
              for (int a = 0; a < Dim; ++a) {
                const double ga = along * g[a];
                for (int c = 0; c < Dim; ++c) moment[a * Dim + c] += ga * offset[c];
              }
            }
            Vec& gradient_sum = state.boundary.gradient_sum[static_cast<std::size_t>(b)];
            Mat& normal_moment = state.boundary.normal_moment[static_cast<std::size_t>(b)];
            for (int d = 0; d < Dim; ++d) {
              gradient_sum[d] = g_sum[d];
              for (int c = 0; c < Dim; ++c) normal_moment(d, c) = moment[d * Dim + c];
            }
            state.boundary.half_stress_gradient[static_cast<std::size_t>(b)] =
                Eval::stress_gradient(source, nb, w, s.stress);
          }
          // Its motion velocity's carry from the centroid to the particle (after the
          // boundary block: widening overwrites the row's weights).
          Vec carry = Vec::Zero();
          if (deficient_surface)
            carry = complete_deficient_row(state, kernel, r, static_cast<std::size_t>(slot), s.velocity_gradient, source,
                                           nb, h_row, source_points, scratch, counts);
          if (material_motion) {  // x^{n+1} = x^n + dt v^{n+1/2}(x_r), from the midpoint x^n + dt/2 v_r^n
            Vec half_velocity = s.velocity;
            // SolverSettings::surface_motion = linear: a free or loaded surface row on
            // Shepard's weights (alpha 0.6: a face's virtual neighbours at one depth, an
            // edge's two, a corner's one; a 3D face the guard keeps on Shepard) moves with
            // the linear interpolation of the widened stencil. Its Shepard value is the
            // velocity at the stencil's centroid, dx/2 inside: in bending the faces turned
            // 26 % less than their sections (the 41 x 5 cantilever), a shear of the
            // particle lattice the stress never saw, which made updated Lagrangian 2 %
            // stiffer than small strain in 3D and the k = 3 elastica diverge
            // (docs/notes/2026-11-28-surface-motion.md).
            const bool linear_surface_motion =
                surface_motion_linear && !deficient_surface && slot >= 0 &&
                status.interpolation_fallback && state.boundary.on_surface[static_cast<std::size_t>(slot)] &&
                state.condition_of(r).kind != BoundaryCondition<Dim>::Kind::velocity;
            if (widen_motion || linear_surface_motion) {  // the Shepard value belongs to the stencil's centroid, dx/2 inside
              double h_wide = h;
              StencilStatus wide_status;
              if (widen(state, kernel, r, target.position_of(r), source_points, source.volume, scratch, h_wide, wide_status)) {
                half_velocity = Eval::evaluate(source, scratch.wide_row, w, scratch.gathered).velocity;
                ++counts.widened;
              }
            }
            // The Shepard value of a deficient row is the velocity at its centroid, dx/2
            // inside a face at alpha 0.6 (the face moved at 0.9 of a rigid spin's speed):
            // carried to the particle with the completed gradient.
            else if (deficient_surface)
              half_velocity += carry;
            for (int d = 0; d < Dim; ++d)
              state.next_position[d][r] = target.position[d][r] + dt * (half_velocity[d] - 0.5 * target.velocity[d][r]);
          }
          StressVector<Dim> previous;  // sigma_r^n
          for (int m = 0; m < stress_count; ++m) previous[m] = target.stress[m][r];
          // The Jaumann terms W sigma - sigma W rotate the particle's own midpoint stress
          // sigma_r^n + dt/2 rate(L^{n+1/2}, sigma_r^n), not the interpolated virtual
          // stress s.stress: the update is then the second-order Taylor expansion of the
          // rotation of sigma_r^n, which does no work (sigma : C^-1 : (W sigma - sigma W) =
          // 0). On the virtual stress it made energy wherever the two differ (the twisting
          // column at alpha 1.2: 1.86 E0 at 1.1 s, 1.50 with the own stress;
          // docs/notes/2026-11-29-own-stress-rotation.md). A particle that yielded in the
          // last step keeps s.stress: its midpoint lies on the yield surface, where the
          // virtual particles' predictor returned it (the own midpoint would need a
          // second return: a plastic step 1.34x an elastic one instead of 1.23x).
          StressVector<Dim> midpoint = s.stress;
          if (objective && !(plastic && state.real.yielding[r] != 0)) {
            const StressUpdate<Dim> half{previous, previous, s.velocity_gradient, 0.5 * dt, objective, true};
            midpoint = model.update_stress(half);
          }
          // A plastic state is kept unless a boundary stage replaces the stress (it returns
          // its own stress with the state at n: characteristics.hpp, wall_gradient.hpp).
          const StressUpdate<Dim> update{previous, midpoint, s.velocity_gradient, dt, objective};
          const StressVector<Dim> stress = plastic ? plastic_stress(state, r, update) : model.update_stress(update);
          for (int m = 0; m < stress_count; ++m) target.stress[m][r] = stress[m];
          for (int d = 0; d < Dim; ++d)
            target.velocity[d][r] +=
                dt * (s.stress_divergence[d] / s.density + state.settings.body_force[d] -
                      state.settings.damping * s.velocity[d]);
          if (book_damping)
            for (int d = 0; d < Dim; ++d) state.damped_velocity[d][r] = s.velocity[d];
          if (volumetric_average) state.volumetric_rate[r] = s.velocity_gradient.trace();
          if (compressible) {
            target.density[r] *= exp_of_small(-dt * s.velocity_gradient.trace());
            target.volume[r] = target.mass[r] / target.density[r];
          }
        }));
    if (cached) factors.mark_filled();
    if (volumetric_average) VolumetricAverage<Dim>::apply(state, dt);
  }

  /// The projector onto the directions spanned by a rank-deficient row's offsets from its
  /// interpolation centroid x_c = sum_k Wn_k x_k (BoundaryParticles::half_span): the
  /// directions along which the row's gradients, taken relative to the interpolated
  /// value, are exact. Eigenvalues of sum_k Wn_k (x_k - x_c)(x_k - x_c)^T below 1e-8 h^2 or
  /// 1e-3 of the largest count as missing (a face row that has left its plane a little,
  /// such as a 3D face the interpolation guard keeps on Shepard's weights, still misses
  /// its normal).
  [[gnu::noinline]] static Mat spanned_directions(const ParticleView<Dim>& source, std::span<const std::uint32_t> nb,
                                                  const StencilWeights<Dim>& w, double h, Vec& centroid) {
    double total = 0.0;
    centroid = Vec::Zero();
    for (std::size_t k = 0; k < nb.size(); ++k) {
      total += w.value[k];
      centroid += w.value[k] * source.position_of(nb[k]);
    }
    if (!(total > 0.0)) return Mat::Zero();
    centroid /= total;
    Mat spread = Mat::Zero();
    for (std::size_t k = 0; k < nb.size(); ++k) {
      const Vec offset = source.position_of(nb[k]) - centroid;
      spread += (w.value[k] / total) * offset * offset.transpose();
    }
    Eigen::SelfAdjointEigenSolver<Mat> solver(spread);
    Mat projector = Mat::Zero();
    const double floor = std::max(1e-8 * h * h, 1e-3 * solver.eigenvalues()[Dim - 1]);
    for (int k = 0; k < Dim; ++k)
      if (solver.eigenvalues()[k] > floor)
        projector += solver.eigenvectors().col(k) * solver.eigenvectors().col(k).transpose();
    return projector;
  }

  /// deficient_stencils = complete, a deficient surface row (its weights in
  /// scratch.weights, its velocity gradient G): the derivatives it misses (the directions
  /// outside its span P, spanned_directions) from a widened virtual stencil at n+1/2
  /// (widen), or where none is regular from the real set at n (characteristics.hpp reads
  /// half_span then). Where a tangential direction is missing (a corner, a 3D edge) the
  /// boundary's half-step gradients become G P + G_wide (I - P). Returns the motion
  /// velocity's carry from the Shepard centroid x_c to the particle, (G P + G_wide (I - P))
  /// (x_r - x_c).
  template <class Kernel>
  [[gnu::noinline]] static Vec complete_deficient_row(SolverState<Dim>& state, const Kernel& kernel, std::size_t r,
                                                      std::size_t b, const Mat& row_gradient,
                                                      const ParticleView<Dim>& source, std::span<const std::uint32_t> nb,
                                                      double h_row, const PointsView<Dim>& source_points,
                                                      StepScratch& scratch, StencilCounts& counts) {
    Vec centroid;
    const Mat span = spanned_directions(source, nb, scratch.weights, h_row, centroid);
    const Vec carry_offset = state.real.position_of(r) - centroid;
    if (span.isIdentity(1e-12)) return row_gradient * carry_offset;
    const Mat missing = Mat::Identity() - span;
    Mat& velocity_gradient = state.boundary.half_velocity_gradient[b];
    auto& stress_gradient = state.boundary.half_stress_gradient[b];
    // The boundary conditions read tangential derivatives: a face whose stencil spans
    // its tangents (its virtual neighbours at one depth) keeps its gradients.
    const Vec& n = state.boundary.normal[b];
    const bool tangents_missing = (missing * (Mat::Identity() - n * n.transpose())).norm() > 1e-6;
    double h_wide = state.settings.smoothing_length;
    StencilStatus wide_status;
    if (widen(state, kernel, r, state.real.position_of(r), source_points, source.volume, scratch, h_wide, wide_status)) {
      ++counts.widened;
      const LocalState wide = Eval::evaluate(source, scratch.wide_row, scratch.weights, scratch.gathered);
      const Mat completed = row_gradient * span + wide.velocity_gradient * missing;
      if (tangents_missing) {
        const auto wide_stress = Eval::stress_gradient(source, scratch.wide_row, scratch.weights, wide.stress);
        velocity_gradient = completed;
        for (std::size_t m = 0; m < stress_gradient.size(); ++m)
          stress_gradient[m] = span * stress_gradient[m] + missing * wide_stress[m];
      }
      return completed * carry_offset;
    }
    if (tangents_missing) state.boundary.half_span[b] = span;
    return (row_gradient * span + state.boundary.velocity_gradient[b] * missing) * carry_offset;
  }

  /// A plastic material's stress at n+1 of real particle r with its own state, kept
  /// unless a boundary stage replaces the stress (out of line: the elastic loop stays lean).
  [[gnu::noinline]] static StressVector<Dim> plastic_stress(SolverState<Dim>& state, std::size_t r,
                                                            const StressUpdate<Dim>& update) {
    const std::int32_t slot = state.boundary.slot[r];
    const bool replaced = slot >= 0 && state.boundary.on_surface[static_cast<std::size_t>(slot)] && !state.driven();
    return state.update_real_stress(r, update, !replaced);
  }

  /// SolverSettings::deficient_stencils: a real particle whose virtual stencil
  /// leaves its corrected gradient (or its linear interpolation) rank-deficient (a corner with one virtual neighbour
  /// at h / dx = 0.6 in 2D, an edge or a corner in 3D: the gradient of every field is 0
  /// there, so the particle feels no stress divergence and, in a rigid rotation, no
  /// centripetal force; docs/notes/2026-11-25-deficient-stencils.md) takes the virtual
  /// particles of its own row and of its real neighbours' rows (boundary particles
  /// only: state.lists.real_from_real), with the smoothing length grown by 1.5, then 2,
  /// until the correction matrix is regular. On success the weights in scratch.weights
  /// belong to scratch.wide_row, h_row is the length used and status that stencil's;
  /// otherwise the row's own weights are computed again and false returned.
  template <class Kernel>
  static bool widen(const SolverState<Dim>& state, const Kernel& kernel, std::size_t r, const Vec& x_r,
                    const PointsView<Dim>& source_points, const double* source_volume, StepScratch& scratch,
                    double& h_row, StencilStatus& status) {
    const std::int32_t b = state.boundary.slot[r];
    const NeighborList& own = state.lists.real_from_virtual;
    const double h = state.settings.smoothing_length;
    std::vector<std::uint32_t>& row = scratch.wide_row;
    if (b >= 0 && state.lists.real_from_real.query_count() > r) {
      row.assign(own.neighbors(r).begin(), own.neighbors(r).end());
      for (const std::uint32_t j : state.lists.real_from_real.neighbors(r))
        if (j < own.query_count())  // a mirror ghost has no row (its images' virtual ghosts are not indexed)
          row.insert(row.end(), own.neighbors(j).begin(), own.neighbors(j).end());
      std::sort(row.begin(), row.end());
      row.erase(std::unique(row.begin(), row.end()), row.end());
      for (const double factor : {1.5, 2.0}) {
        const StencilStatus wide = compute_stencil<Dim>(kernel, factor * h, x_r, source_points, source_volume, row,
                                                        state.settings.interpolation, scratch.weights);
        if (!wide.gradient_fallback && !wide.interpolation_fallback && !wide.no_neighbors) {
          h_row = factor * h;
          status = wide;
          return true;
        }
      }
    }
    status = compute_stencil<Dim>(kernel, h, x_r, source_points, source_volume, own.neighbors(r),
                                  state.settings.interpolation, scratch.weights);
    return false;
  }
};

}  // namespace tsph
