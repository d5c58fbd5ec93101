// The Taylor-SPH stepper (seed eqs. 3-4; docs/method.md section 3), Dim = 1, 2, 3: the
// solver's state (solver/state.hpp) and the stages of one step n -> n+1, each in its own
// file under engine/solver/ (docs/architecture.md has the map and the data flow).
//
// The flux divergence is written per field: the velocity gradient grad v (which gives
// D : d and the Jaumann spin, seed eq. 1a) and the stress divergence div sigma (seed
// eq. 1b, divided by the density at the particle). The source S (Jaumann terms, body
// force, damping -c v) is evaluated at the particle being updated from its own
// interpolated state and corrected velocity gradient (our choice: the same order of
// accuracy, and no same-set neighbour lists in the bulk).
#pragma once

#include "engine/boundary_condition.hpp"
#include "engine/material/material.hpp"
#include "engine/input_error.hpp"
#include "engine/particle_set.hpp"
#include "engine/solver/boundary/characteristics.hpp"
#include "engine/solver/boundary/conservative_momentum.hpp"
#include "engine/solver/boundary/free_edge.hpp"
#include "engine/solver/energy_ledger.hpp"
#include "engine/solver/full_step.hpp"
#include "engine/solver/half_step.hpp"
#include "engine/solver/kinematics.hpp"
#include "engine/solver/neighbor_lists.hpp"
#include "engine/solver/settings.hpp"
#include "engine/solver/stabilisation/hourglass_stiffness.hpp"
#include "engine/solver/stabilisation/surface_filter.hpp"
#include "engine/solver/stability_monitor.hpp"
#include "engine/solver/state.hpp"
#include "engine/solver/time_step.hpp"

#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace tsph {

template <int Dim>
class TaylorSph {
 public:
  using Vec = Vector<Dim>;
  using Mat = Matrix<Dim>;
  static constexpr int stress_count = stress_component_count<Dim>;

  TaylorSph(ParticleSet<Dim> real, ParticleSet<Dim> virtual_particles, Material<Dim> material,
            SolverSettings<Dim> settings, std::vector<BoundaryCondition<Dim>> boundaries);

  /// Advances the solution by dt: seed eqs. (3) and (4), the boundary conditions and the
  /// stabilisations (advance_fields), the stability check, then the motion and the
  /// neighbour lists (advance_positions).
  void step(double dt);

  /// The stages of step() up to the stability check, in the seed's order (the step map,
  /// engine/analysis/step_map.hpp, runs this and advance_positions).
  void advance_fields(double dt);

  /// NaN/Inf in either set, an unphysical state (density, stress, speed, a particle
  /// that left the body) or a runaway of the energy: throws SolutionDiverged.
  void check_stability(double dt);
  /// Displacements, and in updated Lagrangian the positions and the neighbour lists.
  void advance_positions(double dt);

  /// The stages one at a time (benchmarks): seed eq. (3), seed eq. (4), the lists.
  void half_step(double dt);
  void full_step(double dt);
  void rebuild_neighbors();

  /// The whole state, for the stages run from outside (the step map sets the real
  /// particles' fields before each step).
  SolverState<Dim>& state() { return state_; }
  const SolverState<Dim>& state() const { return state_; }

