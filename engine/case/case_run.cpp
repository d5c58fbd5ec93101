#include "engine/case/case_run.hpp"

#include "engine/case/case_build.hpp"
#include "engine/case/case_checks.hpp"   // issue 15: probe ids checked by `check` too
#include "engine/case/restart_check.hpp"  // issue 15: physics record, checkpoint pruning
#include "engine/memory_estimate.hpp"
#include "engine/output_file.hpp"
#include "engine/output/checkpoint.hpp"
#include "engine/output/progress.hpp"
#include "engine/output/vtu_writer.hpp"
#include "engine/parallel.hpp"
#include "engine/taylor_sph.hpp"

#include <fmt/core.h>
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <set>
#include <memory>
#include <optional>
#include <sstream>

namespace tsph {
namespace {

namespace fs = std::filesystem;

/// time.adaptive: a step below this fraction of the initial one stops the run.
constexpr double kSmallestAdaptiveStep = 1e-3;

template <int Dim>
std::string format_vector(const Vector<Dim>& x) {
  std::string text = "(";
  for (int d = 0; d < Dim; ++d) text += fmt::format("{}{:.6g}", d > 0 ? ", " : "", x[d]);
  return text + ")";
}

template <int Dim>
CaseOverview inspect(const CaseFile& c) {
  BuiltCase<Dim> b = build_case<Dim>(c);
  check_probe_particles(c, b.real.size());  // issue 15: as run refuses them
  CaseOverview o;
  o.real_particles = b.real.size();
  o.virtual_particles = b.virtual_particles.size();
  for (double v : b.real.volume) o.real_volume += v;
  o.spacing = c.spacing;
  o.smoothing_length = b.settings.smoothing_length;
  o.wave_speed = b.wave_speed;
  o.dt = b.dt;
  o.steps = count_steps(c, b.dt);
  o.frames = 2 + static_cast<std::int64_t>(c.output_times.size()) +
             (c.output_every > 0 ? o.steps / c.output_every : 0);
  o.boundary_particles = b.boundary_counts;
  // The solver itself checks what only it can (a traction inside the body, ...), and
  // gives the real neighbour-list sizes.
  std::optional<TaylorSph<Dim>> solver;
  try {
    solver.emplace(std::move(b.real), std::move(b.virtual_particles), *b.material, b.settings, b.conditions);
  } catch (const std::invalid_argument& e) {
    throw CaseError({c.path + ": " + e.what()});
  }
  // Fields: 4 Dim vectors + stresses + mass, density, volume (doubles), 3 int32 tags
  // (the virtual set: 2 Dim vectors, no tags, unless its frames are written:
  // SolverSettings::keep_virtual_fields); lists: a 4-byte index per pair, a 4-byte row
  // start per row (NeighborList).
  // A plastic material adds its internal variables to the real set, the volumetric
  // average its stencils and rates (memory_estimate.hpp).
  const double set_per_particle = 8.0 * (4 * Dim + stress_component_count<Dim> + 3) + 12.0;
  const double virtual_per_particle =
      c.output_virtual ? set_per_particle : 8.0 * (2 * Dim + stress_component_count<Dim> + 3);
  const MemoryModel model = memory_model(c);
  const double real_per_particle = set_per_particle + (model.plastic_fields ? plastic_field_bytes<Dim>() : 0.0) +
                                   (model.volumetric_average ? volumetric_average_bytes<Dim>() : 0.0);
  const double particles = static_cast<double>(o.real_particles + o.virtual_particles);
  const double pairs = static_cast<double>(solver->virtual_from_real().pair_count() +
                                           solver->real_from_virtual().pair_count());
  o.memory_bytes = static_cast<double>(o.real_particles) * real_per_particle +
                   static_cast<double>(o.virtual_particles) * virtual_per_particle + 4.0 * pairs +
                   4.0 * particles;
  return o;
}

// ---------------------------------------------------------------------------------
// Output

std::string json_string(const std::string& s) {
  std::string out = "\"";
  for (char ch : s) {
    switch (ch) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\t': out += "\\t"; break;
      default:
        if (static_cast<unsigned char>(ch) < 0x20) out += fmt::format("\\u{:04x}", ch);
        else out += ch;
    }
  }
  return out + "\"";
}

std::string json_number(double v) {
  return std::isfinite(v) ? fmt::format("{:.17g}", v) : "null";
}

/// The six stress components in VTK's symmetric-tensor order XX, YY, ZZ, XY, YZ, XZ.
template <int Dim>
std::array<double, 6> stress_tensor(const ParticleSet<Dim>& p, std::size_t i) {
  if constexpr (Dim == 1) return {p.stress[0][i], 0, 0, 0, 0, 0};
  else if constexpr (Dim == 2) return {p.stress[0][i], p.stress[1][i], p.stress[3][i], p.stress[2][i], 0, 0};
  else return {p.stress[0][i], p.stress[1][i], p.stress[2][i], p.stress[3][i], p.stress[4][i], p.stress[5][i]};
}

double von_mises(const std::array<double, 6>& s) {
  const double a = s[0] - s[1], b = s[1] - s[2], d = s[2] - s[0];
  return std::sqrt(0.5 * (a * a + b * b + d * d) + 3.0 * (s[3] * s[3] + s[4] * s[4] + s[5] * s[5]));
}

template <int Dim>
output::VtuFrame snapshot(const ParticleSet<Dim>& p, const CaseFile& c, const BuiltCase<Dim>* b,
                          double time) {
  output::VtuFrame f;
  const std::size_t n = p.size();
  f.point_count = n;
  f.points.assign(3 * n, 0.0);
  for (std::size_t i = 0; i < n; ++i)
    for (int d = 0; d < Dim; ++d) f.points[3 * i + static_cast<std::size_t>(d)] = p.position[d][i];
  auto vector_field = [&](const char* name, const std::array<std::vector<double>, Dim>& field) {
    output::VtuArray a{name, 3, std::vector<double>(3 * n, 0.0), {}, false};
    for (std::size_t i = 0; i < n; ++i)
      for (int d = 0; d < Dim; ++d) a.float64[3 * i + static_cast<std::size_t>(d)] = field[d][i];
    f.arrays.push_back(std::move(a));
  };
  if (c.has_field("velocity")) vector_field("velocity", p.velocity);
  if (c.has_field("displacement")) {
    vector_field("displacement", p.displacement);
    vector_field("initial_position", p.initial_position);  // small strain: the points themselves
  }
  if (c.has_field("stress") || c.has_field("von_mises")) {
    output::VtuArray stress{"stress", 6, std::vector<double>(6 * n), {}, false};
    output::VtuArray mises{"von_mises", 1, std::vector<double>(n), {}, false};
    for (std::size_t i = 0; i < n; ++i) {
      const auto s = stress_tensor(p, i);
      std::copy(s.begin(), s.end(), stress.float64.begin() + static_cast<std::ptrdiff_t>(6 * i));
      mises.float64[i] = von_mises(s);
    }
    if (c.has_field("stress")) f.arrays.push_back(std::move(stress));
    if (c.has_field("von_mises")) f.arrays.push_back(std::move(mises));
  }
  if (c.has_field("density")) f.arrays.push_back({"density", 1, p.density, {}, false});
  if (c.has_field("id")) f.arrays.push_back({"id", 1, {}, p.id, true});
  if (c.has_field("plastic") && p.carries_plastic_fields()) {  // a plastic material's real set
    f.arrays.push_back({"plastic_strain", 1, p.plastic_strain, {}, false});
    f.arrays.push_back({"plastic_work", 1, p.plastic_work, {}, false});
    f.arrays.push_back({"temperature", 1, p.temperature, {}, false});
    f.arrays.push_back({"yielding", 1, std::vector<double>(p.yielding.begin(), p.yielding.end()), {}, false});
  }
  if (b && b->exact && c.has_field("exact"))
    for (const auto& e : b->exact->fields()) {
      output::VtuArray a{"exact_" + e.name, 1, std::vector<double>(n), {}, false};
      for (std::size_t i = 0; i < n; ++i) {
        Vector<Dim> x0;
        for (int d = 0; d < Dim; ++d) x0[d] = p.initial_position[d][i];
        a.float64[i] = e.exact(x0, time);
      }
      f.arrays.push_back(std::move(a));
    }
  return f;
}

/// Opens a CSV output file: a new one with `header`, or, when the run continues from a
/// checkpoint at `restart_time` and the file exists, that file with its header and its
/// rows up to that time (the later rows are the interrupted run's; they come again).
std::ofstream open_csv(const fs::path& path, const std::string& header, std::optional<double> restart_time) {
  std::string kept;
  if (restart_time && fs::exists(path)) {
    std::ifstream in(path);
    std::string line;
    while (std::getline(in, line)) {
      const bool row = !line.empty() && (std::isdigit(static_cast<unsigned char>(line[0])) || line[0] == '-');
      if (row) {  // the rows print 11 digits: a row at the checkpoint's own time may read above it
        double t = 0.0;
        try {
          t = std::stod(line);
        } catch (const std::exception&) {
          break;  // a row cut short (the interrupted run's last): written again
        }
        if (t > *restart_time + 1e-9 * std::abs(*restart_time)) break;
      }
      kept += line + "\n";
    }
  }
  if (kept.empty()) kept = header;  // a new file, or an empty one
  std::ofstream file(path, std::ios::trunc);
  file << kept;
  if (!file) throw_output_error(path.string(), "open", errno);
  return file;
}

/// The boundary conditions' columns of energy.csv: "boundary_" and the name in letters,
/// digits and '_' (others become '_'), with "_2", "_3", ... where two names meet.
template <int Dim>
std::vector<std::string> boundary_columns(const std::vector<BoundaryCondition<Dim>>& conditions) {
  std::vector<std::string> columns;
  for (const auto& condition : conditions) {
    std::string name = "boundary_" + condition.name;
    for (char& ch : name)
      if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
    std::string column = name;
    for (int k = 2; std::find(columns.begin(), columns.end(), column) != columns.end(); ++k)
      column = name + "_" + std::to_string(k);
    columns.push_back(column);
  }
  return columns;
}

/// energy.csv (output.energy_every): the energies and the works of the ledger
/// (engine/solver/energy_ledger.hpp), and what the scheme itself leaves unbalanced.
template <int Dim>
class EnergyFile {
 public:
  EnergyFile(const CaseFile& c, const TaylorSph<Dim>& solver, const fs::path& out, std::optional<double> restart_time)
      : path_(out / "energy.csv") {
    if (c.energy_every <= 0) return;
    std::string header = "t,step,kinetic,elastic,plastic_work,body_force,damping";
    for (const std::string& column : boundary_columns(solver.state().boundaries)) header += "," + column;
    header += ",hourglass,surface_filter,energy_change,external_work,balance_error,overwrite_work,hourglass_energy\n";
    file_ = open_csv(path_, header, restart_time);
    if (restart_time) last_time_ = *restart_time;  // its row is in the file
    open_ = true;
  }
  /// A row at the solver's time (once per time).
  void record(TaylorSph<Dim>& solver) {
    if (!open_ || solver.time() == last_time_) return;
    last_time_ = solver.time();
    SolverState<Dim>& state = solver.state();
    EnergyLedger& l = state.energy;
    l.boundary.resize(state.boundaries.size(), 0.0);
    const double kinetic = EnergyAccounting<Dim>::kinetic(state), elastic = EnergyAccounting<Dim>::elastic(state),
                 plastic = EnergyAccounting<Dim>::plastic_work(state);  // as EnergyAccounting::mechanical
    if (std::isnan(l.initial_energy)) l.initial_energy = kinetic + elastic + plastic;
    const double change = kinetic + elastic + plastic - l.initial_energy, external = l.external_work();
    std::string line = fmt::format("{:.10e},{},{:.10e},{:.10e},{:.10e},{:.10e},{:.10e}", solver.time(),
                                   state.counters.steps, kinetic, elastic, plastic, l.body_force, l.damping);
    for (double w : l.boundary) line += fmt::format(",{:.10e}", w);
    line += fmt::format(",{:.10e},{:.10e},{:.10e},{:.10e},{:.10e},{:.10e},{:.10e}\n", l.hourglass, l.surface_filter,
                        change, external, change - external, l.boundary_overwrite, l.hourglass_energy);
    file_ << line;
  }
  /// Flushes (and closes if `close`); a failed write throws OutputError naming the file.
  void flush(bool close = false) {
    if (!open_) return;
    errno = 0;
    file_.flush();
    if (close) file_.close();
    if (!file_) throw_output_error(path_.string(), "write", errno != 0 ? errno : EIO);
    if (close) open_ = false;
  }

