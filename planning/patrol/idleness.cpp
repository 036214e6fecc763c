#include "planning/patrol/idleness.h"

#include <algorithm>
#include <cmath>

namespace vigil::planning::patrol {

IdlenessStats idleness(std::vector<Visit> visits, int vertex_count, double end_time) {
  std::stable_sort(visits.begin(), visits.end(), [](const Visit& a, const Visit& b) { return a.t < b.t; });
  IdlenessStats s;
  s.vertices = vertex_count;
  std::vector<double> last(static_cast<size_t>(std::max(vertex_count, 0)), -1.0);
  std::vector<double> sum(last.size(), 0.0);
  std::vector<int> cnt(last.size(), 0);
  std::vector<double> all;
  for (const Visit& v : visits) {
    if (v.vertex < 0 || v.vertex >= vertex_count) continue;
    ++s.visits;
    double& l = last[v.vertex];
    if (l >= 0) {
      const double iv = v.t - l;
      all.push_back(iv);
      sum[v.vertex] += iv;
      ++cnt[v.vertex];
    }
    l = v.t;
  }
  s.intervals = static_cast<int>(all.size());
  if (!all.empty()) {
    double m = 0;
    for (double x : all) m += x;
    m /= static_cast<double>(all.size());
    double var = 0;
    for (double x : all) var += (x - m) * (x - m);
    s.average = m;
    s.stddev = std::sqrt(var / static_cast<double>(all.size()));
    s.worst = *std::max_element(all.begin(), all.end());
    std::vector<double> sorted = all;
    std::sort(sorted.begin(), sorted.end());
    const size_t k = sorted.size();
    s.median = k % 2 ? sorted[k / 2] : 0.5 * (sorted[k / 2 - 1] + sorted[k / 2]);
  }
  for (size_t i = 0; i < last.size(); ++i) {
    if (last[i] < 0) {
      ++s.unvisited;
      s.longest_open = std::max(s.longest_open, end_time);
    } else {
      s.longest_open = std::max(s.longest_open, end_time - last[i]);
    }
    s.vertex_average.push_back(cnt[i] ? sum[i] / cnt[i] : 0.0);
  }
  return s;
}

VisitDetector::VisitDetector(std::vector<Vec2> vertices, double radius) : v_(std::move(vertices)), r_(radius) {}

void VisitDetector::observe(const std::string& robot, double t, Vec2 p) {
  auto it = std::find_if(robots_.begin(), robots_.end(), [&](const auto& r) { return r.first == robot; });
  if (it == robots_.end()) {
    robots_.push_back({robot, Armed{std::vector<char>(v_.size(), 0)}});
    it = robots_.end() - 1;
  }
  auto& inside = it->second.inside;
  for (size_t i = 0; i < v_.size(); ++i) {
    const double d = (v_[i] - p).norm();
    if (!inside[i] && d <= r_) {
      inside[i] = 1;
      visits_.push_back({t, static_cast<int>(i), robot});
    } else if (inside[i] && d > 1.5 * r_) {
      inside[i] = 0;
    }
  }
}

void InterferenceCounter::observe(const std::vector<std::pair<std::string, Vec2>>& robots) {
  for (size_t i = 0; i < robots.size(); ++i) {
    for (size_t j = i + 1; j < robots.size(); ++j) {
      auto key = std::minmax(robots[i].first, robots[j].first);
      std::pair<std::string, std::string> k{key.first, key.second};
      const double d = (robots[i].second - robots[j].second).norm();
      auto it = std::find(close_.begin(), close_.end(), k);
      if (it == close_.end() && d <= d_) {
        close_.push_back(k);
        ++count_;
      } else if (it != close_.end() && d > 1.25 * d_) {
        close_.erase(it);
      }
    }
  }
}

}  // namespace vigil::planning::patrol
