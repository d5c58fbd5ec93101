// Peak memory of a Taylor-SPH run per real particle, estimated before anything is
// allocated, so that a particle count that cannot fit is refused with the estimate and
// the limit instead of failing (or swapping) half-way (issue 4, "Bad input").
//
// The model follows what TaylorSph holds at its peak in an updated-Lagrangian step
// (bench/RESULTS.md compares it with /usr/bin/time -v):
//   * the real set, per particle (4 Dim + stress components + 3) doubles and 3 int32;
//   * about as many virtual particles, each (3 Dim + stress components + 3) doubles:
//     the solver releases the virtual set's optional fields (displacement, id, boundary,
//     group; ParticleSet::release_optional_fields) unless
//     SolverSettings::keep_virtual_fields (`keep_virtual_fields` here: + Dim doubles
//     and 3 int32); the initial positions X_v (Dim doubles) are kept, read by the
//     updated-Lagrangian virtual motion (TaylorSph::place_at_material_point,
//     the default) and the hourglass stiffness;
//   * with the hourglass stiffness (`hourglass_stiffness` here; the default of an
//     elastic material in 2D and 3D): its return trip's two lists in the initial
//     coordinates, radius max(2h, 1.75 dx), each with 4 B row starts and 4 B indices
//     plus 8 B weights per pair (the pairs counted exactly: the cell centres of the
//     lattice within that radius of a node), 9 B per half-step pair (A's kept weights
//     and support flags), and per particle two fits (Dim + 2 doubles) and two vectors;
//     without a skin, both half-step lists (the stiffness reads the half step's after the
//     full step); its lists are released before they are built again;
//   * no v^n (the displacement takes dt/2 v^n before the full step; the conservative
//     momentum option stores it, Dim doubles: not modelled), except with the energy
//     ledger (SolverSettings::energy_ledger, `energy_ledger` here: + Dim doubles; with
//     the hourglass stiffness its kicks, Dim more: not modelled);
//   * one half-step neighbour list at a time: 32-bit row starts (4 B) plus 4 B per
//     pair, with pi (2 alpha)^2 (2D) or 4/3 pi (2 alpha)^3 (3D) pairs per row (the
//     support ball in lattice cells, an upper bound of the measured count);
//   * the boundary list's row starts (4 B per real particle; boundary rows are few);
//   * the cell list being queried: sorted indices, their cells while binning, and
//     the coordinates in cell order (8 + 8 Dim B);
//   * with SolverSettings::transpose_lists, both half-step lists at once while the
//     full step's is transposed from the half step's (instead of the cell list and one
//     list);
//   * with the kernel in the reference configuration (SolverSettings::kernel_configuration,
//     the default: `reference_lists` here), both half-step lists of radius 2h, searched
//     once at X and kept (no skin), the second searched with a cell list while the first
//     is held (unless transposed);
//   * with a Verlet skin s (SolverSettings::neighbor_skin, a fraction of 2h), both
//     half-step lists at once, each of the radius (1 + s) 2h ((1 + s)^Dim times the
//     pairs) (the displacements since the search are bounded by a scalar per set, no
//     stored positions); the cell list is released before the second list is
//     transposed from the first;
//   * a plastic material's internal variables (plastic_field_bytes) and the volumetric
//     average's stencils and rates (volumetric_average_bytes);
//   * with the reference kernel, its factor cache up to SolverSettings::kernel_cache_bytes
//     (kernel_factor_bytes_per_particle; a total, added by the caller).
#pragma once

#include "engine/particle_set.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <fstream>
#include <numbers>
#include <stdexcept>
#include <string>
#include <utility>

#include <sys/resource.h>
#include <unistd.h>