 private:
  fs::path path_;
  std::ofstream file_;
  bool open_ = false;
  double last_time_ = -1.0;
};

template <int Dim>
struct Probe {
  std::string name;
  std::size_t index = 0;
  std::ofstream file;
  double last_time = -1.0;
};

template <int Dim>
std::vector<std::unique_ptr<Probe<Dim>>> open_probes(const CaseFile& c, const ParticleSet<Dim>& real,
                                                     const fs::path& out, std::optional<double> restart_time) {
  std::vector<std::unique_ptr<Probe<Dim>>> probes;
  for (const auto& s : c.probes) {
    auto p = std::make_unique<Probe<Dim>>();
    p->name = s.name;
    if (s.particle >= 0) {
      const auto it = std::find(real.id.begin(), real.id.end(), static_cast<std::uint32_t>(s.particle));
      if (it == real.id.end() || static_cast<std::size_t>(s.particle) >= real.size())
        throw CaseError({c.path + ": output.probe '" + s.name + "': particle = " + std::to_string(s.particle) +
                         " is invalid: ids run from 0 to " + std::to_string(real.size() - 1)});
      p->index = static_cast<std::size_t>(it - real.id.begin());
    } else {
      double best = std::numeric_limits<double>::infinity();
      for (std::size_t i = 0; i < real.size(); ++i) {
        double r2 = 0.0;
        for (int d = 0; d < Dim; ++d) {
          const double e = real.initial_position[d][i] - s.point[static_cast<std::size_t>(d)];
          r2 += e * e;
        }
        if (r2 < best) {
          best = r2;
          p->index = i;
        }
      }
    }
    const char* axes[] = {"x", "y", "z"};
    std::string header = "t";  // the x0 columns name the particle
    for (const char* prefix : {"x0_", "u", "v"})
      for (int d = 0; d < Dim; ++d) header += std::string(",") + prefix + axes[d];
    header += ",sxx,syy,szz,sxy,syz,sxz,von_mises\n";
    p->file = open_csv(out / ("probe_" + s.name + ".csv"), header, restart_time);
    probes.push_back(std::move(p));
  }
  return probes;
}

/// Flushes the probe files (and closes them if `close`); a failed write (a full disk)
/// throws OutputError naming the file. The rows written before stay in the file.
template <int Dim>
void flush_probes(std::vector<std::unique_ptr<Probe<Dim>>>& probes, const fs::path& out, bool close = false) {
  for (auto& p : probes) {
    errno = 0;
    p->file.flush();
    if (close) p->file.close();
    if (!p->file) {
      const int error = errno != 0 ? errno : EIO;
      throw_output_error((out / ("probe_" + p->name + ".csv")).string(), "write", error);
    }
  }
}

template <int Dim>
void record_probes(std::vector<std::unique_ptr<Probe<Dim>>>& probes, const ParticleSet<Dim>& r, double t) {
  for (auto& p : probes) {
    if (p->last_time == t) continue;  // already recorded at this time
    p->last_time = t;
    const std::size_t i = p->index;
    std::string line = fmt::format("{:.10e}", t);
    for (int d = 0; d < Dim; ++d) line += fmt::format(",{:.10e}", r.initial_position[d][i]);
    for (int d = 0; d < Dim; ++d) line += fmt::format(",{:.10e}", r.displacement[d][i]);
    for (int d = 0; d < Dim; ++d) line += fmt::format(",{:.10e}", r.velocity[d][i]);
    const auto s = stress_tensor(r, i);
    for (double v : s) line += fmt::format(",{:.10e}", v);
    line += fmt::format(",{:.10e}\n", von_mises(s));
    p->file << line;
  }
}

const char* status_name(RunReport::Status s) {
  switch (s) {
    case RunReport::Status::finished: return "finished";
    case RunReport::Status::at_rest: return "at_rest";
    case RunReport::Status::not_at_rest: return "not_at_rest";
    case RunReport::Status::interrupted: return "interrupted";
  }
  return "?";
}

template <int Dim>
void write_summary(const fs::path& out, const CaseFile& c, const RunOptions& o, const RunReport& r,
                   const BuiltCase<Dim>& b, const std::string& status, const std::string& message) {
  std::string overrides;
  for (const auto& s : o.overrides) overrides += (overrides.empty() ? "" : ", ") + json_string(s);
  // The method options as the solver resolves them (the builder hands them over as set).
  const SolverSettings<Dim> resolved =
      resolve_automatic_options(b.settings, b.material->plastic(), b.material->pressure_independent_yield());
  std::string errors;
  for (const auto& e : r.errors)
    errors += fmt::format("{}\n    {{\"time\": {}, \"name\": {}, \"value\": {}}}", errors.empty() ? "" : ",",
                          json_number(e.time), json_string(e.name), json_number(e.value));
  std::string text = fmt::format(
      "{{\n  \"schema\": \"tsph.summary/1\",\n  \"program\": \"tsph\",\n  \"version\": {},\n  \"case\": {},\n  \"title\": {},\n"
      "  \"overrides\": [{}],\n  \"restart\": {},\n  \"last_checkpoint\": {},\n  \"status\": {},\n  \"message\": {},\n"
      "  \"resolved\": {{\"dimension\": {}, \"real_particles\": {}, \"virtual_particles\": {}, "
      "\"spacing\": {}, \"smoothing_length\": {}, \"alpha\": {}, \"kernel\": {}, \"interpolation\": {}, "
      "\"kinematics\": {}, \"E\": {}, \"nu\": {}, \"rho\": {}, \"plane\": {}, \"p_wave_speed\": {}, "
      "\"dt\": {}, \"cfl\": {}, \"end_time\": {}, \"damping\": {}, \"hourglass\": {}, "
      "\"hourglass_stiffness\": {}, \"velocity_wall\": {}, \"surface_extrapolation\": {}, \"free_edge_uniaxial\": {}, \"volumetric_average\": {}, \"kernel_configuration\": {}, \"neighbor_skin\": {}, "
      "\"threads\": {}}},\n"
      "  \"time\": {},\n  \"steps\": {},\n  \"neighbor_builds\": {},\n  \"wall_seconds\": {},\n  \"particle_steps_per_second\": {},\n"
      "  \"output_frames\": {},\n  \"output_writer_seconds\": {},\n  \"output_wait_seconds\": {},\n"
      "  \"errors\": [{}\n  ]\n}}\n",
      json_string(o.version), json_string(c.path), json_string(c.title), overrides,
      o.restart.empty() ? "null" : json_string(o.restart),
      r.last_checkpoint.empty() ? "null" : json_string(r.last_checkpoint), json_string(status),
      json_string(message), Dim, r.real_particles, r.virtual_particles, json_number(c.spacing),
      json_number(b.settings.smoothing_length), json_number(c.alpha), json_string(std::string(to_string(c.kernel))),
      json_string(std::string(to_string(c.interpolation))), json_string(std::string(to_string(c.kinematics))),
      json_number(c.young_modulus), json_number(c.poisson_ratio), json_number(c.density),
      json_string(Dim == 2 ? (c.plane_mode == PlaneMode::plane_strain ? "strain" : "stress") : "none"),
      json_number(b.wave_speed), json_number(b.dt), json_number(b.dt * b.wave_speed / c.spacing),
      json_number(c.end_time), json_number(c.damping), json_number(resolved.hourglass_coefficient),
      json_number(resolved.hourglass_stiffness),
      json_string(resolved.velocity_wall == SolverSettings<Dim>::VelocityWall::wall_gradient ? "wall_gradient" : "characteristics"),
      resolved.surface_extrapolation == Toggle::on ? "true" : "false", resolved.free_edge_uniaxial == Toggle::on ? "true" : "false",
      resolved.volumetric_average == Toggle::on ? "true" : "false",
      // The kernel's configuration and the skin in effect: small strain evaluates the kernel
      // at X, and only the current kernel of updated Lagrangian has a skin.
      json_string(c.kinematics == Kinematics::updated_lagrangian ? c.kernel_configuration : std::string("reference")),
      json_number(resolved_method_options(c).neighbor_skin),
      thread_count(),
      json_number(r.time), r.steps, r.neighbor_builds, json_number(r.wall_seconds), json_number(r.particle_steps_per_second),
      r.frames, json_number(r.output_busy_seconds), json_number(r.output_wait_seconds), errors);
  output::write_text_file((out / "summary.json").string(), text);
}

template <int Dim>
RunReport run(const CaseFile& c, const RunOptions& o) {
  BuiltCase<Dim> b = build_case<Dim>(c);
  const fs::path out(o.out_dir);
  RunReport report;
  report.real_particles = b.real.size();
  report.virtual_particles = b.virtual_particles.size();
  report.dt = b.dt;
  std::optional<output::Checkpoint<Dim>> checkpoint;
  if (!o.restart.empty()) {
    try {
      checkpoint = output::read_checkpoint<Dim>(o.restart);
    } catch (const std::runtime_error& e) {
      throw CaseError({std::string("restart: ") + e.what()});
    }
    if (checkpoint->real.size() != b.real.size() || checkpoint->virtual_particles.size() != b.virtual_particles.size())
      throw CaseError({o.restart + ": the checkpoint holds " + std::to_string(checkpoint->real.size()) + " real and " +
                       std::to_string(checkpoint->virtual_particles.size()) + " virtual particles, the case " +
                       std::to_string(b.real.size()) + " and " + std::to_string(b.virtual_particles.size()) +
                       ": restart with the case file (and --set overrides) of the run that wrote it"});
    for (std::size_t i = 0; i < b.real.size(); ++i)
      if (checkpoint->real.boundary[i] != b.real.boundary[i])
        throw CaseError({o.restart + ": the boundary conditions of the case differ from the checkpoint's: restart "
                         "with the case file of the run that wrote it"});
    b.real = std::move(checkpoint->real);
    b.virtual_particles = std::move(checkpoint->virtual_particles);
  }
  std::optional<TaylorSph<Dim>> solver;
  try {
    solver.emplace(std::move(b.real), std::move(b.virtual_particles), *b.material, b.settings, b.conditions);
  } catch (const std::invalid_argument& e) {
    throw CaseError({c.path + ": " + e.what()});
  }
  std::int64_t step_offset = 0;  // steps before the restart
  if (checkpoint) {
    solver->set_time(checkpoint->time);
    step_offset = checkpoint->steps;
    // The solver counts on from the checkpoint's step: the updated-Lagrangian virtual
    // particles are put back at their material points every 8th step (half_step.hpp), and
    // a restart keeps that schedule (bit for bit) and the step numbers of diagnoses.
    solver->state().counters.steps = checkpoint->steps;
    solver->state().energy = checkpoint->energy;  // the works booked before it (format 3: none)
    report.frames = checkpoint->frames;
    for (const auto& e : checkpoint->errors) report.errors.push_back({e.time, e.name, e.value});
  }
  auto step_count = [&] { return solver->counters().steps; };
  auto probes = open_probes<Dim>(c, solver->real(), out,
                                 checkpoint ? std::optional<double>(checkpoint->time) : std::nullopt);
  EnergyFile<Dim> energy(c, *solver, out, checkpoint ? std::optional<double>(checkpoint->time) : std::nullopt);
  std::optional<std::size_t> rest_index;
  for (const auto& p : probes)
    if (p->name == c.rest_probe) rest_index = p->index;

  // Output: frames written by a background thread from snapshots.
  output::BackgroundWriter writer;
  std::vector<output::PvdEntry> real_series, virtual_series;
  double last_frame_time = -1.0;
  if (checkpoint) {
    real_series = checkpoint->real_series;
    virtual_series = checkpoint->virtual_series;
    last_frame_time = real_series.empty() ? -1.0 : real_series.back().time;
    // issue 15: --restart DIR --out OTHER lists only the frames present in OTHER
    std::erase_if(real_series, [&](const output::PvdEntry& e) { return !fs::exists(out / e.file); });
    std::erase_if(virtual_series, [&](const output::PvdEntry& e) { return !fs::exists(out / e.file); });
  }
  std::vector<std::string> checkpoints;  // written by this run, newest last; two are kept
  const std::string physics = physics_record(c);  // issue 15: a restart compares it with its case
  auto write_checkpoint = [&] {
    writer.finish();  // the frames it lists are on disk first
    output::Checkpoint<Dim> k;
    k.real = solver->real();
    k.virtual_particles = solver->virtual_particles();
    k.time = solver->time();
    k.steps = step_count();
    k.frames = report.frames;
    k.real_series = real_series;
    k.virtual_series = virtual_series;
    for (const auto& e : report.errors) k.errors.push_back({e.time, e.name, e.value});
    k.physics = physics;
    if (c.energy_every > 0) k.energy = solver->state().energy;  // off: a later run with it starts afresh
    const fs::path path = out / fmt::format("checkpoint_{:010d}.bin", k.steps);
    output::write_checkpoint((path).string(), k);
    prune_checkpoints(out.string(), path.string());  // issue 15: also those from before a restart
    flush_probes(probes, out);
    energy.flush();
    if (checkpoints.empty() || checkpoints.back() != path.string()) checkpoints.push_back(path.string());
    if (checkpoints.size() > 2) {
      std::error_code ec;
      fs::remove(checkpoints.front(), ec);
      checkpoints.erase(checkpoints.begin());
    }
    report.last_checkpoint = path.string();
  };
  auto errors_at = [&](double t) {
    if (b.exact) b.exact->errors(solver->real(), t, report.errors);
  };
  auto frame = [&] {
    const double t = solver->time();
    const std::size_t k = report.frames++;
    last_frame_time = t;
    errors_at(t);
    const std::string real_name = fmt::format("particles_{:06d}.vtu", k);
    real_series.push_back({t, real_name});
    auto real_frame = std::make_shared<output::VtuFrame>(snapshot(solver->real(), c, &b, t));
    if (o.on_frame) o.on_frame(*real_frame, t);
    std::shared_ptr<output::VtuFrame> virtual_frame;
    std::string virtual_name;
    if (c.output_virtual) {
      virtual_name = fmt::format("virtual_{:06d}.vtu", k);
      virtual_series.push_back({t, virtual_name});
      virtual_frame = std::make_shared<output::VtuFrame>(snapshot<Dim>(solver->virtual_particles(), c, nullptr, t));
    }
    writer.submit([=, real_series = real_series, virtual_series = virtual_series] {
      output::write_vtu((out / real_name).string(), *real_frame);
      output::write_pvd((out / "particles.pvd").string(), real_series);
      if (virtual_frame) {
        output::write_vtu((out / virtual_name).string(), *virtual_frame);
        output::write_pvd((out / "virtual.pvd").string(), virtual_series);
      }
    });
    flush_probes(probes, out);
    energy.flush();
  };

  output::ProgressLine progress(o.progress, o.quiet, c.end_time, report.real_particles);
  const double dt = b.dt;
  const bool resting = c.rest_velocity > 0.0;  // damping.rest_velocity = 0: no rest criterion
  std::size_t next_time = 0;
  while (next_time < c.output_times.size() && solver->time() >= c.output_times[next_time] - 1e-9 * dt) ++next_time;
  std::string message;
  const auto start = std::chrono::steady_clock::now();
  auto call_on_step = [&](std::int64_t step) {
    RunOptions::StepRecord record{solver->time(), step, solver->kinetic_energy(), solver->strain_energy()};
    if (o.node_and_cell_energies) {
      const auto e = solver->node_and_cell_energies();
      record.kinetic_node_and_cell = e.kinetic;
      record.strain_node_and_cell = e.elastic;
    }
    o.on_step(record);
  };
  if (!checkpoint) {
    frame();
    record_probes(probes, solver->real(), 0.0);
    energy.record(*solver);
    if (o.on_step && o.node_and_cell_energies) call_on_step(0);  // E0 on that quadrature too
  }
  // A diverged run (the stepper's monitor, or the adaptive step collapsing) stops with
  // the frames and probe rows of the steps before, each of which passed the monitor.
  auto stop_diverged = [&](std::string diagnosis) {
    message = std::move(diagnosis);
    report.time = solver->time();
    report.steps = step_count();
    writer.finish();
    flush_probes(probes, out, /*close=*/true);  // the step that failed wrote no row
    energy.flush(/*close=*/true);
    write_summary(out, c, o, report, b, "diverged", message);
    throw RunDiverged(message);
  };
  {
    while (solver->time() < c.end_time - 1e-9 * dt) {
      const double target = next_time < c.output_times.size() ? c.output_times[next_time] : c.end_time;
      const double remaining = target - solver->time();
      double step_dt = dt;
      if (c.adaptive_time_step) {  // time.adaptive: the smallest current spacing (engine/solver/time_step.hpp)
        const auto limit = solver->stable_time_step();
        step_dt = std::min(dt, c.cfl * limit.time_step);
        if (!(step_dt >= kSmallestAdaptiveStep * dt))
          stop_diverged(fmt::format(
              "solver: the adaptive time step fell to {:.4g} s, below {:g} of the initial {:.4g} s, at t = {:.6g} s: "
              "the neighbourhood of virtual particle {} (at {}) is compressed to a principal stretch of {:.4g} "
              "(det F = {:.4g}); likely cause: the body is crushed or has lost its particle order (use a finer spacing, "
              "or end the run earlier)",
              step_dt, kSmallestAdaptiveStep, dt, solver->time(), limit.particle,
              format_vector(solver->virtual_particles().position_of(limit.particle)), limit.stretch, limit.jacobian));
      }
      const bool lands = remaining <= step_dt * (1.0 + 1e-9);
      try {
        solver->step(lands ? remaining : step_dt);
      } catch (const std::runtime_error& e) {  // the stepper's non-finite check (I/O errors pass)
        stop_diverged(e.what());
      }
      if (lands) solver->set_time(target);
      const std::int64_t step = step_count();
      bool write = false;
      while (next_time < c.output_times.size() && solver->time() >= c.output_times[next_time] - 1e-9 * dt) {
        ++next_time;
        write = true;
      }
      if (c.output_every > 0 && step % c.output_every == 0) write = true;
      if (step % c.probe_every == 0 || write) record_probes(probes, solver->real(), solver->time());
      if (c.energy_every > 0 && (step % c.energy_every == 0 || write)) energy.record(*solver);
      if (o.on_step) call_on_step(step);
      if (resting && solver->time() >= c.rest_after) {
        // At rest: the speed (of the rest probe, else the fastest real particle) below
        // damping.rest_velocity and, where given, the kinetic energy below
        // damping.rest_kinetic_energy (a sum over the particles: only once the speed is).
        const auto& r = solver->real();
        double speed = 0.0;
        auto speed_of = [&](std::size_t i) {
          double v2 = 0.0;
          for (int d = 0; d < Dim; ++d) v2 += r.velocity[d][i] * r.velocity[d][i];
          return std::sqrt(v2);
        };
        if (rest_index) speed = speed_of(*rest_index);
        else
          for (std::size_t i = 0; i < r.size(); ++i) speed = std::max(speed, speed_of(i));
        if (speed < c.rest_velocity &&
            (c.rest_kinetic_energy <= 0.0 || solver->kinetic_energy() < c.rest_kinetic_energy)) {
          report.status = RunReport::Status::at_rest;
          message = c.rest_kinetic_energy > 0.0
                        ? fmt::format("at rest at t = {} s: speed {:.3e} m/s < rest_velocity, kinetic energy "
                                      "{:.3e} J < rest_kinetic_energy",
                                      solver->time(), speed, solver->kinetic_energy())
                        : fmt::format("at rest at t = {} s: speed {:.3e} m/s < rest_velocity", solver->time(), speed);
          break;
        }
      }
      if (write) frame();
      if (c.checkpoint_every > 0 && step % c.checkpoint_every == 0) write_checkpoint();
      progress.update(step, solver->time());
      if (o.stop_requested && *o.stop_requested) {
        report.status = RunReport::Status::interrupted;
        message = fmt::format("interrupted by a signal at t = {} s", solver->time());
        break;
      }
    }
  }
  if (report.status == RunReport::Status::finished && resting) {
    report.status = RunReport::Status::not_at_rest;
    message = fmt::format("not at rest by time.end = {} s (damping.rest_velocity = {} m/s)", c.end_time,
                          c.rest_velocity);
  }
  if (last_frame_time != solver->time()) {
    record_probes(probes, solver->real(), solver->time());
    frame();
  }
  energy.record(*solver);
  if (c.checkpoint_every > 0 || report.status == RunReport::Status::interrupted) write_checkpoint();
  progress.finish(step_count(), solver->time());
  writer.finish();
  const auto stop = std::chrono::steady_clock::now();
  report.wall_seconds = std::chrono::duration<double>(stop - start).count();
  report.time = solver->time();
  report.steps = step_count();
  report.neighbor_builds = solver->counters().neighbor_builds;
  report.particle_steps_per_second = static_cast<double>(report.real_particles) *
                                     static_cast<double>(solver->counters().steps - step_offset) /
                                     std::max(report.wall_seconds, 1e-12);
  report.output_busy_seconds = writer.busy_seconds();
  report.output_wait_seconds = writer.waited_seconds();
  flush_probes(probes, out, /*close=*/true);
  energy.flush(/*close=*/true);
  write_summary(out, c, o, report, b, status_name(report.status), message);
  return report;
}

}  // namespace

CaseOverview inspect_case(const CaseFile& c) {
  switch (c.dimension) {
    case 1: return inspect<1>(c);
    case 2: return inspect<2>(c);
    case 3: return inspect<3>(c);
  }
  throw CaseError({c.path + ": dimension must be 1, 2 or 3"});
}

std::string resolve_checkpoint(const std::string& path) {
  std::error_code ec;
  if (!fs::is_directory(path, ec)) return path;
  std::string newest;
  for (const auto& entry : fs::directory_iterator(path, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("checkpoint_", 0) == 0 && entry.path().extension() == ".bin" &&
        (newest.empty() || entry.path().string() > newest))
      newest = entry.path().string();
  }
  if (newest.empty())
    throw CaseError({path + ": no checkpoint_*.bin in this directory: give a checkpoint file, or set "
                     "output.checkpoint_every in the case"});
  return newest;
}

RunReport run_case(const CaseFile& c, const RunOptions& options) {
  switch (c.dimension) {
    case 1: return run<1>(c, options);
    case 2: return run<2>(c, options);
    case 3: return run<3>(c, options);
  }
  throw CaseError({c.path + ": dimension must be 1, 2 or 3"});
}

}  // namespace tsph
