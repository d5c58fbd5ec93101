// SolverSettings::volumetric_average: the volumetric strain rate of the yielding particles
// averaged over their neighbourhood, the particle form of B-bar (Hughes 1980; the mean
// dilatation of finite elements). Isochoric plastic flow asks every particle's tr D to
// vanish, more constraints than the velocities can meet; the pressure, which each particle
// updates from its own tr L, then carries an odd-even mode that the corrected gradients
// of the virtual set do not see. On the Tresca footing it is (-1)^(i+j) +-2 c over the
// whole plastic zone at every spacing (docs/notes/2026-12-06-damping-work.md); on the
// Taylor bar it held the impact face back (R_f -2.8 % at R0 / 4).
//
// The virtual particles sit at the centres of the real lattice's cells, as the elements'
// centres of a mesh of the real particles. After the full step (seed eq. 4) each cell
// takes the volume-weighted mean of its corners' tr L^{n+1/2} (the real particles within
// dx of it at X: 2^D on the lattice), theta_c = A tr L, and each yielding interior
// particle the volume-weighted mean of its 2^D cells', theta = R A tr L; its pressure and
// density then follow theta instead of its own tr L:
//   sigma_ii += dt K (theta - tr L)   (K = lambda + 2 mu / 3; plane strain: sigma_zz too),
//   rho      *= exp(-dt (theta - tr L)),
// a pressure alone: B-bar's volumetric strain rate (theta - tr L) / 3 I, which in plane
// strain has a zz part and leaves the deviator unchanged. Exact where tr L is uniform or
// (inside, on the lattice) linear; the odd-even mode averages to zero in every cell.
// Only for a yield surface that does not depend on the pressure (J2, Johnson-Cook,
// Drucker-Prager with phi = 0 and no tension cut-off): the deviatoric return does not
// read the pressure there, so the corrected stress is the return of the trial with the
// averaged rate, still on the surface. Boundary particles are left out of the data and of
// the correction: their stress is the boundary stage's, which replaces their own tr L. A
// mirror plane's ghost stands for its owned particle. The change of elastic energy is not
// booked apart: it is part of the ledger's balance error.
//
// The corners and cells are the neighbour lists' entries within dx of each other at X
// (at x in small strain, where x = X), ghosts replaced by their owned particles, taken
// after each search of the lists (VolumetricAverageStencils; once per run with the
// reference kernel, the default): two passes over 2^D entries a step. Material stencils:
// the lists must hold the pairs within dx at X when searched (the reference kernel's
// always do; the current kernel's with a skin until the body has stretched by 2h / dx)
// and be kept across the step (not SolverSettings::lists_used_once, which the key refuses).
// The kernel's whole support (2h, alpha 1.2: about 18 entries a row in 2D) cost 1.28x the
// plastic step in instructions and gave the same footing and Taylor bar to 1-2 %; a
// uniform weight over the support at X let the Taylor bar's face lag (R_f -8 % at R0 / 4:
// docs/notes/2026-12-06-volumetric-average.md).
#pragma once

#include "engine/parallel.hpp"
#include "engine/solver/state.hpp"
#include "engine/solver/stencil_evaluation.hpp"  // exp_of_small

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

namespace tsph {

template <int Dim>
struct VolumetricAverage {
  /// Whether the run averages: SolverSettings::volumetric_average on, in 2D and 3D.
  static bool active(const SolverState<Dim>& state) {
    return Dim >= 2 && state.settings.volumetric_average == Toggle::on;
  }

