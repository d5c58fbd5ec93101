// SolverSettings::hourglass_stiffness: a restoring force on the part of the real
// displacement field that the virtual particles cannot see (docs/method.md section 5: the
// checkerboard and the odd-even columns), zero for every linear displacement field.
#pragma once

#include "engine/parallel.hpp"
#include "engine/solver/boundary/symmetry_planes.hpp"
#include "engine/solver/state.hpp"
#include "neighbor/cell_list.hpp"

#include <Eigen/LU>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <span>
#include <vector>

namespace tsph {

template <int Dim>
class HourglassStiffness {
 public:
  using Vec = Vector<Dim>;

  /// Step 3b: hourglass stiffness (SolverSettings::hourglass_stiffness), a restoring
  /// force on what the virtual particles cannot see. The scheme sees the real field only
  /// through its values interpolated to the virtual particles (cell centres) and their
  /// gradients, so every real field whose cell averages vanish is invisible to the
  /// stress: the checkerboard (-1)^(i+j), and also (-1)^i f(y) and (-1)^j g(x) (a
  /// column-wise odd-even u_y is what makes the cantilever creep). The round trip
  /// RT(u) = R A u measures them: A takes the real displacements to the virtual
  /// particles (linear least-squares fit over the virtual particle's real neighbours,
  /// value at X_v), R brings the virtual values back to each real particle (linear
  /// least-squares fit over the virtual particles within max(2h, 1.75 dx), value at X_I),
  /// both in the initial coordinates X with kernel weights. Both fits reproduce linear
  /// fields, so r = u - RT(u) is zero for every linear field (rigid motions included),
  /// at the boundary too, and equals u for the invisible fields (A u = 0). The force is
  /// that of the energy
  ///     E = k/2 sum_I V_I |r_I|^2,   k = kappa M / h^2   (M: P-wave modulus),
  ///     F_J = -dE/du_J = -k ( V_J r_J - sum_v A_vJ s_v ),   s_v = sum_I V_I r_I R_Iv.
  /// For a smooth field r = O(dx^2 grad grad u), so F = O(kappa M dx^2 d^4 u): it vanishes
  /// with the spacing (the one-sided form -k r would be O(kappa M d^2 u), a competing
  /// elasticity: measured, it makes the cantilever worse). sum_v A_vJ = sum_v R_Iv = 1, so
  /// sum_J F_J = 0: linear momentum is conserved. Time integration:
  /// v^{n+1} = v* + dt F(u*) / m at the displacement the step is heading for,
  /// u* = u^n + dt/2 (v^n + v*), v* the full step's velocity
  /// (SolverSettings::hourglass_kick = predicted; midpoint, before 2026-11-29: at
  /// u^n + dt/2 v^n). On the spring alone (v* = v^n) the step's determinant is
  /// 1 - a/2, a = k dt^2 / rho: the kick damps the spring's own oscillation by a/4 per
  /// step (stable for a < 2), where the midpoint form kept it at |lambda| = 1 and the
  /// coupling with the Taylor step made a through-thickness mode grow: the plate at
  /// alpha 1.2 (51 x 6, small strain, stiffness 0.05) +2.1e-4 per step at 0.48 rad per
  /// step, 41 x 9 +1.1e-4; now none (tsph spectrum; docs/notes/2026-11-29-hourglass-kick.md).
  /// Particles with a prescribed velocity receive no force (their reaction is the
  /// constraint's).
  template <class Kernel>
  void apply(SolverState<Dim>& state, const Kernel& kernel, double dt) {
    if (lists_outdated(state)) build_lists(state);
    const double h = state.settings.smoothing_length;
    const double return_h = 0.5 * hourglass_radius_;  // kernel support = the list radius
    const double stiffness = state.settings.hourglass_stiffness * state.material.elastic().p_wave_modulus() / (h * h);
    using Basis = Eigen::Matrix<double, Dim + 1, 1>;
    using Moments = Eigen::Matrix<double, Dim + 1, Dim + 1>;
    auto offset = [&](std::uint32_t r, std::uint32_t v) {  // X_r - X_v, initial coordinates
      Vec dx;
      for (int d = 0; d < Dim; ++d)
        dx[d] = state.real.initial_position[d][r] - state.virtual_.initial_position[d][v];
      return dx;
    };
    auto basis = [](const Vec& dx) {
      Basis p;
      p[0] = 1.0;
      p.template tail<Dim>() = dx;
      return p;
    };
    // Linear least-squares fit weights over a stencil, offsets X_source - X_centre; the
    // neighbours for which keep(k) is false are skipped.
    auto fit = [&](auto&& neighbours, auto&& dx_of, double kernel_h, auto&& keep) {
      Moments moments = Moments::Zero();
      double weight_sum = 0.0;
      for (std::uint32_t k : neighbours) {
        if (!keep(k)) continue;
        const Vec dx = dx_of(k);
        const Basis p = basis(dx);
        const double w = kernel.value(dx.norm(), kernel_h);
        moments += w * p * p.transpose();
        weight_sum += w;
      }
      LinearFitWeights out;
      if (!(weight_sum > 0.0)) return out;
      Eigen::FullPivLU<Moments> lu(moments / weight_sum);
      lu.setThreshold(1e-10);
      if (!lu.isInvertible()) return out;  // neighbours on a line: no fit, no force
      out.first_column = lu.inverse().col(0);
      out.weight_sum = weight_sum;
      return out;
    };
    auto coefficient = [&](const LinearFitWeights& f, const Vec& dx, double kernel_h) {
      return kernel.value(dx.norm(), kernel_h) / f.weight_sum * f.first_column.dot(basis(dx));
    };
    // The displacement the step is heading for, u* = u^n + dt/2 (v^n + v*): the field holds
    // u^n + dt/2 v^n (begin_displacement), the velocity v* the full step's v^{n+1}. A
    // mirror ghost's velocity was refreshed before the full step: its owned particle's
    // v*, reflected, is read instead.
    const std::size_t owned_real = state.real.size();
    const double ahead =
        state.settings.hourglass_kick == SolverSettings<Dim>::HourglassKick::predicted ? 0.5 * dt : 0.0;
    // Once per particle (ghosts included) into one array, read by the fits' rows as one
    // Vec per pair instead of six gathered fields and a ghost test.
    ahead_displacement_.resize(state.real.storage_size());
    parallel_for(state.real.storage_size(), [&](std::size_t j) {
      Vec v = state.velocity_of(j);
      if (j >= owned_real) {
        const std::size_t g = j - owned_real;
        v = state.mirror.reflect_direction(state.mirror.real.planes[g], state.velocity_of(state.mirror.real.source[g]));
      }
      Vec u;
      for (int d = 0; d < Dim; ++d) u[d] = state.real.displacement[d][j] + ahead * v[d];
      ahead_displacement_[j] = u;
    });
    const Vec* const displacement = ahead_displacement_.data();
    // The half-step lists with a skin also hold pairs beyond 2h at the current positions
    // (within_support): the fit and the force skip them (their weights come from the
    // initial coordinates, so they would not vanish).
    const PointsView<Dim> real_points = points_of<Dim>(state.real), virtual_points = points_of<Dim>(state.virtual_);
    const auto every = [](std::uint32_t) { return true; };
    const std::size_t real_count = state.real.size(), virtual_count = state.virtual_.size();
    // Mirror ghosts (boundary/mirror_planes.hpp) are entries of the rows, never rows:
    // their fits and values are their owned particles', reflected.
    const MirrorGhosts<Dim>& mirror = state.mirror;
    forward_fit_.resize(state.virtual_.storage_size());
    return_fit_.resize(state.real.storage_size());
    virtual_value_.resize(state.virtual_.storage_size());
    round_trip_residual_.resize(state.real.storage_size());
    auto mirror_fits = [&](std::vector<LinearFitWeights>& fits, const typename MirrorGhosts<Dim>::Images& images,
                           std::size_t owned) {
      for (std::size_t g = 0; g < images.source.size(); ++g) {
        LinearFitWeights f = fits[images.source[g]];
        const Vec c = f.first_column.template tail<Dim>();
        f.first_column.template tail<Dim>() = mirror.reflect_direction(images.planes[g], c);
        fits[owned + g] = f;
      }
    };
    // A: virtual values a_v = sum_J A_vJ u_J. A's fit and weights A_vJ depend on the
    // initial coordinates, the list and which of its pairs lie within the support now:
    // kept along the list (support_weights_, forward_in_support_) and computed again for a
    // row only when a pair of the row crossed the support's edge or, after a build of the
    // list, when the row's pairs within the support are not those of the last step (the
    // same numbers as computing them each step; 2026-11-27: the fits were 29 % of a 2D
    // updated-Lagrangian step with the elastic defaults).
    const NeighborList& forward_list = state.lists.virtual_from_real;
    const bool forward_kept = forward_build_ == state.counters.neighbor_builds && forward_h_ == h &&
                              forward_in_support_.size() == forward_list.pair_count();
    ++fit_stamp_;
    forward_version_.resize(state.virtual_.storage_size(), 0);
    // After a build of the list a row whose pairs within the support are those of the
    // last step, in the same order (most rows: the build follows the skin, not the
    // row), keeps its fit and weights: the previous rows are kept for the comparison.
    const bool compare_previous = !forward_kept && forward_build_ >= 0 && forward_h_ == h &&
                                  forward_renumberings_ == state.counters.renumberings &&
                                  support_count_.size() == virtual_count;
    if (!forward_kept) {
      std::swap(previous_entries_, support_entries_);
      std::swap(previous_weights_, support_weights_);
      std::swap(previous_begin_, support_begin_);
      std::swap(previous_count_, support_count_);
      forward_in_support_.assign(forward_list.pair_count(), 0);
      support_entries_.assign(forward_list.pair_count(), 0);
      support_weights_.assign(forward_list.pair_count(), 0.0);
      support_begin_.resize(virtual_count);
      for (std::size_t v = 0; v < virtual_count; ++v) support_begin_[v] = forward_list.row_begin(v);
      support_count_.assign(virtual_count, 0);
      forward_build_ = state.counters.neighbor_builds;
      forward_renumberings_ = state.counters.renumberings;
      forward_h_ = h;
    }
    // Without a skin (the reference kernel, the default of updated Lagrangian; small
    // strain) every pair of the lists lies within the support at every step: between
    // builds a row's entries are the row itself and nothing is checked per pair.
    const bool every_pair_within = state.skin_distance() == 0.0;
    parallel_for(virtual_count, [&](std::size_t v) {
      const auto nb = forward_list.neighbors(v);
      const auto vi = static_cast<std::uint32_t>(v);
      char* kept_support = forward_in_support_.data() + forward_list.row_begin(v);
      std::uint32_t* entries = support_entries_.data() + support_begin_[v];
      double* weight = support_weights_.data() + support_begin_[v];
      bool same = forward_kept;
      std::uint32_t count = 0;
      if (every_pair_within && forward_kept) {
        count = static_cast<std::uint32_t>(nb.size());
      } else {
        for (std::size_t k = 0; k < nb.size(); ++k) {
          const char now = state.within_support(virtual_points, v, real_points, nb[k]) ? 1 : 0;
          same = same && now == kept_support[k];
          kept_support[k] = now;
          if (now) entries[count++] = nb[k];
        }
      }
      if (!same) {
        support_count_[v] = count;
        const bool unchanged = compare_previous && previous_count_[v] == count &&
                               std::equal(entries, entries + count, previous_entries_.data() + previous_begin_[v]);
        if (unchanged) {
          std::copy_n(previous_weights_.data() + previous_begin_[v], count, weight);
        } else {
          forward_fit_[v] = fit(std::span<const std::uint32_t>(entries, count),
                                [&](std::uint32_t j) { return offset(j, vi); }, h, every);
          forward_version_[v] = fit_stamp_;
          for (std::uint32_t m = 0; m < count; ++m)
            weight[m] = forward_fit_[v].weight_sum > 0.0 ? coefficient(forward_fit_[v], offset(entries[m], vi), h) : 0.0;
        }
      }
      Vec value = Vec::Zero();
      if (forward_fit_[v].weight_sum > 0.0)
        for (std::uint32_t m = 0; m < count; ++m) value += weight[m] * displacement[entries[m]];
      virtual_value_[v] = value;
    });
    if (mirror.active()) {
      mirror_fits(forward_fit_, mirror.virtual_, virtual_count);
      mirror_directions(mirror, virtual_value_, mirror.virtual_, virtual_count);
      for (std::size_t g = 0; g < mirror.virtual_.source.size(); ++g)
        forward_version_[virtual_count + g] = forward_version_[mirror.virtual_.source[g]];
    }
    // R's fits and weights R_Iv depend on the initial coordinates and the lists alone:
    // computed once per list build (both list orders), then read (the same numbers as
    // computing them each step; 2026-11-27: the hourglass stiffness was half the quarter
    // Taylor bar's time).
    if (return_weights_build_ != hourglass_list_generation_) {
      return_weight_.resize(hourglass_from_virtual_.pair_count());
      transposed_return_weight_.resize(hourglass_to_real_.pair_count());
      parallel_for(real_count, [&](std::size_t i) {
        const auto nb = hourglass_from_virtual_.neighbors(i);
        const auto ri = static_cast<std::uint32_t>(i);
        return_fit_[i] = fit(nb, [&](std::uint32_t v) { return Vec(-offset(ri, v)); }, return_h, every);
        double* weight = return_weight_.data() + hourglass_from_virtual_.row_begin(i);
        for (std::size_t k = 0; k < nb.size(); ++k)
          weight[k] = return_fit_[i].weight_sum > 0.0 ? coefficient(return_fit_[i], Vec(-offset(ri, nb[k])), return_h) : 0.0;
      });
      if (mirror.active()) mirror_fits(return_fit_, mirror.real, real_count);
      parallel_for(virtual_count, [&](std::size_t v) {
        const auto nb = hourglass_to_real_.neighbors(v);
        double* weight = transposed_return_weight_.data() + hourglass_to_real_.row_begin(v);
        for (std::size_t k = 0; k < nb.size(); ++k)
          weight[k] = return_fit_[nb[k]].weight_sum > 0.0
                          ? coefficient(return_fit_[nb[k]], Vec(-offset(nb[k], static_cast<std::uint32_t>(v))), return_h)
                          : 0.0;
      });
      return_weights_build_ = hourglass_list_generation_;
    }
    // R: r_I = u_I - sum_v R_Iv a_v, weighted by V_I (less the reference where it follows
    // the flow: take_flow_into_reference).
    const bool follows_flow = state.settings.hourglass_reference == SolverSettings<Dim>::HourglassReference::flow &&
                              state.real.carries_plastic_fields();
    if (follows_flow) total_residual_.resize(state.real.storage_size());
    parallel_for(real_count, [&](std::size_t i) {
      Vec residual = Vec::Zero();
      if (return_fit_[i].weight_sum > 0.0) residual = displacement[i] - returned_value(i);
      if (follows_flow) total_residual_[i] = residual;
      else round_trip_residual_[i] = (state.real.mass[i] / state.real.density[i]) * residual;
    });
    if (follows_flow) take_flow_into_reference(state);
    if (mirror.active()) mirror_directions(mirror, round_trip_residual_, mirror.real, real_count);
    if (state.settings.energy_ledger)  // E = k/2 sum_I V_I |r_I|^2 (round_trip_residual_ holds V_I r_I)
      state.energy.hourglass_energy = 0.5 * stiffness * deterministic_sum(real_count, [&](std::size_t i) {
        return state.share(i) * round_trip_residual_[i].squaredNorm() * state.real.density[i] / state.real.mass[i];
      });
    // s_v = sum_I R_Iv V_I r_I (the transposed return trip; reuses virtual_value_). A
    // real particle without a return fit has R_Iv = 0 (and r_I = 0): no test per pair.
    parallel_for(virtual_count, [&](std::size_t v) {
      const auto nb = hourglass_to_real_.neighbors(v);
      const double* weight = transposed_return_weight_.data() + hourglass_to_real_.row_begin(v);
      Vec sum = Vec::Zero();
      for (std::size_t k = 0; k < nb.size(); ++k) sum += weight[k] * round_trip_residual_[nb[k]];
      virtual_value_[v] = sum;
    });
    if (mirror.active()) mirror_directions(mirror, virtual_value_, mirror.virtual_, virtual_count);
    // F_J = -k (V_J r_J - sum_v A_vJ s_v).
    const bool ledger = state.settings.energy_ledger;
    if (ledger) kick_.resize(real_count);
    // A_vJ along the full step's list (rows: real), kept per pair with the version of
    // the fit it came from: computed again only where the list was built again or row v
    // was fitted again (the same numbers as computing them each step).
    const NeighborList& backward_list = state.lists.real_from_virtual;
    if (backward_build_ != state.counters.neighbor_builds || backward_weight_.size() != backward_list.pair_count()) {
      backward_weight_.assign(backward_list.pair_count(), 0.0);
      backward_version_.assign(backward_list.pair_count(), 0);
      backward_build_ = state.counters.neighbor_builds;
      backward_current_ = false;
    }
    // Every pair within the support and no row of A fitted again since the last pass
    // (forward_kept): every weight along the list is that pass's, no version is read.
    const bool backward_current = backward_current_ && every_pair_within && forward_kept;
    parallel_for(real_count, [&](std::size_t j) {
      if (const std::int32_t b = state.boundary.slot[j]; b >= 0) {
        const auto& condition = state.boundaries[static_cast<std::size_t>(state.real.boundary[j])];
        if (condition.kind == BoundaryCondition<Dim>::Kind::velocity) {
          if (ledger) kick_[j].setZero();
          return;
        }
      }
      const auto rj = static_cast<std::uint32_t>(j);
      // The sum in plain scalars: an Eigen vector here lived on the stack, each pair's
      // subtraction a load right after the last pair's store (a store-forwarding stall:
      // 63 % of this loop's samples, 5.6 % of the quarter Taylor bar's, perf on
      // 2026-12-07). The same operations in the same order: the same bits.
      std::array<double, Dim> sum;
      for (int d = 0; d < Dim; ++d) sum[d] = round_trip_residual_[j][d];
      const auto nb = backward_list.neighbors(j);
      double* weight = backward_weight_.data() + backward_list.row_begin(j);
      std::uint64_t* version = backward_version_.data() + backward_list.row_begin(j);
      for (std::size_t k = 0; k < nb.size(); ++k) {
        const std::uint32_t v = nb[k];
        if (!every_pair_within && !state.within_support(real_points, j, virtual_points, v)) continue;
        if (!backward_current && version[k] != forward_version_[v]) {  // a row without a fit weighs 0
          weight[k] = forward_fit_[v].weight_sum > 0.0 ? coefficient(forward_fit_[v], offset(rj, v), h) : 0.0;
          version[k] = forward_version_[v];
        }
        const double w = weight[k];
        const Vec& value = virtual_value_[v];
        for (int d = 0; d < Dim; ++d) sum[d] -= w * value[d];
      }
      Vec force;
      for (int d = 0; d < Dim; ++d) force[d] = sum[d];
      // A symmetry plane (or a smooth wall) keeps its normal velocity: the force acts along it.
      if (const std::int32_t b = state.boundary.slot[j];
          b >= 0 && state.condition_of(j).kind == BoundaryCondition<Dim>::Kind::symmetry) {
        const Vec& n = state.boundary.normal[static_cast<std::size_t>(b)];
        force -= force.dot(n) * n;
      }
      if (const std::int32_t b = state.boundary.slot[j]; b >= 0 && SymmetryPlanes<Dim>::any(state, static_cast<std::size_t>(b)))
        SymmetryPlanes<Dim>::along_planes(state, static_cast<std::size_t>(b), force);
      Vec kick;
      for (int d = 0; d < Dim; ++d) {
        kick[d] = -(dt * stiffness * force[d] / state.real.mass[j]);
        state.real.velocity[d][j] += kick[d];
      }
      if (ledger) kick_[j] = kick;
    });
    backward_current_ = every_pair_within;  // each weight read above is current
  }

