// The summary.json of a run that ran out of memory (issue 15, docs/reliability.md):
// std::bad_alloc unwinds the run, which frees what it held, and this small summary is
// written in its place (the fields of case_run.cpp's summary that are known without the
// run: program, version, case, overrides, status "out_of_memory", message).
#pragma once

#include "engine/output/vtu_writer.hpp"
#include "engine/output_file.hpp"

#include <filesystem>
#include <string>
#include <vector>

namespace tsph {

inline std::string json_quoted(const std::string& s) {
  std::string out = "\"";
  for (char ch : s) {
    if (ch == '"' || ch == '\\') out += '\\';
    if (static_cast<unsigned char>(ch) < 0x20) {
      const char* hex = "0123456789abcdef";
      out += std::string("\\u00") + hex[(ch >> 4) & 0xf] + hex[ch & 0xf];
    } else {
      out += ch;
    }
  }
  return out + "\"";
}

/// Writes out_dir/summary.json; returns what to tell the user (where it is, or why not).
inline std::string write_out_of_memory_summary(const std::string& out_dir, const std::string& case_path,
                                               const std::string& version,
                                               const std::vector<std::string>& overrides) {
  std::string list;
  for (const auto& o : overrides) list += (list.empty() ? "" : ", ") + json_quoted(o);
  const std::string message =
      "the run ran out of memory: use a larger geometry.spacing or a smaller body, write fewer "
      "frames, or run on a machine (or under a limit: ulimit -v, the control group) with more memory";
  const std::string text = "{\n  \"program\": \"tsph\",\n  \"version\": " + json_quoted(version) +
                           ",\n  \"case\": " + json_quoted(case_path) + ",\n  \"overrides\": [" + list +
                           "],\n  \"status\": \"out_of_memory\",\n  \"message\": " + json_quoted(message) + "\n}\n";
  const std::string path = (std::filesystem::path(out_dir) / "summary.json").string();
  try {
    output::write_text_file(path, text);
  } catch (const std::exception& e) {
    return message + " (summary.json not written: " + e.what() + ")";
  }
  return message + "; status in " + path;
}

}  // namespace tsph
