// The internal variables of the plastic models (issue 16; material/j2_plasticity.hpp,
// material/drucker_prager.hpp), one per particle beside the stress, and the scalar
// equation every return mapping of those models reduces to.
#pragma once

#include <Eigen/Core>

#include <cmath>
#include <stdexcept>
#include <string>

namespace tsph {

/// One particle's plastic state. Tensors are full 3x3 (plane strain keeps sigma_zz and
/// the back stress's zz component). Starts at zero (virgin material), except the
/// temperature, which a model with thermal softening sets to its room temperature.
struct PlasticState {
  /// J2: the equivalent (von Mises) plastic strain, int sqrt(2/3 d^p : d^p) dt.
  /// Drucker-Prager: the hardening variable, int xi dgamma (de Souza Neto et al. 2008,
  /// section 8.3), equal to it for a friction angle of zero.
  double equivalent_plastic_strain = 0.0;
  /// Plastic work per unit current volume, int sigma : d^p dt (J/m^3).
  double plastic_work = 0.0;
  /// Johnson-Cook thermal softening: the temperature (K), raised by the plastic work.
  double temperature = 0.0;
  /// Kinematic hardening: the back stress (deviatoric, rotated with the Jaumann rate).
  Eigen::Matrix3d back_stress = Eigen::Matrix3d::Zero();
  /// The last update returned to the yield surface.
  bool yielding = false;
};

/// The root of a decreasing scalar function r on [0, upper] with r(0) > 0 >= r(upper):
/// Newton steps kept inside a bisection bracket (each return mapping's consistency
/// condition, rate-dependent forms included), to a relative tolerance of 1e-15 of the
/// bracket or 200 iterations. `r_and_slope(x, slope)` returns r(x) and sets r'(x).
template <class F>
double decreasing_root(F&& r_and_slope, double upper) {
  double low = 0.0, high = upper;
  double x = 0.5 * upper;
  for (int iteration = 0; iteration < 200; ++iteration) {
    double slope = 0.0;
    const double r = r_and_slope(x, slope);
    if (r == 0.0) return x;
    if (r > 0.0)
      low = x;
    else
      high = x;
    if (high - low <= 1e-15 * high) break;
    double next = slope < 0.0 && std::isfinite(slope) ? x - r / slope : 0.5 * (low + high);
    if (!(next > low && next < high)) next = 0.5 * (low + high);
    x = next;
  }
  return x;
}

/// Degrees to radians for the angles of the case keys.
inline double radians(double degrees) { return degrees * 3.14159265358979323846 / 180.0; }

/// Deviatoric part and trace helpers of 3x3 tensors.
inline Eigen::Matrix3d deviator(const Eigen::Matrix3d& t) {
  return t - (t.trace() / 3.0) * Eigen::Matrix3d::Identity();
}

/// Checks a material parameter: finite and >= `minimum` (or > when `strict`).
inline void check_parameter(const char* model, const char* name, double value, double minimum,
                            bool strict, const char* fix) {
  if (!std::isfinite(value) || (strict ? !(value > minimum) : !(value >= minimum)))
    throw std::invalid_argument(
        std::string("material (") + model + "): " + name + " = " + std::to_string(value) +
        " must be " + (strict ? "above " : "at least ") + std::to_string(minimum) + ": " + fix);
}

}  // namespace tsph
