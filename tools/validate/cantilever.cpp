// The large-deflection cantilever against the elastica (issue 14; docs/validation.md):
// tools/cases/cantilever_2d_large.toml (updated Lagrangian, dead tip load,
// P L^2 / (E I) = k) run through load_case + run_case, the tip of the axis read from the
// last frame (current positions minus initial ones) against the elastica with shear and
// extension (engine/validation/elastica.hpp; kappa from Timoshenko & Goodier's 2D
// solution, so that small loads give the validated linear answer). "At rest" is checked
// as the tip's drift over the last 0.3 s of the run (the case's rest criterion reads the
// real particles' speed, which carries the scheme's O(dt) rest velocity in updated
// Lagrangian; docs/known-problems.md).
// The shipped 3D cantilever (tools/cases/cantilever_3d.toml) in updated Lagrangian against
// the Timoshenko beam (engine/validation/cantilever.hpp), issue 14's "3D: the shipped
// cantilever in updated Lagrangian at rest within 3 %": the tip of the axis from the
// frames (current minus initial position), at rest judged the same way.
#include "tools/validate/support.hpp"
#include "tools/validate/validation_case.hpp"

#include "engine/case/case_file.hpp"
#include "engine/case/case_run.hpp"
#include "engine/validation/cantilever.hpp"
#include "engine/validation/elastica.hpp"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

