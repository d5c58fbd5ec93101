// The benchmark workload shared by bench_step_nd, tsph-memory and the CI timing
// workload: a block of Dim dimensions on a box lattice (about `particles` real
// particles, as many virtual ones), E = 8e7 Pa, nu = 0.3, rho = 2000 kg/m^3, held at
// x = 0, free at the opposite face, with a smooth initial velocity field so that
// every particle does real work. Updated Lagrangian: every step rebuilds the lists.
#pragma once

#include "engine/lattice.hpp"
#include "engine/region.hpp"
#include "engine/taylor_sph.hpp"

#include <cmath>
#include <cstdint>

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

/// `reorder(set, support radius)` may permute each set before the solver is built;
/// `configure(settings)` may change the solver settings.
template <int Dim, class Reorder = void (*)(ParticleSet<Dim>&, double),
          class Configure = void (*)(SolverSettings<Dim>&)>
TaylorSph<Dim> make_block(std::int64_t particles, double alpha,
                          Kinematics kinematics = Kinematics::updated_lagrangian,
                          Reorder reorder = [](ParticleSet<Dim>&, double) {},
                          Configure configure = [](SolverSettings<Dim>&) {}) {
  const LatticeBox<Dim> box = block_box<Dim>(particles);
  ParticleSet<Dim> real = make_real_lattice(box, kBlockDensity);
  ParticleSet<Dim> virtual_particles = make_virtual_lattice(box, kBlockDensity);
  const double tolerance = 1e-9 * box.spacing;
  Vector<Dim> far = box.lower;
  far[0] += static_cast<double>(box.node_count[0] - 1) * box.spacing;
  assign_boundary(real, Region<Dim>::half_space("clamp", box.lower, -Vector<Dim>::Unit(0)), 0,
                  tolerance);
  assign_boundary(real, Region<Dim>::half_space("end", far, Vector<Dim>::Unit(0)), 1, tolerance);
  for (std::size_t i = 0; i < real.size(); ++i)
    for (int d = 0; d < Dim; ++d)
      real.velocity[d][i] = 0.01 * std::sin(3.0 * real.position[0][i] + d) *
                            std::cos(2.0 * real.position[Dim - 1][i]);
  SolverSettings<Dim> settings;
  settings.smoothing_length = alpha * box.spacing;
  reorder(real, kSupportFactor * settings.smoothing_length);
  reorder(virtual_particles, kSupportFactor * settings.smoothing_length);
  settings.kinematics = kinematics;
  configure(settings);
  return TaylorSph<Dim>(std::move(real), std::move(virtual_particles),
                        LinearElastic<Dim>(kBlockYoung, 0.3, kBlockDensity), settings,
                        {BoundaryCondition<Dim>::fixed("clamp"), BoundaryCondition<Dim>::free("end")});
}

/// A stable step: a third of the CFL limit dx / c_p.
template <int Dim>
double block_time_step(const TaylorSph<Dim>& solver, double alpha) {
  const double dx = solver.settings().smoothing_length / alpha;
  return 0.3 * dx / std::sqrt(solver.material().p_wave_modulus() / kBlockDensity);
}

}  // namespace tsph::bench
