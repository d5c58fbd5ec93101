// tsph converge CASE --sweep KEY=V1,V2,...: a convergence study over a case. Runs the
// case once per value of KEY (through the one case pipeline, as `tsph run` would),
// then prints a table of the case's error figures (the "*_percent" entries of its
// exact solution at the end of each run) with the observed rate between successive
// runs, log(e1 / e2) / log(V1 / V2): the order of convergence when KEY is
// geometry.spacing.
//
//   tsph converge tools/cases/cantilever_2d.toml --sweep geometry.spacing=0.025,0.0125,0.00625
//
// Writes into --out (default out/<case name>-converge): one `tsph run` output directory
// per value (<KEY's last part>_<value>/), converge.csv and summary.json
// ("schema": "tsph.summary/1", "command": "converge"; docs/cases.md). A run that does
// not come to rest is reported as such, its rate as '-'. Exit status: 0, 2 bad input,
// 3 a run diverged or did not come to rest, 1 other failure.
#include "engine/case/case_file.hpp"
#include "engine/case/case_run.hpp"
#include "engine/output_file.hpp"
#include "engine/parallel.hpp"
#include "tools/cli_common.hpp"
#include "tools/tsph_commands.hpp"

#include <fmt/core.h>
#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <exception>
#include <filesystem>
#include <iterator>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

