// The state of the stepper: both particle sets, the material, the settings and
// boundary conditions, the clock and counters, the neighbour lists, and the
// per-boundary-particle state (one structure of arrays). Every stage of a step
// (docs/architecture.md) takes this state; scratch stays with the stage that uses it.
#pragma once

#include "engine/boundary_condition.hpp"
#include "engine/material/material.hpp"
#include "engine/particle_set.hpp"
#include "engine/solver/kernel_factor_cache.hpp"
#include "engine/solver/settings.hpp"
#include "engine/solver/stencil_evaluation.hpp"
#include "neighbor/cell_list.hpp"
#include "neighbor/neighbor_list.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace tsph {

/// Per boundary slot (one per real particle with a boundary condition, in increasing
/// real index): structure of arrays with `for_each_field`, so that `assign` and
/// `permute` cannot forget a field (the ParticleSet pattern).
template <int Dim>
struct BoundaryParticles {
  using Vec = Vector<Dim>;
  using Mat = Matrix<Dim>;
  using StressGradient = std::array<Vec, stress_component_count<Dim>>;

  std::vector<std::uint32_t> particle;   ///< real index of the slot
  std::vector<Vec> profile;              ///< BoundaryCondition::profile(x0)
  std::vector<char> on_surface;          ///< decided at the first build of the lists
  /// Decided with on_surface, in the initial configuration (FreeEdge::classify): 1 where
  /// the particle is extreme along every axis among its neighbours (a box's corner in 2D,
  /// its vertex in 3D; FreeEdge::free_corner adds the neighbours' conditions at t)
  std::vector<char> box_corner;
  /// Likewise: for a surface particle of a traction condition, the axis of the convex
  /// axis-parallel edge it lies on with its normal between the faces (3D,
  /// FreeEdge::uniaxial_edge_axis), else -1
  std::vector<std::int8_t> edge_axis;
  /// Likewise: 1 for a particle of a symmetry condition (a smooth wall) with a particle of
  /// a traction condition one spacing from it, i.e. on the edge where a free face meets
  /// the wall (FreeEdge::wall_free_normal)
  std::vector<char> wall_edge;
  std::vector<Vec> normal;               ///< outward unit normal (boundary/normals.hpp)
  std::vector<StressVector<Dim>> stress;  ///< sigma^n
  std::vector<Vec> velocity;             ///< v^n
  std::vector<double> density;           ///< rho^n
  std::vector<StressGradient> stress_gradient;       ///< grad sigma^n (real set)
  std::vector<Mat> velocity_gradient;                ///< grad v^n (real set)
  std::vector<StressGradient> half_stress_gradient;  ///< grad sigma^{n+1/2} (virtual set)
  std::vector<Mat> half_velocity_gradient;           ///< grad v^{n+1/2} (virtual set)
  std::vector<Vec> half_velocity;   ///< v^{n+1/2} interpolated at the particle
  /// M_ab = sum_v V_v Gn_Iv,a r_b (r . n), r = x_v - x_I, over its virtual stencil (n the
  /// normal at the list build): the gradient d_a the row reads of the field r_b (r . n)
  /// that is zero at I, i.e. the depth at which the row evaluates a tangential gradient
  /// that changes across the surface (surface_extrapolation.hpp).
  std::vector<Mat> normal_moment;
  std::vector<Vec> gradient_sum;    ///< sum_J V_J Gn_IJ over its virtual stencil
  /// 1 where the half-step gradient's correction matrix was inverted, 0 where its stencil
  /// is rank-deficient (a corner at alpha 0.6: one virtual neighbour, the missing
  /// direction read as zero) or empty: then half_velocity_gradient is not a gradient
  std::vector<char> full_rank_gradient;
  /// 1 where the half-step row's linear interpolation was regular too (its virtual stencil
  /// spans every direction from its centroid: at alpha >= 1 a 1D end has virtual particles
  /// at two depths, at alpha 0.6 one), so that its half-step gradient along the normal is
  /// a derivative of the virtual field and not of the particle's own value
  /// (characteristics.hpp, the 1D ends' normal derivative at n+1/2).
  std::vector<char> linear_half_row;
  /// deficient_stencils = complete only: the projector onto the directions a row's virtual
  /// stencil spans (0 for a corner at alpha 0.6, the edge's direction for a 3D edge) where
  /// it misses a tangent and no widened stencil was regular to complete its half-step
  /// gradients (full_step.hpp, complete_deficient_row); the characteristic relations take
  /// the missing tangential derivatives from the real set at n. The identity otherwise.
  std::vector<Mat> half_span;
  /// The further symmetry planes the particle keeps to besides its own condition
  /// (BoundaryCondition::also_on_plane; solver/boundary/symmetry_planes.hpp): their
  /// condition indices, -1 for none (at most Dim - 1), and their unit normals at x^n
  /// (boundary/normals.hpp).
  std::vector<std::array<std::int32_t, 2>> extra_plane;
  std::vector<std::array<Vec, 2>> extra_normal;
  /// A driven body's particle's area vector in the reference configuration: its shares
  /// of the lattice faces through it, from the cells it touches
  /// (SolverState::assign_face_areas; the energy ledger's drive power); zero otherwise.
  std::vector<Vec> face_area;
  /// Per real particle (not per slot): its slot, or -1.
  std::vector<std::int32_t> slot;

