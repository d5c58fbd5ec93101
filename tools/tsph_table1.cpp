// tsph table1: the seed's Table 1 (section 4.1) from the bar case, tools/cases/bar.toml:
// the case run at alpha = 0.6, 1.2 and 1.6 through the one case pipeline, its L2
// velocity errors at the case's output times printed beside the paper's.
//
// Writes into --out (default out/bar-table1): alpha<A>/ (each a `tsph run` output
// directory: frames, probes, summary.json; tools/plot_table1.py reads them),
// profile_alpha<A>_t<T>ms.csv (x, velocity, exact velocity, stress, exact stress at
// each output time; tools/plot_bar.py), table1.csv and summary.json
// ("schema": "tsph.summary/1", "command": "table1"; docs/cases.md).
#include "engine/case/case_file.hpp"
#include "engine/case/case_run.hpp"
#include "engine/output_file.hpp"
#include "engine/parallel.hpp"
#include "tools/cli_common.hpp"
#include "tools/tsph_commands.hpp"

#include <fmt/core.h>
#include <fmt/format.h>

#include <cmath>
#include <exception>
#include <filesystem>
#include <iterator>
#include <map>
#include <memory>
#include <string>
#include <vector>

#ifndef TSPH_CASES_DIR
#define TSPH_CASES_DIR "tools/cases"
#endif

