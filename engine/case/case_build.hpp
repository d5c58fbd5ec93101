// The one case builder: particles, boundary conditions, material, solver settings,
// time step and exact solution of a CaseFile (read from TOML, or written in code with
// load_case_text). `tsph run`, `tsph check`, `tsph table1`, `tsph spectrum`,
// `tsph converge`, the tests and the benchmark block all build their runs here.
#pragma once

#include "engine/boundary_condition.hpp"
#include "engine/case/case_file.hpp"
#include "engine/elasticity.hpp"
#include "engine/taylor_sph.hpp"
#include "engine/validation/exact_solution.hpp"

#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace tsph {

/// dt = cfl dx / c_p (c_p the material's p-wave speed), or the case's fixed time.dt:
/// the one place the time step of a case is computed.
double case_time_step(const CaseFile& c);

/// The p-wave speed of the case's material (plane stress in 2D where the case says so).
double case_wave_speed(const CaseFile& c);

template <int Dim>
struct BuiltCase {
  ParticleSet<Dim> real, virtual_particles;
  std::vector<BoundaryCondition<Dim>> conditions;
  std::vector<std::pair<std::string, std::size_t>> boundary_counts;  ///< real particles per condition
  std::optional<Material<Dim>> material;
  SolverSettings<Dim> settings;
  double dt = 0.0, wave_speed = 0.0;
  std::shared_ptr<const ExactSolution<Dim>> exact;  ///< null: the case names none
};

/// Builds the case (not the solver). Throws CaseError (bad geometry, a region that
/// selects nothing, a malformed particle file, a time.dt above the stability limit).
template <int Dim>
BuiltCase<Dim> build_case(const CaseFile& c);

/// The automatic method options of a case as the run resolves them (the solver's rule,
/// resolve_automatic_options), and the neighbour lists it keeps: for the memory estimate,
/// the restart record, summary.json and `tsph check`, which read the case before a
/// solver exists.
struct ResolvedMethodOptions {
  double hourglass = 0.0;
  double hourglass_stiffness = 0.0;
  bool wall_gradient = false;
  bool surface_extrapolation = false;
  bool free_edge_uniaxial = false;
  bool volumetric_average = false;  ///< SolverSettings::volumetric_average
  /// Updated Lagrangian with the kernel in the reference configuration (the default):
  /// the lists of X, searched once (SolverState::reference_kernel).
  bool reference_lists = false;
  /// The Verlet skin in effect: the case's with the current kernel of updated
  /// Lagrangian, else 0 (its lists never move, or are never searched again).
  double neighbor_skin = 0.0;
};
ResolvedMethodOptions resolved_method_options(const CaseFile& c);

/// The solver of a built case; takes the particles out of `b`. Throws CaseError for
/// what only the solver can check (a traction inside the body, ...).
template <int Dim>
TaylorSph<Dim> make_solver(const CaseFile& c, BuiltCase<Dim>& b);

/// Time steps to reach the end, landing on every output time (as the run does).
std::int64_t count_steps(const CaseFile& c, double dt);

}  // namespace tsph
