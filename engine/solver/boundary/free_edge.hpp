// SolverSettings::free_edge_uniaxial (3D): the uniaxial stress of a zero-traction
// particle on a convex axis-parallel edge, instead of the characteristic relations on
// its diagonal kernel normal, which leave the shear sigma_xy = -sigma_xz free; and the
// free corners of 2D bodies and free vertices of 3D ones (free_corner), whose stress is
// zero; and the wall-free edges (wall_free_normal), where a traction-free face meets a
// smooth wall. Which particles these are is decided once, at the first build (classify).
#pragma once

#include "engine/solver/boundary/normals.hpp"
#include "engine/solver/state.hpp"

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

namespace tsph {

template <int Dim>
struct FreeEdge {
  using Vec = Vector<Dim>;
  using Mat = Matrix<Dim>;

  /// Whether real particle i is a free corner at time t: extreme along every axis among
  /// its neighbours within the support, in the initial configuration (the corner of a
  /// box, in 2D; a vertex in 3D: BoundaryParticles::box_corner, decided at the first
  /// build), with every boundary particle among its neighbours within the support under a
  /// traction condition whose traction is zero at t. A corner next to a held or loaded
  /// face (the cantilever's clamp and tip) is not one. Used in 2D and, for the zero
  /// stress of a free vertex, in 3D (characteristics.hpp).
  static bool free_corner(const SolverState<Dim>& state, std::uint32_t i, double t) {
    const std::int32_t b = state.boundary.slot[i];
    if (b < 0 || !state.boundary.box_corner[static_cast<std::size_t>(b)]) return false;
    const PointsView<Dim> real_points = points_of<Dim>(state.real);
    for (std::uint32_t j : state.lists.real_from_real.neighbors(i)) {
      const std::int32_t bj = state.boundary.slot[j];
      if (bj < 0 || !state.within_support(real_points, i, real_points, j)) continue;
      const auto& c = state.boundaries[static_cast<std::size_t>(state.real.boundary[j])];
      if (c.kind != BoundaryCondition<Dim>::Kind::traction ||
          c.prescribed(state.initial_position_of(j), state.boundary.profile[static_cast<std::size_t>(bj)], t).squaredNorm() != 0.0)
        return false;
    }
    return true;
  }

  /// The static geometry of the free corners and edges, decided once at the first build
  /// of the lists in the initial configuration (as BoundaryNormals decides on_surface):
  /// BoundaryParticles::box_corner and edge_axis. Before, both were decided again at
  /// every step for every surface particle (the edges' initial normal: a kernel sum and
  /// an eigen-solve each), and the support was the current one, so that an edge could
  /// leave the treatment when a neighbour left the support. Since 2026-11-29 the 3D step
  /// costs 1.0036 of its baseline instead of 1.0129 (tools/check_timing.py).
  static void classify(SolverState<Dim>& state) {
    for (std::size_t b = 0; b < state.boundary.particle.size(); ++b) {
      const std::uint32_t i = state.boundary.particle[b];
      state.boundary.box_corner[b] = 0;
      state.boundary.edge_axis[b] = -1;
      state.boundary.wall_edge[b] = 0;
      if (!state.boundary.on_surface[b]) continue;
      const Sides sides = neighbour_sides(state, i);
      bool corner = Dim >= 2;
      for (int d = 0; d < Dim; ++d) corner = corner && sides.below[d] != sides.above[d];
      state.boundary.box_corner[b] = corner ? 1 : 0;
      const auto& condition = state.boundaries[static_cast<std::size_t>(state.real.boundary[i])];
      if (condition.kind == BoundaryCondition<Dim>::Kind::traction)
        state.boundary.edge_axis[b] = static_cast<std::int8_t>(uniaxial_edge_axis(state, i, sides));
      if (Dim >= 2 && condition.kind == BoundaryCondition<Dim>::Kind::symmetry)
        for_each_wall_edge_neighbour(state, i, [&](std::uint32_t) { state.boundary.wall_edge[b] = 1; });
    }
  }

  /// Calls visit(j) for the real particles j of a traction condition one initial spacing
  /// or less from real particle i in the initial configuration (its nearest neighbours on
  /// a lattice): for a particle of a symmetry condition, the free face next to it
  /// (wall_free_normal).
  template <class Visit>
  static void for_each_wall_edge_neighbour(const SolverState<Dim>& state, std::uint32_t i, Visit&& visit) {
    const Vec x0 = state.initial_position_of(i);
    const double reach = 1.01 * state.initial_spacing;
    for (std::uint32_t j : state.lists.real_from_real.neighbors(i)) {
      if (j == i || j >= state.real.size() || state.boundary.slot[j] < 0) continue;
      const auto& c = state.boundaries[static_cast<std::size_t>(state.real.boundary[j])];
      if (c.kind != BoundaryCondition<Dim>::Kind::traction) continue;
      if ((state.initial_position_of(j) - x0).norm() > reach) continue;
      visit(j);
    }
  }

