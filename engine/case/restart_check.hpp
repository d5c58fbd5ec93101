// What a restart checks before it writes anything (issue 15, docs/reliability.md):
// the checkpoint is intact (size and crc32, engine/output/checkpoint.hpp), falling back
// to the newest intact one of a directory, and was written by a case with the same
// resolved physics.
//
// The physics record is a canonical serialisation of the resolved CaseFile, one
// "key = value" line per key in a fixed order, numbers in their shortest round-trip
// form: every key that changes the state a run computes (geometry, with the particle
// file's size and crc32 rather than its path; material; method; solver; time.cfl or
// time.dt; boundaries; initial conditions; damping.coefficient). Left out are the
// output and run-control keys, which a continued run may change: title, threads,
// time.end, the rest criterion of [damping] (rest_velocity, rest_after, rest_probe),
// [output] and [exact].
#pragma once

#include "engine/case/case_file.hpp"

#include <cstdio>
#include <string>
#include <vector>

namespace tsph {

/// The "key = value" lines of the case's resolved physics.
std::string physics_record(const CaseFile& c);

/// "key = case value (the checkpoint: value)" for every key whose value differs, or that
/// only one of the two records holds.
std::vector<std::string> physics_differences(const std::string& checkpoint_record, const std::string& case_record);

/// The checkpoint a restart continues from: `restart` itself if it is a file, else the
/// newest intact checkpoint_*.bin of the directory (a damaged newer one is named on
/// `log`, with the failed check, and skipped). Throws CaseError (exit status 2) if the
/// file or every checkpoint of the directory is damaged, or if the physics of `c`
/// differ from the checkpoint's (naming the keys). Reads only: writes nothing.
std::string select_restart_checkpoint(const CaseFile& c, const std::string& restart, std::FILE* log);

/// The checkpoints kept in an output directory: older ones are removed after a new one
/// is written (prune_checkpoints).
inline constexpr int kKeptCheckpoints = 2;

/// Removes the checkpoint_*.bin of `dir` older than `newest` (by step number), keeping
/// the kKeptCheckpoints newest up to and including it; newer ones (another timeline)
/// are left alone.
void prune_checkpoints(const std::string& dir, const std::string& newest);

}  // namespace tsph