  /// After the full step, with state.volumetric_rate holding every real particle's
  /// tr L^{n+1/2}: the yielding interior particles' pressure and density take theta.
  static void apply(SolverState<Dim>& state, double dt) {
    VolumetricAverageStencils& stencils = state.volumetric_stencils;
    if (stencils.neighbor_builds != state.counters.neighbor_builds)
      build(state);  // taken by NeighborLists::search
    const double* const rate = state.volumetric_rate.data();
    const double* const real_volume = state.real.volume.data();
    const double* const cell_volume = state.virtual_.volume.data();
    const std::uint32_t* const corner_start = stencils.cell_start.data();
    const std::uint32_t* const corner = stencils.cell_corner.data();
    std::vector<double>& cell_rate_storage = state.volumetric_cell_rate;
    cell_rate_storage.resize(state.virtual_.size());
    double* const cell_rate = cell_rate_storage.data();
    // A tr L: each cell's mean over its interior corners (none with a rate: NaN, no value).
    parallel_for(state.virtual_.size(), [&](std::size_t q) {
      double weights = 0.0, sum = 0.0;
      for (std::uint32_t k = corner_start[q]; k < corner_start[q + 1]; ++k) {
        const std::uint32_t j = corner[k];
        if (std::isnan(rate[j])) continue;  // its row had no neighbours: no rate this step
        weights += real_volume[j];
        sum += real_volume[j] * rate[j];
      }
      cell_rate[q] = weights > 0.0 ? sum / weights : std::numeric_limits<double>::quiet_NaN();
    });
    // R (A tr L) at the yielding interior particles, and the correction: a pressure alone,
    // K = lambda + 2 mu / 3 on the three normal stresses (in plane strain too, as B-bar's
    // volumetric strain (theta - tr L) / 3 I: the deviator, and so the yield, unchanged).
    const auto& elastic = state.material.elastic();
    const double bulk = elastic.model_lame() + 2.0 * elastic.shear_modulus() / 3.0;
    const bool compressible = state.density_follows();
    const std::uint32_t* const cell_start = stencils.particle_start.data();
    const std::uint32_t* const cell = stencils.particle_cell.data();
    const std::uint8_t* const yielding = state.real.yielding.data();
    const std::int32_t* const slot = state.boundary.slot.data();
    parallel_for(state.volumetric_rate.size(), [&](std::size_t r) {
      if (slot[r] >= 0 || yielding[r] == 0 || std::isnan(rate[r])) return;
      double weights = 0.0, sum = 0.0;
      for (std::uint32_t k = cell_start[r]; k < cell_start[r + 1]; ++k) {
        const std::uint32_t q = cell[k];
        if (std::isnan(cell_rate[q])) continue;
        weights += cell_volume[q];
        sum += cell_volume[q] * cell_rate[q];
      }
      if (!(weights > 0.0)) return;
      const double excess = sum / weights - rate[r];  // theta - tr L
      for (int m = 0; m < Dim; ++m) state.real.stress[m][r] += dt * bulk * excess;
      if constexpr (Dim == 2)
        state.real.stress[3][r] += dt * bulk * excess;  // sigma_zz (plane strain)
      if (compressible) {
        state.real.density[r] *= exp_of_small(-dt * excess);
        state.real.volume[r] = state.real.mass[r] / state.real.density[r];
      }
    });
  }

  /// The lists' entries within dx at X, owners for ghosts; a cell's corners without the
  /// boundary particles. Serial: after each search of the lists (NeighborLists::search,
  /// the ghosts attached), once per run with the reference kernel.
  static void build(SolverState<Dim>& state) {
    VolumetricAverageStencils& s = state.volumetric_stencils;
    const std::size_t cells = state.virtual_.size(), particles = state.real.size();
    const bool reference =
        state.positions_move();  // small strain: x = X (the initial positions may be released)
    std::array<const double*, Dim> real_x{}, cell_x{};
    for (int d = 0; d < Dim; ++d) {
      real_x[d] = reference ? state.real.initial_position[d].data() : state.real.position[d].data();
      cell_x[d] =
          reference ? state.virtual_.initial_position[d].data() : state.virtual_.position[d].data();
    }
    const double reach_squared = state.initial_spacing * state.initial_spacing;
    const auto within = [&](std::size_t j, std::size_t q) {
      double s2 = 0.0;
      for (int d = 0; d < Dim; ++d) {
        const double dx = real_x[d][j] - cell_x[d][q];
        s2 += dx * dx;
      }
      return s2 < reach_squared;
    };
    const std::size_t owned_real = state.real.size(), owned_cells = state.virtual_.size();
    // Reserved to their bound (2^Dim entries a row: a cell's corners, a particle's cells on
    // the lattice), so that they hold no growth slack (memory_estimate.hpp counts this).
    s.cell_start.reserve(cells + 1);
    s.cell_start.assign(1, 0);
    s.cell_corner.clear();
    s.cell_corner.reserve(cells << Dim);
    for (std::size_t q = 0; q < cells; ++q) {
      for (std::uint32_t j : state.lists.virtual_from_real.neighbors(q)) {
        const std::uint32_t owner = j < owned_real ? j : state.mirror.real.source[j - owned_real];
        if (state.boundary.slot[owner] >= 0 || !within(j, q)) continue;
        s.cell_corner.push_back(owner);
      }
      s.cell_start.push_back(static_cast<std::uint32_t>(s.cell_corner.size()));
    }
    s.particle_start.reserve(particles + 1);
    s.particle_start.assign(1, 0);
    s.particle_cell.clear();
    s.particle_cell.reserve(particles << Dim);
    for (std::size_t r = 0; r < particles; ++r) {
      for (std::uint32_t q : state.lists.real_from_virtual.neighbors(r))
        if (within(r, q))
          s.particle_cell.push_back(
              q < owned_cells ? q : state.mirror.virtual_.source[q - owned_cells]);
      s.particle_start.push_back(static_cast<std::uint32_t>(s.particle_cell.size()));
    }
    s.neighbor_builds = state.counters.neighbor_builds;
  }
};

}  // namespace tsph
