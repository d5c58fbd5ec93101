// What the validation cases share (tools/validate/*.cpp): running a case file of
// tools/cases through the one case pipeline with the frames kept in memory, reading a
// frame's arrays, and making the table's checks.
#pragma once

#include "engine/case/case_file.hpp"
#include "engine/case/case_run.hpp"
#include "engine/output/vtu_writer.hpp"
#include "tools/validate/validation_case.hpp"

#include <map>
#include <string>
#include <vector>

namespace tsph::validate {

/// One run of a case file: the frames at its output times (the case's own fields), the
/// energies of every step, and how it ended.
struct CaseRun {
  CaseFile file;  ///< the case as loaded, overrides applied
  RunReport report;
  bool diverged = false;
  std::string diagnosis;  ///< the stability monitor's message when diverged
  double diverged_time = 0.0;
  std::vector<double> frame_times;
  std::vector<output::VtuFrame> frames;
  std::vector<RunOptions::StepRecord> steps;
  double wall_seconds = 0.0;
  /// The columns of the run's energy.csv by name (the energy ledger; empty without it).
  std::map<std::string, std::vector<double>> energy;
};

/// The largest |balance_error| of the run's energy ledger over its rows, divided by
/// `scale` (J); NaN without a ledger.
double largest_balance_error(const CaseRun& run, double scale);

/// Loads `options.cases_dir / file` with the overrides and runs it into
/// `options.out_dir / run_name` (replaced), quiet, with options.threads (0: the case's).
/// A RunDiverged is caught and recorded. Throws CaseError for bad input.
CaseRun run_case_file(const Options& options, const std::string& file, const std::vector<std::string>& overrides,
                      const std::string& run_name, bool record_steps = false);

/// Sets the OpenMP threads of the next run: options.threads (`tsph validate --threads`),
/// or the case file's `threads` where that is 0. Every case calls it before run_case.
void use_threads(const Options& options, const CaseFile& file);

/// The array `name` of a frame; throws std::runtime_error if the case did not write it.
const std::vector<double>& array_of(const output::VtuFrame& frame, const std::string& name);
/// The "id" array (uint32).
const std::vector<std::uint32_t>& ids_of(const output::VtuFrame& frame);

/// |value - reference| / |reference| <= tolerance.
Check relative_check(std::string figure, double value, double reference, double tolerance);
/// value <= bound (error = value).
Check bound_check(std::string figure, double value, double bound);
/// The run reached its end: FAIL with the diagnosis as a note when it diverged.
Check no_divergence_check(const CaseRun& run, Result& result);

/// "[a, b, c]" for a --set override of a TOML array.
std::string toml_array(const std::vector<double>& values);
/// `count` output times evenly spaced over (0, end].
std::string output_times(double end, int count);

}  // namespace tsph::validate
