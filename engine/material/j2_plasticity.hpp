// J2 (von Mises) plasticity with the Jaumann rate (issue 16): linear isotropic and
// kinematic hardening, or the Johnson-Cook strength (strain hardening, strain rate,
// optional thermal softening from the plastic work), optionally regularised by Perzyna
// viscoplasticity. Dim = 1 (uniaxial stress), 2 (plane strain or plane stress) and 3.
//
// Each step (Simo & Hughes 1998, Box 3.2; de Souza Neto, Peric & Owen 2008, section 7.3):
//   1. elastic predictor: sigma_tr = sigma^n + dt (D : d + W sigma - sigma W)
//      (LinearElastic::stress_rate), back stress alpha_tr = alpha + dt (W alpha - alpha W);
//   2. xi_tr = dev(sigma_tr) - alpha_tr, q_tr = sqrt(3/2) |xi_tr| (1D: |sigma_tr - alpha|);
//   3. if q_tr > Y(eps_p): the consistency condition in the plastic strain increment
//      de = sqrt(2/3) dgamma,
//        q_tr - (3 mu + H_kin) de - Y(eps_p + de, de / dt) = 0      (1D: E in place of 3 mu)
//      (closed form for linear hardening; otherwise a safeguarded Newton solve), then
//      the return along the flow direction n:
//        s = dev(sigma_tr) - 2 mu dgamma n,  alpha += 2/3 H_kin dgamma n,  eps_p += de.
//    The half step's predictor (StressUpdate::predictor) and the characteristic
//    boundary's return (return_map without the step's start) return radially, n = xi_tr /
//    |xi_tr| (backward Euler), the predictor with the back stress turned by dt (W alpha -
//    alpha W). The full step's stress update takes n at the step's midpoint (the
//    generalised midpoint rule with alpha = 1/2; Ortiz & Popov 1985, Simo & Hughes 1998
//    ch. 3): n along xi_c + xi^{n+1}, xi_c where the step's elastic
//    path xi^n -> xi_tr leaves the yield surface (xi^n when it starts on it). With
//    xi^{n+1} = xi_tr - (2 mu + 2/3 H_kin) dgamma n this is n along xi_tr + xi_c, known
//    before the return; the consistency condition then reads
//        sqrt(q_tr^2 - 2 A de q_tr cos + A^2 de^2) - Y(eps_p + de, de / dt) = 0,
//    A = 3 mu + H_kin, cos = xi_tr : n / |xi_tr| (a quadratic for linear hardening). The
//    back stress turns with the spin over the step (Hughes & Winget 1980; Q alpha Q^T,
//    Q = (I - dt/2 W)^-1 (I + dt/2 W)) and its plastic increment over half the step:
//    xi^{n+1} = xi_tr - dgamma v, v = 2 mu n + 2/3 H_kin R(n), R(n) = n + dt/2 (W n - n W),
//    and the consistency condition is solved along v (the stress ends on the surface to
//    round-off). A path whose flow direction turns (simple shear, where the spin turns
//    the stress) is then integrated to second order in dt (the radial return and the
//    forward rotation: first order, 9.7e-6 of the stress in the J2 simple shear of `tsph
//    validate plastic` at CFL 0.9, against ~1e-9 now) for the rate-independent laws.
//    Johnson-Cook's rate term C sees the backward-Euler rate de / dt: first order, with an
//    error 50-100 times smaller than the radial return's (a reviewer's measurement,
//    2026-11-27). Both returns are exact (to round-off) for a step of homogeneous
//    deformation with a fixed flow direction, so the stepped response of a radial path is
//    its closed form. 1D and 2D plane stress keep the radial return.
//    Perzyna in the full step: the trapezoidal rule for the rate, de = w/2 (r_n + r_{n+1}),
//    r = fluidity <(q - Y) / Y0>^N, so the law sees the end rate r_{n+1} = 2 de / w - r_n
//    (clipped at 0: the stress then ends on the surface); r_n from the start's overstress
//    over the whole step (w = dt) when the start lies outside the surface, else r_n = 0 over
//    the part of the step after the elastic path leaves it (w = (1 - s_c) dt). A step from
//    outside whose flow de = r_n dt / 2 would end inside (unloading) relaxes until the
//    overstress reaches zero, at s dt with the rate falling linearly (bisection along the
//    elastic path, the start's flow direction), then is elastic (relaxation_ending). Second
//    order in dt (tests/test_plasticity.cpp, Perzyna.*SecondOrder*: 1.6e-6, 4.1e-7, 1.0e-7 of
//    the stress at 200, 400, 800 steps); backward Euler (de = dt r_{n+1}: first order; 1.7e-4
//    in `tsph validate plastic_j2_perzyna_3d --quick` run at CFL 0.9 on main c6c3f12) stays
//    the predictor's, the characteristic boundary's, 1D's and plane stress's, and the
//    fallback where the trapezoidal rule has no root. Known gap: a step from outside whose
//    trial lies inside and whose relaxation would overshoot the surface's far side returns
//    elastic.
// The yield stress Y:
//   linear:        Y = sigma_y + H_iso eps_p;
//   Johnson-Cook:  Y = (A + B eps_p^n) (1 + C ln max(1, rate / rate_0)) (1 - T*^m),
//                  T* = (T - T_room) / (T_melt - T_room) in [0, 1), rate = de / dt;
//   Perzyna:       Y + sigma_y (rate / fluidity)^(1 / N), i.e. the overstress law
//                  rate = fluidity <(q - Y) / sigma_y>^N (Perzyna 1966).
// Thermal softening: the temperature rises by chi dW_p / (rho_0 c_v) after each step
// (Taylor-Quinney factor chi; explicit in the temperature: the step's Y uses T^n).
//
// Plane stress (2D, material.plane = "stress"; isotropic hardening, Johnson-Cook or
// Perzyna, no kinematic hardening): sigma_zz = 0 with a free plastic e_zz, by the
// plane-stress projected return (Simo & Taylor 1986; de Souza Neto et al. 2008, section
// 9.4.3). With the in-plane trial stress from the plane-stress elastic law, the new stress
// is sigma = [C^-1 + dgamma P]^-1 C^-1 sigma_tr, diagonal in the eigenvectors shared by C
// and the projector P (von Mises q^2 = 3/2 sigma^T P sigma):
//   s11 + s22 = (s11 + s22)_tr / (1 + E dgamma / (3 (1 - nu))),
//   s22 - s11 = (s22 - s11)_tr / (1 + 2 mu dgamma),  s12 = s12_tr / (1 + 2 mu dgamma),
// dgamma the root of  xi(dgamma) / 2 - Y(eps_p + de, de / dt)^2 / 3 = 0  with
//   xi = (s11 + s22)^2 / 6 + (s22 - s11)^2 / 2 + 2 s12^2 (at the new stress),
//   de = dgamma sqrt(2 xi / 3),  and plastic work dgamma xi = Y de.
#pragma once

