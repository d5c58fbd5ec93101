// The progress line of a run: step, simulated time, percentage, ETA and particle-steps
// per second. On a terminal it is redrawn in place (carriage return) every 0.5 s; into
// a file or a pipe it is a plain line every 10 s. Nothing when quiet.
#pragma once

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <string>

#include <fmt/core.h>
#include <unistd.h>

namespace tsph::output {

class ProgressLine {
 public:
  ProgressLine(std::FILE* stream, bool quiet, double end_time, std::size_t particles)
      : stream_(stream), quiet_(quiet), end_time_(end_time), particles_(particles),
        terminal_(stream != nullptr && ::isatty(::fileno(stream)) != 0),
        start_(Clock::now()), last_(start_) {}

  bool terminal() const { return terminal_; }

  /// Called after every step; prints at most every 0.5 s (terminal) or 10 s (otherwise).
  void update(std::int64_t step, double time) {
    if (quiet_ || !stream_) return;
    const auto now = Clock::now();
    const double since = std::chrono::duration<double>(now - last_).count();
    if (since < (terminal_ ? 0.5 : 10.0)) return;
    last_ = now;
    print(step, time, now, false);
  }

  /// The last line (terminal: ends the in-place line).
  void finish(std::int64_t step, double time) {
    if (quiet_ || !stream_) return;
    if (terminal_) print(step, time, Clock::now(), true);
  }

  /// Text of one line (tested): step, t, %, ETA, particle-steps/s.
  static std::string format(std::int64_t step, double time, double end_time, double elapsed,
                            std::size_t particles) {
    const double fraction = end_time > 0.0 ? std::min(1.0, time / end_time) : 1.0;
    const double rate = elapsed > 0.0 ? static_cast<double>(particles) * static_cast<double>(step) / elapsed : 0.0;
    std::string eta = "--";
    if (fraction > 0.0 && fraction < 1.0) {
      const double remaining = elapsed * (1.0 - fraction) / fraction;
      eta = remaining >= 3600.0 ? fmt::format("{:.1f} h", remaining / 3600.0)
            : remaining >= 60.0 ? fmt::format("{:.1f} min", remaining / 60.0)
                                : fmt::format("{:.0f} s", remaining);
    } else if (fraction >= 1.0) {
      eta = "0 s";
    }
    return fmt::format("step {:>8}  t = {:.6e} s  {:5.1f} %  ETA {:>8}  {:.3e} particle-steps/s",
                       step, time, 100.0 * fraction, eta, rate);
  }

 private:
  using Clock = std::chrono::steady_clock;
  void print(std::int64_t step, double time, Clock::time_point now, bool last) {
    const double elapsed = std::chrono::duration<double>(now - start_).count();
    const std::string line = format(step, time, end_time_, elapsed, particles_);
    if (terminal_) fmt::print(stream_, "\r{}\x1b[K{}", line, last ? "\n" : "");
    else fmt::print(stream_, "{}\n", line);
    std::fflush(stream_);
  }

  std::FILE* stream_;
  bool quiet_;
  double end_time_;
  std::size_t particles_;
  bool terminal_;
  Clock::time_point start_, last_;
};

}  // namespace tsph::output
