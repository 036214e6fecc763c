#include "vision/mot_metrics.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include "common/linear_assignment.h"

namespace vigil::vision {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double ratio(double num, double den) { return den != 0 ? num / den : kNaN; }

std::string frame_str(int64_t frame) { return "frame " + std::to_string(frame); }

// Checks that ids are unique within one list of a frame.
Status check_unique(int64_t frame, const std::vector<int64_t>& ids, const char* what) {
  std::set<int64_t> seen;
  for (int64_t id : ids) {
    if (!seen.insert(id).second)
      return bad_input("", 0, what, frame_str(frame) + ": id " + std::to_string(id) + " appears twice");
  }
  return Status::Ok();
}

Status check_items(int64_t frame, const std::vector<MotItem>& items, const char* what, bool boxes) {
  for (const MotItem& it : items) {
    const bool finite = std::isfinite(it.x) && std::isfinite(it.y) && (!boxes || (std::isfinite(it.w) && std::isfinite(it.h)));
    if (!finite)
      return bad_input("", 0, what, frame_str(frame) + ": id " + std::to_string(it.id) + " has a non-finite coordinate");
    if (boxes && (it.w < 0 || it.h < 0))
      return bad_input("", 0, what, frame_str(frame) + ": id " + std::to_string(it.id) + " has a negative box size");
  }
  return Status::Ok();
}

std::vector<int64_t> ids_of(const std::vector<MotItem>& items) {
  std::vector<int64_t> ids;
  ids.reserve(items.size());
  for (const MotItem& it : items) ids.push_back(it.id);
  return ids;
}

}  // namespace

std::string_view to_string(MotEventType t) {
  switch (t) {
    case MotEventType::kMatch: return "MATCH";
    case MotEventType::kSwitch: return "SWITCH";
    case MotEventType::kMiss: return "MISS";
    case MotEventType::kFalsePositive: return "FP";
  }
  return "?";
}

MotEvaluator::MotEvaluator(MotParams params) : params_(params) {}

double MotEvaluator::distance(MotDistance kind, const MotItem& a, const MotItem& b) {
  if (kind == MotDistance::kPointEuclidean) return std::hypot(a.x - b.x, a.y - b.y);
  const double ix = std::max(0.0, std::min(a.x + a.w, b.x + b.w) - std::max(a.x, b.x));
  const double iy = std::max(0.0, std::min(a.y + a.h, b.y + b.h) - std::max(a.y, b.y));
  const double inter = ix * iy;
  const double uni = a.w * a.h + b.w * b.h - inter;
  const double iou = (inter > 0 && uni > 0) ? inter / uni : 0.0;
  return 1.0 - iou;
}

Status MotEvaluator::update(int64_t frame, const std::vector<MotItem>& objects, const std::vector<MotItem>& hypotheses) {
  const bool boxes = params_.distance == MotDistance::kBoxIou;
  if (Status s = check_items(frame, objects, "objects", boxes); !s) return s;
  if (Status s = check_items(frame, hypotheses, "hypotheses", boxes); !s) return s;
  std::vector<double> d(objects.size() * hypotheses.size());
  for (size_t i = 0; i < objects.size(); ++i)
    for (size_t j = 0; j < hypotheses.size(); ++j)
      d[i * hypotheses.size() + j] = distance(params_.distance, objects[i], hypotheses[j]);
  return update(frame, ids_of(objects), ids_of(hypotheses), d);
}

