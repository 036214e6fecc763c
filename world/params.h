// Plugin parameters, after OMPL's declareParam: each plugin declares its parameters with a
// type, default and range; the scenario's values are checked against the declaration and any
// error names the scenario file, line and key.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "world/status.h"

namespace vigil {

// A scenario value: number, bool, string, list of numbers or list of strings.
using ParamValue = std::variant<double, bool, std::string, std::vector<double>, std::vector<std::string>>;

enum class ParamType { kNumber, kInteger, kBool, kString, kNumberList, kStringList };
const char* to_string(ParamType t);

// A value as written in the scenario, with where it was written.
struct ParamEntry {
  ParamValue value;
  int line = 0;
};

// What a plugin accepts.
struct ParamSpec {
  std::string name;
  ParamType type = ParamType::kNumber;
  ParamValue default_value;
  double min = -1e300, max = 1e300;  // for numbers, integers and each element of number lists
  std::string description;
};

// A checked, complete set of parameters: every declared name has a value.
class ParamSet {
 public:
  double number(const std::string& name) const;
  int integer(const std::string& name) const;
  bool boolean(const std::string& name) const;
  const std::string& string(const std::string& name) const;
  const std::vector<double>& numbers(const std::string& name) const;
  const std::vector<std::string>& strings(const std::string& name) const;
  bool has(const std::string& name) const { return values_.count(name) != 0; }
  void set(const std::string& name, ParamValue v) { values_[name] = std::move(v); }

 private:
  std::map<std::string, ParamValue> values_;
};

// Checks `given` against `specs`: unknown names, wrong types and out-of-range values are
// errors naming `file`, the entry's line and `key_prefix` + "." + name. Missing names take
// their defaults.
Result<ParamSet> resolve_params(const std::vector<ParamSpec>& specs,
                                const std::map<std::string, ParamEntry>& given,
                                const std::string& file, const std::string& key_prefix);

}  // namespace vigil
