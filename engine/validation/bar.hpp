// The 1D elastic bar of seed section 4.1: a pulse applied at x = L travelling into a
// bar fixed or free at x = 0 (docs/validation.md, Table 1).
#pragma once

#include "engine/time_function.hpp"
#include "engine/validation/exact_solution.hpp"

#include <cmath>
#include <memory>

namespace tsph {

/// Exact solution by d'Alembert and the method of images: a velocity pulse
/// v0 on 0 < t <= t0 at x = L (or the traction rho c v0 that launches the same wave).
class BarExactSolution {
 public:
  BarExactSolution(double length, double young_modulus, double density, double amplitude, double pulse_duration,
                   bool fixed_left)
      : length_(length),
        speed_(std::sqrt(young_modulus / density)),
        impedance_(density * std::sqrt(young_modulus / density)),
        fixed_left_(fixed_left),
        load_(TimeFunction::rectangular_pulse(amplitude, 0.0, pulse_duration)) {}

  // Images: a_k = t - ((2k+1) L - x)/c (left-going), b_k = t - ((2k+1) L + x)/c
  // (right-going). Fixed end: v = sum f(a_k) - f(b_k), sigma = Z sum f(a_k) + f(b_k).
  // Free end: v = sum (-1)^k (f(a_k) + f(b_k)), sigma = Z sum (-1)^k (f(a_k) - f(b_k)).
  // In a left-going wave sigma = Z v, in a right-going one sigma = -Z v.
  double velocity(double x, double t) const {
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
  double stress(double x, double t) const {
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
  double wave_speed() const { return speed_; }
  double impedance() const { return impedance_; }

 private:
  double pulse(double s) const { return s > 0.0 ? load_(s) : 0.0; }
  double length_, speed_, impedance_;
  bool fixed_left_;
  TimeFunction load_;  ///< the velocity pulse v0 f(t)
};

/// The bar as an ExactSolution: velocity_x and stress_xx over the real particles, in
/// material coordinates relative to the bar's left end `lower`.
class BarValidation final : public ExactSolution<1> {
 public:
  BarValidation(const BarExactSolution& exact, double lower) {
    const auto e = std::make_shared<BarExactSolution>(exact);
    fields_.push_back({"velocity_x", [e, lower](const Vector<1>& x, double t) { return e->velocity(x[0] - lower, t); },
                       [](const ParticleSet<1>& p, std::size_t i) { return p.velocity[0][i]; }});
    fields_.push_back({"stress_xx", [e, lower](const Vector<1>& x, double t) { return e->stress(x[0] - lower, t); },
                       [](const ParticleSet<1>& p, std::size_t i) { return p.stress[0][i]; }});
  }
  const std::vector<ExactField<1>>& fields() const override { return fields_; }

 private:
  std::vector<ExactField<1>> fields_;
};

}  // namespace tsph
