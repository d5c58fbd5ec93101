// tsph-bar: the 1D elastic bar of seed section 4.1 from the command line.
//
//   tsph-bar [options]          one run: L2 errors, CSV profiles, summary.json
//   tsph-bar --table1 [options] the seed's Table 1: alpha = 0.6, 1.2, 1.6 side by side
//                               with the paper's errors
//
// Exit status: 0 success, 2 bad input, 3 the solution diverged (the profiles of the
// output times reached before stay written), 1 other failure (an output file that
// cannot be written: the message names it; files written before are kept).
#include "engine/bar_case.hpp"
#include "engine/output_file.hpp"
#include "engine/parallel.hpp"
#include "tools/cli_common.hpp"

#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <fmt/format.h>

#include <cstdio>
#include <exception>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace {

using namespace tsph;

using cli::kExitBadInput;

struct Options {
  BarCaseSettings bar;
  std::string kernel = "cubic_spline";
  std::string interpolation = "linear";
  std::string kinematics = "small_strain";
  std::string left_end = "fixed";
  std::string load = "velocity";
  std::string out = "out/bar";
  int threads = 0;
  bool table1 = false;
  bool quiet = false;
};

/// Parses a name against a list of allowed ones; records an error otherwise.
template <class T>
bool parse_choice(const std::string& key, const std::string& value,
                  const std::map<std::string, T>& allowed, T& out, std::vector<InputError>& errors) {
  if (auto it = allowed.find(value); it != allowed.end()) {
    out = it->second;
    return true;
  }
  std::string names;
  for (const auto& [name, unused] : allowed) {
    if (!names.empty()) names += ", ";
    names += name;
  }
  errors.push_back({key, "'" + value + "'", "must be one of: " + names});
  return false;
}

std::vector<InputError> resolve(Options& o) {
  std::vector<InputError> errors;
  std::map<std::string, KernelKind> kernels;
  for (KernelKind k : kAllKernelKinds) kernels[std::string(to_string(k))] = k;
  parse_choice("kernel", o.kernel, kernels, o.bar.kernel, errors);
  parse_choice<InterpolationKind>("interpolation", o.interpolation,
                                  {{"linear", InterpolationKind::linear},
                                   {"shepard", InterpolationKind::shepard}},
                                  o.bar.interpolation, errors);
  parse_choice<Kinematics>("kinematics", o.kinematics,
                           {{"small_strain", Kinematics::small_strain},
                            {"updated_lagrangian", Kinematics::updated_lagrangian}},
                           o.bar.kinematics, errors);
  parse_choice<BarEnd>("left-end", o.left_end, {{"fixed", BarEnd::fixed}, {"free", BarEnd::free}},
                       o.bar.left_end, errors);
  parse_choice<BarLoad>("load", o.load,
                        {{"velocity", BarLoad::velocity}, {"traction", BarLoad::traction}},
                        o.bar.right_load, errors);
  if (o.threads < 0)
    errors.push_back({"threads", std::to_string(o.threads), "must be >= 0 (0: OpenMP default)"});
  for (auto& e : validate(o.bar)) errors.push_back(std::move(e));
  return errors;
}

void write_profile(const std::filesystem::path& file, const BarProfile& p) {
  std::string text = "x,velocity,velocity_exact,stress,stress_exact\n";
  for (std::size_t i = 0; i < p.position.size(); ++i)
    fmt::format_to(std::back_inserter(text), "{:.17g},{:.17g},{:.17g},{:.17g},{:.17g}\n",
                   p.position[i], p.velocity[i], p.exact_velocity[i], p.stress[i],
                   p.exact_stress[i]);
  write_file_atomically(file, text);
}