  /// The radius of the return trip's lists: max(2h, 1.75 dx), dx the initial spacing
  /// (SolverState::initial_spacing, from the initial volumes: the lists are in the initial
  /// coordinates; the mirror planes image the particles within it too).
  static double list_radius(const SolverState<Dim>& state) {
    return std::max(state.support_radius(), 1.75 * state.initial_spacing);
  }

  /// The velocity change of each real particle in the last step (with
  /// SolverSettings::energy_ledger only, else empty; energy_ledger.hpp books its work).
  const std::vector<Vec>& kicks() const { return kick_; }

 private:
  /// The ghosts' entries of a per-particle vector field: their owned particles' values,
  /// reflected across the ghost's plane (values[owned + g] for ghost g of `images`).
  static void mirror_directions(const MirrorGhosts<Dim>& mirror, std::vector<Vec>& values,
                                const typename MirrorGhosts<Dim>::Images& images, std::size_t owned) {
    for (std::size_t g = 0; g < images.source.size(); ++g)
      values[owned + g] = mirror.reflect_direction(images.planes[g], values[images.source[g]]);
  }

  /// (R a)_I = sum_v R_Iv a_v: the return trip of virtual_value_ at real particle i.
  Vec returned_value(std::size_t i) const {
    const auto nb = hourglass_from_virtual_.neighbors(i);
    const double* weight = return_weight_.data() + hourglass_from_virtual_.row_begin(i);
    Vec sum = Vec::Zero();
    for (std::size_t k = 0; k < nb.size(); ++k) sum += weight[k] * virtual_value_[nb[k]];
    return sum;
  }