namespace tsph::validate {
namespace {

struct BeamRun {
  bool diverged = false;
  std::string message;
  std::vector<std::vector<double>> tip_history;  ///< t, delta / L, x_tip / L
  std::vector<std::vector<double>> axis;         ///< x / L, y / L of the axis at the end
};

constexpr double kLength = 1.0, kDepth = 0.1, kPoisson = 0.3;
constexpr double kUnitLoad = 6666.666666666667;  // E I / L^2 for E = 8e7, I = D^3 / 12

/// The particle whose initial position is nearest (x, y, z) (z = 0 in 2D frames).
std::size_t nearest_initial(const output::VtuFrame& f, double x, double y, double z) {
  const std::vector<double>& x0 = array_of(f, "initial_position");
  std::size_t at = 0;
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < f.point_count; ++i) {
    const double d = std::hypot(x0[3 * i] - x, std::hypot(x0[3 * i + 1] - y, x0[3 * i + 2] - z));
    if (d < best) best = d, at = i;
  }
  return at;
}

/// The case's own overrides with the rest criterion off: the beams run to the end and
/// rest is judged by the tip's drift (tip_drift).
std::vector<std::string> run_to_end(std::vector<std::string> overrides) {
  overrides.insert(overrides.end(), {"damping.rest_velocity=0", "damping.rest_kinetic_energy=0"});
  return overrides;
}

/// At rest: how far the tip (rows t, a, b) moves over the last 0.3 s, sqrt(da^2 + db^2)
/// from its last position, largest.
double tip_drift(const std::vector<std::vector<double>>& rows) {
  const auto& last = rows.back();
  double drift = 0.0;
  for (const auto& row : rows)
    if (row[0] >= last[0] - 0.3) drift = std::max(drift, std::hypot(row[1] - last[1], row[2] - last[2]));
  return drift;
}

/// Adds the curve (x = row[0], y = row[1]) to a series as its new last column.
void add_curve(Series& series, const std::string& name, const std::vector<std::vector<double>>& rows) {
  series.columns.push_back(name);
  for (auto& row : series.rows) row.resize(series.columns.size(), std::nan(""));
  for (const auto& row : rows) {
    std::vector<double> line(series.columns.size(), std::nan(""));
    line[0] = row[0];
    line.back() = row[1];
    series.rows.push_back(line);
  }
}

BeamRun run_beam(const Options& o, double k, double spacing, double end_time, const std::string& tag) {
  BeamRun out;
  char spacing_text[32];
  std::snprintf(spacing_text, sizeof spacing_text, "%.17g", spacing);  // a whole number of spacings (1/60)
  const CaseRun run = run_case_file(o, "cantilever_2d_large.toml",
                                    run_to_end({std::string("geometry.spacing=") + spacing_text,
                                                "boundary.1.value=[0.0," + std::to_string(k * kUnitLoad) + "]",
                                                "time.end=" + std::to_string(end_time), "output.every=1000",
                                                "output.fields=[\"displacement\"]"}),
                                    tag);
  for (std::size_t q = 0; q < run.frames.size(); ++q) {
    const output::VtuFrame& f = run.frames[q];
    const std::vector<double>& x0 = array_of(f, "initial_position");
    const std::size_t tip = nearest_initial(f, kLength, 0.0, 0.0);
    out.tip_history.push_back(
        {run.frame_times[q], (f.points[3 * tip + 1] - x0[3 * tip + 1]) / kLength, f.points[3 * tip] / kLength});
  }
  if (!run.frames.empty()) {
    const output::VtuFrame& f = run.frames.back();
    const std::vector<double>& x0 = array_of(f, "initial_position");
    for (std::size_t i = 0; i < f.point_count; ++i)
      if (std::abs(x0[3 * i + 1]) < 1e-9) out.axis.push_back({f.points[3 * i] / kLength, f.points[3 * i + 1] / kLength});
  }
  out.diverged = run.diverged;
  out.message = run.diagnosis;
  return out;
}

Result run_load(const Options& o, double k) {
  Result result;
  const ElasticaSolution reference = solve_elastica(k, rectangular_beam_compliance(k, kLength, kDepth, kPoisson));
  const ElasticaSolution inextensible = solve_elastica(k);
  // Quick: 61 x 7. At 41 x 5 the beam is 2.4 % (k = 1) / 2.5 % (k = 3) too far since the
  // faces move with their sections (SolverSettings::surface_motion, 2026-11-28), as small
  // strain is at that grid (+2.3 %); the 2 % is asked at 81 x 9 and 101 x 11.
  const std::vector<double> spacings = o.quick ? std::vector<double>{1.0 / 60.0} : std::vector<double>{0.0125, 0.01};
  const double end_time = o.quick ? 1.2 : 1.5;
  const double tolerance = 0.02;
  Series tip_history{"tip_history_k" + std::to_string(static_cast<int>(k)), "Tip of the axis, k = " + std::to_string(k),
                     "t (s)", "delta / L", {"t"}, {}};
  Series shape{"shape_k" + std::to_string(static_cast<int>(k)), "Deformed axis at the end, k = " + std::to_string(k),
               "x / L", "y / L", {"x / L", "ref elastica (shear + extension)"}, {}};
  for (std::size_t s = 0; s < reference.x.size(); s += 20) shape.rows.push_back({reference.x[s], reference.y[s]});
  for (double dx : spacings) {
    const int nx = static_cast<int>(std::lround(kLength / dx)) + 1, ny = static_cast<int>(std::lround(kDepth / dx)) + 1;
    const std::string grid = std::to_string(nx) + " x " + std::to_string(ny);
    const BeamRun run = run_beam(o, k, dx, end_time, "k" + std::to_string(static_cast<int>(k)) + "_" + std::to_string(nx));
    if (run.diverged || run.tip_history.empty()) {
      result.notes.push_back(grid + ", k = " + std::to_string(k) + ": diverged (" + run.message + ")");
      result.checks.push_back({"delta / L at rest, " + grid, std::nan(""), reference.tip_deflection, std::nan(""),
                               tolerance, "rel", false});
      result.checks.push_back({"x_tip / L at rest, " + grid, std::nan(""), reference.tip_x, std::nan(""), tolerance,
                               "rel", false});
      continue;
    }
    const auto& last = run.tip_history.back();
    auto rel = [](double v, double ref) { return std::abs(v - ref) / std::abs(ref); };
    Check deflection{"delta / L at t = " + std::to_string(last[0]) + " s, " + grid, last[1], reference.tip_deflection,
                     rel(last[1], reference.tip_deflection), tolerance, "rel", false};
    Check tip_x{"x_tip / L at t = " + std::to_string(last[0]) + " s, " + grid, last[2], reference.tip_x,
                rel(last[2], reference.tip_x), tolerance, "rel", false};
    deflection.pass = deflection.error <= tolerance;
    tip_x.pass = tip_x.error <= tolerance;
    // At rest: the tip moves by less than 1e-3 L over the last 0.3 s.
    const double drift = tip_drift(run.tip_history);
    Check rest{"tip drift / L over the last 0.3 s, " + grid, drift, 0.0, drift, 1e-3, "max", drift <= 1e-3};
    result.checks.push_back(deflection);
    result.checks.push_back(tip_x);
    result.checks.push_back(rest);
    result.notes.push_back(grid + ": against the inextensible elastica (" + std::to_string(inextensible.tip_deflection) +
                           ", " + std::to_string(inextensible.tip_x) + ") delta / L " +
                           std::to_string(100.0 * (last[1] / inextensible.tip_deflection - 1.0)) + " %, x_tip / L " +
                           std::to_string(100.0 * (last[2] / inextensible.tip_x - 1.0)) + " %");
    add_curve(tip_history, "delta / L, " + grid, run.tip_history);
    add_curve(shape, "tsph " + grid, run.axis);
  }
  result.series.push_back(std::move(tip_history));
  result.series.push_back(std::move(shape));
  return result;
}

/// The shipped 3D cantilever in updated Lagrangian: 41 x 5 x 5 (quick and full) and
/// 61 x 7 x 7 (full), run to 1.2 s (the small-strain beam rests at 0.83-0.86 s), the tip
/// of the axis against the Timoshenko beam within 3 %, and at rest (drift over the
/// last 0.3 s below 1e-3 L).
Result run_beam_3d(const Options& o) {
  Result result;
  CantileverBeam<3> beam;
  beam.load = 100.0;
  const double reference = beam.tip_deflection();
  const double tolerance = 0.03, end_time = 1.2;
  const std::vector<double> spacings = o.quick ? std::vector<double>{0.025} : std::vector<double>{0.025, 1.0 / 60.0};
  Series history{"tip_history_3d", "Tip of the axis, 3D cantilever, updated Lagrangian", "t (s)", "u_y (m)", {"t"}, {}};
  for (double dx : spacings) {
    const int nx = static_cast<int>(std::lround(kLength / dx)) + 1, ny = static_cast<int>(std::lround(kDepth / dx)) + 1;
    const std::string grid = std::to_string(nx) + " x " + std::to_string(ny) + " x " + std::to_string(ny);
    char spacing[32];
    std::snprintf(spacing, sizeof spacing, "%.17g", dx);  // to_string's 6 digits miss a whole number of spacings
    const CaseRun run = run_case_file(
        o, "cantilever_3d.toml",
        run_to_end({std::string("geometry.spacing=") + spacing, "method.kinematics=updated_lagrangian",
                    "time.end=" + std::to_string(end_time), "output.every=500", "output.fields=[\"displacement\"]"}),
        "run_" + std::to_string(nx));
    std::vector<std::vector<double>> tip;  // t, u_y, u_x of the tip of the axis
    for (std::size_t q = 0; q < run.frames.size(); ++q) {
      const output::VtuFrame& f = run.frames[q];
      const std::vector<double>& x0 = array_of(f, "initial_position");
      const std::size_t at = nearest_initial(f, kLength, 0.0, 0.0);
      // Small strain (a --set of the user's) does not move the particles: the displacement.
      const bool moved = f.points[3 * at] != x0[3 * at] || f.points[3 * at + 1] != x0[3 * at + 1];
      const std::vector<double>& u = array_of(f, "displacement");
      tip.push_back({run.frame_times[q], moved ? f.points[3 * at + 1] - x0[3 * at + 1] : u[3 * at + 1],
                     moved ? f.points[3 * at] - x0[3 * at] : u[3 * at]});
    }
    Check runs = no_divergence_check(run, result);
    runs.figure += ", " + grid;
    result.checks.push_back(runs);
    if (run.diverged || tip.empty()) {
      result.checks.push_back({"tip u_y at rest, " + grid, std::nan(""), reference, std::nan(""), tolerance, "rel", false});
    } else {
      const auto& last = tip.back();
      result.checks.push_back(relative_check("tip u_y (m) at t = " + std::to_string(last[0]) + " s, " + grid, last[1],
                                             reference, tolerance));
      result.checks.push_back(bound_check("tip drift / L over the last 0.3 s, " + grid, tip_drift(tip) / kLength, 1e-3));
    }
    add_curve(history, "u_y, " + grid, tip);
  }
  history.columns.push_back("ref Timoshenko beam");
  for (auto& row : history.rows) {
    row.resize(history.columns.size(), std::nan(""));
    row.back() = reference;
  }
  result.notes.push_back("Timoshenko beam tip deflection " + std::to_string(reference) + " m (small strain: " +
                         "41 x 5 x 5 -1.77 %, 61 x 7 x 7 -1.50 %, docs/validation.md)");
  result.series.push_back(std::move(history));
  return result;
}

}  // namespace

std::vector<Case> cantilever_cases() {
  return {
      {"cantilever_large_k1", "2D cantilever, dead tip load P L^2 / (E I) = 1, updated Lagrangian, vs the elastica",
       true, [](const Options& o) { return run_load(o, 1.0); }},
      {"cantilever_large_k3", "2D cantilever, dead tip load P L^2 / (E I) = 3, updated Lagrangian, vs the elastica",
       true, [](const Options& o) { return run_load(o, 3.0); }},
      {"cantilever_3d_ul", "the shipped 3D cantilever (41 x 5 x 5) in updated Lagrangian, at rest, vs the Timoshenko beam",
       true, run_beam_3d},
  };
}

}  // namespace tsph::validate