std::string json_run(const BarCaseSettings& s, const BarResult& r, const std::string& indent) {
  std::string profiles;
  for (const auto& p : r.profiles)
    profiles += fmt::format("{}{{\"time\": {:.17g}, \"velocity_l2_error_percent\": {:.6e}, "
                            "\"stress_l2_error_percent\": {:.6e}}}",
                            profiles.empty() ? "" : ", ", p.time, p.velocity_error_percent,
                            p.stress_error_percent);
  return fmt::format(
      "{{\n"
      "{0}  \"alpha\": {1}, \"cfl\": {2}, \"kernel\": \"{3}\", \"interpolation\": \"{4}\",\n"
      "{0}  \"kinematics\": \"{5}\", \"particles\": {6}, \"dx\": {7:.17g}, \"dt\": {8:.17g},\n"
      "{0}  \"steps\": {9}, \"wall_seconds\": {10:.6f}, \"particle_steps_per_second\": {11:.6e},\n"
      "{0}  \"threads\": {12}, \"interpolation_fallbacks\": {13}, \"gradient_fallbacks\": {14},\n"
      "{0}  \"empty_stencils\": {15},\n"
      "{0}  \"errors\": [{16}]\n"
      "{0}}}",
      indent, s.alpha, s.cfl, to_string(s.kernel), to_string(s.interpolation),
      to_string(s.kinematics), s.particle_count, s.spacing(), r.time_step, r.steps,
      r.wall_seconds, r.particle_steps_per_second, r.threads, r.counters.interpolation_fallbacks,
      r.counters.gradient_fallbacks, r.counters.empty_stencils, profiles);
}

int run_single(const Options& o, const std::filesystem::path& out) {
  BarCaseSettings settings = o.bar;
  // Each profile is written as soon as it is sampled: a later divergence keeps it.
  settings.on_profile = [&](const BarProfile& p) {
    write_profile(out / fmt::format("profile_t{:.6f}ms.csv", p.time * 1e3), p);
    if (!o.quiet)
      fmt::print("t = {:7.3f} ms   L2 error: velocity {:.3e} %   stress {:.3e} %\n", p.time * 1e3,
                 p.velocity_error_percent, p.stress_error_percent);
  };
  const BarResult result = run_bar(settings);
  write_file_atomically(out / "summary.json",
                        fmt::format("{{\"case\": \"bar\", \"run\": {}}}\n",
                                    json_run(o.bar, result, "")));
  if (!o.quiet)
    fmt::print("{} steps, {:.3f} s wall, {:.3e} particle-steps/s on {} thread(s); output in {}\n",
               result.steps, result.wall_seconds, result.particle_steps_per_second,
               result.threads, out.string());
  return 0;
}

