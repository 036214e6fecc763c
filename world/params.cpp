#include "world/params.h"

#include <cmath>

namespace vigil {

const char* to_string(ParamType t) {
  switch (t) {
    case ParamType::kNumber: return "number";
    case ParamType::kInteger: return "integer";
    case ParamType::kBool: return "bool";
    case ParamType::kString: return "string";
    case ParamType::kNumberList: return "list of numbers";
    case ParamType::kStringList: return "list of strings";
  }
  return "?";
}

double ParamSet::number(const std::string& name) const { return std::get<double>(values_.at(name)); }
int ParamSet::integer(const std::string& name) const {
  return static_cast<int>(std::llround(std::get<double>(values_.at(name))));
}
bool ParamSet::boolean(const std::string& name) const { return std::get<bool>(values_.at(name)); }
const std::string& ParamSet::string(const std::string& name) const {
  return std::get<std::string>(values_.at(name));
}
const std::vector<double>& ParamSet::numbers(const std::string& name) const {
  return std::get<std::vector<double>>(values_.at(name));
}
const std::vector<std::string>& ParamSet::strings(const std::string& name) const {
  return std::get<std::vector<std::string>>(values_.at(name));
}

namespace {

bool type_matches(ParamType t, const ParamValue& v) {
  switch (t) {
    case ParamType::kNumber:
    case ParamType::kInteger: return std::holds_alternative<double>(v);
    case ParamType::kBool: return std::holds_alternative<bool>(v);
    case ParamType::kString: return std::holds_alternative<std::string>(v);
    case ParamType::kNumberList: return std::holds_alternative<std::vector<double>>(v);
    case ParamType::kStringList: return std::holds_alternative<std::vector<std::string>>(v);
  }
  return false;
}

std::string format_range(const ParamSpec& s) {
  return "[" + std::to_string(s.min) + ", " + std::to_string(s.max) + "]";
}

}  // namespace

Result<ParamSet> resolve_params(const std::vector<ParamSpec>& specs,
                                const std::map<std::string, ParamEntry>& given,
                                const std::string& file, const std::string& key_prefix) {
  ParamSet out;
  std::map<std::string, const ParamSpec*> by_name;
  for (const auto& s : specs) by_name[s.name] = &s;
  for (const auto& [name, entry] : given) {
    const std::string key = key_prefix.empty() ? name : key_prefix + "." + name;
    auto it = by_name.find(name);
    if (it == by_name.end()) {
      std::string known;
      for (const auto& s : specs) known += (known.empty() ? "" : ", ") + s.name;
      return bad_input(file, entry.line, key,
                       "unknown parameter (known: " + (known.empty() ? "none" : known) + ")");
    }
    const ParamSpec& spec = *it->second;
    ParamValue v = entry.value;
    // An empty list parses as a list of strings; accept it for number lists too.
    if (spec.type == ParamType::kNumberList) {
      if (auto* sl = std::get_if<std::vector<std::string>>(&v); sl && sl->empty()) v = std::vector<double>{};
    }
    if (!type_matches(spec.type, v)) {
      return bad_input(file, entry.line, key, std::string("expected a ") + to_string(spec.type));
    }
    const int line = entry.line;  // a structured binding cannot be captured before C++20 in clang 14
    auto check = [&](double x) -> Status {
      if (!std::isfinite(x)) return bad_input(file, line, key, "must be a finite number");
      if (x < spec.min || x > spec.max)
        return bad_input(file, line, key, "value " + std::to_string(x) + " outside " + format_range(spec));
      if (spec.type == ParamType::kInteger && x != std::floor(x))
        return bad_input(file, line, key, "expected an integer");
      return Status::Ok();
    };
    if (auto* d = std::get_if<double>(&v)) {
      if (Status s = check(*d); !s) return s.error();
    } else if (auto* dl = std::get_if<std::vector<double>>(&v)) {
      for (double x : *dl) {
        if (Status s = check(x); !s) return s.error();
      }
    }
    out.set(name, std::move(v));
  }
  for (const auto& s : specs) {
    if (!out.has(s.name)) out.set(s.name, s.default_value);
  }
  return out;
}

}  // namespace vigil