  double support_radius() const { return state_.support_radius(); }
  /// The skin in length units (SolverSettings::neighbor_skin x 2h), 0 in small strain.
  double skin_distance() const { return state_.skin_distance(); }
  bool positions_move() const { return state_.positions_move(); }
  bool objective_rates() const { return state_.objective_rates(); }
  bool density_follows() const { return state_.density_follows(); }
  /// Radius of the neighbour searches: 2h plus the skin.
  double list_radius() const { return state_.list_radius(); }
  /// The time a p-wave takes to cross the smallest current spacing (no CFL factor), and
  /// where (engine/solver/time_step.hpp; time.adaptive).
  /// With mirror planes the ghosts are attached for the fit (the rows index them).
  typename StableTimeStep<Dim>::Limit stable_time_step() {
    MirrorPlanes<Dim>::attach(state_);
    const auto limit = StableTimeStep<Dim>::compute(state_);
    MirrorPlanes<Dim>::detach(state_);
    return limit;
  }
  double time() const { return state_.time; }
  /// Sets the clock (to land exactly on an output time after round-off).
  void set_time(double t) { state_.time = t; }
  const ParticleSet<Dim>& real() const { return state_.real; }
  const ParticleSet<Dim>& virtual_particles() const { return state_.virtual_; }
  const Material<Dim>& material() const { return state_.material; }
  const SolverSettings<Dim>& settings() const { return state_.settings; }
  const SolverCounters& counters() const { return state_.counters; }
  /// The lists (rows: owned particles). With mirror planes their entries also index the
  /// ghosts, held behind the owned particles during a step only (mirror_planes.hpp):
  /// between steps an entry >= real().size() (virtual_particles().size()) is a ghost.
  const NeighborList& virtual_from_real() const { return state_.lists.virtual_from_real; }
  /// The search of the last rebuild (cell_list or kd_tree; `automatic` resolved).
  NeighborSearch neighbor_search_used() const { return state_.lists.search_used; }
  /// In updated-Lagrangian runs without skin this list is built in the full step and
  /// released by the rebuild at the end of the step (SolverState::lists_used_once):
  /// empty between steps. With a skin both lists are kept (radius list_radius()).
  const NeighborList& real_from_virtual() const { return state_.lists.real_from_virtual; }
  /// Rows: real particles (only the boundary ones filled); entries: real, self excluded.
  const NeighborList& real_from_real() const { return state_.lists.real_from_real; }
  /// Boundary particles (indices into real()) and their outward unit normals.
  const std::vector<std::uint32_t>& boundary_particles() const { return state_.boundary.particle; }
  const std::vector<Vec>& boundary_normals() const { return state_.boundary.normal; }

  /// Renumbers the particles: new real particle k is old real_order[k], new virtual
  /// particle k old virtual_order[k] (each a permutation), with every per-particle state
  /// of the stepper (NeighborLists::permute), and builds the neighbour lists again. The
  /// run goes on as it would have, up to the order of sums (round-off).
  /// SolverSettings::spatial_order does this itself when the order decays.
  void permute_particles(const std::vector<std::uint32_t>& real_order,
                         const std::vector<std::uint32_t>& virtual_order);


  /// SolverSettings::free_edge_uniaxial: the real particles that take the uniaxial stress
  /// of a free edge (boundary/free_edge.hpp). Empty with the option off.
  std::vector<std::uint32_t> free_edge_particles() const;

  /// Kinetic energy sum_I m_I |v_I|^2 / 2 of the real particles (the same bits on any
  /// thread count; with mirror planes, of the modelled part: energy_ledger.hpp).
  double kinetic_energy() const { return EnergyAccounting<Dim>::kinetic(state_); }
  /// Strain energy sum_I V_I w(sigma_I) of the real particles.
  double strain_energy() const { return EnergyAccounting<Dim>::elastic(state_); }
  /// The kinetic and strain energies on the node-and-cell quadrature, exact for
  /// quadratic densities on the lattice (EnergyAccounting::node_and_cell; an
  /// interpolation pass over the virtual particles). A diagnostic for the validation
  /// of free vibrations: kinetic_energy() and strain_energy() stay the ledger's.
  typename EnergyAccounting<Dim>::NodeAndCellEnergies node_and_cell_energies();
  /// Linear momentum sum_I m_I v_I of the real particles (with mirror planes, of the
  /// modelled part: SolverState::share).
  Vec linear_momentum() const {
    Vec p = Vec::Zero();
    const ParticleSet<Dim>& real = state_.real;
    for (std::size_t i = 0; i < real.size(); ++i)
      for (int d = 0; d < Dim; ++d) p[d] += state_.share(i) * real.mass[i] * real.velocity[d][i];
    return p;
  }

