// Closed-form stresses of homogeneous large strain in the isotropic hypoelastic law with
// the Jaumann rate (seed eq. 1a; docs/validation.md, "Large deformation"):
//   sigma_dot - W sigma + sigma W = lambda tr(D) I + 2 mu D,
// from zero stress under a constant velocity gradient L = D + W (v = L x, x current).
// References: ../shared/reference/large-deformation.md section 1; simple shear: Dienes
// (1979). `jaumann_rk4` integrates the same ODE numerically for the tests.
#pragma once

#include <Eigen/Core>

#include <cmath>

namespace tsph::homogeneous {

/// Uniaxial stress, v = eps_dot (x, -nu y, -nu z) (3D, or 2D plane stress): D constant,
/// W = 0, so sigma_xx = E eps_dot t = E ln(stretch), the other components zero.
inline Eigen::Matrix3d uniaxial_stress(double young_modulus, double log_stretch) {
  Eigen::Matrix3d s = Eigen::Matrix3d::Zero();
  s(0, 0) = young_modulus * log_stretch;
  return s;
}

/// Uniaxial strain, v = (eps_dot x, 0, 0) (2D plane strain, 3D): sigma_xx =
/// (lambda + 2 mu) ln(stretch), sigma_yy = sigma_zz = lambda ln(stretch).
inline Eigen::Matrix3d uniaxial_strain(double lame, double shear_modulus, double log_stretch) {
  Eigen::Matrix3d s = Eigen::Matrix3d::Zero();
  s(0, 0) = (lame + 2.0 * shear_modulus) * log_stretch;
  s(1, 1) = s(2, 2) = lame * log_stretch;
  return s;
}

/// Simple shear, v = (gamma_dot y, 0, 0), gamma = gamma_dot t (Dienes 1979):
/// sigma_xy = mu sin(gamma), sigma_xx = -sigma_yy = mu (1 - cos(gamma)), sigma_zz = 0.
inline Eigen::Matrix3d simple_shear(double shear_modulus, double gamma) {
  Eigen::Matrix3d s = Eigen::Matrix3d::Zero();
  s(0, 0) = shear_modulus * (1.0 - std::cos(gamma));
  s(1, 1) = -s(0, 0);
  s(0, 1) = s(1, 0) = shear_modulus * std::sin(gamma);
  return s;
}

/// The Jaumann stress rate lambda tr(D) I + 2 mu D + W sigma - sigma W.
inline Eigen::Matrix3d jaumann_rate(double lame, double shear_modulus, const Eigen::Matrix3d& velocity_gradient,
                                    const Eigen::Matrix3d& stress) {
  const Eigen::Matrix3d d = 0.5 * (velocity_gradient + velocity_gradient.transpose());
  const Eigen::Matrix3d w = 0.5 * (velocity_gradient - velocity_gradient.transpose());
  return lame * d.trace() * Eigen::Matrix3d::Identity() + 2.0 * shear_modulus * d + w * stress - stress * w;
}

/// sigma(t) from zero by `steps` classical Runge-Kutta steps of the Jaumann ODE under the
/// constant velocity gradient L (global error O((t / steps)^4)).
inline Eigen::Matrix3d jaumann_rk4(double lame, double shear_modulus, const Eigen::Matrix3d& velocity_gradient,
                                   double t, int steps) {
  Eigen::Matrix3d s = Eigen::Matrix3d::Zero();
  const double dt = t / steps;
  auto f = [&](const Eigen::Matrix3d& x) { return jaumann_rate(lame, shear_modulus, velocity_gradient, x); };
  for (int k = 0; k < steps; ++k) {
    const Eigen::Matrix3d k1 = f(s), k2 = f(s + 0.5 * dt * k1), k3 = f(s + 0.5 * dt * k2), k4 = f(s + dt * k3);
    s += dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
  }
  return s;
}

}  // namespace tsph::homogeneous
