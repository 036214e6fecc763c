#include "world/ground_truth.h"

#include <cmath>

namespace vigil {

std::string fixed4(double v) {
  if (!std::isfinite(v)) return "null";
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.4f", v);
  std::string s(buf);
  if (s == "-0.0000") s = "0.0000";
  return s;
}

namespace {

std::string quoted(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    if (static_cast<unsigned char>(c) < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", c);
      out += buf;
      continue;
    }
    out += c;
  }
  return out + "\"";
}

}  // namespace

GroundTruthLog::~GroundTruthLog() {
  if (f_) std::fclose(f_);
}

Status GroundTruthLog::open(const std::filesystem::path& path) {
  if (path.empty()) return Status::Ok();
  f_ = std::fopen(path.c_str(), "wb");
  if (!f_) return bad_input(path.string(), 0, "", "cannot open for writing");
  return Status::Ok();
}

void GroundTruthLog::emit(const std::string& line) {
  hash_.update(line);
  hash_.update("\n");
  bytes_ += line.size() + 1;
  lines_++;
  if (f_) {
    std::fwrite(line.data(), 1, line.size(), f_);
    std::fputc('\n', f_);
  }
}

void GroundTruthLog::write_tick(const World& world) {
  std::string s;
  s.reserve(64 + 96 * (world.robots().size() + world.people().size() + world.objects().size()));
  s += "{\"type\":\"tick\",\"t_ns\":" + std::to_string(world.time()) + ",\"entities\":[";
  bool first = true;
  auto sep = [&] {
    if (!first) s += ',';
    first = false;
  };
  for (const auto& r : world.robots()) {
    sep();
    const auto& p = r.pose;
    const auto& o = r.state.odometry;
    s += "{\"id\":" + quoted(r.spec.id) + ",\"kind\":\"robot\",\"x\":" + fixed4(p.x) + ",\"y\":" + fixed4(p.y) +
         ",\"yaw\":" + fixed4(p.yaw) + ",\"odom\":[" + fixed4(o.x) + "," + fixed4(o.y) + "," + fixed4(o.yaw) + "]}";
  }
  for (const auto& p : world.people()) {
    if (!p.present) continue;
    sep();
    s += "{\"id\":" + quoted(p.spec.id) + ",\"kind\":\"person\",\"x\":" + fixed4(p.pose.x) + ",\"y\":" +
         fixed4(p.pose.y) + ",\"yaw\":" + fixed4(p.pose.yaw) + "}";
  }
  for (const auto& ob : world.objects()) {
    if (!ob.present) continue;
    sep();
    s += "{\"id\":" + quoted(ob.spec.id) + ",\"kind\":" + quoted(to_string(ob.spec.kind)) + ",\"x\":" +
         fixed4(ob.pose.x) + ",\"y\":" + fixed4(ob.pose.y) + ",\"z\":" + fixed4(ob.z) + ",\"yaw\":" + fixed4(ob.pose.yaw);
    if (ob.carrier >= 0) s += ",\"carried_by\":" + quoted(world.people()[ob.carrier].spec.id);
    s += "}";
  }
  s += "]}";
  emit(s);
}

void GroundTruthLog::write_timeline(const World& world) {
  for (const auto& a : world.actions()) {
    std::string s = "{\"type\":\"action\",\"t_ns\":" + std::to_string(a.t) + ",\"person\":" + quoted(a.person) +
                    ",\"action\":" + quoted(a.action);
    if (!a.object.empty()) s += ",\"object\":" + quoted(a.object);
    s += ",\"x\":" + fixed4(a.where.x) + ",\"y\":" + fixed4(a.where.y) + "}";
    emit(s);
  }
  for (const auto& e : world.events()) {
    std::string people;
    for (const auto& p : e.people) {
      if (!people.empty()) people += ',';
      people += quoted(p);
    }
    emit("{\"type\":\"event\",\"kind\":" + quoted(e.kind) + ",\"t_ns\":" + std::to_string(e.t) +
         ",\"confirmed_ns\":" + std::to_string(e.confirmed) + ",\"people\":[" + people + "],\"object\":" +
         quoted(e.object) + ",\"owner\":" + quoted(e.owner) + ",\"x\":" + fixed4(e.where.x) + ",\"y\":" +
         fixed4(e.where.y) + ",\"z\":" + fixed4(e.where.z) + "}");
  }
  for (const auto& c : world.contacts()) {
    emit("{\"type\":\"contact\",\"robot\":" + quoted(c.robot) + ",\"other\":" + quoted(c.other) +
         ",\"other_kind\":" + quoted(c.other_kind) + ",\"start_ns\":" + std::to_string(c.start) +
         ",\"end_ns\":" + std::to_string(c.end) + ",\"x\":" + fixed4(c.where.x) + ",\"y\":" + fixed4(c.where.y) +
         ",\"robot_speed\":" + fixed4(c.robot_speed) + ",\"robot_pushing\":" + (c.robot_pushing ? "true" : "false") +
         "}");
  }
}

Status GroundTruthLog::close() {
  if (f_) {
    const bool bad = std::ferror(f_) != 0;
    std::fclose(f_);
    f_ = nullptr;
    if (bad) return internal_error("write error on ground_truth.jsonl");
  }
  return Status::Ok();
}

std::string GroundTruthLog::sha256() {
  if (digest_.empty()) digest_ = hash_.hex_digest();
  return digest_;
}

}  // namespace vigil
