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

}  // namespace

void RegionTracker::reset() {
  tracks_.clear();
  ids_.clear();
  next_id_ = 1;
  counts_ = {};
}

const std::vector<int64_t>& RegionTracker::update(const Segmentation& s) {
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
  greedy(false);
  // Phase 3 (line corners) is not built yet.
  greedy(true);

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
    ids_[r] = t.id;
    next.push_back(t);
  }
  tracks_.swap(next);
  return ids_;
}

}  // namespace vigil::vision::mser
