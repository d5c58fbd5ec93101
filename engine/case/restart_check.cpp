#include "engine/case/restart_check.hpp"

#include "engine/case/case_build.hpp"
#include "engine/output/checkpoint.hpp"

#include <fmt/core.h>
#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>

namespace tsph {
namespace {

namespace fs = std::filesystem;

class Record {
 public:
  void add(const std::string& key, const std::string& value) { text_ += key + " = " + value + "\n"; }
  void add(const std::string& key, double value) { add(key, fmt::format("{}", value)); }
  void add(const std::string& key, bool value) { add(key, std::string(value ? "true" : "false")); }
  void add(const std::string& key, const std::vector<double>& values) {
    add(key, fmt::format("[{}]", fmt::join(values, ", ")));
  }
  void add_text(const std::string& key, const std::string& value) { add(key, "\"" + value + "\""); }
  const std::string& text() const { return text_; }

 private:
  std::string text_;
};

/// Size and crc32 of a particle file (its contents are physics; its path is not).
std::string file_fingerprint(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return "unreadable";
  std::vector<char> piece(std::size_t{1} << 20);  // in pieces: the file may be large
  std::uint64_t bytes = 0;
  uLong crc = ::crc32(0L, Z_NULL, 0);
  while (in.read(piece.data(), static_cast<std::streamsize>(piece.size())) || in.gcount() > 0) {
    crc = ::crc32(crc, reinterpret_cast<const Bytef*>(piece.data()), static_cast<uInt>(in.gcount()));
    bytes += static_cast<std::uint64_t>(in.gcount());
  }
  return fmt::format("{} bytes, crc32 {}", bytes, crc);
}

std::map<std::string, std::string> parse_record(const std::string& record) {
  std::map<std::string, std::string> keys;
  std::size_t start = 0;
  while (start < record.size()) {
    std::size_t end = record.find('\n', start);
    if (end == std::string::npos) end = record.size();
    const std::string line = record.substr(start, end - start);
    const auto eq = line.find(" = ");
    if (eq != std::string::npos) keys[line.substr(0, eq)] = line.substr(eq + 3);
    start = end + 1;
  }
  return keys;
}

/// checkpoint_*.bin of a directory, newest (largest step number) first.
std::vector<std::string> checkpoints_of(const std::string& dir) {
  std::vector<std::string> found;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("checkpoint_", 0) == 0 && entry.path().extension() == ".bin")
      found.push_back(entry.path().string());
  }
  std::sort(found.begin(), found.end(), std::greater<>());  // zero-padded step numbers
  return found;
}

}  // namespace

