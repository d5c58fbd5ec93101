// libFuzzer target: the checkpoint reader (engine/output/checkpoint.hpp) on arbitrary
// bytes.
//
// The first byte picks the dimension (1, 2 or 3: byte % 3) and whether the rest is
// read as it is or with its body size and crc32 made right first (byte & 4): random
// bytes almost never carry a matching checksum, so without the repair the fuzzer would
// only ever reach the checksum check. A rejected checkpoint must end in CheckpointError
// (the reader's one error channel, whose message the command line prints); any other
// exception, a crash or a sanitizer report is a finding. An accepted one must hold
// particle sets whose fields agree in size.
#include "engine/output/checkpoint.hpp"

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

namespace {

template <int Dim>
void read(const std::vector<char>& bytes) {
  tsph::output::Checkpoint<Dim> c = tsph::output::parse_checkpoint<Dim>(bytes, "fuzz.bin");
  c.real.check_field_sizes("fuzz");
  c.virtual_particles.check_field_sizes("fuzz");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const int dim = 1 + data[0] % 3;
  const bool repair = (data[0] & 4) != 0;
  std::vector<char> bytes(reinterpret_cast<const char*>(data + 1), reinterpret_cast<const char*>(data + size));
  constexpr std::size_t prefix = tsph::output::detail::kCheckpointPrefixBytes;
  if (repair && bytes.size() >= prefix) {
    const std::uint64_t body = bytes.size() - prefix;
    const std::uint32_t crc = tsph::output::detail::crc32_of(bytes.data() + prefix, body);
    std::memcpy(bytes.data() + 8, &body, sizeof body);
    std::memcpy(bytes.data() + 16, &crc, sizeof crc);
  }
  try {
    if (dim == 1) read<1>(bytes);
    else if (dim == 2) read<2>(bytes);
    else read<3>(bytes);
  } catch (const tsph::output::CheckpointError&) {
    // a clean refusal with a message
  }
  return 0;
}
