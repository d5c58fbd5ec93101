#include "engine/bar_case.hpp"

#include "engine/lattice.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace tsph {
double BarCaseSettings::wave_speed() const { return std::sqrt(young_modulus / density); }

double BarCaseSettings::final_time() const {
  double last = end_time;
  for (double t : output_times) last = std::max(last, t);
  return last;
}

std::vector<InputError> validate(const BarCaseSettings& s) {
  std::vector<InputError> errors;
  auto positive = [&](const char* name, double value) { require_positive(errors, name, value); };
  positive("length", s.length);
  positive("density", s.density);
  positive("young_modulus", s.young_modulus);
  positive("pulse_duration", s.pulse_duration);
  if (s.particle_count < 3)
    errors.push_back({"particles", std::to_string(s.particle_count), "needs at least 3"});
  else positive("dx", s.spacing());
  // Below 0.5 the support 2h < dx holds no neighbour; the seed's range is 0.6-1.2.
  if (!(s.alpha > 0.5) || !(s.alpha <= 4.0))
    errors.push_back({"alpha", format_number(s.alpha),
                      "must lie in (0.5, 4] (h = alpha dx; the support 2h must reach the "
                      "nearest neighbour; the seed recommends 0.6 to 1.2)"});
  if (!(s.cfl > 0.0) || !std::isfinite(s.cfl) || (s.cfl > 1.0 && !s.force))
    errors.push_back({"cfl", format_number(s.cfl),
                      "must lie in (0, 1]: the two-step scheme is unstable above CFL 1 "
                      "(force runs it anyway)"});
  if (!std::isfinite(s.amplitude)) errors.push_back({"amplitude", format_number(s.amplitude), "must be finite"});
  if (!std::isfinite(s.body_force))
    errors.push_back({"body_force", format_number(s.body_force), "must be finite"});
  if (!(s.end_time >= 0.0) || !std::isfinite(s.end_time))
    errors.push_back({"end_time", format_number(s.end_time), "must be >= 0 (0: the last output time)"});
  if (s.output_times.empty() && !(s.end_time > 0.0))
    errors.push_back({"output_times", "(none)", "give at least one output time or an end time"});
  const double end = s.end_time > 0.0 ? s.end_time : s.final_time();
  for (double t : s.output_times)
    if (!(t > 0.0) || !(t <= end))
      errors.push_back({"output_times", format_number(t),
                        "each must lie in (0, end_time = " + format_number(end) + "]"});
  if (!std::is_sorted(s.output_times.begin(), s.output_times.end()))
    errors.push_back({"output_times", "(unsorted)", "must be given in increasing order"});
  return errors;
}

BarExactSolution::BarExactSolution(const BarCaseSettings& s)
    : length_(s.length),
      speed_(s.wave_speed()),
      impedance_(s.density * s.wave_speed()),
      fixed_left_(s.left_end == BarEnd::fixed),
      load_(TimeFunction::rectangular_pulse(s.amplitude, 0.0, s.pulse_duration)) {}

// Images: a_k = t - ((2k+1) L - x)/c (left-going), b_k = t - ((2k+1) L + x)/c
// (right-going). Fixed end: v = sum f(a_k) - f(b_k), sigma = Z sum f(a_k) + f(b_k).
// Free end: v = sum (-1)^k (f(a_k) + f(b_k)), sigma = Z sum (-1)^k (f(a_k) - f(b_k)).
// In a left-going wave sigma = Z v, in a right-going one sigma = -Z v.
double BarExactSolution::velocity(double x, double t) const {
  double v = 0.0;
  for (int k = 0;; ++k) {
    const double a = t - ((2 * k + 1) * length_ - x) / speed_;
    if (a <= 0.0) break;
    const double b = t - ((2 * k + 1) * length_ + x) / speed_;
    if (fixed_left_) v += pulse(a) - pulse(b);
    else v += (k % 2 == 0 ? 1.0 : -1.0) * (pulse(a) + pulse(b));
  }
  return v;
}

double BarExactSolution::stress(double x, double t) const {
  double sigma = 0.0;
  for (int k = 0;; ++k) {
    const double a = t - ((2 * k + 1) * length_ - x) / speed_;
    if (a <= 0.0) break;
    const double b = t - ((2 * k + 1) * length_ + x) / speed_;
    if (fixed_left_) sigma += pulse(a) + pulse(b);
    else sigma += (k % 2 == 0 ? 1.0 : -1.0) * (pulse(a) - pulse(b));
  }
  return impedance_ * sigma;
}

