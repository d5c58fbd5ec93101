// Free rigid rotation (issue 14, item 1): a free block (tools/cases/rotation_{2,3}d.toml)
// given the rigid spin v = omega e_z x (x - c), updated Lagrangian, three full turns, at
// alpha 0.6 and 1.2. Checks: no divergence, the angular momentum about the centre of
// mass kept to 1e-3, the shape that of the rigidly turned block to 0.05 dx (RMS after
// the best-fit rigid motion), and no stress beyond what the spin needs.
//
// The centripetal stress: a material line through the axis of half-length R spinning at
// omega carries sigma(r) = rho omega^2 (R^2 - r^2) / 2 (div sigma = -rho omega^2 r, free
// ends), at most rho omega^2 R^2 / 2 on the axis; a disc of radius R carries less
// ((3 + nu) / 8 rho omega^2 R^2, plane stress). With R the block's half-diagonal (the
// farthest particle) sigma_c = rho omega^2 R^2 / 2 bounds the static stress; the spin is
// started from zero stress, so the block breathes about the static state with up to
// twice it: the bound is 2 sigma_c = rho omega^2 R^2.
#include "engine/case/case_build.hpp"
#include "tools/validate/support.hpp"

#include <Eigen/Dense>
#include <fmt/core.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>

namespace tsph::validate {
namespace {

struct RotationSpec {
  std::string name, description;
  int dimension = 2;
  double alpha = 0.6;
};

constexpr double kOmega = 2.0;  ///< rad/s, the case files' spin (checked below)

/// Masses by particle id, from the built case (the frames do not carry them).
std::vector<double> masses_by_id(const CaseFile& c) {
  std::vector<double> mass;
  auto fill = [&](const auto& real) {
    mass.assign(real.size(), 0.0);
    for (std::size_t i = 0; i < real.size(); ++i) mass.at(real.id[i]) = real.mass[i];
  };
  if (c.dimension == 2) fill(build_case<2>(c).real);
  else fill(build_case<3>(c).real);
  return mass;
}

struct FrameFigures {
  double angular_momentum = 0.0;  ///< about the centre of mass, z component
  double shape_rms = 0.0;         ///< after the best-fit rigid motion (m)
  double angle = 0.0;             ///< of the best-fit rotation about z (rad, in (-pi, pi])
  double max_stress = 0.0;        ///< largest |principal stress| (Pa)
};

FrameFigures measure(const output::VtuFrame& f, const std::vector<double>& mass) {
  const std::size_t n = f.point_count;
  const auto& ids = ids_of(f);
  const auto& v = array_of(f, "velocity");
  const auto& x0 = array_of(f, "initial_position");
  const auto& stress = array_of(f, "stress");
  Eigen::Vector3d centre = Eigen::Vector3d::Zero(), centre0 = Eigen::Vector3d::Zero();
  double total = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const double m = mass.at(ids[i]);
    total += m;
    centre += m * Eigen::Vector3d(f.points[3 * i], f.points[3 * i + 1], f.points[3 * i + 2]);
    centre0 += m * Eigen::Vector3d(x0[3 * i], x0[3 * i + 1], x0[3 * i + 2]);
  }
  centre /= total;
  centre0 /= total;
  FrameFigures r;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  // Kabsch: sum (x - c)(X - C)^T
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d x = Eigen::Vector3d(f.points[3 * i], f.points[3 * i + 1], f.points[3 * i + 2]) - centre;
    const Eigen::Vector3d X = Eigen::Vector3d(x0[3 * i], x0[3 * i + 1], x0[3 * i + 2]) - centre0;
    const Eigen::Vector3d vi(v[3 * i], v[3 * i + 1], v[3 * i + 2]);
    r.angular_momentum += mass.at(ids[i]) * x.cross(vi)[2];
    covariance += x * X.transpose();
    const double* p = stress.data() + 6 * i;
    Eigen::Matrix3d s;
    s << p[0], p[3], p[5], p[3], p[1], p[4], p[5], p[4], p[2];
    r.max_stress = std::max(r.max_stress, Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(s).eigenvalues().cwiseAbs().maxCoeff());
  }
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(covariance, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  d(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;
  const Eigen::Matrix3d rotation = svd.matrixU() * d * svd.matrixV().transpose();  // x ~ R X
  double sum = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d x = Eigen::Vector3d(f.points[3 * i], f.points[3 * i + 1], f.points[3 * i + 2]) - centre;
    const Eigen::Vector3d X = Eigen::Vector3d(x0[3 * i], x0[3 * i + 1], x0[3 * i + 2]) - centre0;
    sum += (x - rotation * X).squaredNorm();
  }
  r.shape_rms = std::sqrt(sum / static_cast<double>(n));
  if (std::getenv("TSPH_VALIDATE_DEBUG")) {  // which particle and field deviate first
    double worst_v = 0.0, worst_s = 0.0;
    std::size_t iv = 0, is = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const Eigen::Vector3d x = Eigen::Vector3d(f.points[3 * i], f.points[3 * i + 1], f.points[3 * i + 2]) - centre;
      const Eigen::Vector3d rigid = kOmega * Eigen::Vector3d::UnitZ().cross(x);
      const double dv = (Eigen::Vector3d(v[3 * i], v[3 * i + 1], v[3 * i + 2]) - rigid).norm();
      if (dv > worst_v) { worst_v = dv; iv = i; }
      const double* p = stress.data() + 6 * i;
      const double sn = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2] + 2 * (p[3] * p[3] + p[4] * p[4] + p[5] * p[5]));
      if (sn > worst_s) { worst_s = sn; is = i; }
    }
    fmt::print(stderr, "  |v - rigid| max {:.3e} m/s at X = ({:.3g}, {:.3g}, {:.3g}); |sigma| max {:.3e} Pa at X = ({:.3g}, {:.3g}, {:.3g}); shape rms {:.3e}\n",
               worst_v, x0[3 * iv], x0[3 * iv + 1], x0[3 * iv + 2], worst_s, x0[3 * is], x0[3 * is + 1], x0[3 * is + 2], r.shape_rms);
  }
  r.angle = std::atan2(rotation(1, 0), rotation(0, 0));
  return r;
}

