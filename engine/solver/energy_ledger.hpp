// SolverSettings::energy_ledger: the energy balance of a run (docs/validation.md,
// "Energy balance"). With E = kinetic + elastic + plastic work of the real particles,
//     E(t) - E(0) = sum_conditions W_boundary + W_body + W_damping + W_hourglass
//                   + W_filter + (the scheme's own error),
// the works booked step by step (trapezoidal in time):
//  * W_boundary, per boundary condition: int sum_b t_b . v_b A_b dt over the condition's
//    surface particles b, the power of the traction it imposes (traction_power), and for
//    a velocity held inside the body (a driven region) the work of its overwrite.
//    A_b = 2 V_b / dx: on the node lattice of tsph (and of its validation cases) a face
//    particle holds half a cell of volume and a cell face of area (edge and corner
//    particles their shares). A free surface and a fixed smooth wall do no work. In a
//    driven body (SolverState::driven_condition) the particle's own traction acts on
//    every lattice face it holds a share of: the power is v . sigma a with the area
//    vector a = J F^-T A0 (BoundaryParticles::face_area carried by the fitted F).
//  * W_body = int b . P dt, W_damping = -c int sum_I m_I v_damped,I . v_I dt with
//    v_damped the velocity the full step damps (the interpolated v^{n+1/2},
//    SolverState::damped_velocity);
//  * W_hourglass, W_filter: the work of the hourglass stiffness's and of the surface
//    filter's velocity changes (stabilisation/), booked as below.
// Not a work of the balance: the characteristic boundary replaces the velocity the full
// step gave each boundary particle; the work of that replacement is booked apart
// (EnergyLedger::boundary_overwrite). Where the boundary particles obey the momentum
// balance it is the traction's power again; where they do not (a prescribed velocity
// against a one-sided stress gradient) the two differ, and the difference is part of
// the scheme's error, with the Taylor expansion's own dissipation (alpha) and the
// stress-side updates of the boundary stages.
// With mirror planes (boundary/mirror_planes.hpp) a particle on a plane counts for its
// share of the modelled part, 1/2 per plane (SolverState::share): every sum is then the
// whole mirrored body's divided by 2 per plane (a quarter model: the whole bar's / 4).
// The sums run in fixed blocks (deterministic_sum) and the boundary slots serially: the
// ledger has the same bits on any thread count and after a restart.
#pragma once

#include "engine/parallel.hpp"
#include "engine/solver/boundary/normals.hpp"
#include "engine/solver/state.hpp"
#include "engine/solver/stencil_evaluation.hpp"

#include <Eigen/Eigenvalues>

#include <array>
#include <cmath>
#include <cstddef>
#include <vector>

namespace tsph {

/// The bookkeeping of SolverState::energy inside TaylorSph::advance_fields. A stage's
/// work over a step is its impulse on each particle times the particle's mean velocity
/// (v^n + v^{n+1}) / 2, m dv . v_mean: the works of all the velocity changes of a step
/// add up to its change of kinetic energy, and a force that a later stage of the same
/// step undoes (the hourglass stiffness holding a static state against the full step's
/// one-sided gradients) does no work. Memory while on: v^n (Dim doubles per real
/// particle) and the hourglass stiffness's kicks; passes: a copy at the start and two
/// sums at the end, and serial passes over the boundary slots.
template <int Dim>
class EnergyAccounting {
 public:
  using Vec = Vector<Dim>;

  /// Kinetic energy sum_I m_I |v_I|^2 / 2.
  static double kinetic(const SolverState<Dim>& state) {
    const ParticleSet<Dim>& r = state.real;
    return deterministic_sum(r.size(), [&](std::size_t i) {
      double v2 = 0.0;
      for (int d = 0; d < Dim; ++d) v2 += r.velocity[d][i] * r.velocity[d][i];
      return 0.5 * state.share(i) * r.mass[i] * v2;
    });
  }
  /// Elastic energy sum_I V_I w(sigma_I).
  static double elastic(const SolverState<Dim>& state) {
    const ParticleSet<Dim>& r = state.real;
    double e = 0.0;
    state.material.visit([&](const auto& model) {
      e = deterministic_sum(r.size(), [&](std::size_t i) {
        return state.share(i) * r.volume[i] * model.strain_energy_density(SolverState<Dim>::stress_of(r, i));
      });
    });
    return e;
  }
  /// Plastic work sum_I V_I w_p,I (w_p per unit current volume; 0 in elastic runs).
  static double plastic_work(const SolverState<Dim>& state) {
    const ParticleSet<Dim>& r = state.real;
    if (!r.carries_plastic_fields()) return 0.0;
    return deterministic_sum(r.size(), [&](std::size_t i) { return state.share(i) * r.volume[i] * r.plastic_work[i]; });
  }
  /// kinetic + elastic + plastic work.
  static double mechanical(const SolverState<Dim>& state) {
    return kinetic(state) + elastic(state) + plastic_work(state);
  }