#include "engine/material/linear_elastic.hpp"
#include "engine/material/plastic_state.hpp"
#include "engine/material/stress.hpp"
#include "engine/material/stress_update.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>
#include <utility>

namespace tsph {

/// The full 3x3 velocity gradient of a Dim-dimensional one (zero out of plane).
template <int Dim>
Eigen::Matrix3d embed_gradient(const Matrix<Dim>& grad_v) {
  Eigen::Matrix3d g = Eigen::Matrix3d::Zero();
  g.topLeftCorner<Dim, Dim>() = grad_v;
  return g;
}

/// The spin W = skew(L) of a Dim-dimensional velocity gradient, as a full 3x3 tensor.
template <int Dim>
Eigen::Matrix3d spin_of(const Matrix<Dim>& grad_v) {
  const Eigen::Matrix3d g = embed_gradient<Dim>(grad_v);
  return 0.5 * (g - g.transpose());
}

/// Drucker-Prager's refusal of a 2D plane-stress elastic part (its return keeps sigma_zz
/// as a stress of its own: plane strain; J2 has a plane-stress return).
template <int Dim>
void require_plane_strain(const LinearElastic<Dim>& elastic) {
  if constexpr (Dim == 2)
    if (elastic.plane_mode() == PlaneMode::plane_stress)
      throw std::invalid_argument(
          "material: drucker_prager in 2D needs material.plane = \"strain\" (its plane-stress return "
          "mapping, sigma_zz = 0 with a plastic e_zz, is not implemented)");
}

template <int Dim>
class J2Plasticity {
 public:
  /// Linear hardening: Y = yield_stress + isotropic_modulus eps_p; the back stress grows
  /// by 2/3 kinematic_modulus d eps^p.
  struct Linear {
    double yield_stress = 0.0;
    double isotropic_modulus = 0.0;
    double kinematic_modulus = 0.0;
  };
  /// Johnson & Cook (1983). `thermal`: the softening term and the heating by plastic
  /// work (off: T stays at room temperature and the term is 1).
  struct JohnsonCook {
    double a = 0.0, b = 0.0, n = 1.0, c = 0.0;
    double reference_rate = 1.0;  ///< rate_0 (1/s)
    bool thermal = false;
    double room_temperature = 293.0, melt_temperature = 1356.0, m = 1.0;
    double specific_heat = 383.0;  ///< c_v (J/(kg K))
    double taylor_quinney = 0.9;   ///< chi, the part of the plastic work turned into heat
  };
  /// Perzyna regularisation (linear hardening only): fluidity (1/s) > 0, exponent N >= 1.
  struct Perzyna {
    double fluidity = 0.0;
    double exponent = 1.0;
  };

