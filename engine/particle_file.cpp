#include "engine/particle_file.hpp"

#include "engine/input_error.hpp"

#include <algorithm>
#include <array>
#include <cerrno>
#include <charconv>
#include <cstring>
#include <filesystem>
#include <numeric>
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <sys/stat.h>
#include <unistd.h>

namespace tsph {
namespace {

std::vector<std::string> split(std::string line) {
  if (!line.empty() && line.back() == '\r') line.pop_back();  // CRLF files
  std::vector<std::string> fields;
  std::string field;
  std::istringstream in(line);
  while (std::getline(in, field, ',')) {
    const auto first = field.find_first_not_of(" \t\r");
    const auto last = field.find_last_not_of(" \t\r");
    fields.push_back(first == std::string::npos ? "" : field.substr(first, last - first + 1));
  }
  if (!line.empty() && line.back() == ',') fields.emplace_back();
  return fields;
}

/// Whether every field of a line reads as a number (a data line, not a header).
bool all_numbers(const std::vector<std::string>& fields) {
  for (const auto& f : fields) {
    double value = 0.0;
    const auto r = std::from_chars(f.data(), f.data() + f.size(), value);
    if (f.empty() || r.ec != std::errc() || r.ptr != f.data() + f.size()) return false;
  }
  return !fields.empty();
}

/// The first pair (i, j), i < j in file order with the smallest i, of particles closer
/// than `radius`; nothing if there is none. Particles are sorted by their cell of side
/// `radius` (so a close pair lies in the same or adjacent cells); each particle is
/// compared with those of the 3^Dim cells around its own.
template <int Dim>
std::optional<std::pair<std::size_t, std::size_t>> first_close_pair(const ParticleSet<Dim>& set, double radius) {
  using Cell = std::array<std::int64_t, Dim>;
  const std::size_t n = set.size();
  std::vector<Cell> cell(n);
  for (std::size_t i = 0; i < n; ++i)
    for (int d = 0; d < Dim; ++d) {
      // Clamped: far-off coordinates share the outermost cells, which stays correct
      // (the distance decides) and only costs comparisons.
      const double q = std::clamp(std::floor(set.position[d][i] / radius), -4e18, 4e18);
      cell[i][static_cast<std::size_t>(d)] = static_cast<std::int64_t>(q);
    }
  std::vector<std::uint32_t> order(n);
  std::iota(order.begin(), order.end(), 0u);
  std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
    return cell[a] != cell[b] ? cell[a] < cell[b] : a < b;
  });
  const double r2 = radius * radius;
  for (std::size_t i = 0; i < n; ++i) {
    std::optional<std::size_t> best;
    std::array<std::int64_t, Dim> offset;
    offset.fill(-1);
    for (;;) {
      Cell c = cell[i];
      bool representable = true;
      for (int d = 0; d < Dim; ++d) {
        const auto k = static_cast<std::size_t>(d);
        representable = representable && !(offset[k] < 0 && c[k] == INT64_MIN) && !(offset[k] > 0 && c[k] == INT64_MAX);
        c[k] += offset[k];
      }
      if (representable) {
        auto it = std::lower_bound(order.begin(), order.end(), c,
                                   [&](std::uint32_t a, const Cell& key) { return cell[a] < key; });
        for (; it != order.end() && cell[*it] == c; ++it) {
          const std::size_t j = *it;
          if (j == i || (best && j >= *best)) continue;
          double distance2 = 0.0;
          for (int d = 0; d < Dim; ++d) {
            const double e = set.position[d][i] - set.position[d][j];
            distance2 += e * e;
          }
          if (distance2 <= r2) best = j;  // as the cell lists: within the radius
        }
      }
      int d = 0;  // next offset in {-1, 0, 1}^Dim
      while (d < Dim && offset[static_cast<std::size_t>(d)] == 1) offset[static_cast<std::size_t>(d++)] = -1;
      if (d == Dim) break;
      ++offset[static_cast<std::size_t>(d)];
    }
    if (best) return std::make_pair(std::min(i, *best), std::max(i, *best));
  }
  return std::nullopt;
}

template <int Dim>
std::vector<std::string> stress_columns() {
  if constexpr (Dim == 1) return {"sxx"};
  else if constexpr (Dim == 2) return {"sxx", "syy", "sxy", "szz"};
  else return {"sxx", "syy", "szz", "sxy", "syz", "szx"};
}

/// The column names of the first line that is neither blank nor a comment (empty at the
/// end of the stream); `line_number` counts the lines read.
std::vector<std::string> read_header(std::istream& in, std::size_t& line_number) {
  std::string line;
  while (std::getline(in, line)) {
    ++line_number;
    if (line.find_first_not_of(" \t\r") == std::string::npos || line[0] == '#') continue;
    return split(line);
  }
  return {};
}

}  // namespace

bool particle_file_has_column(const std::string& path, const std::string& column) {
  std::ifstream in(path);
  std::size_t line_number = 0;
  const std::vector<std::string> names = read_header(in, line_number);
  return std::find(names.begin(), names.end(), column) != names.end();
}

