// What the validation cases share (tools/validate/*.cpp): running a case file of
// tools/cases through the one case pipeline with the frames kept in memory, reading a
// frame's arrays, and making the table's checks.
#pragma once

#include "engine/case/case_file.hpp"
#include "engine/case/case_run.hpp"
#include "engine/output/vtu_writer.hpp"
#include "tools/validate/validation_case.hpp"

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
};

/// Loads `options.cases_dir / file` with the overrides and runs it into
/// `options.out_dir / run_name` (replaced), quiet, with options.threads (0: the case's).
/// A RunDiverged is caught and recorded. Throws CaseError for bad input.
CaseRun run_case_file(const Options& options, const std::string& file, const std::vector<std::string>& overrides,
                      const std::string& run_name, bool record_steps = false);

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

/// The elastic (complementary) energy per unit volume of a stress in VTK order
/// (xx yy zz xy yz xz), isotropic: ((1 + nu) s:s - nu (tr s)^2) / (2 E).
inline double elastic_energy_density(const double* s, double young, double nu) {
  const double trace = s[0] + s[1] + s[2];
  const double squares = s[0] * s[0] + s[1] * s[1] + s[2] * s[2] + 2.0 * (s[3] * s[3] + s[4] * s[4] + s[5] * s[5]);
  return ((1.0 + nu) * squares - nu * trace * trace) / (2.0 * young);
}

/// "[a, b, c]" for a --set override of a TOML array.
std::string toml_array(const std::vector<double>& values);
/// `count` output times evenly spaced over (0, end].
std::string output_times(double end, int count);

}  // namespace tsph::validate
