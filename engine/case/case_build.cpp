#include "engine/case/case_build.hpp"

#include "engine/affine_motion.hpp"
#include "engine/lattice.hpp"
#include "engine/parallel.hpp"
#include "engine/particle_file.hpp"
#include "engine/region.hpp"
#include "engine/time_function.hpp"
#include "engine/validation/bar.hpp"
#include "engine/validation/cantilever.hpp"
#include "engine/validation/plate.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <set>

namespace tsph {
namespace {

template <int Dim>
Vector<Dim> to_vector(const std::vector<double>& v) {
  Vector<Dim> out;
  for (int d = 0; d < Dim; ++d) out[d] = v[static_cast<std::size_t>(d)];
  return out;
}

TimeFunction make_time_function(const TimeFunctionSpec& f, double amplitude) {
  if (f.type == "pulse") return TimeFunction::rectangular_pulse(amplitude, f.start, f.end);
  if (f.type == "ramp") return TimeFunction::linear_ramp(amplitude, f.start, f.end);
  if (f.type == "table") {
    std::vector<double> values = f.values;
    for (double& v : values) v *= amplitude;
    return TimeFunction::table(f.times, values);
  }
  return TimeFunction::constant(amplitude);
}

template <int Dim>
CantileverBeam<Dim> cantilever_beam(const CaseFile& c) {
  CantileverBeam<Dim> s;
  s.length = c.box_upper[0] - c.box_lower[0];
  s.depth = c.box_upper[1] - c.box_lower[1];
  if constexpr (Dim == 3) s.width = c.box_upper[2] - c.box_lower[2];
  s.young_modulus = c.young_modulus;
  s.poisson_ratio = c.poisson_ratio;
  s.density = c.density;
  s.plane_mode = c.plane_mode;
  for (const auto& b : c.boundaries)
    if (b.profile == "cantilever_shear") s.load = b.value[1];
  return s;
}

/// Real and virtual particles of a union of boxes on one lattice (spacing dx, origin the
/// first box's lower corner): a cell is filled if it lies in any box; real particles sit
/// on the corners of filled cells, each with 1/2^Dim of the volume of every filled cell
/// it touches (the trapezoidal rule of lattice.hpp, which one box reproduces); virtual
/// particles at the centres of the filled cells.
template <int Dim>
void union_of_boxes(const CaseFile& c, ParticleSet<Dim>& real, ParticleSet<Dim>& virtual_particles) {
  using Index = std::array<std::int64_t, Dim>;
  const double dx = c.spacing;
  const auto& origin = c.boxes[0].first;
  auto cell_of = [&](double x, int d) { return std::llround((x - origin[static_cast<std::size_t>(d)]) / dx); };
  std::set<Index> cells;
  for (const auto& [lower, upper] : c.boxes) {
    Index first, count;
    for (int d = 0; d < Dim; ++d) {
      first[d] = cell_of(lower[static_cast<std::size_t>(d)], d);
      count[d] = cell_of(upper[static_cast<std::size_t>(d)], d) - first[d];
    }
    detail::for_each_multi_index<Dim>(count, [&](std::int64_t, const auto& index) {
      Index cell;
      for (int d = 0; d < Dim; ++d) cell[d] = first[d] + index[d];
      cells.insert(cell);
    });
  }
  std::map<Index, double> node_volume;  // ordered: deterministic particle order
  const double cell_volume = std::pow(dx, Dim);
  const double share = cell_volume / static_cast<double>(1 << Dim);
  Index two;
  two.fill(2);
  for (const Index& cell : cells)
    detail::for_each_multi_index<Dim>(two, [&](std::int64_t, const auto& corner) {
      Index node;
      for (int d = 0; d < Dim; ++d) node[d] = cell[d] + corner[d];
      node_volume[node] += share;
    });
  auto position = [&](const Index& i, double offset) {
    Vector<Dim> x;
    for (int d = 0; d < Dim; ++d)
      x[d] = origin[static_cast<std::size_t>(d)] + (static_cast<double>(i[d]) + offset) * dx;
    return x;
  };
  real.resize(node_volume.size());
  std::size_t k = 0;
  for (const auto& [node, volume] : node_volume) detail::fill_particle(real, k++, position(node, 0.0), volume, c.density);
  virtual_particles.resize(cells.size());
  k = 0;
  for (const Index& cell : cells) detail::fill_particle(virtual_particles, k++, position(cell, 0.5), cell_volume, c.density);
}

template <int Dim>
LinearElastic<Dim> case_material(const CaseFile& c) {
  return LinearElastic<Dim>(c.young_modulus, c.poisson_ratio, c.density,
                            Dim == 2 ? c.plane_mode : PlaneMode::plane_strain);
}

/// The case's material model (material.model, issue 16) around its elastic part.
template <int Dim>
Material<Dim> case_model(const CaseFile& c) {
  const CaseFile::Plasticity& p = c.plasticity;
  LinearElastic<Dim> elastic = case_material<Dim>(c);
  if (p.model == "j2") {
    std::optional<typename J2Plasticity<Dim>::Perzyna> perzyna;
    if (p.fluidity > 0.0) perzyna = typename J2Plasticity<Dim>::Perzyna{p.fluidity, p.exponent};
    return J2Plasticity<Dim>(elastic, typename J2Plasticity<Dim>::Linear{p.yield_stress, p.isotropic_hardening,
                                                                         p.kinematic_hardening},
                             perzyna);
  }
  if (p.model == "johnson_cook") {
    typename J2Plasticity<Dim>::JohnsonCook jc;
    jc.a = p.a, jc.b = p.b, jc.n = p.n, jc.c = p.c, jc.reference_rate = p.reference_rate;
    jc.thermal = p.thermal, jc.room_temperature = p.room_temperature, jc.melt_temperature = p.melt_temperature;
    jc.m = p.m, jc.specific_heat = p.specific_heat, jc.taylor_quinney = p.taylor_quinney;
    return J2Plasticity<Dim>(elastic, jc);
  }
  if (p.model == "drucker_prager") {
    typename DruckerPrager<Dim>::Parameters dp;
    dp.cohesion = p.cohesion, dp.friction_angle = p.friction_angle, dp.dilation_angle = p.dilation_angle;
    dp.hardening = p.hardening, dp.tension_cutoff = p.tension_cutoff;
    using Cone = typename DruckerPrager<Dim>::Cone;
    dp.cone = p.cone == "compression" ? Cone::compression : p.cone == "extension" ? Cone::extension : Cone::plane_strain;
    std::optional<typename DruckerPrager<Dim>::Perzyna> perzyna;
    if (p.fluidity > 0.0) perzyna = typename DruckerPrager<Dim>::Perzyna{p.fluidity, p.exponent};
    return DruckerPrager<Dim>(elastic, dp, perzyna);
  }
  return elastic;
}

}  // namespace

double case_wave_speed(const CaseFile& c) {
  switch (c.dimension) {
    case 1: return case_material<1>(c).p_wave_speed(c.density);
    case 2: return case_material<2>(c).p_wave_speed(c.density);
    case 3: return case_material<3>(c).p_wave_speed(c.density);
  }
  throw CaseError({c.path + ": dimension must be 1, 2 or 3"});
}

double case_time_step(const CaseFile& c) { return c.dt > 0.0 ? c.dt : c.cfl * c.spacing / case_wave_speed(c); }

namespace {

/// The velocity of the case's beam mode shapes at x0 ([initial.profile] types
/// "cantilever_mode" and "twist", docs/cases.md): s the distance along the axis from the
/// clamp, zero behind it (s < 0).
template <int Dim>
Vector<Dim> shape_velocity(const CaseFile& c, const Vector<Dim>& x0) {
  Vector<Dim> v = Vector<Dim>::Zero();
  for (const VelocityShape& shape : c.velocity_shapes) {
    const Vector<Dim> axis = to_vector<Dim>(shape.axis).normalized();
    const Vector<Dim> r = x0 - to_vector<Dim>(shape.origin);
    const double s = r.dot(axis);
    if (s < 0.0) continue;
    if (shape.type == "cantilever_mode") {
      // Reference section 3: v = V phi_n(s / L), phi_n(1) = 1.
      const double kl = cantilever_mode_wavenumber(static_cast<int>(shape.mode));
      v += to_vector<Dim>(shape.amplitude) * cantilever_mode_shape(kl, s / shape.length);
    } else if constexpr (Dim == 3) {
      // Reference section 4: v = omega0 sin(pi s / (2 L)) a x r.
      v += shape.angular_velocity * std::sin(M_PI * s / (2.0 * shape.length)) * axis.cross(r);
    }
  }
  return v;
}

/// The case's four automatic method options (as set, or automatic) into `settings`.
template <int Dim>
void set_automatic_options(const CaseFile& c, SolverSettings<Dim>& settings) {
  using Wall = typename SolverSettings<Dim>::VelocityWall;
  settings.hourglass_coefficient = c.hourglass;
  settings.hourglass_stiffness = c.hourglass_stiffness;
  settings.velocity_wall = c.velocity_wall == CaseFile::VelocityWall::wall_gradient     ? Wall::wall_gradient
                           : c.velocity_wall == CaseFile::VelocityWall::characteristics ? Wall::characteristics
                                                                                        : Wall::automatic;
  settings.surface_extrapolation = c.surface_extrapolation;
  settings.free_edge_uniaxial = c.free_edge_uniaxial;
  settings.volumetric_average = c.volumetric_average;
}

template <int Dim>
ResolvedMethodOptions resolved_method_options_in(const CaseFile& c) {
  SolverSettings<Dim> settings;
  set_automatic_options(c, settings);
  settings.kinematics = c.kinematics;  // SolverSettings::lists_used_once
  settings.kernel_configuration = c.kernel_configuration == "reference"
                                      ? SolverSettings<Dim>::KernelConfiguration::reference
                                      : SolverSettings<Dim>::KernelConfiguration::current;
  settings.neighbor_skin = c.neighbor_skin;
  settings = resolve_automatic_options(settings, c.plasticity.model != "elastic",  // Material::plastic()
                                      pressure_independent_yield(c));
  const bool moving = c.kinematics == Kinematics::updated_lagrangian;
  const bool reference_lists = moving && c.kernel_configuration == "reference";
  return {settings.hourglass_coefficient,
          settings.hourglass_stiffness,
          settings.velocity_wall == SolverSettings<Dim>::VelocityWall::wall_gradient,
          settings.surface_extrapolation == Toggle::on,
          settings.free_edge_uniaxial == Toggle::on,
          settings.volumetric_average == Toggle::on,
          reference_lists,
          moving && !reference_lists ? c.neighbor_skin : 0.0};
}

}  // namespace

ResolvedMethodOptions resolved_method_options(const CaseFile& c) {
  // The rule depends on the dimension only through Dim >= 2.
  return c.dimension == 1 ? resolved_method_options_in<1>(c) : resolved_method_options_in<3>(c);
}

template <int Dim>
BuiltCase<Dim> build_case(const CaseFile& c) {
  using Vec = Vector<Dim>;
  BuiltCase<Dim> b;
  const double dx = c.spacing;
  try {
    if (!c.box_lower.empty()) {
      LatticeBox<Dim> box;
      box.spacing = dx;
      box.lower = to_vector<Dim>(c.box_lower);
      for (int d = 0; d < Dim; ++d)
        box.node_count[d] = std::llround((c.box_upper[d] - c.box_lower[d]) / dx) + 1;
      b.real = make_real_lattice(box, c.density);
      b.virtual_particles = make_virtual_lattice(box, c.density);
    } else if (!c.boxes.empty()) {
      union_of_boxes(c, b.real, b.virtual_particles);
    } else {
      b.real = read_particle_csv<Dim>(c.particle_file, dx, c.density);
      b.virtual_particles = make_virtual_particles(b.real, dx, c.density);
    }
  } catch (const std::invalid_argument& e) {
    throw CaseError({c.path + ": geometry: " + e.what()});
  }
  if (b.virtual_particles.size() == 0)
    throw CaseError({c.path + ": geometry: no lattice cell of spacing dx = " + format_number(dx) +
                     " is filled by real particles, so there are no virtual particles: check "
                     "geometry.spacing against the particle file"});

  // A particle on a mirror plane is inside the mirrored body: the lattice (or a particle
  // file cut at the plane, as `tsph validate` writes the quarter Taylor bar) gives it the
  // modelled part's share of its volume, half per plane; it carries the whole.
  // A particle file without a volume column gives every particle a whole cell dx^Dim:
  // nothing to restore there.
  const bool shares = c.particle_file.empty() || particle_file_has_column(c.particle_file, "volume");
  std::vector<std::size_t> on_mirror(c.boundaries.size(), 0);  // reported as the plane's particles
  for (std::size_t k = 0; k < c.boundaries.size(); ++k) {
    const BoundarySpec& s = c.boundaries[k];
    if (s.type != "mirror" || s.regions.size() != 1) continue;
    const Vec point = to_vector<Dim>(s.regions[0].point), normal = to_vector<Dim>(s.regions[0].normal).normalized();
    for (std::size_t i = 0; i < b.real.size(); ++i) {
      Vec x0;
      for (int d = 0; d < Dim; ++d) x0[d] = b.real.initial_position[d][i];
      if (std::abs((x0 - point).dot(normal)) > 1e-6 * dx) continue;
      if (shares) {
        b.real.volume[i] *= 2.0;
        b.real.mass[i] *= 2.0;
      }
      ++on_mirror[k];
    }
  }

  // Initial conditions: v = v0 + G x0 (G row by row), uniform stress, added to the
  // particle file's values.
  const Vec v0 = to_vector<Dim>(c.initial_velocity);
  Matrix<Dim> gradient;
  for (int r = 0; r < Dim; ++r)
    for (int k = 0; k < Dim; ++k) gradient(r, k) = c.velocity_gradient[static_cast<std::size_t>(r * Dim + k)];
  for (ParticleSet<Dim>* set : {&b.real, &b.virtual_particles})
    for (std::size_t i = 0; i < set->size(); ++i) {
      Vec x0;
      for (int d = 0; d < Dim; ++d) x0[d] = set->initial_position[d][i];
      Vec v = v0 + gradient * x0;
      for (const VelocityWave& w : c.velocity_waves) {  // a standing or travelling wave's velocity
        const Vec n = to_vector<Dim>(w.direction).normalized();
        v += to_vector<Dim>(w.amplitude) * std::sin(2.0 * M_PI * x0.dot(n) / w.wavelength + w.phase);
      }
      v += shape_velocity<Dim>(c, x0);
      for (int d = 0; d < Dim; ++d) set->velocity[d][i] += v[d];
      for (int s = 0; s < stress_component_count<Dim>; ++s)
        set->stress[s][i] += c.initial_stress[static_cast<std::size_t>(s)];
    }

  // Boundary conditions, assigned in order (later ones win where regions overlap); a
  // symmetry plane also keeps the particles of its region that a later condition took
  // (BoundaryCondition::also_on_plane).
  const double tolerance = 1e-6 * dx;
  std::vector<std::string> errors;
  std::vector<std::vector<Region<Dim>>> regions_of(c.boundaries.size());
  for (std::size_t k = 0; k < c.boundaries.size(); ++k) {
    const BoundarySpec& s = c.boundaries[k];
    std::array<TimeFunction, Dim> components = BoundaryCondition<Dim>::filled(TimeFunction::constant(0.0));
    for (int d = 0; d < Dim; ++d)
      components[static_cast<std::size_t>(d)] = make_time_function(s.time, s.value[static_cast<std::size_t>(d)]);
    typename BoundaryCondition<Dim>::Profile profile = BoundaryCondition<Dim>::uniform();
    if constexpr (Dim >= 2) {
      if (s.profile == "cantilever_shear") {
        // Seed eq. (6): tau_xy = P / (2 I) (D^2 / 4 - y^2) over the end face; value = P.
        const auto cs = cantilever_beam<Dim>(c);
        const double centre = 0.5 * (c.box_lower[1] + c.box_upper[1]);
        const double scale = 1.0 / (2.0 * cs.second_moment()), quarter = 0.25 * cs.depth * cs.depth;
        profile = [=](const Vec& x) {
          const double y = x[1] - centre;
          return Vec(Vec::Ones() * (scale * (quarter - y * y)));
        };
      }
    }
    if (s.type == "fixed") b.conditions.push_back(BoundaryCondition<Dim>::fixed(s.name));
    else if (s.type == "free") b.conditions.push_back(BoundaryCondition<Dim>::free(s.name));
    else if (s.type == "symmetry") b.conditions.push_back(BoundaryCondition<Dim>::symmetry(s.name, components));
    else if (s.type == "mirror") {
      // No particle carries it: its ghosts model it (engine/solver/boundary/mirror_planes.hpp).
      b.conditions.push_back(BoundaryCondition<Dim>::mirror(s.name, to_vector<Dim>(s.regions[0].point),
                                                            to_vector<Dim>(s.regions[0].normal)));
      regions_of[k].clear();
      continue;
    }
    else if (s.type == "velocity" && !s.velocity_gradient.empty()) {
      // v = value + G x along the exact affine motion (engine/affine_motion.hpp).
      Matrix<Dim> g;
      for (int r = 0; r < Dim; ++r)
        for (int col = 0; col < Dim; ++col) g(r, col) = s.velocity_gradient[static_cast<std::size_t>(r * Dim + col)];
      const AffineMotion<Dim> motion(g, to_vector<Dim>(s.value));
      if (s.time.type == "constant") {
        b.conditions.push_back(BoundaryCondition<Dim>::velocity_field(
            [motion](const Vec& x0, double t) { return motion.velocity(x0, t); }, s.name));
      } else {
        // value = 0 (case_file.cpp): v = f(t) G x along x(t) = exp(G F(t)) x0, F = int_0^t f
        // (f G at different times commute), so the motion stays exact.
        const TimeFunction f = make_time_function(s.time, 1.0);
        b.conditions.push_back(BoundaryCondition<Dim>::velocity_field(
            [motion, f](const Vec& x0, double t) { return Vec(f(t) * motion.velocity(x0, f.integral(t))); }, s.name));
      }
    } else if (s.type == "velocity")
      b.conditions.push_back(BoundaryCondition<Dim>::velocity(components, s.name, profile));
    else
      b.conditions.push_back(BoundaryCondition<Dim>::traction(components, s.name, profile));
    std::string missed;
    for (const RegionSpec& spec : s.regions) {
      Region<Dim> region;
      if (spec.type == "box")
        region = Region<Dim>::box(s.name, to_vector<Dim>(spec.lower), to_vector<Dim>(spec.upper));
      else if (spec.type == "half_space")
        region = Region<Dim>::half_space(s.name, to_vector<Dim>(spec.point), to_vector<Dim>(spec.normal));
      else if (spec.type == "group")
        region = Region<Dim>::of_group(s.name, static_cast<std::int32_t>(spec.group));
      else  // all: a half-space that holds every particle
        region = Region<Dim>::half_space(s.name, Vec::Constant(-1e300), Vec::Unit(0));
      regions_of[k].push_back(region);
      try {
        assign_boundary(b.real, region, static_cast<std::int32_t>(k), tolerance);
      } catch (const std::invalid_argument& e) {
        missed = e.what();
      }
    }
    if (!missed.empty()) errors.push_back(c.path + ": boundary[" + std::to_string(k) + "] '" + s.name + "': " + missed);
  }
  if (!errors.empty()) throw CaseError(errors);
  // A symmetry condition's particles that a later condition took keep to its plane too
  // (BoundaryCondition::also_on_plane). Two planes of one condition that meet (half-spaces
  // whose normals lie more than 25 degrees apart, kSameFaceCosine, both holding a particle)
  // are refused: the particles there would take one normal, the kernel normal between
  // the planes, and leave both; each plane needs its own condition.
  for (std::size_t k = 0; k < c.boundaries.size() && errors.empty(); ++k) {
    if (b.conditions[k].kind != BoundaryCondition<Dim>::Kind::symmetry) continue;
    const auto& regions = regions_of[k];
    for (std::size_t i = 0; i < b.real.size() && errors.empty(); ++i) {
      Vec x0;
      for (int d = 0; d < Dim; ++d) x0[d] = b.real.initial_position[d][i];
      const Region<Dim>* first = nullptr;  // the first half-space region holding the particle
      bool held = false;
      for (std::size_t r = 0; r < regions.size(); ++r) {
        if (!regions[r].contains(x0, b.real.group[i], tolerance)) continue;
        held = true;
        if (regions[r].kind != Region<Dim>::Kind::half_space) continue;
        if (first && std::abs(first->normal.dot(regions[r].normal)) <= kSameFaceCosine) {
          errors.push_back(c.path + ": boundary[" + std::to_string(k) + "] '" + c.boundaries[k].name + "': its regions " +
                           std::to_string(first - regions.data()) + " and " + std::to_string(r) +
                           " are planes that meet (real particle " + std::to_string(b.real.id[i]) +
                           " lies on both): one symmetry condition keeps a particle to one plane; give each "
                           "plane its own [[boundary]] of type \"symmetry\" (the line where they meet then "
                           "keeps to both)");
          break;
        }
        if (!first) first = &regions[r];
      }
      if (held && b.real.boundary[i] != static_cast<std::int32_t>(k)) b.conditions[k].also_on_plane.push_back(b.real.id[i]);
    }
  }
  if (!errors.empty()) throw CaseError(errors);
  for (std::size_t k = 0; k < c.boundaries.size(); ++k)
    b.boundary_counts.emplace_back(
        c.boundaries[k].name,
        c.boundaries[k].type == "mirror"
            ? on_mirror[k]
            : static_cast<std::size_t>(std::count(b.real.boundary.begin(), b.real.boundary.end(), static_cast<std::int32_t>(k))));

  b.settings.smoothing_length = c.alpha * dx;
  b.settings.kernel = c.kernel;
  b.settings.interpolation = c.interpolation;
  b.settings.kinematics = c.kinematics;
  b.settings.body_force = to_vector<Dim>(c.body_force);
  b.settings.damping = c.damping;
  set_automatic_options(c, b.settings);
  b.settings.energy_ledger = c.energy_every > 0;
  b.settings.material_velocity_motion = c.material_velocity_motion;
  b.settings.hourglass_kick = c.hourglass_kick == "midpoint" ? SolverSettings<Dim>::HourglassKick::midpoint
                                                             : SolverSettings<Dim>::HourglassKick::predicted;
  b.settings.hourglass_reference = c.hourglass_reference == "initial"
                                       ? SolverSettings<Dim>::HourglassReference::initial
                                       : SolverSettings<Dim>::HourglassReference::flow;
  b.settings.surface_motion = c.surface_motion == "shepard" ? SolverSettings<Dim>::SurfaceMotion::shepard
                                                            : SolverSettings<Dim>::SurfaceMotion::linear;
  b.settings.conservative_momentum = c.conservative_momentum;
  using Deficient = typename SolverSettings<Dim>::DeficientStencils;
  b.settings.deficient_stencils = c.deficient_stencils == "widen"          ? Deficient::widen
                                  : c.deficient_stencils == "widen_motion" ? Deficient::widen_motion
                                  : c.deficient_stencils == "complete"     ? Deficient::complete
                                                                           : Deficient::keep;
  b.settings.kernel_configuration = c.kernel_configuration == "reference"
                                        ? SolverSettings<Dim>::KernelConfiguration::reference
                                        : SolverSettings<Dim>::KernelConfiguration::current;
  b.settings.neighbor_search = c.neighbor_search;
  b.settings.transpose_lists = c.transpose_lists;
  b.settings.neighbor_skin = c.neighbor_skin;
  b.settings.kernel_cache_bytes = static_cast<std::size_t>(c.kernel_cache_mb * 1048576.0);
  b.settings.keep_virtual_fields = c.output_virtual;  // its frames write them (snapshot)
  b.material.emplace(case_model<Dim>(c));
  b.wave_speed = case_wave_speed(c);
  b.dt = case_time_step(c);
  if (!c.force && b.dt > dx / b.wave_speed * (1.0 + 1e-12))
    throw CaseError({c.path + ": time.dt = " + format_number(c.dt) +
                     " is invalid: exceeds the stability limit dx / c_p = " + format_number(dx / b.wave_speed) +
                     " s (CFL 1); use a smaller dt or time.cfl (time.force = true runs it anyway)"});

  // Exact solutions, in material coordinates relative to the box.
  if (c.exact == "bar") {
    if constexpr (Dim == 1) {
      const BarExactSolution exact(c.box_upper[0] - c.box_lower[0], c.young_modulus, c.density, c.bar_amplitude,
                                   c.bar_pulse_duration, c.bar_left_end != "free");
      b.exact = std::make_shared<BarValidation>(exact, c.box_lower[0]);
    }
  } else if (c.exact == "cantilever") {
    if constexpr (Dim >= 2) {
      Vec centre;
      for (int d = 0; d < Dim; ++d) centre[d] = 0.5 * (c.box_lower[d] + c.box_upper[d]);
      centre[0] = c.box_lower[0];
      std::vector<std::size_t> axis;
      std::optional<std::size_t> tip;
      for (std::size_t i = 0; i < b.real.size(); ++i) {
        bool on_axis = true;
        for (int d = 1; d < Dim; ++d) on_axis = on_axis && std::abs(b.real.initial_position[d][i] - centre[d]) < tolerance;
        if (!on_axis) continue;
        axis.push_back(i);
        if (std::abs(b.real.initial_position[0][i] - c.box_upper[0]) < tolerance) tip = i;
      }
      if (!tip)
        throw CaseError({c.path + ": exact.solution = 'cantilever' needs a real particle on the beam axis "
                         "at the tip: choose geometry.spacing so that the depth holds an even number of spacings"});
      b.exact = std::make_shared<CantileverValidation<Dim>>(cantilever_beam<Dim>(c), centre, std::move(axis), *tip);
    }
  }
  return b;
}

template <int Dim>
TaylorSph<Dim> make_solver(const CaseFile& c, BuiltCase<Dim>& b) {
  try {
    return TaylorSph<Dim>(std::move(b.real), std::move(b.virtual_particles), *b.material, b.settings, b.conditions);
  } catch (const std::invalid_argument& e) {
    throw CaseError({c.path + ": " + e.what()});
  }
}

std::int64_t count_steps(const CaseFile& c, double dt) {
  std::int64_t steps = 0;
  double t = 0.0;
  std::vector<double> targets = c.output_times;
  targets.push_back(c.end_time);
  for (double target : targets) {
    if (target <= t) continue;
    steps += static_cast<std::int64_t>(std::ceil((target - t) / dt * (1.0 - 1e-9)));
    t = target;
  }
  return steps;
}


template BuiltCase<1> build_case<1>(const CaseFile&);
template BuiltCase<2> build_case<2>(const CaseFile&);
template BuiltCase<3> build_case<3>(const CaseFile&);
template TaylorSph<1> make_solver<1>(const CaseFile&, BuiltCase<1>&);
template TaylorSph<2> make_solver<2>(const CaseFile&, BuiltCase<2>&);
template TaylorSph<3> make_solver<3>(const CaseFile&, BuiltCase<3>&);

}  // namespace tsph
