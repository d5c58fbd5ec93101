#include "engine/case/case_checks.hpp"

#include "engine/elasticity.hpp"
#include "engine/input_error.hpp"
#include "engine/particle_file.hpp"

#include <fmt/core.h>

#include <cmath>
#include <filesystem>
#include <map>

namespace tsph {
namespace {

double p_wave_speed(const CaseFile& c) {
  const PlaneMode mode = c.dimension == 2 ? c.plane_mode : PlaneMode::plane_strain;
  switch (c.dimension) {
    case 1: return LinearElastic<1>(c.young_modulus, c.poisson_ratio, c.density, mode).p_wave_speed(c.density);
    case 2: return LinearElastic<2>(c.young_modulus, c.poisson_ratio, c.density, mode).p_wave_speed(c.density);
    case 3: return LinearElastic<3>(c.young_modulus, c.poisson_ratio, c.density, mode).p_wave_speed(c.density);
  }
  return 0.0;
}

}  // namespace

std::vector<std::string> whole_case_errors(const CaseFile& c) {
  std::vector<std::string> errors;
  std::map<std::string, std::size_t> probes;
  for (std::size_t k = 0; k < c.probes.size(); ++k) {
    const auto [it, fresh] = probes.emplace(c.probes[k].name, k);
    if (!fresh && !c.probes[k].name.empty())
      errors.push_back(fmt::format("{}: output.probe[{}].name = '{}' is invalid: output.probe[{}] has the same name "
                                   "(each probe writes probe_<name>.csv): give every probe its own name",
                                   c.path, k, c.probes[k].name, it->second));
  }
  // A special file is refused here, before the resource estimate reads the file; a
  // missing one is reported by the reader when the case is built (as before).
  std::error_code ec;
  if (!c.particle_file.empty() && std::filesystem::exists(c.particle_file, ec))
    if (const auto problem = particle_file_problem(c.particle_file))
      errors.push_back(c.path + ": geometry.particle_file = '" + c.particle_file + "' is invalid: the file " + *problem);

  // The step count, from the resolved dt (build_case: cfl dx / c_p, or time.dt).
  const bool material_valid = c.dimension >= 1 && c.dimension <= 3 && c.young_modulus > 0.0 && c.density > 0.0 &&
                              c.poisson_ratio > -1.0 && c.poisson_ratio < 0.5 && c.spacing > 0.0 &&
                              std::isfinite(c.young_modulus) && std::isfinite(c.density) && std::isfinite(c.spacing);
  if (c.dt > 0.0 && c.end_time > 0.0 && c.dt > c.end_time)
    errors.push_back(c.path + ": time.dt = " + format_number(c.dt) + " is invalid: it exceeds time.end = " +
                     format_number(c.end_time) + " s, so the run would not take one full step: use a dt below " +
                     "time.end (or time.cfl)");
  else if (material_valid && c.end_time > 0.0 && (c.dt > 0.0 || c.cfl > 0.0)) {
    const double dt = c.dt > 0.0 ? c.dt : c.cfl * c.spacing / p_wave_speed(c);
    const double steps = c.end_time / dt;
    if (!(steps <= kMaxSteps))
      errors.push_back(fmt::format("{}: time.end = {} is invalid: at dt = {} s it needs {:.3g} steps, more than the "
                                   "{:.0e} a run may take: use a smaller time.end (or a larger dt or spacing)",
                                   c.path, format_number(c.end_time), format_number(dt), steps, kMaxSteps));
  }
  return errors;
}

void check_probe_particles(const CaseFile& c, std::size_t real_particles) {
  std::vector<std::string> errors;
  for (const auto& s : c.probes)
    if (s.particle >= 0 && static_cast<std::size_t>(s.particle) >= real_particles)
      errors.push_back(c.path + ": output.probe '" + s.name + "': particle = " + std::to_string(s.particle) +
                       " is invalid: ids run from 0 to " + std::to_string(real_particles - 1));
  if (!errors.empty()) throw CaseError(errors);
}

}  // namespace tsph
