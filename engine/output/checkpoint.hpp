// Checkpoints: the whole state a run needs to continue bit for bit (every field of
// both particle sets, the time, the step count, and the output bookkeeping: frame
// count, .pvd entries, error records), in one binary file written atomically
// (temporary file, fsync, rename). The stepper keeps no other state from one step to
// the next in small-strain runs: its neighbour lists, normals and boundary slots are
// rebuilt from the particles when it is constructed.
//
// Format 5 (2026-12-07: ParticleSet::hourglass_reference among the plastic fields; formats
// 3 and 4 are read with it zero), format 4 (the energy ledger, engine/solver/energy_ledger.hpp,
// after the error records; format 3 is read with an empty ledger), format 3 (issue 16: the
// plastic fields of ParticleSet, empty in elastic runs; format 2, "TSPHCKP2", is refused
// naming its format) and, as format 2 (issue 15, docs/reliability.md): the magic "TSPHCKP5", the byte count of the
// body (uint64) and zlib's crc32 of the body (uint32), then the body: the record of the
// case's resolved physics (engine/case/physics_record.hpp: one "key = value" line per
// key, and its crc32) followed by the state. A damaged file (a flipped bit, overwritten
// or missing bytes) fails the size or the checksum and is refused with a
// CheckpointError naming the file and the check; nothing of it is parsed before. Format
// 1 (magic "TSPHCKP1", no checksum, no physics record) is refused with a message that
// says so: its state cannot be verified.
#pragma once

#include "engine/output/vtu_writer.hpp"
#include "engine/particle_set.hpp"
#include "engine/solver/settings.hpp"

#include <cstdint>
#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include <zlib.h>

namespace tsph::output {

/// A checkpoint that cannot be used: missing, not a checkpoint, of an old format, or
/// damaged. what() names the file and the check that failed.
class CheckpointError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct ErrorEntry {
  double time = 0.0;
  std::string name;
  double value = 0.0;
};

template <int Dim>
struct Checkpoint {
  ParticleSet<Dim> real, virtual_particles;
  double time = 0.0;
  std::int64_t steps = 0;
  std::uint64_t frames = 0;
  std::vector<PvdEntry> real_series, virtual_series;
  std::vector<ErrorEntry> errors;
  /// The resolved physics of the case that wrote it (physics_record.hpp).
  std::string physics;
  /// The works booked so far (empty when the run keeps no ledger or the file is of format 3).
  EnergyLedger energy;
};

/// What can be checked of a checkpoint without knowing its dimension: written whole
/// (size and checksum) and by which case.
struct CheckpointHeader {
  std::string path;
  std::uint32_t checksum = 0;  ///< crc32 of the body
  std::string physics;         ///< "key = value" lines
  std::uint32_t physics_checksum = 0;
  std::int32_t dimension = 0;
  double time = 0.0;
  std::int64_t steps = 0;
  int format = 5;  ///< 3: no energy ledger; 3 and 4: no hourglass reference
};

namespace detail {

constexpr char kCheckpointMagic[8] = {'T', 'S', 'P', 'H', 'C', 'K', 'P', '5'};
constexpr char kCheckpointMagicFormat4[8] = {'T', 'S', 'P', 'H', 'C', 'K', 'P', '4'};
constexpr char kCheckpointMagicFormat3[8] = {'T', 'S', 'P', 'H', 'C', 'K', 'P', '3'};
constexpr char kCheckpointMagicFormat1[8] = {'T', 'S', 'P', 'H', 'C', 'K', 'P', '1'};
constexpr char kCheckpointMagicFormat2[8] = {'T', 'S', 'P', 'H', 'C', 'K', 'P', '2'};
/// Magic, body size, body checksum.
constexpr std::size_t kCheckpointPrefixBytes = 8 + 8 + 4;

/// zlib's crc32 of `bytes` (in pieces: zlib takes at most UINT_MAX bytes at a time).
inline std::uint32_t crc32_of(const char* bytes, std::size_t size) {
  uLong crc = ::crc32(0L, Z_NULL, 0);
  while (size > 0) {
    const auto piece = static_cast<uInt>(std::min<std::size_t>(size, 1u << 30));
    crc = ::crc32(crc, reinterpret_cast<const Bytef*>(bytes), piece);
    bytes += piece;
    size -= piece;
  }
  return static_cast<std::uint32_t>(crc);
}

class Bytes {
 public:
  template <class T>
  void put(const T& value) {
    static_assert(std::is_trivially_copyable_v<T>);
    const auto* p = reinterpret_cast<const char*>(&value);
    data_.insert(data_.end(), p, p + sizeof(T));
  }
  template <class T>
  void put_vector(const std::vector<T>& v) {
    put<std::uint64_t>(v.size());
    const auto* p = reinterpret_cast<const char*>(v.data());
    data_.insert(data_.end(), p, p + v.size() * sizeof(T));
  }
  void put_string(const std::string& s) {
    put<std::uint64_t>(s.size());
    data_.insert(data_.end(), s.begin(), s.end());
  }
  const std::vector<char>& data() const { return data_; }
  std::vector<char>& data() { return data_; }

