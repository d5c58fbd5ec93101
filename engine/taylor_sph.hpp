// The Taylor-SPH stepper (seed eqs. 3-4; DESIGN.md section 3), Dim = 1, 2, 3.
//
// One step n -> n+1:
//   0. boundary pre-pass: gradients of U^n at the boundary real particles, from the
//      real set itself (for the characteristic boundary conditions);
//   1. half_step (real -> virtual), seed eq. (3): interpolate U^n to every virtual
//      particle with the normalised kernel, then
//        U_v^{n+1/2} = U_v^n + dt/2 [ S_v^n - div F ],
//      the divergence from sum_r V_r (F_r^n - F_v^n) . Gn_vr;
//      [conservative momentum option: the half step's gradient weights are stored;
//      updated Lagrangian: both sets move to the midpoint configuration]
//   2. full_step (virtual -> real), seed eq. (4):
//        U_r^{n+1} = U_r^n + dt [ S_r^{n+1/2} - div F ],
//      with F_r^{n+1/2} interpolated from the virtual neighbours (DESIGN.md 3.2);
//   3. boundary conditions at n+1 by characteristics (below); [the conservative
//      momentum update, if enabled]; then the hourglass stiffness (if enabled,
//      apply_hourglass_stiffness);
//   4. hourglass filter of the traction-surface particles' velocities (if enabled);
//   5. displacements; in updated-Lagrangian mode: the second half of the motion of
//      both sets, then rebuild the neighbour lists and normals.
//
// The flux divergence is written per field: the velocity gradient grad v (which
// gives D : d and the Jaumann spin, seed eq. 1a) and the stress divergence div sigma
// (seed eq. 1b, divided by the density at the particle).
//
// Our choices, beyond the seed (documented in README.md):
//  * The source S (Jaumann terms, body force, damping -c v) is evaluated at the
//    particle being updated from its own interpolated state and corrected velocity
//    gradient, rather than at the neighbours and interpolated: the same order of
//    accuracy, and no same-set neighbour lists in the bulk.
//  * Boundary real particles take their state from the characteristic relations in
//    the frame (n, t_k) of their computed outward normal. With t_n = n.sigma.n,
//    u_n = v.n, Z_p = rho c_p (and t_k = n.sigma.t_k, u_k = v.t_k, Z_s = rho c_s):
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
//    loaded along its axis (nu = 0) reproduces the 1D bar exactly.
#pragma once

#include "engine/boundary_condition.hpp"
#include "engine/elasticity.hpp"
#include "engine/input_error.hpp"
#include "engine/parallel.hpp"
#include "engine/particle_set.hpp"
#include "kernels/corrected_operators.hpp"
#include "kernels/smoothing_kernels.hpp"
#include "neighbor/cell_list.hpp"
#include "neighbor/neighbor_search.hpp"
#include "neighbor/spatial_order.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace tsph {

/// small_strain: particles stay at their initial positions and the density is fixed
/// (geometrically linear, the setting of the seed's bar and of its exact solution).
/// updated_lagrangian: particles move with the material, density follows
/// d rho/dt = -rho div v, and neighbour lists are rebuilt every step.
enum class Kinematics { small_strain, updated_lagrangian };

inline std::string_view to_string(Kinematics k) {
  return k == Kinematics::small_strain ? "small_strain" : "updated_lagrangian";
}

template <int Dim>
struct SolverSettings {
  double smoothing_length = 0.0;  ///< h; the support radius is 2h
  KernelKind kernel = KernelKind::cubic_spline;
  InterpolationKind interpolation = InterpolationKind::linear;
  Kinematics kinematics = Kinematics::small_strain;
  Vector<Dim> body_force = Vector<Dim>::Zero();  ///< b, per unit mass
  /// Velocity damping c (1/s): dv/dt = ... - c v (dynamic relaxation to a static state).
  double damping = 0.0;
  /// Hourglass control epsilon in [0, 1): each step the velocity of every real particle
  /// on a traction (free or loaded) surface is relaxed towards the linear-corrected
  /// average of its real neighbours, v <- (1 - eps) v + eps vbar. Exact for linear
  /// fields. Without it, a surface particle can hold a steady velocity pattern that the
  /// virtual set cannot see (the real-particle checkerboard of DESIGN.md section 5,
  /// fed by the characteristic relations): the 2D plane-stress cantilever then creeps
  /// without end. 0.02 to 0.05 cures it; 0.1 and above spoils it (README).
  double hourglass_coefficient = 0.0;
  /// Hourglass stiffness kappa >= 0 (dimensionless; see apply_hourglass_stiffness): a
  /// restoring force on the part of the real displacement field that the virtual
  /// particles cannot see (the checkerboard, odd-even columns), with stiffness
  /// k = kappa M / h^2 per unit volume (M the P-wave modulus). Zero for every linear
  /// displacement field (rigid motions included), so it leaves the patch test exact.
  /// Off by default: it smooths the cantilever's displacement field but does not make
  /// the cantilever converge (README, Known problems). Diverges above about 0.25 at
  /// alpha 0.6, CFL 0.9.
  double hourglass_stiffness = 0.0;
  /// Stress of the particles on a prescribed-velocity surface (a clamp).
  /// characteristics: the characteristic relations (default; exact for the 1D bar).
  /// wall_gradient: the bulk update sigma += dt D : grad v^{n+1/2} with the gradient of
  /// the virtual half-step velocity taken relative to the prescribed velocity at the
  /// particle (not relative to the interpolated one), so that a virtual velocity that
  /// does not vanish at a fixed wall (a rigid rotation about the clamp) is a strain
  /// there and meets a stress. tools/tsph-spectrum: with characteristics the clamped
  /// cantilever's one-step map has a fixed point that rotates about the clamp (the creep).
  enum class VelocityWall { characteristics, wall_gradient };
  VelocityWall velocity_wall = VelocityWall::characteristics;
  /// Momentum update in conservative (weak, Galerkin) form instead of the corrected
  /// divergence (option, off by default; README, Known problems): the velocity of every
  /// real particle without a velocity condition or a non-zero traction gets
  ///   m_I dv_I/dt = -sum_v V_v sigma_v^{n+1/2} . D_vI,
  /// D_vI the weight of I in the half step's corrected gradient at v (sum_I D_vI = 0),
  /// so that every virtual particle's forces sum to zero: linear momentum is conserved
  /// to round-off without external loads, and free surfaces are natural (zero traction).
  bool conservative_momentum = false;
  /// Free- and traction-surface particles take their tangential velocity gradient from
  /// the virtual half-step velocities, whose stencil (one row, alpha 0.6) lies a distance
  /// delta = n . (x_I - x_centroid) inside: the gradient of the row, not of the surface
  /// (the cantilever's outer fibres are then softer by delta / (D / 2)). With this option
  /// the tangential block is extrapolated to the surface to first order,
  ///   d_k v_l (surface) = d_k v_l (row) + delta d_n d_k v_l,  d_n d_k v_l = -d_k d_l v_n,
  /// the last from the traction-free rate d_n v_l + d_l v_n = 0 (sigma_nl = 0 along the
  /// surface); d_k d_l v_n is the tangential difference of the neighbouring surface
  /// particles' half-step gradients d_k v_n (README, The cantilever). Off by default.
  bool surface_extrapolation = false;
  /// 3D only (refused in 1D and 2D): a zero-traction particle on a convex edge parallel
  /// to a coordinate axis (free_edge_axis: in the initial configuration its neighbours
  /// fill a quarter space bounded by two coordinate planes, as on the edges of an
  /// axis-aligned box), both faces under its condition (its normal between them), takes the uniaxial stress along the edge (make_free_edge_uniaxial)
  /// instead of the characteristic relations on its diagonal kernel normal, which leave
  /// the shear sigma_xy = -sigma_xz free (the 3D cantilever's edges then carry its shear
  /// force and the bending moment never builds: -86 % at 41 x 5 x 5; README, The
  /// cantilever). Other particles (faces, corners, re-entrant or oblique edges, curved
  /// surfaces) are left as they are. Off by default; on in CantileverSettings<3>.
  bool free_edge_uniaxial = false;
  /// Neighbour search of the half-step and boundary lists: the cell list, the kd-tree,
  /// or `automatic`, which picks per rebuild by the rule of neighbor/neighbor_search.hpp
  /// (the kd-tree only for sets spread thinly over a large box). Same lists either way.
  NeighborSearch neighbor_search = NeighborSearch::automatic;
  /// The real -> virtual list of the full step is the transpose of the virtual -> real
  /// list of the half step (same radius: the same pairs) instead of a second search:
  /// 11 % (2D) and 14 % (3D) fewer instructions per updated-Lagrangian step, but both
  /// lists are then held at once, +65 B per real particle in 2D (461 B, over the 400 B
  /// target; bench/RESULTS.md, memory_estimate.hpp). Off by default for that reason.
  bool transpose_lists = false;
  /// Verlet skin of the updated-Lagrangian neighbour lists, as a fraction of the support
  /// radius 2h, in [0, 1]; 0.05 by default (1.4-1.5x per step; bench/RESULTS.md). 0: the
  /// lists are searched at every use (the full step's list at the midpoint
  /// configuration, the others at x^n), one list held at a time. s > 0: all
  /// lists are searched with the radius (1 + s) 2h, kept across steps (the full step's
  /// is the transpose of the half step's), and searched again only when a pair may have
  /// come closer by more than the skin s 2h since the last search: a bound on each set's
  /// path length since then (the sum over moves of the largest dt/2 |v|, no stored
  /// positions), checked at every configuration at which lists are used (x^n, and the
  /// midpoint of move_to_midpoint; lists_outdated). Pairs beyond 2h have kernel weights exactly 0 and
  /// every other use of a row is filtered by distance (within_support), so the run is
  /// the run without skin to round-off (the zero pairs shift the lanes of the packed
  /// sums; tested to 1e-12); with hourglass_stiffness,
  /// hourglass_coefficient or surface_extrapolation the run without skin uses lists of
  /// x^n at the midpoint, the run with skin the pairs within 2h at the midpoint (the
  /// two differ by pairs that cross the support edge within half a step). Not used in
  /// small strain (nothing moves). Both half-step lists are then held at once
  /// (bench/RESULTS.md, memory_estimate.hpp: 2D 365-372 B, 3D 764 B per real particle at the
  /// peak, under the 400 B / 800 B targets of issue 4).
  double neighbor_skin = 0.05;
  /// Locality: both particle sets are sorted into this order (cells of a quarter of the
  /// support radius, row by row or along the Z curve) when their order has decayed:
  /// when the mean index spread of the rows of the virtual -> real list (last - first
  /// real index of a row) exceeds `reorder_threshold` times that of the sorted order.
  /// Checked at construction (a set in random order is sorted; a lattice built by the
  /// cases is already in order and is kept) and at each updated-Lagrangian rebuild.
  /// Sorting renumbers the particles (ids are kept, counted in SolverCounters::reorders):
  /// callers that hold particle indices across steps must look them up again after a
  /// reorder. `none` (the default): never sorted.
  SpatialOrder spatial_order = SpatialOrder::none;
  double reorder_threshold = 2.0;  ///< > 1
  /// The virtual set keeps the optional fields of ParticleSet (initial positions,
  /// displacements, ids, boundary and group tags) for callers that read them (the
  /// virtual frames of `tsph run`). Off (the default): the constructor releases them
  /// (ParticleSet::release_optional_fields), 44 B per virtual particle in 2D and 60 B in
  /// 3D (bench/RESULTS.md, Memory): the stepper reads none of them, except the initial
  /// positions with the hourglass stiffness, which are then kept.
  bool keep_virtual_fields = false;
};

/// What the run did; fallbacks are counted per stencil evaluation.
struct SolverCounters {
  std::int64_t steps = 0;
  std::int64_t neighbor_builds = 0;
  std::int64_t empty_stencils = 0;
  std::int64_t interpolation_fallbacks = 0;
  std::int64_t gradient_fallbacks = 0;
  std::int64_t reorders = 0;  ///< sorts of the particle sets (SolverSettings::spatial_order)
  /// Checks of the displacement since the last search (SolverSettings::neighbor_skin):
  /// two per updated-Lagrangian step; each that finds a particle beyond half the skin
  /// searches again (neighbor_builds).
  std::int64_t skin_checks = 0;
};

/// exp(x), as std::exp to round-off (1-2 ulp), for the density update
/// rho^{n+1} = rho^n exp(-dt tr L): there |x| is about dt |div v|, far below 2^-10, where
/// the Taylor polynomial to x^5 is exact to x^6 / 720 < 2e-21 (relative), and costs a
/// tenth of std::exp (two calls per pair of stencil rows); std::exp elsewhere.
inline double exp_of_small(double x) {
  if (!(std::abs(x) <= 0x1p-10)) return std::exp(x);
  return 1.0 + x * (1.0 + x * (0.5 + x * (1.0 / 6.0 + x * (1.0 / 24.0 + x * (1.0 / 120.0)))));
}

/// Orthonormal frame whose first column is the unit vector n.
template <int Dim>
Matrix<Dim> normal_frame(const Vector<Dim>& n) {
  Matrix<Dim> frame;
  frame.col(0) = n;
  if constexpr (Dim == 2) {
    frame(0, 1) = -n[1];
    frame(1, 1) = n[0];
  } else if constexpr (Dim == 3) {
    int axis = 0;  // the coordinate axis least aligned with n
    for (int d = 1; d < 3; ++d)
      if (std::abs(n[d]) < std::abs(n[axis])) axis = d;
    Vector<3> e = Vector<3>::Unit(axis);
    const Vector<3> t1 = (e - e.dot(n) * n).normalized();
    frame.col(1) = t1;
    frame.col(2) = n.cross(t1);
  }
  return frame;
}

