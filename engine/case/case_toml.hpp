// The TOML reading behind load_case (engine/case/case_file.cpp, its only includer): a
// Table wraps a toml++ table and reads keys with their types, ranges and messages
// ("FILE:LINE:COLUMN: key = value is invalid: what is allowed"; unknown keys name the
// nearest valid one), and --set overrides are applied to the parsed table.
#pragma once

#include "engine/case/case_file.hpp"
#include "engine/input_error.hpp"

#include <toml++/toml.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <functional>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

namespace tsph {
namespace {

std::string join(const std::vector<std::string>& items) {
  std::string out;
  for (const auto& s : items) out += (out.empty() ? "" : ", ") + s;
  return out;
}

/// The candidate closest to `word` by edit distance, or "" if none is close (at most
/// half the word's length, and at least 2, edits away).
std::string nearest(const std::string& word, const std::vector<std::string>& candidates) {
  std::string best;
  std::size_t best_distance = std::string::npos;
  for (const auto& c : candidates) {
    const std::size_t d = edit_distance(word, c);
    if (d < best_distance) {
      best_distance = d;
      best = c;
    }
  }
  return best_distance <= std::max<std::size_t>(2, word.size() / 2) ? best : "";
}

std::string did_you_mean(const std::string& suggestion, const std::string& quote = "") {
  return suggestion.empty() ? "" : " (did you mean " + quote + suggestion + quote + "?)";
}

std::string show(const toml::node& node) {
  std::ostringstream out;
  if (const auto* s = node.as_string()) out << "'" << s->get() << "'";
  else if (const auto* d = node.as_floating_point()) out << format_number(d->get());
  else if (node.is_table()) out << "a table";
  else if (node.is_array_of_tables()) out << "an array of tables";
  else node.visit([&](const auto& n) { out << n; });
  return out.str();
}

struct Context {
  std::string file;
  std::vector<std::string> errors;

  std::string where(const toml::node* node) const {
    if (node && node->source().begin.line > 0)
      return file + ":" + std::to_string(node->source().begin.line) + ":" +
             std::to_string(node->source().begin.column) + ": ";
    return file + ": ";
  }
  void invalid(const toml::node* node, const std::string& key, const std::string& allowed) {
    errors.push_back(where(node) + key + " = " + (node ? show(*node) : "?") +
                     " is invalid: " + allowed);
  }
};

/// Words that name a key by another name (checked before the edit distance).
const std::vector<std::pair<std::string, std::string>> kSynonyms = {
    {"young", "E"}, {"modulus", "E"}, {"poisson", "nu"}, {"density", "rho"},
    {"kernal", "kernel"}, {"dx", "spacing"}, {"step", "dt"}};

/// A TOML table being read: remembers the keys asked for, so that the keys left over
/// are reported as unknown (with the nearest known one suggested).
class Table {
 public:
  Table(Context& context, const toml::table* table, std::string prefix, const toml::node* self)
      : context_(context), table_(table), prefix_(std::move(prefix)), self_(self) {}

  std::string path(const std::string& key) const { return prefix_.empty() ? key : prefix_ + "." + key; }
  bool has(const std::string& key) const { return table_ && table_->contains(key); }

  const toml::node* get(const std::string& key, bool required, const std::string& example) {
    known_.push_back(key);
    const toml::node* node = table_ ? table_->get(key) : nullptr;
    if (!node && required)
      context_.errors.push_back(context_.where(self_) + "missing required key " + path(key) +
                                (prefix_.empty() ? "" : " in [" + prefix_ + "]") + ": add e.g. " +
                                key + " = " + example);
    return node;
  }

  std::optional<double> real(const std::string& key, bool required, const std::string& example,
                             const std::function<bool(double)>& ok = {},
                             const std::string& allowed = "") {
    const toml::node* node = get(key, required, example);
    if (!node) return std::nullopt;
    const auto value = node->value<double>();
    if (!value || (!node->is_floating_point() && !node->is_integer())) {
      context_.invalid(node, path(key), "must be a number, e.g. " + key + " = " + example);
      return std::nullopt;
    }
    if (!std::isfinite(*value)) {
      context_.invalid(node, path(key), "must be finite");
      return std::nullopt;
    }
    if (ok && !ok(*value)) {
      context_.invalid(node, path(key), allowed);
      return std::nullopt;
    }
    return value;
  }

