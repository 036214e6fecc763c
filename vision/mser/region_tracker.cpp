#include "vision/mser/region_tracker.h"

#include "vision/mser/kd_tree.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <tuple>

namespace vigil::vision::mser {
namespace {

double colour_distance(const cv::Vec3f& a, const cv::Vec3f& b) { return cv::norm(a - b); }

constexpr double kPi = 3.14159265358979323846;

// |a - b| wrapped to 0..pi.
double angle_difference(double a, double b) {
  double d = std::fmod(std::abs(a - b), 2 * kPi);
  return d > kPi ? 2 * kPi - d : d;
}

}  // namespace

std::vector<std::vector<LineCorner>> line_corners(const Segmentation& s, const Lines& lines,
                                                  const RegionTrackerParams& p) {
  std::vector<std::vector<LineCorner>> out(s.regions.size());
  const cv::Mat& lab = s.labels;
  if (lab.empty() || lab.type() != CV_32S) return out;
  const int nr = static_cast<int>(s.regions.size());
  auto label_at = [&](cv::Point2f q) {
    const int x = static_cast<int>(std::lround(q.x)), y = static_cast<int>(std::lround(q.y));
    if (x < 0 || y < 0 || x >= lab.cols || y >= lab.rows) return -1;
    const int r = lab.at<int32_t>(y, x);
    return r >= 0 && r < nr ? r : -1;
  };
  auto near_region = [&](cv::Point2f q, int r) {
    const int x0 = static_cast<int>(std::lround(q.x)), y0 = static_cast<int>(std::lround(q.y));
    for (int y = std::max(0, y0 - p.corner_near); y <= std::min(lab.rows - 1, y0 + p.corner_near); ++y)
      for (int x = std::max(0, x0 - p.corner_near); x <= std::min(lab.cols - 1, x0 + p.corner_near); ++x)
        if (lab.at<int32_t>(y, x) == r) return true;
    return false;
  };
  for (const LineSegment& seg : lines.segments) {
    const cv::Point2f d = seg.b - seg.a;
    const float len = static_cast<float>(cv::norm(d));
    if (!(len > 1e-3f)) continue;
    const cv::Point2f n(-d.y / len, d.x / len);  // a unit normal
    int side_region[2] = {-1, -1};
    for (int side = 0; side < 2; ++side) {
      const float sgn = side == 0 ? 1.0f : -1.0f;
      // The majority of three samples along the segment, `corner_side` px off it.
      int samples[3];
      for (int k = 0; k < 3; ++k) samples[k] = label_at(seg.a + (0.25f * (k + 1)) * d + sgn * static_cast<float>(p.corner_side) * n);
      for (int k = 0; k < 3 && side_region[side] < 0; ++k) {
        int votes = 0;
        for (int j = 0; j < 3; ++j) votes += samples[j] == samples[k];
        if (samples[k] >= 0 && votes >= 2) side_region[side] = samples[k];
      }
    }
    if (side_region[0] == side_region[1]) continue;  // not a boundary: inside one region (or off the image)
    for (int side = 0; side < 2; ++side) {
      const int r = side_region[side];
      if (r < 0 || s.regions[r].size < p.min_size) continue;
      // Looking out of region r across the line: `out_dir`; its right hand is `right`.
      const cv::Point2f out_dir = side == 0 ? -n : n;
      const cv::Point2f right(-out_dir.y, out_dir.x);
      const bool a_left = (seg.a - seg.b).dot(right) < 0;
      const cv::Point2f from_right_to_left = a_left ? seg.a - seg.b : seg.b - seg.a;
      const float angle = std::atan2(from_right_to_left.y, from_right_to_left.x);
      for (int e = 0; e < 2; ++e) {
        const cv::Point2f pos = e == 0 ? seg.a : seg.b;
        const bool left = e == 0 ? a_left : !a_left;
        if (!near_region(pos, r)) continue;
        // The same corner twice (an edge traced on both its sides): keep the first.
        bool dup = false;
        for (const LineCorner& c : out[r]) {
          if (c.left != left || std::abs(c.pos.x - pos.x) >= 1.5f || std::abs(c.pos.y - pos.y) >= 1.5f) continue;
          if (cv::norm(c.pos - pos) < 1.5 && angle_difference(c.angle, angle) <= p.corner_angle * kPi / 180) {
            dup = true;
            break;
          }
        }
        if (!dup) out[r].push_back({pos, angle, s.regions[r].mean, left, r});
      }
    }
  }
  return out;
}

void RegionTracker::reset() {
  tracks_.clear();
  ids_.clear();
  next_id_ = 1;
  counts_ = {};
}

const std::vector<int64_t>& RegionTracker::update(const Segmentation& s, const Lines* lines) {
  counts_ = {};
  const size_t nr = s.regions.size();
  ids_.assign(nr, -1);
  std::vector<int> track_of(nr, -1);  // region -> index into tracks_
  std::vector<char> matched(tracks_.size(), 0);
  auto trackable = [&](size_t r) { return s.regions[r].size >= p_.min_size; };
  auto link = [&](size_t ti, int r, TrackPhase phase) {
    matched[ti] = 1;
    track_of[r] = static_cast<int>(ti);
    tracks_[ti].phase = phase;
  };

  // Phase 1: feed-forward. The last frame's region -> its live track.
  std::map<int, size_t> track_by_region;
  for (size_t ti = 0; ti < tracks_.size(); ++ti)
    if (tracks_[ti].lost == 0 && tracks_[ti].region >= 0) track_by_region[tracks_[ti].region] = ti;
  std::map<int, int> heir;  // donor -> the region with most seeds from it
  for (size_t r = 0; r < nr; ++r) {
    const Region& reg = s.regions[r];
    if (reg.donor < 0 || !trackable(r)) continue;
    auto it = heir.find(reg.donor);
    if (it == heir.end() || reg.seeds > s.regions[it->second].seeds) heir[reg.donor] = static_cast<int>(r);
  }
  for (const auto& [donor, r] : heir) {
    auto t = track_by_region.find(donor);
    if (t == track_by_region.end() || matched[t->second]) continue;
    link(t->second, r, TrackPhase::kFeedForward);
    ++counts_.feed_forward;
  }

  // Phases 2 and 4: candidates from a kd-tree over the unmatched regions, greedy by similarity.
  auto greedy = [&](bool secondary) {
    std::vector<std::pair<cv::Point2f, int>> pts;
    for (size_t r = 0; r < nr; ++r)
      if (track_of[r] < 0 && trackable(r)) pts.push_back({s.regions[r].centroid, static_cast<int>(r)});
    if (pts.empty()) return;
    const KdTree2 tree(std::move(pts));
    const double k = secondary ? p_.loose : 1.0;
    std::vector<std::tuple<double, size_t, int>> cands;
    for (size_t ti = 0; ti < tracks_.size(); ++ti) {
      const RegionTrack& t = tracks_[ti];
      if (matched[ti]) continue;
      if (!secondary && t.lost != 0) continue;
      if (secondary && t.lost + 1 > p_.window) continue;
      // Phase 2 compares successive frames as they are; phase 4 where the motion model puts it.
      const cv::Point2f at = secondary ? t.centroid + t.velocity * static_cast<float>(t.lost + 1) : t.centroid;
      const double radius = k * (p_.max_shift + p_.shift_per_size * (t.width + t.height));
      for (int r : tree.within(at, static_cast<float>(radius))) {
        const Region& reg = s.regions[r];
        const double rw = std::max<double>(reg.width(), 1) / std::max<double>(t.width, 1);
        const double rh = std::max<double>(reg.height(), 1) / std::max<double>(t.height, 1);
        const double lim = std::pow(p_.max_size_ratio, k);
        if (rw > lim || rw < 1 / lim || rh > lim || rh < 1 / lim) continue;
        const double dc = colour_distance(reg.mean, t.colour);
        if (dc > k * p_.max_colour) continue;
        const double dp = cv::norm(reg.centroid - at);
        const double sim = dp / radius + (std::abs(std::log(rw)) + std::abs(std::log(rh))) / (2 * std::log(lim)) +
                           dc / (k * p_.max_colour);
        cands.push_back({sim, ti, r});
      }
    }
    std::sort(cands.begin(), cands.end());
    for (const auto& [sim, ti, r] : cands) {
      if (matched[ti] || track_of[r] >= 0) continue;
      link(ti, r, secondary ? TrackPhase::kSecondary : TrackPhase::kMser);
      ++(secondary ? counts_.secondary : counts_.mser);
    }
  };
  // Phase 3 and phase 4's second half: line corners. A track's corners (from the last frame it
  // was matched; phase 4: moved where its motion model puts them) find candidates among the
  // corners of the regions still unmatched; per track-region pair the agreeing corners are
  // paired one to one (closest first); a pair with `min_corners` of them, or one strong one, is
  // a candidate; candidates are linked greedily, most agreeing corners first, then the closest.
  const bool use_lines = lines && p_.line_tracking;
  const std::vector<std::vector<LineCorner>> corners =
      use_lines ? line_corners(s, *lines, p_) : std::vector<std::vector<LineCorner>>(nr);
  auto line_phase = [&](bool secondary) {
    if (!use_lines) return;
    std::vector<std::pair<cv::Point2f, int>> pts;
    std::vector<const LineCorner*> flat;
    for (size_t r = 0; r < nr; ++r)
      if (track_of[r] < 0 && trackable(r))
        for (const LineCorner& c : corners[r]) {
          pts.push_back({c.pos, static_cast<int>(flat.size())});
          flat.push_back(&c);
        }
    if (pts.empty()) return;
    const KdTree2 tree(std::move(pts));
    const double k = secondary ? p_.loose : 1.0;
    const double max_dp = k * p_.corner_shift, max_da = k * p_.corner_angle * kPi / 180, max_dc = k * p_.corner_colour;
    std::vector<std::tuple<int, double, size_t, int>> cands;  // (-agreeing, mean distance, track, region)
    for (size_t ti = 0; ti < tracks_.size(); ++ti) {
      const RegionTrack& t = tracks_[ti];
      if (matched[ti] || t.corners.empty()) continue;
      if (!secondary && t.lost != 0) continue;
      if (secondary && t.lost + 1 > p_.window) continue;
      const cv::Point2f shift = secondary ? t.velocity * static_cast<float>(t.lost + 1) : cv::Point2f(0, 0);
      std::map<int, std::vector<std::tuple<double, int, int, bool>>> per_region;  // (distance, track corner, corner, strong)
      for (size_t i = 0; i < t.corners.size(); ++i) {
        const LineCorner& tc = t.corners[i];
        const cv::Point2f q = tc.pos + shift;
        for (int fi : tree.within(q, static_cast<float>(max_dp))) {
          const LineCorner& rc = *flat[fi];
          if (rc.left != tc.left) continue;
          const double da = angle_difference(rc.angle, tc.angle);
          if (da > max_da) continue;
          const double dc = colour_distance(rc.colour, tc.colour);
          if (dc > max_dc) continue;
          const double dp = cv::norm(rc.pos - q);
          const bool strong = dp <= k * p_.strong_shift && da <= k * p_.strong_angle * kPi / 180 && dc <= max_dc / 2;
          per_region[rc.region].push_back({dp / max_dp + da / max_da + dc / max_dc, static_cast<int>(i), fi, strong});
        }
      }
      for (auto& [r, list] : per_region) {
        std::sort(list.begin(), list.end());
        std::vector<int> used_t, used_c;
        int agree = 0;
        bool strong = false;
        double sum = 0;
        for (const auto& [dist, i, fi, st] : list) {
          if (std::find(used_t.begin(), used_t.end(), i) != used_t.end() ||
              std::find(used_c.begin(), used_c.end(), fi) != used_c.end())
            continue;
          used_t.push_back(i);
          used_c.push_back(fi);
          ++agree;
          sum += dist;
          strong = strong || st;
        }
        if (agree >= p_.min_corners || strong) cands.push_back({-agree, sum / agree, ti, r});
      }
    }
    std::sort(cands.begin(), cands.end());
    for (const auto& [neg, dist, ti, r] : cands) {
      if (matched[ti] || track_of[r] >= 0) continue;
      link(ti, r, secondary ? TrackPhase::kSecondary : TrackPhase::kLine);
      if (secondary) {
        ++counts_.secondary;
        ++counts_.secondary_line;
      } else {
        ++counts_.line;
      }
    }
  };
  greedy(false);
  line_phase(false);
  greedy(true);
  line_phase(true);

  // Update the matched tracks, age the rest, start new ones.
  std::vector<RegionTrack> next;
  for (size_t ti = 0; ti < tracks_.size(); ++ti) {
    RegionTrack t = tracks_[ti];
    if (!matched[ti]) {
      ++t.lost;
      t.region = -1;
      if (t.lost <= p_.window) next.push_back(t);
    }
  }
  for (size_t r = 0; r < nr; ++r) {
    const Region& reg = s.regions[r];
    RegionTrack t;
    if (track_of[r] >= 0) {
      t = tracks_[track_of[r]];
      const cv::Point2f step = (reg.centroid - t.centroid) / static_cast<float>(t.lost + 1);
      t.velocity = t.age > 0 ? 0.5f * t.velocity + 0.5f * step : step;
      ++t.age;
    } else if (trackable(r)) {
      t.id = next_id_++;
      t.phase = TrackPhase::kNew;
      ++counts_.created;
    } else {
      continue;
    }
    t.region = static_cast<int>(r);
    t.lost = 0;
    t.centroid = reg.centroid;
    t.width = reg.width();
    t.height = reg.height();
    t.colour = reg.mean;
    t.corners = corners[r];
    ids_[r] = t.id;
    next.push_back(t);
  }
  tracks_.swap(next);
  return ids_;
}

}  // namespace vigil::vision::mser
