// Drucker-Prager plasticity with the Jaumann rate (issue 16): cohesion c with linear
// hardening, friction angle phi, dilation angle psi (non-associated for psi < phi), a
// tension cut-off, the apex return, and optional Perzyna viscoplasticity. Dim = 2 (plane
// strain) and 3. Tension positive, p = tr(sigma) / 3, s = dev(sigma), J2 = s : s / 2:
//   yield     f = sqrt(J2) + eta p - xi c(eps_p),     c(eps_p) = c0 + H eps_p,
//   potential g = sqrt(J2) + eta_bar p  (eta_bar from psi as eta from phi),
// with (eta, xi) matched to Mohr-Coulomb (de Souza Neto, Peric & Owen 2008, table 6.1):
//   plane_strain: eta = 3 tan(phi) / sqrt(9 + 12 tan^2 phi), xi = 3 / sqrt(9 + 12 tan^2 phi)
//                 (phi = 0: sqrt(J2) <= c, Tresca's c in plane strain: the footing's
//                 (2 + pi) c of Prandtl);
//   compression:  eta = 6 sin(phi) / (sqrt(3) (3 - sin phi)), xi = 6 cos(phi) / (sqrt(3) (3 - sin
//   phi))
//                 (the outer cone, through the triaxial-compression corners);
//   extension:    the same with 3 + sin(phi) (the inner cone).
// The return mapping (de Souza Neto et al., Boxes 8.8-8.9), after the elastic predictor
// sigma_tr = sigma^n + dt (D : d + W sigma - sigma W):
//   1. tension cut-off: p_tr above t (the key, or the apex eta p = xi c when psi = 0, where
//      no plastic flow can lower p) is brought back to t by a volumetric plastic strain;
//   2. cone: the consistency condition in dgamma,
//        sqrt(J2_tr) - G dgamma + eta (p_tr - K eta_bar dgamma) - xi c(eps_p + xi dgamma)
//          - [Perzyna] xi c0 (r / fluidity)^(1/N) = 0,  r = dgamma / dt (backward Euler;
//          the full step: the trapezoidal rule's end rate, below),
//      then s = (1 - G dgamma / sqrt(J2_tr)) s_tr, p = p_tr - K eta_bar dgamma,
//      eps_p += xi dgamma; valid while sqrt(J2_tr) >= G dgamma. The stress update (not the
//      characteristic boundary's return) takes the deviatoric direction at the step's
//      midpoint instead, as J2Plasticity does (j2_plasticity.hpp): n along s_tr + s_c, s_c
//      where the step's elastic path sigma^n -> sigma_tr leaves the cone, s = s_tr -
//      sqrt(2) G dgamma n, and dgamma from
//        sqrt(J2_tr - 2 sqrt(J2_tr) cos G dgamma + G^2 dgamma^2) + eta (p_tr - K eta_bar
//          dgamma) - xi c(eps_p + xi dgamma) [- Perzyna] = 0,   cos = s_tr : n / |s_tr|
//      (second order in dt where the spin turns the deviator; radial where the cut-off
//      acted or the midpoint return would pass the apex);
//   3. otherwise the apex (s = 0): the volumetric plastic strain de_v solves
//        p_tr - K de_v = (xi / eta) [c(eps_p + (xi / eta_bar) de_v) + Perzyna term],
//      eps_p += (xi / eta_bar) de_v.
// Each is exact for a step of homogeneous deformation with a fixed flow direction.
// Perzyna in the full step's cone return: the trapezoidal rule for the rate as J2's
// (j2_plasticity.hpp), dgamma = w/2 (r_n + r_{n+1}), r = fluidity <f / (xi c0)>^N, w = dt
// from a start outside the cone, else the part of the step after the path leaves it
// (second order: Perzyna.DruckerPragerObjectiveSimpleShearIsSecondOrderInDt); the apex,
// the predictor and the characteristic boundary keep backward Euler (dgamma = dt r_{n+1}).
// A step from outside the cone whose relaxation ends within it (unloading) relaxes until
// f = 0, then is elastic, as J2's (relaxation_ending).
// Known simplification: the cut-off and the cone are returned to one after the other,
// not as a two-surface corner return.
#pragma once