namespace tsph::cli {
namespace {

namespace fs = std::filesystem;

struct ConvergeOptions {
  std::string case_path;
  std::string sweep;  ///< KEY=V1,V2,...
  std::vector<std::string> overrides;
  std::string out;
  int threads = -1;
};

struct SweepRun {
  std::string value, directory, status;
  double number = std::nan("");  ///< the value as a number (NaN if it is not one)
  RunReport report;
};

std::string status_of(const RunReport& r) {
  switch (r.status) {
    case RunReport::Status::finished: return "finished";
    case RunReport::Status::at_rest: return "at_rest";
    case RunReport::Status::not_at_rest: return "not_at_rest";
    case RunReport::Status::interrupted: return "interrupted";
  }
  return "?";
}

/// The error figures at the run's last time, in the order the exact solution gives them.
std::vector<ErrorRecord> final_errors(const RunReport& r) {
  std::vector<ErrorRecord> out;
  for (const auto& e : r.errors)
    if (e.time == r.time && e.name.size() > 8 && e.name.compare(e.name.size() - 8, 8, "_percent") == 0)
      out.push_back(e);
  return out;
}

int run_converge(const ConvergeOptions& o) {
  const auto equals = o.sweep.find('=');
  if (equals == std::string::npos || equals == 0 || equals + 1 == o.sweep.size())
    throw CaseError({"--sweep '" + o.sweep + "' is invalid: write --sweep KEY=V1,V2,..., e.g. --sweep "
                     "geometry.spacing=0.025,0.0125"});
  const std::string key = o.sweep.substr(0, equals);
  std::vector<std::string> values;
  std::stringstream list(o.sweep.substr(equals + 1));
  for (std::string v; std::getline(list, v, ',');)
    if (!v.empty()) values.push_back(v);
  if (values.size() < 2)
    throw CaseError({"--sweep " + key + ": give at least two values (V1,V2,...) to observe a rate"});
  // Every case first: bad input is refused before any run.
  std::vector<CaseFile> cases;
  for (const auto& v : values) {
    std::vector<std::string> overrides = o.overrides;
    overrides.push_back(key + "=" + v);
    cases.push_back(load_case(o.case_path, overrides));
  }
  const std::string out = !o.out.empty() ? o.out : (fs::path("out") / (fs::path(o.case_path).stem().string() + "-converge")).string();
  if (!prepare_output_directory("tsph", out)) return kExitBadInput;
  const std::string last_part = key.substr(key.rfind('.') == std::string::npos ? 0 : key.rfind('.') + 1);
  std::vector<SweepRun> runs;
  bool all_good = true;
  for (std::size_t k = 0; k < values.size(); ++k) {
    const CaseFile& c = cases[k];
    set_thread_count(o.threads >= 0 ? o.threads : c.threads);
    SweepRun run;
    run.value = values[k];
    try {
      std::size_t used = 0;
      run.number = std::stod(values[k], &used);
      if (used != values[k].size()) run.number = std::nan("");
    } catch (const std::exception&) {
    }
    run.directory = last_part + "_" + values[k];
    for (char& ch : run.directory)
      if (!std::isalnum(static_cast<unsigned char>(ch)) && ch != '.' && ch != '-' && ch != '_') ch = '_';
    if (!fresh_directory("tsph", (fs::path(out) / run.directory).string())) return kExitBadInput;
    RunOptions options;
    options.out_dir = (fs::path(out) / run.directory).string();
    options.quiet = true;
    options.version = TSPH_VERSION;
    options.overrides = o.overrides;
    options.overrides.push_back(key + "=" + values[k]);
    fmt::print(stderr, "tsph converge: {} = {} ...\n", key, values[k]);
    try {
      run.report = run_case(c, options);
      run.status = status_of(run.report);
    } catch (const RunDiverged& e) {
      run.status = "diverged";
      fmt::print(stderr, "tsph converge: {} = {} diverged: {}\n", key, values[k], e.what());
    }
    all_good = all_good && (run.status == "finished" || run.status == "at_rest");
    runs.push_back(std::move(run));
  }

  // The table: per run its status and error figures, with the rate against the previous.
  std::vector<std::string> names;
  for (const auto& r : runs)
    for (const auto& e : final_errors(r.report))
      if (std::find(names.begin(), names.end(), e.name) == names.end()) names.push_back(e.name);
  auto value_of = [](const SweepRun& r, const std::string& name) {
    for (const auto& e : final_errors(r.report))
      if (e.name == name) return e.value;
    return std::nan("");
  };
  auto good = [](const SweepRun& r) { return r.status == "finished" || r.status == "at_rest"; };
  std::string header = fmt::format("{:>12} {:>12} {:>8} {:>10}", last_part, "status", "steps", "t (s)");
  std::string csv = key + ",status,steps,time";
  std::vector<std::size_t> widths;  // of each error column
  for (const auto& name : names) {
    const std::string label = name.substr(0, name.size() - 8) + " %";
    widths.push_back(std::max<std::size_t>(10, label.size()));
    header += fmt::format(" {:>{}} {:>6}", label, widths.back(), "rate");
    csv += "," + name + ",rate_" + name.substr(0, name.size() - 8);
  }
  fmt::print("{}: {} over {}\n{}\n", o.case_path, key, o.sweep.substr(equals + 1), header);
  csv += "\n";
  std::string json_runs;
  for (std::size_t k = 0; k < runs.size(); ++k) {
    const SweepRun& r = runs[k];
    std::string line = fmt::format("{:>12} {:>12} {:>8} {:>10.4g}", r.value, r.status, r.report.steps, r.report.time);
    std::string row = fmt::format("{},{},{},{:.17g}", r.value, r.status, r.report.steps, r.report.time);
    std::string json_errors;
    for (std::size_t n = 0; n < names.size(); ++n) {
      const std::string& name = names[n];
      const double e = value_of(r, name);
      std::string rate = "-";
      if (k > 0 && good(r) && good(runs[k - 1]) && std::isfinite(r.number) && std::isfinite(runs[k - 1].number) &&
          r.number != runs[k - 1].number) {
        const double previous = value_of(runs[k - 1], name);
        if (std::abs(e) > 0.0 && std::abs(previous) > 0.0)
          rate = fmt::format("{:.2f}", std::log(std::abs(previous) / std::abs(e)) / std::log(runs[k - 1].number / r.number));
      }
      line += fmt::format(" {:>{}.4g} {:>6}", e, widths[n], rate);
      row += fmt::format(",{:.17g},{}", e, rate == "-" ? "" : rate);
      json_errors += fmt::format("{}{{\"name\": {}, \"value\": {}, \"rate\": {}}}", json_errors.empty() ? "" : ", ",
                                 json_quote(name), std::isfinite(e) ? fmt::format("{:.17g}", e) : "null",
                                 rate == "-" ? "null" : rate);
    }
    fmt::print("{}\n", line);
    csv += row + "\n";
    json_runs += fmt::format("{}\n    {{\"value\": {}, \"directory\": {}, \"status\": {}, \"steps\": {}, \"time\": {:.17g}, "
                             "\"errors\": [{}]}}",
                             json_runs.empty() ? "" : ",", json_quote(r.value), json_quote(r.directory),
                             json_quote(r.status), r.report.steps, r.report.time, json_errors);
  }
  write_file_atomically(fs::path(out) / "converge.csv", csv);
  std::string overrides;
  for (const auto& s : o.overrides) overrides += (overrides.empty() ? "" : ", ") + json_quote(s);
  write_file_atomically(fs::path(out) / "summary.json",
                        fmt::format("{{\n  \"schema\": \"tsph.summary/1\",\n  \"program\": \"tsph\",\n  \"version\": {},\n"
                                    "  \"command\": \"converge\",\n  \"case\": {},\n  \"overrides\": [{}],\n"
                                    "  \"sweep\": {},\n  \"runs\": [{}\n  ]\n}}\n",
                                    json_quote(TSPH_VERSION), json_quote(o.case_path), overrides, json_quote(key),
                                    json_runs));
  fmt::print("runs, converge.csv and summary.json in {}\n", out);
  return all_good ? kExitOk : kExitNotConverged;
}

}  // namespace

Subcommand add_converge(CLI::App& app) {
  auto o = std::make_shared<ConvergeOptions>();
  CLI::App* sub = app.add_subcommand(
      "converge", "a convergence study: the case run once per value of a key, its error figures and observed rates");
  sub->add_option("CASE", o->case_path, "case file (TOML)")->required();
  sub->add_option("--sweep", o->sweep, "the key and its values, e.g. --sweep geometry.spacing=0.025,0.0125")
      ->type_name("KEY=V1,V2,...")
      ->required();
  sub->add_option("--set", o->overrides, "override a key of the case for every run (repeatable)")
      ->type_name("KEY=VALUE")
      ->take_all()
      ->allow_extra_args(false);
  sub->add_option("--out", o->out, "output directory (default: out/<case name>-converge)");
  sub->add_option("--threads", o->threads, "OpenMP threads (0: OpenMP default; overrides the case's threads)")
      ->check(CLI::NonNegativeNumber);
  return {sub, [o] {
            try {
              return run_converge(*o);
            } catch (const CaseError& e) {
              for (const auto& m : e.messages()) fmt::print(stderr, "tsph: error: {}\n", m);
              return kExitBadInput;
            } catch (const std::exception& e) {
              fmt::print(stderr, "tsph: failed: {}\n", e.what());
              return kExitFailure;
            }
          }};
}

}  // namespace tsph::cli
