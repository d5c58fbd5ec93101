// Closed-form elastoplastic responses to homogeneous radial paths (issue 16;
// ../shared/reference/large-deformation.md section 5): the references of the plastic
// models' tests (tests/test_plasticity.cpp) and of the plastic cases of `tsph validate`
// (tools/validate/plasticity.cpp). Small-strain formulas; along a path with no spin and
// a fixed principal frame (uniaxial strain driven by v = G x, G diagonal) they hold
// with the logarithmic strain, which the Jaumann rate integrates exactly there.
#pragma once

#include "engine/material/linear_elastic.hpp"
#include "engine/material/plastic_state.hpp"

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

namespace tsph::elastoplastic {

/// Linear isotropic + kinematic hardening along a fixed deviatoric direction N: e the
/// deviatoric strain along N (tensor norm), s and a the deviatoric and back stresses
/// along N; elastic ds = modulus de (2 mu; 1D: E), the yield surface
/// |s - a| = radius_factor (Y0 + H_iso eps_p), and on it (plastic strain norm dg)
///   ds = modulus (de - dg),  da = kin_factor H_kin dg,  deps_p = eps_factor dg.
/// J2 in 2D/3D: radius and eps factors sqrt(2/3), kin factor 2/3; 1D: all 1.
/// advance(de) follows one monotonic segment exactly (elastic to the surface, then the
/// constant plastic tangent).
struct LinearHardeningPath {
  double modulus, radius_factor, kin_factor, eps_factor, yield, iso, kin;
  double s = 0.0, a = 0.0, eps = 0.0;
  void advance(double de) {
    const double sign = de > 0.0 ? 1.0 : -1.0;
    const double radius = radius_factor * (yield + iso * eps);
    const double elastic_room = (sign * radius - (s - a)) / modulus;  // to the surface, de's sign
    if (std::abs(elastic_room) >= std::abs(de)) {
      s += modulus * de;
      return;
    }
    s += modulus * elastic_room;
    const double rest = std::abs(de - elastic_room);
    // Consistency: modulus (rest - dg) - kin_factor H_kin dg = radius_factor H_iso eps_factor dg.
    const double dg = modulus * rest / (modulus + kin_factor * kin + radius_factor * iso * eps_factor);
    s += sign * (modulus * rest - modulus * dg);
    a += sign * kin_factor * kin * dg;
    eps += eps_factor * dg;
  }
};

/// J2 with linear hardening in uniaxial strain eps_xx = strain (2D plane strain, 3D),
/// loaded to `peak` and then, if `reversed`, strained back to `strain` (unloading, then
/// reverse yielding: the Bauschinger effect with kinematic hardening); else loaded
/// monotonically to `strain`. The stress tensor; `plastic_strain` gets eps_p.
inline Eigen::Matrix3d j2_uniaxial_strain_cycle(double young, double nu, double yield, double iso, double kin,
                                                double peak, bool reversed, double strain,
                                                double* plastic_strain = nullptr) {
  const double mu = young / (2.0 * (1.0 + nu)), bulk = young / (3.0 * (1.0 - 2.0 * nu));
  LinearHardeningPath path{2.0 * mu, std::sqrt(2.0 / 3.0), 2.0 / 3.0, std::sqrt(2.0 / 3.0), yield, iso, kin};
  if (!reversed) peak = strain;
  path.advance(std::sqrt(2.0 / 3.0) * peak);  // |dev eps| along N = (2, -1, -1) / sqrt(6)
  path.advance(std::sqrt(2.0 / 3.0) * (strain - peak));
  if (plastic_strain) *plastic_strain = path.eps;
  const double deviator_xx = std::sqrt(2.0 / 3.0) * path.s;
  return Eigen::Vector3d(bulk * strain + deviator_xx, bulk * strain - 0.5 * deviator_xx,
                         bulk * strain - 0.5 * deviator_xx)
      .asDiagonal();
}

/// The same loaded monotonically from rest to `strain`.
inline Eigen::Matrix3d j2_uniaxial_strain(double young, double nu, double yield, double iso, double kin, double strain,
                                          double* plastic_strain = nullptr) {
  return j2_uniaxial_strain_cycle(young, nu, yield, iso, kin, strain, false, strain, plastic_strain);
}

/// Johnson-Cook strength without rate and temperature terms, Y = A + B eps_p^n, in
/// uniaxial strain loaded monotonically: q = 3 mu (2/3 strain - eps_p) = Y(eps_p)
/// (radial: the return of any step size lands on it), solved by bisection.
inline Eigen::Matrix3d johnson_cook_uniaxial_strain(double young, double nu, double a, double b, double n,
                                                    double strain, double* plastic_strain = nullptr) {
  const double mu = young / (2.0 * (1.0 + nu)), bulk = young / (3.0 * (1.0 - 2.0 * nu));
  const double sign = strain >= 0.0 ? 1.0 : -1.0, equivalent = 2.0 / 3.0 * std::abs(strain);
  double eps = 0.0;
  if (3.0 * mu * equivalent > a) {
    double low = 0.0, high = equivalent;
    for (int k = 0; k < 200; ++k) {
      eps = 0.5 * (low + high);
      (3.0 * mu * (equivalent - eps) > a + b * std::pow(eps, n) ? low : high) = eps;
    }
  }
  if (plastic_strain) *plastic_strain = eps;
  const double q = 3.0 * mu * (equivalent - eps);  // sigma_xx - sigma_yy
  const double mean = bulk * strain;
  return Eigen::Vector3d(mean + sign * 2.0 / 3.0 * q, mean - sign * q / 3.0, mean - sign * q / 3.0).asDiagonal();
}

/// The same loaded to `peak` and then, if `reversed`, strained back to `strain`: elastic
/// unloading until the deviator along N = (2, -1, -1) / sqrt 6, s, reaches
/// -sqrt(2/3) Y(eps_p), then reverse yielding on it (isotropic hardening):
///   s = s_peak + 2 mu (de - dp),  eps_p = eps_peak + sqrt(2/3) |dp|,
/// with de = sqrt(2/3) (strain - peak), solved for eps_p by bisection.
inline Eigen::Matrix3d johnson_cook_uniaxial_strain_cycle(double young, double nu, double a, double b, double n,
                                                          double peak, bool reversed, double strain,
                                                          double* plastic_strain = nullptr) {
  if (!reversed) return johnson_cook_uniaxial_strain(young, nu, a, b, n, strain, plastic_strain);
  const double mu = young / (2.0 * (1.0 + nu)), bulk = young / (3.0 * (1.0 - 2.0 * nu));
  double eps_peak = 0.0;
  const Eigen::Matrix3d at_peak = johnson_cook_uniaxial_strain(young, nu, a, b, n, peak, &eps_peak);
  const double sign = peak >= 0.0 ? 1.0 : -1.0;  // the direction of the first loading
  const double s_peak = std::sqrt(1.5) * (at_peak(0, 0) - bulk * peak);  // deviator_xx = sqrt(2/3) s
  const double de = std::sqrt(2.0 / 3.0) * (strain - peak);
  const double yield = [&](double eps) { return a + b * std::pow(eps, n); }(eps_peak);
  double eps = eps_peak, s = s_peak + 2.0 * mu * de;
  if (sign * s < -std::sqrt(2.0 / 3.0) * yield) {  // reverse yielding: s = -sign sqrt(2/3) Y(eps)
    // g(eps) = sign s(eps) + sqrt(2/3) Y(eps), s(eps) = s_peak + 2 mu de + sign 2 mu sqrt(3/2) (eps - eps_peak),
    // increases with eps from g(eps_peak) < 0.
    const auto g = [&](double e) {
      return sign * (s_peak + 2.0 * mu * de) + 2.0 * mu * std::sqrt(1.5) * (e - eps_peak) +
             std::sqrt(2.0 / 3.0) * (a + b * std::pow(e, n));
    };
    double low = eps_peak, high = eps_peak + std::abs(de) * std::sqrt(2.0 / 3.0) + 1e-300;
    for (int k = 0; k < 200; ++k) {
      eps = 0.5 * (low + high);
      (g(eps) < 0.0 ? low : high) = eps;
    }
    s = -sign * std::sqrt(2.0 / 3.0) * (a + b * std::pow(eps, n));
  }
  if (plastic_strain) *plastic_strain = eps;
  const double deviator_xx = std::sqrt(2.0 / 3.0) * s;
  return Eigen::Vector3d(bulk * strain + deviator_xx, bulk * strain - 0.5 * deviator_xx,
                         bulk * strain - 0.5 * deviator_xx)
      .asDiagonal();
}

/// Perfectly plastic Drucker-Prager (constants eta, xi, eta_bar of the model) in uniaxial
/// strain compression (strain < 0), loaded monotonically: elastic until
/// sqrt(J2) + eta p = xi c, then along the cone with
///   d lambda = (-(2G / sqrt 3) + eta K) d strain / (G + K eta eta_bar)
/// (needs 2G / sqrt 3 > eta K, or the path never yields).
inline Eigen::Matrix3d drucker_prager_uniaxial_compression(double young, double nu, double cohesion, double eta,
                                                           double xi, double eta_bar, double strain,
                                                           double* plastic_strain = nullptr) {
  const double g = young / (2.0 * (1.0 + nu)), k = young / (3.0 * (1.0 - 2.0 * nu));
  const double rise = 2.0 * g / std::sqrt(3.0) - eta * k;
  const double first_yield = -xi * cohesion / rise;
  const double lambda = strain < first_yield ? -rise * (strain - first_yield) / (g + k * eta * eta_bar) : 0.0;
  if (plastic_strain) *plastic_strain = xi * lambda;
  const double root_j2 = -(2.0 * g / std::sqrt(3.0)) * strain - g * lambda;
  const double mean = k * strain - k * eta_bar * lambda;
  return Eigen::Vector3d(mean - 2.0 / std::sqrt(3.0) * root_j2, mean + root_j2 / std::sqrt(3.0),
                         mean + root_j2 / std::sqrt(3.0))
      .asDiagonal();
}

/// The same compressed to `peak` (< 0) and then, if `reversed`, strained back to `strain`
/// (> peak): with r the signed sqrt(J2) (positive for extension along x; -root J2 on the
/// compression cone), elastic unloading r = r_peak + (2G / sqrt 3) de, p = p_peak + K de
/// until the extension side of the cone, r + eta p = xi c (r > 0), then along it with
///   d lambda = (2G / sqrt 3 + eta K) de / (G + K eta eta_bar)
/// (valid while p stays below the apex xi c / eta).
inline Eigen::Matrix3d drucker_prager_uniaxial_cycle(double young, double nu, double cohesion, double eta, double xi,
                                                     double eta_bar, double peak, bool reversed, double strain,
                                                     double* plastic_strain = nullptr) {
  if (!reversed)
    return drucker_prager_uniaxial_compression(young, nu, cohesion, eta, xi, eta_bar, strain, plastic_strain);
  const double g = young / (2.0 * (1.0 + nu)), k = young / (3.0 * (1.0 - 2.0 * nu));
  double plastic_peak = 0.0;
  const Eigen::Matrix3d at_peak =
      drucker_prager_uniaxial_compression(young, nu, cohesion, eta, xi, eta_bar, peak, &plastic_peak);
  const double p_peak = at_peak.trace() / 3.0;
  const double r_peak = std::sqrt(3.0) / 2.0 * (at_peak(0, 0) - p_peak);  // sigma_xx = p + (2 / sqrt 3) r
  const double de = strain - peak, rise = 2.0 * g / std::sqrt(3.0);
  const double de_yield = (xi * cohesion - r_peak - eta * p_peak) / (rise + eta * k);
  double r = r_peak + rise * de, p = p_peak + k * de, lambda = 0.0;
  if (de > de_yield) {
    lambda = (rise + eta * k) * (de - de_yield) / (g + k * eta * eta_bar);
    r -= g * lambda;
    p -= k * eta_bar * lambda;
  }
  if (plastic_strain) *plastic_strain = plastic_peak + xi * lambda;
  return Eigen::Vector3d(p + 2.0 / std::sqrt(3.0) * r, p - r / std::sqrt(3.0), p - r / std::sqrt(3.0)).asDiagonal();
}

/// Perfectly plastic Drucker-Prager (constants eta, xi, eta_bar of the model, eta_bar > 0,
/// no tension cut-off) under hydrostatic expansion to the volumetric strain `volumetric`:
/// p = K eps_v up to the apex xi c / eta, then held there (s = 0) while the rest of the
/// expansion is plastic, eps_p = (xi / eta_bar) (eps_v - xi c / (eta K)).
inline Eigen::Matrix3d drucker_prager_hydrostatic_expansion(double young, double nu, double cohesion, double eta,
                                                            double xi, double eta_bar, double volumetric,
                                                            double* plastic_strain = nullptr) {
  const double k = young / (3.0 * (1.0 - 2.0 * nu));
  const double apex = xi * cohesion / eta;
  const double plastic = std::max(0.0, volumetric - apex / k);
  if (plastic_strain) *plastic_strain = xi / eta_bar * plastic;
  return Eigen::Matrix3d::Identity() * std::min(k * volumetric, apex);
}

/// The state of the rate equations below: stress, back stress, equivalent plastic strain.
struct RateState {
  Eigen::Matrix3d stress = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d back_stress = Eigen::Matrix3d::Zero();
  double plastic_strain = 0.0;
};

/// The elastic part of every model's rates below: the hypoelastic Jaumann rate
/// C : d_e + W sigma - sigma W of the solver's own law (LinearElastic::stress_rate, seed
/// eq. 1a), with the elastic rate of deformation d_e and the spin W.
inline Eigen::Matrix3d jaumann_elastic_rate(const LinearElastic<3>& law, const Eigen::Matrix3d& elastic_d,
                                            const Eigen::Matrix3d& w, const Eigen::Matrix3d& sigma) {
  return to_tensor<3>(law.stress_rate(elastic_d + w, from_tensor<3>(sigma)));
}

/// J2 with linear isotropic and kinematic hardening as rate equations (Jaumann rates;
/// Simo & Hughes 1998, ch. 3), rate of deformation D, spin W:
///   dsigma/dt = lambda tr(D - lambda_dot n) I + 2 mu (D - lambda_dot n) + W sigma - sigma W,
///   dalpha/dt = 2/3 H_kin lambda_dot n + W alpha - alpha W,  deps_p/dt = sqrt(2/3) lambda_dot,
///   n = xi / |xi|, xi = dev(sigma) - alpha,
///   lambda_dot = 2 mu n : D / (2 mu + 2/3 (H_kin + H_iso)) on the yield surface (0 below it,
///   or when unloading), |xi| = sqrt(2/3) (Y0 + H_iso eps_p).
/// With Perzyna viscoplasticity (fluidity > 0, exponent N; J2Plasticity::Perzyna) the
/// multiplier is the overstress law instead, deps_p/dt = fluidity <f / Y0>^N with
/// f = sqrt(3/2) |xi| - (Y0 + H_iso eps_p) (lambda_dot = sqrt(3/2) deps_p/dt): the stress
/// may lie outside the surface, and relaxes towards it while f > 0.
struct J2Rates {
  double young, nu, yield, iso, kin;
  double fluidity = 0.0, exponent = 1.0;  ///< Perzyna (fluidity 0: rate independent)
  static Eigen::Matrix3d relative(const RateState& y) { return deviator(y.stress) - y.back_stress; }
  double yield_function(const RateState& y) const {
    return std::sqrt(1.5) * relative(y).norm() - (yield + iso * y.plastic_strain);
  }
  /// The flow rule's multiplier is positive (n : D > 0; Perzyna: or the stress lies
  /// outside the surface, and relaxes).
  bool loading(const RateState& y, const Eigen::Matrix3d& d) const {
    return relative(y).cwiseProduct(d).sum() > 0.0 || (fluidity > 0.0 && yield_function(y) > 0.0);
  }
  RateState rates(const RateState& y, const Eigen::Matrix3d& d, const Eigen::Matrix3d& w, bool plastic) const {
    const LinearElastic<3> law(young, nu, 1.0);
    const double mu = law.shear_modulus();
    Eigen::Matrix3d elastic_d = d, flow = Eigen::Matrix3d::Zero();
    double multiplier = 0.0;
    if (plastic) {
      const Eigen::Matrix3d xi = relative(y);
      flow = xi / xi.norm();
      multiplier = fluidity > 0.0
                       ? std::sqrt(1.5) * fluidity * std::pow(std::max(0.0, yield_function(y)) / yield, exponent)
                       : std::max(0.0, 2.0 * mu * flow.cwiseProduct(d).sum() / (2.0 * mu + 2.0 / 3.0 * (kin + iso)));
      elastic_d -= multiplier * flow;
    }
    RateState r;
    r.stress = jaumann_elastic_rate(law, elastic_d, w, y.stress);
    r.back_stress = 2.0 / 3.0 * kin * multiplier * flow + w * y.back_stress - y.back_stress * w;
    r.plastic_strain = std::sqrt(2.0 / 3.0) * multiplier;
    return r;
  }
};

/// Johnson-Cook strength without the rate and thermal terms, Y = A + B eps_p^n, as rate
/// equations (J2Rates' flow with the tangent modulus H = B n eps_p^(n-1) in place of
/// H_iso, no kinematic hardening). For n < 1, H is infinite at first yield and d eps_p / dt
/// ~ eps_p^(1-n), which RK4 cannot start from eps_p = 0; RateState::plastic_strain holds
/// u = eps_p^n instead, whose rate
///   du/dt = sqrt(2/3) n 2 mu n : D / (2 mu eps_p^(1-n) + 2/3 B n)
/// is finite there (plastic_strain(y) = u^(1/n)).
struct JohnsonCookRates {
  double young, nu, a, b, n;
  double plastic_strain(const RateState& y) const { return std::pow(std::max(y.plastic_strain, 0.0), 1.0 / n); }
  double yield_function(const RateState& y) const {
    return std::sqrt(1.5) * deviator(y.stress).norm() - (a + b * std::max(y.plastic_strain, 0.0));
  }
  bool loading(const RateState& y, const Eigen::Matrix3d& d) const { return deviator(y.stress).cwiseProduct(d).sum() > 0.0; }
  RateState rates(const RateState& y, const Eigen::Matrix3d& d, const Eigen::Matrix3d& w, bool plastic) const {
    const LinearElastic<3> law(young, nu, 1.0);
    const double mu = law.shear_modulus();
    Eigen::Matrix3d elastic_d = d;
    RateState r;
    if (plastic) {
      const Eigen::Matrix3d xi = deviator(y.stress);
      const Eigen::Matrix3d flow = xi / xi.norm();
      const double driving = std::max(0.0, 2.0 * mu * flow.cwiseProduct(d).sum());
      const double lag = 2.0 * mu * std::pow(plastic_strain(y), 1.0 - n);  // 2 mu eps_p^(1-n)
      const double denominator = lag + 2.0 / 3.0 * b * n;
      elastic_d -= driving * (lag / (2.0 * mu)) / denominator * flow;  // lambda_dot = 2 mu n:D eps^(1-n) / (...)
      r.plastic_strain = std::sqrt(2.0 / 3.0) * n * driving / denominator;
    }
    r.stress = jaumann_elastic_rate(law, elastic_d, w, y.stress);
    return r;
  }
};

/// Drucker-Prager (engine/material/drucker_prager.hpp) as rate equations: cohesion
/// c = c0 + H eps_p, yield f = sqrt(J2) + eta p - xi c, potential g = sqrt(J2) + eta_bar p,
/// m = dg/dsigma = s / (2 sqrt(J2)) + eta_bar / 3 I, on the cone (de Souza Neto et al. 2008, ch. 8)
///   dsigma/dt = C : (D - lambda_dot m) + W sigma - sigma W,  deps_p/dt = xi lambda_dot,
///   lambda_dot = (mu s : D / sqrt(J2) + eta K tr D) / (mu + K eta eta_bar + xi^2 H)
/// (0 below the cone or when unloading; the cone, not its apex). With Perzyna
/// viscoplasticity (fluidity > 0, exponent N; DruckerPrager::Perzyna) the multiplier is
/// the overstress law instead, lambda_dot = fluidity <f / (xi c0)>^N.
struct DruckerPragerRates {
  double young, nu, cohesion, hardening, eta, xi, eta_bar;
  double fluidity = 0.0, exponent = 1.0;  ///< Perzyna (fluidity 0: rate independent)
  double yield_function(const RateState& y) const {
    return std::sqrt(0.5 * deviator(y.stress).squaredNorm()) + eta * y.stress.trace() / 3.0 -
           xi * (cohesion + hardening * y.plastic_strain);
  }
  /// The flow rule's multiplier's numerator: mu s : D / sqrt(J2) + eta K tr D.
  double driving(const LinearElastic<3>& law, const RateState& y, const Eigen::Matrix3d& d) const {
    const Eigen::Matrix3d s = deviator(y.stress);
    const double bulk = law.model_lame() + 2.0 / 3.0 * law.shear_modulus();
    return law.shear_modulus() * s.cwiseProduct(d).sum() / std::sqrt(0.5 * s.squaredNorm()) + eta * bulk * d.trace();
  }
  /// The flow rule's multiplier is positive.
  bool loading(const RateState& y, const Eigen::Matrix3d& d) const {
    return driving(LinearElastic<3>(young, nu, 1.0), y, d) > 0.0 || (fluidity > 0.0 && yield_function(y) > 0.0);
  }
  RateState rates(const RateState& y, const Eigen::Matrix3d& d, const Eigen::Matrix3d& w, bool plastic) const {
    const LinearElastic<3> law(young, nu, 1.0);
    const double mu = law.shear_modulus(), bulk = law.model_lame() + 2.0 / 3.0 * mu;
    Eigen::Matrix3d elastic_d = d;
    double multiplier = 0.0;
    if (plastic) {
      const Eigen::Matrix3d s = deviator(y.stress);
      multiplier = fluidity > 0.0
                       ? fluidity * std::pow(std::max(0.0, yield_function(y)) / (xi * cohesion), exponent)
                       : std::max(0.0, driving(law, y, d) / (mu + bulk * eta * eta_bar + xi * xi * hardening));
      elastic_d -= multiplier * (s / (2.0 * std::sqrt(0.5 * s.squaredNorm())) + eta_bar / 3.0 * Eigen::Matrix3d::Identity());
    }
    RateState r;
    r.stress = jaumann_elastic_rate(law, elastic_d, w, y.stress);
    r.plastic_strain = xi * multiplier;
    return r;
  }
};

/// A model's rate equations (J2Rates, ...) under the velocity gradient L(t) = f(t) L0
/// (3x3), from a stress-free virgin state over the time t: the reference of paths whose
/// flow direction turns (simple shear: the spin turns the stress), which have no closed
/// form. Classical Runge-Kutta (RK4), steps of at most `step` between the `breakpoints`
/// (where f has a kink or changes sign: each is a step boundary); the elastic phase's step
/// that crosses the yield surface is bisected to the onset, and a plastic phase turns
/// elastic at a step where the model unloads (`loading` false: the flow rule's multiplier
/// would be negative), so that every kink of the rates falls on a step boundary and the
/// order holds (tests/test_plasticity.cpp: converged to ~1e-13). With Perzyna the kink
/// where a relaxing overstress <f> reaches zero falls inside a step (O(h^2) there; the
/// Perzyna cases' references take steps 4 times shorter).
template <class Rates, class Scale>
RateState integrate_gradient_path(const Rates& model, const Eigen::Matrix3d& grad_v, Scale&& f,
                                  std::vector<double> breakpoints, double t, double step) {
  const Eigen::Matrix3d d0 = 0.5 * (grad_v + grad_v.transpose()), w0 = 0.5 * (grad_v - grad_v.transpose());
  const auto advance = [&](const RateState& y, double h, const RateState& k, double factor) {
    RateState next = y;
    next.stress += factor * h * k.stress;
    next.back_stress += factor * h * k.back_stress;
    next.plastic_strain += factor * h * k.plastic_strain;
    return next;
  };
  const auto rates = [&](const RateState& y, double time, bool plastic) {
    const double scale = f(time);
    return model.rates(y, scale * d0, scale * w0, plastic);
  };
  const auto rk4 = [&](const RateState& y, double time, double h, bool plastic) {
    const RateState k1 = rates(y, time, plastic);
    const RateState k2 = rates(advance(y, h, k1, 0.5), time + 0.5 * h, plastic);
    const RateState k3 = rates(advance(y, h, k2, 0.5), time + 0.5 * h, plastic);
    const RateState k4 = rates(advance(y, h, k3, 1.0), time + h, plastic);
    RateState next = y;
    next.stress += h / 6.0 * (k1.stress + 2.0 * k2.stress + 2.0 * k3.stress + k4.stress);
    next.back_stress += h / 6.0 * (k1.back_stress + 2.0 * k2.back_stress + 2.0 * k3.back_stress + k4.back_stress);
    next.plastic_strain +=
        h / 6.0 * (k1.plastic_strain + 2.0 * k2.plastic_strain + 2.0 * k3.plastic_strain + k4.plastic_strain);
    return next;
  };
  if (!(step > 0.0 && t >= 0.0)) throw std::invalid_argument("integrate_gradient_path: step and t must be positive");
  std::sort(breakpoints.begin(), breakpoints.end());
  breakpoints.erase(std::remove_if(breakpoints.begin(), breakpoints.end(), [&](double b) { return !(b > 0.0 && b < t); }),
                    breakpoints.end());
  breakpoints.push_back(t);
  RateState y;
  bool plastic = false;
  double time = 0.0;
  for (const double end : breakpoints) {
    const int steps = std::max(1, static_cast<int>(std::ceil((end - time) / step)));
    const double h = (end - time) / steps, segment_start = time;
    for (int n = 0; n < steps;) {
      const double from = std::max(segment_start + n * h, time);  // after an onset: the step's rest
      const double length = (n + 1 == steps ? end : segment_start + (n + 1) * h) - from;
      if (!(length > 0.0)) {
        ++n;
        continue;
      }
      if (plastic) {
        const double scale = f(from + 0.5 * length);  // unloading: elastic from here
        if (!model.loading(y, scale * d0)) plastic = false;
      }
      const RateState next = rk4(y, from, length, plastic);
      // An onset: f rises above 0 (and above a round-off excess that a plastic phase left:
      // unloaded or held there, f stays, and the step is elastic).
      if (!plastic && model.yield_function(next) > std::max(0.0, model.yield_function(y))) {
        double inside = 0.0, outside = length;
        for (int i = 0; i < 200 && outside - inside > 1e-16 * outside; ++i) {
          const double mid = 0.5 * (inside + outside);
          (model.yield_function(rk4(y, from, mid, false)) > 0.0 ? outside : inside) = mid;
        }
        y = rk4(y, from, inside, false);
        time = from + inside;
        plastic = true;
        continue;  // the same step's rest, plastically
      }
      y = next;
      time = from + length;
      ++n;
    }
    time = end;
  }
  return y;
}

/// integrate_gradient_path with a constant gradient (f = 1) in `steps` equal steps.
template <class Rates>
RateState integrate_constant_gradient(const Rates& model, const Eigen::Matrix3d& grad_v, double t, int steps) {
  return integrate_gradient_path(model, grad_v, [](double) { return 1.0; }, {}, t, t / steps);
}

}  // namespace tsph::elastoplastic