  std::size_t size() const { return particle.size(); }

  template <class F>
  void for_each_field(F&& f) {
    f(particle), f(profile), f(on_surface), f(box_corner), f(edge_axis), f(wall_edge), f(normal), f(stress), f(velocity), f(density);
    f(stress_gradient), f(velocity_gradient), f(half_stress_gradient), f(half_velocity_gradient);
    f(half_velocity), f(normal_moment), f(gradient_sum), f(full_rank_gradient), f(linear_half_row), f(half_span), f(extra_plane), f(extra_normal);
    f(face_area);
  }

  /// Whether slot b keeps to the plane of symmetry condition k as a further plane.
  bool keeps_extra_plane(std::size_t b, std::int32_t k) const {
    return extra_plane[b][0] == k || extra_plane[b][1] == k;
  }

  /// Sizes every per-step field to the slots of `particle` and zeroes it (Eigen's
  /// fixed-size types are not initialised by default: a boundary particle whose stencil
  /// is empty, counted, then reads zero gradients).
  void zero_step_fields() {
    const std::size_t n = size();
    StressGradient zero_gradient;
    for (auto& g : zero_gradient) g.setZero();
    on_surface.assign(n, 1);
    box_corner.assign(n, 0);
    edge_axis.assign(n, -1);
    wall_edge.assign(n, 0);
    normal.assign(n, Vec::Zero());
    stress.assign(n, StressVector<Dim>{});
    velocity.assign(n, Vec::Zero());
    density.assign(n, 0.0);
    stress_gradient.assign(n, zero_gradient);
    velocity_gradient.assign(n, Mat::Zero());
    half_stress_gradient.assign(n, zero_gradient);
    half_velocity_gradient.assign(n, Mat::Zero());
    half_velocity.assign(n, Vec::Zero());
    normal_moment.assign(n, Mat::Zero());
    gradient_sum.assign(n, Vec::Zero());
    full_rank_gradient.assign(n, 0);
    linear_half_row.assign(n, 0);
    half_span.assign(n, Mat::Identity());
    extra_normal.assign(n, {Vec::Zero(), Vec::Zero()});
  }

  /// Renumbers after the real set was permuted: new_index[old real index] is the new
  /// index. Slots are kept in increasing real index, every field moves with its slot.
  void permute(const std::vector<std::uint32_t>& new_index) {
    std::vector<std::size_t> slot_order(size());  // slot_order[s] = the old slot of new slot s
    for (std::size_t b = 0; b < slot_order.size(); ++b) slot_order[b] = b;
    std::sort(slot_order.begin(), slot_order.end(),
              [&](std::size_t a, std::size_t b) { return new_index[particle[a]] < new_index[particle[b]]; });
    for_each_field([&slot_order](auto& per_slot) {
      auto reordered = per_slot;
      for (std::size_t s = 0; s < slot_order.size(); ++s) reordered[s] = per_slot[slot_order[s]];
      per_slot.swap(reordered);
    });
    for (auto& i : particle) i = new_index[i];
    slot.assign(new_index.size(), -1);
    for (std::size_t s = 0; s < size(); ++s) slot[particle[s]] = static_cast<std::int32_t>(s);
  }
};

/// The neighbour lists of a step and their bookkeeping (lifecycle: neighbor_lists.hpp).
struct SolverLists {
  NeighborList virtual_from_real;  ///< rows: virtual particles; entries: real
  NeighborList real_from_virtual;  ///< rows: real particles; entries: virtual
  NeighborList real_from_real;     ///< rows: real (only boundary ones filled); entries: real, self excluded
  NeighborSearch search_used = NeighborSearch::cell_list;  ///< at the last search
  double sorted_spread = -1.0;  ///< mean row spread of the sorted order (-1: not known yet)
  /// Bounds on the path length of any particle of each set since the last search (skin).
  double real_path_bound = 0.0, virtual_path_bound = 0.0;
  /// The largest real move of the last Motion::move when it is not dt/2 |v^{n+1}|
  /// (SolverSettings::material_velocity_motion); -1: dt/2 |v| bounds it.
  double real_move_bound = -1.0;
  bool surface_decided = false;  ///< BoundaryParticles::on_surface set (at the first build)
};

/// Mirror planes (BoundaryCondition::Kind::mirror) and their ghost particles
/// (solver/boundary/mirror_planes.hpp): which owned particle each ghost images, across
/// which planes, per set; and the owned real particles on a plane.
template <int Dim>
struct MirrorGhosts {
  using Vec = Vector<Dim>;
  struct Plane {
    Vec point;
    Vec normal;  ///< unit, out of the body
    std::size_t condition = 0;
  };
  struct Images {
    std::vector<std::uint32_t> source;  ///< per ghost: the owned particle it images
    std::vector<std::uint8_t> planes;   ///< per ghost: bit k set = reflected across planes[k]
  };
  std::vector<Plane> planes;
  Images real, virtual_;
  std::vector<std::uint32_t> on_plane;      ///< owned real particles on a plane (initial position)
  std::vector<std::uint8_t> on_plane_mask;  ///< their planes (bits as above)
  /// Per owned real particle (empty without planes): its share of the modelled part,
  /// 1/2 per plane it lies on (SolverState::share; the energy ledger's sums).
  std::vector<double> share;
  /// Whether the case has a mirror plane.
  bool active() const { return !planes.empty(); }

