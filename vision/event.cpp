#include "vision/event.h"

#include "common/lines.h"
#include "vision/json_text.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>

namespace vigil::vision {

namespace {

struct KindNames {
  EventKind kind;
  const char* id;
  const char* chapter;
};
constexpr KindNames kKinds[] = {
    {EventKind::kLeftBag, "left_bag", "left bag"},
    {EventKind::kBagTaken, "bag_taken", "bag taken"},
    {EventKind::kExchange, "exchange", "exchange"},
    {EventKind::kUnauthorisedObject, "unauthorised_object", "allert"},
};

std::string num3(double v) { return fixed_number(v, 3); }
std::string num4(double v) { return fixed_number(v, 4); }

std::string point_json(const Point3& p) {
  std::string s = "[";
  s += num4(p.x);
  s += ',';
  s += num4(p.y);
  s += ',';
  s += num4(p.z);
  s += ']';
  return s;
}

bool finite(const Point3& p) { return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z); }

}  // namespace

std::string_view to_string(EventKind k) {
  for (const auto& n : kKinds)
    if (n.kind == k) return n.id;
  return "?";
}

std::optional<EventKind> parse_event_kind(std::string_view s) {
  for (const auto& n : kKinds)
    if (s == n.id) return n.kind;
  return std::nullopt;
}

std::string_view chapter_name(EventKind k) {
  for (const auto& n : kKinds)
    if (n.kind == k) return n.chapter;
  return "?";
}

std::string format_event_string(const Event& e) {
  std::string s = e.cancelled ? "cancel " : "";
  s += chapter_name(e.kind);
  for (double v : {e.map_position.x, e.map_position.y, e.map_position.z}) {
    s += ' ';
    s += num3(v);
  }
  return s;
}

Result<Event> parse_event_string(std::string_view text, const std::string& source) {
  while (!text.empty() && (text.back() == '\n' || text.back() == '\r' || text.back() == ' ')) text.remove_suffix(1);
  Event e;
  constexpr std::string_view kCancel = "cancel ";
  if (text.substr(0, kCancel.size()) == kCancel) {
    e.cancelled = true;
    text.remove_prefix(kCancel.size());
  }
  bool named = false;
  for (const auto& n : kKinds) {
    const std::string_view name = n.chapter;
    if (text.size() > name.size() && text.substr(0, name.size()) == name && text[name.size()] == ' ') {
      e.kind = n.kind;
      text.remove_prefix(name.size() + 1);
      named = true;
      break;
    }
  }
  if (!named)
    return bad_input(source, 0, "name",
                     "expected an event name (left bag, bag taken, exchange, allert) then x y z, got '" +
                         std::string(text) + "'");
  double* coords[3] = {&e.map_position.x, &e.map_position.y, &e.map_position.z};
  const char* keys[3] = {"x", "y", "z"};
  std::string rest(text);
  const char* p = rest.c_str();
  for (int i = 0; i < 3; ++i) {
    while (*p == ' ') ++p;
    char* end = nullptr;
    const double v = std::strtod(p, &end);
    if (end == p) return bad_input(source, 0, keys[i], "expected a number at '" + std::string(p) + "'");
    if (!std::isfinite(v)) return bad_input(source, 0, keys[i], "must be finite");
    *coords[i] = v;
    p = end;
  }
  while (*p == ' ') ++p;
  if (*p) return bad_input(source, 0, "", "unexpected text after the coordinates: '" + std::string(p) + "'");
  return e;
}

std::string format_event_json(const Event& e) {
  std::string s = "{\"t_ns\":" + std::to_string(e.stamp_ns) + ",\"id\":" + std::to_string(e.id) + ",\"kind\":\"" +
                  std::string(to_string(e.kind)) + "\",\"cancelled\":" + (e.cancelled ? "true" : "false") +
                  ",\"camera\":" + json_string(e.camera) + ",\"map\":" + point_json(e.map_position) +
                  ",\"camera_frame\":" + point_json(e.camera_position) +
                  ",\"object_track\":" + std::to_string(e.object_track) + ",\"object\":" + json_string(e.object) +
                  ",\"people\":[";
  for (size_t i = 0; i < e.people.size(); ++i) {
    if (i) s += ',';
    s += std::to_string(e.people[i]);
  }
  s += "],\"confidence\":" + num4(e.confidence) + ",\"text\":" + json_string(format_event_string(e)) + "}";
  return s;
}