#include "engine/material/j2_plasticity.hpp"
#include "engine/material/linear_elastic.hpp"
#include "engine/material/plastic_state.hpp"
#include "engine/material/stress.hpp"
#include "engine/material/stress_update.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>

namespace tsph {

template <int Dim>
class DruckerPrager {
 public:
  enum class Cone { plane_strain, compression, extension };
  struct Parameters {
    double cohesion = 0.0;                                            ///< c0 (Pa) > 0
    double friction_angle = 0.0;                                      ///< phi (degrees) in [0, 90)
    double dilation_angle = 0.0;                                      ///< psi (degrees) in [0, phi]
    double hardening = 0.0;                                           ///< H (Pa): c = c0 + H eps_p
    double tension_cutoff = std::numeric_limits<double>::infinity();  ///< t (Pa), p <= t
    Cone cone = Cone::plane_strain;
  };
  struct Perzyna {
    double fluidity = 0.0;  ///< 1/s
    double exponent = 1.0;  ///< N >= 1
  };

  DruckerPrager(LinearElastic<Dim> elastic, Parameters parameters,
                std::optional<Perzyna> perzyna = std::nullopt)
      : elastic_(std::move(elastic)), p_(parameters), perzyna_(perzyna) {
    if constexpr (Dim == 1)
      throw std::invalid_argument("material (drucker_prager): needs two or three dimensions (1D is uniaxial stress)");
    require_plane_strain(elastic_);
    check_parameter("drucker_prager", "cohesion", p_.cohesion, 0.0, true,
                    "give the cohesion c in Pa");
    if (!(p_.friction_angle >= 0.0 && p_.friction_angle < 90.0))
      throw std::invalid_argument(
          "material (drucker_prager): friction_angle = " + std::to_string(p_.friction_angle) +
          " must lie in [0, 90) degrees");
    if (!(p_.dilation_angle >= 0.0 && p_.dilation_angle <= p_.friction_angle))
      throw std::invalid_argument(
          "material (drucker_prager): dilation_angle = " + std::to_string(p_.dilation_angle) +
          " must lie in [0, friction_angle = " + std::to_string(p_.friction_angle) + "] degrees");
    check_parameter("drucker_prager", "hardening", p_.hardening, 0.0, false, "give H >= 0 (Pa)");
    if (std::isnan(p_.tension_cutoff))
      throw std::invalid_argument("material (drucker_prager): tension_cutoff is not a number");
    if (perzyna_) {
      check_parameter("drucker_prager", "fluidity", perzyna_->fluidity, 0.0, true,
                      "give the Perzyna fluidity in 1/s");
      check_parameter("drucker_prager", "exponent", perzyna_->exponent, 1.0, false,
                      "give the Perzyna exponent N >= 1");
    }
    cone_constants(radians(p_.friction_angle), eta_, xi_);
    double unused = 0.0;
    cone_constants(radians(p_.dilation_angle), eta_bar_, unused);
  }

  const LinearElastic<Dim>& elastic() const { return elastic_; }
  double strain_energy_density(const StressVector<Dim>& stress) const {
    return elastic_.strain_energy_density(stress);
  }
  PlasticState initial_state() const { return {}; }
  double eta() const { return eta_; }
  /// phi = 0 without a tension cut-off: the yield function does not read the pressure.
  bool pressure_independent_yield() const { return eta_ == 0.0 && std::isinf(p_.tension_cutoff); }
  double xi() const { return xi_; }
  double eta_bar() const { return eta_bar_; }
  double cohesion(double plastic_strain) const {
    return p_.cohesion + p_.hardening * plastic_strain;
  }
  /// The yield function f at a stress (tension positive) and hardening variable.
  double yield_function(const Eigen::Matrix3d& sigma, double plastic_strain) const {
    const Eigen::Matrix3d s = deviator(sigma);
    return std::sqrt(0.5 * s.squaredNorm()) + eta_ * sigma.trace() / 3.0 -
           xi_ * cohesion(plastic_strain);
  }

