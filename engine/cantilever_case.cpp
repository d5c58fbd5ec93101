#include "engine/cantilever_case.hpp"

#include "engine/bar_case.hpp"  // relative_l2_percent

#include "engine/lattice.hpp"
#include "engine/region.hpp"

#include <chrono>
#include <cmath>
#include <stdexcept>

namespace tsph {
template <int Dim>
double CantileverSettings<Dim>::second_moment() const {
  const double thickness = Dim == 2 ? 1.0 : width;
  return thickness * depth * depth * depth / 12.0;
}

template <int Dim>
double CantileverSettings<Dim>::first_mode_frequency() const {
  const double area = Dim == 2 ? depth : depth * width;
  const double beta = 1.875104 / length;
  return beta * beta * std::sqrt(young_modulus * second_moment() / (density * area));
}

template <int Dim>
std::vector<InputError> validate(const CantileverSettings<Dim>& s) {
  std::vector<InputError> errors;
  auto positive = [&](const char* name, double value) { require_positive(errors, name, value); };
  positive("length", s.length);
  positive("depth", s.depth);
  if (Dim == 3) positive("width", s.width);
  positive("young_modulus", s.young_modulus);
  positive("density", s.density);
  positive("end_time", s.end_time);
  positive("tolerance", s.tolerance);
  positive("kinetic_tolerance", s.kinetic_tolerance);
  if (!(s.poisson_ratio > -1.0 && s.poisson_ratio < 0.5))
    errors.push_back({"poisson_ratio", format_number(s.poisson_ratio), "must lie in (-1, 0.5)"});
  if (!std::isfinite(s.load) || s.load == 0.0)
    errors.push_back({"load", format_number(s.load), "must be finite and non-zero"});
  if (s.nodes_x < 3 || s.nodes_y < 3 || (Dim == 3 && s.nodes_z < 3))
    errors.push_back({"nodes", std::to_string(s.nodes_x) + " x " + std::to_string(s.nodes_y),
                      "needs at least 3 particles along each axis"});
  else {
    const double dx = s.spacing();
    const double dy = s.depth / (s.nodes_y - 1);
    if (std::abs(dy - dx) > 1e-9 * dx)
      errors.push_back({"nodes_y", std::to_string(s.nodes_y),
                        "must give the spacing of x, depth / (nodes_y - 1) = " + format_number(dx)});
    if (s.nodes_y % 2 == 0 || (Dim == 3 && s.nodes_z % 2 == 0))
      errors.push_back({Dim == 3 && s.nodes_y % 2 != 0 ? "nodes_z" : "nodes_y",
                        std::to_string(s.nodes_y % 2 == 0 ? s.nodes_y : s.nodes_z),
                        "must be odd so that a row of particles lies on the beam axis (choose "
                        "nx so that depth / dx is even)"});
    if (Dim == 3 && std::abs(s.width / (s.nodes_z - 1) - dx) > 1e-9 * dx)
      errors.push_back({"nodes_z", std::to_string(s.nodes_z),
                        "must give the spacing of x, width / (nodes_z - 1) = " + format_number(dx)});
  }
  // The largest alpha whose supports still let the solver recognise the particles at
  // the beam's corners as surface particles (the free surfaces and the tip traction
  // need them), on the thinnest beam allowed (nodes_y = 3; deeper beams allow a little
  // more: 2.6-2.7 for the cubic spline). Measured by bisection with tsph-cantilever
  // --nx 21: cubic spline 1.95, Wendland C2 2.14, quintic spline 2.43.
  const double alpha_limit = s.kernel == KernelKind::quintic_spline ? 2.4
                             : s.kernel == KernelKind::wendland_c2  ? 2.1
                                                                    : 1.9;
  if (!(s.alpha > 0.5) || !(s.alpha <= alpha_limit))
    errors.push_back({"alpha", format_number(s.alpha),
                      "must lie in (0.5, " + format_number(alpha_limit) + "] for the " +
                          std::string(to_string(s.kernel)) +
                          " kernel: with a larger support the particles at the beam's corners "
                          "no longer look like surface particles, which the free surface and "
                          "the tip traction need"});
  if (!(s.cfl > 0.0) || !std::isfinite(s.cfl) || (s.cfl > 1.0 && !s.force))
    errors.push_back({"cfl", format_number(s.cfl),
                      "must lie in (0, 1]: the two-step scheme is unstable above CFL 1 "
                      "(force runs it anyway)"});
  if (!(s.hourglass >= 0.0 && s.hourglass < 1.0))
    errors.push_back({"hourglass", format_number(s.hourglass), "must lie in [0, 1)"});
  if (Dim != 3 && s.free_edge_uniaxial)
    errors.push_back({"free_edge_uniaxial", "true", "applies to the edges of the 3D beam only"});
  if (!(s.hourglass_stiffness >= 0.0 && s.hourglass_stiffness <= 1.0))
    errors.push_back({"hourglass_stiffness", format_number(s.hourglass_stiffness),
                      "must lie in [0, 1] (0: off)"});
  return errors;
}

template <int Dim>
double CantileverExact<Dim>::tip_shear(double y) const {
  return s_.load / (2.0 * s_.second_moment()) * (0.25 * s_.depth * s_.depth - y * y);
}

template <int Dim>
double CantileverExact<Dim>::deflection(double x, double y) const {
  const double p = s_.load, l = s_.length, d = s_.depth;
  const double i = s_.second_moment();
  if constexpr (Dim == 2) {
    double e = s_.young_modulus, nu = s_.poisson_ratio;
    if (s_.plane_mode == PlaneMode::plane_strain) {
      e /= 1.0 - nu * nu;
      nu /= 1.0 - nu;
    }
    // Seed eq. (5).
    return p / (6.0 * e * i) *
           (3.0 * nu * y * y * (l - x) + (4.0 + 5.0 * nu) * d * d * x / 4.0 + (3.0 * l - x) * x * x);
  } else {
    (void)y;
    const double shear = s_.young_modulus / (2.0 * (1.0 + s_.poisson_ratio));
    const double area = s_.depth * s_.width;
    return p / (6.0 * s_.young_modulus * i) * (3.0 * l - x) * x * x +
           p * x / (5.0 / 6.0 * shear * area);
  }
}

template <int Dim>
CantileverModel<Dim> make_cantilever(const CantileverSettings<Dim>& s) {
  throw_if_invalid(validate(s));
  using Vec = Vector<Dim>;
  const double dx = s.spacing();
  LatticeBox<Dim> box;
  box.spacing = dx;
  box.lower[0] = 0.0;
  box.lower[1] = -0.5 * s.depth;
  box.node_count[0] = s.nodes_x;
  box.node_count[1] = s.nodes_y;
  if constexpr (Dim == 3) {
    box.lower[2] = -0.5 * s.width;
    box.node_count[2] = s.nodes_z;
  }
  ParticleSet<Dim> real = make_real_lattice(box, s.density);
  ParticleSet<Dim> virtual_particles = make_virtual_lattice(box, s.density);

  const CantileverExact<Dim> exact(s);
  const double omega = s.first_mode_frequency();
  CantileverModel<Dim> model;
  model.period = 2.0 * M_PI / omega;
  model.ramp = s.ramp_time >= 0.0 ? s.ramp_time : model.period;
  const double ramp = model.ramp;
  const TimeFunction load_in_time =
      ramp > 0.0 ? TimeFunction::linear_ramp(1.0, 0.0, ramp) : TimeFunction::constant(1.0);

  // Conditions: free surfaces first, then the loaded tip, then the clamp (later
  // assignments win at the edges).
  std::vector<BoundaryCondition<Dim>> conditions;
  conditions.push_back(BoundaryCondition<Dim>::free("free surface"));
  auto tip_components = BoundaryCondition<Dim>::filled(TimeFunction::constant(0.0));
  tip_components[1] = load_in_time;
  conditions.push_back(BoundaryCondition<Dim>::traction(
      tip_components, "tip shear", [exact](const Vec& x) {
        Vec t = Vec::Zero();
        t[1] = exact.tip_shear(x[1]);
        return t;
      }));
  conditions.push_back(BoundaryCondition<Dim>::fixed("clamp"));
  const double tol = 1e-6 * dx;
  Vec upper;
  for (int d = 0; d < Dim; ++d)
    upper[d] = box.lower[d] + static_cast<double>(box.node_count[d] - 1) * dx;
  for (int d = 1; d < Dim; ++d) {
    assign_boundary(real, Region<Dim>::half_space("top", upper, Vec::Unit(d)), 0, tol);
    assign_boundary(real, Region<Dim>::half_space("bottom", box.lower, Vec(-Vec::Unit(d))), 0, tol);
  }
  assign_boundary(real, Region<Dim>::half_space("tip", upper, Vec::Unit(0)), 1, tol);
  assign_boundary(real, Region<Dim>::half_space("clamp", box.lower, Vec(-Vec::Unit(0))), 2, tol);

  SolverSettings<Dim> settings;
  settings.smoothing_length = s.alpha * dx;
  settings.kernel = s.kernel;
  settings.kinematics = s.kinematics;
  settings.damping = s.damping >= 0.0 ? s.damping : 2.0 * omega;
  settings.hourglass_coefficient = s.hourglass;
  settings.hourglass_stiffness = s.hourglass_stiffness;
  settings.velocity_wall = s.clamp;
  settings.surface_extrapolation = s.surface_extrapolation;
  settings.free_edge_uniaxial = s.free_edge_uniaxial;
  const LinearElastic<Dim> material(s.young_modulus, s.poisson_ratio, s.density, s.plane_mode);
  model.conditions = conditions;
  model.solver = std::make_unique<TaylorSph<Dim>>(std::move(real), std::move(virtual_particles),
                                                  material, settings, conditions);
  model.time_step = s.cfl * dx / material.p_wave_speed(s.density);

  // The tip particle on the axis, and the particles on the axis.
  const auto& r0 = model.solver->real();
  for (std::size_t i = 0; i < r0.size(); ++i) {
    bool on_axis = true;
    for (int d = 1; d < Dim; ++d) on_axis = on_axis && std::abs(r0.initial_position[d][i]) < tol;
    if (!on_axis) continue;
    model.axis.push_back(i);
    if (std::abs(r0.initial_position[0][i] - s.length) < tol) model.tip = i;
  }
  return model;
}

template <int Dim>
CantileverResult run_cantilever(const CantileverSettings<Dim>& s) {
  CantileverModel<Dim> model = make_cantilever(s);
  TaylorSph<Dim>& solver = *model.solver;
  const CantileverExact<Dim> exact(s);
  const double period = model.period, ramp = model.ramp;
  const std::size_t tip = model.tip;
  const std::vector<std::size_t>& axis = model.axis;

  CantileverResult result;
  result.tip_exact = exact.tip_deflection();
  result.time_step = model.time_step;
  result.real_particles = solver.real().size();
  result.virtual_particles = solver.virtual_particles().size();
  const double dt = result.time_step;
  // Converged: after the ramp, the tip moves slower than tolerance x (tip deflection / T1)
  // and the kinetic energy is below kinetic_tolerance x the work of the load.
  const double velocity_tolerance = s.tolerance * std::abs(result.tip_exact) / period;
  result.load_work = std::abs(s.load * result.tip_exact);
  const double kinetic_limit = s.kinetic_tolerance * result.load_work;
  const auto start = std::chrono::steady_clock::now();
  std::int64_t report_every = std::max<std::int64_t>(1, static_cast<std::int64_t>(0.02 / dt));
  // The result of the current state (fields, errors, timing).
  auto collect = [&](CantileverResult& out) {
    const auto stop = std::chrono::steady_clock::now();
    out.wall_seconds = std::chrono::duration<double>(stop - start).count();
    out.time = solver.time();
    out.kinetic_energy = solver.kinetic_energy();
    out.steps = solver.counters().steps;
    out.counters = solver.counters();
    out.particle_steps_per_second = static_cast<double>(out.real_particles) *
                                    static_cast<double>(out.steps) /
                                    std::max(out.wall_seconds, 1e-12);
    const auto& r = solver.real();
    out.tip_deflection = r.displacement[1][tip];
    out.tip_error_percent =
        100.0 * std::abs(out.tip_deflection - out.tip_exact) / std::abs(out.tip_exact);
    out.axis_x.clear();
    out.axis_uy.clear();
    out.axis_exact.clear();
    for (std::size_t i : axis) {
      out.axis_x.push_back(r.initial_position[0][i]);
      out.axis_uy.push_back(r.displacement[1][i]);
      out.axis_exact.push_back(exact.deflection(r.initial_position[0][i], 0.0));
    }
    out.axis_l2_error_percent = relative_l2_percent(out.axis_uy, out.axis_exact);
    out.initial_position.clear();
    out.displacement.clear();
    out.velocity.clear();
    out.stress.clear();
    for (std::size_t i = 0; i < r.size(); ++i) {
      std::array<double, 3> x{}, u{}, v{};
      std::array<double, 6> sigma{};
      for (int d = 0; d < Dim; ++d) {
        x[static_cast<std::size_t>(d)] = r.initial_position[d][i];
        u[static_cast<std::size_t>(d)] = r.displacement[d][i];
        v[static_cast<std::size_t>(d)] = r.velocity[d][i];
      }
      for (int m = 0; m < stress_component_count<Dim>; ++m) sigma[static_cast<std::size_t>(m)] = r.stress[m][i];
      out.initial_position.push_back(x);
      out.displacement.push_back(u);
      out.velocity.push_back(v);
      out.stress.push_back(sigma);
    }
  };
  // The last good state, kept for the output of a run that diverges (issue 6).
  CantileverResult last_good = result;
  collect(last_good);
  std::vector<std::array<double, 3>> history{{0.0, 0.0, 0.0}};
  while (solver.time() < s.end_time) {
    try {
      solver.step(dt);
    } catch (const SolutionDiverged& e) {
      throw CantileverDiverged(e.what(), std::move(last_good));
    }
    const double tip_velocity = std::abs(solver.real().velocity[1][tip]);
    if (solver.counters().steps % report_every == 0) {
      const double kinetic = solver.kinetic_energy();
      if (s.progress) s.progress(solver.time(), solver.real().displacement[1][tip], kinetic);
      history.push_back({solver.time(), solver.real().displacement[1][tip], kinetic});
      collect(last_good);
      last_good.history = history;
    }
    // The kinetic energy (a sum over the particles) only once the tip is slow.
    if (solver.time() > ramp + 0.25 * period && tip_velocity < velocity_tolerance &&
        solver.kinetic_energy() < kinetic_limit) {
      result.converged = true;
      break;
    }
  }
  collect(result);
  history.push_back({solver.time(), solver.real().displacement[1][tip], solver.kinetic_energy()});
  result.history = std::move(history);
  return result;
}

template struct CantileverSettings<2>;
template struct CantileverSettings<3>;
template class CantileverExact<2>;
template class CantileverExact<3>;
template std::vector<InputError> validate(const CantileverSettings<2>&);
template std::vector<InputError> validate(const CantileverSettings<3>&);
template CantileverModel<2> make_cantilever(const CantileverSettings<2>&);
template CantileverModel<3> make_cantilever(const CantileverSettings<3>&);
template CantileverResult run_cantilever(const CantileverSettings<2>&);
template CantileverResult run_cantilever(const CantileverSettings<3>&);

}  // namespace tsph
