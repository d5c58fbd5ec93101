// libFuzzer target: the case-file parser (engine/case/case_file.*) on arbitrary bytes,
// then, for a case it accepts, the up-front resource estimate and, when that is small,
// the build of the case itself (geometry, boundary regions, the solver's checks).
//
// The input is the TOML text; its lines that start with "#--set " (TOML comments) are
// also passed as --set overrides. A refused case must end in CaseError (the parser's one
// error channel, whose messages tsph prints); any other exception, a crash, a hang, a
// leak or a sanitizer report is a finding. Cases that name a particle file are not
// built (the path could name any file of the machine: the particle reader has its own
// target, fuzz_particle_file).
#include "engine/case/case_file.hpp"
#include "engine/case/case_run.hpp"

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

namespace {

/// One file per process, rewritten for every input (load_case reads a path).
const std::string& case_path() {
  static const std::string path = [] {
    char directory[] = "/tmp/fuzz_case_file.XXXXXX";
    if (!::mkdtemp(directory)) std::abort();
    return std::string(directory) + "/case.toml";
  }();
  return path;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  std::vector<std::string> overrides;
  {
    std::istringstream lines(text);
    std::string line;
    while (std::getline(lines, line))
      if (line.rfind("#--set ", 0) == 0) overrides.push_back(line.substr(7));
  }
  {
    std::ofstream file(case_path(), std::ios::binary | std::ios::trunc);
    file.write(text.data(), static_cast<std::streamsize>(text.size()));
  }
  try {
    const tsph::CaseFile c = tsph::load_case(case_path(), overrides);
    const tsph::ResourceEstimate e = tsph::estimate_resources(c);
    if (!(e.memory_bytes >= 0.0) || !(e.output_bytes >= 0.0)) __builtin_trap();  // NaN or negative
    if (c.particle_file.empty() && e.real_particles + e.virtual_particles <= 4000.0)
      (void)tsph::inspect_case(c);
  } catch (const tsph::CaseError&) {
    // a clean refusal with messages
  }
  return 0;
}