  StressVector<Dim> update_stress(const StressUpdate<Dim>& in, PlasticState& state) const {
    const StressVector<Dim> rate = elastic_.stress_rate(in.velocity_gradient, in.rate_stress, in.objective);
    StressVector<Dim> trial;
    for (int m = 0; m < stress_component_count<Dim>; ++m) trial[m] = in.stress[m] + in.dt * rate[m];
    return return_map(trial, state, in.dt, in.predictor ? nullptr : &in.stress);
  }

  /// Steps 1-3 of the file comment: the return of an elastic trial stress reached over
  /// dt; with the step's start sigma^n (`start`), the cone return along the midpoint
  /// deviatoric direction, else radially.
  StressVector<Dim> return_map(const StressVector<Dim>& trial, PlasticState& state, double dt,
                               const StressVector<Dim>* start = nullptr) const {
    state.yielding = false;
    // In the stress arrays' layout (stress.hpp: contract, deviator_of), not as 3x3 tensors.
    double mean = mean_of<Dim>(trial);
    StressVector<Dim> dev = deviator_of<Dim>(trial);
    const double bulk = elastic_.model_lame() + 2.0 * elastic_.shear_modulus() / 3.0;
    const double shear = elastic_.shear_modulus();
    double work = 0.0;
    double eps = state.equivalent_plastic_strain;

    // 1. Tension cut-off (with psi = 0 the apex pressure is one: see the file comment).
    double cutoff = p_.tension_cutoff;
    if (eta_bar_ == 0.0 && eta_ > 0.0) cutoff = std::min(cutoff, xi_ * cohesion(eps) / eta_);
    if (mean > cutoff) {
      start = nullptr;  // the cone's return from the cut-off's stress: radial
      const double volumetric = (mean - cutoff) / bulk;  // plastic tr(d eps^p)
      mean = cutoff;
      work += mean * volumetric;
      state.yielding = true;
    }
    // The return along the cone's flow direction by dgamma: s -= sqrt(2) mu dgamma n (the
    // deviatoric flow n / sqrt(2), |n| = 1; no further than the apex), p -= K eta_bar dgamma.
    const auto flow = [&](double dgamma, const StressVector<Dim>& direction) {
      const double along = std::min(std::sqrt(2.0) * shear * dgamma, contract<Dim>(dev, direction));
      for (int m = 0; m < stress_component_count<Dim>; ++m) dev[m] -= along * direction[m];
      mean -= bulk * eta_bar_ * dgamma;
      eps += xi_ * dgamma;
      work += dgamma * (contract<Dim>(dev, direction) / std::sqrt(2.0) + eta_bar_ * mean);  // sigma : d eps^p
      state.yielding = true;
    };
    // Perzyna's rate at the step's start (the full step; file comment: the trapezoidal
    // rule; < 0: backward Euler), and a step from outside the cone whose relaxation ends
    // within it (unloading): the flow until then, elastic after (relaxation_ending).
    double start_rate = -1.0;
    std::optional<std::pair<double, StressVector<Dim>>> ended;
    if (start && perzyna_) {
      start_rate = perzyna_rate(yield_function(to_tensor<Dim>(*start), eps));
      ended = relaxation_ending(*start, start_rate, dev, mean, eps, dt);
      if (ended) flow(ended->first, ended->second);
    }
    // 2. Cone.
    const double root_j2 = std::sqrt(0.5 * contract<Dim>(dev, dev));
    const double f_trial = root_j2 + eta_ * mean - xi_ * cohesion(eps);
    if (!ended && f_trial > 0.0) {
      state.yielding = true;
      const double slope_elastic = shear + bulk * eta_ * eta_bar_ + xi_ * xi_ * p_.hardening;
      // With the step's start: along the midpoint deviatoric direction (file comment),
      // where that return stays on the cone's side of the apex; else radially.
      double dgamma = std::numeric_limits<double>::quiet_NaN();
      StressVector<Dim> direction = scaled<Dim>(dev, root_j2 > 0.0 ? 1.0 / (std::sqrt(2.0) * root_j2) : 0.0);
      const double target = xi_ * cohesion(eps) - eta_ * mean;  // sqrt(J2) on the cone at dgamma = 0
      if (start && target > 0.0 && root_j2 > 0.0) {
        double leaves = 0.0;
        const StressVector<Dim> midpoint = midpoint_direction(*start, dev, mean, eps, &leaves);
        const double alignment = contract<Dim>(dev, midpoint) / (std::sqrt(2.0) * root_j2);
        if (start_rate > 0.0) leaves = 0.0;  // Perzyna: from the start outside the cone, else from where the path leaves it
        dgamma = cone_increment(root_j2, alignment, target, slope_elastic - shear, dt, start_rate,
                                std::max(1.0 - leaves, 1e-12) * dt);
        if (std::isfinite(dgamma)) direction = midpoint;
      }
      if (!std::isfinite(dgamma)) {
        if (!perzyna_) {
          dgamma = f_trial / slope_elastic;
        } else {
          const double c0 = p_.cohesion, scale = dt * perzyna_->fluidity, power = 1.0 / perzyna_->exponent;
          dgamma = decreasing_root(
              [&](double x, double& slope) {
                const double viscous = xi_ * c0 * std::pow(x / scale, power);
                slope = -slope_elastic - (x > 0.0 ? power * viscous / x : 0.0);
                return f_trial - slope_elastic * x - viscous;
              },
              f_trial / slope_elastic);
        }
        // With psi = 0 the cut-off has kept p at or below the apex, and the cone return is
        // valid up to round-off.
        if (!(root_j2 - shear * dgamma >= 0.0 || eta_bar_ == 0.0)) dgamma = -1.0;  // past the apex
      }
      if (dgamma >= 0.0) {
        flow(dgamma, direction);
      } else {
        // 3. Apex (eta_bar > 0 here: with psi = 0 the cut-off kept p at or below it).
        const double alpha = xi_ / eta_bar_, beta = xi_ / eta_;
        const double p_trial = mean, eps0 = eps;
        const auto residual = [&](double x, double& slope) {
          double viscous = 0.0, viscous_slope = 0.0;
          if (perzyna_) {
            const double power = 1.0 / perzyna_->exponent;
            viscous = p_.cohesion * std::pow(alpha * x / xi_ / (dt * perzyna_->fluidity), power);
            viscous_slope = x > 0.0 ? power * viscous / x : 0.0;
          }
          slope = -bulk - beta * (alpha * p_.hardening + viscous_slope);
          return p_trial - bulk * x - beta * (cohesion(eps0 + alpha * x) + viscous);
        };
        double volumetric = 0.0;
        if (!perzyna_)
          volumetric = (p_trial - beta * cohesion(eps0)) / (bulk + alpha * beta * p_.hardening);
        else
          volumetric = decreasing_root(residual, p_trial / bulk);
        dev = {};
        mean = p_trial - bulk * volumetric;
        eps = eps0 + alpha * volumetric;
        work += mean * volumetric;
      }
    }
    if (state.yielding) {
      state.equivalent_plastic_strain = eps;
      state.plastic_work += work;
    }
    for (int m = 0; m < stress_component_count<Dim>; ++m)
      if (is_normal_component<Dim>(m)) dev[m] += mean;
    return dev;
  }

