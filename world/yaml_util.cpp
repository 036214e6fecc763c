// Strict YAML accessors with file/line/key errors (see yaml_util.h).
#include "world/yaml_util.h"

#include <yaml-cpp/anchor.h>
#include <yaml-cpp/depthguard.h>
#include <yaml-cpp/eventhandler.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>

namespace vigil::yaml_input {

namespace {

// Joins a key path and a child key.
std::string join_key(const std::string& parent, const std::string& child) {
  return parent.empty() ? child : parent + "." + child;
}

// Lists names as "a, b, c".
std::string list_names(const std::vector<std::string>& names) {
  std::string out;
  for (const auto& n : names) out += (out.empty() ? "" : ", ") + n;
  return out.empty() ? "none" : out;
}

// Parses a plain number without locale: decimal, optional sign and exponent, or YAML's
// .inf/.nan spellings (returned as non-finite so the caller can say so).
std::optional<double> parse_number(const std::string& s) {
  if (s.empty() || s.size() > 64) return std::nullopt;
  static const std::set<std::string> kInf = {".inf", ".Inf", ".INF", "+.inf", "+.Inf", "+.INF"};
  static const std::set<std::string> kNegInf = {"-.inf", "-.Inf", "-.INF"};
  static const std::set<std::string> kNan = {".nan", ".NaN", ".NAN"};
  if (kInf.count(s)) return std::numeric_limits<double>::infinity();
  if (kNegInf.count(s)) return -std::numeric_limits<double>::infinity();
  if (kNan.count(s)) return std::numeric_limits<double>::quiet_NaN();
  const char* b = s.data();
  const char* e = s.data() + s.size();
  if (*b == '+') ++b;
  if (b == e || *b == '+' || (*b == '-' && b != s.data())) return std::nullopt;
  double v = 0;
  auto [p, ec] = std::from_chars(b, e, v, std::chars_format::general);
  if (p != e) return std::nullopt;
  if (ec == std::errc::result_out_of_range) {
    // Overflow reads as infinity (then refused as non-finite); underflow as zero.
    const bool big = s.find_first_of("eE") != std::string::npos &&
                     s.find("e-") == std::string::npos && s.find("E-") == std::string::npos;
    const bool neg = s[0] == '-';
    return big ? (neg ? -1.0 : 1.0) * std::numeric_limits<double>::infinity() : 0.0;
  }
  if (ec != std::errc()) return std::nullopt;
  return v;
}

// A short description of what a node is, for "expected X, got Y" messages.
std::string describe(const YAML::Node& n) {
  if (n.IsNull()) return "nothing";
  if (n.IsSequence()) return "a list";
  if (n.IsMap()) return "a mapping";
  if (n.IsScalar()) return quoted(n.Scalar());
  return "an undefined value";
}

}  // namespace

void fail(const std::string& file, int line, const std::string& key, const std::string& message) {
  throw InputError{bad_input(file, line, key, message)};
}

std::string read_text_file(const std::filesystem::path& path, size_t max_bytes) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) fail(path.string(), 0, "", "file does not exist");
  if (!std::filesystem::is_regular_file(path, ec)) fail(path.string(), 0, "", "not a regular file");
  const auto size = std::filesystem::file_size(path, ec);
  if (ec) fail(path.string(), 0, "", "cannot read file: " + ec.message());
  if (size > max_bytes) {
    fail(path.string(), 0, "", "file too large (" + std::to_string(size) + " bytes, at most " +
                                   std::to_string(max_bytes) + ")");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path.string(), 0, "", "cannot open file");
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) fail(path.string(), 0, "", "cannot read file");
  return ss.str();
}

std::string quoted(const std::string& text) {
  std::string t = text.size() > 40 ? text.substr(0, 37) + "..." : text;
  std::string out = "\"";
  for (char c : t) {
    const auto u = static_cast<unsigned char>(c);
    if (u < 0x20 || u == 0x7f) {
      out += '?';
    } else {
      out += c;
    }
  }
  return out + "\"";
}

int line_of(const YAML::Node& node, int fallback) {
  if (!node.IsDefined()) return fallback;
  const YAML::Mark m = node.Mark();
  if (m.is_null() || m.line < 0) return fallback;
  return m.line + 1;
}