  /// SolverSettings::hourglass_reference = flow in a plastic material: the spring above
  /// acts on r_I - p_I, p_I = ParticleSet::hourglass_reference. A particle that yields in
  /// the step takes the smooth part of its residual into its reference,
  ///     p_I = (R A r)_I,
  /// the round trip of the residual field (the same fits as above). The round trip
  /// reproduces linear fields and is zero on the invisible ones, so p_I follows the
  /// residual that the curvature of a smooth flow leaves (r = O(dx^2 grad grad u), which
  /// grows with the total displacement of a plastic flow and made the spring resist it:
  /// the quarter Taylor bar's impact face 5.1 % short at R0 / 8) while a checkerboard or
  /// an odd-even column stays restored at the full stiffness, yielding or not. Outside
  /// the plastic zone p_I stays where the particle last yielded (zero if never): the
  /// elastic spring of before. Resetting the whole residual instead (p_I = r_I) leaves
  /// the hourglass modes of the plastic zone free: the coarse quarter bar gains energy and
  /// diverges (docs/notes/2026-12-07-hourglass-reference.md).
  void take_flow_into_reference(SolverState<Dim>& state) {
    const std::size_t real_count = state.real.size(), virtual_count = state.virtual_.size();
    const MirrorGhosts<Dim>& mirror = state.mirror;
    if (mirror.active()) mirror_directions(mirror, total_residual_, mirror.real, real_count);
    // A: the residual's values at the virtual particles (virtual_value_ is free until the
    // transposed trip).
    parallel_for(virtual_count, [&](std::size_t v) {
      Vec value = Vec::Zero();
      if (forward_fit_[v].weight_sum > 0.0) {
        const std::uint32_t* entries = support_entries_.data() + support_begin_[v];
        const double* weight = support_weights_.data() + support_begin_[v];
        for (std::uint32_t m = 0; m < support_count_[v]; ++m) value += weight[m] * total_residual_[entries[m]];
      }
      virtual_value_[v] = value;
    });
    if (mirror.active()) mirror_directions(mirror, virtual_value_, mirror.virtual_, virtual_count);
    // R, at the particles that yield; then V_I (r_I - p_I) at every one.
    auto& reference = state.real.hourglass_reference;
    parallel_for(real_count, [&](std::size_t i) {
      if (state.real.yielding[i] != 0 && return_fit_[i].weight_sum > 0.0) {
        const Vec smooth = returned_value(i);
        for (int d = 0; d < Dim; ++d) reference[d][i] = smooth[d];
      }
      Vec relative = total_residual_[i];
      for (int d = 0; d < Dim; ++d) relative[d] -= reference[d][i];
      round_trip_residual_[i] = (state.real.mass[i] / state.real.density[i]) * relative;
    });
  }

