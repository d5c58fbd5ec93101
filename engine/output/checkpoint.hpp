// Checkpoints: the whole state a run needs to continue bit for bit (every field of
// both particle sets, the time, the step count, and the output bookkeeping: frame
// count, .pvd entries, error records), in one binary file written atomically
// (temporary file, fsync, rename). The stepper keeps no other state from one step to
// the next in small-strain runs: its neighbour lists, normals and boundary slots are
// rebuilt from the particles when it is constructed.
#pragma once

#include "engine/output/vtu_writer.hpp"
#include "engine/particle_set.hpp"

#include <cstdint>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace tsph::output {

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
};

namespace detail {

constexpr char kCheckpointMagic[8] = {'T', 'S', 'P', 'H', 'C', 'K', 'P', '1'};

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
    if (n != expected && n != 0)
      throw std::runtime_error("checkpoint '" + path_ + "' is damaged: a field holds " + std::to_string(n) +
                               " values, expected " + std::to_string(expected));
    v.resize(n);
    take(v.data(), n * sizeof(T));
  }
  std::string get_string() {
    const auto n = get<std::uint64_t>();
    if (n > data_.size()) throw std::runtime_error("checkpoint '" + path_ + "' is damaged (string length)");
    std::string s(n, '\0');
    take(s.data(), n);
    return s;
  }
  bool at_end() const { return position_ == data_.size(); }

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
  std::vector<PvdEntry> series(r.get<std::uint64_t>());
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
  write_text_file(path, std::string(b.data().begin(), b.data().end()), /*durable=*/true);
}

/// Reads a checkpoint; throws std::runtime_error naming the file if it is not one,
/// is of another dimension, or is damaged.
template <int Dim>
Checkpoint<Dim> read_checkpoint(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("checkpoint '" + path + "' cannot be opened");
  std::vector<char> data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  detail::Reader r(std::move(data), path);
  for (char ch : detail::kCheckpointMagic)
    if (r.get<char>() != ch) throw std::runtime_error("'" + path + "' is not a tsph checkpoint");
  const auto dim = r.get<std::int32_t>();
  if (dim != Dim)
    throw std::runtime_error("checkpoint '" + path + "' is of a " + std::to_string(dim) + "D run, the case is " +
                             std::to_string(Dim) + "D");
  Checkpoint<Dim> c;
  c.time = r.get<double>();
  c.steps = r.get<std::int64_t>();
  c.frames = r.get<std::uint64_t>();
  for (ParticleSet<Dim>* set : {&c.real, &c.virtual_particles}) {
    const auto n = r.get<std::uint64_t>();
    set->for_each_field([&r, n](auto& field) { r.get_vector(field, n); });
    try {  // released optional fields (the solver's virtual set) come back released
      set->check_field_sizes("checkpoint '" + path + "'");
    } catch (const std::invalid_argument& e) {
      throw std::runtime_error(std::string(e.what()) + " (damaged)");
    }
  }
  c.real_series = detail::get_series(r);
  c.virtual_series = detail::get_series(r);
  c.errors.resize(r.get<std::uint64_t>());
  for (auto& e : c.errors) {
    e.time = r.get<double>();
    e.name = r.get_string();
    e.value = r.get<double>();
  }
  if (!r.at_end()) throw std::runtime_error("checkpoint '" + path + "' is damaged (trailing bytes)");
  return c;
}

}  // namespace tsph::output
