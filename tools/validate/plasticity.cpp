// Homogeneous elastoplastic deformation (issue 16, item 3): the block of
// tools/cases/homogeneous_{2,3}d.toml with a plastic material.model, every particle
// driven by v = G x (uniaxial strain, G = diag(rate, 0, 0)), updated Lagrangian, past
// first yield; the stress and the equivalent plastic strain of every particle against
// the closed-form responses of engine/validation/elastoplastic.hpp (J2 with linear
// isotropic and kinematic hardening, Johnson-Cook, perfectly plastic Drucker-Prager in
// compression, and in hydrostatic expansion to its apex). With no spin and a fixed principal frame the Jaumann rate integrates
// the logarithmic strain exactly, so the closed forms hold at eps = rate t. The cycles
// (J2, Johnson-Cook, Drucker-Prager) scale G by a time table (1, then -1: v = f(t) G x, eps = rate int_0^t f): loaded to
// ln(stretch) 0.15, unloaded and yielded in reverse to about -0.05 (the end on a whole
// step; J2: the Bauschinger effect of the kinematic hardening); Drucker-Prager compressed
// to -0.15 and reversed to about 0.02, where it yields on the cone's extension side.
// The simple shears (J2, Johnson-Cook, Drucker-Prager; v_x = rate y to gamma = 1, or to 0.5 and reversed
// by the same time table to about -0.1) turn the flow direction with the spin: no closed
// form; the reference is the Jaumann-rate equations integrated to convergence
// (elastoplastic::integrate_gradient_path), which the stepper meets to second order in dt
// (J2Plasticity's midpoint flow direction).
#include "engine/material/drucker_prager.hpp"
#include "engine/time_function.hpp"
#include "engine/validation/elastoplastic.hpp"
#include "tools/validate/support.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace tsph::validate {
namespace {

enum class Model { j2, johnson_cook, drucker_prager };

struct PlasticSpec {
  std::string name, description;
  int dimension = 2;
  Model model = Model::j2;
  double log_strain = 0.15;  ///< ln(stretch) at the end (negative: compression)
  double reverse_at = 0.0;   ///< ln(stretch) of the load reversal (0: monotonic)
  bool hydrostatic = false;  ///< Drucker-Prager, 3D: G = rate I (expansion to the apex), not uniaxial strain
  bool shear = false;        ///< simple shear G = rate e_x (x) e_y to gamma = log_strain, not uniaxial strain
  double fluidity = 0.0;     ///< Perzyna viscoplasticity (J2, Drucker-Prager; 0: rate independent)
  double exponent = 1.0;     ///< Perzyna's N
};

constexpr double kReversal = 0.1;  ///< s: f(t) goes from 1 to -1 linearly over about this time

constexpr double kRate = 0.05;  ///< true strain rate (1/s), as the elastic homogeneous cases
constexpr int kFrames = 30;
constexpr double kTolerance = 1e-6;  ///< issue 16: the closed-form response to 1e-6

// The parameters (the case files' E = 1e6 Pa, nu = 0.3): first yield at a strain of
// 0.026 (J2, JC) and -0.056 (Drucker-Prager), the end 3 to 6 times beyond.
constexpr double kYield = 2e4, kIsotropic = 1e5, kKinematic = 5e4;       // j2
constexpr double kA = 2e4, kB = 8e4, kN = 0.4;                           // johnson_cook
constexpr double kCohesion = 1e4, kFriction = 20.0, kDilation = 5.0;     // drucker_prager
constexpr double kFluidity = 0.1;                                        // Perzyna (1/s)
constexpr double kPerzynaCfl = 0.2;  ///< the Perzyna cases' CFL (the case files': 0.9)

std::vector<std::string> material_overrides(const PlasticSpec& s) {
  std::vector<std::string> perzyna;
  if (s.fluidity > 0.0)
    perzyna = {fmt::format("material.fluidity={}", s.fluidity), fmt::format("material.exponent={}", s.exponent)};
  std::vector<std::string> base;
  switch (s.model) {
    case Model::j2:
      base = {"material.model=\"j2\"", fmt::format("material.yield_stress={}", kYield),
              fmt::format("material.isotropic_hardening={}", kIsotropic),
              fmt::format("material.kinematic_hardening={}", kKinematic)};
      break;
    case Model::johnson_cook:
      base = {"material.model=\"johnson_cook\"", fmt::format("material.A={}", kA), fmt::format("material.B={}", kB),
              fmt::format("material.n={}", kN)};
      break;
    case Model::drucker_prager:
      base = {"material.model=\"drucker_prager\"", fmt::format("material.cohesion={}", kCohesion),
              fmt::format("material.friction_angle={}", kFriction),
              fmt::format("material.dilation_angle={}", kDilation)};
      break;
  }
  base.insert(base.end(), perzyna.begin(), perzyna.end());
  return base;
}

/// The closed-form stress at the log strain e, and its equivalent plastic strain.
/// `reversed`: past the cycle's reversal at the strain `peak`.
/// The reference of the simple shears and of the Perzyna cases at `time`: the rate
/// equations under the case's gradient, v = f(t) G x (`gradient`: G as 3x3), converged
/// (RK4 with |G| dt <= 2.5e-4, Perzyna 6.25e-5, f's kinks and zero as step boundaries).
Eigen::Matrix3d rate_reference(const PlasticSpec& s, const CaseFile& c, const Eigen::Matrix3d& g, double time,
                               const TimeFunction& f, const std::vector<double>& breakpoints, double& plastic) {
  const double young = c.young_modulus, nu = c.poisson_ratio;
  const auto scale = [&](double t) { return f(t); };
  const double step = (s.fluidity > 0.0 ? 6.25e-5 : 2.5e-4) / kRate;
  elastoplastic::RateState y;
  if (s.model == Model::j2) {
    y = elastoplastic::integrate_gradient_path(
        elastoplastic::J2Rates{young, nu, kYield, kIsotropic, kKinematic, s.fluidity, s.exponent}, g, scale,
        breakpoints, time, step);
  } else if (s.model == Model::johnson_cook) {  // its eps_p^n as the variable: d gamma 6.25e-5 (converged to 1e-10)
    const elastoplastic::JohnsonCookRates rates{young, nu, kA, kB, kN};
    y = elastoplastic::integrate_gradient_path(rates, g, scale, breakpoints, time, 0.25 * step);
    plastic = rates.plastic_strain(y);
    return y.stress;
  } else {
    typename DruckerPrager<3>::Parameters p;
    p.cohesion = kCohesion, p.friction_angle = kFriction, p.dilation_angle = kDilation;
    const DruckerPrager<3> model(LinearElastic<3>(young, nu, c.density), p);  // its cone constants
    y = elastoplastic::integrate_gradient_path(
        elastoplastic::DruckerPragerRates{young, nu, kCohesion, 0.0, model.eta(), model.xi(), model.eta_bar(),
                                          s.fluidity, s.exponent},
        g, scale, breakpoints, time, step);
  }
  plastic = y.plastic_strain;
  return y.stress;
}

Eigen::Matrix3d reference(const PlasticSpec& s, const CaseFile& c, double e, double& plastic, double peak = 0.0,
                          bool reversed = false) {
  const double young = c.young_modulus, nu = c.poisson_ratio;
  switch (s.model) {
    case Model::j2:
      return elastoplastic::j2_uniaxial_strain_cycle(young, nu, kYield, kIsotropic, kKinematic, peak, reversed,
                                                     e, &plastic);
    case Model::johnson_cook:
      return elastoplastic::johnson_cook_uniaxial_strain_cycle(young, nu, kA, kB, kN, peak, reversed, e, &plastic);
    case Model::drucker_prager: {
      typename DruckerPrager<3>::Parameters p;
      p.cohesion = kCohesion, p.friction_angle = kFriction, p.dilation_angle = kDilation;
      const DruckerPrager<3> model(LinearElastic<3>(young, nu, c.density), p);  // its cone constants
      if (s.hydrostatic)  // e: the log stretch of each axis
        return elastoplastic::drucker_prager_hydrostatic_expansion(young, nu, kCohesion, model.eta(), model.xi(),
                                                                   model.eta_bar(), 3.0 * e, &plastic);
      return elastoplastic::drucker_prager_uniaxial_cycle(young, nu, kCohesion, model.eta(), model.xi(),
                                                          model.eta_bar(), peak, reversed, e, &plastic);
    }
  }
  return Eigen::Matrix3d::Zero();
}

Result run_plastic(const PlasticSpec& s, const Options& o) {
  const bool cycle = s.reverse_at != 0.0;
  const double rate = std::copysign(kRate, cycle ? s.reverse_at : s.log_strain);
  std::vector<double> g(static_cast<std::size_t>(s.dimension * s.dimension), 0.0);
  for (int d = 0; d < (s.hydrostatic ? s.dimension : 1); ++d) g[static_cast<std::size_t>(d * (s.dimension + 1))] = rate;
  if (s.shear) g = std::vector<double>(g.size(), 0.0), g[1] = rate;  // L_xy: v_x = rate y
  std::vector<std::string> overrides = {"boundary.0.velocity_gradient=" + toml_array(g),
                                        "initial.velocity_gradient=" + toml_array(g)};
  for (auto& m : material_overrides(s)) overrides.push_back(m);
  // Perzyna's rate law is integrated to second order in dt, not exactly (the trapezoidal
  // rule, J2Plasticity's file comment): CFL 0.2 puts its error below 1e-6 with a margin.
  if (s.fluidity > 0.0) overrides.push_back(fmt::format("time.cfl={}", kPerzynaCfl));
  if (s.dimension == 2) overrides.push_back("material.plane=\"strain\"");
  if (o.quick) overrides.push_back(s.dimension == 2 ? "geometry.spacing=0.2" : "geometry.spacing=0.25");
  const std::string file = s.dimension == 2 ? "homogeneous_2d.toml" : "homogeneous_3d.toml";
  // The cycle's f(t): 1 until t_a, linear to -1 at t_b, then -1, with t_a and t_b on step
  // boundaries (multiples of the run's dt, read from a one-step run), where the midpoint
  // rule of the stress update integrates f exactly; the strain peaks at (t_a + t_b) / 2.
  TimeFunction f = TimeFunction::constant(1.0);
  std::vector<double> breakpoints;  // f's kinks and zero (the shears' reference)
  double end = s.log_strain / rate, turn = end;
  if (cycle) {
    std::vector<std::string> probe = overrides;
    probe.insert(probe.end(), {"time.end=1e-6", "output.times=[1e-6]"});
    const double dt = run_case_file(o, file, probe, "dt").report.dt;
    const double steps_a = std::round((s.reverse_at / rate - 0.25 * kReversal) / dt);
    // An even count puts the turn (f = 0, the strain's peak) on a step boundary too: a
    // step across it would see only the net increment and miss the plastic flow up to the peak.
    const double steps_turn = 2.0 * std::max(1.0, std::round(0.5 * kReversal / dt));
    const double t_a = steps_a * dt, t_b = (steps_a + steps_turn) * dt;
    f = TimeFunction::table({t_a, t_b}, {1.0, -1.0});
    turn = 0.5 * (t_a + t_b);
    breakpoints = {t_a, turn, t_b};
    // int_0^end f = log_strain / rate, to a whole step; the frames on whole steps too (a
    // step is shortened to land on a frame, which would move the grid off t_a and t_b).
    const double frame_steps = std::round((t_b + f.integral(t_b) - s.log_strain / rate) / dt / kFrames);
    end = kFrames * frame_steps * dt;
    overrides.push_back(fmt::format("boundary.0.time={{ type = \"table\", times = [{:.17g}, {:.17g}], values = [1.0, -1.0] }}",
                                    t_a, t_b));
    std::string times = "output.times=[";
    for (int k = 1; k <= kFrames; ++k) times += fmt::format("{}{:.17g}", k > 1 ? ", " : "", k * frame_steps * dt);
    overrides.push_back(times + "]");
  } else {
    overrides.push_back(output_times(end, kFrames));
  }
  const double peak = rate * f.integral(turn);  // the cycle's largest strain
  const double final_strain = rate * f.integral(end);
  overrides.insert(overrides.end(), {fmt::format("time.end={:.17g}", end),
                                     "output.fields=[\"stress\",\"displacement\",\"id\",\"plastic\"]"});
  CaseRun run = run_case_file(o, file, overrides, "run");
  Result result;

  Series series;
  series.name = "stress";
  series.title = s.description;
  // Uniaxial: sigma_xx and sigma_yy; simple shear: sigma_xy and the normal stress sigma_xx the spin makes.
  const int second_i = s.shear ? 0 : 1, second_j = 1;
  const std::string strain_name = s.shear ? "gamma" : "ln(stretch)";
  const std::string second = s.shear ? "sigma_xy" : "sigma_yy";
  series.x_label = strain_name;
  series.y_label = "mean stress (Pa), plastic strain x 1e6";
  series.columns = {strain_name, "sigma_xx", second, "plastic strain x 1e6", "ref sigma_xx", "ref " + second,
                    "ref plastic strain x 1e6"};
  double final_plastic = 0.0;
  Eigen::Matrix3d gradient = Eigen::Matrix3d::Zero();  // G as 3x3 (plane strain: zero third row and column)
  for (int i = 0; i < s.dimension; ++i)
    for (int j = 0; j < s.dimension; ++j) gradient(i, j) = g[static_cast<std::size_t>(i * s.dimension + j)];
  const auto reference_at = [&](double time, double e, double& plastic_ref, bool reversed) {
    return s.shear || s.fluidity > 0.0 ? rate_reference(s, run.file, gradient, time, f, breakpoints, plastic_ref)
                                       : reference(s, run.file, e, plastic_ref, peak, reversed);
  };
  const Eigen::Matrix3d final_reference = reference_at(end, final_strain, final_plastic, cycle);
  const double scale = final_reference.cwiseAbs().maxCoeff();
  double worst = 0.0, worst_plastic = 0.0, mean_xx = 0.0, mean_yy = 0.0, mean_plastic = 0.0;
  for (std::size_t k = 0; k < run.frames.size(); ++k) {
    const double e = rate * f.integral(run.frame_times[k]);
    double plastic_ref = 0.0;
    const Eigen::Matrix3d ref = reference_at(run.frame_times[k], e, plastic_ref, cycle && run.frame_times[k] > turn);
    const auto& stress = array_of(run.frames[k], "stress");  // VTK order xx yy zz xy yz xz
    const auto& plastic = array_of(run.frames[k], "plastic_strain");
    const std::size_t n = run.frames[k].point_count;
    double sxx = 0.0, syy = 0.0, ep = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      const double* p = stress.data() + 6 * i;
      const double error = std::max({std::abs(p[0] - ref(0, 0)), std::abs(p[1] - ref(1, 1)), std::abs(p[2] - ref(2, 2)),
                                     std::abs(p[3] - ref(0, 1)), std::abs(p[4] - ref(1, 2)), std::abs(p[5] - ref(0, 2))}) /
                           scale;
      worst = std::max(worst, error);
      worst_plastic = std::max(worst_plastic, std::abs(plastic[i] - plastic_ref) / final_plastic);
      sxx += p[0] / static_cast<double>(n);
      syy += p[s.shear ? 3 : 1] / static_cast<double>(n);
      ep += plastic[i] / static_cast<double>(n);
    }
    series.rows.push_back({e, sxx, syy, 1e6 * ep, ref(0, 0), ref(second_i, second_j), 1e6 * plastic_ref});
    if (k + 1 == run.frames.size()) mean_xx = sxx, mean_yy = syy, mean_plastic = ep;
  }
  result.checks.push_back(no_divergence_check(run, result));
  if (run.diverged || run.frames.empty()) {
    result.series.push_back(std::move(series));
    return result;
  }
  const std::string when = fmt::format("{} = {:.4g}", strain_name, final_strain);
  result.checks.push_back(relative_check("mean sigma_xx at " + when, mean_xx, final_reference(0, 0), kTolerance));
  result.checks.push_back(
      relative_check("mean " + second + " at " + when, mean_yy, final_reference(second_i, second_j), kTolerance));
  result.checks.push_back(relative_check("mean plastic strain at " + when, mean_plastic, final_plastic, kTolerance));
  result.checks.push_back(
      bound_check(fmt::format("worst particle and frame, max |sigma - ref| / {:.4g} Pa", scale), worst, kTolerance));
  result.checks.push_back(bound_check("worst particle and frame, |eps_p - ref| / final eps_p", worst_plastic, kTolerance));
  result.notes.push_back(fmt::format("{} steps, dt = {:.4g} s, {} particles, {:.2f} s wall", run.report.steps,
                                     run.report.dt, run.report.real_particles, run.wall_seconds));
  result.series.push_back(std::move(series));
  return result;
}

}  // namespace

