// libFuzzer target: the particle file reader (engine/particle_file.*) on arbitrary bytes.
//
// The first byte picks the dimension (1, 2 or 3), the rest is the CSV text. A rejected
// file must end in std::invalid_argument (the reader's one error channel, whose message
// the command line prints); any other exception, a crash or a sanitizer report is a
// finding. An accepted file also goes through make_virtual_particles, as a case would.
#include "engine/particle_file.hpp"

#include <cstddef>
#include <cstdint>
#include <sstream>
#include <stdexcept>
#include <string>

namespace {

template <int Dim>
void read(const std::string& text) {
  std::istringstream in(text);
  const tsph::ParticleSet<Dim> real = tsph::read_particle_csv<Dim>(in, "fuzz.csv", 0.1, 1000.0);
  if (real.size() == 0) __builtin_trap();  // the reader promises at least one particle
  (void)tsph::make_virtual_particles<Dim>(real, 0.1, 1000.0);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const int dim = 1 + data[0] % 3;
  const std::string text(reinterpret_cast<const char*>(data + 1), size - 1);
  try {
    if (dim == 1) read<1>(text);
    else if (dim == 2) read<2>(text);
    else read<3>(text);
  } catch (const std::invalid_argument&) {
    // a clean refusal with a message
  }
  return 0;
}
