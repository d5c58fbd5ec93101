// The characteristic boundary treatment (docs/method.md section 4), Dim = 1, 2, 3: the
// boundary pre-pass (U^n and its gradients at the boundary particles, from the real set)
// and the boundary state at n+1.
//
// (seed eq. 1b, divided by the density at the particle).
//
// Our choices, beyond the seed (documented in docs/method.md):
//  * The source S (Jaumann terms, body force, damping -c v) is evaluated at the
//    particle being updated from its own interpolated state and corrected velocity
//    gradient, rather than at the neighbours and interpolated: the same order of
//    accuracy, and no same-set neighbour lists in the bulk.
//  * Boundary real particles take their state from the characteristic relations in
//    the frame (n, t_k) of their computed outward normal (on a traction condition in
//    updated Lagrangian, carried to t_new by the step's deformation: condition_normal).
//    With t_n = n.sigma.n, u_n = v.n, Z_p = rho c_p (and t_k = n.sigma.t_k, u_k = v.t_k,
//    Z_s = rho c_s):
//      d/dt (t_n - Z_p u_n) + c_p d/dn (t_n - Z_p u_n)
//          = lambda div_t v_t - c_p div_t (sigma n)_t - Z_p b_n,
//      d/dt (t_k - Z_s u_k) + c_s d/dn (t_k - Z_s u_k)
//          = mu d_k u_n - c_s sum_l d_l sigma_lk - Z_s b_k.
//    Each outgoing invariant is carried from the foot x - c dt n at time n
//    (interpolated with the real set's corrected gradient) plus dt times its
//    right-hand side, whose tangential derivatives are taken at n+1/2 from the
//    virtual set; the incoming invariants follow from the prescribed velocity or
//    traction. The tangential stresses then follow from the constitutive law with the
//    normal derivative of u_n eliminated through the t_n rate. In 1D there are no
//    tangents and this is exact at CFL 1 with nearest-neighbour stencils; a 2D strip
#pragma once

#include "engine/solver/boundary/free_edge.hpp"
#include "engine/solver/boundary/normals.hpp"
#include "engine/solver/boundary/symmetry_planes.hpp"
#include "engine/solver/boundary/wall_gradient.hpp"
#include "engine/solver/stabilisation/surface_extrapolation.hpp"
#include "engine/solver/state.hpp"
#include "engine/solver/stencil_evaluation.hpp"

#include <array>
#include <cmath>

namespace tsph {

template <int Dim>
struct CharacteristicBoundary {
  using Vec = Vector<Dim>;
  using Mat = Matrix<Dim>;
  static constexpr int stress_count = stress_component_count<Dim>;

  /// Step 0: U^n and its gradients at the boundary particles, from the real set.
  template <class Kernel>
  static void gradients_at_n(SolverState<Dim>& state, const Kernel& kernel) {
    const ParticleView<Dim> source = state.real.view();
    const PointsView<Dim> source_points = points_of<Dim>(state.real);
    StencilWeights<Dim> w;
    StencilCounts counts;
    for (std::size_t b = 0; b < state.boundary.particle.size(); ++b) {
      const std::uint32_t i = state.boundary.particle[b];
      const auto nb = state.lists.real_from_real.neighbors(i);
      const ReferenceStencil<Dim> row_reference = state.reference_kernel()
                                                      ? SolverState<Dim>::reference_stencil(state.initial_position_of(i), state.real)
                                                      : ReferenceStencil<Dim>{};
      counts += compute_stencil<Dim>(kernel, state.settings.smoothing_length, state.real.position_of(i),
                                     source_points, source.volume, nb,
                                     InterpolationKind::shepard, w, simd_path(),
                                     state.reference_kernel() ? &row_reference : nullptr);
      state.boundary.stress[b] = state.stress_of(state.real, i);
      state.boundary.velocity[b] = state.velocity_of(i);
      state.boundary.density[b] = state.real.density[i];
      StencilEvaluation<Dim>::velocity_and_stress_gradients(source, nb, w, state.boundary.velocity[b],
                                                            state.boundary.stress[b], state.boundary.velocity_gradient[b],
                                                            state.boundary.stress_gradient[b]);
    }
    counts.interpolation = 0;  // the Shepard weights are not used here
    state.add(counts);
  }

