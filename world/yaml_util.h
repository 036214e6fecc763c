// Reading hand-written YAML files (floorplans, scenarios) with errors that name the file, line
// and key: a thin, strict layer over yaml-cpp. Accessors throw InputError; each parser's public
// entry point catches it and returns the Error, so nothing is thrown out of the libraries.
// Numbers are parsed locale-independently and must be finite; keys are checked against an
// allowed list; duplicate keys are errors.
#pragma once

#include <yaml-cpp/yaml.h>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "common/geometry.h"
#include "world/status.h"

namespace vigil::yaml_input {

// The exception the accessors throw; carries the finished Error.
struct InputError {
  Error error;
};

// Throws InputError(bad_input(...)).
[[noreturn]] void fail(const std::string& file, int line, const std::string& key,
                       const std::string& message);

// Reads a whole (regular, at most `max_bytes`) file; throws InputError naming it otherwise.
std::string read_text_file(const std::filesystem::path& path, size_t max_bytes = 16u << 20);

// Parses one YAML document; syntax errors carry the line of yaml-cpp's mark. An empty document
// or more than one document is an error.
YAML::Node parse_document(const std::string& text, const std::string& file);

// Quotes and shortens user text for a message.
std::string quoted(const std::string& text);

class Mapping;

// A node of the document with the file, key path (e.g. "people[1].script[0].walk_to") and line
// it came from.
class Value {
 public:
  Value(YAML::Node node, std::shared_ptr<const std::string> file, std::string key, int line);

  const YAML::Node& node() const { return node_; }
  const std::string& file() const { return *file_; }
  const std::shared_ptr<const std::string>& file_ptr() const { return file_; }
  const std::string& key() const { return key_; }
  int line() const { return line_; }

  // Throws an InputError at this value's line and key.
  [[noreturn]] void fail(const std::string& message) const;
  // The Error fail() would throw.
  Error error(const std::string& message) const;

  bool is_null() const { return node_.IsNull(); }
  bool is_scalar() const { return node_.IsScalar(); }
  bool is_sequence() const { return node_.IsSequence(); }
  bool is_mapping() const { return node_.IsMap(); }
  // True for a scalar written in quotes ("1.5" is then a string, not a number).
  bool is_quoted() const;
  // True when this is a plain scalar that reads as a number (possibly non-finite).
  bool looks_numeric() const;

  double number() const;                          // a finite number
  double number_in(double lo, double hi) const;   // finite, lo <= x <= hi
  double positive(double hi = 1e12) const;        // 0 < x <= hi
  double non_negative(double hi = 1e12) const;    // 0 <= x <= hi
  int64_t integer(int64_t lo, int64_t hi) const;  // whole number in [lo, hi]
  uint64_t unsigned_integer() const;              // 0 .. 2^64-1, digits only
  bool boolean() const;                           // true or false
  std::string string() const;                     // a non-empty scalar
  std::string identifier() const;                 // letters, digits, '_', '-', '.'; 1..64 chars
  std::string colour() const;                     // "#rrggbb" (lower-cased)
  // A list of numbers: exactly `n` when n > 0, otherwise between min_n and max_n.
  std::vector<double> numbers(size_t n, size_t min_n = 0, size_t max_n = 1u << 20) const;
  Vec2 point() const;  // [x, y]

  // Items of a list (null reads as an empty list).
  std::vector<Value> items() const;
  // This value as a mapping with only the `allowed` keys (null reads as an empty mapping).
  Mapping mapping(const std::vector<std::string>& allowed) const;
  // This value as a mapping whose keys are free-form names (e.g. places, plugin parameters).
  Mapping open_mapping() const;

 private:
  YAML::Node node_;
  std::shared_ptr<const std::string> file_;
  std::string key_;
  int line_;
};

// A checked mapping: keys are plain scalars, unique, and among the allowed ones.
class Mapping {
 public:
  // Checks `self` against `allowed`; with `any_key` every identifier-like key is accepted.
  Mapping(const Value& self, const std::vector<std::string>& allowed, bool any_key = false);

  const Value& self() const { return self_; }
  bool has(const std::string& key) const { return find(key) != nullptr; }
  std::optional<Value> get(const std::string& key) const;
  // The value, or an error "missing required key" at the mapping's line.
  Value require(const std::string& key) const;
  // All entries in file order.
  const std::vector<std::pair<std::string, Value>>& entries() const { return entries_; }

 private:
  const Value* find(const std::string& key) const;
  Value self_;
  std::vector<std::pair<std::string, Value>> entries_;
};

// The 1-based line of a node's mark, or `fallback` when it has none.
int line_of(const YAML::Node& node, int fallback);

}  // namespace vigil::yaml_input
