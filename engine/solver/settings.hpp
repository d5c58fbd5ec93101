// What a run of the stepper is told (SolverSettings) and what it counts (SolverCounters).
// The measurements behind the defaults are in docs/ (docs/architecture.md points to
// them) and bench/RESULTS.md; here each option says what it does.
#pragma once

#include "engine/particle_set.hpp"
#include "kernels/corrected_operators.hpp"
#include "kernels/smoothing_kernels.hpp"
#include "neighbor/neighbor_search.hpp"
#include "neighbor/spatial_order.hpp"

#include <cstddef>
#include <cstdint>
#include <limits>
#include <string_view>
#include <vector>

namespace tsph {

/// small_strain: particles stay at their initial positions and the density is fixed
/// (geometrically linear, the setting of the seed's bar and of its exact solution).
/// updated_lagrangian: particles move with the material, density follows
/// d rho/dt = -rho div v, and the stress rate carries the Jaumann terms.
enum class Kinematics { small_strain, updated_lagrangian };

inline std::string_view to_string(Kinematics k) {
  return k == Kinematics::small_strain ? "small_strain" : "updated_lagrangian";
}

/// The value of a numeric method option (SolverSettings::hourglass_coefficient,
/// hourglass_stiffness) that asks for its default; resolved once per run by
/// resolve_automatic_options, where the rule and the measurements behind it are cited.
inline constexpr double kAutomaticOption = -1.0;

/// An on/off method option whose default depends on the run (resolve_automatic_options).
enum class Toggle : std::int8_t { automatic, off, on };

template <int Dim>
struct SolverSettings {
  double smoothing_length = 0.0;  ///< h; the support radius is 2h
  KernelKind kernel = KernelKind::cubic_spline;
  InterpolationKind interpolation = InterpolationKind::linear;
  Kinematics kinematics = Kinematics::small_strain;
  Vector<Dim> body_force = Vector<Dim>::Zero();  ///< b, per unit mass
  /// Velocity damping c (1/s): dv/dt = ... - c v (dynamic relaxation to a static state).
  double damping = 0.0;
  /// Book the work of the boundaries, the body force, the damping and the stabilisations
  /// (SolverState::energy, energy_ledger.hpp): a copy of v^n and two or three passes over
  /// the real particles per step. Off: none.
  bool energy_ledger = false;
  /// Surface hourglass filter epsilon in [0, 1): the velocity of every real particle on a
  /// traction surface is relaxed towards the linear-corrected average of its real
  /// neighbours, v <- (1 - eps) v + eps vbar (stabilisation/surface_filter.hpp).
  /// kAutomaticOption: resolve_automatic_options (0.02 in 2D and 3D).
  double hourglass_coefficient = kAutomaticOption;
  /// Hourglass stiffness kappa in [0, 1]: a restoring force on the part of the real
  /// displacement field that the virtual particles cannot see, k = kappa M / h^2 per unit
  /// volume (stabilisation/hourglass_stiffness.hpp). 0: off. kAutomaticOption:
  /// resolve_automatic_options (0.05 for an elastic material in 2D and 3D).
  double hourglass_stiffness = kAutomaticOption;
  /// Where the hourglass stiffness reads the displacement for its kick: predicted (the
  /// default), at the displacement the step is heading for, u^n + dt/2 (v^n + v*) with v*
  /// the full step's velocity, which damps the spring's own oscillation by
  /// k dt^2 / (4 rho) per step; midpoint (before 2026-11-29), at u^n + dt/2 v^n, which
  /// keeps it and lets a through-thickness mode of the Taylor step grow at alpha 1.2
  /// (stabilisation/hourglass_stiffness.hpp; docs/notes/2026-11-29-hourglass-kick.md).
  enum class HourglassKick { predicted, midpoint };
  HourglassKick hourglass_kick = HourglassKick::predicted;
  /// What the hourglass stiffness's residual is measured from in a plastic material
  /// (an elastic one always takes the initial configuration): flow (the default since
  /// 2026-12-07), where a particle yields in a step, the smooth part of its residual (the
  /// round trip of the residual, R A r) is taken into its reference
  /// (ParticleSet::hourglass_reference), so the spring restores the invisible modes but
  /// not the curvature of the plastic flow; initial (before), the residual of the total
  /// displacement, which resists the flow (the quarter Taylor bar's radius -5.1 % at
  /// R0 / 8 and R0 / 10; with flow and the wall-free edge -4.3 % and -3.4 %, where flow
  /// alone diverged at R0 / 10 from the rim: stabilisation/hourglass_stiffness.hpp,
  /// docs/notes/2026-12-07-wall-free-edge.md).
  enum class HourglassReference { flow, initial };
  HourglassReference hourglass_reference = HourglassReference::flow;
  /// Stress of the particles on a prescribed-velocity surface (a clamp): by the
  /// characteristic relations (boundary/characteristics.hpp; exact for the 1D bar), or by
  /// the bulk update with the velocity gradient taken relative to the wall velocity
  /// (boundary/wall_gradient.hpp). automatic: resolve_automatic_options (wall_gradient in
  /// 2D and 3D).
  enum class VelocityWall { automatic, characteristics, wall_gradient };
  VelocityWall velocity_wall = VelocityWall::automatic;
  /// Momentum update of the particles without a velocity condition or a load in
  /// conservative (weak) form, m_I dv_I/dt = -sum_v V_v sigma_v . D_vI
  /// (boundary/conservative_momentum.hpp). Its forces exert no net torque: a free
  /// spinning body keeps its angular momentum (docs/notes/2026-11-26-rotation-drift.md),
  /// but the first row inside free faces is not linear-exact (the large-deflection
  /// cantilever is 10 % too soft). Off by default; case key method.conservative_momentum.
  bool conservative_momentum = false;
  /// The tangential velocity gradient of traction-free surface particles extrapolated
  /// from their virtual stencil's centroid to the surface (stabilisation/
  /// surface_extrapolation.hpp). automatic: resolve_automatic_options (on in 2D and 3D).
  Toggle surface_extrapolation = Toggle::automatic;
  /// 3D only: a zero-traction particle on a convex axis-parallel edge takes the uniaxial
  /// stress along the edge (boundary/free_edge.hpp). automatic: resolve_automatic_options
  /// (on for an elastic material in 3D).
  Toggle free_edge_uniaxial = Toggle::automatic;
  /// 2D and 3D, a plastic material whose yield does not depend on the pressure: the
  /// yielding interior particles' pressure and density follow the volumetric rate
  /// averaged over their neighbourhood, R A tr L, instead of their own (B-bar;
  /// stabilisation/volumetric_average.hpp). automatic: resolve_automatic_options (on
  /// wherever it applies).
  Toggle volumetric_average = Toggle::automatic;
  /// Updated Lagrangian: the real particles move with the velocity the stress sees, the
  /// virtual half-step velocity interpolated at the particle (x^{n+1} = x^n + dt
  /// v^{n+1/2}, midpoint rule; solver/kinematics.hpp), instead of the trapezoid of their
  /// own v^n and v^{n+1}. Their own velocity carries the two-step scheme's
  /// -dt/2 div sigma / rho at rest (docs/notes/2026-11-25-large-deflection.md): moved by
  /// it the body drifts and shears with no stress (the large-deflection cantilever
  /// diverges). On by default; off: the former trapezoid.
  bool material_velocity_motion = true;
  /// Updated Lagrangian with material_velocity_motion: the motion velocity of a free or
  /// loaded surface particle whose full-step row is on Shepard's weights (no linear
  /// interpolation: alpha 0.6 faces, edges and corners, 3D faces the interpolation guard
  /// keeps on Shepard). linear (the default): the linear interpolation of the row widened
  /// as for deficient_stencils (the virtual particles of its real neighbours, h x 1.5 or
  /// 2; Shepard's value where none is regular). shepard: the row's Shepard value, the
  /// velocity at its centroid dx/2 inside, with which the faces of a bent beam lagged
  /// their sections by 26 % (docs/notes/2026-11-28-surface-motion.md). The row's update
  /// (stress, velocity) is not changed. A case with mirror planes keeps shepard (the
  /// widened row does not see a mirror ghost's virtual neighbours).
  enum class SurfaceMotion { shepard, linear };
  SurfaceMotion surface_motion = SurfaceMotion::linear;
  /// Updated Lagrangian, experimental (issue 14; docs/notes/2026-11-25-deficient-stencils.md):
  /// a boundary particle whose full-step stencil is rank-deficient (a corner at
  /// h / dx = 0.6: one virtual neighbour, zero gradient; an edge: two, no linear
  /// interpolation) may take a widened stencil, the virtual particles of its real
  /// neighbours too with h grown by 1.5 or 2 (solver/full_step.hpp, widen).
  /// keep: the row as it is (the default: widening made the bending cases stiffer);
  /// widen: every deficient row, for the update and the motion; widen_motion: rows with
  /// a deficient gradient for both, rows with only a deficient interpolation for the
  /// motion velocity alone; complete: a free or loaded surface particle keeps its row for
  /// the update, its motion velocity is carried from the Shepard centroid to the particle,
  /// and the tangential derivatives its stencil misses (a corner) come from a widened
  /// stencil for the characteristic relations (full_step.hpp, complete_deficient_row;
  /// docs/notes/2026-11-28-deficient-surface-rows.md).
  enum class DeficientStencils { keep, widen, widen_motion, complete };
  DeficientStencils deficient_stencils = DeficientStencils::keep;
  /// Updated Lagrangian (issue 14; docs/notes/2026-11-26-reference-kernel.md,
  /// docs/notes/2026-11-29-reference-kernel-default.md): where the kernel is evaluated.
  /// reference (the default since 2026-11-29): at the initial offsets X_J - X_I, the
  /// corrections (gradient, linear interpolation) at the current ones
  /// (kernels/corrected_operators.hpp, ReferenceStencil), so the stencils are those of
  /// the undeformed body (a Lagrangian kernel, Belytschko et al. 2000: no tensile
  /// instability) and the weights stay exact for linear fields of the current
  /// configuration. The lists are searched once, in the reference configuration (no
  /// skin, no rebuild): bodies that tear or mix are out of its reach. current: at the
  /// current offsets x_J - x_I (the stencils deform with the body: a sheared corner or a
  /// compressed face loses its neighbours; the twisting column at alpha 0.6 diverges in
  /// its first 60 steps).
  enum class KernelConfiguration { current, reference };
  KernelConfiguration kernel_configuration = KernelConfiguration::reference;
  /// Search of the neighbour lists: cell list, kd-tree, or `automatic` (the rule of
  /// neighbor/neighbor_search.hpp). Same lists either way.
  NeighborSearch neighbor_search = NeighborSearch::automatic;
  /// The full step's real -> virtual list is the transpose of the half step's list
  /// instead of a second search (both then held at once). Off by default.
  bool transpose_lists = false;
  /// With the reference kernel: the most memory the two half-step lists' kernel factors
  /// may take (solver/kernel_factor_cache.hpp; 16 B per pair and list). Where they need
  /// more they are evaluated at every step, as with 0. Same results either way.
  std::size_t kernel_cache_bytes = std::size_t{256} << 20;
  /// Verlet skin of the updated-Lagrangian neighbour lists with the kernel in the current
  /// configuration (the reference kernel, the default, searches its lists once and
  /// ignores it), a fraction of 2h in [0, 1]: lists searched with radius (1 + s) 2h and
  /// kept until a pair may have come closer by more than s 2h
  /// (solver/neighbor_lists.hpp). 0: searched at every use.
  double neighbor_skin = 0.05;
  /// Both particle sets are sorted into this order when the mean index spread of the
  /// virtual -> real rows exceeds `reorder_threshold` times that of the sorted order
  /// (solver/neighbor_lists.hpp). Sorting renumbers the particles (ids are kept).
  /// `none` (the default): never sorted.
  SpatialOrder spatial_order = SpatialOrder::none;
  double reorder_threshold = 2.0;  ///< > 1
  /// The virtual set keeps the optional fields of ParticleSet (initial positions,
  /// displacements, ids, boundary and group tags) for callers that read them. Off: the
  /// constructor releases those the stepper does not read.
  bool keep_virtual_fields = false;