 private:
  /// Perzyna's rate at the overstress f: fluidity <f / (xi c0)>^N.
  double perzyna_rate(double overstress) const {
    return overstress > 0.0 ? perzyna_->fluidity * std::pow(overstress / (xi_ * p_.cohesion), perzyna_->exponent)
                            : 0.0;
  }

  /// A Perzyna step from a start sigma^n outside the cone (rate r_n = perzyna_rate(f_n) >
  /// 0) whose trapezoidal flow dgamma = r_n dt / 2 would end inside it (as
  /// J2Plasticity::relaxation_ending): the relaxation ends at the fraction tau of the step
  /// where f reaches zero along the elastic path sigma^n + tau (sigma_tr - sigma^n) less the
  /// flow r_n tau dt / 2 (the start's direction: deviatoric n^n, volumetric eta_bar), the
  /// rest of the step elastic if its path stays inside. Returns {dgamma, n^n}, or nothing
  /// (the step's regular return) where the flow lasts the whole step, would pass the
  /// apex, or the path leaves the cone again.
  [[gnu::noinline]] std::optional<std::pair<double, StressVector<Dim>>> relaxation_ending(
      const StressVector<Dim>& start, double rate, const StressVector<Dim>& trial_deviator, double trial_mean,
      double eps, double dt) const {
    const StressVector<Dim> s0 = deviator_of<Dim>(start);
    const double p0 = mean_of<Dim>(start);
    const double s0_norm = std::sqrt(contract<Dim>(s0, s0));
    if (!(rate > 0.0 && s0_norm > 0.0)) return std::nullopt;  // s0 = 0: held at the apex
    const StressVector<Dim> n = scaled<Dim>(s0, 1.0 / s0_norm);
    const double shear = elastic_.shear_modulus(), bulk = elastic_.model_lame() + 2.0 * shear / 3.0;
    // f at the fraction tau of the elastic path after the flow dgamma; `along`: s . n there.
    const auto yield_at = [&](double tau, double dgamma, double& along) {
      StressVector<Dim> s;
      for (int m = 0; m < stress_component_count<Dim>; ++m)
        s[m] = s0[m] + tau * (trial_deviator[m] - s0[m]) - std::sqrt(2.0) * shear * dgamma * n[m];
      along = contract<Dim>(s, n);
      const double p = p0 + tau * (trial_mean - p0) - bulk * eta_bar_ * dgamma;
      return std::sqrt(0.5 * contract<Dim>(s, s)) + eta_ * p - xi_ * cohesion(eps + xi_ * dgamma);
    };
    const auto flow_until = [&](double tau) { return 0.5 * rate * tau * dt; };
    double along = 0.0;
    if (!(yield_at(1.0, flow_until(1.0), along) < 0.0)) return std::nullopt;
    double outside = 0.0, inside = 1.0;
    for (int i = 0; i < 100 && inside - outside > 1e-15; ++i) {
      const double mid = 0.5 * (outside + inside);
      (yield_at(mid, flow_until(mid), along) > 0.0 ? outside : inside) = mid;
    }
    const double dgamma = flow_until(0.5 * (outside + inside));
    if (!(yield_at(1.0, dgamma, along) <= 0.0 && along >= 0.0)) return std::nullopt;
    return std::make_pair(dgamma, n);
  }