Result run_rotation(const RotationSpec& s, const Options& o) {
  const double turn = 2.0 * M_PI / kOmega;
  const int turns = o.quick ? 1 : 3;
  const int frames_per_turn = std::getenv("TSPH_VALIDATE_FRAMES") ? std::atoi(std::getenv("TSPH_VALIDATE_FRAMES")) : 12;
  const double end = turns * turn;
  std::vector<std::string> overrides = {fmt::format("method.alpha={}", s.alpha), fmt::format("time.end={:.17g}", end),
                                        output_times(end, turns * frames_per_turn)};
  // Quick: one turn of the 21 x 21 block (alpha 1.2: |L - L0| / L0 6.1e-4; the case file's
  // 41 x 41 over three turns 4.3e-4, 2026-12-06), of the 6^3 cube.
  if (o.quick) overrides.push_back(s.dimension == 2 ? "geometry.spacing=0.05" : "geometry.spacing=0.2");
  const std::string file = s.dimension == 2 ? "rotation_2d.toml" : "rotation_3d.toml";
  CaseRun run = run_case_file(o, file, overrides, "run", true);
  const CaseFile& c = run.file;
  if (std::abs(c.velocity_gradient[static_cast<std::size_t>(c.dimension)] - kOmega) > 1e-12)
    throw std::runtime_error(file + ": the validation assumes initial.velocity_gradient = omega e_z x x with omega = 2 rad/s");
  Result result;
  result.checks.push_back(no_divergence_check(run, result));
  const std::vector<double> mass = masses_by_id(c);
  // The farthest particle from the z axis: a corner of the square cross-section.
  const double half_diagonal = 0.5 * std::sqrt(2.0) * (c.box_upper[0] - c.box_lower[0]);
  const double sigma_c = 0.5 * c.density * kOmega * kOmega * half_diagonal * half_diagonal;

  Series history;
  history.name = "history";
  history.title = s.description;
  history.x_label = "turns";
  history.y_label = "relative to the bound (1 = at the tolerance)";
  history.columns = {"turns", "angular momentum change / 1e-3", "shape RMS / (0.05 dx)", "max stress / (2 sigma_c)",
                     "ref tolerance"};
  double worst_momentum = 0.0, worst_shape = 0.0, worst_stress = 0.0, worst_lag = 0.0;
  double l0 = 0.0;
  for (std::size_t k = 0; k < run.frames.size(); ++k) {
    if (std::getenv("TSPH_VALIDATE_DEBUG")) fmt::print(stderr, "t = {:.5g} s:\n", run.frame_times[k]);
    const FrameFigures fig = measure(run.frames[k], mass);
    if (k == 0) l0 = fig.angular_momentum;
    const double momentum = std::abs(fig.angular_momentum - l0) / std::abs(l0);
    const double t = run.frame_times[k];
    double lag = std::remainder(kOmega * t - fig.angle, 2.0 * M_PI);
    worst_momentum = std::max(worst_momentum, momentum);
    worst_shape = std::max(worst_shape, fig.shape_rms);
    worst_stress = std::max(worst_stress, fig.max_stress);
    if (std::abs(lag) > std::abs(worst_lag)) worst_lag = lag;
    history.rows.push_back({t / turn, momentum / 1e-3, fig.shape_rms / (0.05 * c.spacing), fig.max_stress / (2.0 * sigma_c), 1.0});
  }
  const std::string span = run.diverged ? fmt::format("to t = {:.4g} s (diverged)", run.diverged_time)
                                        : fmt::format("over {} turns", turns);
  result.checks.push_back(bound_check("angular momentum change |L - L0| / L0 " + span, worst_momentum, 1e-3));
  result.checks.push_back(bound_check("shape RMS after best-fit rigid motion / dx " + span, worst_shape / c.spacing, 0.05));
  result.checks.push_back(bound_check(fmt::format("max |principal stress| (Pa) {} (bound rho omega^2 R^2, R = {:.4g} m)", span, half_diagonal),
                                      worst_stress, 2.0 * sigma_c));
  // A run that diverged did not turn its turns: its figures up to the divergence cannot
  // pass (the 3D cube at alpha 0.6 diverged at step 3, before its first frame after
  // t = 0, and its untouched state passed all three).
  if (run.diverged)
    for (std::size_t k = result.checks.size() - 3; k < result.checks.size(); ++k) result.checks[k].pass = false;
  if (!run.steps.empty()) {
    Series energy;
    energy.name = "energy";
    energy.title = s.description + ": energy";
    energy.x_label = "turns";
    energy.y_label = "(E - E0) / E0";
    energy.columns = {"turns", "total energy change", "ref 0"};
    const double e0 = 0.5 * [&] {  // the initial kinetic energy: sum m |omega x r|^2 / 2
      double sum = 0.0;
      const auto& f = run.frames.front();
      const auto& ids = ids_of(f);
      for (std::size_t i = 0; i < f.point_count; ++i) {
        const double x = f.points[3 * i], y = f.points[3 * i + 1];
        sum += mass.at(ids[i]) * kOmega * kOmega * (x * x + y * y);
      }
      return sum;
    }();
    double worst_gain = -1e300, final_change = 0.0;
    const std::size_t stride = std::max<std::size_t>(1, run.steps.size() / 400);
    for (std::size_t k = 0; k < run.steps.size(); ++k) {
      const double change = (run.steps[k].kinetic_energy + run.steps[k].strain_energy - e0) / e0;
      worst_gain = std::max(worst_gain, change);
      final_change = change;
      if (k % stride == 0 || k + 1 == run.steps.size()) energy.rows.push_back({run.steps[k].time / turn, change, 0.0});
    }
    result.series.push_back(std::move(energy));
    // The largest gain and the change at the end: a block that brakes loses its energy
    // (a loss the largest gain, taken at the first steps, does not show).
    result.notes.push_back(fmt::format("energy (E - E0) / E0: largest {:.3e}, at the end {:.3e} (E0 = {:.6g} J{}); "
                                       "rotation lag omega t - angle = {:.3e} rad",
                                       worst_gain, final_change, e0, s.dimension == 2 ? " per m" : "", worst_lag));
  }
  result.notes.push_back(fmt::format("sigma_c = rho omega^2 R^2 / 2 = {:.4g} Pa; {} steps, dt = {:.4g} s, {} particles, {:.2f} s wall",
                                     sigma_c, run.diverged ? static_cast<std::int64_t>(run.steps.size()) : run.report.steps,
                                     case_time_step(c), mass.size(),
                                     run.wall_seconds));
  result.series.push_back(std::move(history));
  return result;
}

}  // namespace

std::vector<Case> rotation_cases() {
  const std::vector<RotationSpec> specs = {
      {"rotation_2d_alpha0.6", "free rigid rotation, 2D block 41 x 41, alpha 0.6", 2, 0.6},
      {"rotation_2d_alpha1.2", "free rigid rotation, 2D block 41 x 41, alpha 1.2", 2, 1.2},
      {"rotation_3d_alpha0.6", "free rigid rotation, 3D cube 11^3, alpha 0.6", 3, 0.6},
      {"rotation_3d_alpha1.2", "free rigid rotation, 3D cube 11^3, alpha 1.2", 3, 1.2},
  };
  std::vector<Case> cases;
  for (const auto& s : specs)
    cases.push_back({s.name, s.description, s.dimension == 3, [s](const Options& o) { return run_rotation(s, o); }});
  return cases;
}

}  // namespace tsph::validate