  /// The kinetic and elastic energies on the node-and-cell quadrature (a diagnostic,
  /// not the ledger's measure).
  struct NodeAndCellEnergies {
    double kinetic = 0.0, elastic = 0.0;
  };
  /// (T + 2 M) / 3: T the real particles' sums above (on tsph's node lattice the
  /// trapezoidal rule: a face particle holds half a cell), M the midpoint rule over the
  /// virtual particles (the cell centres), each with the real state interpolated at it
  /// as the half step interpolates it (seed eq. 3, before the rates): m_q |v(x_q)|^2 / 2
  /// and (m_q / rho(x_q)) w(sigma(x_q)). On a lattice the O(dx^2) errors of T and M are
  /// +dx^2 / 12 and -dx^2 / 24 times sum_d int d_d^2 f, so the combination is exact for
  /// every quadratic density, where T alone is not: a stress linear across the thickness
  /// of a beam of n rows (bending) has T's elastic energy too large by 2 / (n - 1)^2
  /// (8 % at 6 rows, 2 % at 11: docs/notes/2026-11-29-energy-quadrature.md), while
  /// the kinetic energy of a uniform velocity has none: T's total energy rises at every
  /// quarter period of a bending mode the scheme damps. Lists and ghosts as the half step
  /// leaves them between steps (TaylorSph::node_and_cell_energies attaches the ghosts);
  /// `owned_virtual`: the virtual particles to sum (the owned ones). Same bits on any
  /// thread count.
  template <class Kernel>
  static NodeAndCellEnergies node_and_cell(SolverState<Dim>& state, const Kernel& kernel,
                                           std::size_t owned_virtual) {
    using Eval = StencilEvaluation<Dim>;
    using StepScratch = typename Eval::StepScratch;
    const ParticleView<Dim> source = state.real.view();
    const PointsView<Dim> source_points = points_of<Dim>(state.real);
    const ParticleSet<Dim>& cells = state.virtual_;
    const bool reference = state.reference_kernel();
    const PointsView<Dim> cell_reference = reference ? initial_points_of<Dim>(cells) : PointsView<Dim>{};
    std::vector<double> kinetic_density(owned_virtual, 0.0), elastic_density(owned_virtual, 0.0);
    parallel_for_with_scratch<StepScratch, StencilCounts>(
        owned_virtual, [&](std::size_t q, StepScratch& scratch, StencilCounts&) {
          const auto nb = state.lists.virtual_from_real.neighbors(q);
          const ReferenceStencil<Dim> row_reference =
              reference ? SolverState<Dim>::reference_stencil(cell_reference.point(q), state.real) : ReferenceStencil<Dim>{};
          const StencilStatus status = compute_stencil<Dim>(
              kernel, state.settings.smoothing_length, cells.position_of(q), source_points, source.volume, nb,
              state.settings.interpolation, scratch.weights, simd_path(), reference ? &row_reference : nullptr);
          if (status.no_neighbors) return;
          const typename Eval::LocalState s = Eval::evaluate(source, nb, scratch.weights, scratch.gathered);
          const double m = cells.mass[q];
          kinetic_density[q] = 0.5 * m * s.velocity.squaredNorm();
          state.material.visit([&](const auto& model) {
            elastic_density[q] = (m / s.density) * model.strain_energy_density(s.stress);
          });
        });
    const double kinetic_cells = deterministic_sum(owned_virtual, [&](std::size_t q) { return kinetic_density[q]; });
    const double elastic_cells = deterministic_sum(owned_virtual, [&](std::size_t q) { return elastic_density[q]; });
    return {(kinetic(state) + 2.0 * kinetic_cells) / 3.0, (elastic(state) + 2.0 * elastic_cells) / 3.0};
  }