/// A particle is on a surface when none of its real neighbours lies within 60 degrees
/// of the outward kernel normal -sum_J V_J grad W_IJ (cosine below this value).
inline constexpr double kSurfaceCosine = 0.5;

/// The run blew up: NaN/Inf in either particle set or a runaway of the energy. The
/// message names the step, the time, the first offending particle (id, position) and
/// the likely cause; the command-line programs exit with status 3 on it.
class SolutionDiverged : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Runaway energy: the total energy of the real set grows by at least a factor g in each
/// of K(g) consecutive steps, g^K(g) >= kRunawayFactor, for any g of kRunawayGrowths (or
/// it overflows). A load switched on at any time whose energy input grows like
/// (t - t1)^k grows by (1 + 1/m)^k at its m-th step, which stays above g for K(g)
/// consecutive steps only if k > ln(kRunawayFactor) = 6.9, so no load of degree up to 6
/// triggers it, while a mode that grows by g or more per step (an unstable CFL: about
/// 1.45 at CFL 1.05, 12 at CFL 1.5 in the bar) is caught within K(g) steps of
/// dominating the energy, long before it overflows.
inline constexpr double kRunawayFactor = 1000.0;
inline constexpr std::array<double, 3> kRunawayGrowths = {2.0, 1.2, 1.05};
/// Runaway of an oscillating energy (the per-step rule above misses it): the largest
/// energy so far, M, grew by kRunawayWindowFactor or more over the last W steps and
/// over the W before, the later growth at least half the earlier one (an exponential,
/// whose log is straight; a power (t - t1)^k has a concave log and passes both only for
/// k > 20), for W of kRunawayWindows.
inline constexpr double kRunawayWindowFactor = 30.0;
inline constexpr std::array<int, 2> kRunawayWindows = {20, 100};
/// A sudden blow-up (the 2D updated-Lagrangian cantilever at its clamp: the energy jumps
/// x85 in 4 steps, falls back, and overflows 60 steps later): the energy exceeds
/// kRunawayJumpFactor times the largest energy of the run up to kRunawayJumpSteps steps
/// before, once the run has carried energy for kRunawayJumpAfter steps (a power
/// (t - t1)^k of the time since the load started does that only for k > 340).
inline constexpr double kRunawayJumpFactor = 30.0;
inline constexpr int kRunawayJumpSteps = 10;
inline constexpr std::int64_t kRunawayJumpAfter = 1000;
/// Benchmarks time the stages of a step one by one (defined in bench/bench_step_nd.cpp).
template <int Dim>
struct StepStages;
/// One step applied to a given state, for the spectrum of the step map (defined in
/// engine/step_map.hpp).
template <int Dim>
struct LinearStepAccess;

template <int Dim>
class TaylorSph {
  friend struct StepStages<Dim>;
  friend struct LinearStepAccess<Dim>;

 public:
  using Vec = Vector<Dim>;
  using Mat = Matrix<Dim>;
  static constexpr int stress_count = stress_component_count<Dim>;
  using StressGradient = std::array<Vec, stress_count>;

  TaylorSph(ParticleSet<Dim> real, ParticleSet<Dim> virtual_particles, LinearElastic<Dim> material,
            SolverSettings<Dim> settings, std::vector<BoundaryCondition<Dim>> boundaries)
      : real_(std::move(real)),
        virtual_(std::move(virtual_particles)),
        material_(std::move(material)),
        settings_(std::move(settings)),
        boundaries_(std::move(boundaries)) {
    if (!(settings_.smoothing_length > 0.0) || !std::isfinite(settings_.smoothing_length))
      throw std::invalid_argument("solver: smoothing length h = " +
                                  std::to_string(settings_.smoothing_length) +
                                  " must be positive");
    if (!(settings_.damping >= 0.0) || !std::isfinite(settings_.damping))
      throw std::invalid_argument("solver: damping = " + std::to_string(settings_.damping) +
                                  " must be >= 0");
    if (!(settings_.hourglass_coefficient >= 0.0 && settings_.hourglass_coefficient < 1.0))
      throw std::invalid_argument("solver: hourglass coefficient = " +
                                  std::to_string(settings_.hourglass_coefficient) +
                                  " must lie in [0, 1)");
    if (!(settings_.hourglass_stiffness >= 0.0 && settings_.hourglass_stiffness <= 1.0))
      throw std::invalid_argument("solver: hourglass stiffness = " +
                                  std::to_string(settings_.hourglass_stiffness) +
                                  " must lie in [0, 1]");
    if (!(settings_.reorder_threshold > 1.0) || !std::isfinite(settings_.reorder_threshold))
      throw std::invalid_argument("solver: reorder threshold = " +
                                  std::to_string(settings_.reorder_threshold) + " must be > 1");
    if (!(settings_.neighbor_skin >= 0.0 && settings_.neighbor_skin <= 1.0))
      throw std::invalid_argument("solver: neighbour skin = " + std::to_string(settings_.neighbor_skin) +
                                  " must lie in [0, 1] (a fraction of the support radius 2h)");
    if (real_.size() == 0 || virtual_.size() == 0)
      throw std::invalid_argument("solver: needs at least one real and one virtual particle");
    if (settings_.free_edge_uniaxial && Dim != 3)
      throw std::invalid_argument("solver: free_edge_uniaxial applies to the edges of 3D bodies only (dimension " +
                                  std::to_string(Dim) + ")");
    real_.check_field_sizes("solver: the real set");
    virtual_.check_field_sizes("solver: the virtual set");
    if (!real_.carries(real_.initial_position) || !real_.carries(real_.displacement) ||
        !real_.carries(real_.id) || !real_.carries(real_.boundary))
      throw std::invalid_argument("solver: the real set must carry its initial positions, displacements, "
                                  "ids and boundary tags (released optional fields)");
    // The virtual initial positions X_v: read by the hourglass stiffness and by the
    // updated-Lagrangian virtual motions that keep the virtual particles at X_v.
    const bool virtual_initial_positions =
        settings_.hourglass_stiffness > 0.0 || settings_.keep_virtual_fields ||
        positions_move();
    if (settings_.keep_virtual_fields
            ? !(virtual_.carries(virtual_.initial_position) && virtual_.carries(virtual_.displacement) &&
                virtual_.carries(virtual_.id) && virtual_.carries(virtual_.boundary) &&
                virtual_.carries(virtual_.group))
            : virtual_initial_positions && !virtual_.carries(virtual_.initial_position))
      throw std::invalid_argument(
          "solver: the virtual set has released optional fields that this run reads (the initial "
          "positions for the hourglass stiffness or the updated-Lagrangian virtual motion, or every field with keep_virtual_fields)");
    if (!settings_.keep_virtual_fields) virtual_.release_optional_fields(virtual_initial_positions);
    boundary_slot_.assign(real_.size(), -1);
    for (std::size_t i = 0; i < real_.size(); ++i) {
      const std::int32_t b = real_.boundary[i];
      if (b == ParticleSet<Dim>::kNoBoundary) continue;
      if (b < 0 || static_cast<std::size_t>(b) >= boundaries_.size())
        throw std::invalid_argument("solver: real particle " + std::to_string(i) +
                                    " refers to boundary condition " + std::to_string(b) +
                                    " of " + std::to_string(boundaries_.size()));
      boundary_slot_[i] = static_cast<std::int32_t>(boundary_particles_.size());
      boundary_particles_.push_back(static_cast<std::uint32_t>(i));
      const Vec x0 = initial_position_of(i);
      boundary_profile_.push_back(boundaries_[static_cast<std::size_t>(b)].profile(x0));
    }
    const std::size_t nb = boundary_particles_.size();
    // Eigen's fixed-size types are not initialised by default: zero every slot, so that a
    // boundary particle whose stencil is empty (counted) reads zero gradients.
    StressGradient zero_gradient;
    for (auto& g : zero_gradient) g.setZero();
    boundary_normal_.assign(nb, Vec::Zero());
    boundary_stress_.assign(nb, StressVector<Dim>{});
    boundary_velocity_.assign(nb, Vec::Zero());
    boundary_density_.assign(nb, 0.0);
    boundary_stress_gradient_.assign(nb, zero_gradient);
    boundary_velocity_gradient_.assign(nb, Mat::Zero());
    boundary_half_stress_gradient_.assign(nb, zero_gradient);
    boundary_half_velocity_gradient_.assign(nb, Mat::Zero());
    boundary_half_velocity_.assign(nb, Vec::Zero());
    boundary_gradient_sum_.assign(nb, Vec::Zero());
    boundary_stencil_offset_.assign(nb, Vec::Zero());
    if (settings_.conservative_momentum)  // the only reader of v^n after the full step
      for (auto& v : previous_velocity_) v.resize(real_.size());
    filtered_velocity_.assign(nb, Vec::Zero());
    double virtual_volume = 0.0;  // dx of the CFL in a diagnosis (check_stability)
    for (std::size_t q = 0; q < virtual_.size(); ++q) virtual_volume += virtual_.volume[q];
    initial_spacing_ = std::pow(virtual_volume / static_cast<double>(virtual_.size()), 1.0 / Dim);
    rebuild_neighbors();
  }

  double support_radius() const { return kSupportFactor * settings_.smoothing_length; }
  /// The skin in length units (SolverSettings::neighbor_skin x 2h), 0 in small strain.
  double skin_distance() const {
    return positions_move() ? settings_.neighbor_skin * support_radius() : 0.0;
  }
  /// Updated Lagrangian: the particles move.
  bool positions_move() const { return settings_.kinematics == Kinematics::updated_lagrangian; }
  /// Updated Lagrangian: the stress rate carries the Jaumann terms.
  bool objective_rates() const { return settings_.kinematics == Kinematics::updated_lagrangian; }
  /// Updated Lagrangian: d rho / dt = -rho div v.
  bool density_follows() const { return settings_.kinematics == Kinematics::updated_lagrangian; }
  /// Radius of the neighbour searches: 2h plus the skin.
  double list_radius() const { return support_radius() + skin_distance(); }
  double time() const { return time_; }
  /// Sets the clock (to land exactly on an output time after round-off).
  void set_time(double t) { time_ = t; }
  const ParticleSet<Dim>& real() const { return real_; }
  const ParticleSet<Dim>& virtual_particles() const { return virtual_; }
  const LinearElastic<Dim>& material() const { return material_; }
  const SolverSettings<Dim>& settings() const { return settings_; }
  const SolverCounters& counters() const { return counters_; }
  const NeighborList& virtual_from_real() const { return virtual_from_real_; }
  /// The search of the last rebuild (cell_list or kd_tree; `automatic` resolved).
  NeighborSearch neighbor_search_used() const { return neighbor_search_used_; }
  /// In updated-Lagrangian runs without skin this list is built in the full step and
  /// released by the rebuild at the end of the step (see lists_used_once()): empty
  /// between steps. With a skin both lists are kept (radius list_radius()).
  const NeighborList& real_from_virtual() const { return real_from_virtual_; }
  /// Rows: real particles (only the boundary ones filled); entries: real, self excluded.
  const NeighborList& real_from_real() const { return real_from_real_; }
  /// Boundary particles (indices into real()) and their outward unit normals.
  const std::vector<std::uint32_t>& boundary_particles() const { return boundary_particles_; }
  const std::vector<Vec>& boundary_normals() const { return boundary_normal_; }

  /// Advances the solution by dt (seed eqs. 3 and 4, then the boundary conditions).
  void step(double dt) {
    if (!(dt > 0.0) || !std::isfinite(dt))
      throw std::invalid_argument("solver: time step dt = " + std::to_string(dt) +
                                  " must be positive");
    visit_kernel<Dim>(settings_.kernel, [&](const auto& kernel) {
      boundary_gradients(kernel);
      half_step(kernel, dt);
      if (settings_.conservative_momentum) store_momentum_weights(kernel);
      if (positions_move()) {
        move_to_midpoint(dt);  // and begin_displacement's update
        if (skin_distance() > 0.0 && lists_outdated(dt)) search_lists();  // lists used at the midpoint
      } else {
        begin_displacement(dt);
      }
      full_step(kernel, dt);
      apply_boundary_conditions(dt, time_ + dt);
      if (settings_.conservative_momentum) apply_conservative_momentum(dt, time_ + dt);
      if (settings_.hourglass_stiffness > 0.0) apply_hourglass_stiffness(kernel, dt);
      if (settings_.hourglass_coefficient > 0.0) filter_hourglass(kernel);
    });
    check_stability(dt);  // a diverged state is reported before it moves any particle
    move(dt);
    if (positions_move()) {
      if (skin_distance() > 0.0 && !lists_outdated(dt)) {
        compute_boundary_normals();  // the lists still hold every pair within 2h at x^{n+1}
      } else {
        rebuild_neighbors();
      }
    }
    time_ += dt;
    ++counters_.steps;
  }

  /// Renumbers the particles: new real particle k is old real_order[k], new virtual
  /// particle k old virtual_order[k] (each a permutation), with every per-particle state
  /// of the stepper (permute_state), and builds the neighbour lists again. The run goes
  /// on as it would have, up to the order of sums (round-off). SolverSettings::
  /// spatial_order does this itself when the order decays; exposed to impose an order.
  void permute_particles(const std::vector<std::uint32_t>& real_order,
                         const std::vector<std::uint32_t>& virtual_order) {
    // Both checked before anything moves (ParticleSet::permute checks again).
    require_permutation(real_order, real_.size(), "solver: permute_particles: the real order");
    require_permutation(virtual_order, virtual_.size(), "solver: permute_particles: the virtual order");
    permute_state(real_order, virtual_order);
    build_lists();
    sorted_spread_ = -1.0;  // the sorted order's spread, measured again at the next rebuild
  }

