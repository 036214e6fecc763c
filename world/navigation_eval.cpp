#include "world/navigation_eval.h"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "common/geometry.h"
#include "common/lines.h"

namespace vigil {
namespace {

struct TruePose {
  int64_t t;
  Pose2 pose;
};

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

}  // namespace

Result<NavigationFigures> evaluate_navigation(const std::filesystem::path& gt_path,
                                              const std::filesystem::path& robots_path) {
  NavigationFigures out;
  std::map<std::string, std::vector<TruePose>> truth;
  std::map<std::string, std::map<std::string, int>> contacts;
  std::map<std::string, int> pushing;
  int64_t last_t = 0;
  Status s = for_each_line(gt_path, [&](std::string_view line, int n) -> Status {
    auto j = nlohmann::json::parse(line, nullptr, false);
    if (j.is_discarded() || !j.is_object()) return bad_input(gt_path.string(), n, "", "not a JSON object");
    const std::string type = j.value("type", "");
    if (type == "tick") {
      const int64_t t = j.value("t_ns", int64_t{0});
      last_t = std::max(last_t, t);
      for (const auto& e : j.value("entities", nlohmann::json::array())) {
        if (e.value("kind", "") != "robot") continue;
        truth[e.value("id", "")].push_back({t, {e.value("x", 0.0), e.value("y", 0.0), e.value("yaw", 0.0)}});
      }
    } else if (type == "contact") {
      contacts[j.value("robot", "")][j.value("other_kind", "")]++;
      if (j.value("robot_pushing", false) && j.value("other_kind", "") != "wall") pushing[j.value("robot", "")]++;
    }
    return Status::Ok();
  });
  if (!s) return s.error();
  out.duration_s = to_seconds(last_t);

  struct Acc {
    RobotNavigationFigures f;
    double pos2 = 0, yaw2 = 0;
    std::map<uint64_t, double> started;  // goal key -> start time
    int64_t start_t = -1;
    std::vector<double> ratios;
  };
  std::map<std::string, Acc> acc;
  for (const auto& [id, poses] : truth) acc[id].f.robot = id;
  s = for_each_line(robots_path, [&](std::string_view line, int n) -> Status {
    auto j = nlohmann::json::parse(line, nullptr, false);
    if (j.is_discarded() || !j.is_object() || !j.contains("robot") || !j.contains("t_ns"))
      return bad_input(robots_path.string(), n, "", "not a robot report (needs robot and t_ns)");
    const std::string id = j.value("robot", "");
    const int64_t t = j.value("t_ns", int64_t{0});
    Acc& a = acc[id];
    a.f.robot = id;
    a.f.reports++;
    // The truth at the report's time, interpolated between the bracketing ticks.
    const auto it = truth.find(id);
    if (j.value("localized", false) && it != truth.end() && !it->second.empty()) {
      const auto& tp = it->second;
      auto hi = std::lower_bound(tp.begin(), tp.end(), t, [](const TruePose& p, int64_t v) { return p.t < v; });
      Pose2 truth_pose;
      if (hi == tp.end()) truth_pose = tp.back().pose;
      else if (hi == tp.begin() || hi->t == t) truth_pose = hi->pose;
      else {
        const auto lo = hi - 1;
        const double u = static_cast<double>(t - lo->t) / static_cast<double>(hi->t - lo->t);
        truth_pose = {lo->pose.x + u * (hi->pose.x - lo->pose.x), lo->pose.y + u * (hi->pose.y - lo->pose.y),
                      wrap_angle(lo->pose.yaw + u * wrap_angle(hi->pose.yaw - lo->pose.yaw))};
      }
      const double dp = std::hypot(j.value("x", 0.0) - truth_pose.x, j.value("y", 0.0) - truth_pose.y);
      const double dy = std::abs(wrap_angle(j.value("yaw", 0.0) - truth_pose.yaw));
      a.f.localized_reports++;
      if (a.f.first_localized_s < 0) a.f.first_localized_s = to_seconds(t);
      a.pos2 += dp * dp;
      a.yaw2 += dy * dy;
      a.f.position_worst = std::max(a.f.position_worst, dp);
      a.f.heading_worst = std::max(a.f.heading_worst, dy);
    }
    const std::string ev = j.value("event", "");
    if (ev == "goal_started") {
      a.f.goals_started++;
      a.start_t = t;
    } else if (ev == "goal_reached") {
      a.f.goals_reached++;
      const double L = j.value("path_length", 0.0), v = j.value("cruise_speed", 0.0);
      if (a.start_t >= 0 && L > 0 && v > 0) a.ratios.push_back(to_seconds(t - a.start_t) / (L / v));
      a.start_t = -1;
    } else if (ev == "goal_failed") {
      a.f.goals_failed++;
      a.f.failures.push_back(j.value("detail", ""));
      a.start_t = -1;
    }
    return Status::Ok();
  });
  if (!s) return s.error();
  int touching = 0;
  for (auto& [id, a] : acc) {
    if (a.f.localized_reports > 0) {
      a.f.position_rms = std::sqrt(a.pos2 / a.f.localized_reports);
      a.f.heading_rms = std::sqrt(a.yaw2 / a.f.localized_reports);
    }
    a.f.median_time_ratio = median(a.ratios);
    a.f.worst_time_ratio = a.ratios.empty() ? 0 : *std::max_element(a.ratios.begin(), a.ratios.end());
    a.f.contacts = contacts[id];
    a.f.pushing_contacts = pushing[id];
    out.pushing_contacts += pushing[id];
    for (const auto& [kind, count] : a.f.contacts) {
      if (kind == "wall") out.contacts_with_walls += count;
      else if (kind == "robot") out.contacts_with_robots += count;
      else out.contacts_with_people_or_objects += count;
    }
    out.robots.push_back(a.f);
  }
  touching = out.contacts_with_people_or_objects + out.contacts_with_robots;
  const double robot_hours = out.duration_s / 3600.0 * static_cast<double>(out.robots.size());
  out.contacts_per_robot_hour = robot_hours > 0 ? touching / robot_hours : 0;
  out.pushing_contacts_per_robot_hour = robot_hours > 0 ? out.pushing_contacts / robot_hours : 0;
  return out;
}

}  // namespace vigil
