#include "engine/output/vtu_writer.hpp"

#include "engine/output_file.hpp"

#include <chrono>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <string>

#include <fcntl.h>
#include <unistd.h>

namespace tsph::output {
namespace {

static_assert(sizeof(double) == 8 && sizeof(std::uint64_t) == 8);

bool little_endian() {
  const std::uint16_t probe = 1;
  return *reinterpret_cast<const unsigned char*>(&probe) == 1;
}

/// A file written under `path.tmp`, flushed to disk and renamed onto `path` on commit.
/// Every failure (open, write, flush, fsync, close, rename: a full disk, a read-only or
/// vanished directory) throws OutputError naming `path` and the reason, removes the
/// temporary file and leaves `path` as it was.
class AtomicFile {
 public:
  explicit AtomicFile(std::string path) : path_(std::move(path)), temporary_(path_ + ".tmp") {
    file_ = std::fopen(temporary_.c_str(), "wb");
    if (!file_) throw_output_error(path_, "open", errno);
  }
  ~AtomicFile() {
    if (file_) std::fclose(file_);
    if (!committed_) std::remove(temporary_.c_str());
  }
  void write(const void* data, std::size_t bytes) {
    if (bytes > 0 && std::fwrite(data, 1, bytes, file_) != bytes) throw_output_error(path_, "write", errno);
  }
  void write(const std::string& text) { write(text.data(), text.size()); }
  /// `durable`: fsync before the rename (checkpoints); frames only need the rename,
  /// which already keeps readers from seeing half a file.
  void commit(bool durable) {
    if (std::fflush(file_) != 0) throw_output_error(path_, "write", errno);
    if (durable && ::fsync(::fileno(file_)) != 0 && errno != EINVAL) throw_output_error(path_, "fsync", errno);
    const int closed = std::fclose(file_);
    file_ = nullptr;
    if (closed != 0) throw_output_error(path_, "close", errno);
    if (std::rename(temporary_.c_str(), path_.c_str()) != 0) throw_output_error(path_, "rename", errno);
    committed_ = true;
  }

 private:
  std::string path_, temporary_;
  std::FILE* file_ = nullptr;
  bool committed_ = false;
};

std::string xml_escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

}  // namespace

void write_vtu(const std::string& path, const VtuFrame& frame) {
  if (!little_endian()) throw std::runtime_error("VTU output assumes a little-endian machine");
  const std::uint64_t n = frame.point_count;
  if (frame.points.size() != 3 * n) throw std::logic_error("write_vtu: points must hold 3 per point");

  // The header, with the offset of each block in the appended section.
  std::uint64_t offset = 0;
  std::string header =
      "<?xml version=\"1.0\"?>\n"
      "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" "
      "header_type=\"UInt64\">\n  <UnstructuredGrid>\n    <Piece NumberOfPoints=\"" +
      std::to_string(n) + "\" NumberOfCells=\"" + std::to_string(n) + "\">\n      <PointData>\n";
  auto data_array = [&](const std::string& type, const std::string& name, int components,
                        std::uint64_t bytes) {
    std::string line = "<DataArray type=\"" + type + "\"";
    if (!name.empty()) line += " Name=\"" + xml_escape(name) + "\"";
    line += " NumberOfComponents=\"" + std::to_string(components) +
            "\" format=\"appended\" offset=\"" + std::to_string(offset) + "\"/>\n";
    offset += 8 + bytes;
    return line;
  };
  for (const auto& a : frame.arrays) {
    const std::size_t values = a.is_uint32 ? a.uint32.size() : a.float64.size();
    if (values != n * static_cast<std::size_t>(a.components))
      throw std::logic_error("write_vtu: array '" + a.name + "' has the wrong size");
    header += "        " + data_array(a.is_uint32 ? "UInt32" : "Float64", a.name, a.components,
                                      values * (a.is_uint32 ? 4 : 8));
  }
  // One call per statement: the offsets must follow the order of the blocks.
  header += "      </PointData>\n      <Points>\n        ";
  header += data_array("Float64", "Points", 3, 3 * n * 8);
  header += "      </Points>\n      <Cells>\n        ";
  header += data_array("Int64", "connectivity", 1, n * 8);
  header += "        ";
  header += data_array("Int64", "offsets", 1, n * 8);
  header += "        ";
  header += data_array("UInt8", "types", 1, n);
  header += "      </Cells>\n    </Piece>\n  </UnstructuredGrid>\n  <AppendedData encoding=\"raw\">\n   _";

  AtomicFile file(path);
  file.write(header);
  auto block = [&](const void* data, std::uint64_t bytes) {
    file.write(&bytes, 8);
    file.write(data, bytes);
  };
  for (const auto& a : frame.arrays) {
    if (a.is_uint32) block(a.uint32.data(), a.uint32.size() * 4);
    else block(a.float64.data(), a.float64.size() * 8);
  }
  block(frame.points.data(), 3 * n * 8);
  std::vector<std::int64_t> counting(n);
  for (std::uint64_t i = 0; i < n; ++i) counting[i] = static_cast<std::int64_t>(i);
  block(counting.data(), n * 8);  // connectivity: point i
  for (std::uint64_t i = 0; i < n; ++i) counting[i] = static_cast<std::int64_t>(i + 1);
  block(counting.data(), n * 8);  // offsets: one point per cell
  const std::vector<std::uint8_t> types(n, 1);  // VTK_VERTEX
  block(types.data(), n);
  file.write("\n  </AppendedData>\n</VTKFile>\n");
  file.commit(false);
}

void write_pvd(const std::string& path, const std::vector<PvdEntry>& entries) {
  std::string text =
      "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"1.0\" "
      "byte_order=\"LittleEndian\">\n  <Collection>\n";
  char time[64];
  for (const auto& e : entries) {
    std::snprintf(time, sizeof time, "%.17g", e.time);
    text += "    <DataSet timestep=\"" + std::string(time) + "\" part=\"0\" file=\"" +
            xml_escape(e.file) + "\"/>\n";
  }
  text += "  </Collection>\n</VTKFile>\n";
  write_text_file(path, text);
}

void write_text_file(const std::string& path, const std::string& text, bool durable) {
  AtomicFile file(path);
  file.write(text);
  file.commit(durable);
}

BackgroundWriter::~BackgroundWriter() {
  if (pending_.valid()) pending_.wait();
}

void BackgroundWriter::submit(std::function<void()> job) {
  finish();
  pending_ = std::async(std::launch::async, [job = std::move(job)] {
    const auto start = std::chrono::steady_clock::now();
    job();
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  });
}

void BackgroundWriter::finish() {
  if (!pending_.valid()) return;
  const auto start = std::chrono::steady_clock::now();
  pending_.wait();
  waited_seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  busy_seconds_ += pending_.get();  // rethrows the job's exception
}

}  // namespace tsph::output
