// Case checks that need the whole resolved case (issue 15, docs/reliability.md), run at
// the end of load_case: duplicate probe names (each writes probe_<name>.csv), a step
// count that cannot be counted (time.end / dt above kMaxSteps), a fixed time.dt above
// time.end, and a particle file that is not a regular file of sane size.
#pragma once

#include "engine/case/case_file.hpp"

#include <string>
#include <vector>

namespace tsph {

/// The most time steps a run may take: 1e15. The run's time t advances by dt only while
/// t / dt stays well below 2^53 (9.0e15, the doubles' integer range), and the int64 step
/// counter overflows at 9.2e18. time.end = 1e20 at dt = 5e-5 would need 2e24.
inline constexpr double kMaxSteps = 1e15;

/// One message per problem ("FILE: key = value is invalid: rule; fix"), or none.
std::vector<std::string> whole_case_errors(const CaseFile& c);

/// The probes that name a particle id the case's real particles do not hold; `tsph
/// check` and `tsph run` give the same message. Throws CaseError.
void check_probe_particles(const CaseFile& c, std::size_t real_particles);

}  // namespace tsph