  J2Plasticity(LinearElastic<Dim> elastic, Linear hardening,
               std::optional<Perzyna> perzyna = std::nullopt)
      : elastic_(std::move(elastic)), linear_(hardening), perzyna_(perzyna) {
    check_parameter("j2", "yield_stress", linear_.yield_stress, 0.0, true,
                    "give the initial yield stress in Pa");
    check_parameter("j2", "isotropic_hardening", linear_.isotropic_modulus, 0.0, false,
                    "give a hardening modulus >= 0 (Pa)");
    check_parameter("j2", "kinematic_hardening", linear_.kinematic_modulus, 0.0, false,
                    "give a hardening modulus >= 0 (Pa)");
    if (plane_stress() && linear_.kinematic_modulus > 0.0)
      throw std::invalid_argument(
          "material (j2): kinematic_hardening = " + std::to_string(linear_.kinematic_modulus) +
          " is not available in plane stress (the plane-stress return has isotropic hardening only): "
          "set it to 0, or use material.plane = \"strain\"");
    if (perzyna_) {
      check_parameter("j2", "fluidity", perzyna_->fluidity, 0.0, true,
                      "give the Perzyna fluidity in 1/s");
      check_parameter("j2", "exponent", perzyna_->exponent, 1.0, false,
                      "give the Perzyna exponent N >= 1");
    }
  }
  J2Plasticity(LinearElastic<Dim> elastic, JohnsonCook strength)
      : elastic_(std::move(elastic)), johnson_cook_(strength) {
    const JohnsonCook& j = *johnson_cook_;
    check_parameter("johnson_cook", "A", j.a, 0.0, true, "give the initial yield stress A in Pa");
    check_parameter("johnson_cook", "B", j.b, 0.0, false, "give the hardening B >= 0 (Pa)");
    check_parameter("johnson_cook", "n", j.n, 0.0, true, "give the hardening exponent n > 0");
    check_parameter("johnson_cook", "C", j.c, 0.0, false,
                    "give the strain-rate coefficient C >= 0");
    check_parameter("johnson_cook", "reference_rate", j.reference_rate, 0.0, true,
                    "give rate_0 in 1/s");
    if (j.thermal) {
      check_parameter("johnson_cook", "m", j.m, 0.0, true, "give the thermal exponent m > 0");
      check_parameter("johnson_cook", "room_temperature", j.room_temperature, 0.0, true,
                      "give T_room in K");
      if (!(j.melt_temperature > j.room_temperature))
        throw std::invalid_argument(
            "material (johnson_cook): melt_temperature = " + std::to_string(j.melt_temperature) +
            " must be above room_temperature = " + std::to_string(j.room_temperature));
      check_parameter("johnson_cook", "specific_heat", j.specific_heat, 0.0, true,
                      "give c_v in J/(kg K)");
      check_parameter("johnson_cook", "taylor_quinney", j.taylor_quinney, 0.0, false,
                      "give chi in [0, 1]");
      if (j.taylor_quinney > 1.0)
        throw std::invalid_argument("material (johnson_cook): taylor_quinney = " +
                                    std::to_string(j.taylor_quinney) + " must be at most 1");
    }
  }

  const LinearElastic<Dim>& elastic() const { return elastic_; }
  double strain_energy_density(const StressVector<Dim>& stress) const {
    return elastic_.strain_energy_density(stress);
  }
  bool is_johnson_cook() const { return johnson_cook_.has_value(); }
  /// The state the model reads: the back stress (kinematic hardening), the temperature
  /// (Johnson-Cook's thermal softening).
  bool reads_back_stress() const { return has_kinematic(); }
  bool reads_temperature() const { return johnson_cook_ && johnson_cook_->thermal; }

  /// The state of a virgin particle (the temperature at room temperature).
  PlasticState initial_state() const {
    PlasticState state;
    if (johnson_cook_) state.temperature = johnson_cook_->room_temperature;
    return state;
  }