 private:
  std::vector<char> data_;
};

class Reader {
 public:
  Reader(std::vector<char> data, std::string path) : data_(std::move(data)), path_(std::move(path)) {}
  template <class T>
  T get() {
    T value;
    take(&value, sizeof(T));
    return value;
  }
  template <class T>
  /// `expected` values, or none (a released optional field of a ParticleSet).
  void get_vector(std::vector<T>& v, std::uint64_t expected) {
    const auto n = get<std::uint64_t>();
    if (n > (data_.size() - position_) / sizeof(T))
      throw std::runtime_error("checkpoint '" + path_ + "' is damaged: a field holds " + std::to_string(n) +
                               " values, more than the file");
    if (n != expected && n != 0)
      throw std::runtime_error("checkpoint '" + path_ + "' is damaged: a field holds " + std::to_string(n) +
                               " values, expected " + std::to_string(expected));
    v.resize(n);
    take(v.data(), n * sizeof(T));
  }
  std::string get_string() {
    const auto n = get<std::uint64_t>();
    if (n > data_.size() - position_)
      throw std::runtime_error("checkpoint '" + path_ + "' is damaged (string length)");
    std::string s(n, '\0');
    take(s.data(), n);
    return s;
  }
  bool at_end() const { return position_ == data_.size(); }
  std::size_t position() const { return position_; }
  const std::vector<char>& bytes() const { return data_; }