Status MotEvaluator::update(int64_t frame, const std::vector<int64_t>& oids, const std::vector<int64_t>& hids,
                            const std::vector<double>& distances) {
  if (started_ && frame <= last_frame_)
    return bad_input("", 0, "frame", frame_str(frame) + " does not come after " + frame_str(last_frame_));
  if (distances.size() != oids.size() * hids.size())
    return bad_input("", 0, "distances", frame_str(frame) + ": expected " + std::to_string(oids.size()) + " x " +
                                             std::to_string(hids.size()) + " distances, got " + std::to_string(distances.size()));
  if (Status s = check_unique(frame, oids, "objects"); !s) return s;
  if (Status s = check_unique(frame, hids, "hypotheses"); !s) return s;

  const size_t n = oids.size(), m = hids.size();
  auto dist = [&](size_t i, size_t j) { return distances[i * m + j]; };
  auto valid = [&](size_t i, size_t j) {
    const double d = dist(i, j);
    return std::isfinite(d) && d <= params_.max_distance;
  };
  auto record = [&](MotEventType type, int64_t o, int64_t h, double d) {
    if (params_.record_events) events_.push_back(MotEvent{frame, type, o, h, d});
  };

  // Who appears, and which pairs are within the threshold (for the identity metrics).
  ++num_frames_;
  num_objects_ += static_cast<int64_t>(n);
  num_predictions_ += static_cast<int64_t>(m);
  for (int64_t o : oids) ++objects_[o].frames;
  for (int64_t h : hids) ++hypothesis_frames_[h];
  for (size_t i = 0; i < n; ++i)
    for (size_t j = 0; j < m; ++j)
      if (valid(i, j)) ++within_[{oids[i], hids[j]}];

  std::vector<char> object_done(n, 0), hyp_done(m, 0);
  if (n > 0 && m > 0) {
    // 1. Keep the previous frame's matches that are still within the threshold.
    for (size_t i = 0; i < n; ++i) {
      const int64_t o = oids[i];
      const auto prev = last_hyp_of_object_.find(o);
      if (prev == last_hyp_of_object_.end()) continue;
      if (params_.keep_only_consecutive_matches) {
        const auto lm = last_match_frame_.find(o);
        if (lm == last_match_frame_.end() || !started_ || lm->second != last_frame_) continue;
      }
      size_t j = 0;
      while (j < m && (hyp_done[j] || hids[j] != prev->second)) ++j;
      if (j == m || !valid(i, j)) continue;
      object_done[i] = hyp_done[j] = 1;
      last_match_frame_[o] = frame;
      ever_matched_hyps_.insert(hids[j]);
      ++matches_;
      distance_sum_ += dist(i, j);
      record(MotEventType::kMatch, o, hids[j], dist(i, j));
    }

    // 2. Minimum-cost assignment of the rest.
    CostMatrix cost(static_cast<int>(n), static_cast<int>(m), kNaN);
    for (size_t i = 0; i < n; ++i)
      for (size_t j = 0; j < m; ++j)
        if (!object_done[i] && !hyp_done[j] && valid(i, j)) cost.at(static_cast<int>(i), static_cast<int>(j)) = dist(i, j);
    for (const auto& [ri, cj] : solve_linear_assignment(cost)) {
      const size_t i = static_cast<size_t>(ri), j = static_cast<size_t>(cj);
      const int64_t o = oids[i], h = hids[j];
      const auto prev = last_hyp_of_object_.find(o);
      const bool is_switch = prev != last_hyp_of_object_.end() && prev->second != h;
      if (is_switch && !ever_matched_hyps_.count(h)) ++ascends_;
      const auto prev_obj = last_object_of_hyp_.find(h);
      if (prev_obj != last_object_of_hyp_.end() && prev_obj->second != o) {
        if (!last_match_frame_.count(o)) ++migrates_;
        ++transfers_;
      }
      ever_matched_hyps_.insert(h);
      last_match_frame_[o] = frame;
      last_hyp_of_object_[o] = h;
      last_object_of_hyp_[h] = o;
      object_done[i] = hyp_done[j] = 1;
      if (is_switch) {
        ++switches_;
      } else {
        ++matches_;
      }
      distance_sum_ += dist(i, j);
      record(is_switch ? MotEventType::kSwitch : MotEventType::kMatch, o, h, dist(i, j));
    }
  }

  // 3. Misses, 4. false positives; per-object tracked state (coverage, fragmentations).
  for (size_t i = 0; i < n; ++i) {
    ObjectState& st = objects_[oids[i]];
    if (object_done[i]) {
      ++st.tracked;
      if (st.lost_after_tracked) ++st.fragmentations;
      st.lost_after_tracked = false;
      st.ever_tracked = true;
    } else {
      ++misses_;
      if (st.ever_tracked) st.lost_after_tracked = true;
      record(MotEventType::kMiss, oids[i], -1, kNaN);
    }
  }
  for (size_t j = 0; j < m; ++j) {
    if (hyp_done[j]) continue;
    ++false_positives_;
    record(MotEventType::kFalsePositive, -1, hids[j], kNaN);
  }
  last_frame_ = frame;
  started_ = true;
  return Status::Ok();
}

