// The oscillating plate of Gray, Monaghan & Swift (CMAME 190, 2001): a plate L x H
// clamped at x = 0, set moving in its first bending mode (reference, large-deformation.md
// section 3). The mode shape is also what the case format's
// `[initial.profile] type = "cantilever_mode"` sets (engine/case/case_build.cpp).
#pragma once

#include <cmath>
#include <stdexcept>

namespace tsph {

/// beta_n L: the n-th root of cos(x) cosh(x) = -1 (a clamped-free Euler-Bernoulli beam),
/// 1.875104, 4.694091, 7.854757, ... (Newton from (n - 1/2) pi, n >= 1).
inline double cantilever_mode_wavenumber(int n) {
  if (n < 1) throw std::invalid_argument("cantilever_mode_wavenumber: the mode number must be >= 1");
  double x = (n - 0.5) * M_PI;
  for (int k = 0; k < 50; ++k) {
    const double f = std::cos(x) * std::cosh(x) + 1.0;
    const double df = -std::sin(x) * std::cosh(x) + std::cos(x) * std::sinh(x);
    const double step = f / df;
    x -= step;
    if (std::abs(step) < 1e-15 * x) break;
  }
  return x;
}

/// The clamped-free mode shape at xi = s / L (0 at the clamp) for kL = `kl`, in the form of
/// the reference (GMS 2001, section 3): [M (cos ks - cosh ks) - N (sin ks - sinh ks)] / Q with
/// M = sin kL + sinh kL, N = cos kL + cosh kL, Q = 2 (cos kL sinh kL - sin kL cosh kL).
/// At the tip (xi = 1) the bracket equals Q whatever kL, so the shape is 1 there: its
/// amplitude is the tip's value.
inline double cantilever_mode_shape(double kl, double xi) {
  const double m = std::sin(kl) + std::sinh(kl), n = std::cos(kl) + std::cosh(kl);
  const double q = 2.0 * (std::cos(kl) * std::sinh(kl) - std::sin(kl) * std::cosh(kl));
  const double ks = kl * xi;
  return (m * (std::cos(ks) - std::cosh(ks)) - n * (std::sin(ks) - std::sinh(ks))) / q;
}

/// The reference's numbers (section 3). The plate is thin (H/L = 0.1) and in plane
/// strain: the bending stiffness per unit width is E H^3 / (12 (1 - nu^2)), which is the
/// reference's omega formula (plane stress would drop the 1 - nu^2).
struct OscillatingPlate {
  double length = 0.2, thickness = 0.02;  ///< L, H (m)
  double young_modulus = 2e6, poisson_ratio = 0.3975, density = 1000.0;
  double kl = 1.875104068711961;  ///< first mode, cos kL cosh kL = -1

  double wavenumber() const { return kl / length; }
  /// c0 = sqrt(E / (3 (1 - 2 nu) rho)) (the bulk sound speed sqrt(K / rho), PySPH's form).
  double sound_speed() const { return std::sqrt(young_modulus / (3.0 * (1.0 - 2.0 * poisson_ratio) * density)); }
  /// omega^2 = E H^2 k^4 / (12 rho (1 - nu^2)) (thin plate, plane strain).
  double omega() const {
    const double k = wavenumber();
    return std::sqrt(young_modulus * thickness * thickness * k * k * k * k /
                     (12.0 * density * (1.0 - poisson_ratio * poisson_ratio)));
  }
  double period() const { return 2.0 * M_PI / omega(); }
  /// The tip's initial speed V_f c0 (the mode shape is 1 at the tip).
  double tip_velocity(double v_f) const { return v_f * sound_speed(); }
  /// The initial v_y at distance x from the clamp.
  double initial_velocity(double v_f, double x) const {
    return tip_velocity(v_f) * cantilever_mode_shape(kl, x / length);
  }
  /// Linear theory's tip excursion V_f c0 / omega (m).
  double linear_tip_amplitude(double v_f) const { return tip_velocity(v_f) / omega(); }
  /// Initial kinetic energy per unit thickness, rho H int_0^L v_y^2 dx (Simpson, 2000 panels).
  double initial_kinetic_energy(double v_f) const {
    const int n = 2000;
    double sum = 0.0;
    for (int i = 0; i <= n; ++i) {
      const double v = initial_velocity(v_f, length * i / n);
      sum += (i == 0 || i == n ? 1.0 : i % 2 ? 4.0 : 2.0) * v * v;
    }
    return 0.5 * density * thickness * sum * length / (3.0 * n);
  }
};

}  // namespace tsph
