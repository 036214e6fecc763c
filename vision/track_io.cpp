#include "vision/track_io.h"

#include "common/lines.h"
#include "vision/json_text.h"

#include <cmath>
#include <cstdint>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>

namespace vigil::vision {

namespace {

std::string num4(double v) { return fixed_number(v, 4); }

struct NumberField {
  const char* key;
  double Track::*member;
};
constexpr NumberField kNumbers[] = {
    {"x", &Track::x},         {"y", &Track::y},         {"vx", &Track::vx},         {"vy", &Track::vy},
    {"height", &Track::height}, {"width", &Track::width}, {"confidence", &Track::confidence},
};

const char* type_name(const nlohmann::json& v) {
  if (v.is_null()) return "null";
  if (v.is_boolean()) return "a boolean";
  if (v.is_number()) return "a number";
  if (v.is_string()) return "a string";
  if (v.is_array()) return "an array";
  return "an object";
}

// An integer value of `j[key]` (JSON integer within int64), or an error naming the key.
Result<int64_t> get_int(const nlohmann::json& j, const char* key, const std::string& file, int line) {
  const auto it = j.find(key);
  if (it == j.end()) return bad_input(file, line, key, "missing");
  if (it->is_number_unsigned()) {
    const auto u = it->get<uint64_t>();
    if (u > static_cast<uint64_t>(std::numeric_limits<int64_t>::max())) return bad_input(file, line, key, "out of range");
    return static_cast<int64_t>(u);
  }
  if (it->is_number_integer()) return it->get<int64_t>();
  return bad_input(file, line, key, std::string("expected an integer, got ") + (it->is_number() ? "a fraction" : type_name(*it)));
}

}  // namespace

std::string format_track_json(const Track& t) {
  std::string s = "{\"t_ns\":" + std::to_string(t.stamp_ns) + ",\"camera\":" + json_string(t.camera) +
                  ",\"id\":" + std::to_string(t.id) + ",\"class\":\"" + std::string(to_string(t.cls)) + "\"";
  for (const auto& f : kNumbers) s += std::string(",\"") + f.key + "\":" + num4(t.*(f.member));
  if (!t.measured) s += ",\"measured\":false";  // written only for predictions (absent: measured)
  if (t.top_cut) s += ",\"top_cut\":true";       // only while the top of the image cuts the object
  if (t.hand_on != 0) s += ",\"hand_on\":" + std::to_string(t.hand_on);  // only while a hand is seen on something
  s += "}";
  return s;
}

Status check_track(const Track& t) {
  if (t.camera.empty()) return internal_error("track " + std::to_string(t.id) + " has an empty camera id");
  for (const auto& f : kNumbers) {
    if (!std::isfinite(t.*(f.member)))
      return internal_error("track " + std::to_string(t.id) + " of camera " + t.camera + " at t_ns " +
                            std::to_string(t.stamp_ns) + " has a non-finite " + f.key);
  }
  return Status::Ok();
}

Result<Track> parse_track_json(std::string_view text, const std::string& file, int line) {
  const nlohmann::json j = nlohmann::json::parse(text.begin(), text.end(), nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) return bad_input(file, line, "", "not valid JSON");
  if (!j.is_object()) return bad_input(file, line, "", std::string("expected a JSON object, got ") + type_name(j));
  Track t;
  auto stamp = get_int(j, "t_ns", file, line);
  if (!stamp) return stamp.error();
  t.stamp_ns = *stamp;
  auto id = get_int(j, "id", file, line);
  if (!id) return id.error();
  if (*id < std::numeric_limits<int>::min() || *id > std::numeric_limits<int>::max())
    return bad_input(file, line, "id", "out of range");
  t.id = static_cast<int>(*id);
  const auto cam = j.find("camera");
  if (cam == j.end()) return bad_input(file, line, "camera", "missing");
  if (!cam->is_string()) return bad_input(file, line, "camera", std::string("expected a string, got ") + type_name(*cam));
  t.camera = cam->get<std::string>();
  if (t.camera.empty()) return bad_input(file, line, "camera", "empty");
  const auto cls = j.find("class");
  if (cls == j.end()) return bad_input(file, line, "class", "missing");
  if (!cls->is_string()) return bad_input(file, line, "class", std::string("expected a string, got ") + type_name(*cls));
  const auto parsed = parse_track_class(cls->get<std::string>());
  if (!parsed)
    return bad_input(file, line, "class", "unknown class '" + cls->get<std::string>() + "' (known: unknown, person, bag, robot)");
  t.cls = *parsed;
  for (const auto& f : kNumbers) {
    const auto it = j.find(f.key);
    const bool required = std::string_view(f.key) == "x" || std::string_view(f.key) == "y";
    if (it == j.end()) {
      if (required) return bad_input(file, line, f.key, "missing");
      continue;
    }
    if (!it->is_number()) return bad_input(file, line, f.key, std::string("expected a number, got ") + type_name(*it));
    t.*(f.member) = it->get<double>();
  }
  if (const auto it = j.find("measured"); it != j.end()) {
    if (!it->is_boolean()) return bad_input(file, line, "measured", std::string("expected a boolean, got ") + type_name(*it));
    t.measured = it->get<bool>();
  }
  if (const auto it = j.find("top_cut"); it != j.end()) {
    if (!it->is_boolean()) return bad_input(file, line, "top_cut", std::string("expected a boolean, got ") + type_name(*it));
    t.top_cut = it->get<bool>();
  }
  if (j.contains("hand_on")) {
    auto hand = get_int(j, "hand_on", file, line);
    if (!hand) return hand.error();
    if (*hand < std::numeric_limits<int>::min() || *hand > std::numeric_limits<int>::max())
      return bad_input(file, line, "hand_on", "out of range");
    t.hand_on = static_cast<int>(*hand);
  }
  return t;
}

Result<std::vector<Track>> load_tracks_jsonl(const std::filesystem::path& path) {
  const std::string file = path.string();
  std::vector<Track> tracks;
  const Status s = for_each_line(path, [&](std::string_view text, int line) -> Status {
    auto t = parse_track_json(text, file, line);
    if (!t) return t.error();
    tracks.push_back(std::move(*t));
    return Status::Ok();
  });
  if (!s) return s.error();
  return tracks;
}

Status save_tracks_jsonl(const std::filesystem::path& path, const std::vector<Track>& tracks) {
  TrackJsonlWriter w;
  if (Status s = w.open(path); !s) return s;
  for (const Track& t : tracks) {
    if (Status s = w.write(t); !s) return s;
  }
  return w.close();
}

TrackJsonlWriter::~TrackJsonlWriter() {
  if (f_) std::fclose(f_);
}

Status TrackJsonlWriter::open(const std::filesystem::path& path) {
  if (f_) return internal_error("TrackJsonlWriter: " + path_ + " is already open");
  path_ = path.string();
  f_ = std::fopen(path_.c_str(), "wb");
  if (!f_) return bad_input(path_, 0, "", "cannot open for writing");
  return Status::Ok();
}

Status TrackJsonlWriter::write(const Track& t) {
  if (!f_) return internal_error("TrackJsonlWriter: write before open");
  if (Status s = check_track(t); !s) return s;
  const std::string line = format_track_json(t) + "\n";
  if (std::fwrite(line.data(), 1, line.size(), f_) != line.size()) return internal_error("cannot write " + path_);
  return Status::Ok();
}

Status TrackJsonlWriter::close() {
  if (!f_) return Status::Ok();
  const int rc = std::fclose(f_);
  f_ = nullptr;
  if (rc != 0) return internal_error("cannot write " + path_);
  return Status::Ok();
}

}  // namespace vigil::vision