namespace {

// Records where each document of a stream starts, and nothing else.
class DocumentStarts : public YAML::EventHandler {
 public:
  std::vector<YAML::Mark> marks;
  void OnDocumentStart(const YAML::Mark& mark) override { marks.push_back(mark); }
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark&, YAML::anchor_t) override {}
  void OnAlias(const YAML::Mark&, YAML::anchor_t) override {}
  void OnScalar(const YAML::Mark&, const std::string&, YAML::anchor_t, const std::string&) override {}
  void OnSequenceStart(const YAML::Mark&, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {}
  void OnSequenceEnd() override {}
  void OnMapStart(const YAML::Mark&, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {}
  void OnMapEnd() override {}
};

}  // namespace

YAML::Node parse_document(const std::string& text, const std::string& file) {
  // A first pass over at most three documents finds extra documents, and stray tokens that
  // yaml-cpp 0.7 neither consumes nor reports (a lone ',' makes YAML::LoadAll loop forever):
  // such a token shows up as documents starting again at the same place.
  try {
    std::istringstream in(text);
    YAML::Parser parser(in);
    DocumentStarts starts;
    for (int i = 0; i < 3 && parser.HandleNextDocument(starts); ++i) {
      const auto& m = starts.marks;
      if (m.size() >= 2 && m[m.size() - 1].pos == m[m.size() - 2].pos) {
        const YAML::Mark& at = m.back();
        const char c = at.pos >= 0 && static_cast<size_t>(at.pos) < text.size() ? text[static_cast<size_t>(at.pos)] : '?';
        fail(file, at.line + 1, "", "YAML syntax error: unexpected " + quoted(std::string(1, c)));
      }
    }
    if (starts.marks.size() > 1) {
      fail(file, starts.marks[1].line + 1, "", "more than one YAML document (the second starts here)");
    }
  } catch (const YAML::DeepRecursion& e) {
    fail(file, e.mark.is_null() ? 0 : e.mark.line + 1, "", "YAML nested too deeply");
  } catch (const YAML::Exception& e) {
    const int line = e.mark.is_null() ? 0 : e.mark.line + 1;
    fail(file, line, "", "YAML syntax error: " + e.msg);
  }
  YAML::Node doc;
  try {
    doc = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    const int line = e.mark.is_null() ? 0 : e.mark.line + 1;
    fail(file, line, "", "YAML syntax error: " + e.msg);
  }
  if (!doc.IsDefined() || doc.IsNull()) fail(file, 0, "", "empty file");
  return doc;
}

Value::Value(YAML::Node node, std::shared_ptr<const std::string> file, std::string key, int line)
    : node_(std::move(node)), file_(std::move(file)), key_(std::move(key)), line_(line) {}

void Value::fail(const std::string& message) const { throw InputError{error(message)}; }

Error Value::error(const std::string& message) const { return bad_input(*file_, line_, key_, message); }

bool Value::is_quoted() const { return node_.IsScalar() && node_.Tag() == "!"; }

bool Value::looks_numeric() const {
  return node_.IsScalar() && !is_quoted() && parse_number(node_.Scalar()).has_value();
}

double Value::number() const {
  if (!node_.IsScalar()) fail("expected a number, got " + describe(node_));
  const auto v = parse_number(node_.Scalar());
  if (!v) fail("expected a number, got " + describe(node_));
  if (!std::isfinite(*v)) fail("must be a finite number, got " + describe(node_));
  return *v;
}

double Value::number_in(double lo, double hi) const {
  const double v = number();
  if (v < lo || v > hi) {
    std::ostringstream ss;
    ss << "must be between " << lo << " and " << hi << ", got " << v;
    fail(ss.str());
  }
  return v;
}

double Value::positive(double hi) const {
  const double v = number();
  if (v <= 0) {
    std::ostringstream ss;
    ss << "must be greater than 0, got " << v;
    fail(ss.str());
  }
  if (v > hi) {
    std::ostringstream ss;
    ss << "must be at most " << hi << ", got " << v;
    fail(ss.str());
  }
  return v;
}

double Value::non_negative(double hi) const {
  const double v = number();
  if (v < 0) {
    std::ostringstream ss;
    ss << "must not be negative, got " << v;
    fail(ss.str());
  }
  if (v > hi) {
    std::ostringstream ss;
    ss << "must be at most " << hi << ", got " << v;
    fail(ss.str());
  }
  return v;
}

int64_t Value::integer(int64_t lo, int64_t hi) const {
  const double v = number();
  if (v != std::floor(v)) fail("expected a whole number, got " + describe(node_));
  if (v < static_cast<double>(lo) || v > static_cast<double>(hi)) {
    fail("must be between " + std::to_string(lo) + " and " + std::to_string(hi) + ", got " +
         describe(node_));
  }
  return static_cast<int64_t>(v);
}

uint64_t Value::unsigned_integer() const {
  if (!node_.IsScalar()) fail("expected a whole number >= 0, got " + describe(node_));
  std::string s = node_.Scalar();
  if (!s.empty() && s[0] == '+') s = s.substr(1);
  uint64_t v = 0;
  const bool digits = !s.empty() && std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
  if (!digits) fail("expected a whole number >= 0, got " + describe(node_));
  auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || p != s.data() + s.size()) fail("must be at most 18446744073709551615");
  return v;
}

bool Value::boolean() const {
  if (node_.IsScalar() && !is_quoted()) {
    const std::string& s = node_.Scalar();
    if (s == "true" || s == "True" || s == "TRUE") return true;
    if (s == "false" || s == "False" || s == "FALSE") return false;
  }
  fail("expected true or false, got " + describe(node_));
}

std::string Value::string() const {
  if (!node_.IsScalar()) fail("expected a string, got " + describe(node_));
  if (node_.Scalar().empty()) fail("must not be empty");
  return node_.Scalar();
}

