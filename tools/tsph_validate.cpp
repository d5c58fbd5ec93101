// tsph validate [NAME...] [--quick] [--out DIR] [--cases DIR] [--list] [--threads N] [--jobs N] [--set KEY=VALUE...]:
// the large-deformation validation suite (issue 14; docs/validation.md, "Large
// deformation (tsph validate)"). Runs the selected cases (all by default; NAME is a
// case name or the beginning of some, e.g. "homogeneous" or "rotation_2d"), prints one
// row per check (case, figure, value, reference, error, tolerance, verdict), and writes
//   OUT/<case>/<series>.csv    the curves of each case (tools/validate/validation_case.hpp)
//   OUT/<case>/run/            the case's run (VTU frames, summary.json)
//   OUT/table.md               the table, dated, with the command
//   OUT/validate.json          the same, for programs
//   OUT/<case>/<series>.png    drawn by tools/plot_validation.py (python3 + matplotlib)
// Exit status: 0 every check passed, 4 some check failed (a case that diverged is a
// failed "no divergence" check), 2 bad input (an unknown case name lists the valid
// ones; a --set that a case file refuses: that case's row fails, the others run and
// the table is written), 1 other failure (an output file that cannot be written).
#include "tools/cli_common.hpp"
#include "tools/tsph_commands.hpp"
#include "tools/validate/validation_case.hpp"

#include "engine/case/case_file.hpp"
#include "engine/case/case_run.hpp"
#include "engine/output_file.hpp"
#include "engine/threads.hpp"

#include <fmt/core.h>
#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <thread>
#include <string>
#include <vector>

#ifndef TSPH_VERSION
#define TSPH_VERSION "unknown"
#endif
#ifndef TSPH_CASES_DIR
#define TSPH_CASES_DIR "tools/cases"
#endif
#ifndef TSPH_TOOLS_DIR
#define TSPH_TOOLS_DIR "tools"
#endif

