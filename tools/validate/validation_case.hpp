// The validation suite's interface (issue 14): each case is a function that runs one or
// more case files (tools/cases/*.toml) through the one case pipeline (load_case +
// run_case, with the on_frame / on_step hooks), measures figures, and compares them with
// an exact or reference solution computed in code (engine/validation/). `tsph validate`
// (tools/tsph_validate.cpp) runs the registered cases, prints one table row per check
// (case, figure, value, reference, error, tolerance, verdict), writes each case's series
// as CSV and draws PNG plots of them against the references (tools/plot_validation.py).
#pragma once
#include <functional>
#include <string>
#include <vector>

namespace tsph::validate {

struct Options {
  std::string cases_dir;  ///< where the case files are (default: the source tree's tools/cases)
  std::string out_dir;    ///< this case's own output directory (exists; run outputs go below it)
  bool quick = false;     ///< the fast version (the default ctest suite): coarser and/or shorter
  bool quiet = true;      ///< no progress lines from the runs
  int threads = 0;        ///< 0: the runtime's default
  /// tsph validate --set: KEY=VALUE applied to every case file after the case's own
  /// overrides (so a key the case sets, e.g. method.alpha, takes the user's value).
  std::vector<std::string> overrides;
};

/// The case's own overrides followed by the user's (Options::overrides).
inline std::vector<std::string> with_user_overrides(const Options& options, std::vector<std::string> own) {
  own.insert(own.end(), options.overrides.begin(), options.overrides.end());
  return own;
}

/// One measured figure against its reference.
struct Check {
  std::string figure;     ///< what is measured, with where/when: "sigma_xy at gamma = 5"
  double value = 0.0;     ///< tsph's figure
  double reference = 0.0; ///< the exact or reference value
  double error = 0.0;     ///< as `error_kind` says
  double tolerance = 0.0;
  std::string error_kind = "rel";  ///< "rel" |value-ref|/|ref|, "abs" |value-ref|, "max" value <= tol
  bool pass = false;
};

/// A curve or a set of curves written as OUT/<case>/<name>.csv (header = columns) and
/// plotted by tools/plot_validation.py: column 0 is x; a column whose name starts with
/// "ref " is drawn as a line (the reference), every other as markers (tsph).
struct Series {
  std::string name;     ///< file stem
  std::string title, x_label, y_label;
  std::vector<std::string> columns;
  std::vector<std::vector<double>> rows;
};

struct Result {
  std::vector<Check> checks;
  std::vector<Series> series;
  std::vector<std::string> notes;  ///< printed under the table (e.g. "diverged at t = ...")
};

struct Case {
  std::string name;         ///< what `tsph validate NAME` selects, e.g. "shear_2d"
  std::string description;  ///< one line
  bool slow = false;        ///< the full version takes more than about a minute on 2 cores
  std::function<Result(const Options&)> run;
};

/// Each group of cases registers in its own file (tools/validate/<group>.cpp).
std::vector<Case> homogeneous_cases();   // uniaxial stretch/compression, simple shear (2D, 3D)
std::vector<Case> rotation_cases();      // free rigid rotation, alpha 0.6 and 1.2
std::vector<Case> cantilever_cases();    // large-deflection cantilever vs the elastica; 3D UL cantilever
std::vector<Case> plate_cases();         // oscillating plate (Gray, Monaghan & Swift 2001)
std::vector<Case> column_cases();        // twisting column (3D)
std::vector<Case> plasticity_cases();    // homogeneous elastoplastic paths (issue 16)
std::vector<Case> footing_cases();       // strip footing on Tresca soil (issue 16)
std::vector<Case> taylor_bar_cases();    // Taylor bar impact (issue 16)

}  // namespace tsph::validate