  /// SolverSettings::free_edge_uniaxial: the real particles that take the uniaxial stress
  /// of a free edge (surface particles of a traction condition on a convex axis-parallel
  /// edge, both faces under that condition; while the traction there is zero). Empty
  /// with the option off.
  std::vector<std::uint32_t> free_edge_particles() const {
    std::vector<std::uint32_t> edge;
    if (!settings_.free_edge_uniaxial) return edge;
    for (std::size_t b = 0; b < boundary_particles_.size(); ++b) {
      const std::uint32_t i = boundary_particles_[b];
      const auto& condition = boundaries_[static_cast<std::size_t>(real_.boundary[i])];
      if (boundary_on_surface_[b] && condition.kind == BoundaryCondition<Dim>::Kind::traction &&
          uniaxial_edge_axis(i, boundary_normal_[b]) >= 0)
        edge.push_back(i);
    }
    return edge;
  }

  /// Kinetic energy sum_I m_I |v_I|^2 / 2 of the real particles.
  double kinetic_energy() const {
    double energy = 0.0;
    for (std::size_t i = 0; i < real_.size(); ++i) {
      double v2 = 0.0;
      for (int d = 0; d < Dim; ++d) v2 += real_.velocity[d][i] * real_.velocity[d][i];
      energy += 0.5 * real_.mass[i] * v2;
    }
    return energy;
  }
  /// Strain energy sum_I V_I w(sigma_I) of the real particles.
  double strain_energy() const {
    double energy = 0.0;
    for (std::size_t i = 0; i < real_.size(); ++i)
      energy += real_.volume[i] * material_.strain_energy_density(stress_of(real_, i));
    return energy;
  }
  /// Linear momentum sum_I m_I v_I of the real particles.
  Vec linear_momentum() const {
    Vec p = Vec::Zero();
    for (std::size_t i = 0; i < real_.size(); ++i)
      for (int d = 0; d < Dim; ++d) p[d] += real_.mass[i] * real_.velocity[d][i];
    return p;
  }

 private:
  /// NaN/Inf in the velocity or stress of either set, or a runaway of the energy
  /// (kRunawayGrowths, kRunawayWindows, kRunawayJumpFactor): throws SolutionDiverged
  /// with the diagnosis.
  void check_stability(double dt) {
    const std::int64_t step = counters_.steps + 1;
    auto non_finite = [](const ParticleSet<Dim>& set, std::size_t i) -> const char* {
      for (int d = 0; d < Dim; ++d)
        if (!std::isfinite(set.velocity[d][i])) return "velocity";
      for (int m = 0; m < stress_count; ++m)
        if (!std::isfinite(set.stress[m][i])) return "stress";
      return nullptr;
    };
    // One parallel pass over fixed blocks of particles (kStabilityBlock, not one per
    // thread: the energy's sum order, hence its round-off, does not depend on the thread
    // count): the first non-finite particle of each block and the block's energies,
    // combined in block order. Was two serial passes (3 % of a 2D step, serial).
    const std::size_t real_blocks = (real_.size() + kStabilityBlock - 1) / kStabilityBlock;
    const std::size_t virtual_blocks = (virtual_.size() + kStabilityBlock - 1) / kStabilityBlock;
    stability_blocks_.resize(real_blocks + virtual_blocks);
    parallel_for(real_blocks + virtual_blocks, [&](std::size_t block) {
      const bool is_real = block < real_blocks;
      const ParticleSet<Dim>& set = is_real ? real_ : virtual_;
      const std::size_t begin = (is_real ? block : block - real_blocks) * kStabilityBlock;
      const std::size_t end = std::min(set.size(), begin + kStabilityBlock);
      StabilityBlock result;
      for (std::size_t i = begin; i < end; ++i)
        if (non_finite(set, i) != nullptr) {
          result.first_non_finite = i;
          break;
        }
      if (is_real)
        for (std::size_t i = begin; i < end; ++i) {
          double v2 = 0.0;
          for (int d = 0; d < Dim; ++d) v2 += set.velocity[d][i] * set.velocity[d][i];
          result.kinetic += 0.5 * set.mass[i] * v2;
          result.strain += set.volume[i] * material_.strain_energy_density(stress_of(set, i));
        }
      stability_blocks_[block] = result;
    });
    for (std::size_t block = 0; block < real_blocks + virtual_blocks; ++block)
      if (const std::size_t i = stability_blocks_[block].first_non_finite; i != kNoParticle) {
        const ParticleSet<Dim>& set = block < real_blocks ? real_ : virtual_;
        throw SolutionDiverged(diagnosis(step, dt, set, i, std::string("has a non-finite ") + non_finite(set, i)));
      }
    double kinetic = 0.0, strain = 0.0;
    for (std::size_t block = 0; block < real_blocks; ++block) {
      kinetic += stability_blocks_[block].kinetic;
      strain += stability_blocks_[block].strain;
    }
    const double energy = kinetic + strain;
    std::string runaway = std::isfinite(energy) ? "" : "the total energy overflowed";
    for (std::size_t k = 0; k < kRunawayGrowths.size(); ++k) {
      const double g = kRunawayGrowths[k];
      auto& count = energy_growth_steps_[k];
      count = previous_energy_ > 0.0 && energy >= g * previous_energy_ ? count + 1 : 0;
      const int steps = static_cast<int>(std::ceil(std::log(kRunawayFactor) / std::log(g)));
      if (runaway.empty() && count >= steps)
        runaway = "the total energy grew by a factor " + format_number(g) + " or more in each of the last " +
                  std::to_string(steps) + " steps (to " + format_number(energy) + " J)";
    }
    const double largest = std::max(largest_energy_.empty() ? 0.0 : largest_energy_.back(), energy);
    largest_energy_.push_back(largest);  // the last 2 W + 1 values of M
    if (largest_energy_.size() > 2 * static_cast<std::size_t>(kRunawayWindows.back()) + 1)
      largest_energy_.erase(largest_energy_.begin());
    if (largest > 0.0) ++energized_steps_;
    if (const std::size_t n = largest_energy_.size() - 1, back = kRunawayJumpSteps;
        runaway.empty() && energized_steps_ > kRunawayJumpAfter && n >= back &&
        energy >= kRunawayJumpFactor * largest_energy_[n - back])
      runaway = "the total energy jumped to " + format_number(energy) + " J, x" +
                format_number(energy / largest_energy_[n - back]) +
                " the largest of the run until " + std::to_string(kRunawayJumpSteps) +
                " steps before";
    for (int w : kRunawayWindows) {
      const std::size_t n = largest_energy_.size() - 1, window = static_cast<std::size_t>(w);
      if (!runaway.empty() || n < 2 * window) continue;
      const double now = largest_energy_[n], before = largest_energy_[n - window],
                   earlier = largest_energy_[n - 2 * window];
      if (earlier > 0.0 && before >= kRunawayWindowFactor * earlier &&
          now >= kRunawayWindowFactor * before && now / before >= 0.5 * (before / earlier))
        runaway = "the largest energy so far grew steadily, x" + format_number(before / earlier) +
                  " and then x" + format_number(now / before) + " over two spans of " +
                  std::to_string(w) + " steps (to " + format_number(now) + " J)";
    }
    if (!runaway.empty()) {
      std::size_t worst = 0;  // the real particle holding the most energy
      double worst_energy = -1.0;
      for (std::size_t i = 0; i < real_.size(); ++i) {
        const Vec v = velocity_of(i);
        const double e = 0.5 * real_.mass[i] * v.squaredNorm() +
                         real_.volume[i] * material_.strain_energy_density(stress_of(real_, i));
        if (e > worst_energy) worst_energy = e, worst = i;
      }
      throw SolutionDiverged(
          diagnosis(step, dt, real_, worst, "holds the most energy of a runaway: " + runaway));
    }
    previous_energy_ = energy;
  }

  /// "solver: the solution diverged at step n (t = ...): <set> particle <id> at (x, y)
  /// <what>; likely cause: ..." The cause, in order: a time step above the stability
  /// limit (CFL = dt c_p / dx > 1, c_p at the material's reference density, dx from the
  /// virtual particles' initial volumes), a boundary
  /// condition (the particle is on a boundary or within the support 2h of one), else
  /// alpha = h / dx or the kinematics.
  std::string diagnosis(std::int64_t step, double dt, const ParticleSet<Dim>& set, std::size_t i,
                        const std::string& what) const {
    const bool is_real = &set == &real_;
    const Vec x = set.position_of(i);
    std::string where = "(";
    for (int d = 0; d < Dim; ++d) where += (d ? ", " : "") + format_number(x[d]);
    where += ")";
    const double dx = initial_spacing_;
    const double cfl = dt * material_.p_wave_speed(material_.reference_density()) / dx;
    std::string cause;
    if (cfl > 1.0 + 1e-9) {
      cause = "the time step: CFL = dt c_p / dx = " + format_number(cfl) +
              " is above the scheme's stability limit 1; lower cfl";
    } else {
      const int near = nearest_boundary(x, is_real ? real_.boundary[i] : ParticleSet<Dim>::kNoBoundary);
      if (near != ParticleSet<Dim>::kNoBoundary)
        cause = "the boundary condition '" + boundaries_[static_cast<std::size_t>(near)].name +
                "' (the particle is within the support 2h of it): check its kind and values, "
                "and that a traction acts on a free surface";
      else
        cause = "alpha = h / dx = " + format_number(settings_.smoothing_length / dx) + " or the " +
                std::string(to_string(settings_.kinematics)) +
                " kinematics (stable: alpha 0.6 to 1.2, small_strain; README, Known problems)";
    }
    return "solver: the solution diverged at step " + std::to_string(step) + " (t = " +
           format_number(time_ + dt) + " s): " + (is_real ? "real" : "virtual") + " particle " +
           std::to_string(set.carries(set.id) ? set.id[i] : i) + " at " + where + " " + what +
           "; likely cause: " + cause;
  }

  /// The boundary condition a particle is on (`own`), else that of the nearest boundary
  /// particle within the support radius, else kNoBoundary.
  int nearest_boundary(const Vec& x, std::int32_t own) const {
    if (own != ParticleSet<Dim>::kNoBoundary) return own;
    int found = ParticleSet<Dim>::kNoBoundary;
    double best = support_radius() * support_radius();
    for (std::uint32_t b : boundary_particles_) {
      const double d2 = (real_.position_of(b) - x).squaredNorm();
      if (d2 <= best) best = d2, found = real_.boundary[b];
    }
    return found;
  }

  static StressVector<Dim> stress_of(const ParticleSet<Dim>& set, std::size_t i) {
    StressVector<Dim> s;
    for (int c = 0; c < stress_count; ++c) s[c] = set.stress[c][i];
    return s;
  }
  Vec initial_position_of(std::size_t i) const {
    Vec x;
    for (int d = 0; d < Dim; ++d) x[d] = real_.initial_position[d][i];
    return x;
  }
  Vec velocity_of(std::size_t i) const {
    Vec v;
    for (int d = 0; d < Dim; ++d) v[d] = real_.velocity[d][i];
    return v;
  }
  /// The in-plane (Dim x Dim) part of a stress vector as a tensor.
  static Mat in_plane(const StressVector<Dim>& s) {
    return to_tensor<Dim>(s).template topLeftCorner<Dim, Dim>();
  }
  /// Directional derivative (a . grad) of the stress tensor, in-plane part.
  static Mat directional(const StressGradient& gradient, const Vec& a) {
    StressVector<Dim> s;
    for (int m = 0; m < stress_count; ++m) s[m] = gradient[m].dot(a);
    return in_plane(s);
  }

  /// Interpolated state and flux derivatives of one query point over a stencil.
  struct LocalState {
    StressVector<Dim> stress{};
    Vec velocity = Vec::Zero();
    double density = 0.0;
    Mat velocity_gradient = Mat::Zero();  ///< grad v(i, j) = d v_i / d x_j
    Vec stress_divergence = Vec::Zero();  ///< div sigma
  };

  /// Source fields evaluate reads per neighbour: stress components, then velocity, then
  /// density; the first `gradient_field_count` (the in-plane stress components and the
  /// velocity) also enter the gradients.
  static constexpr int velocity_field = stress_count, density_field = stress_count + Dim;
  static constexpr int gathered_count = stress_count + Dim + 1;
  static constexpr int gradient_field_count = stress_count + Dim;
  /// The gradient fields of one row, as loaded by the interpolation pass (padded like
  /// StencilWeights), for the gradient pass.
  struct GatheredSource {
    std::array<PackBuffer, gradient_field_count> field;
  };
  /// Per-thread scratch of the half and full steps.
  struct StepScratch {
    StencilWeights<Dim> weights;
    GatheredSource gathered;
  };

