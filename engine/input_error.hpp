// Validation results shared by every case: a failure names the parameter, its value
// and what is allowed (docs/conventions.md: "Errors are values at the edges").
#pragma once

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace tsph {

struct InputError {
  std::string parameter;
  std::string value;
  std::string allowed;
  std::string message() const { return parameter + " = " + value + " is invalid: " + allowed; }
};

/// A number as a user would type it (shortest round-trip-free form).
inline std::string format_number(double v) {
  std::ostringstream out;
  out << v;
  return out.str();
}

/// Appends an error unless `value` is positive and finite.
inline void require_positive(std::vector<InputError>& errors, const char* name, double value) {
  if (!(value > 0.0) || !std::isfinite(value))
    errors.push_back({name, format_number(value), "must be a positive finite number"});
}

/// Throws std::invalid_argument with every message, one per line, if there are any.
inline void throw_if_invalid(const std::vector<InputError>& errors) {
  if (errors.empty()) return;
  std::string message;
  for (const auto& e : errors) {
    if (!message.empty()) message += "\n";
    message += e.message();
  }
  throw std::invalid_argument(message);
}

}  // namespace tsph