int run_table1(const Options& o, const std::filesystem::path& out) {
  struct Row {
    double alpha;
    const char* paper;
  };
  const std::vector<Row> rows = {{0.6, "1e-3"}, {1.2, "1e-2"}, {1.6, "10"}};
  fmt::print("Seed Table 1: 1D elastic bar, {} real particles, dx = {} m, CFL = {}, kernel {},\n"
             "interpolation {}, kinematics {}. L2 error of the velocity in percent.\n\n",
             o.bar.particle_count, o.bar.spacing(), o.bar.cfl, to_string(o.bar.kernel),
             to_string(o.bar.interpolation), to_string(o.bar.kinematics));
  fmt::print("{:>6} {:>9} {:>11} {:>16} {:>16} {:>11}\n", "alpha", "2h (m)", "neighbours",
             "ours t=3.75 ms", "ours t=7.5 ms", "paper");
  std::string runs;
  std::string csv = "alpha,support_radius,error_percent_3p75ms,error_percent_7p5ms,paper_percent\n";
  for (const Row& row : rows) {
    BarCaseSettings s = o.bar;
    s.alpha = row.alpha;
    s.output_times = {3.75e-3, 7.5e-3};
    const BarResult r = run_bar(s);
    // Real particles within 2h of a virtual particle (midpoint), as in the seed's table.
    const int neighbours = 2 * static_cast<int>(std::floor(2.0 * row.alpha + 0.5 + 1e-12));
    fmt::print("{:>6.1f} {:>9.3f} {:>11} {:>16.3e} {:>16.3e} {:>11}\n", row.alpha,
               2.0 * row.alpha * s.spacing(), neighbours, r.profiles[0].velocity_error_percent,
               r.profiles[1].velocity_error_percent, row.paper);
    fmt::format_to(std::back_inserter(csv), "{},{},{:.6e},{:.6e},{}\n", row.alpha, 2.0 * row.alpha * s.spacing(),
              r.profiles[0].velocity_error_percent, r.profiles[1].velocity_error_percent,
              row.paper);
    for (const auto& p : r.profiles)
      write_profile(out / fmt::format("profile_alpha{:.1f}_t{:.6f}ms.csv", row.alpha, p.time * 1e3), p);
    if (!runs.empty()) runs += ",\n  ";
    runs += json_run(s, r, "  ");
  }
  write_file_atomically(out / "table1.csv", csv);
  write_file_atomically(out / "summary.json",
                        fmt::format("{{\"case\": \"bar_table1\", \"runs\": [\n  {}\n]}}\n", runs));
  fmt::print("\nProfiles, table1.csv and summary.json in {}\n", out.string());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  CLI::App app{"tsph-bar: the 1D elastic bar of the Taylor-SPH seed paper (section 4.1)"};
  app.add_flag("--table1", o.table1, "Reproduce the seed's Table 1 (alpha = 0.6, 1.2, 1.6)");
  app.add_option("--alpha", o.bar.alpha, "h / dx (seed: 0.6 to 1.2)")->capture_default_str();
  app.add_option("--cfl", o.bar.cfl, "dt = CFL dx / c, in (0, 1]")->capture_default_str();
  app.add_option("--kernel", o.kernel, "cubic_spline | wendland_c2 | quintic_spline")
      ->capture_default_str();
  app.add_option("--interpolation", o.interpolation,
                 "normalised kernel: linear (first-order corrected) | shepard")
      ->capture_default_str();
  app.add_option("--kinematics", o.kinematics, "small_strain | updated_lagrangian")
      ->capture_default_str();
  app.add_option("--particles", o.bar.particle_count, "real particles (dx = L / (N - 1))")
      ->capture_default_str();
  app.add_option("--length", o.bar.length, "bar length L (m)")->capture_default_str();
  app.add_option("--E", o.bar.young_modulus, "Young's modulus (Pa)")->capture_default_str();
  app.add_option("--rho", o.bar.density, "density (kg/m^3)")->capture_default_str();
  app.add_option("--v0", o.bar.amplitude, "pulse amplitude (m/s)")->capture_default_str();
  app.add_option("--t0", o.bar.pulse_duration, "pulse duration (s)")->capture_default_str();
  app.add_option("--left-end", o.left_end, "fixed | free")->capture_default_str();
  app.add_option("--load", o.load, "velocity | traction (rho c v0) pulse at x = L")
      ->capture_default_str();
  app.add_option("--body-force", o.bar.body_force, "body force per unit mass (m/s^2)")
      ->capture_default_str();
  app.add_option("--times", o.bar.output_times, "output times (s), increasing")
      ->capture_default_str()
      ->delimiter(',');
  app.add_option("--end-time", o.bar.end_time, "end time (s); 0: the last output time")
      ->capture_default_str();
  app.add_option("--out", o.out, "output directory")->capture_default_str();
  app.add_option("--threads", o.threads, "OpenMP threads (0: OpenMP default)");
  app.add_flag("--force", o.bar.force,
               "run a CFL above the stability limit 1 anyway (it diverges: exit status 3)");
  app.add_flag("--quiet", o.quiet, "print nothing but errors");
  if (const auto stop = cli::parse(app, argc, argv)) return *stop;

  if (const auto errors = resolve(o); !errors.empty()) {
    for (const auto& e : errors) fmt::print(stderr, "tsph-bar: error: {}\n", e.message());
    return kExitBadInput;
  }
  set_thread_count(o.threads);
  if (!cli::prepare_output_directory("tsph-bar", o.out)) return kExitBadInput;
  const std::filesystem::path out(o.out);
  try {
    return o.table1 ? run_table1(o, out) : run_single(o, out);
  } catch (const std::invalid_argument& e) {
    fmt::print(stderr, "tsph-bar: error: {}\n", e.what());
    return kExitBadInput;
  } catch (const SolutionDiverged& e) {
    fmt::print(stderr, "tsph-bar: stopped: {}\n", e.what());
    return cli::kExitDiverged;
  } catch (const OutputError& e) {
    fmt::print(stderr, "tsph-bar: stopped: {}\n", e.what());
    return cli::kExitFailure;
  } catch (const std::exception& e) {
    fmt::print(stderr, "tsph-bar: failed: {}\n", e.what());
    return cli::kExitFailure;
  }
}
