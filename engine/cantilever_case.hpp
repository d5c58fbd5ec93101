// The cantilever of seed section 4.2 (reference README section 2): a beam
// 0 <= x <= L, |y| <= D/2 (and |z| <= B/2 in 3D), clamped at x = 0, loaded at x = L by
// the parabolic shear traction of the exact solution, brought to rest by a load ramp
// and velocity damping (dynamic relaxation). 2D: plane stress or plane strain against
// Timoshenko & Goodier (seed eqs. 5-6); 3D: against Timoshenko beam theory.
#pragma once

#include "engine/input_error.hpp"
#include "engine/taylor_sph.hpp"

#include <functional>
#include <memory>
#include <utility>
#include <string>
#include <vector>

namespace tsph {

template <int Dim>
struct CantileverSettings {
  static_assert(Dim == 2 || Dim == 3, "the cantilever is a 2D or 3D case");
  double length = 1.0;   ///< L (m)
  double depth = 0.1;    ///< D (m), along y (the load direction)
  double width = 0.1;    ///< B (m), along z (3D only)
  int nodes_x = 101;     ///< real particles along x (dx = L / (nodes_x - 1))
  int nodes_y = 11;      ///< along y; must give the same spacing as x
  int nodes_z = 11;      ///< along z (3D)
  double young_modulus = 8e7;
  double poisson_ratio = 0.3;
  double density = 2000.0;
  double load = Dim == 2 ? 1000.0 : 100.0;  ///< P (N; per unit thickness in 2D)
  PlaneMode plane_mode = PlaneMode::plane_stress;
  double alpha = 0.6;
  double cfl = 0.9;
  bool force = false;    ///< accept a CFL above the stability limit 1 (to study it)
  KernelKind kernel = KernelKind::cubic_spline;
  /// The exact solutions are those of linear elasticity: small strain by default.
  Kinematics kinematics = Kinematics::small_strain;
  double damping = -1.0;       ///< c (1/s); < 0: 2 omega_1 (critical for the first mode)
  double ramp_time = -1.0;     ///< load ramp (s); < 0: one first-mode period
  double hourglass = 0.02;     ///< surface hourglass filter coefficient
  // The defaults (wall clamp, hourglass stiffness 0.05, surface extrapolation, and in 3D
  // the free edges' uniaxial stress) bring the beam to rest with the error falling at
  // second order in 2D (101 x 11: 0.38 % at the tip; 161 x 17: 0.15 %, but a slow drift
  // remains at 6 s) and give the Timoshenko beam in 3D (README, The cantilever). Without
  // free_edge_uniaxial the 3D beam's free edges carry its shear force (-86 %).
  double hourglass_stiffness = 0.05;  ///< kappa (SolverSettings); 0: off
  /// Stress update of the clamped particles (SolverSettings::velocity_wall).
  typename SolverSettings<Dim>::VelocityWall clamp = SolverSettings<Dim>::VelocityWall::wall_gradient;
  bool surface_extrapolation = true;      ///< SolverSettings::surface_extrapolation
  bool free_edge_uniaxial = Dim == 3;     ///< SolverSettings::free_edge_uniaxial (3D only)
  double end_time = 3.0;       ///< give up after this simulated time (s)
  double tolerance = 1e-5;     ///< converged when |tip velocity| < tolerance * tip_exact / T1
  /// ... and the kinetic energy < kinetic_tolerance * P |tip_exact| (the work of the
  /// load on the exact static deflection): the tip particle alone can be slow while the
  /// rest of the beam still moves (the 3D beam without free_edge_uniaxial was "at rest"
  /// by the tip with 3e-3 of that work as kinetic energy; README, The cantilever).
  double kinetic_tolerance = 1e-5;
  std::function<void(double time, double tip, double kinetic)> progress;  ///< optional

  double spacing() const { return length / (nodes_x - 1); }
  double second_moment() const;            ///< I: D^3/12 (2D), B D^3/12 (3D)
  double first_mode_frequency() const;     ///< omega_1, Euler-Bernoulli (rad/s)
};

template <int Dim>
std::vector<InputError> validate(const CantileverSettings<Dim>& settings);

/// Exact static solution: Timoshenko & Goodier in 2D (plane strain by E' = E/(1-nu^2),
/// nu' = nu/(1-nu)); Timoshenko beam (shear coefficient 5/6) in 3D.
template <int Dim>
class CantileverExact {
 public:
  explicit CantileverExact(const CantileverSettings<Dim>& settings) : s_(settings) {}
  /// Vertical displacement of the point initially at x (on the axis y = z = 0 in 3D).
  double deflection(double x, double y) const;
  double tip_deflection() const { return deflection(s_.length, 0.0); }
  /// The parabolic shear traction at the tip, per unit area, at height y.
  double tip_shear(double y) const;

 private:
  CantileverSettings<Dim> s_;
};

struct CantileverResult {
  bool converged = false;
  double time = 0.0;                   ///< simulated time reached
  std::int64_t steps = 0;
  double time_step = 0.0;
  double wall_seconds = 0.0;
  double particle_steps_per_second = 0.0;
  std::size_t real_particles = 0, virtual_particles = 0;
  double tip_deflection = 0.0, tip_exact = 0.0, tip_error_percent = 0.0;
  std::vector<double> axis_x, axis_uy, axis_exact;  ///< particles on the axis
  double axis_l2_error_percent = 0.0;
  double kinetic_energy = 0.0;         ///< at the end (J; per unit thickness in 2D)
  double load_work = 0.0;              ///< P |tip_exact|, the scale of kinetic_tolerance (J)
  /// Every 0.02 s of simulated time: time, tip u_y, kinetic energy (history.csv).
  std::vector<std::array<double, 3>> history;
  SolverCounters counters;
  /// Every real particle: initial position, displacement, velocity, stress (for CSV output).
  std::vector<std::array<double, 3>> initial_position, displacement, velocity;
  std::vector<std::array<double, 6>> stress;
};

/// The cantilever's solver and what a run needs around it (run_cantilever, and the
/// spectrum tool, tools/tsph_spectrum.cpp, which applies single steps to it).
template <int Dim>
struct CantileverModel {
  std::unique_ptr<TaylorSph<Dim>> solver;
  double time_step = 0.0;   ///< dt = CFL dx / c_p
  double period = 0.0;      ///< first-mode period T1 (s)
  double ramp = 0.0;        ///< load ramp time (s)
  std::size_t tip = 0;      ///< the real particle at the tip on the axis
  std::vector<std::size_t> axis;  ///< the real particles on the axis
  /// The solver's boundary conditions (free surface, tip shear, clamp), for building
  /// another solver on the same case.
  std::vector<BoundaryCondition<Dim>> conditions;
};

/// Builds the particles, conditions and solver of the cantilever (throws on invalid
/// settings).
template <int Dim>
CantileverModel<Dim> make_cantilever(const CantileverSettings<Dim>& settings);

/// The cantilever run diverged (SolutionDiverged's diagnosis in what()); `last_good`
/// holds the last state recorded before it (every 0.02 s of simulated time, and the
/// initial state), so that the tool can write it instead of nothing.
class CantileverDiverged : public SolutionDiverged {
 public:
  CantileverDiverged(const std::string& message, CantileverResult state)
      : SolutionDiverged(message), last_good(std::move(state)) {}
  CantileverResult last_good;
};

/// Runs the case to rest (or to end_time). Throws std::invalid_argument for invalid
/// settings and CantileverDiverged when the stepper detects a divergence.
template <int Dim>
CantileverResult run_cantilever(const CantileverSettings<Dim>& settings);

}  // namespace tsph
