// VTK XML output for ParaView: one UnstructuredGrid file (.vtu) per frame, binary
// appended data in raw encoding (each block: a UInt64 byte count, then the values,
// little endian), one vertex cell per particle, and a .pvd collection listing the
// frames with their times. Files are written to a temporary name and renamed, so a
// reader never sees half a file (frames are not fsynced: that is for checkpoints).
#pragma once

#include <cstddef>
#include <cstdint>
#include <future>
#include <functional>
#include <string>
#include <vector>

namespace tsph::output {

/// One named point array: Float64 or UInt32 values, `components` per point.
struct VtuArray {
  std::string name;
  int components = 1;
  std::vector<double> float64;        ///< used when `is_uint32` is false
  std::vector<std::uint32_t> uint32;  ///< used when `is_uint32` is true
  bool is_uint32 = false;
};

/// Everything one .vtu file holds; owns its data (a snapshot), so it can be written
/// by a background thread while the solver goes on.
struct VtuFrame {
  std::size_t point_count = 0;
  std::vector<double> points;  ///< 3 per point (missing coordinates are 0)
  std::vector<VtuArray> arrays;
};

/// Writes the frame to `path` (via `path.tmp` and a rename). Throws OutputError (output_file.hpp)
/// naming the file if it cannot be written.
void write_vtu(const std::string& path, const VtuFrame& frame);

struct PvdEntry {
  double time = 0.0;
  std::string file;  ///< relative to the .pvd file
};
void write_pvd(const std::string& path, const std::vector<PvdEntry>& entries);

/// Runs write jobs one at a time on a background thread: `submit` waits for the
/// previous job (so at most one snapshot is in flight), `finish` waits for the last.
/// An exception from a job is rethrown by the next `submit` or `finish`.
class BackgroundWriter {
 public:
  ~BackgroundWriter();
  void submit(std::function<void()> job);
  void finish();
  double busy_seconds() const { return busy_seconds_; }      ///< time the jobs took
  double waited_seconds() const { return waited_seconds_; }  ///< time the caller waited

 private:
  std::future<double> pending_;
  double busy_seconds_ = 0.0, waited_seconds_ = 0.0;
};

/// Writes `text` to `path` atomically (temporary file, flush, rename), with an fsync
/// before the rename if `durable`.
void write_text_file(const std::string& path, const std::string& text, bool durable = false);

}  // namespace tsph::output
