// The video server's logic (chapter 10.6.3) without DDS or camera models: camera reports of
// events, already in the building's map frame with their uncertainty, become incidents. Reports
// of one kind from different cameras close in place and time are one incident, whose position
// is the particle-filter fusion of all its reports (position_filter.h); an incident is withdrawn
// when every camera that reported it has withdrawn its report. The DDS transport
// (plugins/dds_bridge/event_server.h) changes frames and carries messages around this.
//
// Incident ids come from the first report: (camera's index + 1) * 1e6 + the camera's report id,
// so a restarted server sent the same reports again gives the same ids.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "common/geometry.h"
#include "planning/fusion/position_filter.h"

namespace vigil::planning::fusion {

// One camera's report of an event (or its withdrawal), in the map frame.
struct Report {
  std::string camera;
  uint64_t id = 0;           // the camera's own id of the event
  std::string kind;          // left_bag, bag_taken, ...
  bool cancelled = false;
  int64_t stamp_ns = 0;
  Vec3 position;             // map frame
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Identity() * 0.01;  // of (x, y), m^2
  std::string object;
  double confidence = 0;
  std::vector<int> people;   // the camera's track ids
  Vec3 camera_position;      // where the camera saw it, in its own frame (kept for logs)
};

struct Incident {
  uint64_t id = 0;
  std::string kind;
  bool cancelled = false;
  int64_t stamp_ns = 0;
  Vec3 position;                          // the fused belief's mean (z: the reports' mean)
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Zero();  // the belief's
  std::vector<std::string> cameras;       // reporting cameras, first first
  std::vector<uint64_t> camera_event_ids;
  std::string object;
  double confidence = 0;
  std::vector<int> people;                // the first report's
  Vec3 camera_position;                   // the first report's
  int reports = 0;                        // fused into the belief
};

struct MergeParams {
  double merge_distance = 1.0;  // m: reports of one kind this close...
  double merge_time_s = 5.0;    // ...and this close in time are one incident
  PositionFilterParams filter;
};

class IncidentMerger {
 public:
  // `cameras`: the known camera ids, in the scenario's order (they make the incident ids).
  // `inside_map(x, y)`: whether a map point is inside the building (reports elsewhere are
  // rejected; particles stay inside).
  IncidentMerger(std::vector<std::string> cameras, MergeParams params, std::function<bool(double, double)> inside_map);

  struct Outcome {
    enum What { kNew, kCancelled, kMerged, kIgnored, kRejected } what = kIgnored;
    Incident incident;   // kNew, kCancelled: what to publish; kMerged: the incident it joined, fused
    std::string reason;  // kRejected, kIgnored, kMerged: why
    bool moved = false;  // kMerged: the fused position moved (more than 2 cm): worth publishing
  };
  Outcome add(const Report& r);
  const std::vector<Incident>& incidents() const { return incidents_; }
  // The belief of incident `i` (index into incidents()).
  const PositionFilter& belief(size_t i) const { return filters_[i]; }

 private:
  std::vector<std::string> cameras_;
  MergeParams params_;
  std::function<bool(double, double)> inside_map_;
  std::vector<Incident> incidents_;
  std::vector<PositionFilter> filters_;
  std::vector<double> z_sum_;
  std::map<std::pair<std::string, uint64_t>, size_t> report_to_incident_;
  std::map<std::pair<std::string, uint64_t>, bool> cancelled_reports_;
};

}  // namespace vigil::planning::fusion