  /// Before the full step: v^n and the tractions' power at n.
  void begin(SolverState<Dim>& state) {
    EnergyLedger& l = state.energy;
    l.boundary.resize(state.boundaries.size(), 0.0);
    if (std::isnan(l.initial_energy)) l.initial_energy = mechanical(state);
    for (int d = 0; d < Dim; ++d) {
      start_velocity_[d].resize(state.real.size());
      const std::vector<double>& v = state.real.velocity[d];
      std::vector<double>& copy = start_velocity_[d];
      parallel_for(copy.size(), [&](std::size_t i) { copy[i] = v[i]; });
    }
    traction_power(state, state.time, 0.0, start_traction_power_);
    overwrite_.clear();
    filter_.clear();
  }
  /// Around the characteristic boundary stage (`overwrite`; with the conservative momentum
  /// update, around both) or the surface filter: the velocity changes of the boundary
  /// particles.
  void before_boundary_stage(const SolverState<Dim>& state) { slot_velocities(state, slot_before_); }
  void after_boundary_stage(const SolverState<Dim>& state, bool overwrite) {
    slot_velocities(state, slot_after_);
    std::vector<Vec>& change = overwrite ? overwrite_ : filter_;
    change.resize(slot_after_.size());
    for (std::size_t b = 0; b < slot_after_.size(); ++b) change[b] = slot_after_[b] - slot_before_[b];
  }
  /// End of the fields' update: every work of the step. `hourglass_kicks`: the hourglass
  /// stiffness's velocity changes (empty: off).
  void end(SolverState<Dim>& state, double dt, const std::vector<Vec>& hourglass_kicks) {
    EnergyLedger& l = state.energy;
    const ParticleSet<Dim>& r = state.real;
    auto mean_velocity = [&](std::size_t i) {
      Vec v;
      for (int d = 0; d < Dim; ++d) v[d] = 0.5 * (start_velocity_[d][i] + r.velocity[d][i]);
      return v;
    };
    const Vec& b = state.settings.body_force;
    const double c = state.settings.damping;
    if (b.squaredNorm() > 0.0)  // int b . P dt, P = sum m v at the step's middle
      l.body_force += dt * deterministic_sum(r.size(), [&](std::size_t i) { return state.share(i) * r.mass[i] * b.dot(mean_velocity(i)); });
    // The damping's impulse -c dt m v_damped (SolverState::damped_velocity: the velocity
    // the full step damped, interpolated) on the mean velocity. Booked as -c dt m |v_mean|^2
    // (before 2026-12-06) it counted an odd-even velocity that the interpolation does not
    // see, and so the damping does not touch, as damped: the strip footing's kinetic
    // energy in such a mode (3-9 J/m) was booked as 178-418 J/m of damping
    // (docs/notes/2026-12-06-damping-work.md).
    if (c > 0.0)
      l.damping -= c * dt * deterministic_sum(r.size(), [&](std::size_t i) {
        Vec damped;
        for (int d = 0; d < Dim; ++d) damped[d] = state.damped_velocity[d][i];
        return state.share(i) * r.mass[i] * damped.dot(mean_velocity(i));
      });
    if (!hourglass_kicks.empty())
      l.hourglass += deterministic_sum(r.size(), [&](std::size_t i) {
        return state.share(i) * r.mass[i] * hourglass_kicks[i].dot(mean_velocity(i));
      });
    // The overwrite of a velocity held inside the body (no surface, no traction) is the
    // constraint's work: its condition's; on a surface it is booked apart.
    for (std::size_t s = 0; s < overwrite_.size(); ++s) {
      const std::uint32_t i = state.boundary.particle[s];
      const double w = state.share(i) * r.mass[i] * overwrite_[s].dot(mean_velocity(i));
      if (state.boundary.on_surface[s]) l.boundary_overwrite += w;
      else l.boundary[static_cast<std::size_t>(state.real.boundary[i])] += w;
    }
    for (std::size_t s = 0; s < filter_.size(); ++s) {
      const std::uint32_t i = state.boundary.particle[s];
      l.surface_filter += state.share(i) * r.mass[i] * filter_[s].dot(mean_velocity(i));
    }
    // The particles are at the midpoint x^n + dt/2 v^n until Motion::second_half: the
    // drive's area vectors are fitted at x^{n+1} = x + dt/2 v^{n+1}.
    traction_power(state, state.time + dt, 0.5 * dt, end_traction_power_);
    for (std::size_t k = 0; k < end_traction_power_.size(); ++k)
      l.boundary[k] += 0.5 * dt * (start_traction_power_[k] + end_traction_power_[k]);
  }