namespace tsph::cli {
namespace {

namespace fs = std::filesystem;

struct Table1Options {
  std::string case_path = std::string(TSPH_CASES_DIR) + "/bar.toml";
  std::vector<std::string> overrides;
  std::string out = "out/bar-table1";
  int threads = -1;
};

/// One output time of one run: the profiles along the bar.
struct Profile {
  double time = 0.0;
  std::vector<double> position, velocity, exact_velocity, stress, exact_stress;
};

const output::VtuArray* find_array(const output::VtuFrame& f, const std::string& name) {
  for (const auto& a : f.arrays)
    if (a.name == name) return &a;
  return nullptr;
}

Profile profile_of(const output::VtuFrame& f, double time) {
  Profile p;
  p.time = time;
  const auto* v = find_array(f, "velocity");
  const auto* s = find_array(f, "stress");
  const auto* ev = find_array(f, "exact_velocity_x");
  const auto* es = find_array(f, "exact_stress_xx");
  if (!v || !s || !ev || !es)
    throw CaseError({"table1: the case must write output.fields velocity, stress and exact (exact.solution = "
                     "\"bar\"): they give the profiles"});
  for (std::size_t i = 0; i < f.point_count; ++i) {
    p.position.push_back(f.points[3 * i]);
    p.velocity.push_back(v->float64[3 * i]);
    p.stress.push_back(s->float64[6 * i]);
    p.exact_velocity.push_back(ev->float64[i]);
    p.exact_stress.push_back(es->float64[i]);
  }
  return p;
}

void write_profile(const fs::path& file, const Profile& p) {
  std::string text = "x,velocity,velocity_exact,stress,stress_exact\n";
  for (std::size_t i = 0; i < p.position.size(); ++i)
    fmt::format_to(std::back_inserter(text), "{:.17g},{:.17g},{:.17g},{:.17g},{:.17g}\n", p.position[i],
                   p.velocity[i], p.exact_velocity[i], p.stress[i], p.exact_stress[i]);
  write_file_atomically(file, text);
}

double error_at(const RunReport& r, const std::string& name, double time) {
  for (const auto& e : r.errors)
    if (e.name == name && e.time == time) return e.value;
  return std::nan("");
}

int run_table1(const Table1Options& o) {
  struct Row {
    double alpha;
    const char* paper;  // seed Table 1, L2 velocity error (%)
  };
  const std::vector<Row> rows = {{0.6, "1e-3"}, {1.2, "1e-2"}, {1.6, "10"}};
  if (!prepare_output_directory("tsph", o.out)) return kExitBadInput;
  const fs::path out(o.out);
  std::string csv_times, runs;
  std::string csv;
  bool header = false;
  for (const Row& row : rows) {
    std::vector<std::string> overrides = o.overrides;
    overrides.push_back(fmt::format("method.alpha={}", row.alpha));
    const CaseFile c = load_case(o.case_path, overrides);
    if (c.exact != "bar" || c.output_times.empty())
      throw CaseError({c.path + ": tsph table1 needs the bar case: exact.solution = \"bar\" and output.times"});
    set_thread_count(o.threads >= 0 ? o.threads : c.threads);
    const std::string name = fmt::format("alpha{:.1f}", row.alpha);
    if (!fresh_directory("tsph", (out / name).string())) return kExitBadInput;
    std::vector<Profile> profiles;
    RunOptions options;
    options.out_dir = (out / name).string();
    options.quiet = true;
    options.version = TSPH_VERSION;
    options.overrides = overrides;
    options.on_frame = [&](const output::VtuFrame& f, double t) {
      for (double target : c.output_times)
        if (t == target) profiles.push_back(profile_of(f, t));
    };
    const RunReport r = run_case(c, options);
    if (!header) {
      fmt::print("Seed Table 1: 1D elastic bar, {} real particles, dx = {} m, CFL = {}, kernel {},\n"
                 "interpolation {}, kinematics {}. L2 error of the velocity in percent.\n\n",
                 r.real_particles, c.spacing, c.cfl, to_string(c.kernel), to_string(c.interpolation),
                 to_string(c.kinematics));
      std::string columns;
      for (double t : c.output_times) {
        columns += fmt::format(" {:>16}", fmt::format("ours t={:g} ms", t * 1e3));
        csv_times += fmt::format(",error_percent_{}ms", fmt::format("{:g}", t * 1e3));
      }
      for (char& ch : csv_times)
        if (ch == '.') ch = 'p';
      fmt::print("{:>6} {:>9} {:>11}{} {:>11}\n", "alpha", "2h (m)", "neighbours", columns, "paper");
      csv = "alpha,support_radius" + csv_times + ",paper_percent\n";
      header = true;
    }
    // Real particles within 2h of a virtual particle (midpoint), as in the seed's table.
    const int neighbours = 2 * static_cast<int>(std::floor(2.0 * row.alpha + 0.5 + 1e-12));
    std::string values, csv_values;
    std::string errors;
    for (double t : c.output_times) {
      const double e = error_at(r, "velocity_x_l2_percent", t);
      values += fmt::format(" {:>16.3e}", e);
      csv_values += fmt::format(",{:.6e}", e);
    }
    for (const auto& e : r.errors)
      errors += fmt::format("{}{{\"time\": {:.17g}, \"name\": {}, \"value\": {:.17g}}}", errors.empty() ? "" : ", ",
                            e.time, json_quote(e.name), e.value);
    fmt::print("{:>6.1f} {:>9.3f} {:>11}{} {:>11}\n", row.alpha, 2.0 * row.alpha * c.spacing, neighbours, values,
               row.paper);
    fmt::format_to(std::back_inserter(csv), "{},{}{},{}\n", row.alpha, 2.0 * row.alpha * c.spacing, csv_values,
                   row.paper);
    for (const auto& p : profiles)
      write_profile(out / fmt::format("profile_alpha{:.1f}_t{:.6f}ms.csv", row.alpha, p.time * 1e3), p);
    runs += fmt::format("{}\n    {{\"directory\": {}, \"alpha\": {}, \"paper_percent\": {}, \"steps\": {}, "
                        "\"dt\": {:.17g}, \"errors\": [{}]}}",
                        runs.empty() ? "" : ",", json_quote(name), row.alpha, row.paper, r.steps, r.dt, errors);
  }
  write_file_atomically(out / "table1.csv", csv);
  write_file_atomically(out / "summary.json",
                        fmt::format("{{\n  \"schema\": \"tsph.summary/1\",\n  \"program\": \"tsph\",\n  \"version\": {},\n"
                                    "  \"command\": \"table1\",\n  \"case\": {},\n  \"runs\": [{}\n  ]\n}}\n",
                                    json_quote(TSPH_VERSION), json_quote(o.case_path), runs));
  fmt::print("\nProfiles, table1.csv and summary.json in {}\n", out.string());
  return kExitOk;
}

}  // namespace

std::string json_quote(const std::string& s) {
  std::string out = "\"";
  for (char ch : s) {
    if (ch == '"' || ch == '\\') out += '\\';
    if (static_cast<unsigned char>(ch) < 0x20) out += fmt::format("\\u{:04x}", ch);
    else out += ch;
  }
  return out + "\"";
}

bool fresh_directory(const std::string& program, const std::string& dir) {
  std::error_code ec;
  fs::remove_all(dir, ec);
  return prepare_output_directory(program, dir);
}

Subcommand add_table1(CLI::App& app) {
  auto o = std::make_shared<Table1Options>();
  CLI::App* sub = app.add_subcommand(
      "table1", "the seed's Table 1: the bar case at alpha = 0.6, 1.2, 1.6, our L2 velocity errors beside the "
                "paper's");
  sub->add_option("CASE", o->case_path, "the bar case file")->capture_default_str();
  sub->add_option("--set", o->overrides, "override a key of the case, e.g. --set method.kernel=wendland_c2 (repeatable)")
      ->type_name("KEY=VALUE")
      ->take_all()
      ->allow_extra_args(false);
  sub->add_option("--out", o->out, "output directory (its alpha*/ run directories are replaced)")
      ->capture_default_str();
  sub->add_option("--threads", o->threads, "OpenMP threads (0: OpenMP default; overrides the case's threads)")
      ->check(CLI::NonNegativeNumber);
  return {sub, [o] {
            try {
              return run_table1(*o);
            } catch (const CaseError& e) {
              for (const auto& m : e.messages()) fmt::print(stderr, "tsph: error: {}\n", m);
              return kExitBadInput;
            } catch (const RunDiverged& e) {
              fmt::print(stderr, "tsph: diverged: {}\n", e.what());
              return kExitDiverged;
            } catch (const std::exception& e) {
              fmt::print(stderr, "tsph: failed: {}\n", e.what());
              return kExitFailure;
            }
          }};
}

}  // namespace tsph::cli
