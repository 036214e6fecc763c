#include "vision/map_track_eval.h"

#include "common/lines.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <numbers>
#include <optional>
#include <set>
#include <tuple>
#include <unordered_map>

namespace vigil::vision {

namespace {

constexpr std::array<TrackClass, 4> kClasses = {TrackClass::kPerson, TrackClass::kBag, TrackClass::kRobot,
                                                TrackClass::kUnknown};

size_t class_index(TrackClass c) {
  for (size_t i = 0; i < kClasses.size(); ++i)
    if (kClasses[i] == c) return i;
  return kClasses.size() - 1;
}

// The commonest gap between consecutive sorted distinct times (the smallest on a tie); 0 when
// there are fewer than two.
int64_t commonest_gap(const std::vector<int64_t>& times) {
  std::map<int64_t, int> counts;
  for (size_t i = 1; i < times.size(); ++i) ++counts[times[i] - times[i - 1]];
  int64_t best = 0;
  int best_count = 0;
  for (const auto& [gap, count] : counts) {
    if (count > best_count) {
      best = gap;
      best_count = count;
    }
  }
  return best;
}

Result<double> get_number(const nlohmann::json& j, const char* key, const std::string& file, int line,
                          const std::string& prefix) {
  const auto it = j.find(key);
  if (it == j.end()) return bad_input(file, line, prefix + key, "missing");
  if (!it->is_number()) return bad_input(file, line, prefix + key, "expected a number");
  const double v = it->get<double>();
  if (!std::isfinite(v)) return bad_input(file, line, prefix + key, "not finite");
  return v;
}

Result<std::string> get_string(const nlohmann::json& j, const char* key, const std::string& file, int line,
                               const std::string& prefix) {
  const auto it = j.find(key);
  if (it == j.end()) return bad_input(file, line, prefix + key, "missing");
  if (!it->is_string()) return bad_input(file, line, prefix + key, "expected a string");
  return it->get<std::string>();
}

}  // namespace

TrackClass track_class_of_kind(std::string_view kind) {
  if (kind == "person") return TrackClass::kPerson;
  if (kind == "bag") return TrackClass::kBag;
  if (kind == "robot") return TrackClass::kRobot;
  return TrackClass::kUnknown;
}

Result<std::vector<GroundTruthTick>> load_ground_truth_ticks(const std::filesystem::path& path) {
  const std::string file = path.string();
  std::vector<GroundTruthTick> ticks;
  const Status st = for_each_line(path, [&](std::string_view text, int line) -> Status {
    const nlohmann::json j = nlohmann::json::parse(text.begin(), text.end(), nullptr, /*allow_exceptions=*/false);
    if (j.is_discarded()) return bad_input(file, line, "", "not valid JSON");
    if (!j.is_object()) return bad_input(file, line, "", "expected a JSON object");
    auto type = get_string(j, "type", file, line, "");
    if (!type) return type.error();
    if (*type != "tick") return Status::Ok();
    GroundTruthTick tick;
    const auto t = j.find("t_ns");
    if (t == j.end()) return bad_input(file, line, "t_ns", "missing");
    if (!t->is_number_integer()) return bad_input(file, line, "t_ns", "expected an integer");
    tick.t_ns = t->get<int64_t>();
    if (!ticks.empty() && tick.t_ns <= ticks.back().t_ns)
      return bad_input(file, line, "t_ns", "ticks must come in increasing time (previous t_ns " +
                                               std::to_string(ticks.back().t_ns) + ")");
    const auto ents = j.find("entities");
    if (ents == j.end()) return bad_input(file, line, "entities", "missing");
    if (!ents->is_array()) return bad_input(file, line, "entities", "expected an array");
    std::set<std::string> ids;
    for (size_t i = 0; i < ents->size(); ++i) {
      const nlohmann::json& e = (*ents)[i];
      const std::string prefix = "entities[" + std::to_string(i) + "].";
      if (!e.is_object()) return bad_input(file, line, "entities[" + std::to_string(i) + "]", "expected an object");
      GroundTruthEntity ent;
      auto id = get_string(e, "id", file, line, prefix);
      if (!id) return id.error();
      auto kind = get_string(e, "kind", file, line, prefix);
      if (!kind) return kind.error();
      auto x = get_number(e, "x", file, line, prefix);
      if (!x) return x.error();
      auto y = get_number(e, "y", file, line, prefix);
      if (!y) return y.error();
      if (!ids.insert(*id).second) return bad_input(file, line, prefix + "id", "'" + *id + "' appears twice in this tick");
      ent.id = *id;
      ent.kind = *kind;
      ent.x = *x;
      ent.y = *y;
      const auto carrier = e.find("carried_by");
      ent.carried = carrier != e.end() && carrier->is_string() && !carrier->get<std::string>().empty();
      tick.entities.push_back(std::move(ent));
    }
    ticks.push_back(std::move(tick));
    return Status::Ok();
  });
  if (!st) return st.error();
  return ticks;
}

Result<MapTrackEvalResult> evaluate_map_tracks(const std::vector<GroundTruthTick>& gt, const std::vector<Track>& tracks,
                                               const MapTrackEvalOptions& opt) {
  if (!(opt.match_distance > 0) || !std::isfinite(opt.match_distance))
    return bad_input("", 0, "match_distance", "must be a positive number of metres");
  if (opt.max_range && (!(*opt.max_range > 0) || !std::isfinite(*opt.max_range)))
    return bad_input("", 0, "max_range", "must be a positive number of metres");
  if (opt.half_fov && (!(*opt.half_fov > 0) || !std::isfinite(*opt.half_fov)))
    return bad_input("", 0, "half_fov", "must be a positive angle");
  if (!(opt.camera_period_s >= 0) || !std::isfinite(opt.camera_period_s))
    return bad_input("", 0, "camera_period", "must be >= 0 s");
  if (gt.empty()) return bad_input("", 0, "ground truth", "has no tick lines");

  MapTrackEvalResult result;
  auto class_wanted = [&](TrackClass c) {
    return opt.classes.empty() || std::find(opt.classes.begin(), opt.classes.end(), c) != opt.classes.end();
  };
  auto in_view = [&](double x, double y) {
    if (opt.max_range && std::hypot(x - opt.camera_x, y - opt.camera_y) > *opt.max_range) return false;
    if (opt.half_fov) {
      const double bearing = std::atan2(y - opt.camera_y, x - opt.camera_x);
      const double off = std::remainder(bearing - opt.camera_yaw, 2 * std::numbers::pi);
      if (std::fabs(off) > *opt.half_fov) return false;
    }
    return true;
  };

  // The tracks evaluated, by stamp; hypothesis ids number the (camera, track id) pairs.
  std::set<std::string> all_cameras;
  for (const Track& t : tracks) all_cameras.insert(t.camera);
  if (!opt.camera.empty() && !all_cameras.count(opt.camera)) {
    std::string known;
    for (const auto& c : all_cameras) known += (known.empty() ? "" : ", ") + c;
    return bad_input("", 0, "camera", "no tracks from camera '" + opt.camera + "' (cameras with tracks: " +
                                          (known.empty() ? "none" : known) + ")");
  }
  std::set<std::string> cameras;
  std::map<int64_t, std::vector<const Track*>> by_stamp;
  std::map<std::pair<std::string, int>, int64_t> hyp_ids;
  std::set<std::tuple<int64_t, std::string, int>> seen;
  for (const Track& t : tracks) {
    if (!opt.camera.empty() && t.camera != opt.camera) continue;
    cameras.insert(t.camera);
    if (!seen.emplace(t.stamp_ns, t.camera, t.id).second)
      return bad_input("", 0, "tracks", "camera " + t.camera + " track " + std::to_string(t.id) +
                                            " appears twice at t_ns " + std::to_string(t.stamp_ns));
    auto& list = by_stamp[t.stamp_ns];  // every camera frame counts, even when its tracks are filtered out
    if (!class_wanted(t.cls) || !in_view(t.x, t.y)) continue;
    list.push_back(&t);
    hyp_ids.emplace(std::make_pair(t.camera, t.id), static_cast<int64_t>(hyp_ids.size()));
  }
  result.cameras.assign(cameras.begin(), cameras.end());

  std::vector<int64_t> stamps, tick_times;
  for (const auto& [s, list] : by_stamp) stamps.push_back(s);
  for (const auto& tick : gt) tick_times.push_back(tick.t_ns);
  const int64_t tick_period = commonest_gap(tick_times);
  int64_t period = opt.camera_period_s > 0 ? static_cast<int64_t>(std::llround(opt.camera_period_s * 1e9)) : commonest_gap(stamps);
  if (period <= 0) period = tick_period;
  result.camera_period_s = static_cast<double>(period) * 1e-9;

  // Frame times: track stamps within the ground truth's span, and uncovered ticks.
  std::vector<int64_t> frames;
  const int64_t half_tick = tick_period / 2;
  for (int64_t s : stamps) {
    if (s < tick_times.front() - half_tick || s > tick_times.back() + half_tick) {
      ++result.skipped_track_stamps;
      continue;
    }
    frames.push_back(s);
  }
  const int64_t reach = period * 3 / 4;  // a camera frame stands for the ticks this close to it
  for (int64_t t : tick_times) {
    const auto it = std::lower_bound(stamps.begin(), stamps.end(), t - reach);
    if (it != stamps.end() && *it <= t + reach) continue;
    frames.push_back(t);
    ++result.frames_without_tracks;
  }
  std::sort(frames.begin(), frames.end());
  result.frames = static_cast<int64_t>(frames.size());

  // Entity index per tick, for interpolation; object ids number the entity ids.
  std::vector<std::unordered_map<std::string, size_t>> index(gt.size());
  for (size_t k = 0; k < gt.size(); ++k)
    for (size_t i = 0; i < gt[k].entities.size(); ++i) index[k].emplace(gt[k].entities[i].id, i);
  std::map<std::string, int64_t> object_ids;

  MotParams params;
  params.distance = MotDistance::kPointEuclidean;
  params.max_distance = opt.match_distance;
  MotEvaluator overall(params);
  std::vector<MotEvaluator> per_class(kClasses.size(), MotEvaluator(params));

  for (int64_t t : frames) {
    // The ticks around t and the nearest one.
    const size_t after = static_cast<size_t>(std::upper_bound(tick_times.begin(), tick_times.end(), t) - tick_times.begin());
    size_t nearest;
    std::optional<size_t> other;  // the tick on the other side of t, if any
    if (after == 0) {
      nearest = 0;
    } else if (after == gt.size()) {
      nearest = gt.size() - 1;
    } else {
      const size_t before = after - 1;
      nearest = (t - tick_times[before] <= tick_times[after] - t) ? before : after;
      other = nearest == before ? after : before;
    }
    std::vector<MotItem> all_objects, all_hyps;
    std::array<std::vector<MotItem>, kClasses.size()> objects, hyps;
    for (const GroundTruthEntity& e : gt[nearest].entities) {
      const TrackClass c = track_class_of_kind(e.kind);
      if (!class_wanted(c) || (opt.exclude_carried && e.carried)) continue;
      double x = e.x, y = e.y;
      if (other) {
        const auto it = index[*other].find(e.id);
        if (it != index[*other].end()) {
          const GroundTruthEntity& o = gt[*other].entities[it->second];
          const size_t a = std::min(nearest, *other), b = std::max(nearest, *other);
          const double frac = static_cast<double>(t - tick_times[a]) / static_cast<double>(tick_times[b] - tick_times[a]);
          const GroundTruthEntity& ea = a == nearest ? e : o;
          const GroundTruthEntity& eb = a == nearest ? o : e;
          x = ea.x + (eb.x - ea.x) * frac;
          y = ea.y + (eb.y - ea.y) * frac;
        }
      }
      if (!in_view(x, y) || (opt.truth_visible && !opt.truth_visible(x, y))) continue;
      const int64_t id = object_ids.emplace(e.id, static_cast<int64_t>(object_ids.size())).first->second;
      const MotItem item{id, x, y, 0, 0};
      all_objects.push_back(item);
      objects[class_index(c)].push_back(item);
    }
    if (const auto it = by_stamp.find(t); it != by_stamp.end()) {
      for (const Track* tr : it->second) {
        const MotItem item{hyp_ids.at({tr->camera, tr->id}), tr->x, tr->y, 0, 0};
        all_hyps.push_back(item);
        hyps[class_index(tr->cls)].push_back(item);
      }
    }
    if (Status s = overall.update(t, all_objects, all_hyps); !s) return internal_error("evaluation: " + s.error().str());
    for (size_t c = 0; c < kClasses.size(); ++c) {
      if (Status s = per_class[c].update(t, objects[c], hyps[c]); !s) return internal_error("evaluation: " + s.error().str());
    }
  }
  result.overall = overall.metrics();
  for (size_t c = 0; c < kClasses.size(); ++c) {
    MotMetrics m = per_class[c].metrics();
    if (m.num_unique_objects > 0 || m.num_unique_hypotheses > 0) result.per_class.emplace_back(kClasses[c], m);
  }
  return result;
}

}  // namespace vigil::vision
