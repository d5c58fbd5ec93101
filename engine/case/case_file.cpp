#include "engine/case/case_file.hpp"

#include "engine/case/case_toml.hpp"
#include "engine/input_error.hpp"
#include "engine/case/case_checks.hpp"  // issue 15: checks of the whole case
#include "engine/threads.hpp"           // issue 15: the one thread-count rule

#include <toml++/toml.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <optional>
#include <sstream>

namespace tsph {

CaseError::CaseError(const std::vector<std::string>& messages)
    : std::invalid_argument([&] {
        std::string all;
        for (const auto& m : messages) all += (all.empty() ? "" : "\n") + m;
        return all;
      }()),
      messages_(messages) {}

std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      const bool same = std::tolower(static_cast<unsigned char>(a[i - 1])) ==
                        std::tolower(static_cast<unsigned char>(b[j - 1]));
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (same ? 0 : 1)});
      diagonal = up;
    }
  }
  return row[b.size()];
}

const std::vector<std::string>& known_output_fields() {
  static const std::vector<std::string> fields = {"velocity", "stress",  "von_mises", "displacement",
                                                  "density",  "id",      "exact",     "plastic"};
  return fields;
}

bool CaseFile::has_field(const std::string& name) const {
  return std::find(fields.begin(), fields.end(), name) != fields.end();
}

namespace {

TimeFunctionSpec read_time_function(Table t) {
  TimeFunctionSpec f;
  if (!t.present()) return f;
  f.type = t.text("type", true, {"constant", "pulse", "ramp", "table"}).value_or("constant");
  if (f.type == "pulse" || f.type == "ramp") {
    f.start = t.real("start", false, "0.0", non_negative, "must be >= 0").value_or(0.0);
    f.end = t.real("end", true, "2.5e-3").value_or(f.start + 1.0);
    if (!(f.end > f.start))
      t.context().invalid(t.get("end", false, ""), t.path("end"),
                          "must exceed start = " + format_number(f.start));
  } else if (f.type == "table") {
    f.times = t.numbers("times", true, 0, "").value_or(std::vector<double>{});
    f.values = t.numbers("values", true, 0, "").value_or(std::vector<double>{});
    bool increasing = !f.times.empty();
    for (std::size_t k = 1; k < f.times.size(); ++k) increasing = increasing && f.times[k] > f.times[k - 1];
    if (!increasing && t.has("times"))
      t.context().invalid(t.get("times", false, ""), t.path("times"), "must be non-empty and increase strictly");
    if (f.values.size() != f.times.size() && t.has("values"))
      t.context().invalid(t.get("values", false, ""), t.path("values"),
                          "must have as many entries as times (" + std::to_string(f.times.size()) + ")");
  }
  t.finish();
  return f;
}

RegionSpec read_region(Table t, std::size_t dim) {
  RegionSpec r;
  r.type = t.text("type", true, {"box", "half_space", "group", "all"}).value_or("");
  if (r.type == "box") {
    r.lower = t.numbers("lower", true, dim, "one per axis").value_or(std::vector<double>{});
    r.upper = t.numbers("upper", true, dim, "one per axis").value_or(std::vector<double>{});
  } else if (r.type == "half_space") {
    r.point = t.numbers("point", true, dim, "a point on the plane").value_or(std::vector<double>{});
    r.normal = t.numbers("normal", true, dim, "pointing to the selected side").value_or(std::vector<double>{});
    bool zero = !r.normal.empty();
    for (double n : r.normal) zero = zero && n == 0.0;
    if (zero) t.context().invalid(t.get("normal", false, ""), t.path("normal"), "must be non-zero");
  } else if (r.type == "group") {
    r.group = t.integer("group", true, "1").value_or(0);
  }
  t.finish();
  return r;
}

CaseFile read_case(toml::table root, const std::string& path, const std::vector<std::string>& overrides);

}  // namespace

bool pressure_independent_yield(const CaseFile& c) {
  const CaseFile::Plasticity& p = c.plasticity;
  if (c.dimension == 2 && c.plane_mode != PlaneMode::plane_strain) return false;
  return p.model == "j2" || p.model == "johnson_cook" ||
         (p.model == "drucker_prager" && p.friction_angle == 0.0 && std::isinf(p.tension_cutoff));
}