  /// The power of each condition on its surface particles at time t, sum_b t_b . v_b A_b
  /// with the traction t_b that the condition imposes: a traction condition's prescribed
  /// one (zero on a free surface, whatever stress the particle holds: the scheme applies
  /// no other), the particle's own sigma_b n_b where the velocity is prescribed, and its
  /// normal part on a symmetry plane (whose tangential traction is zero).
  /// `ahead`: a driven body's area vectors are fitted at x + ahead v (x^{n+1} at the end
  /// of a step, when the particles still stand at the midpoint).
  static void traction_power(const SolverState<Dim>& state, double t, double ahead, std::vector<double>& power) {
    power.assign(state.boundaries.size(), 0.0);
    const double dx = state.initial_spacing;
    using Kind = typename BoundaryCondition<Dim>::Kind;
    for (std::size_t b = 0; b < state.boundary.particle.size(); ++b) {
      if (!state.boundary.on_surface[b]) continue;
      const std::uint32_t i = state.boundary.particle[b];
      const auto k = static_cast<std::size_t>(state.real.boundary[i]);
      const BoundaryCondition<Dim>& condition = state.boundaries[k];
      const Vec& n = state.boundary.normal[b];
      const Vec v = state.velocity_of(i);
      Vec traction;
      if (condition.kind == Kind::traction) {
        traction = condition.prescribed(state.initial_position_of(i), state.boundary.profile[b], t);
      } else {
        traction = in_plane<Dim>(SolverState<Dim>::stress_of(state.real, i)) * n;
        if (condition.kind == Kind::symmetry) traction = traction.dot(n) * n;
      }
      const double area = 2.0 * state.share(i) * state.real.volume[i] / dx;
      // A driven body (SolverState::driven_condition: every face is the drive's) on the
      // lattice: the drive's power on every face the particle holds a share of,
      // v . sigma a with a = J F^-T A0 its current area vector (Nanson;
      // A0 = BoundaryParticles::face_area). Its kernel normal would give an edge particle
      // a diagonal of half the length, and a face particle next to an edge a share of the
      // other face (the normals tilt by up to 17 degrees on a 6^3 block). Elsewhere a
      // velocity face's edge may border a free face, which does no work: the area model.
      if (state.driven() && state.boundary.face_area[b].squaredNorm() > 0.0) {
        Vec current_area;
        if (current_area_vector(state, b, ahead, current_area)) {
          power[k] += v.dot(in_plane<Dim>(SolverState<Dim>::stress_of(state.real, i)) * current_area);
          continue;
        }
      }
      power[k] += area * traction.dot(v);
      // Further symmetry planes: their normal traction on the normal velocity (zero on a
      // fixed plane), with the same area model.
      for (std::size_t e = 0; e < 2 && state.boundary.extra_plane[b][e] >= 0; ++e) {
        const Vec& m = state.boundary.extra_normal[b][e];
        const double normal_traction = m.dot(in_plane<Dim>(SolverState<Dim>::stress_of(state.real, i)) * m);
        power[static_cast<std::size_t>(state.boundary.extra_plane[b][e])] += area * normal_traction * m.dot(v);
      }
    }
  }

 private:
  /// The current area vector a = J F^-T A0 of boundary slot b, with F = dx / dX the
  /// least-squares fit of the real neighbours' offsets (exact for an affine motion).
  /// False where the fit is singular.
  static bool current_area_vector(const SolverState<Dim>& state, std::size_t b, double ahead, Vec& area) {
    using Mat = Matrix<Dim>;
    const std::uint32_t i = state.boundary.particle[b];
    const PointsView<Dim> points = points_of<Dim>(state.real);
    const Vec x = state.real.position_of(i) + ahead * state.velocity_of(i), x0 = state.initial_position_of(i);
    Mat reference_moments = Mat::Zero(), mixed = Mat::Zero();
    for (std::uint32_t j : state.lists.real_from_real.neighbors(i)) {
      // Within 2h only: the pairs a skin adds depend on when the list was searched.
      if (!state.within_support(points, i, points, j)) continue;
      const Vec dX = state.initial_position_of(j) - x0;
      const Vec dx = state.real.position_of(j) + ahead * state.velocity_of(j) - x;
      reference_moments += dX * dX.transpose();
      mixed += dx * dX.transpose();
    }
    // A fit over neighbours that span every direction (the smaller principal moment at
    // least 1e-3 of the larger; a lattice row has 1/4 or more).
    const Eigen::SelfAdjointEigenSolver<Mat> moments(reference_moments);
    const auto& values = moments.eigenvalues();
    if (!(values[0] > 1e-3 * values[Dim - 1])) return false;
    const Mat deformation = mixed * reference_moments.inverse();  // F
    const double jacobian = deformation.determinant();
    if (!(jacobian > 0.0)) return false;
    area = jacobian * deformation.inverse().transpose() * state.boundary.face_area[b];
    return true;
  }

  static void slot_velocities(const SolverState<Dim>& state, std::vector<Vec>& out) {
    const std::size_t n = state.boundary.particle.size();
    out.resize(n);
    for (std::size_t b = 0; b < n; ++b) out[b] = state.velocity_of(state.boundary.particle[b]);
  }

  std::array<std::vector<double>, Dim> start_velocity_;
  std::vector<double> start_traction_power_, end_traction_power_;
  std::vector<Vec> slot_before_, slot_after_, overwrite_, filter_;
};

}  // namespace tsph