std::optional<std::string> particle_file_problem(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0)
    return std::string("cannot be opened (") + std::strerror(errno) + "): check the path and its permissions";
  if (S_ISDIR(st.st_mode)) return std::string("is a directory: name a CSV file of particles");
  if (!S_ISREG(st.st_mode))
    return std::string("is not a regular file (") +
           (S_ISCHR(st.st_mode) || S_ISBLK(st.st_mode) ? "a device" : S_ISFIFO(st.st_mode) ? "a FIFO" : "a socket or other special file") +
           "): name a CSV file of particles";
  if (::access(path.c_str(), R_OK) != 0)
    return std::string("cannot be opened (") + std::strerror(errno) + "): check the path and its permissions";
  if (st.st_size == 0) return std::string("is empty: it needs a header line (x,y,...) and one line per particle");
  if (static_cast<std::uintmax_t>(st.st_size) > kMaxParticleFileBytes)
    return "holds " + std::to_string(st.st_size) + " bytes, more than the " +
           std::to_string(kMaxParticleFileBytes >> 30) + " GiB a particle file may hold: use a coarser particle set";
  return std::nullopt;
}

template <int Dim>
ParticleSet<Dim> read_particle_csv(const std::string& path, double spacing, double density) {
  std::vector<InputError> errors;
  require_positive(errors, "dx", spacing);
  require_positive(errors, "density", density);
  throw_if_invalid(errors);
  if (const auto problem = particle_file_problem(path))
    throw std::invalid_argument("particle file '" + path + "' " + *problem);
  std::ifstream in(path);
  if (!in)
    throw std::invalid_argument("particle file '" + path +
                                "' cannot be opened: check the path and its permissions");
  return read_particle_csv<Dim>(in, path, spacing, density);
}

template <int Dim>
ParticleSet<Dim> read_particle_csv(std::istream& in, const std::string& path, double spacing,
                                   double density) {
  std::vector<InputError> errors;
  require_positive(errors, "dx", spacing);
  require_positive(errors, "density", density);
  throw_if_invalid(errors);
  const std::array<const char*, 3> axes = {"x", "y", "z"};
  const std::array<const char*, 3> velocities = {"vx", "vy", "vz"};
  // Column name -> (field kind, component).
  std::map<std::string, std::pair<char, int>> known;
  for (int d = 0; d < Dim; ++d) {
    known[axes[static_cast<std::size_t>(d)]] = {'x', d};
    known[velocities[static_cast<std::size_t>(d)]] = {'v', d};
  }
  const auto stresses = stress_columns<Dim>();
  for (std::size_t m = 0; m < stresses.size(); ++m) known[stresses[m]] = {'s', static_cast<int>(m)};
  known["volume"] = {'V', 0};
  known["group"] = {'g', 0};

  std::string line;
  std::size_t line_number = 0;
  std::vector<std::pair<char, int>> columns;
  const std::vector<std::string> names = read_header(in, line_number);
  const std::string where = "particle file '" + path + "'";
  if (names.empty()) throw std::invalid_argument(where + " is empty: it needs a header line");
  if (all_numbers(names)) {
    std::string header;
    for (int d = 0; d < Dim; ++d) header += std::string(d ? "," : "") + axes[static_cast<std::size_t>(d)];
    throw std::invalid_argument(where + ", line " + std::to_string(line_number) +
                                ": the header line is missing (this line holds numbers): add a first line "
                                "naming the columns, e.g. '" + header + "'");
  }
  std::array<bool, Dim> has_axis{};
  for (std::size_t c = 0; c < names.size(); ++c)
    for (std::size_t e = 0; e < c; ++e)
      if (names[c] == names[e])
        throw std::invalid_argument(where + ", line " + std::to_string(line_number) +
                                    ": column '" + names[c] + "' appears twice");
  for (const auto& name : names) {
    const auto it = known.find(name);
    if (it == known.end()) {
      std::string valid;
      for (const auto& [k, unused] : known) valid += (valid.empty() ? "" : ", ") + k;
      throw std::invalid_argument(where + ", line " + std::to_string(line_number) +
                                  ": unknown column '" + name + "'; valid columns: " + valid);
    }
    if (it->second.first == 'x') has_axis[static_cast<std::size_t>(it->second.second)] = true;
    columns.push_back(it->second);
  }
  for (int d = 0; d < Dim; ++d)
    if (!has_axis[static_cast<std::size_t>(d)])
      throw std::invalid_argument(where + ": the header lacks the column '" +
                                  axes[static_cast<std::size_t>(d)] + "'");

  ParticleSet<Dim> set;
  std::vector<std::size_t> line_of;
  const double default_volume = std::pow(spacing, Dim);
  while (std::getline(in, line)) {
    ++line_number;
    if (line.find_first_not_of(" \t\r") == std::string::npos || line[0] == '#') continue;
    const auto fields = split(line);
    if (fields.size() != columns.size())
      throw std::invalid_argument(where + ", line " + std::to_string(line_number) + ": " +
                                  std::to_string(fields.size()) + " fields, the header has " +
                                  std::to_string(columns.size()));
    const std::size_t i = set.size();
    set.resize(i + 1);
    set.volume[i] = default_volume;
    for (std::size_t c = 0; c < columns.size(); ++c) {
      double value = 0.0;
      const std::string& text = fields[c];
      const auto result = std::from_chars(text.data(), text.data() + text.size(), value);
      if (result.ec != std::errc() || result.ptr != text.data() + text.size() || !std::isfinite(value))
        throw std::invalid_argument(where + ", line " + std::to_string(line_number) + ": column '" +
                                    names[c] + "' = '" + text + "' is not a finite number");
      const auto [kind, component] = columns[c];
      switch (kind) {
        case 'x':
          set.position[component][i] = value;
          set.initial_position[component][i] = value;
          break;
        case 'v': set.velocity[component][i] = value; break;
        case 's': set.stress[component][i] = value; break;
        case 'V':
          if (!(value > 0.0))
            throw std::invalid_argument(where + ", line " + std::to_string(line_number) +
                                        ": volume = " + text + " must be positive");
          set.volume[i] = value;
          break;
        case 'g':
          if (value != std::trunc(value) || std::abs(value) > 2147483647.0)
            throw std::invalid_argument(where + ", line " + std::to_string(line_number) +
                                        ": group = " + text + " must be a 32-bit integer");
          set.group[i] = static_cast<std::int32_t>(value);
          break;
      }
    }
    set.density[i] = density;
    set.mass[i] = density * set.volume[i];
    line_of.push_back(line_number);
  }
  if (set.size() == 0) throw std::invalid_argument(where + " holds no particle");

  // Duplicated or overlapping particles: any pair closer than dx / 2.
  if (const auto pair = first_close_pair(set, 0.5 * spacing))
    throw std::invalid_argument(where + ": the particles of lines " + std::to_string(line_of[pair->first]) + " and " +
                                std::to_string(line_of[pair->second]) + " are closer than dx / 2 = " +
                                format_number(0.5 * spacing) + " (duplicated or overlapping)");
  return set;
}

