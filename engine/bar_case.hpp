// The 1D elastic bar of seed section 4.1 (reference README section 1): a shock wave
// from a velocity pulse at x = L travelling into a bar held at x = 0.
#pragma once

#include "engine/input_error.hpp"
#include "engine/taylor_sph.hpp"
#include "engine/time_function.hpp"

#include <functional>
#include <string>
#include <vector>

namespace tsph {

struct BarProfile;

enum class BarEnd { fixed, free };
enum class BarLoad { velocity, traction };

struct BarCaseSettings {
  double length = 1.0;            ///< L (m)
  int particle_count = 101;       ///< real particles, dx = L / (count - 1)
  double density = 2000.0;        ///< rho (kg/m^3)
  double young_modulus = 8e7;     ///< E (Pa)
  double amplitude = 1.0;         ///< v0 (m/s); a traction load applies rho c v0
  double pulse_duration = 2.5e-3; ///< t0 (s)
  double alpha = 0.6;             ///< h / dx
  double cfl = 1.0;               ///< dt = CFL dx / c
  KernelKind kernel = KernelKind::cubic_spline;
  InterpolationKind interpolation = InterpolationKind::linear;
  Kinematics kinematics = Kinematics::small_strain;
  double neighbor_skin = 0.05;    ///< SolverSettings::neighbor_skin (updated Lagrangian)
  BarEnd left_end = BarEnd::fixed;
  BarLoad right_load = BarLoad::velocity;
  double body_force = 0.0;        ///< b (m/s^2)
  std::vector<double> output_times{3.75e-3, 7.5e-3};
  double end_time = 0.0;          ///< 0: the last output time
  bool record_energy = false;     ///< energy after every step (tests, studies)
  bool force = false;             ///< accept a CFL above the stability limit 1 (to study it)
  /// Called with each profile as soon as it is sampled (tsph-bar writes it at once, so
  /// that a run that diverges later keeps its earlier output).
  std::function<void(const BarProfile&)> on_profile;

  double spacing() const { return length / (particle_count - 1); }
  double wave_speed() const;
  double time_step() const { return cfl * spacing() / wave_speed(); }
  double final_time() const;
};

/// Every problem with the settings (empty when they are valid).
std::vector<InputError> validate(const BarCaseSettings& settings);

/// Exact solution by d'Alembert and the method of images: a pulse f(t) applied at
/// x = L (velocity, or traction / Z) into a bar fixed or free at x = 0.
class BarExactSolution {
 public:
  explicit BarExactSolution(const BarCaseSettings& settings);
  double velocity(double x, double t) const;
  double stress(double x, double t) const;

 private:
  double pulse(double s) const { return s > 0.0 ? load_(s) : 0.0; }
  double length_, speed_, impedance_;
  bool fixed_left_;
  TimeFunction load_;  ///< the velocity pulse v0 f(t)
};

struct BarProfile {
  double time = 0.0;
  std::vector<double> position, velocity, stress, exact_velocity, exact_stress;
  double velocity_error_percent = 0.0;  ///< 100 |v - v_exact|_2 / |v_exact|_2
  double stress_error_percent = 0.0;
};

struct BarResult {
  std::vector<BarProfile> profiles;  ///< one per output time
  std::int64_t steps = 0;
  double time_step = 0.0;
  double wall_seconds = 0.0;
  double particle_steps_per_second = 0.0;  ///< real particles x steps / wall time
  int threads = 1;
  SolverCounters counters;
  std::vector<double> energy_time, kinetic_energy, strain_energy;  ///< if recorded
};

/// Builds the bar, runs it to the end time and samples the output times. Throws
/// std::invalid_argument with all validation messages if the settings are invalid.
BarResult run_bar(const BarCaseSettings& settings);

/// The relative L2 error in percent, 100 sqrt(sum (a-b)^2 / sum b^2); NaN if b is 0.
double relative_l2_percent(const std::vector<double>& numerical, const std::vector<double>& exact);

}  // namespace tsph
