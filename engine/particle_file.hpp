// Real particles from a CSV file, and virtual particles generated for them, for shapes
// other than boxes (issue 3). The file has a header naming its columns:
//   x, y[, z]                      positions (required)
//   volume                         particle volume (default dx^Dim)
//   vx, vy[, vz]                   initial velocity (default 0)
//   sxx, syy, sxy, szz (2D) or sxx, syy, szz, sxy, syz, szx (3D), sxx (1D)
//                                  initial stress (default 0)
//   group                          integer group for boundary regions (default 0)
// The particles must lie on a lattice of spacing dx, up to 0.3 dx of disorder: a
// virtual particle is placed at the centre of every lattice cell whose 2^Dim corners
// all hold a real particle. Two particles closer than dx / 2 are refused as
// duplicated or overlapping.
#pragma once

#include "engine/particle_set.hpp"

#include <cstdint>
#include <istream>
#include <optional>
#include <string>

namespace tsph {

/// The largest particle file read: 16 GiB (about 4e7 particles with every column).
inline constexpr std::uintmax_t kMaxParticleFileBytes = std::uintmax_t{16} << 30;

/// Why `path` cannot be a particle file (missing, unreadable, not a regular file: a
/// directory, a device such as /dev/urandom or /dev/zero, a FIFO; empty; larger than
/// kMaxParticleFileBytes), or nothing. Looks only at the file's metadata: it never
/// blocks on a FIFO or reads a device (issue 15).
std::optional<std::string> particle_file_problem(const std::string& path);

/// Whether the file's header line names `column` (false for a file that cannot be read).
bool particle_file_has_column(const std::string& path, const std::string& column);

/// Reads the file; throws std::invalid_argument naming the file, line, column and
/// value of the first problem (missing file, not a regular file, unknown column, wrong
/// field count, unparsable or non-finite value, duplicated or overlapping particles).
/// The duplicate check sorts the particles by cells of dx / 2 and compares each with
/// those of its own and the adjacent cells: O(N log N) time, O(N) memory.
template <int Dim>
ParticleSet<Dim> read_particle_csv(const std::string& path, double spacing, double density);

/// The same from a stream; `name` stands for the file in the messages (the fuzz target
/// reads from memory through this).
template <int Dim>
ParticleSet<Dim> read_particle_csv(std::istream& in, const std::string& name, double spacing,
                                   double density);

/// Virtual particles at the centres of the lattice cells filled by `real`.
template <int Dim>
ParticleSet<Dim> make_virtual_particles(const ParticleSet<Dim>& real, double spacing,
                                        double density);

}  // namespace tsph