  /// The current yield stress Y(eps_p, rate) at temperature T (see the file comment).
  double yield_stress(double plastic_strain, double rate, double temperature) const {
    if (johnson_cook_) {
      const JohnsonCook& j = *johnson_cook_;
      double y = j.a + (plastic_strain > 0.0 ? j.b * std::pow(plastic_strain, j.n) : 0.0);
      if (j.c > 0.0 && rate > j.reference_rate) y *= 1.0 + j.c * std::log(rate / j.reference_rate);
      if (j.thermal) y *= 1.0 - std::pow(homologous(temperature), j.m);
      return y;
    }
    double y = linear_.yield_stress + linear_.isotropic_modulus * plastic_strain;
    if (perzyna_ && rate > 0.0)
      y += linear_.yield_stress * std::pow(rate / perzyna_->fluidity, 1.0 / perzyna_->exponent);
    return y;
  }

  /// sigma^{n+1} and the particle's state at n+1 from sigma^n, L and dt (file comment).
  StressVector<Dim> update_stress(const StressUpdate<Dim>& in, PlasticState& state) const {
    const StressVector<Dim> rate =
        elastic_.stress_rate(in.velocity_gradient, in.rate_stress, in.objective);
    StressVector<Dim> trial;
    for (int m = 0; m < stress_component_count<Dim>; ++m) trial[m] = in.stress[m] + in.dt * rate[m];
    if constexpr (Dim == 1) {
      return return_map(trial, state, in.dt);
    } else {
      if (in.predictor) {  // the half step (StressUpdate::predictor): O(dt^2) per step suffices
        if (in.objective && has_kinematic()) {
          const Eigen::Matrix3d spin = spin_of<Dim>(in.velocity_gradient);
          state.back_stress += in.dt * (spin * state.back_stress - state.back_stress * spin);
        }
        return return_map(trial, state, in.dt);
      }
      Eigen::Matrix3d back_stress_at_n;  // before the rotation below (read only on yielding)
      const bool rotate_back_stress = in.objective && has_kinematic();
      if (rotate_back_stress) {
        back_stress_at_n = state.back_stress;
        // Q = (I - A)^-1 (I + A) = I + 2 / (1 + |a|^2) (A + A^2), A = dt/2 W with axial vector a.
        const Eigen::Matrix3d half = 0.5 * in.dt * spin_of<Dim>(in.velocity_gradient);
        const Eigen::Matrix3d q =
            Eigen::Matrix3d::Identity() + 2.0 / (1.0 + 0.5 * half.squaredNorm()) * (half + half * half);
        state.back_stress = q * state.back_stress * q.transpose();
      }
      const StepStart start{in.stress, rotate_back_stress ? back_stress_at_n : state.back_stress,
                            in.velocity_gradient, in.objective};
      return return_map(trial, state, in.dt, &start);
    }
  }

  /// Where a step began, for the midpoint flow direction (file comment): sigma^n, the
  /// back stress alpha^n, and the velocity gradient whose spin turns the step (when the
  /// Jaumann terms are on). Read only when the step yields.
  struct StepStart {
    const StressVector<Dim>& stress;
    const Eigen::Matrix3d& back_stress;
    const Matrix<Dim>& velocity_gradient;
    bool objective;
  };