  /// The body of evaluate, compiled once per instruction set (kernels/simd.hpp).
  /// Two passes over the row, kLanes neighbours at a time. The interpolation pass loads
  /// each source field straight into a pack from its array (load_indexed_pack; padding
  /// lanes read the first neighbour again and have zero weights) and keeps the gradient
  /// fields' packs for the gradient pass (before: a scalar gather of every field into
  /// buffers first, 2.5x the instructions; same sums, same order: bitwise the same
  /// results; bench/RESULTS.md, "Per-row overheads").
  [[gnu::always_inline]] static LocalState evaluate_in_packs(const ParticleView<Dim>& source,
                                                              std::span<const std::uint32_t> nb,
                                                              const StencilWeights<Dim>& w,
                                                              GatheredSource& gathered) {
    const std::size_t n = nb.size();
    const std::size_t padded = padded_size(n);
    std::array<const double*, gathered_count> source_field;
    for (int m = 0; m < stress_count; ++m) source_field[m] = source.stress[m];
    for (int d = 0; d < Dim; ++d) source_field[velocity_field + d] = source.velocity[d];
    source_field[density_field] = source.density;
    if (gathered.field[0].size() < padded)  // all grow together, never shrink
      for (auto& buffer : gathered.field) buffer.resize(padded);
    std::array<double*, gradient_field_count> kept;
    for (int m = 0; m < gradient_field_count; ++m) kept[m] = gathered.field[m].data();
    const std::uint32_t* const index = nb.data();
    const double* const value = w.value.data();

    // Interpolation: sum_J V_J Wn_IJ f_J, one partial sum per lane.
    std::array<Pack, gathered_count> sum{};
    for (std::size_t k = 0; k < padded; k += kLanes) {
      std::array<std::uint32_t, kLanes> j;
      if (k + kLanes <= n) {  // a full pack (all but the last of a row)
        for (std::size_t l = 0; l < kLanes; ++l) j[l] = index[k + l];
      } else {
        for (std::size_t l = 0; l < kLanes; ++l) j[l] = k + l < n ? index[k + l] : index[0];
      }
      const Pack c = load_pack(value + k);
      for (int m = 0; m < gathered_count; ++m) {
        const Pack f = load_indexed_pack(source_field[m], j);
        if (m < gradient_field_count) store_pack(kept[m] + k, f);
        sum[m] += c * f;
      }
    }
    const auto interpolated = lane_sums(sum);
    LocalState s;
    for (int m = 0; m < stress_count; ++m) s.stress[m] = interpolated[m];
    for (int d = 0; d < Dim; ++d) s.velocity[d] = interpolated[velocity_field + d];
    s.density = interpolated[density_field];

    // Gradients relative to the interpolated value: sum_J V_J Gn_IJ (f_J - f_I).
    std::array<const double*, Dim> gradient;
    for (int l = 0; l < Dim; ++l) gradient[l] = w.gradient[l].data();
    // Partial sums: velocity gradient (i, l) at i * Dim + l, then the divergence.
    std::array<Pack, Dim * Dim + Dim> derivative{};
    for (std::size_t k = 0; k < padded; k += kLanes) {
      std::array<Pack, Dim> g;
      for (int l = 0; l < Dim; ++l) g[l] = load_pack(gradient[l] + k);
      for (int i = 0; i < Dim; ++i) {
        const Pack dv = load_pack(kept[velocity_field + i] + k) - s.velocity[i];
        for (int l = 0; l < Dim; ++l) derivative[i * Dim + l] += dv * g[l];
      }
      for (int i = 0; i < Dim; ++i)
        for (int l = 0; l < Dim; ++l) {
          const int m = stress_index<Dim>(i, l);
          derivative[Dim * Dim + i] += (load_pack(kept[m] + k) - s.stress[m]) * g[l];
        }
    }
    const auto derivatives = lane_sums(derivative);
    for (int i = 0; i < Dim; ++i) {
      for (int l = 0; l < Dim; ++l) s.velocity_gradient(i, l) = derivatives[i * Dim + l];
      s.stress_divergence[i] = derivatives[Dim * Dim + i];
    }
    return s;
  }
  static LocalState evaluate_sse2(const ParticleView<Dim>& source, std::span<const std::uint32_t> nb,
                                  const StencilWeights<Dim>& w, GatheredSource& gathered) {
    return evaluate_in_packs(source, nb, w, gathered);
  }
  TSPH_TARGET_AVX2 static LocalState evaluate_avx2(const ParticleView<Dim>& source,
                                                    std::span<const std::uint32_t> nb,
                                                    const StencilWeights<Dim>& w,
                                                    GatheredSource& gathered) {
    return evaluate_in_packs(source, nb, w, gathered);
  }

  /// Interpolates U at the query point and takes the corrected gradients of the
  /// velocity and the divergence of the stress, both relative to the interpolated
  /// value at the query point (DESIGN.md section 2). Same instruction set as
  /// compute_stencil (simd_path()).
  static LocalState evaluate(const ParticleView<Dim>& source, std::span<const std::uint32_t> nb,
                             const StencilWeights<Dim>& w, GatheredSource& gathered) {
    if (simd_path() == SimdPath::avx2) return evaluate_avx2(source, nb, w, gathered);
    return evaluate_sse2(source, nb, w, gathered);
  }

  /// Full corrected gradient of every stress component, relative to `centre`.
  static StressGradient stress_gradient(const ParticleView<Dim>& source,
                                        std::span<const std::uint32_t> nb,
                                        const StencilWeights<Dim>& w,
                                        const StressVector<Dim>& centre) {
    StressGradient g;
    for (auto& component : g) component.setZero();
    for (std::size_t k = 0; k < nb.size(); ++k)
      for (int m = 0; m < stress_count; ++m)
        g[m] += (source.stress[m][nb[k]] - centre[m]) * w.gradient_of(k);
    return g;
  }

  /// Per-thread tally of stencil fallbacks.
  struct StencilCounts {
    std::int64_t empty = 0, interpolation = 0, gradient = 0;
    StencilCounts& operator+=(const StencilStatus& status) {
      empty += status.no_neighbors;
      interpolation += status.interpolation_fallback;
      gradient += status.gradient_fallback;
      return *this;
    }
    StencilCounts& operator+=(const StencilCounts& other) {
      empty += other.empty;
      interpolation += other.interpolation;
      gradient += other.gradient;
      return *this;
    }
  };
  void add(const StencilCounts& counts) {
    counters_.empty_stencils += counts.empty;
    counters_.interpolation_fallbacks += counts.interpolation;
    counters_.gradient_fallbacks += counts.gradient;
  }

  /// Seed eq. (3): real -> virtual, U_v^{n+1/2} = U_v^n + dt/2 (S - div F).
  template <class Kernel>
  void half_step(const Kernel& kernel, double dt) {
    const ParticleView<Dim> source = real_.view();
    const ParticleView<Dim> target = virtual_.view();
    const PointsView<Dim> source_points = points_of<Dim>(real_);
    const double h = settings_.smoothing_length;
    const double half_dt = 0.5 * dt;
    const bool objective = objective_rates(), compressible = density_follows();
    // The drift it removes is slow (the 2D cantilever: 1e-5 dx per step), so every
    // kMaterialPointInterval-th step is enough; each costs ~15 % of a 2D step (callgrind).
    const bool to_material_point =
        positions_move() && counters_.steps % kMaterialPointInterval == 0;
    const HalfStepCounts shifts = parallel_for_with_scratch<StepScratch, HalfStepCounts>(
        target.count, [&](std::size_t q, StepScratch& scratch, HalfStepCounts& counts) {
          StencilWeights<Dim>& w = scratch.weights;
          const auto nb = virtual_from_real_.neighbors(q);
          const StencilStatus status =
              compute_stencil<Dim>(kernel, h, target.position_of(q), source_points,
                                   source.volume, nb, settings_.interpolation, w);
          counts += status;
          if (status.no_neighbors) return;  // isolated: keeps its values (counted)
          const LocalState s = evaluate(source, nb, w, scratch.gathered);
          const StressVector<Dim> rate = material_.stress_rate(s.velocity_gradient, s.stress, objective);
          for (int m = 0; m < stress_count; ++m)
            target.stress[m][q] = s.stress[m] + half_dt * rate[m];
          for (int d = 0; d < Dim; ++d)
            target.velocity[d][q] =
                s.velocity[d] + half_dt * (s.stress_divergence[d] / s.density +
                                           settings_.body_force[d] -
                                           settings_.damping * s.velocity[d]);
          const double density =
              compressible ? s.density * exp_of_small(-half_dt * s.velocity_gradient.trace()) : s.density;
          target.density[q] = density;
          target.volume[q] = target.mass[q] / density;
          if (to_material_point && !status.gradient_fallback)
            counts.largest_shift = std::max(counts.largest_shift, place_at_material_point(q, nb, w));
        });
    add(shifts);
    virtual_path_bound_ += shifts.largest_shift;  // the lists' skin check (lists_outdated)
  }

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

  /// Puts virtual particle q back at the material point X_q it stands for, read from its
  /// half-step stencil w over the real row nb: with the interpolated initial coordinates
  /// Xbar = sum_J w_J X_J, the interpolated positions xbar = sum_J w_J x_J and the
  /// corrected gradient G = sum_J (X_J - Xbar) (x) grad w_J = dX/dx, it moves to
  /// x_q = xbar + G^{-1} (X_q - Xbar) (exact for every affine motion, rigid ones
  /// included). Moved by their half-step velocity alone the virtual particles drift from
  /// their cells once the body is at rest (v^{n+1/2} carries dt/2 div sigma / rho of the
  /// real stresses). Returns the distance moved (0 where G is singular: the particle stays).
  double place_at_material_point(std::size_t q, std::span<const std::uint32_t> nb, const StencilWeights<Dim>& w) {
    const bool virtual_displacement = virtual_.carries(virtual_.displacement);
    Vec reference_mean = Vec::Zero(), position_mean = Vec::Zero();
    for (std::size_t k = 0; k < nb.size(); ++k) {
      const std::uint32_t j = nb[k];
      for (int d = 0; d < Dim; ++d) {
        reference_mean[d] += w.value[k] * real_.initial_position[d][j];
        position_mean[d] += w.value[k] * real_.position[d][j];
      }
    }
    Mat reference_gradient = Mat::Zero();  // dX/dx
    for (std::size_t k = 0; k < nb.size(); ++k) {
      const std::uint32_t j = nb[k];
      for (int a = 0; a < Dim; ++a) {
        const double dX = real_.initial_position[a][j] - reference_mean[a];
        for (int b = 0; b < Dim; ++b) reference_gradient(a, b) += dX * w.gradient[b][k];
      }
    }
    const double determinant = reference_gradient.determinant();
    if (!(std::abs(determinant) > 1e-6)) return 0.0;
    Vec material;
    for (int d = 0; d < Dim; ++d) material[d] = virtual_.initial_position[d][q] - reference_mean[d];
    const Vec placed = position_mean + reference_gradient.inverse() * material;
    double moved = 0.0;
    for (int d = 0; d < Dim; ++d) {
      moved += (placed[d] - virtual_.position[d][q]) * (placed[d] - virtual_.position[d][q]);
      virtual_.position[d][q] = placed[d];
      if (virtual_displacement) virtual_.displacement[d][q] = placed[d] - virtual_.initial_position[d][q];
    }
    return std::sqrt(moved);
  }

  /// Seed eq. (4): virtual -> real, U_r^{n+1} = U_r^n + dt (S^{n+1/2} - div F^{n+1/2}).
  template <class Kernel>
  void full_step(const Kernel& kernel, double dt) {
    const ParticleView<Dim> source = virtual_.view();
    const ParticleView<Dim> target = real_.view();
    const PointsView<Dim> source_points = points_of<Dim>(virtual_);
    const PointsView<Dim> target_points = points_of<Dim>(real_);
    const double h = settings_.smoothing_length;
    const bool objective = objective_rates(), compressible = density_follows();
    const bool store_previous_velocity = settings_.conservative_momentum;
    if (lists_used_once()) {  // the half step's list is done with: one list at a time
      real_from_virtual_ = NeighborList{};
      if (settings_.transpose_lists) {
        real_from_virtual_ = transpose(virtual_from_real_, real_.size());
        virtual_from_real_ = NeighborList{};
      } else {
        virtual_from_real_ = NeighborList{};
        real_from_virtual_ = NeighborSearcher<Dim>(settings_.neighbor_search, source_points, support_radius())
                                 .query(points_of<Dim>(real_));
      }
    }
    add(parallel_for_with_scratch<StepScratch, StencilCounts>(
        target.count, [&](std::size_t r, StepScratch& scratch, StencilCounts& counts) {
          StencilWeights<Dim>& w = scratch.weights;
          if (store_previous_velocity)
            for (int d = 0; d < Dim; ++d) previous_velocity_[d][r] = target.velocity[d][r];
          const auto nb = real_from_virtual_.neighbors(r);
          const StencilStatus status =
              compute_stencil<Dim>(kernel, h, target.position_of(r), source_points,
                                   source.volume, nb, settings_.interpolation, w);
          counts += status;
          if (status.no_neighbors) {
            if (const std::int32_t b = boundary_slot_[r]; b >= 0) {  // no stale gradients
              boundary_half_velocity_gradient_[static_cast<std::size_t>(b)].setZero();
              boundary_half_velocity_[static_cast<std::size_t>(b)].setZero();
              boundary_gradient_sum_[static_cast<std::size_t>(b)].setZero();
              for (auto& g : boundary_half_stress_gradient_[static_cast<std::size_t>(b)]) g.setZero();
            }
            return;
          }
          const LocalState s = evaluate(source, nb, w, scratch.gathered);
          if (const std::int32_t b = boundary_slot_[r]; b >= 0) {
            // Tangential derivatives at n+1/2 for the boundary conditions.
            boundary_half_velocity_gradient_[static_cast<std::size_t>(b)] = s.velocity_gradient;
            boundary_half_velocity_[static_cast<std::size_t>(b)] = s.velocity;
            Vec gradient_sum = Vec::Zero();  // sum_J V_J Gn_IJ: the gradient of a jump at I
            Vec centroid = Vec::Zero();  // of the virtual stencil (surface_extrapolation)
            std::size_t in_support = 0;  // a row with a skin also holds pairs beyond 2h
            for (std::size_t k = 0; k < nb.size(); ++k) {
              gradient_sum += w.gradient_of(k);
              if (!within_support(target_points, r, source_points, nb[k])) continue;
              centroid += virtual_.position_of(nb[k]);
              ++in_support;
            }
            boundary_gradient_sum_[static_cast<std::size_t>(b)] = gradient_sum;
            boundary_stencil_offset_[static_cast<std::size_t>(b)] =
                target.position_of(r) - centroid / static_cast<double>(in_support);
            boundary_half_stress_gradient_[static_cast<std::size_t>(b)] =
                stress_gradient(source, nb, w, s.stress);
          }
          const StressVector<Dim> rate = material_.stress_rate(s.velocity_gradient, s.stress, objective);
          for (int m = 0; m < stress_count; ++m) target.stress[m][r] += dt * rate[m];
          for (int d = 0; d < Dim; ++d)
            target.velocity[d][r] +=
                dt * (s.stress_divergence[d] / s.density + settings_.body_force[d] -
                      settings_.damping * s.velocity[d]);
          if (compressible) {
            target.density[r] *= exp_of_small(-dt * s.velocity_gradient.trace());
            target.volume[r] = target.mass[r] / target.density[r];
          }
        }));
  }

