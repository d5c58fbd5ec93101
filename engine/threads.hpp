// The one rule for thread counts (issue 15, docs/reliability.md), for the --threads
// flag and the case key `threads` alike: 0 (the OpenMP default) up to 64 x the
// hardware threads of the machine, and never above 4096. Far above that the OpenMP
// runtime fails (100000 threads: a segfault, 50000: libgomp aborts) and nothing runs
// faster: the solver's loops are bound by memory bandwidth.
#pragma once

#include <algorithm>
#include <cstdint>
#include <optional>
#include <string>
#include <thread>

namespace tsph {

inline constexpr std::int64_t kThreadsPerHardwareThread = 64;
inline constexpr std::int64_t kMaxThreads = 4096;

/// The largest thread count accepted on this machine.
inline std::int64_t max_thread_count() {
  const std::int64_t hardware = std::max<std::int64_t>(1, std::thread::hardware_concurrency());
  return std::min(kMaxThreads, kThreadsPerHardwareThread * hardware);
}

/// What a valid count is, for the messages ("must lie in [0, 128] (...)").
inline std::string thread_count_rule() {
  const std::int64_t hardware = std::max<std::int64_t>(1, std::thread::hardware_concurrency());
  return "must lie in [0, " + std::to_string(max_thread_count()) + "] (0: the OpenMP default; at most " +
         std::to_string(kThreadsPerHardwareThread) + " x the " + std::to_string(hardware) +
         " hardware threads of this machine, and at most " + std::to_string(kMaxThreads) + ")";
}

/// The message for a bad count given as `key` ("--threads", "threads"), or nothing.
inline std::optional<std::string> thread_count_error(const std::string& key, std::int64_t value) {
  if (value >= 0 && value <= max_thread_count()) return std::nullopt;
  const std::int64_t hardware = std::max<std::int64_t>(1, std::thread::hardware_concurrency());
  return key + " = " + std::to_string(value) + " is invalid: " + thread_count_rule() + "; use e.g. " + key +
         (key.rfind("--", 0) == 0 ? " " : " = ") + std::to_string(hardware);
}

}  // namespace tsph