  /// The stretch d u_m / d m of a boundary particle on a further symmetry plane of unit
  /// normal m (a corner: symmetry_planes.hpp) at n+1/2, from that plane's outgoing P
  /// characteristic (the file comment's relation along m, with u_m at n+1 the plane's
  /// speed w_m) less its lambda div_t v_t term, which the constitutive law puts back:
  ///   M d_m u_m = Z (w_m - u_m^n) / dt - c_p d_m (t_m - Z u_m)^n - c_p div_t (sigma m)_t - Z b_m
  /// (d_m at n from the real set, as for the own plane's normal derivative; div_t over
  /// the directions orthogonal to m at n+1/2 from the virtual set). The stress t_m that
  /// the constitutive update then gives is the plane's characteristic value. m must point
  /// out of the body (the relation is the outgoing one; -m would give the incoming one):
  /// the caller orients it (outward_plane_normal). The Z (w_m - u_m^n) / dt term is zero
  /// while the projection holds u_m^n = w_m(t_n); otherwise it is the impulse that brings
  /// u_m to the plane's speed. Before, t_m
  /// followed the own frame's tangential update with the virtual set's one-sided estimate
  /// of d_m u_m, blind to the held u_m: in a block between four symmetry planes a stress
  /// mode at a corner grew by 1.4e-3 per step at CFL 0.9 (the step map's leading real
  /// eigenvalue; gone now, others remain), and a plane wave's corners strayed from their
  /// wall (docs/notes/2026-11-27-wall-corners.md).
  static double corner_stretch(const SolverState<Dim>& state, std::size_t b, const Vec& m, double plane_speed,
                               double force_m, double dt, double c_p, double z_p, double modulus) {
    const double normal_velocity = state.boundary.velocity[b].dot(m);
    const double stress_dm = m.dot(directional<Dim>(state.boundary.stress_gradient[b], m) * m);
    const double velocity_dm = m.dot(state.boundary.velocity_gradient[b] * m);
    return (z_p * (plane_speed - normal_velocity) / dt - c_p * (stress_dm - z_p * velocity_dm) -
            c_p * tangential_traction_divergence(state, b, m) - z_p * force_m) /
           modulus;
  }

  /// div_t (sigma m)_t = sum_{d,e} P_de d_d (sigma m)_e, P = I - m m^T, at slot b from the
  /// virtual set at n+1/2: the traction divergence over the directions orthogonal to m
  /// of the P characteristic along m (corner_stretch, free_face_velocity).
  static double tangential_traction_divergence(const SolverState<Dim>& state, std::size_t b, const Vec& m) {
    const Mat projector = Mat::Identity() - m * m.transpose();
    double divergence = 0.0;
    for (int d = 0; d < Dim; ++d)
      divergence += projector.row(d).dot(directional<Dim>(state.boundary.half_stress_gradient[b], Vec::Unit(d)) * m);
    return divergence;
  }

  /// The velocity u_m at n+1 of boundary slot b along the outward normal m of a
  /// traction-free face through it (a wall-free edge's free face), from that face's
  /// outgoing P characteristic (the file comment's relation along m) with t_m = 0 at n+1:
  ///   t_m - Z u_m = (t_m - Z u_m)^n - c_p dt d_m (t_m - Z u_m)^n
  ///                 + dt (lambda div_t v_t - c_p div_t (sigma m)_t - Z b_m),
  /// d_m at n from the real set, div_t over the directions orthogonal to m at n+1/2 from the
  /// virtual set (as corner_stretch).
  static double free_face_velocity(const SolverState<Dim>& state, std::size_t b, const Vec& m, const Vec& force,
                                   double dt, double c_p, double z_p, double lame) {
    const Mat sigma0 = in_plane<Dim>(state.boundary.stress[b]);
    const double tm0 = m.dot(sigma0 * m), um0 = m.dot(state.boundary.velocity[b]);
    const double dm_tm = m.dot(directional<Dim>(state.boundary.stress_gradient[b], m) * m);
    const double dm_um = m.dot(state.boundary.velocity_gradient[b] * m);
    const Mat projector = Mat::Identity() - m * m.transpose();
    const double velocity_divergence = (projector * state.boundary.half_velocity_gradient[b]).trace();
    const double invariant =
        tm0 - z_p * um0 - c_p * dt * (dm_tm - z_p * dm_um) +
        dt * (lame * velocity_divergence - c_p * tangential_traction_divergence(state, b, m) - z_p * force.dot(m));
    return -invariant / z_p;
  }

