// Homogeneous large strain (issue 14, item 1): every particle driven by the affine
// velocity field v = G x (a velocity boundary with velocity_gradient on region "all",
// tools/cases/homogeneous_{2,3}d.toml), updated Lagrangian; the stress of every particle
// against the closed-form hypoelastic (Jaumann) solution, engine/validation/homogeneous.hpp.
#include "engine/validation/homogeneous.hpp"
#include "tools/validate/support.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cstdlib>
#include <cmath>
#include <functional>

namespace tsph::validate {
namespace {

enum class Motion { uniaxial_stress, uniaxial_strain, simple_shear };

struct HomogeneousSpec {
  std::string name, description;
  int dimension = 2;
  Motion motion = Motion::uniaxial_stress;
  double target = 1.5;  ///< the stretch (uniaxial) or gamma (shear) at the end
  bool plane_strain = false;
};

// The rates: a true strain rate of 0.05 1/s and a shear rate of 0.1 1/s keep the
// fastest particle below 2e-3 of the p-wave speed (quasi-static: the prescribed field
// needs no body force to speak of, and the characteristic relations at the faces see a
// slow motion); CFL 0.9 of the case file.
constexpr double kStrainRate = 0.05, kShearRate = 0.1;
constexpr int kFrames = 50;  ///< output times, evenly spaced

/// The reference stress (3x3) at time t.
Eigen::Matrix3d reference_stress(const HomogeneousSpec& s, const CaseFile& c, double t) {
  const double e = c.young_modulus, nu = c.poisson_ratio;
  const double mu = e / (2.0 * (1.0 + nu)), lame = e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
  switch (s.motion) {
    case Motion::uniaxial_stress: return homogeneous::uniaxial_stress(e, std::copysign(kStrainRate, std::log(s.target)) * t);
    case Motion::uniaxial_strain: return homogeneous::uniaxial_strain(lame, mu, std::copysign(kStrainRate, std::log(s.target)) * t);
    case Motion::simple_shear: return homogeneous::simple_shear(mu, kShearRate * t);
  }
  return Eigen::Matrix3d::Zero();
}

/// The 3x3 stress of particle i from the frame's VTK-ordered 6 components.
Eigen::Matrix3d stress_at(const std::vector<double>& s, std::size_t i) {
  const double* p = s.data() + 6 * i;
  Eigen::Matrix3d m;
  m << p[0], p[3], p[5], p[3], p[1], p[4], p[5], p[4], p[2];
  return m;
}

Result run_homogeneous(const HomogeneousSpec& s, const Options& o) {
  const double rate = s.motion == Motion::simple_shear ? kShearRate : std::copysign(kStrainRate, std::log(s.target));
  const double end = s.motion == Motion::simple_shear ? s.target / kShearRate : std::log(s.target) / rate;
  const double nu = 0.3;  // the case files' nu (checked below)
  std::vector<double> g(static_cast<std::size_t>(s.dimension * s.dimension), 0.0);
  auto at = [&](int r, int k) -> double& { return g[static_cast<std::size_t>(r * s.dimension + k)]; };
  switch (s.motion) {
    case Motion::uniaxial_stress:
      at(0, 0) = rate;
      for (int d = 1; d < s.dimension; ++d) at(d, d) = -nu * rate;
      break;
    case Motion::uniaxial_strain: at(0, 0) = rate; break;
    case Motion::simple_shear: at(0, 1) = rate; break;
  }
  std::vector<std::string> overrides = {"boundary.0.velocity_gradient=" + toml_array(g),
                                        "initial.velocity_gradient=" + toml_array(g),
                                        fmt::format("time.end={:.17g}", end), output_times(end, kFrames)};
  if (s.dimension == 2) overrides.push_back(std::string("material.plane=") + (s.plane_strain ? "\"strain\"" : "\"stress\""));
  if (o.quick) overrides.push_back(s.dimension == 2 ? "geometry.spacing=0.2" : "geometry.spacing=0.25");
  const std::string file = s.dimension == 2 ? "homogeneous_2d.toml" : "homogeneous_3d.toml";
  CaseRun run = run_case_file(o, file, overrides, "run");
  Result result;
  if (run.file.poisson_ratio != nu)
    throw std::runtime_error(file + ": the validation assumes material.nu = 0.3 (uniaxial stress field)");

  // Series: the mean stress components against the reference, over the run.
  const char* names[6] = {"xx", "yy", "zz", "xy", "yz", "xz"};
  const int rows[6] = {0, 1, 2, 0, 1, 0}, cols[6] = {0, 1, 2, 1, 2, 2};
  Series series;
  series.name = "stress";
  series.title = s.description;
  series.x_label = s.motion == Motion::simple_shear ? "gamma" : "ln(stretch)";
  series.y_label = "mean stress (Pa)";
  series.columns = {series.x_label};
  std::vector<int> shown;
  const Eigen::Matrix3d final_reference = reference_stress(s, run.file, end);
  const double scale = final_reference.cwiseAbs().maxCoeff();
  for (int m = 0; m < 6; ++m)
    if (std::abs(final_reference(rows[m], cols[m])) > 1e-12 * scale || m == 3) shown.push_back(m);
  for (int m : shown) series.columns.push_back(std::string("sigma_") + names[m]);
  for (int m : shown) series.columns.push_back(std::string("ref sigma_") + names[m]);
  series.columns.push_back("worst particle error / |sigma_ref|max");

  double worst = 0.0;
  std::size_t worst_particle = 0;
  Eigen::Matrix3d mean_final = Eigen::Matrix3d::Zero();
  for (std::size_t f = 0; f < run.frames.size(); ++f) {
    const double t = run.frame_times[f];
    const auto& stress = array_of(run.frames[f], "stress");
    const std::size_t n = run.frames[f].point_count;
    const Eigen::Matrix3d reference = reference_stress(s, run.file, t);
    Eigen::Matrix3d mean = Eigen::Matrix3d::Zero();
    double frame_worst = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      const Eigen::Matrix3d si = stress_at(stress, i);
      mean += si / static_cast<double>(n);
      const double error = (si - reference).cwiseAbs().maxCoeff() / scale;
      if (error > frame_worst) {
        frame_worst = error;
        if (std::getenv("TSPH_VALIDATE_DEBUG")) {
          const auto& x0 = array_of(run.frames[f], "initial_position");
          fmt::print(stderr, "t = {:.4g}: worst {:.3e} at x0 = ({:.3g}, {:.3g}, {:.3g}) error tensor xx {:.3e} yy {:.3e} xy {:.3e}\n", t, error, x0[3 * i], x0[3 * i + 1], x0[3 * i + 2],
                     (si - reference)(0, 0) / scale, (si - reference)(1, 1) / scale, (si - reference)(0, 1) / scale);
        }
      }
      if (f + 1 == run.frames.size() && error >= worst) {
        worst = error;
        worst_particle = i;
      }
    }
    if (f + 1 == run.frames.size()) mean_final = mean;
    std::vector<double> row = {s.motion == Motion::simple_shear ? kShearRate * t : rate * t};
    for (int m : shown) row.push_back(mean(rows[m], cols[m]));
    for (int m : shown) row.push_back(reference(rows[m], cols[m]));
    row.push_back(frame_worst);
    series.rows.push_back(row);
  }
  result.checks.push_back(no_divergence_check(run, result));
  if (run.diverged || run.frames.empty()) {
    result.series.push_back(std::move(series));  // up to the divergence
    return result;
  }
  const double final_time = run.frame_times.back();
  const std::string when = s.motion == Motion::simple_shear ? fmt::format("gamma = {:.3g}", kShearRate * final_time)
                                                            : fmt::format("stretch {:.3g}", std::exp(rate * final_time));
  const Eigen::Matrix3d reference = reference_stress(s, run.file, final_time);
  for (int m : shown) {
    if (std::abs(reference(rows[m], cols[m])) <= 1e-12 * scale) continue;
    result.checks.push_back(relative_check(fmt::format("mean sigma_{} at {}", names[m], when),
                                           mean_final(rows[m], cols[m]), reference(rows[m], cols[m]), 1e-3));
  }
  {
    Check c = bound_check(fmt::format("worst particle, max |sigma - ref| / {:.4g} Pa at {}", scale, when), worst, 1e-3);
    result.checks.push_back(c);
    const auto& x = run.frames.back().points;
    result.notes.push_back(fmt::format("worst particle: index {} at ({:.3g}, {:.3g}, {:.3g}); {} steps, dt = {:.4g} s, {} particles, {:.2f} s wall",
                                       worst_particle, x[3 * worst_particle], x[3 * worst_particle + 1],
                                       x[3 * worst_particle + 2], run.report.steps, run.report.dt,
                                       run.report.real_particles, run.wall_seconds));
  }
  result.series.push_back(std::move(series));
  return result;
}

}  // namespace