  /// A wall-free edge: particle i (slot b) of a symmetry condition (a smooth wall, outward
  /// normal n) on the edge where a traction-free face meets the wall
  /// (BoundaryParticles::wall_edge). Returns the free face's outward normal m there, the
  /// sum of the current normals of the free face's particles next to it projected into
  /// the wall's plane, normalised; zero where the particle is not on such an edge or the
  /// face's traction is not zero at t. Both faces' conditions hold on the edge: the
  /// wall's (u_n given, (sigma n)_t = 0) and the free face's (sigma m = 0), so that
  /// sigma = sigma_nn n n^T + sigma_ee e e^T (e the edge's direction, n x m).
  /// characteristics.hpp imposes the free face's part; before, nothing did, and at the
  /// Taylor bar's rim the radial stress stayed the bulk's compression and pushed the rim
  /// out (docs/notes/2026-12-07-wall-free-edge.md).
  static Vec wall_free_normal(const SolverState<Dim>& state, std::size_t b, std::uint32_t i, const Vec& n, double t) {
    if (!state.boundary.wall_edge[b]) return Vec::Zero();
    Vec m = Vec::Zero();
    bool loaded = false;
    for_each_wall_edge_neighbour(state, i, [&](std::uint32_t j) {
      const auto bj = static_cast<std::size_t>(state.boundary.slot[j]);
      const auto& c = state.boundaries[static_cast<std::size_t>(state.real.boundary[j])];
      loaded = loaded || c.prescribed(state.initial_position_of(j), state.boundary.profile[bj], t).squaredNorm() != 0.0;
      m += state.boundary.normal[bj];
    });
    if (loaded) return Vec::Zero();
    m -= m.dot(n) * n;
    const double norm = m.norm();
    return norm > 1e-6 ? Vec(m / norm) : Vec::Zero();
  }

  /// The current outward normals of the two faces that meet at a 2D corner of a box
  /// (box_corner; face d starts normal to axis d): each face's direction from the chord
  /// sum_j sign(X_j - X_i)_e (x_j - x_i) over the neighbours j that start on the face
  /// with i (the same coordinate d; e the other axis), within the support in the initial
  /// configuration, turned a right angle to the outside the face started on (the side no
  /// neighbour lies on). Unlike the particle's own normal it does not depend on how the
  /// faces are named (a corner whose faces are one condition has the kernel normal, two
  /// conditions the normal of the face it belongs to): the free corner's frame is their
  /// bisector (characteristics.hpp). Returns false where a face has no such neighbour
  /// (and in 1D and 3D).
  static bool corner_face_normals(const SolverState<Dim>& state, std::uint32_t i, std::array<Vec, Dim>& normals) {
    if constexpr (Dim == 2) {
      const Sides sides = neighbour_sides(state, i);
      const auto within = BoundaryNormals<Dim>::within_at_start(state, i);
      const Vec x0 = state.initial_position_of(i);
      const Vec x = state.real.position_of(i);
      const double tol = 1e-6 * state.initial_spacing;
      for (int d = 0; d < 2; ++d) {
        const int e = 1 - d;
        Vec chord = Vec::Zero();
        for (std::uint32_t j : state.lists.real_from_real.neighbors(i)) {
          if (j == i || !within(j)) continue;
          const Vec offset = state.initial_position_of(j) - x0;
          if (std::abs(offset[d]) > tol || std::abs(offset[e]) <= tol) continue;
          chord += (offset[e] > 0.0 ? 1.0 : -1.0) * (state.real.position_of(j) - x);
        }
        if (!(chord.norm() > 0.0)) return false;
        const Vec t = chord.normalized();  // started as +e_e
        // +e_e turned to +e_d: by -90 degrees for d = 0, +90 for d = 1; the outside is
        // the side of axis d with no neighbour.
        const Vec turned = d == 0 ? Vec(t[1], -t[0]) : Vec(-t[1], t[0]);
        normals[static_cast<std::size_t>(d)] = sides.above[d] ? Vec(-turned) : turned;
      }
      return true;
    } else {
      (void)state, (void)i, (void)normals;
      return false;
    }
  }