 private:
  void take(void* out, std::size_t bytes) {
    if (position_ + bytes > data_.size())
      throw std::runtime_error("checkpoint '" + path_ + "' is truncated or damaged");
    if (bytes == 0) return;  // an empty (released) field: its data() may be null, which memcpy must not get
    std::memcpy(out, data_.data() + position_, bytes);
    position_ += bytes;
  }
  std::vector<char> data_;
  std::string path_;
  std::size_t position_ = 0;
};

inline void put_series(Bytes& b, const std::vector<PvdEntry>& series) {
  b.put<std::uint64_t>(series.size());
  for (const auto& e : series) {
    b.put(e.time);
    b.put_string(e.file);
  }
}
inline std::vector<PvdEntry> get_series(Reader& r) {
  const auto n = r.get<std::uint64_t>();
  if (n > r.bytes().size() / 16) throw std::runtime_error("checkpoint is damaged (series length)");
  std::vector<PvdEntry> series(n);
  for (auto& e : series) {
    e.time = r.get<double>();
    e.file = r.get_string();
  }
  return series;
}

}  // namespace detail

/// Writes the checkpoint to `path` atomically.
template <int Dim>
void write_checkpoint(const std::string& path, const Checkpoint<Dim>& c) {
  detail::Bytes b;
  for (char ch : detail::kCheckpointMagic) b.put(ch);
  b.put<std::uint64_t>(0);  // the body's size and checksum, filled in below
  b.put<std::uint32_t>(0);
  b.put<std::uint32_t>(detail::crc32_of(c.physics.data(), c.physics.size()));
  b.put_string(c.physics);
  b.put<std::int32_t>(Dim);
  b.put(c.time);
  b.put(c.steps);
  b.put(c.frames);
  for (const ParticleSet<Dim>* set : {&c.real, &c.virtual_particles}) {
    b.put<std::uint64_t>(set->size());
    ParticleSet<Dim> copy = *set;  // for_each_field visits mutable fields
    copy.for_each_field([&b](auto& field) { b.put_vector(field); });
  }
  detail::put_series(b, c.real_series);
  detail::put_series(b, c.virtual_series);
  b.put<std::uint64_t>(c.errors.size());
  for (const auto& e : c.errors) {
    b.put(e.time);
    b.put_string(e.name);
    b.put(e.value);
  }
  const EnergyLedger& l = c.energy;
  for (double w : {l.body_force, l.damping, l.hourglass, l.surface_filter, l.boundary_overwrite, l.hourglass_energy,
                   l.initial_energy})
    b.put(w);
  b.put<std::uint64_t>(l.boundary.size());  // the count get_vector checks against
  b.put_vector(l.boundary);
  std::vector<char>& bytes = b.data();
  const std::uint64_t body = bytes.size() - detail::kCheckpointPrefixBytes;
  const std::uint32_t crc = detail::crc32_of(bytes.data() + detail::kCheckpointPrefixBytes, body);
  std::memcpy(bytes.data() + 8, &body, sizeof body);
  std::memcpy(bytes.data() + 16, &crc, sizeof crc);
  write_text_file(path, std::string(bytes.begin(), bytes.end()), /*durable=*/true);
}

namespace detail {

/// Checks the magic, the size and the checksum of the bytes of a checkpoint, then reads
/// the header; leaves `r` at the state. Throws CheckpointError naming the failed check.
inline CheckpointHeader verify_checkpoint(Reader& r, std::size_t file_bytes, const std::string& path) {
  const std::string where = "checkpoint '" + path + "'";
  if (file_bytes < 8) throw CheckpointError(where + " is not a tsph checkpoint (" + std::to_string(file_bytes) + " bytes)");
  char magic[8];
  for (char& ch : magic) ch = r.get<char>();
  if (std::memcmp(magic, kCheckpointMagicFormat1, 8) == 0)
    throw CheckpointError(where + " is of format 1 (tsph before issue 15), which has no checksum and no record of "
                          "the case's physics, so it cannot be verified: start the run again (or continue it "
                          "with the tsph that wrote it)");
  if (std::memcmp(magic, kCheckpointMagicFormat2, 8) == 0)
    throw CheckpointError(where + " is of format 2 (tsph before issue 16), which holds no plastic state: start the "
                          "run again (or continue it with the tsph that wrote it)");
  const bool format3 = std::memcmp(magic, kCheckpointMagicFormat3, 8) == 0;
  const bool format4 = std::memcmp(magic, kCheckpointMagicFormat4, 8) == 0;
  if (!format3 && !format4 && std::memcmp(magic, kCheckpointMagic, 8) != 0)
    throw CheckpointError("'" + path + "' is not a tsph checkpoint");
  if (file_bytes < kCheckpointPrefixBytes)
    throw CheckpointError(where + " is damaged: size check failed (truncated to " + std::to_string(file_bytes) +
                          " bytes, in its header)");
  const auto body = r.get<std::uint64_t>();
  const auto crc = r.get<std::uint32_t>();
  if (body != file_bytes - kCheckpointPrefixBytes)
    throw CheckpointError(where + " is damaged: size check failed (the header gives a body of " + std::to_string(body) +
                          " bytes, the file holds " + std::to_string(file_bytes - kCheckpointPrefixBytes) +
                          (body > file_bytes - kCheckpointPrefixBytes ? ": truncated)" : ")"));
  const std::vector<char>& data = r.bytes();
  const std::uint32_t actual = crc32_of(data.data() + kCheckpointPrefixBytes, data.size() - kCheckpointPrefixBytes);
  if (actual != crc)
    throw CheckpointError(where + " is damaged: checksum check failed (crc32 of the body " + std::to_string(actual) +
                          ", recorded " + std::to_string(crc) + ")");
  CheckpointHeader h;
  h.path = path;
  h.format = format3 ? 3 : format4 ? 4 : 5;
  h.checksum = crc;
  try {
    h.physics_checksum = r.get<std::uint32_t>();
    h.physics = r.get_string();
    h.dimension = r.get<std::int32_t>();
    h.time = r.get<double>();
    h.steps = r.get<std::int64_t>();
  } catch (const std::runtime_error& e) {
    throw CheckpointError(e.what());
  }
  if (crc32_of(h.physics.data(), h.physics.size()) != h.physics_checksum)
    throw CheckpointError(where + " is damaged: physics record check failed");
  return h;
}

inline std::vector<char> read_bytes(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    throw CheckpointError("checkpoint '" + path + "' cannot be opened (" +
                          (std::filesystem::exists(path, ec) ? "not a regular file" : "no such file") + ")");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw CheckpointError("checkpoint '" + path + "' cannot be opened (" + std::strerror(errno) + ")");
  return std::vector<char>((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

}  // namespace detail

/// The header of an intact checkpoint (size and checksum verified, state not parsed);
/// throws CheckpointError naming the file and the failed check.
inline CheckpointHeader read_checkpoint_header(const std::string& path) {
  std::vector<char> data = detail::read_bytes(path);
  const std::size_t size = data.size();
  detail::Reader r(std::move(data), path);
  CheckpointHeader h = detail::verify_checkpoint(r, size, path);
  return h;
}

/// Reads a checkpoint from its bytes; `path` names it in the messages. Throws
/// CheckpointError if it is not one, is of another dimension or format, or is damaged.
template <int Dim>
Checkpoint<Dim> parse_checkpoint(std::vector<char> data, const std::string& path) {
  const std::size_t size = data.size();
  detail::Reader r(std::move(data), path);
  const CheckpointHeader h = detail::verify_checkpoint(r, size, path);
  try {
    if (h.dimension != Dim)
      throw CheckpointError("checkpoint '" + path + "' is of a " + std::to_string(h.dimension) + "D run, the case is " +
                            std::to_string(Dim) + "D");
    Checkpoint<Dim> c;
    c.physics = h.physics;
    c.time = h.time;
    c.steps = h.steps;
    c.frames = r.get<std::uint64_t>();
    for (ParticleSet<Dim>* set : {&c.real, &c.virtual_particles}) {
      const auto n = r.get<std::uint64_t>();
      const bool without_reference = h.format < 5;
      set->for_each_field([&r, n, set, without_reference](auto& field) {
        if constexpr (std::is_same_v<std::decay_t<decltype(field)>, std::vector<double>>)
          if (without_reference && set->is_hourglass_reference(field)) return;  // not in formats 3 and 4
        r.get_vector(field, n);
      });
      if (without_reference && set->carries_plastic_fields())  // zero: as at the start of a run
        for (auto& a : set->hourglass_reference) a.assign(set->storage_size(), 0.0);
      try {  // released optional fields (the solver's virtual set) come back released
        set->check_field_sizes("checkpoint '" + path + "'");
      } catch (const std::invalid_argument& e) {
        throw std::runtime_error(std::string(e.what()) + " (damaged)");
      }
    }
    c.real_series = detail::get_series(r);
    c.virtual_series = detail::get_series(r);
    const auto errors = r.get<std::uint64_t>();
    if (errors > size) throw std::runtime_error("checkpoint '" + path + "' is damaged (error record count)");
    c.errors.resize(errors);
    for (auto& e : c.errors) {
      e.time = r.get<double>();
      e.name = r.get_string();
      e.value = r.get<double>();
    }
    if (h.format >= 4) {
      EnergyLedger& l = c.energy;
      for (double* w : {&l.body_force, &l.damping, &l.hourglass, &l.surface_filter, &l.boundary_overwrite,
                        &l.hourglass_energy, &l.initial_energy})
        *w = r.get<double>();
      const auto conditions = r.get<std::uint64_t>();
      if (conditions > size) throw std::runtime_error("checkpoint '" + path + "' is damaged (energy ledger size)");
      r.get_vector(l.boundary, conditions);
    }
    if (!r.at_end()) throw std::runtime_error("checkpoint '" + path + "' is damaged (trailing bytes)");
    return c;
  } catch (const CheckpointError&) {
    throw;
  } catch (const std::runtime_error& e) {
    throw CheckpointError(e.what());
  }
}

/// Reads a checkpoint; throws CheckpointError (a std::runtime_error) naming the file if
/// it is not one, is of another dimension or format, or is damaged.
template <int Dim>
Checkpoint<Dim> read_checkpoint(const std::string& path) {
  return parse_checkpoint<Dim>(detail::read_bytes(path), path);
}

}  // namespace tsph::output