  /// The deviatoric flow direction of the midpoint rule (file comment): along s_tr + s_c,
  /// s_c the deviator where the segment sigma^n -> sigma_tr leaves the cone f = 0 (its
  /// larger crossing in [0, 1]; sigma^n itself when the step starts on or outside the
  /// cone and moves out). On the segment sigma^n + t (sigma_tr - sigma^n),
  ///   |s^n + t ds|^2 = 2 (xi c - eta (p^n + t dp))^2,  with xi c - eta p >= 0.
  StressVector<Dim> midpoint_direction(const StressVector<Dim>& start, const StressVector<Dim>& trial_deviator,
                                       double trial_mean, double eps, double* leaving = nullptr) const {
    const StressVector<Dim> s0 = deviator_of<Dim>(start);
    StressVector<Dim> ds;
    for (int m = 0; m < stress_component_count<Dim>; ++m) ds[m] = trial_deviator[m] - s0[m];
    const double p0 = mean_of<Dim>(start), dp = trial_mean - p0, q0 = xi_ * cohesion(eps) - eta_ * p0;
    const double a = contract<Dim>(ds, ds) - 2.0 * eta_ * eta_ * dp * dp;
    const double b = contract<Dim>(s0, ds) + 2.0 * eta_ * dp * q0;  // half the linear coefficient
    const double c = contract<Dim>(s0, s0) - 2.0 * q0 * q0;
    double leaves = 0.0;
    const auto consider = [&](double t) {
      if (t >= 0.0 && t <= 1.0 && q0 - eta_ * dp * t >= 0.0) leaves = std::max(leaves, t);
    };
    if (a != 0.0) {
      if (const double discriminant = b * b - a * c; discriminant >= 0.0) {
        const double root = std::sqrt(discriminant);
        const double q = -(b + std::copysign(root, b));  // the two roots q / a and c / q
        if (q != 0.0) consider(c / q);
        consider(q / a);
      }
    } else if (b != 0.0) {
      consider(-0.5 * c / b);
    }
    if (leaving) *leaving = leaves;
    StressVector<Dim> sum;
    for (int m = 0; m < stress_component_count<Dim>; ++m) sum[m] = trial_deviator[m] + s0[m] + leaves * ds[m];
    return scaled<Dim>(sum, 1.0 / std::sqrt(contract<Dim>(sum, sum)));
  }

