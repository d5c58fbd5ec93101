// The resource estimate of a case (memory, disk, steps) and the machine's limits that
// `tsph check` and `tsph run` compare it with (docs/reliability.md, Resource limits).
#include "engine/case/case_run.hpp"

#include "engine/case/case_build.hpp"
#include "engine/memory_estimate.hpp"
#include "engine/output_file.hpp"
#include "engine/output/checkpoint.hpp"
#include "engine/output/vtu_writer.hpp"

#include <fmt/core.h>
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace tsph {

namespace {

/// Lattice nodes of a box along one axis, in double (a huge count must not overflow).
double nodes_along(double lower, double upper, double dx) {
  return std::floor((upper - lower) / dx + 0.5) + 1.0;
}

template <int Dim>
ResourceEstimate estimate(const CaseFile& c) {
  ResourceEstimate e;
  const double dx = c.spacing;
  auto add_box = [&](const std::vector<double>& lower, const std::vector<double>& upper) {
    double real = 1.0, cells = 1.0;
    for (std::size_t d = 0; d < static_cast<std::size_t>(Dim); ++d) {
      const double n = std::max(1.0, nodes_along(lower[d], upper[d], dx));
      real *= n;
      cells *= std::max(1.0, n - 1.0);
    }
    e.real_particles += real;
    e.virtual_particles += cells;
  };
  if (!c.box_lower.empty()) {
    add_box(c.box_lower, c.box_upper);
  } else if (!c.boxes.empty()) {
    for (const auto& [lower, upper] : c.boxes) add_box(lower, upper);
  } else {  // a particle file: one particle per data line (the header and comments aside)
    std::ifstream in(c.particle_file);
    std::string line;
    double lines = 0.0;
    while (std::getline(in, line))
      if (!line.empty() && line[0] != '#') lines += 1.0;
    e.real_particles = std::max(0.0, lines - 1.0);
    e.virtual_particles = e.real_particles;
  }
  const double dt = case_time_step(c);
  // Steps to the end time, landing on every output time (count_steps, in double).
  double t = 0.0;
  std::vector<double> targets = c.output_times;
  targets.push_back(c.end_time);
  for (double target : targets) {
    if (target <= t) continue;
    e.steps += std::ceil((target - t) / dt * (1.0 - 1e-9));
    t = target;
  }
  e.frames = 2.0 + static_cast<double>(c.output_times.size()) +
             (c.output_every > 0 ? std::floor(e.steps / static_cast<double>(c.output_every)) : 0.0);

  // One VTU frame (vtu_writer.cpp): points (3 doubles), connectivity and offsets
  // (int64), types (uint8), and per point the fields listed in output.fields; each
  // block has an 8-byte count; about 2 KiB of XML.
  const MemoryModel model = memory_model(c);
  const bool plastic = model.plastic_fields;  // its real set holds plastic_field_bytes more
  auto frame_bytes = [&](double n, bool real) {
    double per_point = 24.0 + 8.0 + 8.0 + 1.0;
    double blocks = 4.0;
    auto field = [&](const char* name, double bytes, double count = 1.0) {
      if (c.has_field(name)) {
        per_point += bytes;
        blocks += count;
      }
    };
    field("velocity", 24.0);
    field("displacement", 48.0, 2.0);  // and initial_position
    field("stress", 48.0);
    field("von_mises", 8.0);
    field("density", 8.0);
    field("id", 4.0);
    if (real && plastic) field("plastic", 32.0, 4.0);
    if (real && c.has_field("exact")) {
      const double exact = c.exact == "bar" ? 2.0 : c.exact == "cantilever" ? 1.0 : 0.0;
      per_point += 8.0 * exact;
      blocks += exact;
    }
    return 2048.0 + 8.0 * blocks + n * per_point;
  };
  e.frame_bytes = frame_bytes(e.real_particles, true) +
                  (c.output_virtual ? frame_bytes(e.virtual_particles, false) : 0.0);
  // A checkpoint (checkpoint.hpp): every field of both sets, 8 bytes per double field
  // and 12 per particle for the three 4-byte tags (the virtual set without the fields the
  // solver releases unless its frames are written: SolverSettings::keep_virtual_fields),
  // plus the .pvd lists and error records.
  const double set_bytes = 8.0 * (4 * Dim + stress_component_count<Dim> + 3) + 12.0;
  const double real_set_bytes = set_bytes + (plastic ? plastic_field_bytes<Dim>() : 0.0);
  const double virtual_set_bytes = c.output_virtual ? set_bytes : 8.0 * (2 * Dim + stress_component_count<Dim> + 3);
  const double bookkeeping = 256.0 * e.frames;  // per frame: .pvd entries, error records
  e.checkpoint_bytes =
      real_set_bytes * e.real_particles + virtual_set_bytes * e.virtual_particles + bookkeeping + 4096.0;
  // Probes: a row of 1 + 3 Dim + 7 numbers of 18 characters per probe_every steps
  // (and per frame); the .pvd lists: about 80 bytes per frame, twice (the file and its
  // temporary copy). Checkpoints: two kept and one being written.
  const double probe_rows = std::floor(e.steps / static_cast<double>(c.probe_every)) + e.frames;
  const double probes = static_cast<double>(c.probes.size()) * probe_rows * 18.0 * (1 + 3 * Dim + 7);
  const double pvd = (c.output_virtual ? 2.0 : 1.0) * 2.0 * 80.0 * e.frames;
  const double checkpoints = c.checkpoint_every > 0 ? 3.0 : 1.0;  // else one on an interruption
  e.output_bytes = e.frames * e.frame_bytes + probes + pvd + checkpoints * e.checkpoint_bytes + 65536.0;
  // Memory: the solver's peak per real particle (memory_estimate.hpp, which counts the
  // virtual set as about as large), the snapshot the background writer holds, and a
  // checkpoint in the making (a copy of both sets, its byte buffer and the string
  // handed to the writer); the frame bookkeeping is held once more by the run.
  e.memory_bytes = estimate_bytes_per_real_particle<Dim>(c.alpha, model) *
                       std::max(e.real_particles, e.virtual_particles) +
                   e.frame_bytes + 3.0 * (e.checkpoint_bytes - bookkeeping) + 4.0 * bookkeeping;
  if (model.reference_lists)  // the kernel factor cache, where it fits its budget
    e.memory_bytes += std::min(c.kernel_cache_mb * 1048576.0, kernel_factor_bytes_per_particle<Dim>(c.alpha) *
                                                                  std::max(e.real_particles, e.virtual_particles));
  return e;
}

std::string gib(double bytes) {
  return bytes >= 1073741824.0 ? fmt::format("{:.3g} GiB", bytes / 1073741824.0)
                               : fmt::format("{:.3g} MiB", bytes / 1048576.0);
}

}  // namespace

MemoryModel memory_model(const CaseFile& c) {
  const ResolvedMethodOptions m = resolved_method_options(c);
  MemoryModel model;
  model.transposed_lists = c.transpose_lists;
  model.skin = m.neighbor_skin;
  model.keep_virtual_fields = c.output_virtual;
  model.energy_ledger = c.energy_every > 0;
  model.hourglass_stiffness = m.hourglass_stiffness > 0.0;
  model.reference_lists = m.reference_lists;
  model.plastic_fields = c.plasticity.model != "elastic";
  model.volumetric_average = m.volumetric_average;
  return model;
}

ResourceEstimate estimate_resources(const CaseFile& c) {
  switch (c.dimension) {
    case 1: return estimate<1>(c);
    case 2: return estimate<2>(c);
    case 3: return estimate<3>(c);
  }
  throw CaseError({c.path + ": dimension must be 1, 2 or 3"});
}

ResourceLimits machine_limits(const std::string& out_dir) {
  ResourceLimits l;
  l.memory_bytes = static_cast<double>(memory_limit_bytes(&l.memory_source));
  if (const auto disk = available_disk_bytes(out_dir)) l.disk_bytes = static_cast<double>(*disk);
  return l;
}

void check_resources(const CaseFile& c, const ResourceEstimate& e, const ResourceLimits& limits,
                     const std::string& out_dir) {
  std::vector<std::string> errors;
  if (limits.memory_bytes > 0.0 && e.memory_bytes > limits.memory_bytes)
    errors.push_back(fmt::format(
        "{}: the run needs about {} of memory ({:.4g} real and {:.4g} virtual particles, "
        "geometry.spacing = {}) but {} are available ({}): use a larger spacing or a smaller "
        "body, or pass --ignore-limits to run it anyway",
        c.path, gib(e.memory_bytes), e.real_particles, e.virtual_particles, format_number(c.spacing),
        gib(limits.memory_bytes), limits.memory_source));
  if (limits.disk_bytes && e.output_bytes > *limits.disk_bytes)
    errors.push_back(fmt::format(
        "{}: the output needs about {} of disk ({:.4g} frames of {} each, {:.4g} steps, "
        "checkpoints of {}) but {} are free under out = '{}': write fewer frames "
        "(output.every, output.times, output.fields), choose another --out, or pass "
        "--ignore-limits to run it anyway",
        c.path, gib(e.output_bytes), e.frames, gib(e.frame_bytes), e.steps, gib(e.checkpoint_bytes),
        gib(*limits.disk_bytes), out_dir));
  if (!errors.empty()) throw CaseError(errors);
}

}  // namespace tsph