  /// Whether some neighbour of real particle i within the support lies below / above it
  /// along each axis, all in the initial configuration.
  struct Sides {
    std::array<bool, Dim> below{}, above{};
  };
  static Sides neighbour_sides(const SolverState<Dim>& state, std::uint32_t i) {
    const auto within = BoundaryNormals<Dim>::within_at_start(state, i);
    const Vec x0 = state.initial_position_of(i);
    const double tol = 1e-6 * state.initial_spacing;
    Sides sides;
    for (std::uint32_t j : state.lists.real_from_real.neighbors(i)) {
      if (!within(j)) continue;
      const Vec offset = state.initial_position_of(j) - x0;
      for (int d = 0; d < Dim; ++d) {
        sides.below[d] = sides.below[d] || offset[d] < -tol;
        sides.above[d] = sides.above[d] || offset[d] > tol;
      }
    }
    return sides;
  }

  /// SolverSettings::free_edge_uniaxial: the real particles that take the uniaxial stress
  /// of a free edge (surface particles of a traction condition on a convex axis-parallel
  /// edge, both faces under that condition; while the traction there is zero). Empty
  /// with the option off.
  static std::vector<std::uint32_t> particles(const SolverState<Dim>& state) {
    std::vector<std::uint32_t> edge;
    if (state.settings.free_edge_uniaxial != Toggle::on) return edge;
    for (std::size_t b = 0; b < state.boundary.particle.size(); ++b)
      if (state.boundary.edge_axis[b] >= 0) edge.push_back(state.boundary.particle[b]);
    return edge;
  }

  /// SolverSettings::free_edge_uniaxial: the axis along which real particle i lies on a
  /// convex edge, or -1. Decided on the initial positions of its neighbours within the
  /// support: on exactly two axes a, b every neighbour lies on one side of i
  /// (s_a (x0_j - x0_i)_a <= 0, the same sign s_a for all; likewise b), which makes i
  /// extreme in two directions: the edge of a box whose faces are coordinate planes.
  /// A face particle is extreme on one axis, a corner on three, a particle on an oblique
  /// or curved surface, or on a re-entrant edge, on one or none.
  static int free_edge_axis(const Sides& sides) {
    const auto& below = sides.below;
    const auto& above = sides.above;
    int extreme = 0, along = -1;
    for (int d = 0; d < Dim; ++d) {
      if (below[d] && above[d]) along = d;
      else if (below[d] != above[d]) ++extreme;
      else return -1;  // no neighbour along d at all: not an edge of a solid
    }
    return extreme == 2 ? along : -1;
  }

  /// The edge axis of free_edge_axis where the particle's normal lies between the two
  /// faces, else -1. Both faces under the particle's condition, or both free surfaces
  /// (BoundaryNormals::same_free_surface): its normal is then the kernel normal, between
  /// the faces (face_normal), with no component along the edge. An edge between two other
  /// conditions (a loaded face and a free one) takes one face's normal: left as it is. Decided on
  /// the normal in the initial configuration (initial_normal), as free_edge_axis
  /// is: the axes are those of the initial box. The current normal turns with the body,
  /// and a cube turned 45 degrees about z had its z-edges' normals on an axis, so the edges
  /// left and rejoined the treatment as the body turned (the rotating cube with the option
  /// on lost 39 % of its angular momentum in a turn at alpha 1.2, 2026-11-27).
  static int uniaxial_edge_axis(const SolverState<Dim>& state, std::uint32_t i, const Sides& sides) {
    if constexpr (Dim == 3) {
      const int along = free_edge_axis(sides);
      if (along < 0) return -1;
      const Vec n = initial_normal(state, i);
      if (std::abs(n[along]) > 0.3 || std::abs(n[(along + 1) % 3]) < 0.3 || std::abs(n[(along + 2) % 3]) < 0.3)
        return -1;
      return along;
    } else {
      (void)state, (void)i, (void)sides;
      return -1;
    }
  }

  /// The normal of real particle i in the initial configuration (initial positions,
  /// volumes m / rho0, the pairs within the support there), as the first step computes
  /// it (BoundaryNormals::compute): the face normal of its condition, which is the kernel
  /// normal -sum_J V_J grad W_IJ / |.| on an edge between two faces of one condition.
  static Vec initial_normal(const SolverState<Dim>& state, std::uint32_t i) {
    Vec normal = Vec::Unit(0);
    visit_kernel<Dim>(state.settings.kernel, [&](const auto& kernel) {
      const Vec sum = BoundaryNormals<Dim>::initial_kernel_gradient_sum(state, kernel, i);
      if (sum.norm() > 0.0) normal = -sum / sum.norm();
      normal = BoundaryNormals<Dim>::face_normal(state, initial_points_of<Dim>(state.real), i, normal,
                                                 state.real.boundary[i], BoundaryNormals<Dim>::within_at_start(state, i));
    });
    return normal;
  }