  std::optional<std::int64_t> integer(const std::string& key, bool required,
                                      const std::string& example,
                                      const std::function<bool(std::int64_t)>& ok = {},
                                      const std::string& allowed = "") {
    const toml::node* node = get(key, required, example);
    if (!node) return std::nullopt;
    if (!node->is_integer()) {
      context_.invalid(node, path(key), "must be an integer, e.g. " + key + " = " + example);
      return std::nullopt;
    }
    const std::int64_t value = *node->value<std::int64_t>();
    if (ok && !ok(value)) {
      context_.invalid(node, path(key), allowed);
      return std::nullopt;
    }
    return value;
  }

  std::optional<bool> boolean(const std::string& key) {
    const toml::node* node = get(key, false, "true");
    if (!node) return std::nullopt;
    if (!node->is_boolean()) {
      context_.invalid(node, path(key), "must be true or false");
      return std::nullopt;
    }
    return node->value<bool>();
  }

  std::optional<std::string> text(const std::string& key, bool required,
                                  const std::vector<std::string>& choices = {},
                                  const std::string& example = "\"...\"") {
    const toml::node* node =
        get(key, required, choices.empty() ? example : "\"" + choices.front() + "\"");
    if (!node) return std::nullopt;
    if (!node->is_string()) {
      context_.invalid(node, path(key),
                       choices.empty() ? "must be a string in quotes"
                                       : "must be one of (in quotes): " + join(choices));
      return std::nullopt;
    }
    std::string value = *node->value<std::string>();
    if (!choices.empty() && std::find(choices.begin(), choices.end(), value) == choices.end()) {
      context_.invalid(node, path(key), "must be one of: " + join(choices) + did_you_mean(nearest(value, choices), "'"));
      return std::nullopt;
    }
    return value;
  }

  /// An array of numbers; `size` > 0 requires that many (the dimension).
  std::optional<std::vector<double>> numbers(const std::string& key, bool required,
                                             std::size_t size, const std::string& what) {
    std::string example = "[";
    const bool unit = key == "normal" || key == "direction";  // issue 15: a valid example (non-zero)
    for (std::size_t k = 0; k < std::max<std::size_t>(size, 1); ++k) example += k ? ", 0.0" : unit ? "1.0" : "0.0";
    example += "]";
    const toml::node* node = get(key, required, example);
    if (!node) return std::nullopt;
    const toml::array* array = node->as_array();
    std::vector<double> values;
    bool ok = array != nullptr;
    if (array)
      for (const auto& item : *array) {
        const auto v = item.value<double>();
        if (!v || !std::isfinite(*v) || (!item.is_integer() && !item.is_floating_point())) ok = false;
        else values.push_back(*v);
      }
    if (!ok) {
      context_.invalid(node, path(key), "must be an array of finite numbers, e.g. " + key + " = " + example);
      return std::nullopt;
    }
    if (size > 0 && values.size() != size) {
      context_.invalid(node, path(key),
                       "must have " + std::to_string(size) + " components (" + what + ")");
      return std::nullopt;
    }
    return values;
  }

  std::optional<std::vector<std::string>> strings(const std::string& key,
                                                  const std::vector<std::string>& choices) {
    const toml::node* node = get(key, false, "[\"" + choices.front() + "\"]");
    if (!node) return std::nullopt;
    const toml::array* array = node->as_array();
    std::vector<std::string> values;
    if (array)
      for (const auto& item : *array) {
        const auto* s = item.as_string();
        if (!s) {
          array = nullptr;
          break;
        }
        if (std::find(choices.begin(), choices.end(), s->get()) == choices.end()) {
          context_.errors.push_back(context_.where(&item) + path(key) + " entry '" + s->get() +
                                    "' is invalid: must be one of: " + join(choices) +
                                    did_you_mean(nearest(s->get(), choices), "'"));
          return std::nullopt;
        }
        values.push_back(s->get());
      }
    if (!array) {
      context_.invalid(node, path(key), "must be an array of strings, e.g. [\"" + choices.front() + "\"]");
      return std::nullopt;
    }
    return values;
  }

  /// A sub-table (or an inline table); an absent optional one reads as empty.
  Table table(const std::string& key, bool required) {
    const toml::node* node = get(key, required, "{ ... } (or a [" + path(key) + "] section)");
    const toml::table* sub = node ? node->as_table() : nullptr;
    if (node && !sub) context_.invalid(node, path(key), "must be a table ([" + path(key) + "])");
    return Table(context_, sub, path(key), node ? node : self_);
  }