namespace tsph::cli {
namespace {

namespace fs = std::filesystem;
using validate::Case;
using validate::Check;
using validate::Result;

/// Every registered case, group by group: the one list to extend.
std::vector<Case> registered_cases() {
  std::vector<Case> all;
  for (auto group : {validate::homogeneous_cases, validate::rotation_cases, validate::cantilever_cases,
                     validate::plate_cases, validate::column_cases, validate::plasticity_cases,
                     validate::footing_cases, validate::taylor_bar_cases}) {
    auto cases = group();
    all.insert(all.end(), cases.begin(), cases.end());
  }
  return all;
}

struct ValidateOptions {
  std::vector<std::string> names;
  bool quick = false, list = false;
  std::string out = "out/validate";
  std::string cases_dir = TSPH_CASES_DIR;
  int threads = 0;  ///< per case; 0: the cores / jobs (one job: each case file's threads)
  int jobs = 0;     ///< cases at a time; 0: the cores / threads
  std::vector<std::string> overrides;  ///< --set KEY=VALUE, for every case file
  std::string command;  ///< the command line, for table.md
};

struct CaseOutcome {
  std::string name, description;
  Result result;
  double wall_seconds = 0.0;
  std::string error;  ///< the case could not run (an exception), else empty
};

std::string number(double v) { return std::isfinite(v) ? fmt::format("{:.6g}", v) : "nan"; }
std::string json_number(double v) { return std::isfinite(v) ? fmt::format("{:.17g}", v) : "null"; }

std::string verdict(const Check& c) { return c.pass ? "PASS" : "FAIL"; }

void print_row(const std::string& name, const Check& c) {
  fmt::print("{:<32} {:<62} {:>13} {:>13} {:>10} {:>9} {:>4} {}\n", name, c.figure, number(c.value), number(c.reference),
             number(c.error), number(c.tolerance), c.error_kind, verdict(c));
}

void write_series(const fs::path& dir, const validate::Series& s) {
  std::string text = "# " + s.title + "\n# x: " + s.x_label + "; y: " + s.y_label + "\n";
  for (std::size_t k = 0; k < s.columns.size(); ++k) {
    std::string name = s.columns[k];
    if (name.find_first_of(",\"") != std::string::npos) {  // RFC 4180 quoting: a comma stays in its column
      std::string quoted(1, '"');
      for (const char ch : name) {
        if (ch == '"') quoted.push_back('"');
        quoted.push_back(ch);
      }
      quoted.push_back('"');
      name = std::move(quoted);
    }
    text += (k ? "," : "") + name;
  }
  text += "\n";
  for (const auto& row : s.rows) {
    for (std::size_t k = 0; k < row.size(); ++k) {
      if (k) text += ',';
      text += fmt::format("{:.12g}", row[k]);
    }
    text += "\n";
  }
  write_file_atomically(dir / (s.name + ".csv"), text);
}

std::string today() {
  const std::time_t now = std::time(nullptr);
  char buffer[32];
  std::strftime(buffer, sizeof buffer, "%Y-%m-%d %H:%M UTC", std::gmtime(&now));
  return buffer;
}

/// Runs one case into `dir` and turns what it throws into rows: a divergence that the case
/// lets through is a failed "no divergence" row, a case file that refuses a --set counts
/// in `refused`, any other error a failed "the case ran" row.
CaseOutcome run_one(const Case& c, const ValidateOptions& o, int threads, const fs::path& dir, std::atomic<int>& refused) {
  CaseOutcome outcome{c.name, c.description, {}, 0.0, ""};
  validate::Options options;
  options.cases_dir = o.cases_dir;
  options.out_dir = dir.string();
  options.quick = o.quick;
  options.threads = threads;
  options.overrides = o.overrides;
  const auto start = std::chrono::steady_clock::now();
  try {
    outcome.result = c.run(options);
  } catch (const RunDiverged& e) {  // a case that lets it through: a failed "no divergence" row
    Check diverged;
    diverged.figure = "no divergence";
    diverged.value = 0.0;
    diverged.reference = 1.0;
    diverged.error = 1.0;
    diverged.error_kind = "abs";
    outcome.result.checks.push_back(diverged);
    outcome.result.notes.push_back(std::string("diverged: ") + e.what());
  } catch (const CaseError& e) {
    outcome.error = std::string("bad case: ") + e.what();
    // The shipped case files load: a message that names a --set key (an unknown key, an
    // option the case cannot take) is the --set's fault; others (a missing file) are not.
    const std::string message = e.what();
    const bool names_override = std::any_of(o.overrides.begin(), o.overrides.end(), [&](const std::string& s) {
      return message.find(s.substr(0, s.find('='))) != std::string::npos;
    });
    if (names_override) {
      fmt::print(stderr, "tsph: error: validate: case {} does not take the --set: {}\n", c.name, message);
      ++refused;
    }
  } catch (const std::exception& e) {
    outcome.error = e.what();
  }
  outcome.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (!outcome.error.empty()) {
    Check failed;
    failed.figure = "the case ran";
    failed.value = std::nan("");
    failed.error_kind = "abs";
    outcome.result.checks.push_back(failed);
    outcome.result.notes.push_back(outcome.error);
  }
  return outcome;
}

int run_validate(const ValidateOptions& o) {
  const std::vector<Case> all = registered_cases();
  if (o.list) {
    for (const auto& c : all) fmt::print("{:<32} {}{}\n", c.name, c.description, c.slow ? " (slow)" : "");
    return kExitOk;
  }
  if (const auto error = thread_count_error("--threads", o.threads)) {
    fmt::print(stderr, "tsph: error: {}\n", *error);
    return kExitBadInput;
  }
  std::error_code ec;
  if (!fs::is_directory(o.cases_dir, ec)) {
    fmt::print(stderr, "tsph: error: --cases '{}' is not a directory: give the directory of the case files (tools/cases)\n",
               o.cases_dir);
    return kExitBadInput;
  }
  // The selection: the case named NAME, or else every case whose name begins with NAME
  // ("taylor_bar" is that case, "rotation_2d" both alphas); all when none given.
  std::vector<const Case*> selected;
  for (const auto& name : o.names) {
    bool found = false;
    const bool exact = std::any_of(all.begin(), all.end(), [&](const Case& c) { return c.name == name; });
    for (const auto& c : all)
      if (exact ? c.name == name : c.name.rfind(name, 0) == 0) {
        found = true;
        if (std::find(selected.begin(), selected.end(), &c) == selected.end()) selected.push_back(&c);
      }
    if (!found) {
      std::string valid;
      for (const auto& c : all) valid += "\n  " + c.name;
      fmt::print(stderr, "tsph: error: validate: no case is named '{}' or begins so; the cases are:{}\n", name, valid);
      return kExitBadInput;
    }
  }
  if (o.names.empty())
    for (const auto& c : all) selected.push_back(&c);
  for (const auto& s : o.overrides)  // the case files' rule (apply_override), checked before any run
    if (s.find('=') == std::string::npos || s.front() == '=') {
      fmt::print(stderr, "tsph: error: validate: --set '{}' is invalid: write --set key=value, e.g. --set "
                         "method.conservative_momentum=true\n", s);
      return kExitBadInput;
    }
  if (!prepare_output_directory("tsph", o.out)) return kExitBadInput;

  // Concurrent cases (--jobs): each case runs on its own std::thread with its own OpenMP
  // thread count (an OpenMP ICV is per thread), the longest first (below), so that the long
  // ones overlap and the short ones fill the gaps. Most cases are too small for two
  // threads to pay (a 2D plate of 1 100 particles runs faster on one thread: the loops'
  // barriers cost more than half the step), so the default is one case per core.
  // At most kDefaultJobs by default: each case keeps its frames in memory, and a large
  // machine is better used with more threads per case than with forty cases at once.
  constexpr int kDefaultJobs = 4;
  const int cores = std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  int jobs = o.jobs > 0 ? o.jobs : std::clamp(cores / std::max(1, o.threads), 1, kDefaultJobs);
  jobs = std::min<int>(jobs, static_cast<int>(selected.size()));
  const int threads = o.threads > 0 ? o.threads : (jobs > 1 ? std::max(1, cores / jobs) : 0);
  // The order: the longest first (the LPT rule), so that the workers finish together.
  // Each listed case's full version took this many seconds of one core in session 40's
  // whole suite (2-core AMD EPYC, 2026-12-07, validate.json of `tsph validate`, two cases
  // at a time; 2 470 s in all, on a host slower that day than session 39's, whose
  // figures these replace: the longest cases took 5-22 % longer with fewer instructions).
  // A case not here keeps the listed order after them (the slow ones first). The
  // figures order the runs only: a stale one costs time, never a result.
  static const std::map<std::string, double> kLongestSeconds = {
      {"taylor_bar_quarter", 699}, {"twisting_column_alpha1.2", 390}, {"plate_large", 385},
      {"twisting_column_alpha0.6", 249}, {"cantilever_3d_ul", 230},   {"taylor_bar", 101},
      {"cantilever_large_k1", 59}, {"cantilever_large_k3", 58},       {"plate_small", 52},
      {"rotation_2d_alpha1.2", 29}, {"rotation_3d_alpha1.2", 28},     {"rotation_2d_alpha0.6", 22},
      {"footing_tresca", 19},      {"rotation_3d_alpha0.6", 15}};
  for (const auto& entry : kLongestSeconds) {  // a renamed case would lose its place
    const std::string& name = entry.first;  // not a structured binding: clang 14 cannot capture one
    if (std::none_of(all.begin(), all.end(), [&](const Case& c) { return c.name == name; })) {
      fmt::print(stderr, "tsph: internal error: validate: the order names '{}', which is no case\n", name);
      return kExitFailure;
    }
  }
  const auto expected_seconds = [&](const Case* c) {
    const auto it = kLongestSeconds.find(c->name);
    return it == kLongestSeconds.end() ? 0.0 : it->second;
  };
  std::vector<std::size_t> order(selected.size());
  for (std::size_t k = 0; k < order.size(); ++k) order[k] = k;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    const double ta = expected_seconds(selected[a]), tb = expected_seconds(selected[b]);
    if (ta != tb) return ta > tb;
    return selected[a]->slow && !selected[b]->slow;
  });
  for (const Case* c : selected)
    if (!fresh_directory("tsph", (fs::path(o.out) / c->name).string())) return kExitBadInput;
  if (jobs > 1)
    fmt::print(stderr, "tsph: validate: {} cases, {} at a time, {} thread{} each (--jobs, --threads)\n", selected.size(),
               jobs, threads, threads == 1 ? "" : "s");