  /// x reflected across the planes of `mask` (the planes are pairwise orthogonal or
  /// parallel: the order does not matter for those a particle is imaged across).
  Vec reflect_point(std::uint8_t mask, Vec x) const {
    for (std::size_t k = 0; k < planes.size(); ++k)
      if (mask >> k & 1u) x -= 2.0 * (x - planes[k].point).dot(planes[k].normal) * planes[k].normal;
    return x;
  }
  /// A vector (velocity, displacement) reflected: v - 2 (v . m) m per plane.
  Vec reflect_direction(std::uint8_t mask, Vec v) const {
    for (std::size_t k = 0; k < planes.size(); ++k)
      if (mask >> k & 1u) v -= 2.0 * v.dot(planes[k].normal) * planes[k].normal;
    return v;
  }
  /// A stress (3 x 3, the out-of-plane components of 2D included) reflected: R s R,
  /// R = I - 2 m m^T per plane.
  Eigen::Matrix3d reflect_tensor(std::uint8_t mask, Eigen::Matrix3d s) const {
    for (std::size_t k = 0; k < planes.size(); ++k)
      if (mask >> k & 1u) {
        Eigen::Vector3d m = Eigen::Vector3d::Zero();
        m.template head<Dim>() = planes[k].normal;
        const Eigen::Matrix3d r = Eigen::Matrix3d::Identity() - 2.0 * m * m.transpose();
        s = r * s * r;
      }
    return s;
  }
};

/// SolverSettings::volumetric_average's material stencils (stabilisation/volumetric_average.hpp),
/// CSR by owned virtual particle (its corners: interior real particles within dx at X) and
/// by owned real particle (its cells within dx at X), ghosts replaced by their owners;
/// taken at the search SolverCounters::neighbor_builds.
struct VolumetricAverageStencils {
  std::vector<std::uint32_t> cell_start, cell_corner, particle_start, particle_cell;
  std::int64_t neighbor_builds = -1;
};

template <int Dim>
struct SolverState {
  using Vec = Vector<Dim>;
  using Mat = Matrix<Dim>;
  static constexpr int stress_count = stress_component_count<Dim>;

  ParticleSet<Dim> real;
  ParticleSet<Dim> virtual_;
  Material<Dim> material;  ///< the stress update (engine/material/material.hpp)
  SolverSettings<Dim> settings;
  std::vector<BoundaryCondition<Dim>> boundaries;
  double time = 0.0;
  SolverCounters counters;
  EnergyLedger energy;  ///< SolverSettings::energy_ledger (energy_ledger.hpp)
  double initial_spacing = 0.0;  ///< (mean initial virtual volume)^(1/Dim)
  /// A driven body: the index of the one velocity condition that every real particle
  /// carries (the body's whole motion is prescribed: the homogeneous deformations of the
  /// validation suite), else -1. Then there is no momentum equation left to solve: the
  /// virtual particles take the prescribed velocity at n+1/2 too (half_step.hpp; their
  /// own update, v + dt/2 div sigma / rho, fed the stress error of a sheared block's
  /// corners back into its velocity gradient), and the surface particles are imposed
  /// like the inner ones, their stress from the full step (characteristics.hpp: the
  /// relations along a corner's single normal diverged at gamma 2). They stay surface
  /// particles for the energy ledger (the traction power of the drive). The condition's
  /// velocity field is then called from the half step's parallel loop: a field given
  /// through the library (BoundaryCondition::velocity_field) must be thread-safe
  /// (AffineMotion is: one lock around its cached exponential).
  std::int32_t driven_condition = -1;
  SolverLists lists;
  BoundaryParticles<Dim> boundary;
  /// The mirror planes and their ghosts (solver/boundary/mirror_planes.hpp); inactive
  /// without a mirror condition.
  MirrorGhosts<Dim> mirror;
  /// SolverSettings::material_velocity_motion: each real particle's position at n+1,
  /// written by the full step (NaN: none, the trapezoid applies), read by
  /// Motion::move in the same step. Scratch, one array per component.
  std::array<std::vector<double>, Dim> next_position;
  /// With the energy ledger and damping: the velocity the momentum update damped at each
  /// real particle, written by the full step (the interpolated v^{n+1/2}; the own v^n where
  /// conservative_momentum replaces the update), read by EnergyAccounting::end, which books
  /// the damping's work as the impulse it applied, -c dt m v_damped . v_mean. An odd-even
  /// velocity that the interpolation does not see is not damped, and so not booked
  /// (docs/notes/2026-12-06-damping-work.md). Empty otherwise; scratch, one array per
  /// component.
  std::array<std::vector<double>, Dim> damped_velocity;
  /// SolverSettings::volumetric_average: every real particle's tr L^{n+1/2}, written by
  /// the full step (NaN where its row had no neighbours), and the cells' means of it
  /// (stabilisation/volumetric_average.hpp). Empty otherwise; scratch.
  std::vector<double> volumetric_rate, volumetric_cell_rate;
  VolumetricAverageStencils volumetric_stencils;  ///< its cells' corners and particles' cells
  /// The reference kernel's factors of the half step's and the full step's lists
  /// (kernel_factor_cache.hpp; SolverSettings::kernel_cache_bytes).
  KernelFactorCache half_kernel_factors, full_kernel_factors;
  /// Readies `cache` for `list` (h the settings'): whether the step reads or fills it
  /// (for its first cache.rows() rows). Each of the two caches has half the budget.
  bool use_kernel_factors(KernelFactorCache& cache, const NeighborList& list) {
    if (!reference_kernel()) return false;
    return cache.prepare(list, counters.neighbor_builds, settings.smoothing_length,
                         settings.kernel_cache_bytes / (2 * sizeof(double)));
  }