  /// A further plane's unit normal m (symmetry_planes.hpp: its sign follows the kernel
  /// normal, which the projections do not mind) turned to point out of the body: the real
  /// neighbours of particle i lie on its inner side.
  static Vec outward_plane_normal(const SolverState<Dim>& state, std::uint32_t i, const Vec& m) {
    double inward = 0.0;
    for (std::uint32_t j : state.lists.real_from_real.neighbors(i))
      inward += (state.real.position_of(j) - state.real.position_of(i)).dot(m);
    return inward > 0.0 ? Vec(-m) : m;
  }

  /// deficient_stencils = complete: the half-step row of slot b spans fewer than Dim
  /// directions and no widened stencil completed it (full_step.hpp, complete_deficient_row
  /// keeps its span P in half_span); the missing directions are read from the real set at n.
  static bool kept_partial_span(const SolverState<Dim>& state, std::size_t b) {
    return state.settings.deficient_stencils == SolverSettings<Dim>::DeficientStencils::complete &&
           !state.boundary.half_span[b].isIdentity(0.0);
  }

  /// The outward normal that a traction condition at t_new holds on. In updated
  /// Lagrangian the normal at n (BoundaryParticles::normal, from the positions at n)
  /// carried over the step by the deformation, n^{n+1} ~ F^-T n = (I - dt L^T) n
  /// normalised, with L the half-step velocity gradient (virtual set, n+1/2; where a
  /// deficient row kept its span P, the real set's gradient at n in the missing
  /// directions, as below). L^T n is the gradient of the normal velocity v . n: its
  /// tangential part turns the normal, its normal part only changes the length (so the
  /// one-sided normal derivative drops out). On further symmetry planes the normal stays
  /// in them (their normals projected out). Before (2026-11-29) the traction held on the
  /// normal at n, which lags a face turning at omega by omega dt: in the twisting column
  /// that made energy (E at 1.1 s: 1.50 E0 at CFL 0.9; 0.68 E0 now, as small strain's
  /// 0.66) and it spun the free rotating blocks up at alpha 1.2 (2D: 2.5e-2 of L per
  /// turn, 4.2e-3 now; docs/notes/2026-11-29-own-stress-rotation.md). The normal at n:
  /// in small strain, in 1D, for a velocity condition (its frame does not change what
  /// is imposed) and a symmetry plane (the plane stays), and where the carried normal
  /// would turn by more than about 25 degrees in one step.
  static Vec condition_normal(const SolverState<Dim>& state, std::size_t b, const BoundaryCondition<Dim>& condition,
                              double dt) {
    const Vec& n = state.boundary.normal[b];
    if (condition.kind != BoundaryCondition<Dim>::Kind::traction) return n;
    return carried_normal(state, b, n, dt);
  }

  /// A unit normal n at slot b at time n carried to t_new by the step's deformation, as
  /// condition_normal carries the particle's own (in small strain and 1D: n itself).
  static Vec carried_normal(const SolverState<Dim>& state, std::size_t b, const Vec& n, double dt) {
    if (Dim == 1 || !state.positions_move()) return n;
    Mat gradient = state.boundary.half_velocity_gradient[b];
    if (kept_partial_span(state, b)) {
      const Mat& span = state.boundary.half_span[b];
      gradient = gradient * span + state.boundary.velocity_gradient[b] * (Mat::Identity() - span);
    }
    Vec carried = n - dt * (gradient.transpose() * n);
    if (SymmetryPlanes<Dim>::any(state, b))
      for (const Vec& plane_normal : state.boundary.extra_normal[b])
        if (plane_normal.squaredNorm() > 0.0) {
          const Vec m = plane_normal.normalized();
          carried -= carried.dot(m) * m;
        }
    const double length = carried.norm();
    if (!std::isfinite(length) || !(carried.dot(n) > 0.9 * length)) return n;
    return carried / length;
  }