  fmt::print("{:<32} {:<62} {:>13} {:>13} {:>10} {:>9} {:>4} {}\n", "case", "figure", "value", "reference", "error",
             "tolerance", "kind", "verdict");
  std::vector<CaseOutcome> outcomes(selected.size());
  std::atomic<int> refused{0};  // cases whose file refused a --set (an unknown key, an option it cannot take)
  std::atomic<bool> write_failed{false};
  std::atomic<std::size_t> next{0};
  std::mutex print_mutex;  // one case's rows and notes stay together
  // A worker stops taking cases once an output could not be written (the run then exits 1
  // without a table); nothing it throws leaves its thread (that would end the program).
  auto worker = [&] {
    for (std::size_t k = next++; k < order.size() && !write_failed; k = next++) {
      const Case* c = selected[order[k]];
      const fs::path dir = fs::path(o.out) / c->name;
      try {
        CaseOutcome outcome = run_one(*c, o, threads, dir, refused);
        const std::lock_guard<std::mutex> lock(print_mutex);
        for (const auto& check : outcome.result.checks) print_row(c->name, check);
        for (const auto& note : outcome.result.notes) fmt::print("  {}: {}\n", c->name, note);
        std::fflush(stdout);
        for (const auto& s : outcome.result.series) write_series(dir, s);
        outcomes[order[k]] = std::move(outcome);
      } catch (const std::exception& e) {
        fmt::print(stderr, "tsph: failed: {}: {}\n", c->name, e.what());
        write_failed = true;
      } catch (...) {
        fmt::print(stderr, "tsph: failed: {}: an unknown error\n", c->name);
        write_failed = true;
      }
    }
  };
  if (jobs <= 1) {
    worker();
  } else {
    std::vector<std::thread> pool;
    for (int j = 0; j < jobs; ++j) pool.emplace_back(worker);
    for (auto& t : pool) t.join();
  }
  if (write_failed) return kExitFailure;