  /// Steps 2-3 of the file comment: the return of an elastic trial stress reached over
  /// dt; with the step's start, along the midpoint flow direction, else radially.
  StressVector<Dim> return_map(const StressVector<Dim>& trial, PlasticState& state, double dt,
                               const StepStart* start = nullptr) const {
    state.yielding = false;
    if constexpr (Dim == 1) {
      const double relative = trial[0] - state.back_stress(0, 0);
      const double q_trial = std::abs(relative);
      const double increment = plastic_increment(q_trial, elastic_.young_modulus(), state, dt);
      if (increment <= 0.0) return trial;
      const double direction = relative > 0.0 ? 1.0 : -1.0;
      StressVector<Dim> updated{trial[0] - elastic_.young_modulus() * increment * direction};
      state.back_stress(0, 0) += linear_.kinematic_modulus * increment * direction;
      finish(state, increment, updated[0] * direction * increment);
      return updated;
    } else {
      if constexpr (Dim == 2)
        if (plane_stress()) return plane_stress_return(trial, state, dt);
      // In the stress arrays' layout (4 components in 2D, 6 in 3D; `contract` is the tensor
      // product), not as 3x3 tensors: the return is a fifth of a plastic step's cost.
      const Compact back = from_tensor<Dim>(state.back_stress);
      const Compact relative = deviator_of<Dim>(trial, back);  // xi_tr
      const double norm = std::sqrt(contract<Dim>(relative, relative));
      const double q_trial = std::sqrt(1.5) * norm;
      const double yield = yield_stress(state.equivalent_plastic_strain, 0.0, state.temperature);
      const double twice_shear = 2.0 * elastic_.shear_modulus();
      // The full step's start: xi^n (read on yielding, and by Perzyna before the yield
      // check), and Perzyna's rate r_n there (file comment: the trapezoidal rule; < 0:
      // backward Euler).
      const auto relative_at_start = [&] { return deviator_of<Dim>(start->stress, from_tensor<Dim>(start->back_stress)); };
      Compact start_relative;  // set where read
      double start_rate = -1.0;
      if (start && perzyna_) {
        start_relative = relative_at_start();
        start_rate = perzyna_rate(start_relative, state.equivalent_plastic_strain, state.temperature);
        // A step from outside the surface whose relaxation ends within it (unloading):
        // the flow until then, elastic after.
        if (const auto ended = relaxation_ending(start_relative, start_rate, relative, state, dt))
          return flow(trial, state, ended->first, ended->second, ended->second);
      }
      if (!(q_trial > yield)) return trial;
      Compact direction = scaled<Dim>(relative, 1.0 / norm);  // n (radial)
      Compact back_direction = direction;                // R(n), below
      double increment = std::numeric_limits<double>::quiet_NaN();
      double flow_window = dt;  // Perzyna: the part of the step with plastic flow
      if (start) {
        // The full step: along the midpoint direction n, or radially where it misses the
        // surface. xi^{n+1} = xi_tr - dgamma v, v = 2 mu n + 2/3 H_kin R(n), R(n) = n +
        // dt/2 (W n - n W): the back stress's increment, made over the step, turned with
        // it over half the step on average (file comment); the consistency condition along v.
        const bool turn = has_kinematic() && start->objective;
        const Eigen::Matrix3d spin = turn ? spin_of<Dim>(start->velocity_gradient) : Eigen::Matrix3d::Zero();
        const auto increment_along = [&](const Compact& n) {
          double along = twice_shear * contract<Dim>(relative, n), squared = twice_shear * twice_shear;  // xi_tr : v, |v|^2
          if (has_kinematic()) {
            back_direction = n;
            if (turn) {
              const Eigen::Matrix3d tensor = to_tensor<Dim>(n);
              back_direction = from_tensor<Dim>(tensor + 0.5 * dt * (spin * tensor - tensor * spin));
            }
            Compact v;
            for (int m = 0; m < kComponents; ++m)
              v[m] = twice_shear * n[m] + (2.0 / 3.0) * linear_.kinematic_modulus * back_direction[m];
            along = contract<Dim>(relative, v), squared = contract<Dim>(v, v);
          }
          return plastic_increment_along(q_trial, 1.5 * std::sqrt(1.5) * along, 2.25 * squared, state, dt, yield,
                                         start_rate, flow_window);
        };
        if (!perzyna_) start_relative = relative_at_start();
        double leaves = 0.0;
        const Compact midpoint = midpoint_direction(start_relative, relative, yield, &leaves);
        // Perzyna from a start inside the surface: r_n = 0 where the step's path leaves it.
        if (perzyna_ && !(start_rate > 0.0)) flow_window = std::max(1.0 - leaves, 1e-12) * dt;
        increment = increment_along(midpoint);
        if (std::isfinite(increment)) direction = midpoint;
        else increment = increment_along(direction);
      }
      if (!std::isfinite(increment)) {  // radial (the characteristic boundary's, the predictor's)
        increment = plastic_increment(q_trial, 1.5 * twice_shear, state, dt, yield);
        back_direction = direction;
      }
      return flow(trial, state, increment, direction, back_direction);
    }
  }

 private:
  bool plane_stress() const { return Dim == 2 && elastic_.plane_mode() == PlaneMode::plane_stress; }

  /// A symmetric tensor in the stress arrays' layout (stress.hpp: contract, deviator_of).
  using Compact = StressVector<Dim>;
  static constexpr int kComponents = stress_component_count<Dim>;

