// tsph: runs a case file (TOML; key reference in docs/cases.md).
//
//   tsph run CASE [--set key=value]... [--out DIR] [--overwrite] [--threads N] [--quiet]
//            [--restart CHECKPOINT|DIR] [--ignore-limits]
//   tsph check CASE [--set key=value]... [--ignore-limits]
//   tsph table1 [BAR_CASE] [--set key=value]... [--out DIR]     (tools/tsph_table1.cpp)
//   tsph spectrum CASE [--set key=value]... [--out DIR]         (tools/tsph_spectrum.cpp)
//   tsph converge CASE --sweep KEY=V1,V2,... [--out DIR]        (tools/tsph_converge.cpp)
//   tsph validate [NAME...] [--quick] [--out DIR] [--list]      (tools/tsph_validate.cpp)
//   tsph --version
//
// Exit status: 0 success, 2 bad input (case file, overrides, output directory, a run
// whose estimated memory or output size exceeds the machine's), 3 the run diverged or
// did not come to rest, 4 (validate) a check of the suite failed, 1 other failure: an
// output file that cannot be written (disk full, permission; the frames and checkpoint
// written before are kept) or a run stopped by SIGINT/SIGTERM/SIGHUP (which still
// writes its last frame and summary.json).
#include "engine/case/case_build.hpp"
#include "engine/case/case_file.hpp"
#include "engine/case/case_run.hpp"
#include "engine/case/failure_summary.hpp"  // issue 15
#include "engine/case/restart_check.hpp"  // issue 15
#include "engine/run_lock.hpp"            // issue 15
#include "engine/threads.hpp"             // issue 15
#include "engine/output_file.hpp"
#include "engine/parallel.hpp"
#include "tools/cli_common.hpp"
#include "tools/tsph_commands.hpp"

#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include <cerrno>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#ifndef TSPH_VERSION
#define TSPH_VERSION "unknown"
#endif