  /// The cone return's dgamma along a deviatoric direction at `alignment` (cos) with s_tr:
  /// sqrt(J2) = sqrt(r^2 - 2 r cos mu dgamma + mu^2 dgamma^2) = target + slope dgamma
  /// [+ Perzyna's xi c0 (rate / fluidity)^(1/N), rate = dgamma / dt, or with start_rate
  /// r_n >= 0 the trapezoidal 2 dgamma / w - r_n over flow_window w], r = sqrt(J2_tr), target =
  /// xi c(eps_p) - eta p_tr, slope = K eta eta_bar + xi^2 H; the root short of the point
  /// closest to the apex's axis (dgamma <= r cos / mu). NaN where there is none.
  double cone_increment(double root_j2, double alignment, double target, double slope, double dt,
                        double start_rate = -1.0, double flow_window = 0.0) const {
    const double shear = elastic_.shear_modulus(), along = root_j2 * alignment;
    const double farthest = along / shear;
    if (!(farthest > 0.0)) return std::numeric_limits<double>::quiet_NaN();
    if (!perzyna_) {  // the smaller root of (mu^2 - slope^2) x^2 - 2 (r cos mu + target slope) x + r^2 - target^2
      const double half_b = along * shear + target * slope;
      const double constant = (root_j2 - target) * (root_j2 + target);
      const double discriminant = half_b * half_b - (shear * shear - slope * slope) * constant;
      if (!(discriminant >= 0.0 && half_b > 0.0)) return std::numeric_limits<double>::quiet_NaN();
      const double x = constant / (half_b + std::sqrt(discriminant));
      return x <= farthest ? x : std::numeric_limits<double>::quiet_NaN();
    }
    // The rate at the step's end: dgamma / dt (backward Euler), or with the step's start
    // rate r_n the trapezoidal rule's 2 dgamma / w - r_n over the flow window w (file comment).
    const double c0 = p_.cohesion, power = 1.0 / perzyna_->exponent;
    const double weight = start_rate >= 0.0 ? 2.0 / flow_window : 1.0 / dt, offset = std::max(0.0, start_rate);
    const auto residual = [&](double x, double& derivative) {
      const double distance =
          std::sqrt(std::max(0.0, root_j2 * root_j2 - 2.0 * along * shear * x + shear * shear * x * x));
      const double rate = std::max(0.0, weight * x - offset);
      const double viscous = xi_ * c0 * std::pow(rate / perzyna_->fluidity, power);
      derivative = (distance > 0.0 ? shear * (shear * x - along) / distance : 0.0) - slope -
                   (rate > 0.0 ? power * viscous / rate * weight : 0.0);
      return distance - target - slope * x - viscous;
    };
    double unused = 0.0;
    if (!(residual(farthest, unused) < 0.0)) return std::numeric_limits<double>::quiet_NaN();
    return decreasing_root(residual, farthest);
  }

  void cone_constants(double angle, double& eta, double& xi) const {
    switch (p_.cone) {
      case Cone::plane_strain: {
        const double t = std::tan(angle), root = std::sqrt(9.0 + 12.0 * t * t);
        eta = 3.0 * t / root;
        xi = 3.0 / root;
        break;
      }
      case Cone::compression:
      case Cone::extension: {
        const double sign = p_.cone == Cone::compression ? -1.0 : 1.0;
        const double denominator = std::sqrt(3.0) * (3.0 + sign * std::sin(angle));
        eta = 6.0 * std::sin(angle) / denominator;
        xi = 6.0 * std::cos(angle) / denominator;
        break;
      }
    }
  }

  LinearElastic<Dim> elastic_;
  Parameters p_;
  std::optional<Perzyna> perzyna_;
  double eta_ = 0.0, xi_ = 1.0, eta_bar_ = 0.0;
};

}  // namespace tsph