  /// The plane-stress return (see the file comment): sigma_zz = 0, isotropic hardening.
  StressVector<Dim> plane_stress_return(const StressVector<Dim>& trial, PlasticState& state, double dt) const {
    const Eigen::Matrix3d sigma = to_tensor<Dim>(trial);
    const double sum = sigma(0, 0) + sigma(1, 1), difference = sigma(1, 1) - sigma(0, 0), shear = sigma(0, 1);
    const double eps = state.equivalent_plastic_strain;
    const auto xi_at = [&](double dgamma, double& sum_factor, double& shear_factor) {
      sum_factor = 1.0 / (1.0 + elastic_.young_modulus() * dgamma / (3.0 * (1.0 - elastic_.poisson_ratio())));
      shear_factor = 1.0 / (1.0 + 2.0 * elastic_.shear_modulus() * dgamma);
      const double a = sum * sum_factor, b = difference * shear_factor, c = shear * shear_factor;
      return a * a / 6.0 + 0.5 * b * b + 2.0 * c * c;
    };
    double sum_factor = 1.0, shear_factor = 1.0;
    const double xi_trial = xi_at(0.0, sum_factor, shear_factor);
    if (!(std::sqrt(1.5 * xi_trial) > yield_stress(eps, 0.0, state.temperature))) return trial;
    // phi(dgamma) = xi / 2 - Y^2 / 3 decreases from phi(0) > 0 (xi falls, de and Y rise).
    const auto phi = [&](double dgamma) {
      double f1 = 0.0, f2 = 0.0;
      const double xi = xi_at(dgamma, f1, f2);
      const double increment = dgamma * std::sqrt(2.0 * xi / 3.0);
      const double y = yield_stress(eps + increment, increment / dt, state.temperature);
      return 0.5 * xi - y * y / 3.0;
    };
    double upper = 1.0 / (2.0 * elastic_.shear_modulus());
    for (int doubling = 0; doubling < 200 && phi(upper) > 0.0; ++doubling) upper *= 2.0;
    const double dgamma = decreasing_root(
        [&](double x, double& slope) {
          const double value = phi(x);
          const double step = std::max(1e-8 * x, 1e-300);
          slope = (phi(x + step) - value) / step;
          return value;
        },
        upper);
    const double xi = xi_at(dgamma, sum_factor, shear_factor);
    const double increment = dgamma * std::sqrt(2.0 * xi / 3.0);
    const double new_sum = sum * sum_factor, new_difference = difference * shear_factor;
    Eigen::Matrix3d updated = Eigen::Matrix3d::Zero();
    updated(0, 0) = 0.5 * (new_sum - new_difference);
    updated(1, 1) = 0.5 * (new_sum + new_difference);
    updated(0, 1) = updated(1, 0) = shear * shear_factor;
    finish(state, increment, dgamma * xi);
    return from_tensor<Dim>(updated);
  }

  bool has_kinematic() const { return !johnson_cook_ && linear_.kinematic_modulus > 0.0; }
  double homologous(double temperature) const {
    const JohnsonCook& j = *johnson_cook_;
    return std::clamp(
        (temperature - j.room_temperature) / (j.melt_temperature - j.room_temperature), 0.0, 1.0);
  }

  /// The return of the trial stress along the flow direction n by the plastic strain
  /// increment de (file comment): sigma_tr - 2 mu dgamma n, alpha += 2/3 H_kin dgamma
  /// R(n) (`back_direction`), dgamma = sqrt(3/2) de.
  StressVector<Dim> flow(const StressVector<Dim>& trial, PlasticState& state, double increment,
                         const Compact& direction, const Compact& back_direction) const {
    const double dgamma = std::sqrt(1.5) * increment;  // |d eps^p| = sqrt(3/2) de
    StressVector<Dim> updated;  // n is deviatoric: the mean stays
    for (int m = 0; m < kComponents; ++m) updated[m] = trial[m] - 2.0 * elastic_.shear_modulus() * dgamma * direction[m];
    if (has_kinematic())
      state.back_stress += to_tensor<Dim>(scaled<Dim>(back_direction, (2.0 / 3.0) * linear_.kinematic_modulus * dgamma));
    finish(state, increment, dgamma * contract<Dim>(updated, direction));
    return updated;
  }

  /// Perzyna's rate at a relative stress xi and plastic strain: fluidity <(q - Y) / Y0>^N.
  [[gnu::noinline]] double perzyna_rate(const Compact& xi, double plastic_strain, double temperature) const {
    const double overstress =
        std::sqrt(1.5 * contract<Dim>(xi, xi)) - yield_stress(plastic_strain, 0.0, temperature);
    return overstress > 0.0 ? perzyna_->fluidity * std::pow(overstress / linear_.yield_stress, perzyna_->exponent)
                            : 0.0;
  }