  /// Checks the settings and both sets, releases the virtual fields the run does not
  /// read, and fills the boundary slots. The lists are built by the solver.
  SolverState(ParticleSet<Dim> real_set, ParticleSet<Dim> virtual_set, Material<Dim> model,
              SolverSettings<Dim> run_settings, std::vector<BoundaryCondition<Dim>> conditions)
      : real(std::move(real_set)),
        virtual_(std::move(virtual_set)),
        material(std::move(model)),
        settings(std::move(run_settings)),
        boundaries(std::move(conditions)) {
    // Which surface treatments the run takes by default (the mirror planes' message); the
    // wall gradient every material in 2D and 3D.
    if (takes_elastic_treatments<Dim>(material.plastic()))
      automatic_surface_treatments_ = {settings.surface_extrapolation == Toggle::automatic,
                                       settings.hourglass_coefficient == kAutomaticOption,
                                       settings.velocity_wall == SolverSettings<Dim>::VelocityWall::automatic,
                                       Dim == 3 && settings.free_edge_uniaxial == Toggle::automatic};
    else
      automatic_surface_treatments_[2] = Dim >= 2 && settings.velocity_wall == SolverSettings<Dim>::VelocityWall::automatic;
    settings = resolve_automatic_options(settings, material.plastic(), material.pressure_independent_yield());
    check_settings();
    real.check_field_sizes("solver: the real set");
    virtual_.check_field_sizes("solver: the virtual set");
    if (!real.carries(real.initial_position) || !real.carries(real.displacement) || !real.carries(real.id) ||
        !real.carries(real.boundary))
      throw std::invalid_argument("solver: the real set must carry its initial positions, displacements, "
                                  "ids and boundary tags (released optional fields)");
    driven_condition = find_driven_condition();
    // The virtual initial positions X_v: read by the hourglass stiffness and by the
    // updated-Lagrangian virtual motion (half_step.hpp, place_at_material_point).
    const bool virtual_initial_positions =
        settings.hourglass_stiffness > 0.0 || settings.keep_virtual_fields || positions_move() || driven();
    if (settings.keep_virtual_fields
            ? !(virtual_.carries(virtual_.initial_position) && virtual_.carries(virtual_.displacement) &&
                virtual_.carries(virtual_.id) && virtual_.carries(virtual_.boundary) &&
                virtual_.carries(virtual_.group))
            : virtual_initial_positions && !virtual_.carries(virtual_.initial_position))
      throw std::invalid_argument(
          "solver: the virtual set has released optional fields that this run reads (the initial "
          "positions for the hourglass stiffness or the updated-Lagrangian virtual motion, or every field with "
          "keep_virtual_fields)");
    if (!settings.keep_virtual_fields) virtual_.release_optional_fields(virtual_initial_positions);
    virtual_.release_plastic_fields();  // a virtual particle's state is interpolated (half_step.hpp)
    if (material.plastic()) real.carry_plastic_fields(material.initial_state().temperature);
    else real.release_plastic_fields();
    assign_mirror_planes();
    boundary.slot.assign(real.size(), -1);
    for (std::size_t i = 0; i < real.size(); ++i) {
      const std::int32_t b = real.boundary[i];
      if (b == ParticleSet<Dim>::kNoBoundary) continue;
      if (b < 0 || static_cast<std::size_t>(b) >= boundaries.size())
        throw std::invalid_argument("solver: real particle " + std::to_string(i) + " refers to boundary condition " +
                                    std::to_string(b) + " of " + std::to_string(boundaries.size()));
      if (boundaries[static_cast<std::size_t>(b)].kind == BoundaryCondition<Dim>::Kind::mirror)
        throw std::invalid_argument("solver: real particle " + std::to_string(i) + " carries the mirror plane '" +
                                    boundaries[static_cast<std::size_t>(b)].name +
                                    "': a mirror plane is no particle's condition (its ghosts model it)");
      boundary.slot[i] = static_cast<std::int32_t>(boundary.particle.size());
      boundary.particle.push_back(static_cast<std::uint32_t>(i));
      boundary.profile.push_back(boundaries[static_cast<std::size_t>(b)].profile(initial_position_of(i)));
    }
    assign_extra_planes();
    boundary.zero_step_fields();
    // dx of the CFL in a diagnosis (stability_monitor.hpp) and of the adaptive step
    // (time_step.hpp): from the initial volumes m / rho0, so that a restart of a deformed
    // body gets the dx of its start (its current volumes would give another).
    double virtual_volume = 0.0;
    const double reference_density = material.elastic().reference_density();
    for (std::size_t q = 0; q < virtual_.size(); ++q) virtual_volume += virtual_.mass[q] / reference_density;
    initial_spacing = std::pow(virtual_volume / static_cast<double>(virtual_.size()), 1.0 / Dim);
    assign_face_areas();
  }