  /// SolverSettings::free_edge_uniaxial: on a convex edge between two zero-traction
  /// faces of one condition (free_edge_axis, and the normal between the faces) both
  /// tractions vanish, so the stress is uniaxial along the
  /// edge direction e, sigma = s e (x) e, with ds/dt = E e . grad v . e (the derivative
  /// along the edge, which the virtual stencil along the edge has). Without it only the
  /// traction on the kernel's diagonal normal vanishes and the edge keeps
  /// sigma_xy = -sigma_xz growing with mu d_x v_t (docs/method.md section 4). e is the
  /// current direction of the edge (the neighbours initially on the edge line; the
  /// coordinate axis itself in small strain), so that it turns with the body.
  /// Returns the stretch rate e . grad v . e when the edge took it (NaN otherwise): in
  /// updated Lagrangian the caller's density follows it (uniaxial_volume_rate).
  static double make_uniaxial(const SolverState<Dim>& state, std::size_t b, std::uint32_t i,
                              const Mat& frame, const Mat& velocity_dt, double dt, Mat& stress_global) {
    constexpr double none = std::numeric_limits<double>::quiet_NaN();
    if constexpr (Dim == 3) {
      const int along = state.boundary.edge_axis[b];
      if (along < 0) return none;
      const PointsView<Dim> real_points = points_of<Dim>(state.real);
      const Vec x0 = state.initial_position_of(i);
      const double tol = 1e-6 * state.initial_spacing;
      Vec chord = Vec::Zero();  // sum over the edge neighbours of sign (x_j - x_i)
      for (std::uint32_t j : state.lists.real_from_real.neighbors(i)) {
        if (!state.within_support(real_points, i, real_points, j)) continue;
        const Vec offset = state.initial_position_of(j) - x0;
        if (std::abs(offset[(along + 1) % 3]) > tol || std::abs(offset[(along + 2) % 3]) > tol) continue;
        chord += (offset[along] > 0.0 ? 1.0 : -1.0) * (state.real.position_of(j) - state.real.position_of(i));
      }
      if (!(chord.norm() > 0.0)) return none;
      const Vec e = chord.normalized();
      // Next to a corner the kernel normal leans towards the end face (n . e up to 0.17
      // at the cantilever's first and last edge particles). velocity_dt has no normal
      // column: it is filled in with the virtual set's normal derivative at n+1/2, so that
      // the rate is the whole directional derivative along e. Left zero, the rate read
      // (n . e) (d v_n / d e_t) in a rigid spin: the end particles of the rotating cube's
      // edges took a uniaxial stress growing at 0.12 E omega, and the cube lost 88 % of its
      // angular momentum in a turn at alpha 1.2 (2026-11-29). Where that stencil is
      // rank-deficient (an edge at alpha 0.6: two virtual neighbours on the edge line) the
      // column stays zero: the real set's at n instead took the 41 x 5 x 5 cantilever in
      // updated Lagrangian from -1.9 % to +6.6 %, drifting. Taking e's tangential part as
      // the edge direction instead gave 0.020 m for 0.050 m at 41 x 5 x 5.
      Mat full = velocity_dt;
      if (state.boundary.full_rank_gradient[b])
        full.col(0) = frame.transpose() * (state.boundary.half_velocity_gradient[b] * Vec(frame.col(0)));
      const Vec e_frame = frame.transpose() * e;
      const double rate = e_frame.dot(full * e_frame);
      const double previous = e.dot(in_plane<Dim>(state.boundary.stress[b]) * e);
      stress_global = (previous + dt * state.material.elastic().young_modulus() * rate) * e * e.transpose();
      return rate;
    } else {
      (void)state, (void)b, (void)i, (void)frame, (void)velocity_dt, (void)dt, (void)stress_global;
      return none;
    }
  }

  /// div v of a free edge stretched at `rate` along it under uniaxial stress: its two
  /// free sides contract at -nu rate each, (1 - 2 nu) rate. The characteristic relations
  /// on the edge's diagonal normal give a volume rate of a stress state that
  /// make_uniaxial then replaces; the density read from it made the compressed edges
  /// next to the 3D cantilever's clamp unstable in updated Lagrangian (diverged at
  /// t = 0.66 s; docs/notes/2026-11-28-cantilever-3d-updated-lagrangian.md).
  static double uniaxial_volume_rate(const SolverState<Dim>& state, double rate) {
    return (1.0 - 2.0 * state.material.elastic().poisson_ratio()) * rate;
  }
};

}  // namespace tsph