std::string physics_record(const CaseFile& c) {
  Record r;
  r.add("dimension", static_cast<double>(c.dimension));
  r.add("geometry.spacing", c.spacing);
  if (!c.box_lower.empty()) {
    r.add("geometry.box.lower", c.box_lower);
    r.add("geometry.box.upper", c.box_upper);
  }
  for (std::size_t k = 0; k < c.boxes.size(); ++k) {
    r.add(fmt::format("geometry.box[{}].lower", k), c.boxes[k].first);
    r.add(fmt::format("geometry.box[{}].upper", k), c.boxes[k].second);
  }
  if (!c.particle_file.empty()) r.add("geometry.particle_file", file_fingerprint(c.particle_file));
  r.add("material.E", c.young_modulus);
  r.add("material.nu", c.poisson_ratio);
  r.add("material.rho", c.density);
  r.add_text("material.plane", c.plane_mode == PlaneMode::plane_strain ? "strain" : "stress");
  const CaseFile::Plasticity& material = c.plasticity;
  if (material.model != "elastic") {  // issue 16: the model and its keys (elastic records stay as they were)
    r.add_text("material.model", material.model);
    if (material.model == "j2") {
      r.add("material.yield_stress", material.yield_stress);
      r.add("material.isotropic_hardening", material.isotropic_hardening);
      r.add("material.kinematic_hardening", material.kinematic_hardening);
    } else if (material.model == "johnson_cook") {
      for (const auto& [key, value] : {std::pair{"A", material.a}, {"B", material.b}, {"n", material.n}, {"C", material.c}, {"reference_rate", material.reference_rate}})
        r.add(std::string("material.") + key, value);
      r.add("material.thermal", material.thermal);
      if (material.thermal)
        for (const auto& [key, value] : {std::pair{"room_temperature", material.room_temperature}, {"melt_temperature", material.melt_temperature},
                                         {"m", material.m}, {"specific_heat", material.specific_heat}, {"taylor_quinney", material.taylor_quinney}})
          r.add(std::string("material.") + key, value);
    } else {
      for (const auto& [key, value] : {std::pair{"cohesion", material.cohesion}, {"friction_angle", material.friction_angle},
                                       {"dilation_angle", material.dilation_angle}, {"hardening", material.hardening},
                                       {"tension_cutoff", material.tension_cutoff}})
        r.add(std::string("material.") + key, value);
      r.add_text("material.cone", material.cone);
    }
    if (material.fluidity > 0.0) {
      r.add("material.fluidity", material.fluidity);
      r.add("material.exponent", material.exponent);
    }
  }
  r.add_text("method.kernel", std::string(to_string(c.kernel)));
  r.add("method.alpha", c.alpha);
  r.add_text("method.interpolation", std::string(to_string(c.interpolation)));
  r.add_text("method.kinematics", std::string(to_string(c.kinematics)));
  // The automatic method options as the run resolves them, in the record's former
  // formats: a checkpoint written before they were automatic matches when the physics
  // is the same (resolved_method_options, the solver's rule).
  const ResolvedMethodOptions options = resolved_method_options(c);
  r.add("method.hourglass", options.hourglass);
  r.add("method.hourglass_stiffness", options.hourglass_stiffness);
  // With the stiffness on only: a checkpoint of a run without it still matches.
  if (options.hourglass_stiffness > 0.0) r.add_text("method.hourglass_kick", c.hourglass_kick);
  // A plastic run with the stiffness and the reference following the flow only: a
  // checkpoint written before 2026-12-07 (the initial reference) matches a restart with
  // `method.hourglass_reference = "initial"`, and is refused naming the key otherwise.
  if (options.hourglass_stiffness > 0.0 && c.plasticity.model != "elastic" && c.hourglass_reference == "flow")
    r.add_text("method.hourglass_reference", c.hourglass_reference);
  // The wall gradient acts on velocity walls ("fixed", "velocity") and moving smooth
  // walls only. Where there is none, an automatic velocity_wall records the rule of
  // before 2026-12-06 (the wall gradient for an elastic material in 2D and 3D only), so
  // that a plastic run's checkpoint of then (the Taylor bar) still matches.
  bool wall_acts = false;
  for (const auto& b : c.boundaries)
    wall_acts = wall_acts || b.type == "fixed" || b.type == "velocity" ||
                (b.type == "symmetry" && std::any_of(b.value.begin(), b.value.end(), [](double v) { return v != 0.0; }));
  const bool recorded_wall_gradient =
      c.velocity_wall == CaseFile::VelocityWall::automatic && !wall_acts
          ? takes_elastic_treatments(c.dimension, c.plasticity.model != "elastic")
          : options.wall_gradient;
  r.add_text("method.velocity_wall", recorded_wall_gradient ? "wall_gradient" : "characteristics");
  r.add("method.surface_extrapolation", options.surface_extrapolation);
  // With the average on only: a checkpoint of a run without it (every elastic run) still
  // matches, and a plastic run's of before 2026-12-06 does not (its physics changed).
  if (options.volumetric_average) r.add("method.volumetric_average", true);
  r.add("method.material_velocity_motion", c.material_velocity_motion);
  // Updated Lagrangian only (the key moves nothing in small strain): a small-strain
  // checkpoint written before the key existed still matches.
  if (c.kinematics == Kinematics::updated_lagrangian) r.add("method.surface_motion", c.surface_motion);
  r.add("method.conservative_momentum", c.conservative_momentum);
  r.add("method.deficient_stencils", c.deficient_stencils);
  // Small strain evaluates the kernel at X whatever the key: recorded as "current", the
  // default before 2026-11-29, so that a small-strain checkpoint written then still matches.
  r.add("method.kernel_configuration",
        c.kinematics == Kinematics::updated_lagrangian ? c.kernel_configuration : std::string("current"));
  r.add("method.free_edge_uniaxial", options.free_edge_uniaxial);
  r.add("method.body_force", c.body_force);
  r.add_text("solver.neighbor_search", std::string(to_string(c.neighbor_search)));
  r.add("solver.transpose_lists", c.transpose_lists);
  r.add("solver.neighbor_skin", c.neighbor_skin);
  if (c.dt > 0.0) r.add("time.dt", c.dt);
  else r.add("time.cfl", c.cfl);
  if (c.adaptive_time_step) r.add("time.adaptive", true);  // absent when off: older checkpoints still match
  for (std::size_t k = 0; k < c.boundaries.size(); ++k) {
    const BoundarySpec& b = c.boundaries[k];
    const std::string p = fmt::format("boundary[{}].", k);
    r.add_text(p + "name", b.name);
    r.add_text(p + "type", b.type);
    for (std::size_t m = 0; m < b.regions.size(); ++m) {
      const RegionSpec& g = b.regions[m];
      const std::string q = p + fmt::format("region[{}].", m);
      r.add_text(q + "type", g.type);
      if (g.type == "box") {
        r.add(q + "lower", g.lower);
        r.add(q + "upper", g.upper);
      } else if (g.type == "half_space") {
        r.add(q + "point", g.point);
        r.add(q + "normal", g.normal);
      } else if (g.type == "group") {
        r.add(q + "group", static_cast<double>(g.group));
      }
    }
    r.add(p + "value", b.value);
    r.add_text(p + "profile", b.profile);
    if (!b.velocity_gradient.empty()) r.add(p + "velocity_gradient", b.velocity_gradient);
    r.add_text(p + "time.type", b.time.type);
    if (b.time.type == "pulse" || b.time.type == "ramp") {
      r.add(p + "time.start", b.time.start);
      r.add(p + "time.end", b.time.end);
    } else if (b.time.type == "table") {
      r.add(p + "time.times", b.time.times);
      r.add(p + "time.values", b.time.values);
    }
  }
  r.add("initial.velocity", c.initial_velocity);
  r.add("initial.velocity_gradient", c.velocity_gradient);
  r.add("initial.stress", c.initial_stress);
  for (std::size_t k = 0; k < c.velocity_waves.size(); ++k) {
    const VelocityWave& w = c.velocity_waves[k];
    const std::string p = fmt::format("initial.profile[{}].", k);
    r.add(p + "amplitude", w.amplitude);
    r.add(p + "direction", w.direction);
    r.add(p + "wavelength", w.wavelength);
    r.add(p + "phase", w.phase);
  }
  for (std::size_t k = 0; k < c.velocity_shapes.size(); ++k) {
    const VelocityShape& v = c.velocity_shapes[k];
    const std::string p = fmt::format("initial.shape[{}].", k);
    r.add_text(p + "type", v.type);
    r.add(p + "origin", v.origin);
    r.add(p + "axis", v.axis);
    r.add(p + "length", v.length);
    r.add(p + "amplitude", v.amplitude);
    r.add(p + "mode", static_cast<double>(v.mode));
    r.add(p + "angular_velocity", v.angular_velocity);
  }
  r.add("damping.coefficient", c.damping);
  return r.text();
}