  /// A Perzyna step from a start xi^n outside the surface (rate r_n > 0) whose trapezoidal
  /// flow would end inside it with a zero end rate (de = r_n dt / 2 brings the stress
  /// inside): the relaxation ends at the fraction tau of the step where the overstress
  /// reaches zero, the rate falling linearly from r_n, de = r_n tau dt / 2, along the
  /// start's direction n^n, with the step's elastic path xi^n + tau (xi_tr - xi^n) up to
  /// there (bisection). The rest of the step is elastic. Returns {de, n^n}, or nothing
  /// where the flow lasts the whole step.
  [[gnu::noinline]] std::optional<std::pair<double, Compact>> relaxation_ending(
      const Compact& start_relative, double rate, const Compact& trial_relative, const PlasticState& state,
      double dt) const {
    if (!(rate > 0.0)) return std::nullopt;
    const double eps = state.equivalent_plastic_strain;
    const Compact n = scaled<Dim>(start_relative, 1.0 / std::sqrt(contract<Dim>(start_relative, start_relative)));
    const double modulus = 2.0 * elastic_.shear_modulus() + (2.0 / 3.0) * linear_.kinematic_modulus;  // |v| along n
    // The overstress at the fraction tau of the elastic path after the flow de.
    const auto overstress = [&](double tau, double de) {
      Compact xi;
      for (int m = 0; m < kComponents; ++m)
        xi[m] = start_relative[m] + tau * (trial_relative[m] - start_relative[m]) - std::sqrt(1.5) * de * modulus * n[m];
      return std::sqrt(1.5 * contract<Dim>(xi, xi)) - yield_stress(eps + de, 0.0, state.temperature);
    };
    const auto flow_until = [&](double tau) { return 0.5 * rate * tau * dt; };
    if (!(overstress(1.0, flow_until(1.0)) < 0.0)) return std::nullopt;
    double outside = 0.0, inside = 1.0;
    for (int i = 0; i < 100 && inside - outside > 1e-15; ++i) {
      const double mid = 0.5 * (outside + inside);
      (overstress(mid, flow_until(mid)) > 0.0 ? outside : inside) = mid;
    }
    const double de = flow_until(0.5 * (outside + inside));
    // The rest of the step elastic only if its path stays inside: else the step's regular
    // return (its end rate clipped at zero, on the surface).
    if (!(overstress(1.0, de) <= 0.0)) return std::nullopt;
    return std::make_pair(de, n);
  }

  /// The flow direction of the midpoint rule (file comment): along xi_tr + xi_c, xi_c the
  /// point where the segment xi^n -> xi_tr leaves the yield surface |xi| = sqrt(2/3)
  /// Y(eps_p) (its larger crossing, clamped to the segment: xi^n itself when the step
  /// starts on or outside the surface and moves out).
  Compact midpoint_direction(const Compact& start, const Compact& trial, double yield, double* leaving = nullptr) const {
    const double radius = std::sqrt(2.0 / 3.0) * yield;
    Compact path;
    for (int m = 0; m < kComponents; ++m) path[m] = trial[m] - start[m];
    const double a = contract<Dim>(path, path), b = contract<Dim>(start, path), c = contract<Dim>(start, start) - radius * radius;
    double leaves = 0.0;  // |start + s path|^2 = radius^2: a s^2 + 2 b s + c = 0, the larger root
    if (const double discriminant = b * b - a * c; a > 0.0 && discriminant >= 0.0) {
      const double root = std::sqrt(discriminant);
      leaves = b <= 0.0 ? (root - b) / a : (root + b > 0.0 ? -c / (root + b) : 0.0);
    }
    leaves = std::clamp(leaves, 0.0, 1.0);
    if (leaving) *leaving = leaves;
    Compact sum;
    for (int m = 0; m < kComponents; ++m) sum[m] = trial[m] + start[m] + leaves * path[m];
    return scaled<Dim>(sum, 1.0 / std::sqrt(contract<Dim>(sum, sum)));
  }

