#include "tools/validate/support.hpp"

#include "engine/parallel.hpp"

#include <fmt/core.h>
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

#ifndef TSPH_VERSION
#define TSPH_VERSION "unknown"
#endif

namespace tsph::validate {

namespace fs = std::filesystem;

void use_threads(const Options& options, const CaseFile& file) {
  set_thread_count(options.threads > 0 ? options.threads : file.threads);
}

CaseRun run_case_file(const Options& options, const std::string& file, const std::vector<std::string>& overrides,
                      const std::string& run_name, bool record_steps) {
  CaseRun run;
  const std::vector<std::string> all_overrides = with_user_overrides(options, overrides);
  run.file = load_case((fs::path(options.cases_dir) / file).string(), all_overrides);
  use_threads(options, run.file);
  const fs::path dir = fs::path(options.out_dir) / run_name;
  std::error_code ec;
  fs::remove_all(dir, ec);
  fs::create_directories(dir, ec);
  if (ec) throw std::runtime_error("cannot create " + dir.string() + ": " + ec.message());
  RunOptions o;
  o.out_dir = dir.string();
  o.quiet = options.quiet;
  o.version = TSPH_VERSION;
  o.overrides = all_overrides;
  o.on_frame = [&run](const output::VtuFrame& frame, double t) {
    run.frame_times.push_back(t);
    run.frames.push_back(frame);
  };
  if (record_steps) o.on_step = [&run](const RunOptions::StepRecord& s) { run.steps.push_back(s); };
  const auto start = std::chrono::steady_clock::now();
  try {
    run.report = run_case(run.file, o);
  } catch (const RunDiverged& e) {
    run.diverged = true;
    run.diagnosis = e.what();
    run.diverged_time = run.steps.empty() ? (run.frame_times.empty() ? 0.0 : run.frame_times.back()) : run.steps.back().time;
  }
  run.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (std::ifstream in(dir / "energy.csv"); in) {
    std::string line;
    std::getline(in, line);
    std::vector<std::string> names;
    std::stringstream header(line);
    for (std::string name; std::getline(header, name, ',');) names.push_back(name);
    while (std::getline(in, line)) {
      std::stringstream row(line);
      std::size_t k = 0;
      for (std::string cell; std::getline(row, cell, ',') && k < names.size(); ++k)
        run.energy[names[k]].push_back(std::stod(cell));
    }
  }
  return run;
}

double largest_balance_error(const CaseRun& run, double scale) {
  const auto it = run.energy.find("balance_error");
  if (it == run.energy.end() || it->second.empty()) return std::numeric_limits<double>::quiet_NaN();
  double largest = 0.0;
  for (double e : it->second) largest = std::max(largest, std::abs(e));
  return largest / scale;
}

const std::vector<double>& array_of(const output::VtuFrame& frame, const std::string& name) {
  for (const auto& a : frame.arrays)
    if (a.name == name && !a.is_uint32) return a.float64;
  throw std::runtime_error("validation: the frame has no array '" + name + "' (add it to output.fields)");
}

const std::vector<std::uint32_t>& ids_of(const output::VtuFrame& frame) {
  for (const auto& a : frame.arrays)
    if (a.name == "id" && a.is_uint32) return a.uint32;
  throw std::runtime_error("validation: the frame has no array 'id' (add it to output.fields)");
}

Check relative_check(std::string figure, double value, double reference, double tolerance) {
  Check c;
  c.figure = std::move(figure);
  c.value = value;
  c.reference = reference;
  c.error = std::abs(value - reference) / std::abs(reference);
  c.tolerance = tolerance;
  c.error_kind = "rel";
  c.pass = std::isfinite(c.error) && c.error <= tolerance;
  return c;
}

Check bound_check(std::string figure, double value, double bound) {
  Check c;
  c.figure = std::move(figure);
  c.value = value;
  c.reference = bound;
  c.error = value;
  c.tolerance = bound;
  c.error_kind = "max";
  c.pass = std::isfinite(value) && value <= bound;
  return c;
}

Check no_divergence_check(const CaseRun& run, Result& result) {
  Check c;
  c.figure = "no divergence (time reached / end)";
  c.reference = 1.0;
  c.value = run.diverged ? run.diverged_time / run.file.end_time : 1.0;
  c.error = std::abs(c.value - 1.0);
  c.tolerance = 0.0;
  c.error_kind = "abs";
  c.pass = !run.diverged;
  if (run.diverged)
    result.notes.push_back(fmt::format("diverged (last frame or step kept at t = {:.6g} s): {}", run.diverged_time,
                                       run.diagnosis));
  return c;
}

std::string toml_array(const std::vector<double>& values) {
  std::string s = "[";
  for (std::size_t k = 0; k < values.size(); ++k) {
    std::string number = fmt::format("{:.17g}", values[k]);
    if (number.find_first_of(".eEn") == std::string::npos) number += ".0";  // a TOML float
    s += (k ? ", " : "") + number;
  }
  return s + "]";
}

std::string output_times(double end, int count) {
  std::vector<double> t;
  for (int k = 1; k <= count; ++k) t.push_back(end * k / count);
  t.back() = end;
  return "output.times=" + toml_array(t);
}

}  // namespace tsph::validate
