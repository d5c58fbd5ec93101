// Running a shipped case (tools/cases/) with overrides through the one case pipeline,
// as `tsph run` does, and reading back what the tests check: the frames at the output
// times, the error figures and the energies after every step.
#pragma once

#include "engine/case/case_build.hpp"
#include "engine/case/case_file.hpp"
#include "engine/case/case_run.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace tsph::testing_cases {

/// A frame of the real particles: positions (x of each point), and the listed fields.
struct Frame {
  double time = 0.0;
  std::vector<double> x, y;  ///< current positions along x and y
  std::vector<double> velocity_x, velocity_y, stress_xx, displacement_y;
};

struct CaseRun {
  CaseFile file;
  RunReport report;
  std::vector<Frame> frames;  ///< every frame written, t = 0 first
  std::vector<RunOptions::StepRecord> steps;  ///< if energies were asked for
  /// The frame at time t (fails the test if there is none).
  const Frame& at(double t) const {
    for (const auto& f : frames)
      if (f.time == t) return f;
    ADD_FAILURE() << "no frame at t = " << t;
    return frames.front();
  }
  /// The error figure `name` at time t (NaN if there is none).
  double error(const std::string& name, double t) const {
    for (const auto& e : report.errors)
      if (e.name == name && e.time == t) return e.value;
    return std::nan("");
  }
  /// The figure `name` at the end of the run.
  double final_error(const std::string& name) const { return error(name, report.time); }
};

inline std::string shipped_case(const std::string& name) {
  return std::string(TSPH_SOURCE_DIR) + "/tools/cases/" + name;
}

/// A shipped case built with `overrides` and its solver stepped `steps` times with the
/// case's time step; the solver is kept with the case and the model it was built from.
template <int Dim>
struct SteppedCase {
  CaseFile file;
  BuiltCase<Dim> model;
  TaylorSph<Dim> solver;
  SteppedCase(const std::string& name, const std::vector<std::string>& overrides, int steps)
      : file(load_case(shipped_case(name), overrides)), model(build_case<Dim>(file)), solver(make_solver(file, model)) {
    for (int k = 0; k < steps; ++k) solver.step(model.dt);
  }
};

/// A fresh output directory under the test's temporary directory.
inline std::string fresh_output_directory() {
  static std::atomic<int> counter{0};
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  const std::filesystem::path dir = std::filesystem::path(::testing::TempDir()) /
                                    ("tsph_" + std::string(info ? info->name() : "run") + "_" +
                                     std::to_string(counter++));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir.string();
}

/// Runs a case file with overrides (--set), keeping every frame's fields.
inline CaseRun run_case_file(const std::string& path, const std::vector<std::string>& overrides,
                             bool record_energy = false) {
  CaseRun run;
  run.file = load_case(path, overrides);
  RunOptions options;
  options.out_dir = fresh_output_directory();
  options.quiet = true;
  options.overrides = overrides;
  options.on_frame = [&run](const output::VtuFrame& f, double t) {
    Frame frame;
    frame.time = t;
    for (std::size_t i = 0; i < f.point_count; ++i) {
      frame.x.push_back(f.points[3 * i]);
      frame.y.push_back(f.points[3 * i + 1]);
    }
    for (const auto& a : f.arrays) {
      for (std::size_t i = 0; i < f.point_count; ++i) {
        if (a.name == "velocity") {
          frame.velocity_x.push_back(a.float64[3 * i]);
          frame.velocity_y.push_back(a.float64[3 * i + 1]);
        } else if (a.name == "stress") {
          frame.stress_xx.push_back(a.float64[6 * i]);
        } else if (a.name == "displacement") {
          frame.displacement_y.push_back(a.float64[3 * i + 1]);
        }
      }
    }
    run.frames.push_back(std::move(frame));
  };
  if (record_energy) options.on_step = [&run](const RunOptions::StepRecord& s) { run.steps.push_back(s); };
  run.report = run_case(run.file, options);
  std::filesystem::remove_all(options.out_dir);
  return run;
}

/// A fresh directory `tsph_<prefix>_<name>` under the test's temporary directory (the
/// same path for the same names: a test reads back what it wrote there).
inline std::filesystem::path fresh_named_directory(const std::string& prefix, const std::string& name) {
  const std::filesystem::path dir = std::filesystem::path(::testing::TempDir()) / ("tsph_" + prefix + "_" + name);
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

/// The last frame written: its points (x, y, z of each), its float64 arrays by name.
struct LastFrame {
  std::vector<double> points;
  std::map<std::string, std::vector<double>> arrays;
  std::size_t count = 0;
};

/// Runs a case text (the file name `name`.toml in messages) with overrides into `out_dir`,
/// quietly, and returns its last frame (and its report if asked).
inline LastFrame run_case_text(const std::string& text, const std::string& name, const std::string& out_dir,
                               const std::vector<std::string>& overrides = {}, RunReport* report = nullptr) {
  const CaseFile c = load_case_text(text, name + ".toml", overrides);
  RunOptions options;
  options.out_dir = out_dir;
  options.quiet = true;
  LastFrame last;
  options.on_frame = [&](const output::VtuFrame& f, double) {
    last.points = f.points;
    last.count = f.point_count;
    last.arrays.clear();
    for (const auto& a : f.arrays) last.arrays[a.name] = a.float64;
  };
  const RunReport r = run_case(c, options);
  if (report) *report = r;
  return last;
}

/// Runs a case text with checkpoints every `every` steps into `checkpoint_dir`, then
/// continues it from its first checkpoint into `out_dir`: the continued run's last frame
/// (a restart test compares it with the uninterrupted run's).
inline LastFrame resume_from_first_checkpoint(const std::string& text, const std::vector<std::string>& overrides,
                                              int every, const std::filesystem::path& checkpoint_dir,
                                              const std::string& out_dir) {
  std::vector<std::string> with_checkpoints = overrides;
  with_checkpoints.push_back("output.checkpoint_every=" + std::to_string(every));
  RunOptions options;
  options.out_dir = checkpoint_dir.string();
  options.quiet = true;
  run_case(load_case_text(text, "restart.toml", with_checkpoints), options);
  std::vector<std::string> checkpoints;
  for (const auto& entry : std::filesystem::directory_iterator(checkpoint_dir))
    if (entry.path().filename().string().rfind("checkpoint_", 0) == 0) checkpoints.push_back(entry.path().string());
  std::sort(checkpoints.begin(), checkpoints.end());
  if (checkpoints.empty()) {
    ADD_FAILURE() << "the run wrote no checkpoint in " << checkpoint_dir;
    return {};
  }
  options.out_dir = out_dir;
  options.restart = checkpoints.front();
  LastFrame resumed;
  options.on_frame = [&](const output::VtuFrame& f, double) {
    resumed.points = f.points;
    resumed.count = f.point_count;
    for (const auto& a : f.arrays) resumed.arrays[a.name] = a.float64;
  };
  run_case(load_case_text(text, "restart.toml", overrides), options);
  return resumed;
}

}  // namespace tsph::testing_cases
