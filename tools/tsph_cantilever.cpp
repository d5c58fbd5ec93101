// tsph-cantilever: the cantilever beam of seed section 4.2 (2D, plane stress or plane
// strain) and its 3D counterpart, run to rest by a load ramp and damping.
//
//   tsph-cantilever [--dim 2|3] [--plane stress|strain] [--nx 101] [options]
//
// Writes axis.csv (x, u_y, exact u_y), particles.csv (every real particle: initial
// position, displacement, stress), history.csv (time, tip u_y, kinetic energy every
// 0.02 s) and summary.json (tip deflection against the exact
// value, L2 error along the axis, steps, wall time, particle-steps per second).
// Exit status: 0 success (converged), 2 bad input, 3 not converged or diverged (the
// diagnosis on stderr; the files then hold the last good state, recorded every 0.02 s
// of simulated time, and summary.json says "status": "diverged"), 1 other failure (an
// output write).
#include "engine/cantilever_case.hpp"
#include "engine/output_file.hpp"
#include "engine/parallel.hpp"
#include "tools/cli_common.hpp"

#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <chrono>
#include <cmath>
#include <exception>
#include <filesystem>
#include <optional>
#include <string>

namespace {

using namespace tsph;

using cli::kExitBadInput;
using cli::kExitNotConverged;

/// The text of a JSON string (without the quotes).
std::string json_escape(const std::string& text) {
  std::string out;
  for (char ch : text) {
    if (ch == '"' || ch == '\\') out += '\\';
    if (static_cast<unsigned char>(ch) < 0x20) out += ' ';
    else out += ch;
  }
  return out;
}

struct Options {
  int dim = 2;
  std::string plane = "stress";
  std::string kernel = "cubic_spline";
  std::string kinematics = "small_strain";
  int nodes_x = 101;
  double length = 1.0, depth = 0.1, width = 0.1;
  double young = 8e7, poisson = 0.3, density = 2000.0;
  double load = 0.0;  // 0: the case's default (1000 N in 2D, 100 N in 3D)
  double alpha = 0.6, cfl = 0.9, damping = -1.0, ramp = -1.0, hourglass = 0.02;
  // The next ones default to the case's (CantileverSettings): the wall clamp, the
  // stiffness 0.05 and the surface extrapolation, and in 3D the free edges' uniaxial
  // stress.
  std::optional<double> hourglass_stiffness;
  std::string clamp = "default";
  bool surface_extrapolation = false, no_surface_extrapolation = false;
  bool free_edge_uniaxial = false, no_free_edge_uniaxial = false;
  double end_time = 3.0, tolerance = 1e-5, kinetic_tolerance = 1e-5;
  std::string out = "out/cantilever";
  int threads = 0;
  bool quiet = false;
  bool force = false;
};

/// Writes axis.csv, particles.csv and summary.json of a result (each file whole or not
/// at all: write_file_atomically).
/// The clamp's name on the command line.
template <int Dim>
const char* clamp_name(const CantileverSettings<Dim>& s) {
  return s.clamp == SolverSettings<Dim>::VelocityWall::wall_gradient ? "wall-gradient" : "characteristics";
}

template <int Dim>
void write_results(const Options& o, const CantileverSettings<Dim>& s, const CantileverResult& r,
                   const std::string& status, const std::string& message) {
  const double dx = s.spacing();
  const std::filesystem::path out(o.out);
  std::string axis = "x,uy,uy_exact\n";
  for (std::size_t k = 0; k < r.axis_x.size(); ++k)
    fmt::format_to(std::back_inserter(axis), "{:.17g},{:.17g},{:.17g}\n", r.axis_x[k],
                   r.axis_uy[k], r.axis_exact[k]);
  write_file_atomically(out / "axis.csv", axis);
  std::string particles = "x0,y0,z0,ux,uy,uz,vx,vy,vz,s0,s1,s2,s3,s4,s5\n";
  for (std::size_t i = 0; i < r.initial_position.size(); ++i) {
    const auto& x = r.initial_position[i];
    const auto& u = r.displacement[i];
    const auto& v = r.velocity[i];
    const auto& sg = r.stress[i];
    fmt::format_to(std::back_inserter(particles), "{:.10g},{:.10g},{:.10g},{:.10g},{:.10g},{:.10g},{:.6g},{:.6g},{:.6g},{:.10g},{:.10g},{:.10g},{:.10g},{:.10g},{:.10g}\n",
                    x[0], x[1], x[2], u[0], u[1], u[2], v[0], v[1], v[2], sg[0], sg[1], sg[2], sg[3], sg[4], sg[5]);
  }
  write_file_atomically(out / "particles.csv", particles);
  std::string history = "t,tip_uy,kinetic_energy\n";
  for (const auto& h : r.history)
    fmt::format_to(std::back_inserter(history), "{:.9g},{:.9e},{:.6e}\n", h[0], h[1], h[2]);
  write_file_atomically(out / "history.csv", history);
  write_file_atomically(out / "summary.json", fmt::format(
      "{{\"case\": \"cantilever\", \"dim\": {}, \"plane\": \"{}\", \"nodes\": [{}, {}, {}],\n"
      " \"dx\": {:.17g}, \"alpha\": {}, \"cfl\": {}, \"kernel\": \"{}\", \"kinematics\": \"{}\",\n"
      " \"hourglass\": {}, \"hourglass_stiffness\": {}, \"clamp\": \"{}\", \"surface_extrapolation\": {},\n"
      " \"free_edge_uniaxial\": {}, \"tolerance\": {}, \"kinetic_tolerance\": {},\n"
      " \"real_particles\": {}, \"virtual_particles\": {},\n"
      " \"status\": \"{}\", \"message\": \"{}\",\n"
      " \"converged\": {}, \"time\": {:.6f}, \"steps\": {}, \"dt\": {:.6e},\n"
      " \"tip_deflection\": {:.9e}, \"tip_exact\": {:.9e}, \"tip_error_percent\": {:.6f},\n"
      " \"axis_l2_error_percent\": {:.6f}, \"kinetic_energy\": {:.6e}, \"load_work\": {:.6e},\n"
      " \"wall_seconds\": {:.3f},\n"
      " \"particle_steps_per_second\": {:.6e}, \"threads\": {},\n"
      " \"gradient_fallbacks\": {}, \"interpolation_fallbacks\": {}}}\n",
      Dim, Dim == 2 ? o.plane : "none", s.nodes_x, s.nodes_y, Dim == 3 ? s.nodes_z : 1, dx,
      s.alpha, s.cfl, o.kernel, o.kinematics,
      s.hourglass, s.hourglass_stiffness, clamp_name(s), s.surface_extrapolation, s.free_edge_uniaxial, s.tolerance,
      s.kinetic_tolerance, r.real_particles, r.virtual_particles,
      status, message, r.converged, r.time, r.steps, r.time_step, r.tip_deflection, r.tip_exact,
      r.tip_error_percent, r.axis_l2_error_percent, r.kinetic_energy, r.load_work, r.wall_seconds, r.particle_steps_per_second,
      thread_count(), r.counters.gradient_fallbacks, r.counters.interpolation_fallbacks));
}

template <int Dim>
int run(const Options& o) {
  CantileverSettings<Dim> s;
  s.length = o.length;
  s.depth = o.depth;
  s.width = o.width;
  s.nodes_x = o.nodes_x;
  const double dx = o.length / (o.nodes_x - 1);
  s.nodes_y = static_cast<int>(std::lround(o.depth / dx)) + 1;
  s.nodes_z = static_cast<int>(std::lround(o.width / dx)) + 1;
  s.young_modulus = o.young;
  s.poisson_ratio = o.poisson;
  s.density = o.density;
  if (o.load != 0.0) s.load = o.load;
  s.plane_mode = o.plane == "strain" ? PlaneMode::plane_strain : PlaneMode::plane_stress;
  s.alpha = o.alpha;
  s.cfl = o.cfl;
  s.force = o.force;
  s.kernel = *parse_kernel_kind(o.kernel);
  s.kinematics = o.kinematics == "small_strain" ? Kinematics::small_strain
                                                : Kinematics::updated_lagrangian;
  s.damping = o.damping;
  s.ramp_time = o.ramp;
  s.hourglass = o.hourglass;
  if (o.hourglass_stiffness) s.hourglass_stiffness = *o.hourglass_stiffness;
  if (o.clamp != "default")
    s.clamp = o.clamp == "wall-gradient" ? SolverSettings<Dim>::VelocityWall::wall_gradient
                                         : SolverSettings<Dim>::VelocityWall::characteristics;
  if (o.surface_extrapolation) s.surface_extrapolation = true;
  if (o.no_surface_extrapolation) s.surface_extrapolation = false;
  if (o.free_edge_uniaxial) s.free_edge_uniaxial = true;
  if (o.no_free_edge_uniaxial) s.free_edge_uniaxial = false;
  s.end_time = o.end_time;
  s.tolerance = o.tolerance;
  s.kinetic_tolerance = o.kinetic_tolerance;
  if (const auto errors = validate(s); !errors.empty()) {
    for (const auto& e : errors) fmt::print(stderr, "tsph-cantilever: error: {}\n", e.message());
    return kExitBadInput;
  }
  const CantileverExact<Dim> exact(s);
  if (!o.quiet) {
    fmt::print("{}D cantilever{}: {} x {}{} real particles, dx = {} m, alpha = {}, CFL = {}, "
               "hourglass = {}, hourglass stiffness = {}, clamp: {}, surface extrapolation {}{}, {}\n",
               Dim, Dim == 2 ? (o.plane == "strain" ? " (plane strain)" : " (plane stress)") : "",
               s.nodes_x, s.nodes_y, Dim == 3 ? fmt::format(" x {}", s.nodes_z) : "", dx, s.alpha,
               s.cfl, s.hourglass, s.hourglass_stiffness, clamp_name(s),
               s.surface_extrapolation ? "on" : "off",
               Dim == 3 ? (s.free_edge_uniaxial ? ", free edges uniaxial" : ", free edges NOT uniaxial") : "",
               o.kinematics);
    fmt::print("exact tip deflection {:.6f} m; first mode period {:.3f} s\n",
               exact.tip_deflection(), 2.0 * M_PI / s.first_mode_frequency());
    auto last = std::make_shared<std::chrono::steady_clock::time_point>(std::chrono::steady_clock::now());
    const double end = s.end_time;
    s.progress = [last, end](double t, double tip, double kinetic) {
      const auto now = std::chrono::steady_clock::now();
      if (std::chrono::duration<double>(now - *last).count() < 2.0) return;
      *last = now;
      fmt::print("  t = {:.3f} s ({:4.1f} % of the time limit)   tip u_y = {:.6f} m   kinetic {:.3e} J\n",
                 t, 100.0 * t / end, tip, kinetic);
      std::fflush(stdout);
    };
  }
  CantileverResult r;
  try {
    r = run_cantilever(s);
  } catch (const CantileverDiverged& e) {
    // Keep the last good state (issue 6), as tsph keeps its last frame.
    write_results<Dim>(o, s, e.last_good, "diverged", json_escape(e.what()));
    throw;
  }
  write_results<Dim>(o, s, r, r.converged ? "converged" : "not_converged", "");
  if (!o.quiet) {
    fmt::print("{} after {} steps (t = {:.3f} s), {:.1f} s wall, {:.3e} particle-steps/s\n",
               r.converged ? "converged" : "NOT converged", r.steps, r.time, r.wall_seconds,
               r.particle_steps_per_second);
    fmt::print("tip deflection {:.6f} m, exact {:.6f} m: error {:.3f} %; L2 error of u_y along "
               "the axis {:.3f} %; kinetic energy {:.3e} J ({:.2e} of the load's work)\noutput in {}\n",
               r.tip_deflection, r.tip_exact, r.tip_error_percent, r.axis_l2_error_percent,
               r.kinetic_energy, r.kinetic_energy / r.load_work, o.out);
  }
  return r.converged ? 0 : kExitNotConverged;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  CLI::App app{"tsph-cantilever: the cantilever beam of the Taylor-SPH seed paper (section 4.2)"};
  app.add_option("--dim", o.dim, "2 or 3")->capture_default_str()->check(CLI::IsMember({2, 3}));
  app.add_option("--plane", o.plane, "2D model: stress | strain")
      ->capture_default_str()->check(CLI::IsMember({"stress", "strain"}));
  app.add_option("--nx", o.nodes_x, "real particles along the length (dx = L / (nx - 1))")
      ->capture_default_str();
  app.add_option("--length", o.length, "L (m)")->capture_default_str();
  app.add_option("--depth", o.depth, "D (m), along the load")->capture_default_str();
  app.add_option("--width", o.width, "B (m), 3D only")->capture_default_str();
  app.add_option("--E", o.young, "Young's modulus (Pa)")->capture_default_str();
  app.add_option("--nu", o.poisson, "Poisson's ratio, in (-1, 0.5)")->capture_default_str();
  app.add_option("--rho", o.density, "density (kg/m^3)")->capture_default_str();
  app.add_option("--load", o.load, "end load P (N); 0: 1000 in 2D, 100 in 3D")->capture_default_str();
  app.add_option("--alpha", o.alpha, "h / dx")->capture_default_str();
  app.add_option("--cfl", o.cfl, "dt = CFL dx / c_p, in (0, 1]")->capture_default_str();
  app.add_option("--kernel", o.kernel, "cubic_spline | wendland_c2 | quintic_spline")
      ->capture_default_str()->check(CLI::IsMember({"cubic_spline", "wendland_c2", "quintic_spline"}));
  app.add_option("--kinematics", o.kinematics, "small_strain | updated_lagrangian (2D cantilever: at rest but too stiff, 2.7 % at 101 x 11; README, Known problems)")
      ->capture_default_str()->check(CLI::IsMember({"updated_lagrangian", "small_strain"}));
  app.add_option("--damping", o.damping, "velocity damping c (1/s); < 0: 2 omega_1")
      ->capture_default_str();
  app.add_option("--ramp", o.ramp, "load ramp time (s); < 0: one first-mode period")
      ->capture_default_str();
  app.add_option("--hourglass", o.hourglass, "surface hourglass filter coefficient in [0, 1)")
      ->capture_default_str();
  app.add_option("--hourglass-stiffness", o.hourglass_stiffness,
                 "hourglass stiffness kappa in [0, 1] (0: off; force on the real modes the virtual "
                 "particles cannot see; diverges above about 0.25 at alpha 0.6, CFL 0.9). "
                 "Default: 0.05");
  app.add_option("--clamp", o.clamp,
                 "stress of the clamped particles: characteristics | wall-gradient (bulk update "
                 "with the half-step velocity gradient taken relative to the wall velocity). "
                 "Default: wall-gradient")
      ->check(CLI::IsMember({"characteristics", "wall-gradient"}));
  auto* extrapolate = app.add_flag(
      "--surface-extrapolation", o.surface_extrapolation,
      "free-surface tangential velocity gradient extrapolated from the virtual row to the surface "
      "(SolverSettings::surface_extrapolation). Default: on");
  app.add_flag("--no-surface-extrapolation", o.no_surface_extrapolation,
               "turn the surface extrapolation off (the 2D defaults before 2026-11-23: --clamp "
               "characteristics --hourglass-stiffness 0 --no-surface-extrapolation)")
      ->excludes(extrapolate);
  auto* uniaxial = app.add_flag(
      "--free-edge-uniaxial", o.free_edge_uniaxial,
      "3D: the particles on an edge between two free faces take the uniaxial stress along the edge "
      "(SolverSettings::free_edge_uniaxial). Default: on in 3D (refused in 2D)");
  app.add_flag("--no-free-edge-uniaxial", o.no_free_edge_uniaxial,
               "3D: turn it off (the edges then carry the shear force: -86 % at 41 x 5 x 5; README, "
               "Known problems)")
      ->excludes(uniaxial);
  app.add_option("--end-time", o.end_time, "simulated time limit (s)")->capture_default_str();
  app.add_option("--tolerance", o.tolerance,
                 "rest criterion: tip speed below this x (exact tip deflection / first-mode period)")
      ->capture_default_str();
  app.add_option("--kinetic-tolerance", o.kinetic_tolerance,
                 "rest criterion, also: kinetic energy below this x P x exact tip deflection")
      ->capture_default_str();
  app.add_option("--out", o.out, "output directory")->capture_default_str();
  app.add_option("--threads", o.threads, "OpenMP threads (0: OpenMP default)");
  app.add_flag("--force", o.force,
               "run a CFL above the stability limit 1 anyway (it diverges: exit status 3)");
  app.add_flag("--quiet", o.quiet, "print nothing but errors");
  if (const auto stop = cli::parse(app, argc, argv)) return *stop;
  if (o.nodes_x < 3) {
    fmt::print(stderr, "tsph-cantilever: error: nx = {} is invalid: needs at least 3\n", o.nodes_x);
    return kExitBadInput;
  }
  set_thread_count(o.threads);
  if (!cli::prepare_output_directory("tsph-cantilever", o.out)) return kExitBadInput;
  try {
    return o.dim == 2 ? run<2>(o) : run<3>(o);
  } catch (const std::invalid_argument& e) {
    fmt::print(stderr, "tsph-cantilever: error: {}\n", e.what());
    return kExitBadInput;
  } catch (const SolutionDiverged& e) {
    fmt::print(stderr, "tsph-cantilever: stopped: {}\n", e.what());
    return cli::kExitDiverged;
  } catch (const OutputError& e) {
    fmt::print(stderr, "tsph-cantilever: stopped: {}\n", e.what());
    return cli::kExitFailure;
  } catch (const std::exception& e) {
    fmt::print(stderr, "tsph-cantilever: failed: {}\n", e.what());
    return cli::kExitFailure;
  }
}
