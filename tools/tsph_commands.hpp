// The study subcommands of tsph beside `run` and `check` (tools/tsph.cpp): each adds
// its subcommand to the application and returns what runs it once parsed.
#pragma once

#include <CLI/CLI.hpp>

#include <functional>
#include <string>
#include <vector>

namespace tsph::cli {

struct Subcommand {
  CLI::App* app = nullptr;
  std::function<int()> run;  ///< the exit status
};

/// `tsph table1`: the seed's Table 1 (tools/tsph_table1.cpp).
Subcommand add_table1(CLI::App& app);
/// `tsph spectrum CASE`: the one-step map of a case (tools/tsph_spectrum.cpp).
Subcommand add_spectrum(CLI::App& app);
/// `tsph converge CASE --sweep KEY=V1,V2,...`: a convergence study (tools/tsph_converge.cpp).
Subcommand add_converge(CLI::App& app);

/// `tsph validate [NAME...]`: the large-deformation validation suite
/// (tools/tsph_validate.cpp); argv is kept for the command line in its table.
Subcommand add_validate(CLI::App& app, int argc, char** argv);

/// The JSON text of a string, quoted.
std::string json_quote(const std::string& text);

/// Replaces `dir` (a directory a study owns: its run directories) by an empty one; on
/// failure prints a message naming it and returns false.
bool fresh_directory(const std::string& program, const std::string& dir);

}  // namespace tsph::cli
