// The oscillating plate (Gray, Monaghan & Swift 2001; reference section 3) as validation
// cases: tools/cases/plate_2d.toml through load_case + run_case, in updated Lagrangian.
//   plate_small: V_f = 0.01, the period from the tip's v_y zero crossings against
//                T = 2 pi / omega = 0.25403 s (3 %), at alpha 0.6 and 1.2.
//   plate_large: V_f = 0.05 (tip excursion ~0.58 L), 30 periods at alpha 0.6 and 1.2:
//                stable, total energy never above the initial (1e-3 relative), decay per
//                period reported, hourglass measure (lattice_measures.hpp) below 0.05 dx.
//                The energy is read on the node-and-cell quadrature
//                (TaylorSph::node_and_cell_energies), exact for the quadratic densities
//                of bending: the real particles' trapezoidal sums put 8 % (51 x 6) and
//                2 % (101 x 11) too much elastic energy in a stress linear across the
//                thickness, which the exact solution would show as a gain at every
//                quarter period (docs/notes/2026-11-29-energy-quadrature.md). Both
//                measures are reported.
// Resolutions: full dx = 0.002 (101 x 11, the reference's); quick dx = 0.004 (51 x 6)
// and, for plate_large, 3 periods instead of 30.
#include "engine/case/case_file.hpp"
#include "engine/case/case_run.hpp"
#include "engine/validation/plate.hpp"
#include "tools/validate/lattice_measures.hpp"
#include "tools/validate/support.hpp"
#include "tools/validate/validation_case.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