namespace tsph {

/// The cell centres of the unit lattice within `radius` (in spacings) of a node.
template <int Dim>
double cell_centres_within(double radius) {
  const int reach = static_cast<int>(std::ceil(radius)) + 1;
  double count = 0.0;
  std::array<int, Dim> k{};
  k.fill(-reach);
  while (true) {
    double r2 = 0.0;
    for (int d = 0; d < Dim; ++d) r2 += (k[d] + 0.5) * (k[d] + 0.5);
    if (r2 <= radius * radius) count += 1.0;  // the cell list's pairs: distance <= radius
    int d = 0;
    while (d < Dim && ++k[d] > reach) k[d++] = -reach;
    if (d == Dim) break;
  }
  return count;
}

/// What a run holds beyond the bare scheme's fields and one list (the header comment).
struct MemoryModel {
  bool transposed_lists = false;     ///< SolverSettings::transpose_lists
  double skin = 0.0;                 ///< SolverSettings::neighbor_skin (a fraction of 2h)
  bool keep_virtual_fields = false;  ///< SolverSettings::keep_virtual_fields
  bool energy_ledger = false;        ///< SolverSettings::energy_ledger
  bool hourglass_stiffness = false;  ///< a positive hourglass stiffness
  bool reference_lists = false;      ///< the kernel in the reference configuration
  bool plastic_fields = false;       ///< a plastic material (ParticleSet::carry_plastic_fields)
  bool volumetric_average = false;   ///< SolverSettings::volumetric_average on
};

/// The plastic models' internal variables of a real particle
/// (ParticleSet::carry_plastic_fields): the equivalent plastic strain, the plastic work,
/// the temperature, the back stress and the hourglass reference (doubles), and the yield
/// flag (1 B): 73 B in 2D, 97 B in 3D.
template <int Dim>
constexpr double plastic_field_bytes() {
  return 8.0 * (3 + stress_component_count<Dim> + Dim) + 1.0;
}

/// The volumetric average (engine/solver/stabilisation/volumetric_average.hpp), per real
/// particle with about as many cells: the two stencils (each a 4 B row start and 2^Dim
/// 4 B entries: a cell's corners, a particle's cells on the lattice) and the two rates
/// (8 B per particle and per cell): 56 B in 2D, 88 B in 3D.
template <int Dim>
constexpr double volumetric_average_bytes() {
  return 2.0 * (4.0 + 4.0 * (1 << Dim)) + 16.0;
}

/// Pairs per row of a list of radius `radius` lattice spacings: the support ball in
/// lattice cells (an upper bound of the measured count).
template <int Dim>
constexpr double pairs_per_row(double radius) {
  return Dim == 1   ? 2.0 * radius
         : Dim == 2 ? std::numbers::pi * radius * radius
                    : 4.0 / 3.0 * std::numbers::pi * radius * radius * radius;
}

/// The reference kernel's factor cache (engine/solver/kernel_factor_cache.hpp) of a
/// particle: two doubles per pair of each of the two half-step lists (radius 2 alpha
/// lattice spacings, counted as the lists are), plus the padding of a row (at most 3
/// lanes, counted as 4) and its 8 B row start. The run holds at most
/// SolverSettings::kernel_cache_bytes of it: the caller adds the smaller of the two.
template <int Dim>
double kernel_factor_bytes_per_particle(double alpha) {
  return 2.0 * (16.0 * (pairs_per_row<Dim>(2.0 * alpha) + 4.0) + 8.0);
}

template <int Dim>
double estimate_bytes_per_real_particle(double alpha, const MemoryModel& model = {}) {
  double skin = model.skin;
  if (!(alpha > 0.0) || !std::isfinite(alpha))
    throw std::invalid_argument("memory estimate: alpha = " + std::to_string(alpha) +
                                " must be positive");
  if (!(skin >= 0.0) || !std::isfinite(skin))
    throw std::invalid_argument("memory estimate: skin = " + std::to_string(skin) + " must be >= 0");
  const double real_set = 8.0 * (4 * Dim + stress_component_count<Dim> + 3) + 12.0;
  const double virtual_set =
      model.keep_virtual_fields ? real_set : 8.0 * (3 * Dim + stress_component_count<Dim> + 3);
  const double sets = real_set + virtual_set + (model.energy_ledger ? 8.0 * Dim : 0.0) +
                      (model.plastic_fields ? plastic_field_bytes<Dim>() : 0.0) +
                      (model.volumetric_average ? volumetric_average_bytes<Dim>() : 0.0);
  if (model.reference_lists) skin = 0.0;  // the lists of X: searched once, no skin
  const double radius = 2.0 * alpha * (1.0 + skin);  // list radius in lattice spacings
  const double pairs = pairs_per_row<Dim>(radius);
  const double list = 4.0 + 4.0 * pairs;
  const double boundary_offsets = 4.0;
  const double cell_list = 8.0 + 8.0 * Dim;
  const double return_pairs = cell_centres_within<Dim>(std::max(2.0 * alpha, 1.75));
  const double stiffness = model.hourglass_stiffness ? 2.0 * (4.0 + 12.0 * return_pairs) + 9.0 * pairs +
                                                           2.0 * 8.0 * (Dim + 2) + 2.0 * 8.0 * Dim
                                                     : 0.0;
  if (skin > 0.0) return sets + 2.0 * list + boundary_offsets + stiffness;
  // The reference lists: the full step's list is searched (a cell list) while the half
  // step's is held, once, at the construction, unless it is transposed from it.
  if (model.reference_lists)
    return sets + 2.0 * list + (model.transposed_lists ? 0.0 : cell_list) + boundary_offsets + stiffness;
  // Without a skin the half-step list is released before the full step's is built, except
  // with the hourglass stiffness, which reads it after the full step (both held).
  const double lists =
      model.transposed_lists ? 2.0 * list : list + cell_list + (model.hourglass_stiffness ? list : 0.0);
  return sets + lists + boundary_offsets + stiffness;
}

/// Memory this process may use: MemAvailable of /proc/meminfo (0 if unknown).
inline std::size_t available_memory_bytes() {
  std::ifstream meminfo("/proc/meminfo");
  std::string key;
  std::size_t kib = 0;
  std::string unit;
  while (meminfo >> key >> kib >> unit)
    if (key == "MemAvailable:") return kib * 1024;
  return 0;
}

/// The number in a one-line /sys file ("max" or a missing file: 0, unknown).
inline std::size_t read_cgroup_bytes(const char* path) {
  std::ifstream file(path);
  std::string text;
  if (!(file >> text) || text == "max") return 0;
  try {
    return static_cast<std::size_t>(std::stoull(text));
  } catch (const std::exception&) {
    return 0;
  }
}

/// What the address-space limit (RLIMIT_AS, `ulimit -v`) leaves this process: the
/// limit less the address space already mapped (/proc/self/statm); 0 if unlimited.
inline std::size_t address_space_left_bytes() {
  struct rlimit limit {};
  if (::getrlimit(RLIMIT_AS, &limit) != 0 || limit.rlim_cur == RLIM_INFINITY) return 0;
  std::ifstream statm("/proc/self/statm");
  std::size_t pages = 0;
  statm >> pages;
  const std::size_t mapped = pages * static_cast<std::size_t>(::sysconf(_SC_PAGESIZE));
  const auto cap = static_cast<std::size_t>(limit.rlim_cur);
  return cap > mapped ? cap - mapped : 1;  // 1: nothing left (0 would mean unknown)
}

/// Memory a run may use: the smallest of MemAvailable, what the control group's limit
/// leaves (cgroup v2 memory.max - memory.current, or v1 limit_in_bytes - usage_in_bytes)
/// and what the address-space limit leaves (RLIMIT_AS, issue 15); 0 if none is known.
/// Writes where the limit comes from to `source` if given.
inline std::size_t memory_limit_bytes(std::string* source = nullptr) {
  std::size_t limit = available_memory_bytes();
  if (source) *source = "MemAvailable in /proc/meminfo";
  const std::pair<const char*, const char*> groups[] = {
      {"/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory.current"},
      {"/sys/fs/cgroup/memory/memory.limit_in_bytes", "/sys/fs/cgroup/memory/memory.usage_in_bytes"}};
  for (const auto& [max_path, current_path] : groups) {
    const std::size_t max = read_cgroup_bytes(max_path);
    if (max == 0 || max >= (std::size_t{1} << 60)) continue;  // no limit (v1 writes a huge number)
    const std::size_t current = read_cgroup_bytes(current_path);
    const std::size_t left = max > current ? max - current : 0;
    if (limit == 0 || left < limit) {
      limit = left;
      if (source) *source = std::string("the control group's limit (") + max_path + ")";
    }
    break;
  }
  if (const std::size_t left = address_space_left_bytes(); left > 0 && (limit == 0 || left < limit)) {
    limit = left;
    if (source) *source = "the address-space limit RLIMIT_AS (ulimit -v) less what this process has mapped";
  }
  return limit;
}

/// Throws when `particles` x `bytes_per_particle` exceeds `limit_bytes` (a limit of 0
/// means unknown: nothing is checked).
inline void check_memory_budget(double bytes_per_particle, std::size_t particles,
                                std::size_t limit_bytes) {
  if (limit_bytes == 0) return;
  const double needed = bytes_per_particle * static_cast<double>(particles);
  if (needed <= static_cast<double>(limit_bytes)) return;
  char message[400];
  std::snprintf(message, sizeof message,
                "particles = %zu is too many for this machine: the run needs about %.1f GiB "
                "(%.0f bytes per real particle, virtual set and neighbour lists included) but "
                "%.1f GiB are available; use at most %.0f particles",
                particles, needed / 1073741824.0, bytes_per_particle,
                static_cast<double>(limit_bytes) / 1073741824.0,
                std::floor(static_cast<double>(limit_bytes) / bytes_per_particle));
  throw std::invalid_argument(message);
}

}  // namespace tsph