MotMetrics MotEvaluator::metrics() const {
  MotMetrics r;
  r.num_frames = num_frames_;
  r.num_objects = num_objects_;
  r.num_predictions = num_predictions_;
  r.num_matches = matches_;
  r.num_switches = switches_;
  r.num_detections = matches_ + switches_;
  r.num_false_positives = false_positives_;
  r.num_misses = misses_;
  r.num_transfer = transfers_;
  r.num_ascend = ascends_;
  r.num_migrate = migrates_;
  r.num_unique_objects = static_cast<int64_t>(objects_.size());
  r.num_unique_hypotheses = static_cast<int64_t>(hypothesis_frames_.size());
  for (const auto& [id, st] : objects_) {
    r.num_fragmentations += st.fragmentations;
    const double covered = static_cast<double>(st.tracked) / static_cast<double>(st.frames);
    if (covered >= 0.8) {
      ++r.mostly_tracked;
    } else if (covered >= 0.2) {
      ++r.partially_tracked;
    } else {
      ++r.mostly_lost;
    }
  }
  r.mota = 1.0 - ratio(static_cast<double>(misses_ + switches_ + false_positives_), static_cast<double>(num_objects_));
  r.motp = ratio(distance_sum_, static_cast<double>(r.num_detections));
  r.recall = ratio(static_cast<double>(r.num_detections), static_cast<double>(num_objects_));
  r.precision = ratio(static_cast<double>(r.num_detections), static_cast<double>(r.num_detections + false_positives_));

  // Identity: one global assignment of objects to hypotheses maximising the frames in which the
  // paired trajectories are within the threshold. Only ids that share such a frame can add to
  // it, so the matrix is built over those.
  std::vector<int64_t> oids, hids;
  for (const auto& [pair, count] : within_) {
    oids.push_back(pair.first);
    hids.push_back(pair.second);
  }
  auto unique_sorted = [](std::vector<int64_t>& v) {
    std::sort(v.begin(), v.end());
    v.erase(std::unique(v.begin(), v.end()), v.end());
  };
  unique_sorted(oids);
  unique_sorted(hids);
  CostMatrix cost(static_cast<int>(oids.size()), static_cast<int>(hids.size()), 0.0);
  for (const auto& [pair, count] : within_) {
    const int r_i = static_cast<int>(std::lower_bound(oids.begin(), oids.end(), pair.first) - oids.begin());
    const int c_j = static_cast<int>(std::lower_bound(hids.begin(), hids.end(), pair.second) - hids.begin());
    cost.at(r_i, c_j) = -static_cast<double>(count);
  }
  int64_t idtp = 0;
  for (const auto& [ri, cj] : solve_linear_assignment(cost)) idtp += static_cast<int64_t>(-cost.at(ri, cj));
  r.idtp = idtp;
  r.idfn = num_objects_ - idtp;
  r.idfp = num_predictions_ - idtp;
  r.idp = ratio(static_cast<double>(idtp), static_cast<double>(idtp + r.idfp));
  r.idr = ratio(static_cast<double>(idtp), static_cast<double>(idtp + r.idfn));
  r.idf1 = ratio(2.0 * static_cast<double>(idtp), static_cast<double>(num_objects_ + num_predictions_));
  return r;
}

// ---- MOTChallenge text ----

namespace {

constexpr const char* kColumns[] = {"frame", "id", "bb_left", "bb_top", "bb_width", "bb_height", "conf"};

std::string_view trim(std::string_view s) {
  const auto b = s.find_first_not_of(" \t\r");
  if (b == std::string_view::npos) return {};
  const auto e = s.find_last_not_of(" \t\r");
  return s.substr(b, e - b + 1);
}

std::vector<std::string_view> split_fields(std::string_view line) {
  std::vector<std::string_view> out;
  if (line.find(',') != std::string_view::npos) {
    size_t start = 0;
    while (true) {
      const size_t comma = line.find(',', start);
      out.push_back(trim(line.substr(start, comma == std::string_view::npos ? std::string_view::npos : comma - start)));
      if (comma == std::string_view::npos) break;
      start = comma + 1;
    }
    return out;
  }
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    if (i >= line.size()) break;
    size_t j = i;
    while (j < line.size() && line[j] != ' ' && line[j] != '\t') ++j;
    out.push_back(line.substr(i, j - i));
    i = j;
  }
  return out;
}