template <int Dim>
ParticleSet<Dim> make_virtual_particles(const ParticleSet<Dim>& real, double spacing,
                                        double density) {
  Vector<Dim> lower = real.position_of(0);
  for (std::size_t i = 0; i < real.size(); ++i) lower = lower.cwiseMin(real.position_of(i));
  // Lattice index of every real particle (rounded), then the cells whose corners are all there.
  std::map<std::array<std::int64_t, Dim>, bool> occupied;
  for (std::size_t i = 0; i < real.size(); ++i) {
    std::array<std::int64_t, Dim> index;
    bool on_lattice = true;
    for (int d = 0; d < Dim; ++d) {
      const double s = (real.position[d][i] - lower[d]) / spacing;
      index[static_cast<std::size_t>(d)] = std::llround(s);
      on_lattice = on_lattice && std::abs(s - std::round(s)) <= 0.3;
    }
    if (on_lattice) occupied[index] = true;
  }
  ParticleSet<Dim> set;
  for (const auto& [index, unused] : occupied) {
    bool filled = true;
    for (int corner = 0; corner < (1 << Dim) && filled; ++corner) {
      auto neighbour = index;
      for (int d = 0; d < Dim; ++d) neighbour[static_cast<std::size_t>(d)] += (corner >> d) & 1;
      filled = occupied.count(neighbour) > 0;
    }
    if (!filled) continue;
    const std::size_t q = set.size();
    set.resize(q + 1);
    for (int d = 0; d < Dim; ++d) {
      const double x = lower[d] + (static_cast<double>(index[static_cast<std::size_t>(d)]) + 0.5) * spacing;
      set.position[d][q] = x;
      set.initial_position[d][q] = x;
    }
    set.volume[q] = std::pow(spacing, Dim);
    set.density[q] = density;
    set.mass[q] = density * set.volume[q];
  }
  if (set.size() == 0)
    throw std::invalid_argument("particle file: no lattice cell of dx = " + format_number(spacing) +
                                " has all its corners filled: check dx against the particles");
  return set;
}

template ParticleSet<1> read_particle_csv<1>(const std::string&, double, double);
template ParticleSet<2> read_particle_csv<2>(const std::string&, double, double);
template ParticleSet<3> read_particle_csv<3>(const std::string&, double, double);
template ParticleSet<1> read_particle_csv<1>(std::istream&, const std::string&, double, double);
template ParticleSet<2> read_particle_csv<2>(std::istream&, const std::string&, double, double);
template ParticleSet<3> read_particle_csv<3>(std::istream&, const std::string&, double, double);
template ParticleSet<1> make_virtual_particles<1>(const ParticleSet<1>&, double, double);
template ParticleSet<2> make_virtual_particles<2>(const ParticleSet<2>&, double, double);
template ParticleSet<3> make_virtual_particles<3>(const ParticleSet<3>&, double, double);

}  // namespace tsph