CaseFile load_case(const std::string& path, const std::vector<std::string>& overrides) {
  {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec))
      throw CaseError({path + ": case file cannot be read (" +
                       (std::filesystem::exists(path, ec) ? "not a regular file" : "no such file") +
                       "): check the path"});
  }
  if (std::ifstream readable(path); !readable)  // issue 15: not a TOML error at 0:0
    throw CaseError({path + ": case file cannot be read (" + std::strerror(errno) + "): check its permissions"});
  try {
    return read_case(toml::parse_file(path), path, overrides);
  } catch (const toml::parse_error& e) {
    throw CaseError({path + ":" + std::to_string(e.source().begin.line) + ":" +
                     std::to_string(e.source().begin.column) + ": TOML syntax error: " +
                     std::string(e.description())});
  }
}

CaseFile load_case_text(const std::string& text, const std::string& name, const std::vector<std::string>& overrides) {
  try {
    return read_case(toml::parse(text, name), name, overrides);
  } catch (const toml::parse_error& e) {
    throw CaseError({name + ":" + std::to_string(e.source().begin.line) + ":" +
                     std::to_string(e.source().begin.column) + ": TOML syntax error: " +
                     std::string(e.description())});
  }
}

namespace {

/// [material] model and the keys of that model (issue 16): the other models' keys are
/// left unread, so that Table::finish reports them as unknown keys of this model.
void read_plasticity(Table& m, CaseFile& c, Context& context) {
  CaseFile::Plasticity& p = c.plasticity;
  p.model = m.text("model", false, {"elastic", "j2", "johnson_cook", "drucker_prager"}).value_or("elastic");
  const auto at_least = [](double minimum) { return [minimum](double v) { return v >= minimum; }; };
  const std::string nonnegative = "must be at least 0";
  const bool plane_stress = c.dimension == 2 && c.plane_mode == PlaneMode::plane_stress;
  if (p.model == "drucker_prager" && plane_stress)
    context.invalid(m.get("model", false, ""), m.path("model"),
                    "needs material.plane = \"strain\" in 2D (the Drucker-Prager plane-stress return is not "
                    "implemented; j2 and johnson_cook have one)");
  if (p.model == "drucker_prager" && c.dimension == 1)
    context.invalid(m.get("model", false, ""), m.path("model"), "needs dimension = 2 or 3 (1D is uniaxial stress)");
  const auto perzyna = [&] {
    p.fluidity = m.real("fluidity", false, "100", positive, kPositive + " (the Perzyna fluidity, 1/s; leave it out "
                                                                        "for a rate-independent model)").value_or(0.0);
    p.exponent = m.real("exponent", false, "1", at_least(1.0), "must be at least 1 (the Perzyna exponent N)").value_or(1.0);
    if (m.has("exponent") && !m.has("fluidity"))
      context.invalid(m.get("exponent", false, ""), m.path("exponent"),
                      "applies with material.fluidity (Perzyna viscoplasticity) only");
  };
  if (p.model == "j2") {
    p.yield_stress = m.real("yield_stress", true, "400e6", positive, kPositive + " (the initial yield stress, Pa)").value_or(0.0);
    p.isotropic_hardening = m.real("isotropic_hardening", false, "100e6", at_least(0.0), nonnegative + " (Pa)").value_or(0.0);
    p.kinematic_hardening = m.real("kinematic_hardening", false, "0", at_least(0.0), nonnegative + " (Pa)").value_or(0.0);
    if (plane_stress && p.kinematic_hardening > 0.0)
      context.invalid(m.get("kinematic_hardening", false, ""), m.path("kinematic_hardening"),
                      "is not available in plane stress (its return has isotropic hardening only): leave it out, "
                      "or set material.plane = \"strain\"");
    perzyna();
  } else if (p.model == "johnson_cook") {
    p.a = m.real("A", true, "90e6", positive, kPositive + " (the initial yield stress A, Pa)").value_or(0.0);
    p.b = m.real("B", false, "292e6", at_least(0.0), nonnegative + " (the hardening B, Pa)").value_or(0.0);
    p.n = m.real("n", false, "0.31", positive, kPositive + " (the hardening exponent)").value_or(1.0);
    p.c = m.real("C", false, "0.025", at_least(0.0), nonnegative + " (the strain-rate coefficient)").value_or(0.0);
    p.reference_rate = m.real("reference_rate", false, "1", positive, kPositive + " (1/s)").value_or(1.0);
    p.thermal = m.boolean("thermal").value_or(false);
    if (p.thermal) {
      p.room_temperature = m.real("room_temperature", false, "293", positive, kPositive + " (K)").value_or(293.0);
      p.melt_temperature = m.real("melt_temperature", true, "1356", positive, kPositive + " (K)").value_or(0.0);
      if (p.melt_temperature > 0.0 && !(p.melt_temperature > p.room_temperature))
        context.invalid(m.get("melt_temperature", false, ""), m.path("melt_temperature"),
                        "must be above room_temperature = " + format_number(p.room_temperature) + " K");
      p.m = m.real("m", false, "1.09", positive, kPositive + " (the thermal exponent)").value_or(1.0);
      p.specific_heat = m.real("specific_heat", true, "383", positive, kPositive + " (J/(kg K))").value_or(0.0);
      p.taylor_quinney = m.real("taylor_quinney", false, "0.9", [](double v) { return v >= 0.0 && v <= 1.0; },
                                "must lie in [0, 1]").value_or(0.9);
    }
  } else if (p.model == "drucker_prager") {
    p.cohesion = m.real("cohesion", true, "50e3", positive, kPositive + " (Pa)").value_or(0.0);
    p.friction_angle = m.real("friction_angle", false, "30", [](double v) { return v >= 0.0 && v < 90.0; },
                              "must lie in [0, 90) degrees").value_or(0.0);
    p.dilation_angle = m.real("dilation_angle", false, "0", [&](double v) { return v >= 0.0 && v <= p.friction_angle; },
                              "must lie in [0, friction_angle = " + format_number(p.friction_angle) + "] degrees").value_or(0.0);
    p.hardening = m.real("hardening", false, "0", at_least(0.0), nonnegative + " (Pa per unit plastic strain)").value_or(0.0);
    p.tension_cutoff = m.real("tension_cutoff", false, "10e3", {}, "").value_or(std::numeric_limits<double>::infinity());
    p.cone = m.text("cone", false, {"plane_strain", "compression", "extension"}).value_or("plane_strain");
    perzyna();
  }
}

CaseFile read_case(toml::table root, const std::string& path, const std::vector<std::string>& overrides) {
  Context context;
  context.file = path;
  for (const auto& o : overrides) apply_override(root, o, context);
  if (!context.errors.empty()) throw CaseError(context.errors);

  CaseFile c;
  c.path = path;
  c.directory = std::filesystem::path(path).parent_path().string();
  Table top(context, &root, "", nullptr);
  c.title = top.text("title", false).value_or(std::filesystem::path(path).stem().string());
  c.dimension = static_cast<int>(
      top.integer("dimension", true, "2", [](std::int64_t d) { return d >= 1 && d <= 3; },
                  "must be 1, 2 or 3").value_or(0));
  const auto dim = static_cast<std::size_t>(c.dimension);  // 0 when invalid: sizes unchecked
  c.threads = static_cast<int>(
      top.integer("threads", false, "2", [](std::int64_t n) { return !thread_count_error("threads", n); },
                  thread_count_rule()).value_or(0));

  {  // [geometry]
    Table g = top.table("geometry", true);
    c.spacing = g.real("spacing", true, "0.01", positive, kPositive + " (the lattice spacing dx, m)").value_or(0.0);
    const bool has_box = g.has("box"), has_file = g.has("particle_file");
    if (has_box == has_file && g.present())
      context.errors.push_back(context.where(g.self()) +
                               "geometry needs exactly one of box = { lower = [...], upper = [...] } "
                               "or particle_file = \"particles.csv\"" +
                               (has_box ? " (both are given)" : ""));
    auto read_box = [&](Table box) {
      auto lower = box.numbers("lower", true, dim, "one per axis").value_or(std::vector<double>{});
      auto upper = box.numbers("upper", true, dim, "one per axis").value_or(std::vector<double>{});
      if (lower.size() == dim && upper.size() == dim && c.spacing > 0.0)
        for (std::size_t d = 0; d < dim; ++d) {
          const double cells = (upper[d] - lower[d]) / c.spacing;
          if (!(cells >= 1.0 - 1e-9) || std::abs(cells - std::round(cells)) > 1e-6 * std::max(1.0, cells))
            context.invalid(box.get("upper", false, ""), box.path("upper"),
                            "must lie a whole number (>= 1) of spacings dx = " + format_number(c.spacing) +
                                " above lower along axis " + std::to_string(d) + " (extent / dx = " +
                                format_number(cells) + ")");
        }
      box.finish();
      c.boxes.emplace_back(std::move(lower), std::move(upper));
    };
    if (g.has("box") && g.get("box", false, "")->is_array()) {
      // Several boxes: their union, on the lattice of the first one.
      for (Table box : g.tables("box")) read_box(box);
      if (c.boxes.empty()) context.invalid(g.get("box", false, ""), g.path("box"), "must hold at least one box");
      for (std::size_t k = 1; k < c.boxes.size() && c.spacing > 0.0; ++k)
        for (std::size_t d = 0; d < c.boxes[k].first.size() && d < c.boxes[0].first.size(); ++d) {
          const double shift = (c.boxes[k].first[d] - c.boxes[0].first[d]) / c.spacing;
          if (std::abs(shift - std::round(shift)) > 1e-6 * std::max(1.0, std::abs(shift))) {
            context.errors.push_back(context.where(g.get("box", false, "")) + "geometry.box[" + std::to_string(k) +
                                     "].lower is invalid: the boxes must share one lattice (their lower "
                                     "corners a whole number of spacings apart)");
            break;
          }
        }
    } else {
      Table box = g.table("box", false);
      if (box.present()) read_box(box);
    }
    if (c.boxes.size() == 1) {
      c.box_lower = c.boxes[0].first;
      c.box_upper = c.boxes[0].second;
      c.boxes.clear();
    }
    if (const auto file = g.text("particle_file", false)) {
      const std::filesystem::path p(*file);
      c.particle_file = p.is_absolute() ? p.string() : (std::filesystem::path(c.directory) / p).string();
    }
    g.finish();
  }
  {  // [material]
    Table m = top.table("material", true);
    c.young_modulus = m.real("E", true, "8e7", positive, kPositive + " (Young's modulus, Pa)").value_or(0.0);
    c.density = m.real("rho", true, "2000", positive, kPositive + " (density, kg/m^3)").value_or(0.0);
    c.poisson_ratio = m.real("nu", c.dimension > 1, "0.3", [](double v) { return v > -1.0 && v < 0.5; },
                             "must lie in (-1, 0.5)").value_or(0.0);
    const auto plane = m.text("plane", false, {"stress", "strain"});
    if (plane && c.dimension != 2)
      context.invalid(m.get("plane", false, ""), m.path("plane"), "applies to dimension = 2 only");
    c.plane_mode = plane.value_or("stress") == "strain" ? PlaneMode::plane_strain : PlaneMode::plane_stress;
    if (c.dimension == 3) c.plane_mode = PlaneMode::plane_strain;  // unused in 3D
    read_plasticity(m, c, context);
    m.finish();
  }
  {  // [method]
    Table m = top.table("method", false);
    const auto kernel = m.text("kernel", false, {"cubic_spline", "wendland_c2", "quintic_spline"});
    c.kernel = *parse_kernel_kind(kernel.value_or("cubic_spline"));
    c.alpha = m.real("alpha", true, "0.6", [](double a) { return a > 0.5 && a <= 4.0; },
                     "must lie in (0.5, 4] (h / dx; below 0.5 the support 2h is shorter than dx)")
                  .value_or(0.0);
    c.interpolation = m.text("interpolation", false, {"linear", "shepard"}).value_or("linear") == "shepard"
                          ? InterpolationKind::shepard
                          : InterpolationKind::linear;
    c.kinematics = m.text("kinematics", false, {"small_strain", "updated_lagrangian"})
                               .value_or("small_strain") == "updated_lagrangian"
                       ? Kinematics::updated_lagrangian
                       : Kinematics::small_strain;
    // Absent: the automatic defaults (resolve_automatic_options in solver/settings.hpp).
    c.hourglass = m.real("hourglass", false, "0.02", [](double e) { return e >= 0.0 && e < 1.0; },
                         "must lie in [0, 1)").value_or(kAutomaticOption);
    c.hourglass_stiffness =
        m.real("hourglass_stiffness", false, "0.05", [](double k) { return k >= 0.0 && k <= 1.0; },
               "must lie in [0, 1]").value_or(kAutomaticOption);
    c.hourglass_kick = m.text("hourglass_kick", false, {"predicted", "midpoint"}).value_or("predicted");
    c.hourglass_reference = m.text("hourglass_reference", false, {"flow", "initial"}).value_or("flow");
    const std::string wall =
        m.text("velocity_wall", false, {"automatic", "characteristics", "wall_gradient"}).value_or("automatic");
    c.velocity_wall = wall == "wall_gradient"     ? CaseFile::VelocityWall::wall_gradient
                      : wall == "characteristics" ? CaseFile::VelocityWall::characteristics
                                                  : CaseFile::VelocityWall::automatic;
    const std::optional<bool> extrapolation = m.boolean("surface_extrapolation");
    c.surface_extrapolation = !extrapolation ? Toggle::automatic : *extrapolation ? Toggle::on : Toggle::off;
    const std::optional<bool> volumetric = m.boolean("volumetric_average");
    c.volumetric_average = !volumetric ? Toggle::automatic : *volumetric ? Toggle::on : Toggle::off;
    if (c.volumetric_average == Toggle::on && !(c.dimension >= 2 && pressure_independent_yield(c)))
      context.invalid(m.get("volumetric_average", false, ""), m.path("volumetric_average"),
                      "applies to a plastic material whose yield does not depend on the pressure (model = \"j2\", "
                      "\"johnson_cook\", or \"drucker_prager\" with friction_angle = 0 and no tension_cutoff) in "
                      "dimension 3 or in plane strain: leave the key out");
    c.material_velocity_motion = m.boolean("material_velocity_motion").value_or(true);
    c.surface_motion = m.text("surface_motion", false, {"linear", "shepard"}).value_or("linear");
    c.conservative_momentum = m.boolean("conservative_momentum").value_or(false);
    c.deficient_stencils =
        m.text("deficient_stencils", false, {"keep", "widen", "widen_motion", "complete"}).value_or("keep");
    c.kernel_configuration =
        m.text("kernel_configuration", false, {"current", "reference"}).value_or("reference");
    const std::optional<bool> free_edges = m.boolean("free_edge_uniaxial");
    c.free_edge_uniaxial = !free_edges ? Toggle::automatic : *free_edges ? Toggle::on : Toggle::off;
    if (c.free_edge_uniaxial == Toggle::on && c.dimension != 3)
      context.invalid(m.get("free_edge_uniaxial", false, ""), m.path("free_edge_uniaxial"),
                      "applies to dimension = 3 only (the edges between two free faces)");
    c.body_force = m.numbers("body_force", false, dim, "m/s^2, one per axis")
                       .value_or(std::vector<double>(dim, 0.0));
    m.finish();
  }
  {  // [solver]
    Table v = top.table("solver", false);
    c.neighbor_search =
        *parse_neighbor_search(v.text("neighbor_search", false, {"auto", "cell_list", "kd_tree"}).value_or("auto"));
    c.transpose_lists = v.boolean("transpose_lists").value_or(false);
    c.neighbor_skin = v.real("neighbor_skin", false, "0.1", [](double s) { return s >= 0.0 && s <= 1.0; },
                             "must lie in [0, 1] (a fraction of the support radius 2h)")
                          .value_or(0.05);  // SolverSettings::neighbor_skin
    c.kernel_cache_mb = v.real("kernel_cache_mb", false, "256", [](double m) { return m >= 0.0 && m <= 1048576.0; },
                               "must lie in [0, 1048576] (MiB; 0: the kernel evaluated at every step)")
                            .value_or(256.0);  // SolverSettings::kernel_cache_bytes
    v.finish();
  }
  {  // [time]
    Table t = top.table("time", true);
    c.end_time = t.real("end", true, "7.5e-3", positive, kPositive + " (s)").value_or(0.0);
    const bool has_cfl = t.has("cfl"), has_dt = t.has("dt");
    c.force = t.boolean("force").value_or(false);
    const bool force = c.force;
    c.cfl = t.real("cfl", false, "0.9", [force](double v) { return v > 0.0 && (v <= 1.0 || (force && v <= 4.0)); },
                   force ? "must lie in (0, 4]: positive (dt = cfl dx / c_p), at most 4 with time.force = true"
                         : "must lie in (0, 1]: positive (dt = cfl dx / c_p), and at most 1 (the two-step scheme is "
                           "unstable above CFL 1; time.force = true runs it anyway, to study the instability)").value_or(0.0);
    c.dt = t.real("dt", false, "1e-5", positive, kPositive + " (s)").value_or(0.0);
    c.adaptive_time_step = t.boolean("adaptive").value_or(false);
    if (c.adaptive_time_step && (has_dt || c.kinematics != Kinematics::updated_lagrangian))
      context.invalid(t.get("adaptive", false, ""), t.path("adaptive"),
                      has_dt ? "needs time.cfl, not a fixed time.dt: the step is cfl x dx lambda_min / c_p"
                             : "applies to method.kinematics = \"updated_lagrangian\" only (in small strain the "
                               "particles keep their spacing): remove it or move the particles");
    if (has_cfl && has_dt)
      context.errors.push_back(context.where(t.get("dt", false, "")) +
                               "time.cfl and time.dt are both given: keep one of them");
    if (!has_cfl && !has_dt && t.present())
      context.errors.push_back(context.where(t.self()) +
                               "missing required key time.cfl (or time.dt) in [time]: add e.g. cfl = 0.9");
    t.finish();
  }
  for (Table b : top.tables("boundary")) {
    BoundarySpec s;
    s.name = b.text("name", true).value_or("");
    s.type = b.text("type", true, {"fixed", "free", "velocity", "traction", "symmetry", "mirror"}).value_or("");
    if (b.has("region") && b.get("region", false, "")->is_array()) {
      // A list of regions: their union.
      for (Table r : b.tables("region")) s.regions.push_back(read_region(r, dim));
      if (s.regions.empty())
        context.invalid(b.get("region", false, ""), b.path("region"), "must hold at least one region");
    } else {
      s.regions.push_back(read_region(b.table("region", true), dim));
    }
    if (s.type == "velocity" || s.type == "traction" || (s.type == "symmetry" && b.has("value"))) {
      // A symmetry plane may move (a smooth rigid wall, a footing): value is its velocity.
      s.value = b.numbers("value", true, dim, s.type == "traction" ? "Pa, sigma . n" : "m/s")
                    .value_or(std::vector<double>(dim, 0.0));
      s.time = read_time_function(b.table("time", false));
      s.profile = b.text("profile", false, {"uniform", "cantilever_shear"}).value_or("uniform");
      if (s.profile == "cantilever_shear" && (s.type != "traction" || c.dimension < 2 || c.box_lower.empty()))
        context.invalid(b.get("profile", false, ""), b.path("profile"),
                        "needs a traction condition on a single-box geometry in 2D or 3D");
    } else {
      s.value.assign(dim, 0.0);
    }
    if (b.has("velocity_gradient")) {  // v = value + G x or f(t) G x (engine/affine_motion.hpp)
      if (s.type != "velocity") {
        context.invalid(b.get("velocity_gradient", false, ""), b.path("velocity_gradient"),
                        "applies to type = \"velocity\" only (v = value + G x); remove it or "
                        "change the type");
      } else {
        s.velocity_gradient = b.numbers("velocity_gradient", true, dim * dim, "row by row, 1/s")
                                  .value_or(std::vector<double>{});
        const bool moving_value = std::any_of(s.value.begin(), s.value.end(), [](double v) { return v != 0.0; });
        if (!s.velocity_gradient.empty() && moving_value && s.time.type != "constant")
          context.invalid(b.get("velocity_gradient", false, ""), b.path("velocity_gradient"),
                          "needs time.type = \"constant\" when value is non-zero (the motion of "
                          "v = value + G x is integrated exactly only for a constant value; with "
                          "value = zeros the time function scales G: v = f(t) G x); set "
                          "value = zeros or remove the time function");
        if (!s.velocity_gradient.empty() && s.profile != "uniform")
          context.invalid(b.get("velocity_gradient", false, ""), b.path("velocity_gradient"),
                          "cannot be combined with profile = \"" + s.profile + "\"");
      }
    }
    if (s.type == "mirror" && !(s.regions.size() == 1 && s.regions[0].type == "half_space"))
      context.invalid(b.get("region", false, ""), b.path("region"),
                      "a mirror plane is one half_space region (its point on the plane, its normal out of the "
                      "body): region = { type = \"half_space\", point = [...], normal = [...] }");
    const bool by_group = std::any_of(s.regions.begin(), s.regions.end(),
                                      [](const RegionSpec& r) { return r.type == "group"; });
    if (by_group && c.particle_file.empty())
      context.invalid(b.self(), b.path("region.type"), "'group' needs geometry.particle_file (groups are a column of it)");
    b.finish();
    c.boundaries.push_back(std::move(s));
  }
  {  // [initial]
    Table i = top.table("initial", false);
    c.initial_velocity = i.numbers("velocity", false, dim, "m/s").value_or(std::vector<double>(dim, 0.0));
    c.velocity_gradient = i.numbers("velocity_gradient", false, dim * dim, "row by row, 1/s")
                              .value_or(std::vector<double>(dim * dim, 0.0));
    const std::size_t stress_count = dim == 1 ? 1 : dim == 2 ? 4 : dim == 3 ? 6 : 0;
    c.initial_stress = i.numbers("stress", false, stress_count,
                                 dim == 2 ? "xx, yy, xy, zz (Pa)" : "xx, yy, zz, xy, yz, zx (Pa)")
                           .value_or(std::vector<double>(stress_count, 0.0));
    if (dim == 2 && c.plane_mode == PlaneMode::plane_stress && c.initial_stress.size() == 4 && c.initial_stress[3] != 0.0)
      context.invalid(i.get("stress", false, ""), i.path("stress"),
                      "has sigma_zz = " + format_number(c.initial_stress[3]) +
                          " in plane stress, where sigma_zz = 0: set the fourth component to 0, or "
                          "material.plane = \"strain\"");
    auto nonzero = [&](Table& profile, const std::string& key, const std::vector<double>& v) {
      if (v.size() == dim && std::all_of(v.begin(), v.end(), [](double x) { return x == 0.0; }))
        context.invalid(profile.get(key, false, ""), profile.path(key), "must be non-zero");
    };
    // A beam's mode shape along an axis (docs/cases.md, [initial.profile]).
    auto read_shape = [&](Table& profile, const std::string& type) {
      VelocityShape s;
      s.type = type;
      s.origin = profile.numbers("origin", false, dim, "the clamp's point on the axis, m")
                     .value_or(std::vector<double>(dim, 0.0));
      s.axis = profile.numbers("axis", true, dim, "along the beam, from the clamp to the free end")
                   .value_or(std::vector<double>(dim, 0.0));
      nonzero(profile, "axis", s.axis);
      s.length = profile.real("length", true, "0.2", positive, kPositive + " (the beam's length L, m)").value_or(1.0);
      if (type == "cantilever_mode") {
        if (dim < 2)
          context.invalid(profile.get("type", false, ""), profile.path("type"),
                          "'cantilever_mode' needs dimension 2 or 3 (a bending mode)");
        s.amplitude = profile.numbers("amplitude", true, dim, "the tip's velocity, m/s")
                          .value_or(std::vector<double>(dim, 0.0));
        s.mode = profile.integer("mode", false, "1", [](std::int64_t n) { return n >= 1 && n <= 20; },
                                 "must be an integer from 1 to 20 (1: the first bending mode)")
                     .value_or(1);
      } else {  // twist
        if (dim != 3)
          context.invalid(profile.get("type", false, ""), profile.path("type"),
                          "'twist' needs dimension = 3 (a rotation about the axis)");
        s.angular_velocity = profile.real("angular_velocity", true, "34.0", {}, "").value_or(0.0);
      }
      profile.finish();
      c.velocity_shapes.push_back(std::move(s));
    };
    auto read_profile = [&](Table profile) {
      VelocityWave w;
      const std::string type =
          profile.text("type", true, {"sine", "cantilever_mode", "twist"}).value_or("");
      if (type.empty()) return;  // reported; its other keys depend on the type
      if (type != "sine") {
        read_shape(profile, type);
        return;
      }
      w.amplitude = profile.numbers("amplitude", true, dim, "the velocity vector at the crests, m/s")
                        .value_or(std::vector<double>(dim, 0.0));
      w.direction = profile.numbers("direction", true, dim, "along which the profile varies")
                        .value_or(std::vector<double>(dim, 0.0));
      nonzero(profile, "direction", w.direction);
      w.wavelength = profile.real("wavelength", true, "2.0", positive, kPositive + " (m)").value_or(1.0);
      w.phase = profile.real("phase", false, "1.5707963267948966").value_or(0.0);
      profile.finish();
      c.velocity_waves.push_back(std::move(w));
    };
    if (i.has("profile") && i.get("profile", false, "")->is_array()) {
      // Several profiles ([[initial.profile]]): their sum.
      for (Table profile : i.tables("profile")) read_profile(profile);
    } else {
      Table profile = i.table("profile", false);
      if (profile.present()) read_profile(profile);
    }
    i.finish();
  }
  {  // [damping]
    Table d = top.table("damping", false);
    c.damping = d.real("coefficient", false, "40", non_negative, "must be >= 0 (1/s)").value_or(0.0);
    c.rest_velocity = d.real("rest_velocity", false, "1e-6", non_negative, "must be >= 0 (m/s)").value_or(0.0);
    c.rest_kinetic_energy = d.real("rest_kinetic_energy", false, "5e-4", non_negative,
                                   "must be >= 0 (J; per unit thickness in 2D)").value_or(0.0);
    c.rest_after = d.real("rest_after", false, "0.4", non_negative, "must be >= 0 (s)").value_or(0.0);
    c.rest_probe = d.text("rest_probe", false).value_or("");
    d.finish();
  }
  {  // [output]
    Table o = top.table("output", false);
    c.output_times = o.numbers("times", false, 0, "").value_or(std::vector<double>{});
    for (std::size_t k = 0; k < c.output_times.size(); ++k)
      if (!(c.output_times[k] > 0.0 && c.output_times[k] <= c.end_time * (1.0 + 1e-12)) ||
          (k > 0 && !(c.output_times[k] > c.output_times[k - 1]))) {
        context.invalid(o.get("times", false, ""), o.path("times"),
                        "each must lie in (0, time.end = " + format_number(c.end_time) +
                            "], in increasing order");
        break;
      }
    c.output_every = o.integer("every", false, "100", [](std::int64_t n) { return n >= 0; },
                               "must be >= 0 (steps; 0: only the listed times)").value_or(0);
    c.fields = o.strings("fields", known_output_fields()).value_or(known_output_fields());
    if (o.has("fields") && c.has_field("plastic") && c.plasticity.model == "elastic")
      context.invalid(o.get("fields", false, ""), o.path("fields"),
                      "lists \"plastic\" (plastic_strain, plastic_work, temperature, yielding), which needs a "
                      "plastic material.model (j2, johnson_cook, drucker_prager)");
    c.output_virtual = o.boolean("virtual").value_or(false);
    c.probe_every = o.integer("probe_every", false, "10", [](std::int64_t n) { return n >= 1; },
                              "must be >= 1 (steps)").value_or(1);
    c.energy_every = o.integer("energy_every", false, "10", [](std::int64_t n) { return n >= 0; },
                               "must be >= 0 (steps; 0: no energy ledger and no energy.csv)").value_or(10);
    c.checkpoint_every = o.integer("checkpoint_every", false, "1000", [](std::int64_t n) { return n >= 0; },
                                   "must be >= 0 (steps; 0: a checkpoint only when interrupted)").value_or(0);
    for (Table p : o.tables("probe")) {
      ProbeSpec s;
      s.name = p.text("name", true).value_or("");
      for (const char ch : s.name)
        if (!std::isalnum(static_cast<unsigned char>(ch)) && ch != '_' && ch != '-') {
          context.invalid(p.get("name", false, ""), p.path("name"), "must use letters, digits, '_' or '-' only (it names a file)");
          break;
        }
      if (p.has("point") == p.has("particle"))
        context.errors.push_back(context.where(p.self()) + p.path("") +
                                 " needs exactly one of point = [...] or particle = ID");
      if (p.has("point")) s.point = p.numbers("point", true, dim, "one per axis").value_or(std::vector<double>{});
      if (p.has("particle"))
        s.particle = p.integer("particle", true, "0", [](std::int64_t i) { return i >= 0; }, "must be >= 0").value_or(-1);
      p.finish();
      c.probes.push_back(std::move(s));
    }
    o.finish();
  }
  {  // [exact]
    Table e = top.table("exact", false);
    c.exact = e.text("solution", e.present(), {"bar", "cantilever"}).value_or("");
    if (c.exact == "bar") {
      if (c.dimension != 1 || c.box_lower.empty())
        context.invalid(e.get("solution", false, ""), e.path("solution"), "'bar' needs dimension = 1 and a single box");
      c.bar_amplitude = e.real("v0", true, "1.0").value_or(0.0);
      c.bar_pulse_duration = e.real("t0", true, "2.5e-3", positive, kPositive + " (s)").value_or(0.0);
      c.bar_left_end = e.text("left_end", false, {"fixed", "free"}).value_or("fixed");
    } else if (c.exact == "cantilever") {
      bool shear = false;
      for (const auto& b : c.boundaries) shear = shear || b.profile == "cantilever_shear";
      if (c.dimension < 2 || c.box_lower.empty() || !shear)
        context.invalid(e.get("solution", false, ""), e.path("solution"),
                        "'cantilever' needs dimension 2 or 3, a single box, and a boundary with profile = "
                        "\"cantilever_shear\" (its value[1] is the load P)");
    }
    e.finish();
  }
  if (!c.rest_probe.empty() &&
      std::none_of(c.probes.begin(), c.probes.end(), [&](const ProbeSpec& p) { return p.name == c.rest_probe; }))
    context.errors.push_back(path + ": damping.rest_probe = '" + c.rest_probe +
                             "' is invalid: name one of the [[output.probe]] entries");
  top.finish();
  for (auto& m : whole_case_errors(c)) context.errors.push_back(std::move(m));  // issue 15
  if (!context.errors.empty()) throw CaseError(context.errors);
  return c;
}

}  // namespace
}  // namespace tsph
