#include "planning/fusion/incident_merger.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace vigil::planning::fusion {

IncidentMerger::IncidentMerger(std::vector<std::string> cameras, MergeParams params,
                               std::function<bool(double, double)> inside_map)
    : cameras_(std::move(cameras)), params_(params), inside_map_(std::move(inside_map)) {}

IncidentMerger::Outcome IncidentMerger::add(const Report& r) {
  Outcome out;
  const auto cam = std::find(cameras_.begin(), cameras_.end(), r.camera);
  if (cam == cameras_.end()) {
    out.what = Outcome::kRejected;
    out.reason = "event " + std::to_string(r.id) + " from unknown camera '" + r.camera + "'";
    return out;
  }
  const auto key = std::make_pair(r.camera, r.id);
  const std::string who = "event " + std::to_string(r.id) + " of camera " + r.camera;

  if (r.cancelled) {
    const auto it = report_to_incident_.find(key);
    if (it == report_to_incident_.end()) {
      out.what = Outcome::kIgnored;
      out.reason = who + ": cancels nothing known";
      return out;
    }
    if (cancelled_reports_[key]) {
      out.what = Outcome::kIgnored;
      out.reason = who + ": already cancelled";
      return out;
    }
    cancelled_reports_[key] = true;
    Incident& in = incidents_[it->second];
    bool all = true;
    for (size_t i = 0; i < in.cameras.size(); ++i) all = all && cancelled_reports_[{in.cameras[i], in.camera_event_ids[i]}];
    if (!all || in.cancelled) {
      out.what = Outcome::kIgnored;
      out.reason = who + ": cancelled; other cameras still report incident " + std::to_string(in.id);
      return out;
    }
    in.cancelled = true;
    in.stamp_ns = std::max(in.stamp_ns, r.stamp_ns);
    out.what = Outcome::kCancelled;
    out.incident = in;
    return out;
  }

  if (report_to_incident_.count(key)) {
    out.what = Outcome::kIgnored;
    out.reason = who + ": duplicate";
    return out;
  }
  const Vec3 p = r.position;
  const bool finite_cov = r.covariance.allFinite();
  if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z) || !finite_cov || !inside_map_(p.x, p.y)) {
    out.what = Outcome::kRejected;
    char buf[160];
    if (!finite_cov) {
      std::snprintf(buf, sizeof buf, ": its position's covariance is not finite");
    } else {
      std::snprintf(buf, sizeof buf, ": at (%.2f, %.2f, %.2f) in the map frame, outside the map", p.x, p.y, p.z);
    }
    out.reason = who + buf;
    return out;
  }
  const Eigen::Vector2d xy(p.x, p.y);
  // Another camera's report of the same incident?
  for (size_t i = 0; i < incidents_.size(); ++i) {
    Incident& in = incidents_[i];
    if (in.cancelled || in.kind != r.kind) continue;
    if (std::find(in.cameras.begin(), in.cameras.end(), r.camera) != in.cameras.end()) continue;
    if (std::abs(r.stamp_ns - in.stamp_ns) * 1e-9 > params_.merge_time_s) continue;
    if (std::hypot(p.x - in.position.x, p.y - in.position.y) > params_.merge_distance) continue;
    in.cameras.push_back(r.camera);
    in.camera_event_ids.push_back(r.id);
    in.confidence = std::max(in.confidence, r.confidence);
    report_to_incident_[key] = i;
    const Vec3 before = in.position;
    PositionFilter& f = filters_[i];
    if (f.update(xy, r.covariance)) {
      ++in.reports;
      z_sum_[i] += p.z;
      const Eigen::Vector2d m = f.mean();
      in.position = {m.x(), m.y(), z_sum_[i] / in.reports};
      in.covariance = f.covariance();
      out.reason = who + ": merged into incident " + std::to_string(in.id) + " and fused";
    } else {
      out.reason = who + ": merged into incident " + std::to_string(in.id) + " (not fused: inconsistent with its belief)";
    }
    out.what = Outcome::kMerged;
    out.moved = std::hypot(in.position.x - before.x, in.position.y - before.y) > 0.02;
    out.incident = in;
    return out;
  }
  Incident in;
  in.id = static_cast<uint64_t>(cam - cameras_.begin() + 1) * 1000000ULL + r.id;
  in.kind = r.kind;
  in.stamp_ns = r.stamp_ns;
  in.cameras = {r.camera};
  in.camera_event_ids = {r.id};
  in.object = r.object;
  in.confidence = r.confidence;
  in.people = r.people;
  in.camera_position = r.camera_position;
  PositionFilter f(in.id, params_.filter, inside_map_);
  f.init(xy, r.covariance);
  // The first report's own position is the incident's until another camera's is fused (the
  // particles' mean only differs from it by sampling noise).
  in.position = p;
  in.covariance = f.covariance();
  in.reports = 1;
  report_to_incident_[key] = incidents_.size();
  incidents_.push_back(in);
  filters_.push_back(std::move(f));
  z_sum_.push_back(p.z);
  out.what = Outcome::kNew;
  out.incident = in;
  return out;
}

}  // namespace vigil::planning::fusion