  /// Fills BoundaryParticles::face_area, for a driven body only (zero otherwise: the
  /// ledger reads it there alone). On the node lattice the cells a real node X_i touches
  /// are its virtual neighbours at sqrt(Dim) dx / 2 (the next ones lie beyond
  /// sqrt(Dim + 8) dx / 2), and each covers (dx / 2)^(Dim - 1) of the faces through the
  /// node, so A0 = (dx / 2)^(Dim - 1) sum_c sign(X_i - X_c): zero inside, the outward
  /// face, edge or corner shares on the surface, re-entrant corners included.
  void assign_face_areas() {
    boundary.face_area.assign(boundary.size(), Vec::Zero());
    if (!driven() || boundary.size() == 0) return;
    const double dx = initial_spacing;
    const PointsView<Dim> nodes = initial_points_of<Dim>(real), cells = initial_points_of<Dim>(virtual_);
    const NeighborList touching = CellList<Dim>(cells, 0.75 * std::sqrt(double(Dim)) * dx)
                                      .query_subset(nodes, boundary.particle, /*exclude_self=*/false);
    const double share = std::pow(0.5 * dx, Dim - 1);
    for (std::size_t b = 0; b < boundary.size(); ++b) {
      const std::uint32_t i = boundary.particle[b];
      Vec sum = Vec::Zero();
      for (std::uint32_t c : touching.neighbors(i))
        for (int d = 0; d < Dim; ++d) sum[d] += nodes.coordinate[d][i] > cells.coordinate[d][c] ? 1.0 : -1.0;
      boundary.face_area[b] = share * sum;
    }
  }

  /// MirrorGhosts::planes from the mirror conditions, checked: pairwise orthogonal or
  /// parallel, at most 8, no option that reads what ghosts do not carry. The ghosts
  /// themselves are made with the lists (mirror_planes.hpp).
  void assign_mirror_planes() {
    for (std::size_t k = 0; k < boundaries.size(); ++k) {
      const auto& c = boundaries[k];
      if (c.kind != BoundaryCondition<Dim>::Kind::mirror) continue;
      if (!(std::abs(c.plane_normal.norm() - 1.0) < 1e-12) || !c.plane_point.allFinite())
        throw std::invalid_argument("solver: mirror plane '" + c.name + "' needs a finite point and a non-zero normal");
      for (const auto& other : mirror.planes) {
        const double cosine = std::abs(other.normal.dot(c.plane_normal));
        if (cosine > 1e-9)
          throw std::invalid_argument("solver: mirror planes '" + boundaries[other.condition].name + "' and '" +
                                      c.name + "' are not orthogonal (|cos| = " + std::to_string(cosine) +
                                      "): the images of a particle are those of orthogonal planes only (a "
                                      "half or quarter model's cuts, at most one plane per direction)");
      }
      if (settings.body_force.dot(c.plane_normal) != 0.0)
        throw std::invalid_argument("solver: mirror plane '" + c.name + "': the body force has a component across "
                                    "the plane, which its mirror image reverses: model the whole body");
      mirror.planes.push_back({c.plane_point, c.plane_normal, k});
    }
    if (!mirror.active()) return;
    if (mirror.planes.size() > 8) throw std::invalid_argument("solver: at most 8 mirror planes");
    // The surface treatments (an elastic material's automatic defaults), then the others.
    // The wall gradient acts on velocity walls and moving smooth walls only: without
    // either (a quarter Taylor bar) it is no option to refuse.
    const bool wall_gradient_acts = std::any_of(boundaries.begin(), boundaries.end(), [](const auto& c) {
      return c.kind == BoundaryCondition<Dim>::Kind::velocity || c.moving_smooth_wall();
    });
    const std::array<bool, 4> treatment_on = {
        settings.surface_extrapolation == Toggle::on, settings.hourglass_coefficient > 0,
        settings.velocity_wall == SolverSettings<Dim>::VelocityWall::wall_gradient && wall_gradient_acts,
        settings.free_edge_uniaxial == Toggle::on};
    const std::array<const char*, 4> treatment_key = {"method.surface_extrapolation", "method.hourglass",
                                                      "method.velocity_wall = \"wall_gradient\"",
                                                      "method.free_edge_uniaxial"};
    const char* surface_treatment = nullptr;
    bool treatment_automatic = false;
    for (std::size_t k = 0; k < treatment_on.size() && !surface_treatment; ++k)
      if (treatment_on[k]) surface_treatment = treatment_key[k], treatment_automatic = automatic_surface_treatments_[k];
    const char* option = settings.conservative_momentum ? "method.conservative_momentum"
                         : surface_treatment            ? surface_treatment
                         : settings.deficient_stencils != SolverSettings<Dim>::DeficientStencils::keep
                             ? "method.deficient_stencils other than \"keep\""
                             : nullptr;
    if (option)
      throw std::invalid_argument(
          std::string("solver: ") + option +
          " is not available with mirror planes yet (it reads per-boundary-particle state that the ghosts do not "
          "carry): turn it off, or model the whole body" +
          (option == surface_treatment && treatment_automatic
               ? (takes_elastic_treatments<Dim>(material.plastic())
                      ? std::string(" (an elastic material in 2D and 3D takes the surface treatments by default: set "
                                    "method.hourglass = 0, method.velocity_wall = \"characteristics\" and "
                                    "method.surface_extrapolation = false" +
                                    std::string(Dim == 3 ? ", and in 3D method.free_edge_uniaxial = false" : "") +
                                    "; the whole body's default also has "
                                    "method.hourglass_stiffness = 0.05, which mirror planes keep)")
                      : std::string(" (every material in 2D and 3D takes it by default for its velocity walls and "
                                    "moving smooth walls: set method.velocity_wall = \"characteristics\")"))
               : std::string()));
    if (find_driven_condition() >= 0)
      throw std::invalid_argument("solver: mirror planes in a driven body (one velocity condition on every "
                                  "particle): the motion is prescribed everywhere already; drop the planes");
  }

