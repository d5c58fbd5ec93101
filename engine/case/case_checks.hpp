// Case checks that need the whole resolved case (issue 15, docs/reliability.md), run at
// the end of load_case: duplicate probe names (each writes probe_<name>.csv), a step
// count that cannot be counted (time.end / dt above kMaxSteps), a fixed time.dt above
// time.end, and a particle file that is not a regular file of sane size.
#pragma once

#include "engine/case/case_file.hpp"

#include <string>
#include <vector>

namespace tsph {

/// The most time steps a run may take: 1e12 (at 1e8 particle-steps/s, one particle
/// would take three hours per 1e12 steps; the int64 step counter and the double time
/// stay exact far beyond). time.end = 1e20 at dt = 1e-5 would need 1e25.
inline constexpr double kMaxSteps = 1e12;

/// One message per problem ("FILE: key = value is invalid: rule; fix"), or none.
std::vector<std::string> whole_case_errors(const CaseFile& c);

/// The probes that name a particle id the case's real particles do not hold; `tsph
/// check` and `tsph run` give the same message. Throws CaseError.
void check_probe_particles(const CaseFile& c, std::size_t real_particles);

}  // namespace tsph
