// What every tsph command-line program shares: exit codes, parsing, output directory.
#pragma once

#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include <filesystem>
#include <optional>
#include <string>
#include <system_error>

namespace tsph::cli {

constexpr int kExitOk = 0;
constexpr int kExitFailure = 1;
constexpr int kExitBadInput = 2;
constexpr int kExitNotConverged = 3;
constexpr int kExitDiverged = 3;  ///< NaN/Inf or runaway energy (SolutionDiverged)
constexpr int kExitValidationFailed = 4;  ///< tsph validate: some check failed

/// Parses the command line; returns the exit status if the program should stop now
/// (0 after --help, kExitBadInput after a parse error, whose message CLI11 printed).
inline std::optional<int> parse(CLI::App& app, int argc, char** argv) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? kExitOk : kExitBadInput;
  }
  return std::nullopt;
}

/// Creates the output directory; on failure prints one message naming it and returns false.
inline bool prepare_output_directory(const std::string& program, const std::string& path) {
  std::error_code ec;
  std::filesystem::create_directories(path, ec);
  if (!ec && std::filesystem::is_directory(path)) return true;
  fmt::print(stderr, "{}: error: out = '{}' cannot be created ({}); choose a writable directory\n",
             program, path, ec ? ec.message() : "not a directory");
  return false;
}

}  // namespace tsph::cli