  // The summary: table.md and validate.json.
  int passed = 0, failed = 0;
  std::string table = fmt::format("Validation suite, {} (tsph {}{}), measured {}:\n\n    {}\n\n", o.quick ? "quick" : "full",
                                  TSPH_VERSION, "", today(), o.command);
  table += "| case | figure | value | reference | error | tolerance | verdict |\n| --- | --- | --- | --- | --- | --- | --- |\n";
  std::string json_cases;
  for (const auto& outcome : outcomes) {
    std::string json_checks;
    for (const auto& c : outcome.result.checks) {
      (c.pass ? passed : failed)++;
      table += fmt::format("| {} | {} | {} | {} | {} ({}) | {} | {} |\n", outcome.name, c.figure, number(c.value),
                           number(c.reference), number(c.error), c.error_kind, number(c.tolerance), verdict(c));
      json_checks += fmt::format("{}\n        {{\"figure\": {}, \"value\": {}, \"reference\": {}, \"error\": {}, "
                                 "\"error_kind\": {}, \"tolerance\": {}, \"pass\": {}}}",
                                 json_checks.empty() ? "" : ",", json_quote(c.figure), json_number(c.value),
                                 json_number(c.reference), json_number(c.error), json_quote(c.error_kind),
                                 json_number(c.tolerance), c.pass ? "true" : "false");
    }
    std::string json_notes;
    for (const auto& n : outcome.result.notes) json_notes += (json_notes.empty() ? "" : ", ") + json_quote(n);
    json_cases += fmt::format("{}\n    {{\"name\": {}, \"description\": {}, \"wall_seconds\": {:.3f}, \"checks\": [{}\n      ], "
                              "\"notes\": [{}]}}",
                              json_cases.empty() ? "" : ",", json_quote(outcome.name), json_quote(outcome.description),
                              outcome.wall_seconds, json_checks, json_notes);
  }
  table += "\n";
  for (const auto& outcome : outcomes) {
    table += fmt::format("- {} ({:.1f} s): {}\n", outcome.name, outcome.wall_seconds, outcome.description);
    for (const auto& n : outcome.result.notes) table += "  - " + n + "\n";
  }
  try {
    write_file_atomically(fs::path(o.out) / "table.md", table);
    write_file_atomically(fs::path(o.out) / "validate.json",
                          fmt::format("{{\n  \"schema\": \"tsph.validate/1\",\n  \"version\": {},\n  \"command\": {},\n"
                                      "  \"date\": {},\n  \"quick\": {},\n  \"passed\": {},\n  \"failed\": {},\n"
                                      "  \"cases\": [{}\n  ]\n}}\n",
                                      json_quote(TSPH_VERSION), json_quote(o.command), json_quote(today()),
                                      o.quick ? "true" : "false", passed, failed, json_cases));
  } catch (const std::exception& e) {
    fmt::print(stderr, "tsph: failed: {}\n", e.what());
    return kExitFailure;
  }
  fmt::print("{} checks passed, {} failed{}; table.md, validate.json and the series in {}\n", passed, failed,
             refused > 0 ? fmt::format(" ({} case(s) refused the --set: exit status 2)", refused.load()) : "", o.out);