std::vector<Case> plasticity_cases() {
  const std::vector<PlasticSpec> specs = {
      {"plastic_j2_2d", "J2, isotropic + kinematic hardening, uniaxial strain to ln 1.16, plane strain", 2, Model::j2, 0.15},
      {"plastic_j2_3d", "J2, isotropic + kinematic hardening, uniaxial strain to ln 1.16, 3D", 3, Model::j2, 0.15},
      {"plastic_j2_cycle_2d", "J2, isotropic + kinematic hardening, uniaxial strain to ln 1.16, reversed to about ln 0.95, plane strain",
       2, Model::j2, -0.05, 0.15},
      {"plastic_j2_cycle_3d", "J2, isotropic + kinematic hardening, uniaxial strain to ln 1.16, reversed to about ln 0.95, 3D", 3,
       Model::j2, -0.05, 0.15},
      {"plastic_johnson_cook_3d", "Johnson-Cook (A, B, n), uniaxial strain to ln 1.16, 3D", 3, Model::johnson_cook, 0.15},
      {"plastic_johnson_cook_cycle_3d", "Johnson-Cook (A, B, n), uniaxial strain to ln 1.16, reversed to about ln 0.95, 3D", 3,
       Model::johnson_cook, -0.05, 0.15},
      {"plastic_drucker_prager_2d", "Drucker-Prager (phi 20, psi 5), uniaxial strain compression to ln 0.86, plane strain",
       2, Model::drucker_prager, -0.15},
      {"plastic_drucker_prager_3d", "Drucker-Prager (phi 20, psi 5), uniaxial strain compression to ln 0.86, 3D", 3,
       Model::drucker_prager, -0.15},
      {"plastic_drucker_prager_cycle_2d",
       "Drucker-Prager (phi 20, psi 5), uniaxial strain compression to ln 0.86, reversed to about ln 1.02 (yielding in "
       "extension), plane strain", 2, Model::drucker_prager, 0.02, -0.15},
      {"plastic_drucker_prager_cycle_3d",
       "Drucker-Prager (phi 20, psi 5), uniaxial strain compression to ln 0.86, reversed to about ln 1.02 (yielding in "
       "extension), 3D", 3, Model::drucker_prager, 0.02, -0.15},
      {"plastic_drucker_prager_apex_3d", "Drucker-Prager (phi 20, psi 5), hydrostatic expansion to J = 1.16: the apex, 3D",
       3, Model::drucker_prager, 0.05, 0.0, true},
      {"plastic_j2_shear_2d", "J2, isotropic + kinematic hardening, simple shear to gamma = 1 (the spin turns the stress), plane strain",
       2, Model::j2, 1.0, 0.0, false, true},
      {"plastic_j2_shear_3d", "J2, isotropic + kinematic hardening, simple shear to gamma = 1 (the spin turns the stress), 3D",
       3, Model::j2, 1.0, 0.0, false, true},
      {"plastic_j2_shear_cycle_2d",
       "J2, isotropic + kinematic hardening, simple shear to gamma = 0.5, reversed to about -0.1, plane strain", 2,
       Model::j2, -0.1, 0.5, false, true},
      {"plastic_j2_shear_cycle_3d",
       "J2, isotropic + kinematic hardening, simple shear to gamma = 0.5, reversed to about -0.1, 3D", 3, Model::j2,
       -0.1, 0.5, false, true},
      {"plastic_johnson_cook_shear_3d", "Johnson-Cook (A, B, n), simple shear to gamma = 1, 3D", 3, Model::johnson_cook,
       1.0, 0.0, false, true},
      {"plastic_johnson_cook_shear_cycle_3d",
       "Johnson-Cook (A, B, n), simple shear to gamma = 0.5, reversed to about -0.1, 3D", 3, Model::johnson_cook, -0.1,
       0.5, false, true},
      {"plastic_drucker_prager_shear_2d",
       "Drucker-Prager (phi 20, psi 5), simple shear to gamma = 1 (dilation against the driven volume), plane strain", 2,
       Model::drucker_prager, 1.0, 0.0, false, true},
      {"plastic_drucker_prager_shear_3d",
       "Drucker-Prager (phi 20, psi 5), simple shear to gamma = 1 (dilation against the driven volume), 3D", 3,
       Model::drucker_prager, 1.0, 0.0, false, true},
      {"plastic_drucker_prager_shear_cycle_3d",
       "Drucker-Prager (phi 20, psi 5), simple shear to gamma = 0.5, reversed to about -0.1, 3D", 3,
       Model::drucker_prager, -0.1, 0.5, false, true},
      // Perzyna viscoplasticity: the overstress law at the strain rate 0.05 1/s (J2: about
      // 50 % of Y0 above the surface; Drucker-Prager: about 70 % of xi c).
      {"plastic_j2_perzyna_3d", "J2 + Perzyna (fluidity 0.1 1/s, N = 1), uniaxial strain to ln 1.16, 3D", 3, Model::j2,
       0.15, 0.0, false, false, kFluidity, 1.0},
      {"plastic_j2_perzyna_cycle_3d",
       "J2 + Perzyna (fluidity 0.1 1/s, N = 1), uniaxial strain to ln 1.16, reversed to about ln 0.95 (relaxing while "
       "unloading), 3D", 3, Model::j2, -0.05, 0.15, false, false, kFluidity, 1.0},
      // The shears in plane strain: 36 particles against 125 in the quick suite (CFL 0.2
      // takes 4.5 times the steps; the 3D path is the uniaxial cases' and the cycles').
      {"plastic_j2_perzyna_shear_2d", "J2 + Perzyna (fluidity 0.1 1/s, N = 1), simple shear to gamma = 1, plane strain",
       2, Model::j2, 1.0, 0.0, false, true, kFluidity, 1.0},
      {"plastic_drucker_prager_perzyna_3d",
       "Drucker-Prager + Perzyna (fluidity 0.1 1/s, N = 2), uniaxial strain compression to ln 0.86, 3D", 3,
       Model::drucker_prager, -0.15, 0.0, false, false, kFluidity, 2.0},
      {"plastic_drucker_prager_perzyna_cycle_3d",
       "Drucker-Prager + Perzyna (fluidity 0.1 1/s, N = 2), uniaxial strain compression to ln 0.86, reversed to about "
       "ln 1.02 (relaxing while unloading, then yielding in extension), 3D", 3, Model::drucker_prager, 0.02, -0.15, false,
       false, kFluidity, 2.0},
      {"plastic_drucker_prager_perzyna_shear_2d",
       "Drucker-Prager + Perzyna (fluidity 0.1 1/s, N = 2), simple shear to gamma = 1, plane strain", 2,
       Model::drucker_prager, 1.0, 0.0, false, true, kFluidity, 2.0},
  };
  std::vector<Case> cases;
  for (const auto& s : specs)
    cases.push_back({s.name, s.description, false, [s](const Options& o) { return run_plastic(s, o); }});
  return cases;
}

}  // namespace tsph::validate