  /// An array of tables ([[key]]).
  std::vector<Table> tables(const std::string& key) {
    const toml::node* node = get(key, false, "");
    std::vector<Table> out;
    if (!node) return out;
    const toml::array* array = node->as_array();
    if (!array || (!array->empty() && !array->is_array_of_tables())) {  // issue 15: [] is reported by the caller
      context_.invalid(node, path(key), "must be an array of tables: write each as [[" + path(key) + "]]");
      return out;
    }
    for (std::size_t k = 0; k < array->size(); ++k)
      out.emplace_back(context_, (*array)[k].as_table(), path(key) + "[" + std::to_string(k) + "]",
                       &(*array)[k]);
    return out;
  }

  /// Reports every key of the table that was never asked for.
  void finish() {
    if (!table_) return;
    for (const auto& [key, node] : *table_) {
      const std::string name(key.str());
      if (std::find(known_.begin(), known_.end(), name) != known_.end()) continue;
      std::string suggestion = nearest(name, known_);
      std::string lower = name;
      for (char& ch : lower) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
      for (const auto& [word, key_name] : kSynonyms)
        if (lower.find(word) != std::string::npos &&
            std::find(known_.begin(), known_.end(), key_name) != known_.end())
          suggestion = key_name;
      const std::string where = key.source().begin.line > 0
                                    ? context_.file + ":" + std::to_string(key.source().begin.line) + ":" +
                                          std::to_string(key.source().begin.column) + ": "
                                    : context_.where(&node);
      context_.errors.push_back(where + "unknown key " + path(name) +
                                (suggestion.empty() ? std::string() : ": did you mean " + path(suggestion) + "?") +
                                " (valid keys" +
                                (prefix_.empty() ? "" : " in [" + prefix_ + "]") + ": " +
                                join(known_) + ")");
    }
  }

  bool present() const { return table_ != nullptr; }
  const toml::node* self() const { return self_; }
  Context& context() { return context_; }

 private:
  Context& context_;
  const toml::table* table_;
  std::string prefix_;
  const toml::node* self_;
  std::vector<std::string> known_;
};

auto positive = [](double v) { return v > 0.0; };
auto non_negative = [](double v) { return v >= 0.0; };
const std::string kPositive = "must be positive";

/// Applies one --set override ("a.b.c=value") to the table.
void apply_override(toml::table& root, const std::string& text, Context& context) {
  const auto equals = text.find('=');
  if (equals == std::string::npos || equals == 0) {
    context.errors.push_back(context.file + ": --set '" + text +
                             "' is invalid: write --set key=value, e.g. --set material.E=2e8");
    return;
  }
  const std::string key = text.substr(0, equals), raw = text.substr(equals + 1);
  toml::table parsed;
  try {
    parsed = toml::parse("v = " + raw);
  } catch (const toml::parse_error&) {
    parsed = toml::table{};
    parsed.insert("v", raw);  // a bare word: a string
  }
  std::vector<std::string> parts;
  std::stringstream in(key);
  for (std::string part; std::getline(in, part, '.');) parts.push_back(part);
  toml::node* current = &root;
  for (std::size_t k = 0; k + 1 < parts.size(); ++k) {
    if (auto* table = current->as_table()) {
      if (!table->contains(parts[k])) table->insert(parts[k], toml::table{});
      current = table->get(parts[k]);
    } else if (auto* array = current->as_array()) {
      std::size_t index = 0;
      const auto [end, ec] = std::from_chars(parts[k].data(), parts[k].data() + parts[k].size(), index);
      if (ec != std::errc{} || end != parts[k].data() + parts[k].size() || index >= array->size()) {
        context.errors.push_back(context.file + ": --set " + key + ": '" + parts[k] +
                                 "' is not an index of the array (0 to " +
                                 std::to_string(array->size() == 0 ? 0 : array->size() - 1) + ")");
        return;
      }
      current = array->get(index);
    } else {
      context.errors.push_back(context.file + ": --set " + key + ": '" + parts[k] +
                               "' is not a table");
      return;
    }
  }
  auto* table = current->as_table();
  if (!table) {
    context.errors.push_back(context.file + ": --set " + key + ": the parent of '" + parts.back() +
                             "' is not a table");
    return;
  }
  if (const auto* existing = table->get(parts.back()); existing && (existing->is_table() || existing->is_array_of_tables())) {
    context.errors.push_back(context.file + ": --set " + key +
                             " names a table; --set overrides scalars and arrays only");
    return;
  }
  // Overridden nodes have no source position; messages about them name the key.
  table->insert_or_assign(parts.back(), *parsed.get("v"));
}

}  // namespace
}  // namespace tsph