  /// The driven_condition of the real set's boundary tags.
  std::int32_t find_driven_condition() const {
    if (real.size() == 0) return -1;
    const std::int32_t k = real.boundary[0];
    if (k < 0 || static_cast<std::size_t>(k) >= boundaries.size() ||
        boundaries[static_cast<std::size_t>(k)].kind != BoundaryCondition<Dim>::Kind::velocity)
      return -1;
    for (std::int32_t b : real.boundary)
      if (b != k) return -1;
    return k;
  }
  /// Whether the whole motion is prescribed (driven_condition).
  bool driven() const { return driven_condition >= 0; }
  /// A driven body's prescribed velocity at time t of the material point of initial
  /// position x0 (virtual or real).
  Vec driven_velocity(const Vec& x0, double t) const {
    const BoundaryCondition<Dim>& c = boundaries[static_cast<std::size_t>(driven_condition)];
    return c.prescribed(x0, c.profile(x0), t);
  }

  /// Fills BoundaryParticles::extra_plane from the symmetry conditions' also_on_plane ids.
  void assign_extra_planes() {
    boundary.extra_plane.assign(boundary.size(), {-1, -1});
    if constexpr (Dim == 1) return;  // an end point is on one plane: its last condition wins
    std::vector<std::int64_t> index_of_id;
    for (std::size_t k = 0; k < boundaries.size(); ++k) {
      const auto& condition = boundaries[k];
      if (condition.also_on_plane.empty()) continue;
      if (condition.kind != BoundaryCondition<Dim>::Kind::symmetry)
        throw std::invalid_argument("solver: boundary condition '" + condition.name +
                                    "' lists particles on its plane but is not a symmetry plane");
      if (index_of_id.empty()) {
        std::uint32_t largest = 0;
        for (std::uint32_t id : real.id) largest = std::max(largest, id);
        index_of_id.assign(static_cast<std::size_t>(largest) + 1, -1);
        for (std::size_t i = 0; i < real.size(); ++i) index_of_id[real.id[i]] = static_cast<std::int64_t>(i);
      }
      for (std::uint32_t id : condition.also_on_plane) {
        const std::int64_t i = id < index_of_id.size() ? index_of_id[id] : -1;
        const std::int32_t b = i >= 0 ? boundary.slot[static_cast<std::size_t>(i)] : -1;
        if (b < 0)
          throw std::invalid_argument("solver: symmetry plane '" + condition.name + "' lists particle id " +
                                      std::to_string(id) + ", which has no boundary condition");
        auto& planes = boundary.extra_plane[static_cast<std::size_t>(b)];
        const auto k32 = static_cast<std::int32_t>(k);
        if (real.boundary[static_cast<std::size_t>(i)] == k32 || planes[0] == k32 || planes[1] == k32) continue;
        const int held = (planes[0] >= 0) + (planes[1] >= 0);
        if (held >= Dim - 1)
          throw std::invalid_argument(
              "boundary condition '" + condition.name + "': real particle " + std::to_string(id) +
              " would keep to " + std::to_string(held + 1) + " symmetry planes besides its own condition '" +
              boundaries[static_cast<std::size_t>(real.boundary[static_cast<std::size_t>(i)])].name +
              "'; in " + std::to_string(Dim) + "D a particle keeps to at most " + std::to_string(Dim - 1) +
              " further planes: make the regions meet at most at a corner (one plane per direction)");
        planes[static_cast<std::size_t>(held)] = k32;
      }
    }
  }