  /// Updated Lagrangian with the kernel in the current configuration, no skin and no
  /// hourglass stiffness: each half step's list is searched for one use and released
  /// (SolverState::lists_used_once; the hourglass stiffness resolved).
  bool lists_used_once() const {
    return kinematics == Kinematics::updated_lagrangian && kernel_configuration == KernelConfiguration::current &&
           hourglass_stiffness == 0.0 && neighbor_skin == 0.0;
  }

  /// The scheme without the automatic treatments (resolve_automatic_options): surface
  /// filter, hourglass stiffness and surface extrapolation off, walls by the
  /// characteristic relations. What the tests of the scheme's own properties run
  /// (exactness, conservation, objectivity), and the seed's method in 2D and 3D.
  static SolverSettings bare_scheme() {
    SolverSettings s;
    s.hourglass_coefficient = 0.0;
    s.hourglass_stiffness = 0.0;
    s.velocity_wall = VelocityWall::characteristics;
    s.surface_extrapolation = Toggle::off;
    s.free_edge_uniaxial = Toggle::off;
    s.volumetric_average = Toggle::off;
    return s;
  }
};

/// Whether the automatic method options of a run resolve to the elastic treatments:
/// an elastic material in 2D or 3D (resolve_automatic_options).
constexpr bool takes_elastic_treatments(int dimension, bool plastic) { return dimension >= 2 && !plastic; }
template <int Dim>
constexpr bool takes_elastic_treatments(bool plastic) {
  return takes_elastic_treatments(Dim, plastic);
}

/// The settings of a run with every automatic option (kAutomaticOption,
/// VelocityWall::automatic, Toggle::automatic) replaced by its default, the same for
/// the library, every case file and every subcommand (SolverState resolves them; a run's
/// summary.json reports the resolved values). One rule: **an elastic material in 2D or
/// 3D takes the treatments with which the 2D cantilever converges to rest at every
/// resolution** (surface filter 0.02, clamp by the wall gradient, hourglass stiffness
/// 0.05, surface extrapolation; in 3D the free edges' uniaxial stress; they pass the
/// validation suite's elastic cases as each case's own keys did: docs/validation.md,
/// "The defaults"); **everything else takes none** (each option off), except that **in
/// 2D and 3D every material takes the wall gradient** for its velocity walls and moving
/// smooth walls (a footing: by the characteristic relations its work did not converge
/// in dt and the Tresca footing lost 45 % of it; boundary/characteristics.hpp):
///  * 1D has no tangential direction and no mode that the virtual set's gradients do not
///    see; the characteristic relations are exact there (Table 1 at alpha 0.6 to
///    round-off: the wall gradient makes it 10 %, the hourglass stiffness diverges);
///  * a plastic material: the hourglass stiffness, an elastic spring on the total
///    displacement, resists the plastic flow (the footing's plateau +34 % at 0.05, +13 %
///    at 0.01 at B/10); an impact case sets its own (tools/cases/taylor_bar_3d.toml:
///    0.01). The surface treatments are left off with it, so that a quarter model
///    with mirror planes, which cannot carry them, runs the whole model's method.
///  * the volumetric average (B-bar) where it applies: a plastic material in 2D or 3D
///    whose yield does not depend on the pressure (`pressure_independent_yield`,
///    Material::pressure_independent_yield), with lists kept across the step (not
///    lists_used_once: it takes its stencils from them). Isochoric plastic flow
///    otherwise leaves an odd-even pressure in the plastic zone (the footing: +-2 c at every spacing).
/// Mirror planes with an elastic material in 2D or 3D: the automatic surface treatments
/// are refused there with the keys to set (SolverState::check_mirror_planes); with any
/// material the wall gradient, where a velocity wall or a moving smooth wall acts.
template <int Dim>
SolverSettings<Dim> resolve_automatic_options(SolverSettings<Dim> settings, bool plastic,
                                              bool pressure_independent_yield) {
  const bool treatments = takes_elastic_treatments<Dim>(plastic);
  if (settings.hourglass_coefficient == kAutomaticOption) settings.hourglass_coefficient = treatments ? 0.02 : 0.0;
  if (settings.hourglass_stiffness == kAutomaticOption) settings.hourglass_stiffness = treatments ? 0.05 : 0.0;
  if (settings.velocity_wall == SolverSettings<Dim>::VelocityWall::automatic)
    settings.velocity_wall = Dim >= 2 ? SolverSettings<Dim>::VelocityWall::wall_gradient
                                      : SolverSettings<Dim>::VelocityWall::characteristics;
  if (settings.surface_extrapolation == Toggle::automatic)
    settings.surface_extrapolation = treatments ? Toggle::on : Toggle::off;
  // The free edges' uniaxial stress, 3D only (there are no edges in 2D): the 3D
  // cantilever converges with it (without it the edges creep, and the beam in updated
  // Lagrangian diverges); the rotating cube keeps its spin with it since 2026-11-29
  // (docs/notes/2026-11-29-free-edges-in-rotation.md).
  if (settings.free_edge_uniaxial == Toggle::automatic)
    settings.free_edge_uniaxial = treatments && Dim == 3 ? Toggle::on : Toggle::off;
  if (settings.volumetric_average == Toggle::automatic)
    settings.volumetric_average =
        Dim >= 2 && plastic && pressure_independent_yield && !settings.lists_used_once() ? Toggle::on : Toggle::off;
  return settings;
}

/// What the run did; fallbacks are counted per stencil evaluation.
struct SolverCounters {
  std::int64_t steps = 0;
  std::int64_t neighbor_builds = 0;
  std::int64_t empty_stencils = 0;
  std::int64_t interpolation_fallbacks = 0;
  std::int64_t gradient_fallbacks = 0;
  /// Full-step rows widened (SolverSettings::deficient_stencils); their status is
  /// that of the widened stencil.
  std::int64_t widened_stencils = 0;
  std::int64_t reorders = 0;  ///< sorts of the particle sets (SolverSettings::spatial_order)
  /// Renumberings of the particle sets: the sorts and TaylorSph::permute_particles.
  std::int64_t renumberings = 0;
  /// Checks of the displacement since the last search (SolverSettings::neighbor_skin):
  /// two per updated-Lagrangian step with the kernel in the current configuration, none
  /// with the reference kernel (its lists are never searched again).
  std::int64_t skin_checks = 0;
};

/// The accumulated works of SolverSettings::energy_ledger (solver/energy_ledger.hpp),
/// in J (per unit thickness in 2D, per unit area in 1D). Part of a checkpoint: a
/// restarted run books on from them.
struct EnergyLedger {
  std::vector<double> boundary;  ///< per boundary condition (SolverState::boundaries' order): int t . v dA dt
  double body_force = 0.0;       ///< int b . P dt
  double damping = 0.0;          ///< -c int sum_I m_I |v_I|^2 dt
  double hourglass = 0.0;        ///< the hourglass stiffness's work on the particles
  double surface_filter = 0.0;   ///< the surface filter's work (it only takes energy out)
  /// Not a work of the balance: the work of the characteristic boundary's overwrite of
  /// the surface particles' velocities (+: puts energy in), beside the full step's value
  /// (energy_ledger.hpp; energy.csv's `overwrite_work`).
  double boundary_overwrite = 0.0;
  /// Not a work: the energy the hourglass stiffness holds at the last step,
  /// k/2 sum_I V_I |r_I|^2 (stabilisation/hourglass_stiffness.hpp; recomputed every step,
  /// checkpointed for a restart's first row).
  double hourglass_energy = 0.0;
  /// E = kinetic + elastic + plastic work when the ledger started (NaN until then).
  double initial_energy = std::numeric_limits<double>::quiet_NaN();

  /// The works of the balance: E(t) - E(0) = external_work() + the scheme's own error.
  double external_work() const {
    double w = body_force + damping + hourglass + surface_filter;
    for (double b : boundary) w += b;
    return w;
  }
};

}  // namespace tsph
