// Running a case file: builds the particles, conditions and solver from a CaseFile,
// steps to the end time (landing on every output time), writes the VTU/PVD series,
// probe CSVs and summary.json into the output directory, and compares with the exact
// solution the case names.
#pragma once

#include "engine/case/case_file.hpp"
#include "engine/output/vtu_writer.hpp"
#include "engine/validation/exact_solution.hpp"

#include <cmath>
#include <csignal>
#include <functional>
#include <cstdint>
#include <cstdio>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace tsph {

/// The run stopped because the solution became non-finite (exit status 3).
class RunDiverged : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// What `tsph check` prints: the resolved case, without running it.
struct CaseOverview {
  std::size_t real_particles = 0, virtual_particles = 0;
  double spacing = 0.0, smoothing_length = 0.0, wave_speed = 0.0, dt = 0.0;
  double real_volume = 0.0;  ///< sum of the real particles' volumes (length, area, volume)
  std::int64_t steps = 0;  ///< to the end time, with the output times landed on
  std::int64_t frames = 0;
  double memory_bytes = 0.0;  ///< estimate: particle fields and neighbour lists
  std::vector<std::pair<std::string, std::size_t>> boundary_particles;  ///< per condition
};

struct RunOptions {
  std::string out_dir;
  bool quiet = false;
  std::FILE* progress = stdout;
  std::string version;
  std::vector<std::string> overrides;
  /// A checkpoint file to continue from (empty: start at t = 0).
  std::string restart;
  /// Set by a signal handler: the run stops after the current step, writing its output.
  const volatile std::sig_atomic_t* stop_requested = nullptr;
  /// Called with every frame of the real particles as it is written (the fields the case
  /// lists, exact_* included), and its time: what `tsph table1` and the tests read.
  std::function<void(const output::VtuFrame& frame, double time)> on_frame;
  /// Called after every step with its energies (computed only when this is set).
  struct StepRecord {
    double time = 0.0;
    std::int64_t step = 0;
    double kinetic_energy = 0.0, strain_energy = 0.0;
    /// The same on the node-and-cell quadrature (TaylorSph::node_and_cell_energies), when
    /// node_and_cell_energies is set; NaN otherwise.
    double kinetic_node_and_cell = std::nan(""), strain_node_and_cell = std::nan("");
  };
  std::function<void(const StepRecord&)> on_step;
  /// on_step also gets the energies on the node-and-cell quadrature (an interpolation
  /// pass over the virtual particles each step), and is called once more before the
  /// first step of a run from t = 0, with step 0.
  bool node_and_cell_energies = false;
};

struct RunReport {
  enum class Status { finished, at_rest, not_at_rest, interrupted };
  Status status = Status::finished;
  double time = 0.0;
  std::int64_t steps = 0;
  std::int64_t neighbor_builds = 0;  ///< list searches of this run (solver.neighbor_skin: fewer than steps)
  double dt = 0.0;
  double wall_seconds = 0.0, particle_steps_per_second = 0.0;
  double output_busy_seconds = 0.0, output_wait_seconds = 0.0;
  std::size_t real_particles = 0, virtual_particles = 0, frames = 0;
  std::string last_checkpoint;  ///< empty if none was written
  std::vector<ErrorRecord> errors;
};

struct MemoryModel;  // engine/memory_estimate.hpp

/// What a run will need, estimated from the case alone (before any particle is built),
/// so that a run that cannot fit is refused up front (issue 6, resource limits).
struct ResourceEstimate {
  double real_particles = 0.0;     ///< from the geometry (a union of boxes: their sum)
  double virtual_particles = 0.0;
  double steps = 0.0, frames = 0.0;
  double memory_bytes = 0.0;       ///< peak: solver (memory_estimate.hpp) + output buffers
  double frame_bytes = 0.0;        ///< one VTU frame (real, and virtual if written)
  double checkpoint_bytes = 0.0;   ///< one checkpoint file
  double output_bytes = 0.0;       ///< everything the run writes, at its largest
};

/// What this machine offers; 0 (memory) or nothing (disk) when unknown.
struct ResourceLimits {
  double memory_bytes = 0.0;
  std::string memory_source;  ///< where the memory limit comes from
  std::optional<double> disk_bytes;
};

ResourceEstimate estimate_resources(const CaseFile& c);

/// What the solver of the case holds beyond the bare scheme's fields and lists
/// (memory_estimate.hpp), with the method options as the run resolves them: the lists'
/// kind and skin, the energy ledger, the hourglass stiffness, a plastic material's fields
/// and the volumetric average. estimate_resources and the overview of `tsph check` read it.
MemoryModel memory_model(const CaseFile& c);

/// MemAvailable or the control group's limit; free space under `out_dir` (statvfs).
ResourceLimits machine_limits(const std::string& out_dir);

/// Throws CaseError naming the estimate, the limit and the way out when the run needs
/// more memory or disk than `limits` offer (`--ignore-limits` skips this check).
void check_resources(const CaseFile& c, const ResourceEstimate& e, const ResourceLimits& limits,
                     const std::string& out_dir);

/// Builds the case without stepping it. Throws CaseError (bad geometry, a region that
/// selects nothing, a malformed particle file).
CaseOverview inspect_case(const CaseFile& c);

/// The newest checkpoint_*.bin in a directory, or the path itself if it is a file.
std::string resolve_checkpoint(const std::string& path);

/// Runs the case. The output directory must exist. Throws CaseError for bad input
/// found while building, RunDiverged, or std::runtime_error for I/O failures.
RunReport run_case(const CaseFile& c, const RunOptions& options);

}  // namespace tsph