  /// Step 0: U^n and its gradients at the boundary particles, from the real set.
  template <class Kernel>
  void boundary_gradients(const Kernel& kernel) {
    const ParticleView<Dim> source = real_.view();
    const PointsView<Dim> source_points = points_of<Dim>(real_);
    StencilWeights<Dim> w;
    StencilCounts counts;
    for (std::size_t b = 0; b < boundary_particles_.size(); ++b) {
      const std::uint32_t i = boundary_particles_[b];
      const auto nb = real_from_real_.neighbors(i);
      counts += compute_stencil<Dim>(kernel, settings_.smoothing_length, real_.position_of(i),
                                     source_points, source.volume, nb,
                                     InterpolationKind::shepard, w);
      Mat grad_v = Mat::Zero();
      for (std::size_t k = 0; k < nb.size(); ++k)
        for (int d = 0; d < Dim; ++d)
          grad_v.row(d) += (source.velocity[d][nb[k]] - source.velocity[d][i]) *
                           w.gradient_of(k).transpose();
      boundary_stress_[b] = stress_of(real_, i);
      boundary_velocity_[b] = velocity_of(i);
      boundary_density_[b] = real_.density[i];
      boundary_velocity_gradient_[b] = grad_v;
      boundary_stress_gradient_[b] = stress_gradient(source, nb, w, boundary_stress_[b]);
    }
    counts.interpolation = 0;  // the Shepard weights are not used here
    add(counts);
  }