std::vector<std::string> physics_differences(const std::string& checkpoint_record, const std::string& case_record) {
  const auto before = parse_record(checkpoint_record), now = parse_record(case_record);
  std::vector<std::string> differ;
  for (const auto& [key, value] : now) {
    const auto it = before.find(key);
    if (it == before.end()) differ.push_back(key + " = " + value + " (the checkpoint: not set)");
    else if (it->second != value) differ.push_back(key + " = " + value + " (the checkpoint: " + it->second + ")");
  }
  for (const auto& [key, value] : before)
    if (!now.count(key)) differ.push_back(key + " not set (the checkpoint: " + value + ")");
  return differ;
}

std::string select_restart_checkpoint(const CaseFile& c, const std::string& restart, std::FILE* log) {
  std::error_code ec;
  const bool directory = fs::is_directory(restart, ec);
  std::vector<std::string> candidates = directory ? checkpoints_of(restart) : std::vector<std::string>{restart};
  if (directory && candidates.empty())
    throw CaseError({restart + ": no checkpoint_*.bin in this directory: give a checkpoint file, or set "
                     "output.checkpoint_every in the case"});
  if (!directory && !fs::exists(restart, ec))
    throw CaseError({"restart = '" + restart + "' is invalid: no such checkpoint file or directory"});
  std::vector<std::string> damaged;
  for (const std::string& path : candidates) {
    output::CheckpointHeader header;
    try {
      header = output::read_checkpoint_header(path);
    } catch (const output::CheckpointError& e) {
      damaged.push_back(e.what());
      continue;
    }
    if (!damaged.empty() && log)
      for (const auto& d : damaged)
        fmt::print(log, "tsph: warning: {}; falling back to {}, the newest intact checkpoint in {}\n", d, path,
                   restart);
    if (header.dimension != c.dimension)
      throw CaseError({fmt::format("restart: checkpoint '{}' is of a {}D run, the case is {}D: restart with the case "
                                   "file (and --set overrides) of the run that wrote it",
                                   path, header.dimension, c.dimension)});
    const auto differ = physics_differences(header.physics, physics_record(c));
    if (!differ.empty()) {
      std::vector<std::string> messages{
          fmt::format("restart: the physics of {} differ from those of checkpoint '{}' in {} key{}: restart with the "
                      "case file and --set overrides of the run that wrote it (or start a new run with --out)",
                      c.path, path, differ.size(), differ.size() == 1 ? "" : "s")};
      for (const auto& d : differ) messages.push_back("  " + d);
      throw CaseError(messages);
    }
    return path;
  }
  std::vector<std::string> messages;
  for (const auto& d : damaged) messages.push_back("restart: " + d);
  messages.push_back(directory ? "restart: no intact checkpoint in " + restart + ": start the run again"
                               : "restart: choose an intact checkpoint (--restart DIR takes the newest intact one)");
  throw CaseError(messages);
}

void prune_checkpoints(const std::string& dir, const std::string& newest) {
  const std::string name = fs::path(newest).filename().string();
  int kept = 0;
  for (const std::string& path : checkpoints_of(dir)) {
    if (fs::path(path).filename().string() > name) continue;  // newer: another timeline, left alone
    if (++kept <= kKeptCheckpoints) continue;
    std::error_code ec;
    fs::remove(path, ec);
  }
}

}  // namespace tsph