  /// Step 3: characteristic boundary conditions at t_new (see the file comment).
  template <class Model>
  static void apply(SolverState<Dim>& state, const Model& model, double dt, double t_new) {
    // The characteristic relations take the elastic part of the model (its wave speeds).
    const LinearElastic<Dim>& elastic = model.elastic();
    const double lame = elastic.model_lame();
    const double shear = elastic.shear_modulus();
    const double modulus = elastic.p_wave_modulus();
    for (std::size_t b = 0; b < state.boundary.particle.size(); ++b) {
      const std::uint32_t i = state.boundary.particle[b];
      const auto& condition = state.boundaries[static_cast<std::size_t>(state.real.boundary[i])];
      // A velocity held inside the body, or any particle of a driven body
      // (SolverState::driven_condition): imposed directly, the stress the full step's.
      if (!state.boundary.on_surface[b] || state.driven()) {
        const Vec v = condition.prescribed(state.initial_position_of(i), state.boundary.profile[b], t_new);
        for (int d = 0; d < Dim; ++d) state.real.velocity[d][i] = v[d];
        continue;
      }
      if (state.settings.velocity_wall == SolverSettings<Dim>::VelocityWall::wall_gradient &&
          condition.kind == BoundaryCondition<Dim>::Kind::velocity) {
        WallGradient<Dim>::apply(state, model, b, i, condition, dt, t_new);
        if (SymmetryPlanes<Dim>::any(state, b)) SymmetryPlanes<Dim>::project_particle(state, b, i, t_new);
        continue;
      }
      // A moving smooth wall (a symmetry condition with a velocity: a footing) with
      // VelocityWall::wall_gradient: its normal velocity is prescribed like a clamp's, so
      // its stress takes the bulk update relative to the wall (wall_gradient.hpp). By the
      // characteristic relations below, a smooth footing on elastic soil did not converge
      // as dt fell (the work 8 086 / 10 782 / 13 262 J/m at CFL 0.9 / 0.45 / 0.225, dx =
      // B/4) and lost 81 % of it (45 % on Tresca soil), at the footing's edges; relative
      // to the wall the work is 23 215 / 23 437 J/m, as a rough footing's, and the Tresca
      // footing's balance error -8.5 % at B/4, -5.4 % at B/10 with the damping's work
      // booked as applied (by the characteristic relations -45 %, -18 %, as booked then;
      // docs/notes/2026-12-06-smooth-footing.md, 2026-12-06-damping-work.md). A fixed plane keeps the characteristic
      // relations, exact for a 1D impact: relative to the wall the Taylor bar's impact
      // face is crushed at 43 us (R0 / 4).
      if (state.settings.velocity_wall == SolverSettings<Dim>::VelocityWall::wall_gradient &&
          condition.moving_smooth_wall()) {
        WallGradient<Dim>::apply_smooth_wall(state, b, i, condition, dt, t_new);
        if (SymmetryPlanes<Dim>::any(state, b)) SymmetryPlanes<Dim>::project_particle(state, b, i, t_new);
        continue;
      }
      const bool velocity_given = condition.kind == BoundaryCondition<Dim>::Kind::velocity;
      // A free corner (FreeEdge::free_corner; below). In 2D its frame is the bisector of
      // its two faces' normals, from the lattice (FreeEdge::corner_face_normals) and
      // carried over the step, whatever the faces are named. Before (2026-12-07) it was
      // the particle's own normal: a face's where the faces are two conditions (the
      // plate's free end), the kernel's diagonal where they are one (a free block); and
      // at full rank the second face's P relation was imposed along the frame's tangent,
      // which at the block's corners is the other diagonal, its sign left to round-off
      // (docs/notes/2026-12-07-free-corners.md).
      const bool free_corner =
          Dim >= 2 && !velocity_given &&
          condition.prescribed(state.initial_position_of(i), state.boundary.profile[b], t_new).squaredNorm() == 0.0 &&
          FreeEdge<Dim>::free_corner(state, i, t_new);
      Vec n = condition_normal(state, b, condition, dt);
      if (Dim == 2 && free_corner) {
        std::array<Vec, Dim> faces;
        if (FreeEdge<Dim>::corner_face_normals(state, i, faces))
          n = carried_normal(state, b, Vec((faces[0] + faces[1]).normalized()), dt);
      }
      const Mat frame = normal_frame<Dim>(n);
      const double density = state.boundary.density[b];
      const double c_p = std::sqrt(modulus / density);
      const double c_s = std::sqrt(shear / density);
      const double z_p = density * c_p;
      const double z_s = density * c_s;

      // State at n and its normal derivatives, in the frame. In 1D, where the row spans the
      // normal (alpha >= 1: virtual particles at two depths), the normal derivatives are
      // the virtual set's at n+1/2, like the tangential ones below: the real set's at n are
      // forward Euler along the normal, and at alpha 1.2 the bar's lowest standing waves
      // grew by 1 + 1.6e-3 per step (11 particles, CFL 0.9), now 1 to round-off at CFL
      // 0.1-1.0. Alpha 0.6 (one virtual depth) keeps the real set at n, exact at CFL 1.
      // Where the normal velocity is prescribed (a fixed end, a wall) the velocity's normal
      // derivative stays the real set's at n: with the virtual set's, a bar with both ends
      // fixed kept a steady velocity field whose virtual gradient is uniform, and its mean
      // stress drifted linearly without bound (a Jordan block at the eigenvalue 1, which the
      // spectral radius does not show; docs/notes/2026-12-06-boundary-second-order-tries.md,
      // test StepMap.FixedFixedBarAtAlpha12DoesNotDrift). In 2D and 3D the n+1/2 rule
      // makes the clamped plate at alpha 1.2 lose energy and diverge at its clamp, so the
      // real set at n stays there (docs/notes/2026-12-06-alpha12-boundary-energy.md).
      // A symmetry plane (a smooth wall): the normal velocity given (the wall's, 0 for a
      // fixed plane), the tangential tractions zero.
      const bool symmetry = condition.kind == BoundaryCondition<Dim>::Kind::symmetry;
      const bool normal_at_half = Dim == 1 && state.boundary.linear_half_row[b];
      const bool velocity_normal_at_half = normal_at_half && !velocity_given && !symmetry;
      const Mat stress0 = frame.transpose() * in_plane<Dim>(state.boundary.stress[b]) * frame;
      const Vec velocity0 = frame.transpose() * state.boundary.velocity[b];
      const Mat stress_dn =
          frame.transpose() *
          directional<Dim>(normal_at_half ? state.boundary.half_stress_gradient[b] : state.boundary.stress_gradient[b], n) *
          frame;
      const Vec velocity_dn =
          frame.transpose() *
          ((velocity_normal_at_half ? state.boundary.half_velocity_gradient[b] : state.boundary.velocity_gradient[b]) * n);
      // Tangential derivatives at n+1/2 (virtual set): column k of velocity_dt is
      // d v' / d t_k, stress_dt[k] is d sigma' / d t_k.
      // Tangential derivatives at n+1/2 from the virtual set (second order in time; the
      // real set's gradients at time n would make this forward Euler, which is
      // unstable). Where the virtual stencil spans fewer than Dim directions (a corner
      // with one virtual neighbour at alpha 0.6) the missing direction is read as zero.
      Mat velocity_dt = Mat::Zero();
      std::array<Mat, Dim> stress_dt{};
      // With deficient_stencils = complete a row that spans fewer directions took the rest
      // from a widened virtual stencil (full_step.hpp, complete_deficient_row); where none
      // was regular its span P is kept, and the missing directions come from the real set
      // at n (first order in time, for those particles only).
      const Mat& span = state.boundary.half_span[b];
      const bool partial = kept_partial_span(state, b);
      for (int k = 1; k < Dim; ++k) {
        const Vec t = frame.col(k);
        const Vec t_seen = partial ? Vec(span * t) : t;
        Vec velocity_derivative = state.boundary.half_velocity_gradient[b] * t_seen;
        Mat stress_derivative = directional<Dim>(state.boundary.half_stress_gradient[b], t_seen);
        if (partial) {
          const Vec t_missing = t - t_seen;
          velocity_derivative += state.boundary.velocity_gradient[b] * t_missing;
          stress_derivative += directional<Dim>(state.boundary.stress_gradient[b], t_missing);
        }
        velocity_dt.col(k) = frame.transpose() * velocity_derivative;
        stress_dt[k] = frame.transpose() * stress_derivative * frame;
      }
      if (state.settings.surface_extrapolation == Toggle::on) SurfaceExtrapolation<Dim>::apply(state, b, i, frame, t_new, velocity_dt);
      // Effective body force, with the damping, at time n.
      const Vec force_global = state.settings.body_force - state.settings.damping * state.boundary.velocity[b];
      const Vec force = frame.transpose() * force_global;
      // A particle on further symmetry planes (a corner): each plane's stretch from its own
      // characteristic relation (see corner_stretch). Where the virtual stencil spans
      // fewer than Dim directions (a corner at alpha 0.6) its divergence term would read a
      // missing direction as zero: the one-sided estimate stays.
      if (SymmetryPlanes<Dim>::any(state, b) && state.boundary.full_rank_gradient[b])
        for (int e = 0; e < 2; ++e) {
          const Vec& plane_normal = state.boundary.extra_normal[b][static_cast<std::size_t>(e)];
          if (plane_normal.squaredNorm() == 0.0) continue;
          const Vec m = outward_plane_normal(state, i, plane_normal);
          const double plane_speed = SymmetryPlanes<Dim>::normal_speed(state, b, e, t_new) * m.dot(plane_normal);
          const Vec m_frame = frame.transpose() * m;
          const double stretch =
              corner_stretch(state, b, m, plane_speed, force_global.dot(m), dt, c_p, z_p, modulus);
          velocity_dt += (stretch - m_frame.dot(velocity_dt * m_frame)) * (m_frame * m_frame.transpose());
        }

      // Updated Lagrangian: the Jaumann terms (W sigma - sigma W) of the normal stress
      // components t_n, t_k (the frame, condition_normal's, is held fixed over the
      // step), with the spin W from the velocity gradient in the frame: tangential
      // columns from the virtual set at n+1/2, the normal column from the real set at n.
      Mat jaumann = Mat::Zero();
      if (state.objective_rates()) {
        Mat gradient_estimate = velocity_dt;
        gradient_estimate.col(0) = velocity_dn;
        const Mat spin_estimate = 0.5 * (gradient_estimate - gradient_estimate.transpose());
        jaumann = objective_rotation_rate<Dim>(spin_estimate, stress0, dt);
      }
      // Outgoing invariants at n+1.
      double tangential_divergence = 0.0;  // div_t v_t
      double p_rhs = -z_p * force[0] + jaumann(0, 0);
      for (int k = 1; k < Dim; ++k) {
        tangential_divergence += velocity_dt(k, k);
        p_rhs += lame * velocity_dt(k, k) - c_p * stress_dt[k](k, 0);
      }
      double p_invariant = stress0(0, 0) - z_p * velocity0[0] -
                           c_p * dt * (stress_dn(0, 0) - z_p * velocity_dn[0]) + dt * p_rhs;
      std::array<double, Dim> s_invariant{};
      for (int k = 1; k < Dim; ++k) {
        double s_rhs = shear * velocity_dt(0, k) - z_s * force[k] + jaumann(0, k);
        for (int l = 1; l < Dim; ++l) s_rhs -= c_s * stress_dt[l](l, k);
        s_invariant[k] = stress0(0, k) - z_s * velocity0[k] -
                         c_s * dt * (stress_dn(0, k) - z_s * velocity_dn[k]) + dt * s_rhs;
      }

      // Incoming invariants from the prescribed velocity or traction.
      const Vec prescribed =
          frame.transpose() * condition.prescribed(state.initial_position_of(i), state.boundary.profile[b], t_new);
      // A wall-free edge (FreeEdge::wall_free_normal; a wall particle with a free face next
      // to it): the free face's sigma_mm = 0 at n+1 sets the stretch d_m u_m, as a free
      // face's zero traction sets its normal stretch (gradient(0, 0) below). The wall's
      // normal stretch d_n u_n does not depend on the tangential ones (the lambda div_t v_t
      // of its outgoing invariant is taken back out below), so it comes first:
      //   M d_m u_m = -sigma_mm^n / dt - J_mm - lambda (d_n u_n + div v - d_n u_n - d_m u_m),
      // the last bracket the rest of the tangential divergence (the edge's direction, 3D).
      // The stretch replaces the virtual set's one-sided estimate in the tangential
      // divergence, the wall's invariant and the tangential stresses; the velocity along
      // m and the zero shear on m follow after the constitutive update.
      const Vec wall_free_m = symmetry && state.boundary.full_rank_gradient[b]
                                  ? FreeEdge<Dim>::wall_free_normal(state, b, i, n, t_new)
                                  : Vec::Zero();
      if (wall_free_m.squaredNorm() > 0.0) {
        const Vec m_frame = frame.transpose() * wall_free_m;
        const double wall_stretch =
            ((p_invariant + z_p * prescribed[0] - stress0(0, 0)) / dt - jaumann(0, 0) - lame * tangential_divergence) /
            modulus;
        const double stretch_m = m_frame.dot(velocity_dt * m_frame);
        const double along_edge = tangential_divergence - stretch_m;
        const double target = (-m_frame.dot(stress0 * m_frame) / dt - m_frame.dot(jaumann * m_frame) -
                               lame * (wall_stretch + along_edge)) /
                              modulus;
        velocity_dt += (target - stretch_m) * (m_frame * m_frame.transpose());
        tangential_divergence += target - stretch_m;
        p_invariant += dt * lame * (target - stretch_m);
      }
      Mat stress1 = stress0;
      Vec velocity1;
      for (int k = 0; k < Dim; ++k) {
        const double invariant = k == 0 ? p_invariant : s_invariant[k];
        const double impedance = k == 0 ? z_p : z_s;
        if (velocity_given || (symmetry && k == 0)) {
          velocity1[k] = prescribed[k];
          stress1(0, k) = invariant + impedance * prescribed[k];
        } else {
          const double traction = symmetry ? 0.0 : prescribed[k];
          stress1(0, k) = traction;
          velocity1[k] = impedance > 0.0 ? (traction - invariant) / impedance : 0.0;
        }
        stress1(k, 0) = stress1(0, k);
      }

      // Tangential stresses: the velocity gradient in the frame, with its normal column
      // recovered from the rates of t_n and t_k, then Hooke and the Jaumann spin.
      Mat gradient = velocity_dt;  // gradient(i, j) = d v'_i / d x'_j
      gradient(0, 0) =
          ((stress1(0, 0) - stress0(0, 0)) / dt - jaumann(0, 0) - lame * tangential_divergence) /
          modulus;
      for (int k = 1; k < Dim; ++k)
        gradient(k, 0) =
            ((stress1(0, k) - stress0(0, k)) / dt - jaumann(0, k)) / shear - velocity_dt(0, k);
      const Mat spin = 0.5 * (gradient - gradient.transpose());
      const Mat rotation_rate = state.objective_rates()
                                    ? Mat(objective_rotation_rate<Dim>(spin, stress0, dt))
                                    : Mat(Mat::Zero());
      const double volumetric = gradient.trace();
      for (int k = 1; k < Dim; ++k)
        for (int l = 1; l < Dim; ++l)
          stress1(k, l) = stress0(k, l) +
                          dt * ((k == l ? lame * volumetric : 0.0) +
                                shear * (gradient(k, l) + gradient(l, k)) + rotation_rate(k, l));

      // Back to the global frame.
      Mat stress_global = frame * stress1 * frame.transpose();
      double volume_rate = volumetric;
      if (state.settings.free_edge_uniaxial == Toggle::on && !velocity_given && prescribed.squaredNorm() == 0.0) {
        const double edge_rate = FreeEdge<Dim>::make_uniaxial(state, b, i, frame, velocity_dt, dt, stress_global);
        if (!std::isnan(edge_rate)) volume_rate = FreeEdge<Dim>::uniaxial_volume_rate(state, edge_rate);
      }
      // Density from the same velocity gradient (the full step's one-sided estimate is
      // replaced, like the rest of the boundary state); a free edge's from its own
      // uniaxial state.
      if (state.density_follows()) {
        state.real.density[i] = state.boundary.density[b] * std::exp(-dt * volume_rate);
        state.real.volume[i] = state.real.mass[i] / state.real.density[i];
      }
      // A free corner (2D; FreeEdge::free_corner): both faces are traction-free, so the
      // in-plane stress is zero (and sigma_zz with it in plane strain, elastic); its
      // velocity is its frame's, the bisector of the faces (above). Session 18 zeroed the
      // stress (the corner had kept the sigma_mm that its first face does not constrain:
      // the oscillating plate, dx = 0.002 m, alpha 1.2, grew a symmetric mode at its free
      // end, 0.38 % per step; docs/notes/2026-11-28-surface-depth-and-free-corners.md)
      // and, at full rank, imposed the second face's P relation along the frame's
      // tangent. Measured 2026-12-07 (docs/notes/2026-12-07-free-corners.md), the
      // rotating block at alpha 1.2, |L - L0| / L0 over three turns at 11^2 / 21^2 /
      // 41^2: that rule 1.07e-2 / 1.38e-3 / 4.33e-4; both faces' P relations on the
      // lattice's normals 8.0e-3 / 2.7e-3 / 1.0e-3; the bisector frame 2.4e-3 / 4.5e-4 /
      // 2.1e-4, the plates as before.
      // A free vertex (3D, the same test: extreme along all three axes, every boundary
      // neighbour under a zero traction) has three traction-free faces, so its stress is
      // zero too; its velocity stays the own frame's. Before, the twisting column at
      // alpha 1.2 diverged from its free end's vertices (dx = 1/12 at 0.37 of its time; now
      // it reaches the end, docs/notes/2026-11-29-free-edges-in-rotation.md).
      if (free_corner) stress_global.setZero();
      Vec velocity_global = frame * velocity1;
      // The wall-free edge (above): the free face's zero shear, sigma <- P sigma P with
      // P = I - m m^T, and the velocity along m from the free face's outgoing P
      // characteristic with t_m = 0 at n+1 (as at a free corner: the own frame gave u_m from
      // the wall's S characteristic).
      if (wall_free_m.squaredNorm() > 0.0) {
        const Mat projector = Mat::Identity() - wall_free_m * wall_free_m.transpose();
        stress_global = projector * stress_global * projector;
        velocity_global += (free_face_velocity(state, b, wall_free_m, force_global, dt, c_p, z_p, lame) -
                            wall_free_m.dot(velocity_global)) *
                           wall_free_m;
      }
      // Further symmetry planes (an axis, a free edge or a wall crossing a plane).
      if (SymmetryPlanes<Dim>::any(state, b)) SymmetryPlanes<Dim>::project(state, b, t_new, velocity_global, stress_global);
      for (int d = 0; d < Dim; ++d) state.real.velocity[d][i] = velocity_global[d];
      StressVector<Dim> updated;
      for (int r = 0; r < Dim; ++r)
        for (int c = r; c < Dim; ++c) updated[stress_index<Dim>(r, c)] = stress_global(r, c);
      if constexpr (Dim == 2) {  // sigma_zz: plane strain follows lambda tr d; plane stress 0
        const auto zz = 3;
        updated[zz] = elastic.plane_mode() == PlaneMode::plane_stress || free_corner
                          ? 0.0
                          : state.boundary.stress[b][zz] + dt * lame * volumetric;
      }
      // A plastic material: the elastic boundary stress returned to the yield surface.
      updated = state.return_real_stress(i, updated, dt);
      for (int m = 0; m < stress_count; ++m) state.real.stress[m][i] = updated[m];
    }
  }
};

}  // namespace tsph