 private:
  /// The kernel, the loops' one runtime choice, dispatched once here: f(kernel, material).
  /// The material dispatches its model per particle (elastic inline, plastic out of
  /// line: material/material.hpp), so the stages are compiled once per kernel.
  template <class F>
  void visit_stages(F&& f) {
    visit_kernel<Dim>(state_.settings.kernel, [&](const auto& kernel) { f(kernel, state_.material); });
  }

  SolverState<Dim> state_;
  // The stages that keep scratch between steps; the others are stateless.
  ConservativeMomentum<Dim> momentum_;
  HourglassStiffness<Dim> hourglass_stiffness_;
  EnergyAccounting<Dim> energy_;
  SurfaceHourglassFilter<Dim> surface_filter_;
  StabilityMonitor<Dim> monitor_;
};

// The member functions that run the stages are defined out of the class, so that they are
// not inline: engine/taylor_sph.cpp instantiates TaylorSph<1>, <2> and <3> once, and every
// other translation unit links to those (extern template below) instead of compiling the
// stages again (about 60 s of -O3 each; docs/architecture.md, "Build").
template <int Dim>
TaylorSph<Dim>::TaylorSph(ParticleSet<Dim> real, ParticleSet<Dim> virtual_particles, Material<Dim> material,
                          SolverSettings<Dim> settings, std::vector<BoundaryCondition<Dim>> boundaries)
    : state_(std::move(real), std::move(virtual_particles), std::move(material), std::move(settings),
             std::move(boundaries)) {
  NeighborLists<Dim>::rebuild(state_);
  MirrorPlanes<Dim>::detach(state_);  // between steps the sets hold their own particles
}
template <int Dim>
void TaylorSph<Dim>::step(double dt) {
  if (!(dt > 0.0) || !std::isfinite(dt))
    throw std::invalid_argument("solver: time step dt = " + std::to_string(dt) + " must be positive");
  try {
    advance_fields(dt);
    check_stability(dt);  // a diverged state is reported before it moves any particle
  } catch (...) {
    MirrorPlanes<Dim>::detach(state_);  // the sets hold their own particles for the caller
    throw;
  }
  advance_positions(dt);
  state_.time += dt;
  ++state_.counters.steps;
}

template <int Dim>
void TaylorSph<Dim>::advance_fields(double dt) {
  const SolverSettings<Dim>& settings = state_.settings;
  const double t_new = state_.time + dt;
  visit_stages([&](const auto& kernel, const auto& model) {
    const bool ledger = settings.energy_ledger;
    // Mirror planes: the ghosts, attached for the step (refreshed where a later stage
    // reads through the lists what an earlier one wrote: the first half of the motion,
    // advance_positions; detached at its end).
    MirrorPlanes<Dim>::attach(state_);
    if (ledger) energy_.begin(state_);
    CharacteristicBoundary<Dim>::gradients_at_n(state_, kernel);  // grad U^n at the boundary
    HalfStep<Dim>::apply(state_, kernel, model, dt);                // seed eq. (3): real -> virtual
    Motion<Dim>::first_half(state_, dt);                            // to x^{n+1/2} (or u += dt/2 v^n); ghosts refreshed
    // The weak form's weights in the configuration the full step evaluates in (the
    // midpoint in updated Lagrangian): its forces exert no torque about it, and the
    // spin is kept (docs/notes/2026-11-26-rotation-drift.md; at x^n it grew by
    // omega^2 dt^2 / 2 per step).
    if (settings.conservative_momentum) momentum_.store_weights(state_, kernel);
    FullStep<Dim>::apply(state_, kernel, model, dt);                // seed eq. (4): virtual -> real
    if (ledger) energy_.before_boundary_stage(state_);
    CharacteristicBoundary<Dim>::apply(state_, model, dt, t_new);   // boundary state at n+1
    if (settings.conservative_momentum) momentum_.apply(state_, dt, t_new);
    if (ledger) energy_.after_boundary_stage(state_, /*overwrite=*/true);  // the slots' change
    if (settings.hourglass_stiffness > 0.0) hourglass_stiffness_.apply(state_, kernel, dt);
    if (settings.hourglass_coefficient > 0.0) {
      if (ledger) energy_.before_boundary_stage(state_);
      surface_filter_.apply(state_, kernel);
      if (ledger) energy_.after_boundary_stage(state_, /*overwrite=*/false);
    }
    MirrorPlanes<Dim>::project_on_planes(state_);  // the particles on a plane keep to it
    if (ledger) energy_.end(state_, dt, hourglass_stiffness_.kicks());  // empty with the stiffness off
  });
}