std::string quoted(std::string_view s) {
  std::string out = "'";
  out.append(s);
  out += '\'';
  return out;
}

bool parse_double(std::string_view s, double* out) {
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  if (s.empty()) return false;
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), *out);
  return ec == std::errc() && ptr == s.data() + s.size();
}

}  // namespace

Result<std::vector<MotChallengeRow>> parse_mot_challenge(std::string_view text, const std::string& file,
                                                         const MotChallengeLoadOptions& options) {
  std::vector<MotChallengeRow> rows;
  std::map<std::pair<int64_t, int64_t>, int> seen;  // (frame, id) -> line
  int line_no = 0;
  size_t pos = 0;
  while (pos < text.size()) {
    const size_t nl = text.find('\n', pos);
    const std::string_view raw = text.substr(pos, nl == std::string_view::npos ? std::string_view::npos : nl - pos);
    pos = nl == std::string_view::npos ? text.size() : nl + 1;
    ++line_no;
    const std::string_view line = trim(raw);
    if (line.empty()) continue;
    const auto fields = split_fields(line);
    if (fields.size() < 7) {
      return bad_input(file, line_no, "",
                       "expected at least 7 fields (frame, id, bb_left, bb_top, bb_width, bb_height, conf), found " +
                           std::to_string(fields.size()));
    }
    double v[7];
    for (int k = 0; k < 7; ++k) {
      if (!parse_double(fields[k], &v[k]) || !std::isfinite(v[k]))
        return bad_input(file, line_no, kColumns[k], quoted(fields[k]) + " is not a finite number");
    }
    for (int k = 0; k < 2; ++k) {
      if (v[k] != std::floor(v[k]) || std::fabs(v[k]) > 9.0e15)
        return bad_input(file, line_no, kColumns[k], quoted(fields[k]) + " is not a whole number");
    }
    if (v[4] < 0) return bad_input(file, line_no, kColumns[4], "negative box width");
    if (v[5] < 0) return bad_input(file, line_no, kColumns[5], "negative box height");
    MotChallengeRow row;
    row.frame = static_cast<int64_t>(v[0]);
    row.id = static_cast<int64_t>(v[1]);
    row.x = v[2];
    row.y = v[3];
    row.w = v[4];
    row.h = v[5];
    row.confidence = v[6];
    row.line = line_no;
    const auto [it, inserted] = seen.emplace(std::make_pair(row.frame, row.id), line_no);
    if (!inserted) {
      return bad_input(file, line_no, "id",
                       "frame " + std::to_string(row.frame) + " lists id " + std::to_string(row.id) +
                           " again (first on line " + std::to_string(it->second) + ")");
    }
    if (row.confidence >= options.min_confidence) rows.push_back(row);
  }
  return rows;
}

Result<std::vector<MotChallengeRow>> load_mot_challenge(const std::string& path, const MotChallengeLoadOptions& options) {
  std::ifstream f(path, std::ios::binary);
  if (!f) return bad_input(path, 0, "", "cannot open file");
  std::stringstream ss;
  ss << f.rdbuf();
  if (f.bad()) return bad_input(path, 0, "", "cannot read file");
  return parse_mot_challenge(ss.str(), path, options);
}

Result<MotMetrics> evaluate_mot_challenge(const std::vector<MotChallengeRow>& ground_truth,
                                          const std::vector<MotChallengeRow>& hypotheses, MotParams params) {
  if (params.distance != MotDistance::kBoxIou)
    return bad_input("", 0, "distance", "MOTChallenge rows are image boxes: use the IoU distance");
  // Frames in increasing order; rows keep their file order within a frame.
  std::map<int64_t, std::pair<std::vector<MotItem>, std::vector<MotItem>>> frames;
  for (const auto& r : ground_truth) frames[r.frame].first.push_back(MotItem{r.id, r.x, r.y, r.w, r.h});
  for (const auto& r : hypotheses) frames[r.frame].second.push_back(MotItem{r.id, r.x, r.y, r.w, r.h});
  MotEvaluator eval(params);
  for (const auto& [frame, lists] : frames) {
    if (Status s = eval.update(frame, lists.first, lists.second); !s) return s.error();
  }
  return eval.metrics();
}

}  // namespace vigil::vision