  /// One linear least-squares fit u(X) ~ a + B (X - X_0) over a stencil (see
  /// apply): the value a = sum_J c^T p_J (w_J / w) u_J, with
  /// p_J = (1, X_J - X_0), w = sum_J w_J and c the first column of the inverse of the
  /// normalised moment matrix sum_J (w_J / w) p_J p_J^T. weight_sum = 0: no fit.
  struct LinearFitWeights {
    Eigen::Matrix<double, Dim + 1, 1> first_column = Eigen::Matrix<double, Dim + 1, 1>::Zero();
    double weight_sum = 0.0;
  };

  /// Whether the return trip's lists must be searched again. They are in the initial
  /// coordinates, so only a renumbering (SolverCounters::renumberings), a change of the sets'
  /// sizes or of the radius outdates them; with mirror planes the ghosts are generated
  /// anew at every search of the solver's lists, and so are these lists.
  bool lists_outdated(const SolverState<Dim>& state) const {
    return hourglass_list_generation_ == 0 || list_renumberings_ != state.counters.renumberings ||
           list_real_size_ != state.real.storage_size() || list_virtual_size_ != state.virtual_.storage_size() ||
           hourglass_radius_ != list_radius(state) ||
           (state.mirror.active() && list_neighbor_build_ != state.counters.neighbor_builds);
  }