double relative_l2_percent(const std::vector<double>& numerical, const std::vector<double>& exact) {
  double difference = 0.0, reference = 0.0;
  for (std::size_t i = 0; i < exact.size(); ++i) {
    difference += (numerical[i] - exact[i]) * (numerical[i] - exact[i]);
    reference += exact[i] * exact[i];
  }
  // No relative error against a zero reference: NaN, so that no check passes by accident.
  return reference > 0.0 ? 100.0 * std::sqrt(difference / reference)
                         : std::numeric_limits<double>::quiet_NaN();
}

BarResult run_bar(const BarCaseSettings& s) {
  throw_if_invalid(validate(s));
  const double dx = s.spacing();
  LatticeBox<1> box;
  box.lower[0] = 0.0;
  box.node_count = {s.particle_count};
  box.spacing = dx;
  ParticleSet<1> real = make_real_lattice(box, s.density);
  ParticleSet<1> virtual_particles = make_virtual_lattice(box, s.density);

  const double impedance = s.density * s.wave_speed();
  std::vector<BoundaryCondition<1>> boundaries;
  boundaries.push_back(s.left_end == BarEnd::fixed ? BoundaryCondition<1>::fixed("left")
                                                   : BoundaryCondition<1>::free("left"));
  if (s.right_load == BarLoad::velocity)
    boundaries.push_back(BoundaryCondition<1>::velocity(
        {TimeFunction::rectangular_pulse(s.amplitude, 0.0, s.pulse_duration)}, "right"));
  else  // the traction Z v0 that launches the same left-going wave as v0
    boundaries.push_back(BoundaryCondition<1>::traction(
        {TimeFunction::rectangular_pulse(impedance * s.amplitude, 0.0, s.pulse_duration)},
        "right"));
  real.boundary.front() = 0;
  real.boundary.back() = 1;

  SolverSettings<1> settings;
  settings.smoothing_length = s.alpha * dx;
  settings.kernel = s.kernel;
  settings.interpolation = s.interpolation;
  settings.kinematics = s.kinematics;
  settings.neighbor_skin = s.neighbor_skin;
  settings.body_force[0] = s.body_force;
  TaylorSph<1> solver(std::move(real), std::move(virtual_particles),
                      LinearElastic<1>(s.young_modulus, 0.0, s.density), settings, boundaries);

  const BarExactSolution exact(s);
  BarResult result;
  result.time_step = s.time_step();
  result.threads = thread_count();
  auto record_energy = [&] {
    if (!s.record_energy) return;
    result.energy_time.push_back(solver.time());
    result.kinetic_energy.push_back(solver.kinetic_energy());
    result.strain_energy.push_back(solver.strain_energy());
  };
  auto sample = [&](double t) {
    BarProfile p;
    p.time = t;
    const auto& r = solver.real();
    for (std::size_t i = 0; i < r.size(); ++i) {
      const double x0 = r.initial_position[0][i];  // exact solution in material coordinates
      p.position.push_back(r.position[0][i]);
      p.velocity.push_back(r.velocity[0][i]);
      p.stress.push_back(r.stress[0][i]);
      p.exact_velocity.push_back(exact.velocity(x0, t));
      p.exact_stress.push_back(exact.stress(x0, t));
    }
    p.velocity_error_percent = relative_l2_percent(p.velocity, p.exact_velocity);
    p.stress_error_percent = relative_l2_percent(p.stress, p.exact_stress);
    if (s.on_profile) s.on_profile(p);
    result.profiles.push_back(std::move(p));
  };

  const double dt = s.time_step();
  const double end = s.final_time();
  std::size_t next_output = 0;
  record_energy();
  const auto start = std::chrono::steady_clock::now();
  while (solver.time() < end - 1e-9 * dt) {
    // Land exactly on the next output (or end) time: shorten the step that would pass it.
    const double target = next_output < s.output_times.size() ? s.output_times[next_output] : end;
    const double remaining = target - solver.time();
    const bool lands = remaining <= dt * (1.0 + 1e-9);
    solver.step(lands ? remaining : dt);
    if (lands) solver.set_time(target);
    record_energy();
    while (next_output < s.output_times.size() &&
           solver.time() >= s.output_times[next_output] - 1e-9 * dt)
      sample(s.output_times[next_output++]);
  }
  const auto stop = std::chrono::steady_clock::now();
  result.wall_seconds = std::chrono::duration<double>(stop - start).count();
  result.steps = solver.counters().steps;
  result.counters = solver.counters();
  result.particle_steps_per_second =
      result.wall_seconds > 0.0
          ? static_cast<double>(solver.real().size()) * static_cast<double>(result.steps) /
                result.wall_seconds
          : 0.0;
  return result;
}

}  // namespace tsph