  /// Step 3: characteristic boundary conditions at t_new (see the file comment).
  void apply_boundary_conditions(double dt, double t_new) {
    const double lame = material_.model_lame();
    const double shear = material_.shear_modulus();
    const double modulus = material_.p_wave_modulus();
    for (std::size_t b = 0; b < boundary_particles_.size(); ++b) {
      const std::uint32_t i = boundary_particles_[b];
      const auto& condition = boundaries_[static_cast<std::size_t>(real_.boundary[i])];
      if (!boundary_on_surface_[b]) {  // a velocity held inside the body: imposed directly
        const Vec v = condition.prescribed(initial_position_of(i), boundary_profile_[b], t_new);
        for (int d = 0; d < Dim; ++d) real_.velocity[d][i] = v[d];
        continue;
      }
      if (settings_.velocity_wall == SolverSettings<Dim>::VelocityWall::wall_gradient &&
          condition.kind == BoundaryCondition<Dim>::Kind::velocity) {
        apply_wall_gradient(b, i, condition, dt, t_new);
        continue;
      }
      const Vec& n = boundary_normal_[b];
      const Mat frame = normal_frame<Dim>(n);
      const double density = boundary_density_[b];
      const double c_p = std::sqrt(modulus / density);
      const double c_s = std::sqrt(shear / density);
      const double z_p = density * c_p;
      const double z_s = density * c_s;

      // State at n and its normal derivatives (real set), in the frame.
      const Mat stress0 = frame.transpose() * in_plane(boundary_stress_[b]) * frame;
      const Vec velocity0 = frame.transpose() * boundary_velocity_[b];
      const Mat stress_dn = frame.transpose() * directional(boundary_stress_gradient_[b], n) * frame;
      const Vec velocity_dn = frame.transpose() * (boundary_velocity_gradient_[b] * n);
      // Tangential derivatives at n+1/2 (virtual set): column k of velocity_dt is
      // d v' / d t_k, stress_dt[k] is d sigma' / d t_k.
      // Tangential derivatives at n+1/2 from the virtual set (second order in time; the
      // real set's gradients at time n would make this forward Euler, which is
      // unstable). Where the virtual stencil spans fewer than Dim directions (a corner
      // with one virtual neighbour at alpha 0.6) the missing direction is read as zero.
      Mat velocity_dt = Mat::Zero();
      std::array<Mat, Dim> stress_dt{};
      for (int k = 1; k < Dim; ++k) {
        const Vec t = frame.col(k);
        velocity_dt.col(k) = frame.transpose() * (boundary_half_velocity_gradient_[b] * t);
        stress_dt[k] = frame.transpose() * directional(boundary_half_stress_gradient_[b], t) * frame;
      }
      if (settings_.surface_extrapolation) extrapolate_to_surface(b, i, frame, t_new, velocity_dt);
      // Effective body force, with the damping, at time n.
      const Vec force = frame.transpose() * (settings_.body_force - settings_.damping * boundary_velocity_[b]);

      // Updated Lagrangian: the Jaumann terms (W sigma - sigma W) of the normal stress
      // components t_n, t_k (the frame is held fixed over the step), with the spin W from
      // the velocity gradient in the frame: tangential columns from the virtual set at
      // n+1/2, the normal column from the real set at n.
      Mat jaumann = Mat::Zero();
      if (objective_rates()) {
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
      const double p_invariant = stress0(0, 0) - z_p * velocity0[0] -
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
          frame.transpose() * condition.prescribed(initial_position_of(i), boundary_profile_[b], t_new);
      Mat stress1 = stress0;
      Vec velocity1;
      const bool velocity_given = condition.kind == BoundaryCondition<Dim>::Kind::velocity;
      for (int k = 0; k < Dim; ++k) {
        const double invariant = k == 0 ? p_invariant : s_invariant[k];
        const double impedance = k == 0 ? z_p : z_s;
        if (velocity_given) {
          velocity1[k] = prescribed[k];
          stress1(0, k) = invariant + impedance * prescribed[k];
        } else {
          stress1(0, k) = prescribed[k];
          velocity1[k] = impedance > 0.0 ? (prescribed[k] - invariant) / impedance : 0.0;
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
      const Mat rotation_rate = objective_rates()
                                    ? Mat(objective_rotation_rate<Dim>(spin, stress0, dt))
                                    : Mat(Mat::Zero());
      const double volumetric = gradient.trace();
      for (int k = 1; k < Dim; ++k)
        for (int l = 1; l < Dim; ++l)
          stress1(k, l) = stress0(k, l) +
                          dt * ((k == l ? lame * volumetric : 0.0) +
                                shear * (gradient(k, l) + gradient(l, k)) + rotation_rate(k, l));

      // Density from the same velocity gradient (the full step's one-sided estimate is
      // replaced, like the rest of the boundary state).
      if (density_follows()) {
        real_.density[i] = boundary_density_[b] * std::exp(-dt * volumetric);
        real_.volume[i] = real_.mass[i] / real_.density[i];
      }

      // Back to the global frame.
      Mat stress_global = frame * stress1 * frame.transpose();
      if (settings_.free_edge_uniaxial && !velocity_given && prescribed.squaredNorm() == 0.0)
        make_free_edge_uniaxial(b, i, n, frame, velocity_dt, dt, stress_global);
      const Vec velocity_global = frame * velocity1;
      for (int d = 0; d < Dim; ++d) real_.velocity[d][i] = velocity_global[d];
      for (int r = 0; r < Dim; ++r)
        for (int c = r; c < Dim; ++c) real_.stress[stress_index<Dim>(r, c)][i] = stress_global(r, c);
      if constexpr (Dim == 2) {  // sigma_zz: plane strain follows lambda tr d; plane stress 0
        const auto zz = 3;
        real_.stress[zz][i] = material_.plane_mode() == PlaneMode::plane_stress
                                  ? 0.0
                                  : boundary_stress_[b][zz] + dt * lame * volumetric;
      }
    }
  }

  /// SolverSettings::free_edge_uniaxial: the axis along which real particle i lies on a
  /// convex edge, or -1. Decided on the initial positions of its neighbours within the
  /// support: on exactly two axes a, b every neighbour lies on one side of i
  /// (s_a (x0_j - x0_i)_a <= 0, the same sign s_a for all; likewise b), which makes i
  /// extreme in two directions: the edge of a box whose faces are coordinate planes.
  /// A face particle is extreme on one axis, a corner on three, a particle on an oblique
  /// or curved surface, or on a re-entrant edge, on one or none.
  int free_edge_axis(std::uint32_t i) const {
    const PointsView<Dim> real_points = points_of<Dim>(real_);
    const Vec x0 = initial_position_of(i);
    const double tol = 1e-6 * initial_spacing_;
    std::array<bool, Dim> below{}, above{};  // some neighbour below / above i along d
    for (std::uint32_t j : real_from_real_.neighbors(i)) {
      if (!within_support(real_points, i, real_points, j)) continue;
      const Vec offset = initial_position_of(j) - x0;
      for (int d = 0; d < Dim; ++d) {
        below[d] = below[d] || offset[d] < -tol;
        above[d] = above[d] || offset[d] > tol;
      }
    }
    int extreme = 0, along = -1;
    for (int d = 0; d < Dim; ++d) {
      if (below[d] && above[d]) along = d;
      else if (below[d] != above[d]) ++extreme;
      else return -1;  // no neighbour along d at all: not an edge of a solid
    }
    return extreme == 2 ? along : -1;
  }

  /// The edge axis of free_edge_axis where the particle's normal n lies between the two
  /// faces, else -1. Both faces under the particle's condition: its normal is then the
  /// kernel normal, between the faces (face_normal), with no component along the edge.
  /// An edge between two conditions takes one face's normal: left as it is.
  int uniaxial_edge_axis(std::uint32_t i, const Vec& n) const {
    if constexpr (Dim == 3) {
      const int along = free_edge_axis(i);
      if (along < 0 || std::abs(n[along]) > 0.3 || std::abs(n[(along + 1) % 3]) < 0.3 ||
          std::abs(n[(along + 2) % 3]) < 0.3)
        return -1;
      return along;
    } else {
      (void)i, (void)n;
      return -1;
    }
  }

  /// SolverSettings::free_edge_uniaxial: on a convex edge between two zero-traction
  /// faces of one condition (free_edge_axis, and the normal between the faces) both
  /// tractions vanish, so the stress is uniaxial along the
  /// edge direction e, sigma = s e (x) e, with ds/dt = E e . grad v . e (the derivative
  /// along the edge, which the virtual stencil along the edge has). Without it only the
  /// traction on the kernel's diagonal normal vanishes and the edge keeps
  /// sigma_xy = -sigma_xz growing with mu d_x v_t (README, The cantilever). e is the
  /// current direction of the edge (the neighbours initially on the edge line; the
  /// coordinate axis itself in small strain), so that it turns with the body.
  void make_free_edge_uniaxial(std::size_t b, std::uint32_t i, const Vec& n, const Mat& frame,
                               const Mat& velocity_dt, double dt, Mat& stress_global) const {
    if constexpr (Dim == 3) {
      const int along = uniaxial_edge_axis(i, n);
      if (along < 0) return;
      const PointsView<Dim> real_points = points_of<Dim>(real_);
      const Vec x0 = initial_position_of(i);
      const double tol = 1e-6 * initial_spacing_;
      Vec chord = Vec::Zero();  // sum over the edge neighbours of sign (x_j - x_i)
      for (std::uint32_t j : real_from_real_.neighbors(i)) {
        if (!within_support(real_points, i, real_points, j)) continue;
        const Vec offset = initial_position_of(j) - x0;
        if (std::abs(offset[(along + 1) % 3]) > tol || std::abs(offset[(along + 2) % 3]) > tol) continue;
        chord += (offset[along] > 0.0 ? 1.0 : -1.0) * (real_.position_of(j) - real_.position_of(i));
      }
      if (!(chord.norm() > 0.0)) return;
      const Vec e = chord.normalized();
      // Next to a corner the kernel normal leans towards the end face (n . e up to 0.17
      // at the cantilever's first and last edge particles); velocity_dt has no normal
      // column, so the rate is that of e's tangential part (taking the tangential part as
      // the edge direction instead gave 0.020 m for 0.050 m at 41 x 5 x 5).
      const Vec e_frame = frame.transpose() * e;
      const double rate = e_frame.dot(velocity_dt * e_frame);
      const double previous = e.dot(in_plane(boundary_stress_[b]) * e);
      stress_global = (previous + dt * material_.young_modulus() * rate) * e * e.transpose();
    } else {
      (void)b, (void)i, (void)n, (void)frame, (void)velocity_dt, (void)dt, (void)stress_global;
    }
  }

  /// SolverSettings::surface_extrapolation: velocity_dt(l, k) = d v'_l / d t_k, l, k
  /// tangential, moved from the virtual stencil's centroid to the particle,
  ///   += -delta H_kl,  H_kl = d_k d_l v_n  (least squares over the neighbouring surface
  /// particles with the same normal: sum_j (g_j - g_i)_k dx_m = H_km sum_j dx_k dx_m,
  /// g = tangential gradient of v_n at n+1/2). No neighbour: no correction.
  void extrapolate_to_surface(std::size_t b, std::uint32_t i, const Mat& frame, double t_new,
                              Mat& velocity_dt) const {
    const Vec& n = boundary_normal_[b];
    const double delta = n.dot(boundary_stencil_offset_[b]);
    if (!(delta > 0.0)) return;
    // Zero traction at I and at every neighbour used (a loaded face, where
    // d_t sigma_nl need not vanish, is left as it is).
    auto unloaded = [&](std::size_t slot, std::uint32_t particle) {
      const auto& c = boundaries_[static_cast<std::size_t>(real_.boundary[particle])];
      return c.kind == BoundaryCondition<Dim>::Kind::traction &&
             c.prescribed(initial_position_of(particle), boundary_profile_[slot], t_new).squaredNorm() == 0.0;
    };
    if (!unloaded(b, i)) return;
    auto g_of = [&](std::size_t slot) {  // grad_t v_n at n+1/2, in the frame
      return Vec(frame.transpose() * (boundary_half_velocity_gradient_[slot].transpose() * n));
    };
    const Vec gi = g_of(b);
    Mat moments = Mat::Zero(), differences = Mat::Zero();
    const PointsView<Dim> real_points = points_of<Dim>(real_);
    for (std::uint32_t j : real_from_real_.neighbors(i)) {
      if (!within_support(real_points, i, real_points, j)) continue;  // skin pairs
      const std::int32_t bj = boundary_slot_[j];
      if (bj < 0 || !boundary_on_surface_[static_cast<std::size_t>(bj)] ||
          boundary_normal_[static_cast<std::size_t>(bj)].dot(n) < 0.999)
        continue;
      if (!unloaded(static_cast<std::size_t>(bj), j)) continue;
      const Vec gj = g_of(static_cast<std::size_t>(bj));
      const Vec dx = frame.transpose() * (real_.position_of(j) - real_.position_of(i));
      for (int k = 1; k < Dim; ++k)
        for (int m = 1; m < Dim; ++m) {
          differences(k, m) += (gj[k] - gi[k]) * dx[m];
          moments(k, m) += dx[k] * dx[m];
        }
    }
    if constexpr (Dim == 2) {
      if (moments(1, 1) > 0.0) {
        velocity_dt(1, 1) -= delta * differences(1, 1) / moments(1, 1);
      }
    } else if constexpr (Dim == 3) {
      const Eigen::Matrix2d a = moments.template block<2, 2>(1, 1);
      if (std::abs(a.determinant()) <= 1e-12 * a.squaredNorm()) return;  // an edge: skip
      const Eigen::Matrix2d hessian = differences.template block<2, 2>(1, 1) * a.inverse();
      const Eigen::Matrix2d symmetric = 0.5 * (hessian + hessian.transpose());
      velocity_dt.template block<2, 2>(1, 1) -= delta * symmetric;
    }
  }

  /// SolverSettings::VelocityWall::wall_gradient at a prescribed-velocity particle:
  /// sigma^{n+1} = sigma^n + dt D : grad v^{n+1/2} (seed eq. 4), with the gradient of the
  /// virtual half-step velocity relative to the prescribed v^{n+1/2} at the particle,
  ///     sum_J V_J (v_J - v_wall) Gn_IJ = grad v + (v(x_I) - v_wall) (x) sum_J V_J Gn_IJ,
  /// and v^{n+1} prescribed.
  void apply_wall_gradient(std::size_t b, std::uint32_t i, const BoundaryCondition<Dim>& condition,
                           double dt, double t_new) {
    const Vec wall_half = condition.prescribed(initial_position_of(i), boundary_profile_[b], t_new - 0.5 * dt);
    const Mat gradient = boundary_half_velocity_gradient_[b] +
                         (boundary_half_velocity_[b] - wall_half) * boundary_gradient_sum_[b].transpose();
    const StressVector<Dim> rate = material_.stress_rate(gradient, boundary_stress_[b], objective_rates());
    for (int m = 0; m < stress_count; ++m) real_.stress[m][i] = boundary_stress_[b][m] + dt * rate[m];
    const Vec v = condition.prescribed(initial_position_of(i), boundary_profile_[b], t_new);
    for (int d = 0; d < Dim; ++d) real_.velocity[d][i] = v[d];
    if (density_follows()) {
      real_.density[i] = boundary_density_[b] * std::exp(-dt * gradient.trace());
      real_.volume[i] = real_.mass[i] / real_.density[i];
    }
  }

  /// Conservative momentum (SolverSettings::conservative_momentum), part 1, right after
  /// the half step: the weights D_vJ = G_vJ - Wn_vJ sum_K G_vK of the half step's
  /// corrected gradient (grad f)_v = sum_J D_vJ f_J (configuration n), per pair of
  /// virtual_from_real_, and the transposed pair list (rows: real particles, entries:
  /// pair indices in increasing virtual order, so the sums are deterministic).
  template <class Kernel>
  void store_momentum_weights(const Kernel& kernel) {
    const PointsView<Dim> source_points = points_of<Dim>(real_);
    const ParticleView<Dim> target = virtual_.view();
    momentum_weight_.resize(virtual_from_real_.pair_count());
    parallel_for_with_scratch<StencilWeights<Dim>, StencilCounts>(
        target.count, [&](std::size_t q, StencilWeights<Dim>& w, StencilCounts&) {
          const auto nb = virtual_from_real_.neighbors(q);
          const std::size_t first = virtual_from_real_.row_begin(q);
          const StencilStatus status =
              compute_stencil<Dim>(kernel, settings_.smoothing_length, target.position_of(q),
                                   source_points, real_.volume.data(), nb,
                                   settings_.interpolation, w);
          Vec sum = Vec::Zero();
          for (std::size_t k = 0; k < nb.size(); ++k) sum += w.gradient_of(k);
          for (std::size_t k = 0; k < nb.size(); ++k)
            momentum_weight_[first + k] =
                status.no_neighbors ? Vec(Vec::Zero()) : Vec(w.gradient_of(k) - w.value[k] * sum);
        });
    momentum_pair_offsets_.assign(real_.size() + 1, 0);
    for (std::uint32_t j : virtual_from_real_.indices) ++momentum_pair_offsets_[j + 1];
    for (std::size_t i = 0; i < real_.size(); ++i)
      momentum_pair_offsets_[i + 1] += momentum_pair_offsets_[i];
    momentum_pair_.resize(virtual_from_real_.pair_count());
    momentum_pair_virtual_.resize(virtual_from_real_.pair_count());
    std::vector<std::uint64_t> fill(momentum_pair_offsets_.begin(), momentum_pair_offsets_.end() - 1);
    for (std::size_t q = 0; q < virtual_.size(); ++q)
      for (std::uint64_t p = virtual_from_real_.row_begin(q); p < virtual_from_real_.row_begin(q + 1); ++p) {
        const std::uint64_t slot = fill[virtual_from_real_.indices[p]]++;
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
  void apply_conservative_momentum(double dt, double t_new) {
    const ParticleView<Dim> source = virtual_.view();
    parallel_for(real_.size(), [&](std::size_t i) {
      if (const std::int32_t b = boundary_slot_[i]; b >= 0) {
        const auto& condition = boundaries_[static_cast<std::size_t>(real_.boundary[i])];
        if (condition.kind == BoundaryCondition<Dim>::Kind::velocity) return;
        const Vec traction =
            condition.prescribed(initial_position_of(i), boundary_profile_[static_cast<std::size_t>(b)], t_new);
        if (traction.squaredNorm() > 0.0) return;  // a loaded surface keeps its characteristics
      }
      Vec force = Vec::Zero();
      for (std::uint64_t slot = momentum_pair_offsets_[i]; slot < momentum_pair_offsets_[i + 1]; ++slot) {
        const std::uint32_t q = momentum_pair_virtual_[slot];
        const Vec& weight = momentum_weight_[momentum_pair_[slot]];
        for (int a = 0; a < Dim; ++a)
          for (int l = 0; l < Dim; ++l)
            force[a] -= source.volume[q] * source.stress[stress_index<Dim>(a, l)][q] * weight[l];
      }
      for (int d = 0; d < Dim; ++d)
        real_.velocity[d][i] = previous_velocity_[d][i] +
                               dt * (force[d] / real_.mass[i] + settings_.body_force[d] -
                                     settings_.damping * previous_velocity_[d][i]);
    });
  }

  /// One linear least-squares fit u(X) ~ a + B (X - X_0) over a stencil (see
  /// apply_hourglass_stiffness): the value a = sum_J c^T p_J (w_J / w) u_J, with
  /// p_J = (1, X_J - X_0), w = sum_J w_J and c the first column of the inverse of the
  /// normalised moment matrix sum_J (w_J / w) p_J p_J^T. weight_sum = 0: no fit.
  struct LinearFitWeights {
    Eigen::Matrix<double, Dim + 1, 1> first_column = Eigen::Matrix<double, Dim + 1, 1>::Zero();
    double weight_sum = 0.0;
  };

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
  /// v^{n+1} += dt F(u^n + dt/2 v^n) / m, with the trapezoidal displacement update an
  /// area-preserving pair, stable for k dt^2 / rho < 4. Particles with a prescribed
  /// velocity receive no force (their reaction is the constraint's).
  template <class Kernel>
  void apply_hourglass_stiffness(const Kernel& kernel, double dt) {
    if (hourglass_list_build_ != counters_.neighbor_builds) build_hourglass_lists();
    const double h = settings_.smoothing_length;
    const double return_h = 0.5 * hourglass_radius_;  // kernel support = the list radius
    const double stiffness = settings_.hourglass_stiffness * material_.p_wave_modulus() / (h * h);
    using Basis = Eigen::Matrix<double, Dim + 1, 1>;
    using Moments = Eigen::Matrix<double, Dim + 1, Dim + 1>;
    auto offset = [&](std::uint32_t r, std::uint32_t v) {  // X_r - X_v, initial coordinates
      Vec dx;
      for (int d = 0; d < Dim; ++d)
        dx[d] = real_.initial_position[d][r] - virtual_.initial_position[d][v];
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
    auto displacement = [&](std::uint32_t j) {  // u^n + dt/2 v^n (begin_displacement)
      Vec u;
      for (int d = 0; d < Dim; ++d) u[d] = real_.displacement[d][j];
      return u;
    };
    // The half-step lists with a skin also hold pairs beyond 2h at the current positions
    // (within_support): the fit and the force skip them (their weights come from the
    // initial coordinates, so they would not vanish).
    const PointsView<Dim> real_points = points_of<Dim>(real_), virtual_points = points_of<Dim>(virtual_);
    const auto every = [](std::uint32_t) { return true; };
    const std::size_t real_count = real_.size(), virtual_count = virtual_.size();
    forward_fit_.resize(virtual_count);
    return_fit_.resize(real_count);
    virtual_value_.resize(virtual_count);
    round_trip_residual_.resize(real_count);
    // A: virtual values a_v = sum_J A_vJ u_J.
    parallel_for(virtual_count, [&](std::size_t v) {
      const auto nb = virtual_from_real_.neighbors(v);
      const auto vi = static_cast<std::uint32_t>(v);
      const auto in_support = [&](std::uint32_t j) { return within_support(virtual_points, v, real_points, j); };
      forward_fit_[v] = fit(nb, [&](std::uint32_t j) { return offset(j, vi); }, h, in_support);
      Vec value = Vec::Zero();
      if (forward_fit_[v].weight_sum > 0.0)
        for (std::uint32_t j : nb)
          if (in_support(j)) value += coefficient(forward_fit_[v], offset(j, vi), h) * displacement(j);
      virtual_value_[v] = value;
    });
    // R: r_I = u_I - sum_v R_Iv a_v, weighted by V_I.
    parallel_for(real_count, [&](std::size_t i) {
      const auto nb = hourglass_from_virtual_.neighbors(i);
      const auto ri = static_cast<std::uint32_t>(i);
      return_fit_[i] = fit(nb, [&](std::uint32_t v) { return Vec(-offset(ri, v)); }, return_h, every);
      Vec residual = Vec::Zero();
      if (return_fit_[i].weight_sum > 0.0) {
        residual = displacement(ri);
        for (std::uint32_t v : nb)
          residual -= coefficient(return_fit_[i], Vec(-offset(ri, v)), return_h) * virtual_value_[v];
      }
      round_trip_residual_[i] = (real_.mass[i] / real_.density[i]) * residual;
    });
    // s_v = sum_I R_Iv V_I r_I (the transposed return trip; reuses virtual_value_).
    parallel_for(virtual_count, [&](std::size_t v) {
      Vec sum = Vec::Zero();
      for (std::uint32_t i : hourglass_to_real_.neighbors(v))
        if (return_fit_[i].weight_sum > 0.0)
          sum += coefficient(return_fit_[i], Vec(-offset(i, static_cast<std::uint32_t>(v))), return_h) *
                 round_trip_residual_[i];
      virtual_value_[v] = sum;
    });
    // F_J = -k (V_J r_J - sum_v A_vJ s_v).
    parallel_for(real_count, [&](std::size_t j) {
      if (const std::int32_t b = boundary_slot_[j]; b >= 0) {
        const auto& condition = boundaries_[static_cast<std::size_t>(real_.boundary[j])];
        if (condition.kind == BoundaryCondition<Dim>::Kind::velocity) return;
      }
      const auto rj = static_cast<std::uint32_t>(j);
      Vec force = round_trip_residual_[j];
      for (std::uint32_t v : real_from_virtual_.neighbors(j))
        if (forward_fit_[v].weight_sum > 0.0 && within_support(real_points, j, virtual_points, v))
          force -= coefficient(forward_fit_[v], offset(rj, v), h) * virtual_value_[v];
      for (int d = 0; d < Dim; ++d) real_.velocity[d][j] -= dt * stiffness * force[d] / real_.mass[j];
    });
  }

  /// The real -> virtual lists of the hourglass stiffness's return trip (and the
  /// transpose), in the initial coordinates: radius max(2h, 1.75 dx) (dx from the mean virtual volume), so that every
  /// real particle, corners included, sees Dim + 1 virtual particles off a line.
  void build_hourglass_lists() {
    double mean_volume = 0.0;
    for (std::size_t v = 0; v < virtual_.size(); ++v) mean_volume += virtual_.mass[v] / virtual_.density[v];
    mean_volume /= static_cast<double>(virtual_.size());
    const double spacing = std::pow(mean_volume, 1.0 / Dim);
    hourglass_radius_ = std::max(support_radius(), 1.75 * spacing);
    const PointsView<Dim> real_points = initial_points_of<Dim>(real_), virtual_points = initial_points_of<Dim>(virtual_);
    hourglass_from_virtual_ = CellList<Dim>(virtual_points, hourglass_radius_).query(real_points);
    hourglass_to_real_ = CellList<Dim>(real_points, hourglass_radius_).query(virtual_points);
    hourglass_list_build_ = counters_.neighbor_builds;
  }

  /// Step 4: hourglass control at free and loaded surfaces (see
  /// SolverSettings::hourglass_coefficient).
  template <class Kernel>
  void filter_hourglass(const Kernel& kernel) {
    const ParticleView<Dim> set = real_.view();
    const PointsView<Dim> points = points_of<Dim>(real_);
    const double epsilon = settings_.hourglass_coefficient;
    const std::size_t count = boundary_particles_.size();
    add(parallel_for_with_scratch<StencilWeights<Dim>, StencilCounts>(
        count, [&](std::size_t b, StencilWeights<Dim>& w, StencilCounts& counts) {
          const std::uint32_t i = boundary_particles_[b];
          const auto& condition = boundaries_[static_cast<std::size_t>(real_.boundary[i])];
          filtered_velocity_[b] = velocity_of(i);
          if (condition.kind != BoundaryCondition<Dim>::Kind::traction || !boundary_on_surface_[b])
            return;  // prescribed velocities are not filtered
          const auto nb = real_from_real_.neighbors(i);
          const StencilStatus status =
              compute_stencil<Dim>(kernel, settings_.smoothing_length, set.position_of(i), points,
                                   set.volume, nb, InterpolationKind::linear, w);
          counts += status;
          if (status.no_neighbors) return;
          Vec average = Vec::Zero();
          for (std::size_t k = 0; k < nb.size(); ++k)
            for (int d = 0; d < Dim; ++d) average[d] += w.value[k] * set.velocity[d][nb[k]];
          filtered_velocity_[b] = (1.0 - epsilon) * velocity_of(i) + epsilon * average;
        }));
    for (std::size_t b = 0; b < count; ++b)
      for (int d = 0; d < Dim; ++d) real_.velocity[d][boundary_particles_[b]] = filtered_velocity_[b][d];
  }

  /// Step 1b (updated Lagrangian): both sets to the midpoint configuration x^{n+1/2},
  /// where the full step takes the velocity gradient L^{n+1/2} (midpoint rule,
  /// L^{n+1/2} dt = d(x^{n+1} - x^n) / d x^{n+1/2}): virtual particles by dt/2 v^{n+1/2}
  /// (half their straight path), real ones by dt/2 v^n (a predictor; their position
  /// enters the full step's kernel weights only, not its linear exactness). Taken at
  /// x^n instead, the gradient of v^{n+1/2} misses the half step's own motion: in a
  /// rigid rotation whose stress carries the centripetal acceleration, v^{n+1/2} =
  /// (omega J - dt/2 omega^2) (x^n - c) has divergence -omega^2 dt, a spurious
  /// compression that grew the pressure linearly in time (README, objectivity). In the
  /// midpoint configuration its gradient is skew to O(dt^2). A non-finite velocity
  /// leaves its particle where it is (check_stability reports it). The real set's pass
  /// also makes begin_displacement's update (the same increment dt/2 v^n).
  void move_to_midpoint(double dt) {
    const double half_dt = 0.5 * dt;
    parallel_for(real_.size(), [&](std::size_t i) {
      for (int d = 0; d < Dim; ++d)
        if (std::isfinite(real_.velocity[d][i])) {
          real_.position[d][i] += half_dt * real_.velocity[d][i];
          real_.displacement[d][i] += half_dt * real_.velocity[d][i];
        }
    });
    parallel_for(virtual_.size(), [&](std::size_t i) {
      for (int d = 0; d < Dim; ++d)
        if (std::isfinite(virtual_.velocity[d][i]))
          virtual_.position[d][i] += half_dt * virtual_.velocity[d][i];
    });
  }

  /// Step 1b in small strain (updated Lagrangian: move_to_midpoint): the first half of
  /// the displacement update u^{n+1} = u^n + dt/2 (v^n + v^{n+1}), u += dt/2 v^n, made
  /// before the full step overwrites v^n, so that v^n need not be stored (Dim doubles
  /// per real particle; memory). The hourglass stiffness reads u^n + dt/2 v^n from here.
  void begin_displacement(double dt) {
    const double half_dt = 0.5 * dt;
    parallel_for(real_.size(), [&](std::size_t i) {
      for (int d = 0; d < Dim; ++d) real_.displacement[d][i] += half_dt * real_.velocity[d][i];
    });
  }

  /// Step 5: displacements with the mean of v^n and v^{n+1} (the second half, dt/2
  /// v^{n+1}; begin_displacement added dt/2 v^n); in updated-Lagrangian mode the real
  /// particles move so, the virtual ones with v^{n+1/2}: both sets are at the midpoint
  /// configuration (move_to_midpoint), so the real ones take the second half dt/2
  /// v^{n+1}, the virtual ones dt/2 v^{n+1/2} (and their displacement, if carried,
  /// dt v^{n+1/2}).
  void move(double dt) {
    const bool moving = positions_move();
    const double half_dt = 0.5 * dt;
    parallel_for(real_.size(), [&](std::size_t i) {
      for (int d = 0; d < Dim; ++d) {
        real_.displacement[d][i] += half_dt * real_.velocity[d][i];
        if (moving) real_.position[d][i] += half_dt * real_.velocity[d][i];
      }
    });
    const bool virtual_displacement = virtual_.carries(virtual_.displacement);
    if (moving) {
      parallel_for(virtual_.size(), [&](std::size_t i) {
        for (int d = 0; d < Dim; ++d) {
          if (virtual_displacement) virtual_.displacement[d][i] += dt * virtual_.velocity[d][i];
          virtual_.position[d][i] += half_dt * virtual_.velocity[d][i];
        }
      });
    }
  }

  /// In updated-Lagrangian runs each half-step list is rebuilt every step and used once,
  /// so only one is held at a time: virtual_from_real_ from the rebuild to the half
  /// step, real_from_virtual_ built at the start of the full step. This halves the
  /// memory of the lists (bench/RESULTS.md, memory) at no cost in time. Not with the
  /// hourglass stiffness, which reads both lists after the full step (released, they
  /// made it read past the end of an empty list: a crash in every updated-Lagrangian run
  /// with the stiffness on); the full step then uses the list built at n, with the
  /// midpoint positions (pairs that cross the support edge in half a step have weights
  /// near zero).
  bool lists_used_once() const {
    return positions_move() && settings_.hourglass_stiffness == 0.0 &&
           skin_distance() == 0.0;
  }

  /// Whether the pair (a_i, b_j) of a neighbour row lies within the support 2h (the
  /// test of the searches: squared_distance <= radius^2). Without skin every row holds
  /// only the pairs of its search and this is true (rows are used as they were built);
  /// with a skin, rows also hold pairs up to 2h + skin, which every use of a row that
  /// does not go through kernel weights (those are exactly 0 beyond 2h) must skip.
  bool within_support(const PointsView<Dim>& a, std::size_t i, const PointsView<Dim>& b, std::size_t j) const {
    if (skin_distance() == 0.0) return true;
    const double radius = support_radius();
    return squared_distance<Dim>(a, i, b, j) <= radius * radius;
  }

  /// Verlet skin (SolverSettings::neighbor_skin): whether the lists may miss a pair
  /// within 2h, from bounds on how far the particles have moved since the last search,
  /// without storing the positions of that search. Each call first adds the move just
  /// made to the path bound of each set: both moves of a step (move_to_midpoint, move)
  /// displace every particle by dt/2 times the velocity it holds after the move, so the
  /// largest dt/2 |v| over the set bounds that move's displacements. A particle's net
  /// displacement since the search is at most its path length, at most its set's bound
  /// b (real_path_bound_, virtual_path_bound_). A pair (i, j) changes its distance by at
  /// most d_i + d_j, so by at most b_real + b_virtual for the virtual -> real rows and
  /// 2 b_real for the real -> real (boundary) rows. While both are <= s, every pair
  /// within 2h now was within 2h + s at the search (triangle inequality:
  /// |x_i - x_j| >= |x_i^0 - x_j^0| - d_i - d_j > (2h + s) - s for a pair not in the
  /// list), so the lists are complete. Called at every configuration where lists are
  /// used, right after the move that reached it: x^n (end of the previous step) and the
  /// midpoint (move_to_midpoint). One pass over the velocities of both sets, a maximum
  /// per block of threads (parallel_blocks), combined afterwards: no atomics, the same
  /// answer on any number of threads. A non-finite velocity makes the bound non-finite
  /// and counts as moved (the search then reports it).
  bool lists_outdated(double dt) {
    ++counters_.skin_checks;
    const double half_dt = 0.5 * dt;
    auto largest_speed = [](const ParticleSet<Dim>& set) {
      std::vector<double> block_largest(static_cast<std::size_t>(std::max(1, thread_count())), 0.0);
      const std::size_t blocks =
          parallel_blocks(set.size(), [&](std::size_t b, std::size_t begin, std::size_t end) {
            double m = 0.0;
            for (std::size_t i = begin; i < end; ++i) {
              double v2 = 0.0;
              for (int d = 0; d < Dim; ++d) v2 += set.velocity[d][i] * set.velocity[d][i];
              m = v2 <= m ? m : v2;  // NaN propagates: a non-finite velocity counts as moved
            }
            block_largest[b] = m;
          });
      double largest = 0.0;
      for (std::size_t b = 0; b < blocks; ++b) largest = block_largest[b] <= largest ? largest : block_largest[b];
      return std::sqrt(largest);
    };
    real_path_bound_ += half_dt * largest_speed(real_);
    virtual_path_bound_ += half_dt * largest_speed(virtual_);
    const double pair_bound = real_path_bound_ + std::max(real_path_bound_, virtual_path_bound_);
    return !(pair_bound <= skin_distance() && std::isfinite(pair_bound));
  }

  /// Neighbour lists (build_lists), and the particle sets sorted when their order has
  /// decayed (SolverSettings::spatial_order), the lists then built again.
  void rebuild_neighbors() {
    build_lists();
    if (settings_.spatial_order == SpatialOrder::none) return;
    const double spread = mean_row_spread(virtual_from_real_, nullptr);
    if (sorted_spread_ < 0.0) {
      // First build: the spread the sorted order would have, from the ranks of the
      // sorted order applied to the current list.
      const std::vector<std::uint32_t> order = order_of(real_);
      std::vector<std::uint32_t> rank(order.size());
      for (std::size_t k = 0; k < order.size(); ++k) rank[order[k]] = static_cast<std::uint32_t>(k);
      sorted_spread_ = mean_row_spread(virtual_from_real_, rank.data());
    }
    if (!(spread > settings_.reorder_threshold * std::max(sorted_spread_, 1.0))) return;
    sort_particles();
    build_lists();
    sorted_spread_ = mean_row_spread(virtual_from_real_, nullptr);
  }

  /// Mean over the rows of `list` of the spread (last - first) of their entries, or of
  /// their ranks rank[j] if given: how far apart in memory one stencil's sources lie.
  static double mean_row_spread(const NeighborList& list, const std::uint32_t* rank) {
    std::uint64_t total = 0;  // an integer sum: exact, whatever the order
    std::size_t rows = 0;
    for (std::size_t i = 0; i < list.query_count(); ++i) {
      const auto row = list.neighbors(i);
      if (row.empty()) continue;
      ++rows;
      if (!rank) {
        total += row.back() - row.front();  // rows are sorted
        continue;
      }
      std::uint32_t low = UINT32_MAX, high = 0;
      for (std::uint32_t j : row) low = std::min(low, rank[j]), high = std::max(high, rank[j]);
      total += high - low;
    }
    return rows > 0 ? static_cast<double>(total) / static_cast<double>(rows) : 0.0;
  }

  std::vector<std::uint32_t> order_of(const ParticleSet<Dim>& set) const {
    return spatial_order<Dim>(settings_.spatial_order, points_of<Dim>(set), 0.25 * support_radius());
  }

  /// Sorts both sets into SolverSettings::spatial_order (permute_state).
  void sort_particles() {
    permute_state(order_of(real_), order_of(virtual_));
    ++counters_.reorders;
  }

  /// Renumbers both sets (ParticleSet::permute: new real particle k is old real_order[k],
  /// likewise for the virtual set) and every per-particle state of the stepper held
  /// outside them:
  ///  - per real particle: previous_velocity_ (v^n) permuted; boundary_slot_ rebuilt;
  ///  - per boundary slot (slots kept in increasing real index): every boundary_* array
  ///    and filtered_velocity_ permuted with the slots: the persistent ones (profile,
  ///    surface flag, normal) and the per-step ones (the state at n and its gradients,
  ///    the half-step gradients, velocity, gradient sum and stencil offset of the wall
  ///    gradient and the surface extrapolation), so that none is left at another
  ///    particle's slot;
  ///  - index-based lists and scratch recomputed from scratch at their next use: the
  ///    hourglass stiffness's lists (hourglass_list_build_) and fits, the conservative
  ///    momentum's weights and pair list (rebuilt every step), cleared here.
  /// The caller builds the neighbour lists again.
  void permute_state(const std::vector<std::uint32_t>& real_order,
                     const std::vector<std::uint32_t>& virtual_order) {
    real_.permute(real_order);
    virtual_.permute(virtual_order);
    for (auto& v : previous_velocity_) {
      if (v.empty()) continue;  // not stored (begin_displacement)
      std::vector<double> reordered(v.size());
      for (std::size_t k = 0; k < real_order.size(); ++k) reordered[k] = v[real_order[k]];
      v.swap(reordered);
    }
    std::vector<std::uint32_t> new_index(real_order.size());
    for (std::size_t k = 0; k < real_order.size(); ++k) new_index[real_order[k]] = static_cast<std::uint32_t>(k);
    // Slots in increasing new index: slot_order[s] = the old slot of new slot s.
    std::vector<std::size_t> slot_order(boundary_particles_.size());
    for (std::size_t b = 0; b < slot_order.size(); ++b) slot_order[b] = b;
    std::sort(slot_order.begin(), slot_order.end(), [&](std::size_t a, std::size_t b) {
      return new_index[boundary_particles_[a]] < new_index[boundary_particles_[b]];
    });
    auto permute_slots = [&slot_order](auto& per_slot) {
      if (per_slot.size() != slot_order.size()) return;  // not yet assigned
      auto reordered = per_slot;
      for (std::size_t s = 0; s < slot_order.size(); ++s) reordered[s] = per_slot[slot_order[s]];
      per_slot.swap(reordered);
    };
    permute_slots(boundary_profile_);
    permute_slots(boundary_on_surface_);
    permute_slots(boundary_normal_);
    permute_slots(boundary_stress_);
    permute_slots(boundary_velocity_);
    permute_slots(boundary_density_);
    permute_slots(boundary_stress_gradient_);
    permute_slots(boundary_velocity_gradient_);
    permute_slots(boundary_half_stress_gradient_);
    permute_slots(boundary_half_velocity_gradient_);
    permute_slots(boundary_half_velocity_);
    permute_slots(boundary_stencil_offset_);
    permute_slots(boundary_gradient_sum_);
    permute_slots(filtered_velocity_);
    std::vector<std::uint32_t> particles(boundary_particles_.size());
    for (std::size_t s = 0; s < slot_order.size(); ++s) particles[s] = new_index[boundary_particles_[slot_order[s]]];
    boundary_particles_.swap(particles);
    boundary_slot_.assign(real_.size(), -1);
    for (std::size_t s = 0; s < boundary_particles_.size(); ++s)
      boundary_slot_[boundary_particles_[s]] = static_cast<std::int32_t>(s);
    // By index, rebuilt at their next use.
    hourglass_list_build_ = -1;
    hourglass_from_virtual_ = NeighborList{};
    hourglass_to_real_ = NeighborList{};
    forward_fit_.clear();
    return_fit_.clear();
    virtual_value_.clear();
    round_trip_residual_.clear();
    momentum_weight_.clear();
    momentum_pair_offsets_.clear();
    momentum_pair_.clear();
    momentum_pair_virtual_.clear();
  }

  /// Neighbour lists of both half-steps and of the real set, and the boundary normals
  /// n = -sum_J V_J grad_I W_IJ / |.| (they point out of the body).
  void build_lists() {
    search_lists();
    compute_boundary_normals();
  }

  /// The searches of build_lists, with radius list_radius(): both half-step lists
  /// (without skin in updated Lagrangian the full step's is left to the full step), the
  /// boundary rows of the real set, and with a skin the path bounds reset.
  void search_lists() {
    const double radius = list_radius();
    const bool skin = skin_distance() > 0.0;
    const PointsView<Dim> real_points = points_of<Dim>(real_);
    const PointsView<Dim> virtual_points = points_of<Dim>(virtual_);
    // The old lists are released first, so that two generations never coexist (memory).
    virtual_from_real_ = NeighborList{};
    real_from_virtual_ = NeighborList{};
    real_from_real_ = NeighborList{};
    {
      const NeighborSearcher<Dim> real_search(settings_.neighbor_search, real_points, radius);
      neighbor_search_used_ = real_search.kind();
      virtual_from_real_ = real_search.query(virtual_points);
      // Same-set rows only where they are used: the boundary particles (rows of the other
      // real particles are empty, so the list is still indexed by real particle).
      real_from_real_ = real_search.query_subset(real_points, boundary_particles_, true);
    }
    if (!lists_used_once())
      real_from_virtual_ =
          settings_.transpose_lists || skin
              ? transpose(virtual_from_real_, real_.size())
              : NeighborSearcher<Dim>(settings_.neighbor_search, virtual_points, radius).query(real_points);
    real_path_bound_ = 0.0;  // the lists hold the pairs within list_radius() from here on
    virtual_path_bound_ = 0.0;
    ++counters_.neighbor_builds;
  }

  /// The boundary normals n = -sum_J V_J grad_I W_IJ / |.| (they point out of the body)
  /// from the real set at its current positions (x^n), and at the first build the
  /// surface/interior decision; rows filtered to the support (within_support).
  void compute_boundary_normals() {
    const PointsView<Dim> real_points = points_of<Dim>(real_);
    visit_kernel<Dim>(settings_.kernel, [&](const auto& kernel) {
      const bool first_build = !surface_decided_;
      if (first_build) boundary_on_surface_.assign(boundary_particles_.size(), 1);
      for (std::size_t b = 0; b < boundary_particles_.size(); ++b) {
        const std::uint32_t i = boundary_particles_[b];
        const Vec x = real_.position_of(i);
        Vec sum = Vec::Zero();
        for (std::uint32_t j : real_from_real_.neighbors(i))
          if (within_support(real_points, i, real_points, j))
            sum += real_.volume[j] * kernel_gradient<Dim>(kernel, Vec(x - real_.position_of(j)),
                                                          settings_.smoothing_length);
        const double norm = sum.norm();
        const Vec kernel_normal = norm > 0.0 ? Vec(-sum / norm) : Vec(Vec::Unit(0));
        // On a surface no neighbour lies within 60 degrees of the outward normal; inside,
        // some neighbour always does (a lattice has one every 90 degrees or closer).
        double most_outward = -1.0;
        for (std::uint32_t j : real_from_real_.neighbors(i)) {
          if (!within_support(real_points, i, real_points, j)) continue;
          const Vec offset = real_.position_of(j) - x;
          most_outward = std::max(most_outward, offset.dot(kernel_normal) / offset.norm());
        }
        const bool on_surface = norm > 0.0 && most_outward < kSurfaceCosine;
        if (first_build) {
          boundary_on_surface_[b] = on_surface;
          const auto& condition = boundaries_[static_cast<std::size_t>(real_.boundary[i])];
          if (!on_surface && condition.kind == BoundaryCondition<Dim>::Kind::traction)
            throw std::invalid_argument(
                "boundary condition '" + condition.name + "': real particle " +
                std::to_string(real_.id[i]) +
                " is inside the body (no free surface there); a traction applies only to "
                "surface particles: shrink the region to the surface");
        }
        boundary_normal_[b] = face_normal(i, kernel_normal);
      }
    });
    surface_decided_ = true;
  }

  /// The normal of the face a boundary particle's condition applies to: the direction
  /// of least spread of the particle and its neighbours under the same condition
  /// (principal components), oriented like `kernel_normal`. Where those particles do
  /// not lie on a (Dim-1)-plane (an edge between two faces of one condition, a lone
  /// particle) the kernel normal -sum V grad W is kept. Unlike the kernel normal, this
  /// gives the face normal at corners and next to them, where half volumes and the
  /// missing neighbours tilt the kernel sum.
  Vec face_normal(std::uint32_t i, const Vec& kernel_normal) const {
    if constexpr (Dim == 1) {
      (void)i;
      return kernel_normal;
    } else {
      const std::int32_t condition = real_.boundary[i];
      const PointsView<Dim> real_points = points_of<Dim>(real_);
      std::vector<Vec> points{real_.position_of(i)};
      for (std::uint32_t j : real_from_real_.neighbors(i))
        if (real_.boundary[j] == condition && within_support(real_points, i, real_points, j))
          points.push_back(real_.position_of(j));
      if (points.size() < static_cast<std::size_t>(Dim)) return kernel_normal;
      Vec mean = Vec::Zero();
      for (const Vec& x : points) mean += x;
      mean /= static_cast<double>(points.size());
      Mat covariance = Mat::Zero();
      for (const Vec& x : points) covariance += (x - mean) * (x - mean).transpose();
      Eigen::SelfAdjointEigenSolver<Mat> eigen(covariance);
      const auto& spread = eigen.eigenvalues();  // increasing
      if (!(spread[1] > 0.0) || spread[0] > 0.1 * spread[1]) return kernel_normal;
      Vec normal = eigen.eigenvectors().col(0);
      return normal.dot(kernel_normal) >= 0.0 ? normal : Vec(-normal);
    }
  }

  ParticleSet<Dim> real_;
  ParticleSet<Dim> virtual_;
  LinearElastic<Dim> material_;
  SolverSettings<Dim> settings_;
  std::vector<BoundaryCondition<Dim>> boundaries_;
  double time_ = 0.0;
  SolverCounters counters_;
  /// check_stability's pass: per block of kStabilityBlock particles (real blocks, then
  /// virtual ones), the first non-finite particle and the real blocks' energies.
  static constexpr std::size_t kStabilityBlock = 4096;
  static constexpr std::size_t kNoParticle = static_cast<std::size_t>(-1);
  struct StabilityBlock {
    std::size_t first_non_finite = kNoParticle;
    double kinetic = 0.0, strain = 0.0;
  };
  std::vector<StabilityBlock> stability_blocks_;
  double previous_energy_ = 0.0;   ///< total energy after the last step (check_stability)
  std::array<int, kRunawayGrowths.size()> energy_growth_steps_{};  ///< consecutive, per growth
  std::vector<double> largest_energy_;  ///< largest energy so far, after each recent step
  double initial_spacing_ = 0.0;        ///< (mean initial virtual volume)^(1/Dim)
  std::int64_t energized_steps_ = 0;    ///< steps with a positive largest energy

  NeighborSearch neighbor_search_used_ = NeighborSearch::cell_list;  ///< at the last rebuild
  double sorted_spread_ = -1.0;  ///< mean_row_spread of the sorted order (-1: not known yet)
  NeighborList virtual_from_real_;  ///< rows: virtual particles; entries: real
  NeighborList real_from_virtual_;  ///< rows: real particles; entries: virtual
  NeighborList real_from_real_;     ///< rows: real particles (only boundary ones filled); entries: real, self excluded
  /// Bounds on the path length of any particle of each set since the last search
  /// (only with a skin: lists_outdated).
  double real_path_bound_ = 0.0, virtual_path_bound_ = 0.0;
  bool surface_decided_ = false;  ///< boundary_on_surface_ set (at the first build)

  std::vector<std::uint32_t> boundary_particles_;  ///< real indices with a condition
  std::vector<std::int32_t> boundary_slot_;        ///< real index -> slot, or -1
  std::vector<Vec> boundary_profile_;              ///< profile(x0) per slot
  std::vector<Vec> boundary_normal_;
  std::vector<char> boundary_on_surface_;  ///< decided at the first build
  std::vector<StressVector<Dim>> boundary_stress_;  ///< sigma^n
  std::vector<Vec> boundary_velocity_;              ///< v^n
  std::vector<double> boundary_density_;            ///< rho^n
  std::vector<StressGradient> boundary_stress_gradient_;  ///< grad sigma^n (real set)
  std::vector<Mat> boundary_velocity_gradient_;           ///< grad v^n (real set)
  std::vector<StressGradient> boundary_half_stress_gradient_;  ///< grad sigma^{n+1/2} (virtual)
  std::vector<Mat> boundary_half_velocity_gradient_;           ///< grad v^{n+1/2} (virtual)
  std::vector<Vec> boundary_half_velocity_;   ///< v^{n+1/2} interpolated at the particle
  std::vector<Vec> boundary_stencil_offset_;  ///< x_I - centroid of its virtual stencil
  std::vector<Vec> boundary_gradient_sum_;    ///< sum_J V_J Gn_IJ over its virtual stencil
  /// v^n of the real particles, stored by the full step only for the conservative
  /// momentum update (the displacement takes dt/2 v^n in begin_displacement).
  std::array<std::vector<double>, Dim> previous_velocity_;
  std::vector<Vec> filtered_velocity_;  ///< hourglass filter scratch, per boundary slot
  // Hourglass stiffness scratch (apply_hourglass_stiffness).
  std::vector<LinearFitWeights> forward_fit_;   ///< A, per virtual particle
  std::vector<LinearFitWeights> return_fit_;    ///< R, per real particle
  std::vector<Vec> virtual_value_;              ///< a_v, then s_v
  std::vector<Vec> round_trip_residual_;        ///< V_I r_I
  // Conservative momentum scratch (store_momentum_weights).
  std::vector<Vec> momentum_weight_;          ///< D_vJ per pair of virtual_from_real_
  std::vector<std::uint64_t> momentum_pair_offsets_;  ///< row starts, rows of real particles
  std::vector<std::uint64_t> momentum_pair_;  ///< pair index, row by real particle
  std::vector<std::uint32_t> momentum_pair_virtual_;  ///< its virtual particle
  NeighborList hourglass_from_virtual_;  ///< rows: real; entries: virtual (initial coordinates)
  NeighborList hourglass_to_real_;       ///< its transpose
  double hourglass_radius_ = 0.0;
  std::int64_t hourglass_list_build_ = -1;  ///< neighbor_builds when it was built
};

}  // namespace tsph