namespace tsph::validate {
namespace {

namespace fs = std::filesystem;

/// What one run of the plate found.
struct PlateRun {
  double alpha = 0.0, dx = 0.0, v_f = 0.0, end_time = 0.0;
  bool diverged = false;
  std::string message;           ///< the divergence diagnosis
  double time_reached = 0.0;
  std::int64_t steps = 0;
  double wall_seconds = 0.0;
  double initial_energy = 0.0;   ///< kinetic, from the t = 0 frame (trapezoidal masses)
  double initial_node_and_cell = 0.0;  ///< kinetic + elastic at t = 0, node-and-cell quadrature
  std::vector<RunOptions::StepRecord> energies;  ///< after every step
  std::vector<double> tip_t, tip_vy, tip_uy;     ///< the tip probe
  struct Hourglass {
    double t, displacement_rms, displacement_max, velocity_rms;  ///< / dx, / dx, / v_rms(0)
  };
  std::vector<Hourglass> hourglass;
};

/// A TOML array of numbers for --set.
std::string toml_array(const std::vector<double>& values) {
  std::string s = "[";
  for (std::size_t k = 0; k < values.size(); ++k) s += fmt::format("{}{:.17g}", k ? ", " : "", values[k]);
  return s + "]";
}

void read_probe(const fs::path& file, PlateRun& run) {
  std::ifstream in(file);
  std::string line;
  if (!std::getline(in, line)) return;
  std::vector<std::string> names;
  {
    std::stringstream header(line);
    std::string name;
    while (std::getline(header, name, ',')) names.push_back(name);
  }
  const auto column = [&](const std::string& name) {
    return static_cast<std::size_t>(std::find(names.begin(), names.end(), name) - names.begin());
  };
  const std::size_t t = column("t"), vy = column("vy"), uy = column("uy");
  while (std::getline(in, line)) {
    std::vector<double> values;
    std::stringstream row(line);
    std::string cell;
    while (std::getline(row, cell, ',')) values.push_back(std::stod(cell));
    if (values.size() != names.size()) continue;
    run.tip_t.push_back(values[t]);
    run.tip_vy.push_back(values[vy]);
    run.tip_uy.push_back(values[uy]);
  }
}

PlateRun run_plate(const Options& o, double v_f, double alpha, double dx, double periods, int frames_per_period,
                   const std::string& name) {
  const OscillatingPlate plate;
  PlateRun run;
  run.alpha = alpha;
  run.dx = dx;
  run.v_f = v_f;
  run.end_time = periods * plate.period();
  std::vector<double> times;
  const int frames = static_cast<int>(std::lround(periods * frames_per_period));
  for (int k = 1; k <= frames; ++k) times.push_back(run.end_time * k / frames);
  const std::vector<std::string> overrides = with_user_overrides(o, {
      fmt::format("geometry.spacing={:.17g}", dx),
      fmt::format("method.alpha={:.17g}", alpha),
      fmt::format("time.end={:.17g}", run.end_time),
      fmt::format("initial.profile.amplitude=[0.0, {:.17g}]", plate.tip_velocity(v_f)),
      "output.every=0",
      "output.fields=[\"velocity\", \"displacement\"]",
      "output.times=" + toml_array(times),
      "output.probe_every=2",
  });
  const std::string case_path = (fs::path(o.cases_dir) / "plate_2d.toml").string();
  const CaseFile c = load_case(case_path, overrides);
  const fs::path out = fs::path(o.out_dir) / name;
  fs::remove_all(out);
  fs::create_directories(out);

  const std::array<double, 2> lower{0.0, -plate.thickness / 2}, upper{plate.length, plate.thickness / 2};
  double velocity_scale = 0.0;  // RMS speed at t = 0
  RunOptions options;
  options.out_dir = out.string();
  options.quiet = o.quiet;
  options.overrides = overrides;  // summary.json lists them
  options.node_and_cell_energies = true;
  options.on_step = [&](const RunOptions::StepRecord& r) {
    if (r.step == 0) run.initial_node_and_cell = r.kinetic_node_and_cell + r.strain_node_and_cell;
    else run.energies.push_back(r);
  };
  options.on_frame = [&](const output::VtuFrame& f, double t) {
    const LatticeFrame<2> lattice(f, lower, upper, dx);
    const auto& v = array_of(f, "velocity");
    if (t == 0.0) {
      double energy = 0.0, mass = 0.0;
      for (std::size_t i = 0; i < f.point_count; ++i) {
        const double m = plate.density * dx * dx * lattice.volume_fraction(i);
        energy += 0.5 * m * (v[3 * i] * v[3 * i] + v[3 * i + 1] * v[3 * i + 1]);
        mass += m;
      }
      run.initial_energy = energy;
      velocity_scale = std::sqrt(2.0 * energy / mass);
    }
    const auto u = hourglass_residual(lattice, array_of(f, "displacement"));
    const auto w = hourglass_residual(lattice, v);
    run.hourglass.push_back({t, u[0] / dx, u[1] / dx, w[0] / velocity_scale});
  };
  try {
    use_threads(o, c);
    const RunReport report = run_case(c, options);
    run.time_reached = report.time;
    run.steps = report.steps;
    run.wall_seconds = report.wall_seconds;
  } catch (const RunDiverged& e) {
    run.diverged = true;
    run.message = e.what();
    run.time_reached = run.energies.empty() ? 0.0 : run.energies.back().time;
    run.steps = run.energies.empty() ? 0 : run.energies.back().step;
  }
  read_probe(out / "probe_tip.csv", run);
  return run;
}

std::string alpha_label(double alpha) { return fmt::format("alpha {:.1f}", alpha); }

/// Energy figures of a run: the largest gain over the initial (relative) and the mean
/// decay per period 1 - (E(N T) / E0)^(1/N) over the whole periods completed.
struct EnergyFigures {
  double largest_gain = 0.0, time_of_largest = 0.0, decay_per_period = 0.0, final_ratio = 1.0;
  double first_above = std::nan("");  ///< the first time E > E0 (1 + 1e-3): the onset of a gain
  int whole_periods = 0;
};

/// The energy measures: the real particles' sums (the ledger's, trapezoidal on the
/// lattice) and the node-and-cell quadrature (the checks').
enum class Quadrature { trapezoidal, node_and_cell };

/// E / E0 of a step record on a measure.
double energy_ratio(const PlateRun& run, const RunOptions::StepRecord& r, Quadrature q) {
  return q == Quadrature::trapezoidal ? (r.kinetic_energy + r.strain_energy) / run.initial_energy
                                      : (r.kinetic_node_and_cell + r.strain_node_and_cell) / run.initial_node_and_cell;
}

EnergyFigures energy_figures(const PlateRun& run, double period, Quadrature q = Quadrature::node_and_cell) {
  EnergyFigures e;
  e.largest_gain = -std::numeric_limits<double>::infinity();
  for (const auto& r : run.energies) {
    const double gain = energy_ratio(run, r, q) - 1.0;
    if (gain > e.largest_gain) e.largest_gain = gain, e.time_of_largest = r.time;
    if (gain > 1e-3 && std::isnan(e.first_above)) e.first_above = r.time;
  }
  e.whole_periods = static_cast<int>(std::floor(run.time_reached / period + 1e-9));
  if (e.whole_periods >= 1) {
    const double target = e.whole_periods * period;
    const auto it = std::min_element(run.energies.begin(), run.energies.end(), [&](const auto& a, const auto& b) {
      return std::abs(a.time - target) < std::abs(b.time - target);
    });
    e.final_ratio = energy_ratio(run, *it, q);
    e.decay_per_period = 1.0 - std::pow(e.final_ratio, 1.0 / e.whole_periods);
  }
  return e;
}

/// The energies as a series, about 50 rows per period.
Series energy_series(const std::vector<const PlateRun*>& runs, double period, const std::string& name) {
  Series s;
  s.name = name;
  s.title = "Oscillating plate: total energy / initial";
  s.x_label = "t / T";
  s.y_label = "E / E0";
  s.columns = {"t/T"};
  for (const auto* r : runs) s.columns.push_back(fmt::format("E/E0 {}", alpha_label(r->alpha)));
  for (const auto* r : runs) s.columns.push_back(fmt::format("E/E0 {} (trapezoidal)", alpha_label(r->alpha)));
  s.columns.push_back("ref E/E0 = 1");
  const double sample = period / 50.0;
  double end = 0.0;
  for (const auto* r : runs) end = std::max(end, r->time_reached);
  for (double t = 0.0; t <= end + 1e-12; t += sample) {
    std::vector<double> row = {t / period};
    for (Quadrature q : {Quadrature::node_and_cell, Quadrature::trapezoidal})
      for (const auto* r : runs) {
        double value = std::nan("");
        if (t == 0.0) value = 1.0;
        else if (!r->energies.empty() && t <= r->time_reached + 1e-12) {
          const auto it = std::lower_bound(r->energies.begin(), r->energies.end(), t,
                                           [](const auto& a, double x) { return a.time < x; });
          value = energy_ratio(*r, it == r->energies.end() ? r->energies.back() : *it, q);
        }
        row.push_back(value);
      }
    row.push_back(1.0);
    s.rows.push_back(std::move(row));
  }
  return s;
}

Series tip_series(const std::vector<const PlateRun*>& runs, double period, double amplitude, double omega,
                  const std::string& name) {
  Series s;
  s.name = name;
  s.title = "Oscillating plate: tip v_y";
  s.x_label = "t / T";
  s.y_label = "v_y tip (m/s)";
  s.columns = {"t/T"};
  for (const auto* r : runs) s.columns.push_back(fmt::format("v_y {}", alpha_label(r->alpha)));
  s.columns.push_back("ref linear V cos(omega t)");
  std::size_t rows = 0;
  for (const auto* r : runs) rows = std::max(rows, r->tip_t.size());
  const std::size_t stride = std::max<std::size_t>(1, rows / 4000);
  const PlateRun* longest = runs.front();
  for (const auto* r : runs)
    if (r->tip_t.size() > longest->tip_t.size()) longest = r;
  for (std::size_t k = 0; k < longest->tip_t.size(); k += stride) {
    const double t = longest->tip_t[k];
    std::vector<double> row = {t / period};
    for (const auto* r : runs) row.push_back(k < r->tip_t.size() ? r->tip_vy[k] : std::nan(""));
    row.push_back(amplitude * std::cos(omega * t));
    s.rows.push_back(std::move(row));
  }
  return s;
}

Series hourglass_series(const std::vector<const PlateRun*>& runs, double period, const std::string& name) {
  Series s;
  s.name = name;
  s.title = "Oscillating plate: hourglass residual (lattice_measures.hpp)";
  s.x_label = "t / T";
  s.y_label = "RMS residual";
  s.columns = {"t/T"};
  for (const auto* r : runs) {
    s.columns.push_back(fmt::format("u rms/dx {}", alpha_label(r->alpha)));
    s.columns.push_back(fmt::format("u max/dx {}", alpha_label(r->alpha)));
    s.columns.push_back(fmt::format("v rms/v0 {}", alpha_label(r->alpha)));
  }
  std::size_t rows = 0;
  for (const auto* r : runs) rows = std::max(rows, r->hourglass.size());
  for (std::size_t k = 0; k < rows; ++k) {
    double t = 0.0;
    for (const auto* r : runs)
      if (k < r->hourglass.size()) t = r->hourglass[k].t;
    std::vector<double> row = {t / period};
    for (const auto* r : runs) {
      const bool has = k < r->hourglass.size();
      row.push_back(has ? r->hourglass[k].displacement_rms : std::nan(""));
      row.push_back(has ? r->hourglass[k].displacement_max : std::nan(""));
      row.push_back(has ? r->hourglass[k].velocity_rms : std::nan(""));
    }
    s.rows.push_back(std::move(row));
  }
  return s;
}

/// The largest hourglass displacement residual (RMS, / dx) in [t0, t1].
double hourglass_peak(const PlateRun& run, double t0, double t1) {
  double peak = 0.0;
  for (const auto& h : run.hourglass)
    if (h.t >= t0 - 1e-12 && h.t <= t1 + 1e-12) peak = std::max(peak, h.displacement_rms);
  return peak;
}

std::string run_note(const PlateRun& r, double period) {
  if (r.diverged)
    return fmt::format("{}, dx = {}: DIVERGED at step {} (t = {:.5g} s = {:.3g} T): {}", alpha_label(r.alpha), r.dx,
                       r.steps, r.time_reached, r.time_reached / period, r.message);
  return fmt::format("{}, dx = {}: {} steps to t = {:.5g} s ({:.3g} T) in {:.1f} s", alpha_label(r.alpha), r.dx,
                     r.steps, r.time_reached, r.time_reached / period, r.wall_seconds);
}

Result plate_small(const Options& o) {
  const OscillatingPlate plate;
  const double dx = o.quick ? 0.004 : 0.002;
  const double periods = o.quick ? 2.0 : 3.0;
  const double v_f = 0.01;
  Result result;
  std::vector<PlateRun> runs;
  for (double alpha : {0.6, 1.2})
    runs.push_back(run_plate(o, v_f, alpha, dx, periods, 8, fmt::format("alpha{:.1f}", alpha)));
  std::vector<const PlateRun*> pointers;
  for (const auto& r : runs) {
    pointers.push_back(&r);
    const double measured = period_from_crossings(zero_crossings(r.tip_t, r.tip_vy));
    Check c;
    c.figure = fmt::format("period (tip v_y zero crossings), V_f = 0.01, {}, dx = {}", alpha_label(r.alpha), dx);
    c.value = measured;
    c.reference = plate.period();
    c.error = std::abs(measured - c.reference) / c.reference;
    c.tolerance = 0.03;
    c.error_kind = "rel";
    c.pass = !r.diverged && std::isfinite(measured) && c.error <= c.tolerance;
    result.checks.push_back(c);
    const EnergyFigures e = energy_figures(r, plate.period());
    const EnergyFigures trapezoidal = energy_figures(r, plate.period(), Quadrature::trapezoidal);
    result.notes.push_back(run_note(r, plate.period()) +
                           fmt::format("; period {:.5g} s; energy (node-and-cell): largest gain {:+.3e} (t = {:.4g} "
                                       "s), first above E0 (1 + 1e-3) at t = {:.4g} s, decay per period {:.3e}; "
                                       "trapezoidal: largest gain {:+.3e}",
                                       measured, e.largest_gain, e.time_of_largest, e.first_above,
                                       e.decay_per_period, trapezoidal.largest_gain));
  }
  result.series.push_back(tip_series(pointers, plate.period(), plate.tip_velocity(v_f), plate.omega(), "tip_vy"));
  result.series.push_back(energy_series(pointers, plate.period(), "energy"));
  return result;
}

Result plate_large(const Options& o) {
  const OscillatingPlate plate;
  const double dx = o.quick ? 0.004 : 0.002;
  const double periods = o.quick ? 3.0 : 30.0;
  const double v_f = 0.05;
  const double gain_tolerance = 1e-3;
  const double hourglass_tolerance = 0.05;  // RMS residual displacement / dx
  Result result;
  std::vector<PlateRun> runs;
  for (double alpha : {0.6, 1.2})
    runs.push_back(run_plate(o, v_f, alpha, dx, periods, 8, fmt::format("alpha{:.1f}", alpha)));
  std::vector<const PlateRun*> pointers;
  for (const auto& r : runs) {
    pointers.push_back(&r);
    const std::string where = fmt::format("V_f = 0.05, {}, dx = {}", alpha_label(r.alpha), dx);
    {
      Check c;
      c.figure = fmt::format("periods completed of {:g}, {}", periods, where);
      c.value = r.time_reached / plate.period();
      c.reference = periods;
      c.error = std::abs(c.value - c.reference);
      c.tolerance = 1e-6;
      c.error_kind = "abs";
      c.pass = !r.diverged && c.error <= c.tolerance;
      result.checks.push_back(c);
    }
    const EnergyFigures e = energy_figures(r, plate.period());
    const EnergyFigures trapezoidal = energy_figures(r, plate.period(), Quadrature::trapezoidal);
    {
      Check c;
      c.figure = fmt::format("largest energy gain (E - E0) / E0 (node-and-cell quadrature), {}", where);
      c.value = e.largest_gain;
      c.reference = 0.0;
      c.error = e.largest_gain;
      c.tolerance = gain_tolerance;
      c.error_kind = "max";
      c.pass = !r.diverged && e.largest_gain <= gain_tolerance;
      result.checks.push_back(c);
    }
    {
      Check c;
      c.figure = fmt::format("hourglass residual of u, RMS / dx, largest over the run, {}", where);
      c.value = hourglass_peak(r, 0.0, r.time_reached);
      c.reference = 0.0;
      c.error = c.value;
      c.tolerance = hourglass_tolerance;
      c.error_kind = "max";
      c.pass = !r.diverged && c.value <= hourglass_tolerance;
      result.checks.push_back(c);
    }
    const double measured = period_from_crossings(zero_crossings(r.tip_t, r.tip_vy));
    // The hourglass measure's growth: its peak over the last 5 periods against the first 5
    // (a third of the run when shorter; the whole run when it ends within the first period).
    double window = std::min(5.0, std::floor(r.time_reached / plate.period() / 3.0)) * plate.period();
    if (window <= 0.0) window = r.time_reached;
    const double first = hourglass_peak(r, 0.0, window);
    const double last = hourglass_peak(r, r.time_reached - window, r.time_reached);
    result.notes.push_back(
        run_note(r, plate.period()) +
        fmt::format("; period {:.5g} s ({:+.2f} % against the linear {:.5g} s); energy (node-and-cell): largest "
                    "gain {:+.3e} at t = {:.4g} s, first above E0 (1 + 1e-3) at t = {:.4g} s, E/E0 = {:.5f} after {} "
                    "periods, decay per period {:.3e}; trapezoidal: largest gain {:+.3e} at t = {:.4g} s; hourglass u "
                    "RMS/dx: first {:.3g} T {:.3e}, last {:.3g} T {:.3e} (growth x{:.3g})",
                    measured, 100.0 * (measured / plate.period() - 1.0), plate.period(), e.largest_gain,
                    e.time_of_largest, e.first_above, e.final_ratio, e.whole_periods, e.decay_per_period,
                    trapezoidal.largest_gain, trapezoidal.time_of_largest,
                    window / plate.period(), first, window / plate.period(), last, first > 0.0 ? last / first : 0.0));
  }
  result.series.push_back(tip_series(pointers, plate.period(), plate.tip_velocity(v_f), plate.omega(), "tip_vy"));
  result.series.push_back(energy_series(pointers, plate.period(), "energy"));
  result.series.push_back(hourglass_series(pointers, plate.period(), "hourglass"));
  return result;
}

}  // namespace

std::vector<Case> plate_cases() {
  return {
      {"plate_small", "oscillating plate V_f = 0.01 (UL): period vs 2 pi / omega = 0.2540 s, alpha 0.6 and 1.2",
       false, plate_small},
      {"plate_large",
       "oscillating plate V_f = 0.05 (UL), 30 periods at alpha 0.6 and 1.2: stability, energy, hourglass", true,
       plate_large},
  };
}

}  // namespace tsph::validate