template <int Dim>
typename EnergyAccounting<Dim>::NodeAndCellEnergies TaylorSph<Dim>::node_and_cell_energies() {
  const std::size_t owned_virtual = state_.virtual_.size();  // between steps: the owned ones
  typename EnergyAccounting<Dim>::NodeAndCellEnergies e;
  MirrorPlanes<Dim>::attach(state_);  // the lists' ghost entries need their ghosts
  visit_kernel<Dim>(state_.settings.kernel, [&](const auto& kernel) {
    e = EnergyAccounting<Dim>::node_and_cell(state_, kernel, owned_virtual);
  });
  MirrorPlanes<Dim>::detach(state_);
  return e;
}

template <int Dim>
void TaylorSph<Dim>::check_stability(double dt) {
  monitor_.check(state_, dt);
}

template <int Dim>
void TaylorSph<Dim>::advance_positions(double dt) {
  // After advance_fields: the real set's new state refreshed (the virtual set is as the
  // first half of the motion left it; the second half refreshes its positions).
  MirrorPlanes<Dim>::attach(state_, /*virtual_changed=*/false);
  Motion<Dim>::second_half(state_, dt);
  MirrorPlanes<Dim>::detach(state_);
}

template <int Dim>
void TaylorSph<Dim>::half_step(double dt) {
  MirrorPlanes<Dim>::attach(state_);
  visit_stages([&](const auto& kernel, const auto& model) { HalfStep<Dim>::apply(state_, kernel, model, dt); });
  MirrorPlanes<Dim>::detach(state_);
}
template <int Dim>
void TaylorSph<Dim>::full_step(double dt) {
  MirrorPlanes<Dim>::attach(state_);
  visit_stages([&](const auto& kernel, const auto& model) { FullStep<Dim>::apply(state_, kernel, model, dt); });
  MirrorPlanes<Dim>::detach(state_);
}
template <int Dim>
void TaylorSph<Dim>::rebuild_neighbors() {
  NeighborLists<Dim>::rebuild(state_);
  MirrorPlanes<Dim>::detach(state_);
}

template <int Dim>
void TaylorSph<Dim>::permute_particles(const std::vector<std::uint32_t>& real_order,
                                      const std::vector<std::uint32_t>& virtual_order) {
  // Both checked before anything moves (ParticleSet::permute checks again).
  require_permutation(real_order, state_.real.size(), "solver: permute_particles: the real order");
  require_permutation(virtual_order, state_.virtual_.size(), "solver: permute_particles: the virtual order");
  NeighborLists<Dim>::permute(state_, real_order, virtual_order);
  NeighborLists<Dim>::build(state_);
  MirrorPlanes<Dim>::detach(state_);
  state_.lists.sorted_spread = -1.0;  // the sorted order's spread, measured again at the next rebuild
}

template <int Dim>
std::vector<std::uint32_t> TaylorSph<Dim>::free_edge_particles() const {
  return FreeEdge<Dim>::particles(state_);
}

extern template class TaylorSph<1>;
extern template class TaylorSph<2>;
extern template class TaylorSph<3>;

}  // namespace tsph