std::vector<Case> homogeneous_cases() {
  const std::vector<HomogeneousSpec> specs = {
      {"homogeneous_stretch_3d", "uniaxial stress, 3D, stretched to 1.5", 3, Motion::uniaxial_stress, 1.5, false},
      {"homogeneous_compress_3d", "uniaxial stress, 3D, compressed to 0.7", 3, Motion::uniaxial_stress, 0.7, false},
      {"homogeneous_stretch_2d", "uniaxial stress, 2D plane stress, stretched to 1.5", 2, Motion::uniaxial_stress, 1.5, false},
      {"homogeneous_compress_2d", "uniaxial stress, 2D plane stress, compressed to 0.7", 2, Motion::uniaxial_stress, 0.7, false},
      {"homogeneous_uniaxial_strain_2d", "uniaxial strain, 2D plane strain, stretched to 1.5", 2, Motion::uniaxial_strain, 1.5, true},
      {"homogeneous_shear_2d", "simple shear to gamma = 5, 2D plane strain", 2, Motion::simple_shear, 5.0, true},
      {"homogeneous_shear_3d", "simple shear to gamma = 5, 3D", 3, Motion::simple_shear, 5.0, false},
  };
  std::vector<Case> cases;
  for (const auto& s : specs)
    cases.push_back({s.name, s.description, false, [s](const Options& o) { return run_homogeneous(s, o); }});
  return cases;
}

}  // namespace tsph::validate