std::string Value::identifier() const {
  const std::string s = string();
  const bool ok = s.size() <= 64 && std::all_of(s.begin(), s.end(), [](char c) {
                    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.';
                  });
  if (!ok) fail("expected a name of letters, digits, '_', '-' or '.' (at most 64), got " + describe(node_));
  return s;
}

std::string Value::colour() const {
  if (node_.IsNull()) {
    fail("expected a colour \"#rrggbb\", got nothing (quote it: an unquoted # starts a YAML comment)");
  }
  if (!node_.IsScalar()) fail("expected a colour \"#rrggbb\", got " + describe(node_));
  std::string s = node_.Scalar();
  const bool ok = s.size() == 7 && s[0] == '#' &&
                  std::all_of(s.begin() + 1, s.end(), [](char c) { return std::isxdigit(static_cast<unsigned char>(c)); });
  if (!ok) fail("expected a colour \"#rrggbb\" (6 hex digits), got " + describe(node_));
  std::transform(s.begin(), s.end(), s.begin(), [](char c) { return static_cast<char>(std::tolower(static_cast<unsigned char>(c))); });
  return s;
}

std::vector<double> Value::numbers(size_t n, size_t min_n, size_t max_n) const {
  const std::string want = n > 0 ? "a list of " + std::to_string(n) + " numbers" : "a list of numbers";
  if (!node_.IsSequence()) fail("expected " + want + ", got " + describe(node_));
  const size_t size = node_.size();
  if ((n > 0 && size != n) || (n == 0 && (size < min_n || size > max_n))) {
    fail("expected " + want + (n == 0 ? " (" + std::to_string(min_n) + " to " + std::to_string(max_n) + ")" : "") +
         ", got " + std::to_string(size));
  }
  std::vector<double> out;
  out.reserve(size);
  for (const Value& item : items()) out.push_back(item.number());
  return out;
}

Vec2 Value::point() const {
  const auto v = numbers(2);
  return {v[0], v[1]};
}

std::vector<Value> Value::items() const {
  if (node_.IsNull()) return {};
  if (!node_.IsSequence()) fail("expected a list, got " + describe(node_));
  std::vector<Value> out;
  out.reserve(node_.size());
  size_t i = 0;
  for (const YAML::Node& item : node_) {
    // A null item's mark points at the next token, so it keeps the list's line.
    const int line = item.IsNull() ? line_ : line_of(item, line_);
    out.emplace_back(item, file_, key_ + "[" + std::to_string(i) + "]", line);
    ++i;
  }
  return out;
}

Mapping Value::mapping(const std::vector<std::string>& allowed) const { return Mapping(*this, allowed); }

Mapping Value::open_mapping() const { return Mapping(*this, {}, true); }

Mapping::Mapping(const Value& self, const std::vector<std::string>& allowed, bool any_key) : self_(self) {
  const YAML::Node& node = self.node();
  if (node.IsNull()) return;
  if (!node.IsMap()) {
    self.fail(any_key ? "expected a mapping, got " + describe(node)
                      : "expected a mapping (keys: " + list_names(allowed) + "), got " + describe(node));
  }
  for (const auto& entry : node) {  // entry is a value: it->first would dangle
    const YAML::Node k = entry.first;
    const int line = line_of(k, self.line());
    if (!k.IsScalar() || k.Scalar().empty()) {
      fail(self.file(), line, self.key(), "keys must be plain names, got " + describe(k));
    }
    const std::string& name = k.Scalar();
    const std::string key = join_key(self.key(), name);
    if (any_key && !(name.size() <= 64 && std::all_of(name.begin(), name.end(), [](char c) {
                       return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.';
                     }))) {
      fail(self.file(), line, key, "names must be letters, digits, '_', '-' or '.' (at most 64)");
    }
    if (!any_key && std::find(allowed.begin(), allowed.end(), name) == allowed.end()) {
      std::string hint;
      if (std::find(allowed.begin(), allowed.end(), name + "_deg") != allowed.end()) {
        hint = "; angles are written in degrees: use " + name + "_deg";
      }
      fail(self.file(), line, key, "unknown key (allowed: " + list_names(allowed) + ")" + hint);
    }
    if (const Value* first = find(name)) {
      fail(self.file(), line, key, "duplicate key (first given at line " + std::to_string(first->line()) + ")");
    }
    entries_.emplace_back(name, Value(entry.second, self.file_ptr(), key, line));
  }
}

const Value* Mapping::find(const std::string& key) const {
  for (const auto& [k, v] : entries_) {
    if (k == key) return &v;
  }
  return nullptr;
}

std::optional<Value> Mapping::get(const std::string& key) const {
  if (const Value* v = find(key)) return *v;
  return std::nullopt;
}

Value Mapping::require(const std::string& key) const {
  if (const Value* v = find(key)) return *v;
  fail(self_.file(), self_.line(), join_key(self_.key(), key), "missing required key");
}

}  // namespace vigil::yaml_input
