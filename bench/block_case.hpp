// The benchmark workload shared by bench_step_nd, tsph-block-run (memory and the CI
// timing workload) and test_memory_estimate: a block of Dim dimensions on a box lattice
// (about `particles` real particles, as many virtual ones), E = 8e7 Pa, nu = 0.3 (plane
// strain in 2D), rho = 2000 kg/m^3, held at x = 0, free at the opposite face, with a
// smooth initial velocity field so that every particle does real work, at CFL 0.3.
// Updated Lagrangian by default. It is a case written in code (block_case), read and
// built by the one case pipeline (engine/case/case_build.hpp).
#pragma once

#include "engine/case/case_build.hpp"
#include "engine/case/case_file.hpp"
#include "engine/lattice.hpp"
#include "engine/taylor_sph.hpp"

#include <fmt/core.h>

#include <cmath>
#include <cstdint>
#include <string>

namespace tsph::bench {

inline constexpr double kBlockDensity = 2000.0;
inline constexpr double kBlockYoung = 8e7;

/// Lattice box with about `particles` nodes, spacing 1 / (nodes per axis - 1).
template <int Dim>
LatticeBox<Dim> block_box(std::int64_t particles) {
  LatticeBox<Dim> box;
  const auto per_axis = std::max<std::int64_t>(
      2, std::llround(std::pow(static_cast<double>(particles), 1.0 / Dim)));
  for (int d = 0; d < Dim; ++d) box.node_count[d] = per_axis;
  box.spacing = 1.0 / static_cast<double>(per_axis - 1);
  return box;
}

/// The block as a case file. The velocity field
/// v_d = 0.01 sin(3 x + d) cos(2 z) (z the last axis) is written as the sum of four
/// sine waves, sin(a + d) cos(b) = (sin(a + b + d) + sin(a - b + d)) / 2 and
/// sin(t + d) = cos(d) sin(t) + sin(d) sin(t + pi/2).
template <int Dim>
/// `material_keys`: more [material] lines (a plastic material.model and its keys).
CaseFile block_case(std::int64_t particles, double alpha, Kinematics kinematics = Kinematics::updated_lagrangian,
                    const std::string& material_keys = "") {
  static_assert(Dim == 2 || Dim == 3, "the benchmark block is 2D or 3D");
  const LatticeBox<Dim> box = block_box<Dim>(particles);
  auto vector = [](auto component) {
    std::string text = "[";
    for (int d = 0; d < Dim; ++d) text += fmt::format("{}{:.17g}", d == 0 ? "" : ", ", component(d));
    return text + "]";
  };
  std::string waves;
  const double wavelength = 2.0 * M_PI / std::sqrt(13.0);  // |(3, 2)| = sqrt(13)
  for (const double sign : {1.0, -1.0})
    for (const bool shifted : {false, true})
      waves += fmt::format(
          "[[initial.profile]]\ntype = \"sine\"\namplitude = {}\ndirection = {}\nwavelength = {:.17g}\nphase = {:.17g}\n",
          vector([&](int d) { return 0.005 * (shifted ? std::sin(d) : std::cos(d)); }),
          vector([&](int d) { return d == 0 ? 3.0 : d == Dim - 1 ? 2.0 * sign : 0.0; }), wavelength,
          shifted ? M_PI / 2.0 : 0.0);
  const std::string text = fmt::format(
      "title = \"benchmark block\"\ndimension = {dim}\n"
      "[geometry]\nspacing = {dx:.17g}\nbox = {{ lower = {zero}, upper = {one} }}\n"
      "[material]\nE = {young:.17g}\nnu = 0.3\nrho = {rho:.17g}\n{plane}{material}"
      // The bare scheme (SolverSettings::bare_scheme): the recorded timings
      // (bench/RESULTS.md) predate the automatic elastic treatments.
      "[method]\nalpha = {alpha:.17g}\nkinematics = \"{kinematics}\"\nhourglass = 0.0\nhourglass_stiffness = 0.0\n"
      "velocity_wall = \"characteristics\"\nsurface_extrapolation = false\n"
      "[time]\nend = 1.0\ncfl = 0.3\n"
      "[[boundary]]\nname = \"clamp\"\ntype = \"fixed\"\n"
      "region = {{ type = \"half_space\", point = {zero}, normal = {minus_x} }}\n"
      "[[boundary]]\nname = \"end\"\ntype = \"free\"\n"
      "region = {{ type = \"half_space\", point = {one}, normal = {plus_x} }}\n"
      "{waves}",
      fmt::arg("dim", Dim), fmt::arg("dx", box.spacing), fmt::arg("zero", vector([](int) { return 0.0; })),
      fmt::arg("one", vector([](int) { return 1.0; })), fmt::arg("young", kBlockYoung), fmt::arg("rho", kBlockDensity),
      fmt::arg("plane", Dim == 2 ? "plane = \"strain\"\n" : ""), fmt::arg("material", material_keys),
      fmt::arg("alpha", alpha),
      fmt::arg("kinematics", to_string(kinematics)),
      fmt::arg("minus_x", vector([](int d) { return d == 0 ? -1.0 : 0.0; })),
      fmt::arg("plus_x", vector([](int d) { return d == 0 ? 1.0 : 0.0; })), fmt::arg("waves", waves));
  return load_case_text(text, "benchmark block");
}

/// `reorder(set, support radius)` may permute each set before the solver is built;
/// `configure(settings)` may change the solver settings.
template <int Dim, class Reorder = void (*)(ParticleSet<Dim>&, double),
          class Configure = void (*)(SolverSettings<Dim>&)>
TaylorSph<Dim> make_block(std::int64_t particles, double alpha,
                          Kinematics kinematics = Kinematics::updated_lagrangian,
                          Reorder reorder = [](ParticleSet<Dim>&, double) {},
                          Configure configure = [](SolverSettings<Dim>&) {}, const std::string& material_keys = "") {
  const CaseFile c = block_case<Dim>(particles, alpha, kinematics, material_keys);
  BuiltCase<Dim> b = build_case<Dim>(c);
  b.settings.energy_ledger = false;  // the step alone (tsph run books energy.csv: +1.4 %)
  reorder(b.real, kSupportFactor * b.settings.smoothing_length);
  reorder(b.virtual_particles, kSupportFactor * b.settings.smoothing_length);
  configure(b.settings);
  return make_solver(c, b);
}

/// The block's time step, dt = 0.3 dx / c_p (the case's time.cfl, case_time_step).
template <int Dim>
double block_time_step(const TaylorSph<Dim>& solver, double alpha) {
  return case_time_step(block_case<Dim>(static_cast<std::int64_t>(solver.real().size()), alpha));
}

}  // namespace tsph::bench