  /// Real particle i's share of the modelled part: 1, or 1/2 per mirror plane it lies on
  /// (its image across the plane is itself: the mirrored body holds it once, not twice).
  double share(std::size_t i) const { return mirror.share.empty() ? 1.0 : mirror.share[i]; }
  double support_radius() const { return kSupportFactor * settings.smoothing_length; }
  /// Updated Lagrangian: the particles move.
  bool positions_move() const { return settings.kinematics == Kinematics::updated_lagrangian; }
  /// Updated Lagrangian with SolverSettings::material_velocity_motion.
  bool moves_with_material_velocity() const { return positions_move() && settings.material_velocity_motion; }
  /// Updated Lagrangian: the stress rate carries the Jaumann terms.
  bool objective_rates() const { return settings.kinematics == Kinematics::updated_lagrangian; }
  /// Updated Lagrangian: d rho / dt = -rho div v.
  bool density_follows() const { return settings.kinematics == Kinematics::updated_lagrangian; }
  /// Updated Lagrangian with the kernel in the reference configuration
  /// (SolverSettings::kernel_configuration): the lists are searched once, at X.
  bool reference_kernel() const {
    return positions_move() && settings.kernel_configuration == SolverSettings<Dim>::KernelConfiguration::reference;
  }
  /// The reference stencil of a row (query point's initial position, sources' initial
  /// positions), passed to compute_stencil when reference_kernel().
  static ReferenceStencil<Dim> reference_stencil(const Vec& query_initial_position, const ParticleSet<Dim>& source_set) {
    return {query_initial_position, initial_points_of<Dim>(source_set)};
  }
  /// The skin in length units (SolverSettings::neighbor_skin x 2h), 0 in small strain
  /// and with the reference kernel (lists never outdated).
  double skin_distance() const {
    return positions_move() && !reference_kernel() ? settings.neighbor_skin * support_radius() : 0.0;
  }
  /// Radius of the neighbour searches: 2h plus the skin.
  double list_radius() const { return support_radius() + skin_distance(); }

  /// In updated-Lagrangian runs without skin each half-step list is rebuilt every step
  /// and used once, so only one is held at a time: virtual_from_real from the rebuild to
  /// the half step, real_from_virtual built at the start of the full step (half the
  /// memory of the lists). Not with the hourglass stiffness, which reads both lists
  /// after the full step; the full step then uses the list built at n, with the midpoint
  /// positions.
  bool lists_used_once() const {
    return settings.lists_used_once();
  }

  /// Whether the pair (a_i, b_j) of a neighbour row lies within the support 2h. Without
  /// skin every row holds only such pairs; with a skin, rows also hold pairs up to
  /// 2h + skin, which every use of a row that does not go through kernel weights (those
  /// are exactly 0 beyond 2h) must skip.
  bool within_support(const PointsView<Dim>& a, std::size_t i, const PointsView<Dim>& b, std::size_t j) const {
    if (skin_distance() == 0.0) return true;
    const double radius = support_radius();
    return squared_distance<Dim>(a, i, b, j) <= radius * radius;
  }

  /// The plastic state of real particle i (a plastic material: the real set carries
  /// the fields; ParticleSet::plastic_strain).
  PlasticState plastic_state_of(std::size_t i) const {
    PlasticState p;
    p.equivalent_plastic_strain = real.plastic_strain[i];
    p.plastic_work = real.plastic_work[i];
    p.temperature = real.temperature[i];
    StressVector<Dim> back;
    for (int c = 0; c < stress_count; ++c) back[c] = real.back_stress[c][i];
    p.back_stress = to_tensor<Dim>(back);
    p.yielding = real.yielding[i] != 0;
    return p;
  }
  void store_plastic_state(std::size_t i, const PlasticState& p) {
    real.plastic_strain[i] = p.equivalent_plastic_strain;
    real.plastic_work[i] = p.plastic_work;
    real.temperature[i] = p.temperature;
    const StressVector<Dim> back = from_tensor<Dim>(p.back_stress);
    for (int c = 0; c < stress_count; ++c) real.back_stress[c][i] = back[c];
    real.yielding[i] = p.yielding ? 1 : 0;
  }
  /// A virtual particle's plastic state at n: interpolated from its real row `nb` with
  /// the half step's interpolation weights (the plastic strain kept >= 0).
  PlasticState interpolated_plastic_state(std::span<const std::uint32_t> nb, const double* weight) const {
    PlasticState p;  // what the model does not read (Material::reads_*) stays zero
    for (std::size_t k = 0; k < nb.size(); ++k) p.equivalent_plastic_strain += weight[k] * real.plastic_strain[nb[k]];
    p.equivalent_plastic_strain = std::max(p.equivalent_plastic_strain, 0.0);
    if (material.reads_temperature())
      for (std::size_t k = 0; k < nb.size(); ++k) p.temperature += weight[k] * real.temperature[nb[k]];
    if (material.reads_back_stress()) {
      StressVector<Dim> back{};
      for (std::size_t k = 0; k < nb.size(); ++k)
        for (int c = 0; c < stress_count; ++c) back[c] += weight[k] * real.back_stress[c][nb[k]];
      p.back_stress = to_tensor<Dim>(back);
    }
    return p;
  }
  /// The stress update of real particle i: elastic, or plastic with the particle's state,
  /// stored back when `keep_state` (not where a boundary stage replaces the stress).
  StressVector<Dim> update_real_stress(std::size_t i, const StressUpdate<Dim>& in, bool keep_state) {
    if (!material.plastic()) return material.update_stress(in);
    PlasticState p = plastic_state_of(i);
    const StressVector<Dim> updated = material.update_stress(in, p);
    if (keep_state) store_plastic_state(i, p);
    return updated;
  }
  /// A boundary stage's stress of real particle i, reached elastically over dt, returned
  /// to the yield surface (plastic materials) with the particle's state at n.
  StressVector<Dim> return_real_stress(std::size_t i, const StressVector<Dim>& trial, double dt) {
    if (!material.plastic()) return trial;
    PlasticState p = plastic_state_of(i);
    const StressVector<Dim> updated = material.return_map(trial, p, dt);
    store_plastic_state(i, p);
    return updated;
  }