  /// The real -> virtual lists of the hourglass stiffness's return trip (and the
  /// transpose), in the initial coordinates: radius list_radius(), so that every real
  /// particle, corners included, sees Dim + 1 virtual particles off a line.
  void build_lists(const SolverState<Dim>& state) {
    hourglass_radius_ = list_radius(state);
    hourglass_from_virtual_ = NeighborList{};  // released first: two generations never coexist (memory)
    hourglass_to_real_ = NeighborList{};
    const PointsView<Dim> real_points = initial_points_of<Dim>(state.real), virtual_points = initial_points_of<Dim>(state.virtual_);
    hourglass_from_virtual_ = CellList<Dim>(virtual_points, hourglass_radius_).query(real_points);
    hourglass_to_real_ = CellList<Dim>(real_points, hourglass_radius_).query(virtual_points);
    ++hourglass_list_generation_;
    list_neighbor_build_ = state.counters.neighbor_builds;
    list_renumberings_ = state.counters.renumberings;
    list_real_size_ = state.real.storage_size();
    list_virtual_size_ = state.virtual_.storage_size();
  }

  std::vector<Vec> kick_;                      ///< the last step's velocity changes (ledger only)
  std::vector<LinearFitWeights> forward_fit_;  ///< A, per virtual particle
  std::vector<char> forward_in_support_;       ///< whether each pair of state.lists.virtual_from_real lay within the support
  /// The pairs of each row within the support, in the list's order, from the row's start
  /// in the list (support_begin_) on, support_count_ of them, and their weights A_vJ.
  std::vector<std::uint32_t> support_entries_;
  std::vector<double> support_weights_;
  std::vector<std::uint64_t> support_begin_;
  std::vector<std::uint32_t> support_count_;
  /// The same of the list before its last build (a row that did not change keeps its fit).
  std::vector<std::uint32_t> previous_entries_;
  std::vector<double> previous_weights_;
  std::vector<std::uint64_t> previous_begin_;
  std::vector<std::uint32_t> previous_count_;
  std::int64_t forward_build_ = -1;            ///< SolverCounters::neighbor_builds of the arrays above
  std::int64_t forward_renumberings_ = -1;     ///< SolverCounters::renumberings of the arrays above
  double forward_h_ = 0.0;                     ///< the smoothing length they were computed with
  std::vector<std::uint64_t> forward_version_;  ///< fit_stamp_ of each virtual particle's last fit (ghosts: their owner's)
  std::uint64_t fit_stamp_ = 0;                 ///< counts the calls of apply (versions start at 1)
  std::vector<double> backward_weight_;         ///< A_vJ along state.lists.real_from_virtual
  std::vector<std::uint64_t> backward_version_; ///< forward_version_ of the fit each weight came from (0: none)
  std::int64_t backward_build_ = -1;            ///< SolverCounters::neighbor_builds of the two above
  bool backward_current_ = false;               ///< the last pass brought every weight it reads up to date
  std::vector<Vec> ahead_displacement_;         ///< u* = u^n + dt/2 (v^n + v*) per real particle, ghosts included
  std::vector<LinearFitWeights> return_fit_;   ///< R, per real particle (per list build)
  std::vector<double> return_weight_;             ///< R_Iv along hourglass_from_virtual_ (per list build)
  std::vector<double> transposed_return_weight_;  ///< R_Iv along hourglass_to_real_ (per list build)
  std::int64_t return_weights_build_ = -1;        ///< hourglass_list_generation_ of return_fit_ and the weights
  std::vector<Vec> virtual_value_;             ///< a_v, then s_v
  std::vector<Vec> round_trip_residual_;       ///< V_I r_I (V_I (r_I - p_I) where the reference follows the flow)
  std::vector<Vec> total_residual_;            ///< r_I, where the reference follows the flow
  NeighborList hourglass_from_virtual_;  ///< rows: real; entries: virtual (initial coordinates)
  NeighborList hourglass_to_real_;       ///< its transpose
  double hourglass_radius_ = 0.0;
  std::int64_t hourglass_list_generation_ = 0;  ///< searches of the two lists above (0: none yet)
  std::int64_t list_neighbor_build_ = -1;       ///< SolverCounters::neighbor_builds at the last search
  std::int64_t list_renumberings_ = -1;         ///< SolverCounters::renumberings at the last search
  std::size_t list_real_size_ = 0, list_virtual_size_ = 0;  ///< storage sizes (ghosts included) then
};

}  // namespace tsph