namespace {

Status get_point(const nlohmann::json& j, const char* key, Point3* out, const std::string& file, int line) {
  const auto it = j.find(key);
  if (it == j.end()) return bad_input(file, line, key, "missing");
  if (!it->is_array() || it->size() != 3) return bad_input(file, line, key, "expected [x, y, z]");
  for (const auto& v : *it)
    if (!v.is_number()) return bad_input(file, line, key, "expected [x, y, z] numbers");
  *out = {(*it)[0].get<double>(), (*it)[1].get<double>(), (*it)[2].get<double>()};
  if (!finite(*out)) return bad_input(file, line, key, "must be finite");
  return Status::Ok();
}

}  // namespace

Result<Event> parse_event_json(std::string_view text, const std::string& file, int line) {
  const nlohmann::json j = nlohmann::json::parse(text.begin(), text.end(), nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) return bad_input(file, line, "", "not valid JSON");
  if (!j.is_object()) return bad_input(file, line, "", "expected a JSON object");
  Event e;
  const auto t = j.find("t_ns");
  if (t == j.end() || !t->is_number_integer()) return bad_input(file, line, "t_ns", "missing or not an integer");
  e.stamp_ns = t->get<int64_t>();
  const auto id = j.find("id");
  if (id == j.end() || !id->is_number_unsigned()) return bad_input(file, line, "id", "missing or not a non-negative integer");
  e.id = id->get<uint64_t>();
  const auto kind = j.find("kind");
  if (kind == j.end() || !kind->is_string()) return bad_input(file, line, "kind", "missing or not a string");
  const auto k = parse_event_kind(kind->get<std::string>());
  if (!k)
    return bad_input(file, line, "kind",
                     "unknown kind '" + kind->get<std::string>() +
                         "' (known: left_bag, bag_taken, exchange, unauthorised_object)");
  e.kind = *k;
  if (const auto c = j.find("cancelled"); c != j.end()) {
    if (!c->is_boolean()) return bad_input(file, line, "cancelled", "expected true or false");
    e.cancelled = c->get<bool>();
  }
  const auto cam = j.find("camera");
  if (cam == j.end() || !cam->is_string() || cam->get<std::string>().empty())
    return bad_input(file, line, "camera", "missing or not a non-empty string");
  e.camera = cam->get<std::string>();
  if (Status s = get_point(j, "map", &e.map_position, file, line); !s) return s.error();
  if (j.contains("camera_frame")) {
    if (Status s = get_point(j, "camera_frame", &e.camera_position, file, line); !s) return s.error();
  }
  if (const auto o = j.find("object_track"); o != j.end()) {
    if (!o->is_number_integer()) return bad_input(file, line, "object_track", "expected an integer");
    e.object_track = o->get<int>();
  }
  if (const auto o = j.find("object"); o != j.end()) {
    if (!o->is_string()) return bad_input(file, line, "object", "expected a string");
    e.object = o->get<std::string>();
  }
  if (const auto p = j.find("people"); p != j.end()) {
    if (!p->is_array()) return bad_input(file, line, "people", "expected an array of track ids");
    for (const auto& v : *p) {
      if (!v.is_number_integer()) return bad_input(file, line, "people", "expected an array of track ids");
      e.people.push_back(v.get<int>());
    }
  }
  if (const auto c = j.find("confidence"); c != j.end()) {
    if (!c->is_number() || !(c->get<double>() >= 0 && c->get<double>() <= 1))
      return bad_input(file, line, "confidence", "expected a number from 0 to 1");
    e.confidence = c->get<double>();
  }
  return e;
}

Result<std::vector<Event>> read_events_jsonl(const std::string& path) {
  std::vector<Event> events;
  const Status s = for_each_line(path, [&](std::string_view text, int line) -> Status {
    auto e = parse_event_json(text, path, line);
    if (!e) return e.error();
    events.push_back(std::move(*e));
    return Status::Ok();
  });
  if (!s) return s.error();
  return events;
}

}  // namespace vigil::vision