  static StressVector<Dim> stress_of(const ParticleSet<Dim>& set, std::size_t i) {
    StressVector<Dim> s;
    for (int c = 0; c < stress_count; ++c) s[c] = set.stress[c][i];
    return s;
  }
  Vec initial_position_of(std::size_t i) const {
    Vec x;
    for (int d = 0; d < Dim; ++d) x[d] = real.initial_position[d][i];
    return x;
  }
  Vec velocity_of(std::size_t i) const {
    Vec v;
    for (int d = 0; d < Dim; ++d) v[d] = real.velocity[d][i];
    return v;
  }
  /// The boundary condition of a real particle that has one.
  const BoundaryCondition<Dim>& condition_of(std::size_t i) const {
    return boundaries[static_cast<std::size_t>(real.boundary[i])];
  }

  void add(const StencilCounts& counts) {
    counters.empty_stencils += counts.empty;
    counters.interpolation_fallbacks += counts.interpolation;
    counters.gradient_fallbacks += counts.gradient;
    counters.widened_stencils += counts.widened;
  }

 private:
  /// Which of the surface treatments that mirror planes refuse (the extrapolation, the
  /// filter, the wall gradient, the free edges; check_mirror_planes's order) came from
  /// the automatic defaults (resolve_automatic_options): the refusal of one of them then
  /// names the keys to set.
  std::array<bool, 4> automatic_surface_treatments_{};

  void check_settings() const {
    if (!(settings.smoothing_length > 0.0) || !std::isfinite(settings.smoothing_length))
      throw std::invalid_argument("solver: smoothing length h = " + std::to_string(settings.smoothing_length) +
                                  " must be positive");
    if (!(settings.damping >= 0.0) || !std::isfinite(settings.damping))
      throw std::invalid_argument("solver: damping = " + std::to_string(settings.damping) + " must be >= 0");
    if (!(settings.hourglass_coefficient >= 0.0 && settings.hourglass_coefficient < 1.0))
      throw std::invalid_argument("solver: hourglass coefficient = " +
                                  std::to_string(settings.hourglass_coefficient) + " must lie in [0, 1)");
    if (!(settings.hourglass_stiffness >= 0.0 && settings.hourglass_stiffness <= 1.0))
      throw std::invalid_argument("solver: hourglass stiffness = " + std::to_string(settings.hourglass_stiffness) +
                                  " must lie in [0, 1]");
    if (!(settings.reorder_threshold > 1.0) || !std::isfinite(settings.reorder_threshold))
      throw std::invalid_argument("solver: reorder threshold = " + std::to_string(settings.reorder_threshold) +
                                  " must be > 1");
    if (!(settings.neighbor_skin >= 0.0 && settings.neighbor_skin <= 1.0))
      throw std::invalid_argument("solver: neighbour skin = " + std::to_string(settings.neighbor_skin) +
                                  " must lie in [0, 1] (a fraction of the support radius 2h)");
    if (real.size() == 0 || virtual_.size() == 0)
      throw std::invalid_argument("solver: needs at least one real and one virtual particle");
    if (settings.volumetric_average == Toggle::on && !(Dim >= 2 && material.pressure_independent_yield()))
      throw std::invalid_argument(
          "solver: volumetric_average (method.volumetric_average) applies to a plastic material whose yield does "
          "not depend on the pressure (j2, johnson_cook, drucker_prager with friction_angle = 0 and no "
          "tension_cutoff) in 3D or in plane strain; this run has " +
          std::string(material.name()) + " in " + std::to_string(Dim) + "D: leave the key out");
    if (settings.volumetric_average == Toggle::on && settings.lists_used_once())
      throw std::invalid_argument(
          "solver: volumetric_average (method.volumetric_average) takes its stencils from neighbour lists kept "
          "across the step: with method.kernel_configuration = \"current\" set solver.neighbor_skin > 0 or "
          "method.hourglass_stiffness > 0 (or leave the key out)");
    if (settings.free_edge_uniaxial == Toggle::on && Dim != 3)
      throw std::invalid_argument("solver: free_edge_uniaxial applies to the edges of 3D bodies only (dimension " +
                                  std::to_string(Dim) + ")");
  }
};

}  // namespace tsph