  // The plots: optional (python3 with matplotlib). The python3 on PATH first, then the
  // system's, where tools/setup.sh installs matplotlib (a pyenv or venv python3 on PATH
  // usually lacks it).
  const std::string script = std::string(TSPH_TOOLS_DIR) + "/plot_validation.py";
  std::string python;
  for (const char* candidate : {"python3", "/usr/bin/python3"})
    if (std::system(fmt::format("{} -c 'import matplotlib' >/dev/null 2>&1", candidate).c_str()) == 0) {
      python = candidate;
      break;
    }
  if (python.empty()) {
    fmt::print(stderr, "tsph: validate: no plots: python3 with matplotlib is missing (tools/setup.sh installs "
                       "python3-matplotlib; then python3 {} {})\n", script, o.out);
  } else if (std::system(fmt::format("{} '{}' '{}'", python, script, o.out).c_str()) != 0) {
    fmt::print(stderr, "tsph: validate: {} failed; the table and the CSV series are written\n", script);
  }
  if (refused > 0) return kExitBadInput;  // after the table: the other cases' rows are kept
  return failed == 0 ? kExitOk : kExitValidationFailed;
}

}  // namespace

Subcommand add_validate(CLI::App& app, int argc, char** argv) {
  auto o = std::make_shared<ValidateOptions>();
  for (int k = 0; k < argc; ++k) o->command += (k ? " " : "") + std::string(argv[k]);
  CLI::App* sub = app.add_subcommand("validate", "the large-deformation validation suite: cases against exact and "
                                                 "reference solutions, a table, CSV series and plots");
  sub->add_option("NAME", o->names, "cases to run: a name (that case alone), or else the beginning of names (default: all; --list)");
  sub->add_flag("--quick", o->quick, "the fast versions (coarser, shorter; the default ctest suite)");
  sub->add_option("--out", o->out, "output directory (default: out/validate)");
  sub->add_option("--cases", o->cases_dir, "directory of the case files (default: the source tree's tools/cases)");
  sub->add_flag("--list", o->list, "list the cases and exit");
  sub->add_option("--threads", o->threads, "OpenMP threads per case (0: the cores / --jobs; with one job, each case file's threads)")
      ->check(CLI::NonNegativeNumber);
  sub->add_option("--jobs", o->jobs, "cases run at a time (0: the cores / --threads, at most 4; 1: one after the other)")
      ->check(CLI::NonNegativeNumber);
  sub->add_option("--set", o->overrides,
                  "override a key of every case file after the case's own settings, e.g. --set "
                  "method.conservative_momentum=true (repeatable; for method keys: the references assume the "
                  "cases' geometry and material; a case file that refuses it fails its row, and the exit status is 2)")
      ->type_name("KEY=VALUE")
      ->allow_extra_args(false);  // one KEY=VALUE per --set: the case names stay positional
  return {sub, [o] {
            try {
              return run_validate(*o);
            } catch (const std::exception& e) {
              fmt::print(stderr, "tsph: failed: {}\n", e.what());
              return kExitFailure;
            }
          }};
}

}  // namespace tsph::cli