  /// The equivalent plastic strain increment de of the step along the return direction
  /// v (xi^{n+1} = xi_tr - sqrt(3/2) de v; 0: elastic): the root of
  ///   sqrt(q_tr^2 - 2 b de + c de^2) - Y(eps_p + de, r) = 0,  r = de / dt, or Perzyna's
  ///   trapezoidal end rate 2 de / w - r_n (start_rate r_n >= 0, flow_window w),
  /// b = (3/2)^(3/2) xi_tr : v, c = (9/4) |v|^2 (radial, v = (2 mu + 2/3 H_kin) n: b = A q_tr,
  /// c = A^2, A = 3 mu + H_kin, and plastic_increment's q_tr - A de - Y), short of the
  /// line's point closest to the surface's centre (de <= b / c). NaN where there is none
  /// (the caller returns radially). `yield`: Y(eps_p, 0).
  double plastic_increment_along(double q_trial, double b, double c, const PlasticState& state, double dt,
                                 double yield, double start_rate = -1.0, double flow_window = 0.0) const {
    const double eps = state.equivalent_plastic_strain;
    const double f_trial = q_trial - yield;
    if (!(f_trial > 0.0)) return 0.0;
    const double closest = b / c;
    if (!(closest > 0.0)) return std::numeric_limits<double>::quiet_NaN();
    if (!johnson_cook_ && !perzyna_) {  // linear: the smaller root of a quadratic
      // (c - H^2) de^2 - 2 (b + Y H) de + (q^2 - Y^2) = 0, as (q^2 - Y^2) / (half_b + sqrt(half_b^2 - ...)).
      const double h = linear_.isotropic_modulus, half_b = b + yield * h;
      const double constant = f_trial * (q_trial + yield);
      const double discriminant = half_b * half_b - (c - h * h) * constant;
      if (!(discriminant >= 0.0 && half_b > 0.0)) return std::numeric_limits<double>::quiet_NaN();
      const double de = constant / (half_b + std::sqrt(discriminant));
      return de <= closest ? de : std::numeric_limits<double>::quiet_NaN();
    }
    // Nonlinear: the residual decreases on [0, b / c] (the distance to the line's closest
    // point falls, Y rises) and must change sign there.
    // The rate the law sees at the step's end: de / dt (backward Euler), or with Perzyna
    // and the step's start rate r_n the trapezoidal rule's 2 de / w - r_n over the flow
    // window w (file comment).
    const auto end_rate = [&](double de) {
      return start_rate >= 0.0 ? std::max(0.0, 2.0 * de / flow_window - start_rate) : de / dt;
    };
    const auto residual = [&](double de, double& slope) {
      const double distance = std::sqrt(std::max(0.0, q_trial * q_trial - 2.0 * b * de + c * de * de));
      const double y = yield_stress(eps + de, end_rate(de), state.temperature);
      const double step = std::max(1e-8 * de, 1e-300);
      const double y_plus = yield_stress(eps + de + step, end_rate(de + step), state.temperature);
      slope = (distance > 0.0 ? (c * de - b) / distance : 0.0) - (y_plus - y) / step;
      return distance - y;
    };
    double unused = 0.0;
    if (!(residual(closest, unused) < 0.0)) return std::numeric_limits<double>::quiet_NaN();
    return decreasing_root(residual, closest);
  }

  /// The equivalent plastic strain increment de of the radial return (0: elastic): the
  /// root of q_trial - (modulus + H_kin) de - Y(eps_p + de, de / dt), modulus = 3 mu (1D:
  /// E). `yield`: Y(eps_p, 0) where the caller has it.
  double plastic_increment(double q_trial, double modulus, const PlasticState& state, double dt,
                           double yield = -1.0) const {
    const double eps = state.equivalent_plastic_strain;
    if (yield < 0.0) yield = yield_stress(eps, 0.0, state.temperature);
    const double f_trial = q_trial - yield;
    if (!(f_trial > 0.0)) return 0.0;
    const double slope_elastic = modulus + (johnson_cook_ ? 0.0 : linear_.kinematic_modulus);
    if (!johnson_cook_ && !perzyna_)  // linear: closed form
      return f_trial / (slope_elastic + linear_.isotropic_modulus);
    const auto residual = [&](double de, double& slope) {
      const double y = yield_stress(eps + de, de / dt, state.temperature);
      // dY/d(de) by a central difference scaled to de (the laws are smooth for de > 0).
      const double step = std::max(1e-8 * de, 1e-300);
      const double y_plus = yield_stress(eps + de + step, (de + step) / dt, state.temperature);
      slope = -slope_elastic - (y_plus - y) / step;
      return q_trial - slope_elastic * de - y;
    };
    return decreasing_root(residual, q_trial / slope_elastic);
  }

  /// Records a plastic step: the strain, the work, and Johnson-Cook heating.
  void finish(PlasticState& state, double increment, double work) const {
    state.yielding = true;
    state.equivalent_plastic_strain += increment;
    state.plastic_work += work;
    if (johnson_cook_ && johnson_cook_->thermal)
      state.temperature += johnson_cook_->taylor_quinney * work /
                           (elastic_.reference_density() * johnson_cook_->specific_heat);
  }

  LinearElastic<Dim> elastic_;
  Linear linear_{};
  std::optional<JohnsonCook> johnson_cook_;
  std::optional<Perzyna> perzyna_;
};

}  // namespace tsph