namespace {

namespace fs = std::filesystem;
using namespace tsph;

volatile std::sig_atomic_t stop_requested = 0;

extern "C" void on_signal(int signal) {
  stop_requested = 1;
  std::signal(signal, SIG_DFL);  // a second Ctrl-C ends the program at once
}

struct Options {
  std::string case_path;
  std::vector<std::string> overrides;
  std::string out;
  bool overwrite = false;
  std::string restart;
  int threads = -1;
  bool quiet = false;
  bool ignore_limits = false;
};

void print_errors(const CaseError& e) {
  for (const auto& m : e.messages()) fmt::print(stderr, "tsph: error: {}\n", m);
}

/// The files a run writes (and --overwrite replaces).
bool is_tsph_output(const fs::path& p) {
  const std::string name = p.filename().string();
  auto starts = [&](const char* s) { return name.rfind(s, 0) == 0; };
  const std::string ext = p.extension().string();
  return ((starts("particles_") || starts("virtual_")) && (ext == ".vtu" || ext == ".tmp")) ||
         name == "particles.pvd" || name == "virtual.pvd" || (starts("probe_") && ext == ".csv") ||
         name == "summary.json" || name == "case.toml" ||
         (starts("checkpoint_") && (ext == ".bin" || ext == ".tmp"));
}

/// Creates the output directory; refuses one that holds files unless --overwrite, and
/// then removes only tsph's own files. Returns false after printing one message.
bool prepare_output(const Options& o) {
  std::error_code ec;
  if (fs::exists(o.out, ec) && fs::is_directory(o.out, ec) && !output_directory_empty(o.out)) {
    if (!o.overwrite) {
      fmt::print(stderr,
                 "tsph: error: out = '{}' is not empty: choose another directory with --out, or "
                 "pass --overwrite to replace the files of a previous run there (other files "
                 "are kept)\n",
                 o.out);
      return false;
    }
    for (const auto& entry : fs::directory_iterator(o.out, ec))
      if (entry.is_regular_file() && is_tsph_output(entry.path())) fs::remove(entry.path(), ec);
  }
  if (!cli::prepare_output_directory("tsph", o.out)) return false;
  const fs::path probe = fs::path(o.out) / ".tsph-write-test";
  if (std::FILE* f = std::fopen(probe.c_str(), "wb")) {
    std::fclose(f);
    fs::remove(probe, ec);
    return true;
  }
  fmt::print(stderr, "tsph: error: out = '{}' cannot be written ({}); choose a writable directory\n",
             o.out, std::strerror(errno));
  return false;
}

void print_overview(const CaseFile& c, const CaseOverview& v) {
  fmt::print("case {} ({}), {}D\n", c.path, c.title, c.dimension);
  fmt::print("  particles: {} real, {} virtual; dx = {} m, h = {} m ({}, alpha = {}); {} {:.6g} m^{}\n",
             v.real_particles, v.virtual_particles, v.spacing, v.smoothing_length,
             to_string(c.kernel), c.alpha, c.dimension == 1 ? "length" : c.dimension == 2 ? "area" : "volume",
             v.real_volume, c.dimension);
  fmt::print("  material: E = {} Pa, nu = {}, rho = {} kg/m^3{}; p-wave speed {:.6g} m/s\n",
             c.young_modulus, c.poisson_ratio, c.density,
             c.dimension == 2 ? (c.plane_mode == PlaneMode::plane_strain ? ", plane strain" : ", plane stress") : "",
             v.wave_speed);
  // The method: the automatic options as the run resolves them (docs/cases.md, Automatic defaults).
  const ResolvedMethodOptions m = resolved_method_options(c);
  const auto automatic = [](bool is) { return is ? " (automatic)" : ""; };
  fmt::print("  method: {}{}, surface filter {}{}, hourglass stiffness {}{}, walls {}{}, surface extrapolation {}{}{}\n",
             to_string(c.kinematics),
             m.reference_lists ? std::string(" (kernel in the reference configuration)")
             : c.kinematics == Kinematics::updated_lagrangian
                 ? fmt::format(" (kernel in the current configuration, neighbour skin {})", m.neighbor_skin)
                 : std::string(),
             m.hourglass, automatic(c.hourglass == kAutomaticOption), m.hourglass_stiffness,
             automatic(c.hourglass_stiffness == kAutomaticOption),
             m.wall_gradient ? "wall_gradient" : "characteristics",
             automatic(c.velocity_wall == CaseFile::VelocityWall::automatic), m.surface_extrapolation ? "on" : "off",
             automatic(c.surface_extrapolation == Toggle::automatic),
             m.volumetric_average ? fmt::format(", volumetric average{}", automatic(c.volumetric_average == Toggle::automatic))
                                  : std::string());
  fmt::print("  time: dt = {:.6g} s (CFL {:.3g}{}), end {} s: {}{} steps, {} output frames\n", v.dt,
             v.dt * v.wave_speed / v.spacing, c.adaptive_time_step ? ", adaptive: smaller as the body flattens" : "",
             c.end_time, c.adaptive_time_step ? "at least " : "", v.steps, v.frames);
  for (const auto& [name, count] : v.boundary_particles)
    fmt::print("  boundary '{}': {} real particles\n", name, count);
  if (!c.exact.empty()) fmt::print("  exact solution: {}\n", c.exact);
  fmt::print("  memory: about {:.1f} MiB (particle fields and neighbour lists)\n",
             v.memory_bytes / (1024.0 * 1024.0));
  fmt::print("  work: {:.3g} particle-steps\n",
             static_cast<double>(v.real_particles) * static_cast<double>(v.steps));
}

int run(const Options& o, bool check_only) {
  CaseFile c;
  try {
    c = load_case(o.case_path, o.overrides);
  } catch (const CaseError& e) {
    print_errors(e);
    return cli::kExitBadInput;
  }
  if (const auto error = thread_count_error("--threads", o.threads); o.threads >= 0 && error) {  // issue 15
    fmt::print(stderr, "tsph: error: {}\n", *error);
    return cli::kExitBadInput;
  }
  if (o.threads >= 0) c.threads = o.threads;
  set_thread_count(c.threads);
  // Resources first: a case too large for this machine is refused before anything is
  // built (the output directory is the one the run would use).
  const std::string planned_out =
      !o.out.empty() ? o.out
      : !o.restart.empty() ? o.restart
                           : (fs::path("out") / fs::path(c.path).stem()).string();
  ResourceEstimate estimate;
  try {
    estimate = estimate_resources(c);
    if (!o.ignore_limits) check_resources(c, estimate, machine_limits(planned_out), planned_out);
  } catch (const CaseError& e) {
    print_errors(e);
    return cli::kExitBadInput;
  }
  if (check_only) {
    try {
      print_overview(c, inspect_case(c));
      const ResourceLimits limits = machine_limits(planned_out);
      fmt::print("  estimate: peak memory {:.1f} MiB of {:.0f} MiB available; output {:.1f} MiB "
                 "({} frames of {:.2f} MiB) of {} free under {}\n",
                 estimate.memory_bytes / 1048576.0, limits.memory_bytes / 1048576.0,
                 estimate.output_bytes / 1048576.0, estimate.frames, estimate.frame_bytes / 1048576.0,
                 limits.disk_bytes ? fmt::format("{:.0f} MiB", *limits.disk_bytes / 1048576.0) : "?",
                 planned_out);
    } catch (const CaseError& e) {
      print_errors(e);
      return cli::kExitBadInput;
    } catch (const std::exception& e) {  // std::bad_alloc past --ignore-limits
      fmt::print(stderr, "tsph: failed: {}\n", e.what());
      return cli::kExitFailure;
    }
    fmt::print("case is valid\n");
    return cli::kExitOk;
  }
  Options resolved = o;
  std::string checkpoint;
  if (!o.restart.empty()) {
    try {
      checkpoint = select_restart_checkpoint(c, o.restart, stderr);  // issue 15: intact, same physics
    } catch (const CaseError& e) {
      print_errors(e);
      return cli::kExitBadInput;
    }
    std::error_code ec;
    if (!fs::is_regular_file(checkpoint, ec)) {
      fmt::print(stderr, "tsph: error: restart = '{}' is invalid: no such checkpoint file or directory\n", o.restart);
      return cli::kExitBadInput;
    }
  }
  const std::string checkpoint_dir =
      checkpoint.empty() ? "" : fs::absolute(fs::path(checkpoint)).parent_path().lexically_normal().string();
  if (resolved.out.empty())
    resolved.out = checkpoint.empty() ? (fs::path("out") / fs::path(c.path).stem()).string() : checkpoint_dir;
  const bool continuing = !checkpoint.empty() &&
                          fs::absolute(fs::path(resolved.out)).lexically_normal().string() == checkpoint_dir;
  RunLock lock;  // issue 15: one run per output directory, taken before the emptiness check
  if (const auto busy = lock.acquire(resolved.out)) {
    fmt::print(stderr, "tsph: error: {}\n", *busy);
    return cli::kExitBadInput;
  }
  if (continuing) {
    if (!o.quiet) fmt::print("continuing the run in {} from {}\n", resolved.out, checkpoint);
  } else if (!prepare_output(resolved)) {
    return cli::kExitBadInput;
  }
  std::error_code ec;
  fs::copy_file(c.path, fs::path(resolved.out) / "case.toml", fs::copy_options::overwrite_existing, ec);

  RunOptions options;
  options.out_dir = resolved.out;
  options.quiet = o.quiet;
  options.version = TSPH_VERSION;
  options.overrides = o.overrides;
  options.restart = checkpoint;
  options.stop_requested = &stop_requested;
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  std::signal(SIGHUP, on_signal);  // issue 15: a closed terminal stops the run as SIGTERM does
  try {
    if (!o.quiet) {
      const CaseOverview v = inspect_case(c);
      fmt::print("tsph {}: {} ({}D), {} real + {} virtual particles, {} steps of {:.4g} s, {} threads\n",
                 TSPH_VERSION, c.path, c.dimension, v.real_particles, v.virtual_particles, v.steps,
                 v.dt, thread_count());
      std::fflush(stdout);
    }
    const RunReport r = run_case(c, options);
    if (!o.quiet) {
      fmt::print("{} at t = {:.6g} s after {} steps: {:.2f} s wall, {:.3e} particle-steps/s; output "
                 "{:.2f} s in the background ({:.2f} s waited)\n",
                 r.status == RunReport::Status::interrupted ? "interrupted"
                 : r.status == RunReport::Status::at_rest   ? "at rest"
                 : r.status == RunReport::Status::not_at_rest ? "NOT at rest"
                                                             : "finished",
                 r.time, r.steps, r.wall_seconds, r.particle_steps_per_second, r.output_busy_seconds,
                 r.output_wait_seconds);
      for (const auto& e : r.errors)
        if (e.time == r.errors.back().time) fmt::print("  {} = {:.6g}\n", e.name, e.value);
      if (!r.last_checkpoint.empty()) fmt::print("checkpoint {}\n", r.last_checkpoint);
      fmt::print("output in {} (open particles.pvd in ParaView)\n", resolved.out);
    }
    switch (r.status) {
      case RunReport::Status::finished:
      case RunReport::Status::at_rest: return cli::kExitOk;
      case RunReport::Status::not_at_rest:
        fmt::print(stderr, "tsph: the run did not come to rest (see summary.json)\n");
        return cli::kExitNotConverged;
      case RunReport::Status::interrupted:
        fmt::print(stderr,
                   "tsph: interrupted; the last frame, summary.json and {} are in {} (continue with "
                   "--restart {})\n",
                   fs::path(r.last_checkpoint).filename().string(), resolved.out, resolved.out);
        return cli::kExitFailure;
    }
  } catch (const CaseError& e) {
    print_errors(e);
    if (!continuing)  // issue 15: a refused run leaves no file that blocks the rerun
      for (const auto& entry : fs::directory_iterator(resolved.out, ec))
        if (entry.is_regular_file() && is_tsph_output(entry.path())) fs::remove(entry.path(), ec);
    return cli::kExitBadInput;
  } catch (const RunDiverged& e) {
    fmt::print(stderr, "tsph: diverged: {}\n", e.what());
    return cli::kExitNotConverged;
  } catch (const OutputError& e) {
    // Every file is written whole or not at all: what is on disk is the last good state.
    std::string kept = "the frames listed in particles.pvd";
    try {
      kept += " and " + fs::path(resolve_checkpoint(resolved.out)).filename().string();
    } catch (const CaseError&) {
    }
    fmt::print(stderr, "tsph: stopped: {}; {} in {} are intact\n", e.what(), kept, resolved.out);
    return cli::kExitFailure;
  } catch (const std::bad_alloc& e) {  // issue 15: past the memory check (--ignore-limits, a limit it missed)
    fmt::print(stderr, "tsph: failed: out of memory ({}); {}\n", e.what(),
               write_out_of_memory_summary(resolved.out, c.path, TSPH_VERSION, o.overrides));
    return cli::kExitFailure;
  } catch (const std::exception& e) {
    fmt::print(stderr, "tsph: failed: {}\n", e.what());
    return cli::kExitFailure;
  }
  return cli::kExitFailure;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"tsph: Taylor-SPH solid dynamics from a case file (keys: docs/cases.md)"};
  app.set_version_flag("--version", std::string("tsph ") + TSPH_VERSION);
  app.require_subcommand(1);
  Options o;
  auto add_case_options = [&o](CLI::App* sub) {
    sub->add_option("CASE", o.case_path, "case file (TOML)")->required();
    sub->add_option("--set", o.overrides,
                    "override a key of the case file, e.g. --set material.E=2e8 (repeatable)")
        ->type_name("KEY=VALUE")
        ->take_all()
        ->allow_extra_args(false);
    sub->add_option("--threads", o.threads, "OpenMP threads (0: OpenMP default; overrides the case's threads)")
        ->check(CLI::NonNegativeNumber);
  };
  CLI::App* run_cmd = app.add_subcommand("run", "run a case and write VTU/PVD, probes and summary.json");
  add_case_options(run_cmd);
  run_cmd->add_option("--out", o.out, "output directory (default: out/<case name>)");
  run_cmd->add_flag("--overwrite", o.overwrite,
                    "reuse a non-empty output directory, replacing the files of a previous run");
  run_cmd->add_flag("--quiet", o.quiet, "print nothing but errors");
  run_cmd->add_flag("--ignore-limits", o.ignore_limits,
                    "run even if the estimated memory or output size exceeds what the machine "
                    "offers (MemAvailable or the cgroup limit; free disk under --out)");
  run_cmd->add_option("--restart", o.restart,
                      "continue from a checkpoint file, or the newest checkpoint_*.bin of a directory "
                      "(output goes on in that directory unless --out is given)");
  CLI::App* check_cmd = app.add_subcommand("check", "validate a case and print it resolved, without running it");
  add_case_options(check_cmd);
  check_cmd->add_flag("--ignore-limits", o.ignore_limits,
                      "build the case even if it exceeds the machine's memory or disk");
  const cli::Subcommand studies[] = {cli::add_table1(app), cli::add_spectrum(app), cli::add_converge(app),
                                     cli::add_validate(app, argc, argv)};
  if (const auto stop = cli::parse(app, argc, argv)) return *stop;
  for (const auto& study : studies)
    if (study.app->parsed()) return study.run();
  return run(o, check_cmd->parsed());
}
