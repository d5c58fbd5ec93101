// The twisting column (reference, large-deformation.md section 4): a column L x a x a
// (x along the axis) clamped at x = 0, set turning about its axis with
// omega(x) = omega0 sin(pi x / (2 L)), the shape of the first torsional mode of a
// clamped-free bar. No closed form at large twist: these are the linear estimates the
// validation case reports beside what it measures.
#pragma once

#include <cmath>

namespace tsph {

struct TwistingColumn {
  double length = 6.0, side = 1.0;  ///< L, a (m): a square section a x a
  double young_modulus = 1.7e7, poisson_ratio = 0.45, density = 1100.0;

  double shear_modulus() const { return young_modulus / (2.0 * (1.0 + poisson_ratio)); }
  /// c_p = sqrt((lambda + 2 mu) / rho).
  double p_wave_speed() const {
    const double nu = poisson_ratio;
    return std::sqrt(young_modulus * (1.0 - nu) / ((1.0 + nu) * (1.0 - 2.0 * nu) * density));
  }
  /// Saint-Venant torsion constant of the square, J = k a^4 with
  /// k = (1/3) (1 - (192 / pi^5) sum_{n odd} tanh(n pi / 2) / n^5) = 0.140577.
  double torsion_constant() const {
    double sum = 0.0;
    for (int n = 1; n < 200; n += 2) sum += std::tanh(n * M_PI / 2.0) / std::pow(n, 5);
    const double k = (1.0 - 192.0 / std::pow(M_PI, 5) * sum) / 3.0;
    return k * std::pow(side, 4);
  }
  /// Polar moment of the section a^4 / 6.
  double polar_moment() const { return std::pow(side, 4) / 6.0; }
  /// Linear first torsional mode of the clamped-free bar: omega_t = (pi / 2L) sqrt(G J / (rho I_p)).
  double torsional_omega() const {
    return M_PI / (2.0 * length) * std::sqrt(shear_modulus() * torsion_constant() / (density * polar_moment()));
  }
  double torsional_period() const { return 2.0 * M_PI / torsional_omega(); }
  /// The initial peak speed, at the tip's corners: omega0 a / sqrt(2).
  double peak_speed(double omega0) const { return omega0 * side / std::sqrt(2.0); }
  /// omega0 whose peak speed is `fraction` c_p.
  double omega0_for(double fraction) const { return fraction * p_wave_speed() * std::sqrt(2.0) / side; }
  /// Linear theory's tip rotation amplitude omega0 / omega_t (rad).
  double linear_tip_rotation(double omega0) const { return omega0 / torsional_omega(); }
};

}  // namespace tsph
