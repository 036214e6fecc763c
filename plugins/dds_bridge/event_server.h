// The video server of chapter 10.6.3, over DDS: camera nodes publish the events their activity
// rules raise, in their own camera frame (topic vigil_camera_events); the server checks each
// one, transforms it into the building's map frame with the camera's pose, merges the reports of
// one incident from several cameras (fusing their positions with a particle filter), and
// publishes incidents to the robots (topic vigil_events): new ones, withdrawn ones, and an
// incident again, same id, when another camera's report moved its fused position.
//
// Incident ids are derived from the first report, (camera's index in the scenario + 1) * 1e6 +
// the camera's event id, so a restarted server that is sent the same reports again (durable
// data) republishes the same instances rather than new incidents.
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "common/status.h"
#include "planning/fusion/incident_merger.h"
#include "plugins/dds_bridge/dds.h"
#include "vision/event.h"
#include "vision/stereo_camera_model.h"
#include "world/plugin.h"

namespace vigil::dds {

struct ServerCamera {
  std::string id;
  vision::StereoCameraModel model;  // pose in the map frame
};

using MergeParams = planning::fusion::MergeParams;

// The uncertainty of a stereo camera's report at camera-frame point p (optical frame: x right,
// y down, z forward), in the map frame's (x, y): the bearing to within `pixel_std` pixels, the
// range from a disparity to within `disparity_std` pixels (sigma_Z = Z^2 sigma_d / (f B)), so a
// far report is sure of its direction and unsure of its distance.
Eigen::Matrix2d report_covariance(const vision::StereoCameraModel& camera, const vision::Point3& p,
                                  double pixel_std = 1.0, double disparity_std = 0.25);

// The server's logic without DDS: checks, the frame change into the map, then the pure merger
// and particle-filter fusion of planning/fusion/incident_merger.h.
class IncidentMerger {
 public:
  // `inside_map(x, y)` says whether a map-frame point is inside the building's map.
  IncidentMerger(std::vector<ServerCamera> cameras, MergeParams params, std::function<bool(double, double)> inside_map);

  struct Outcome {
    enum What { kNew, kCancelled, kMerged, kIgnored, kRejected } what = kIgnored;
    Incident incident;   // kNew, kCancelled: what to publish; kMerged: the incident it joined, fused
    std::string reason;  // kRejected, kIgnored: why
    bool moved = false;  // kMerged: the fused position moved: publish it again (same id)
  };
  // One camera-frame event (camera_position set, map_position ignored).
  Outcome add(const vision::Event& e);
  std::vector<Incident> incidents() const;
  const planning::fusion::IncidentMerger& core() const { return core_; }

 private:
  std::vector<ServerCamera> cameras_;
  planning::fusion::IncidentMerger core_;
};

// Publishes camera events (a camera node's side).
class CameraEventPublisher {
 public:
  static Result<std::unique_ptr<CameraEventPublisher>> create(const Participant& p, const TopicQos& qos = {});
  Status publish(const vision::Event& e);
  Writer& writer() { return *writer_; }

 private:
  std::unique_ptr<Writer> writer_;
};

// The server's DDS side: reads camera events, merges, publishes incidents.
class EventServer {
 public:
  static Result<std::unique_ptr<EventServer>> create(const Participant& p, IncidentMerger merger, const TopicQos& qos = {});

  struct Log {
    std::vector<Incident> published;   // new incidents and cancellations, in order
    std::vector<Incident> updated;     // incidents whose fused position moved (published again)
    std::vector<std::string> rejected; // malformed or impossible reports, with the reason
    std::vector<std::string> ignored;  // duplicates and merged reports
    int received = 0;                  // camera events taken (valid or not)
  };
  // Waits up to `timeout_s` for camera events, then handles every one available.
  Status poll(double timeout_s, Log* log);
  const IncidentMerger& merger() const { return merger_; }

 private:
  EventServer(IncidentMerger m) : merger_(std::move(m)) {}
  IncidentMerger merger_;
  std::unique_ptr<Reader> reader_;
  std::unique_ptr<Writer> writer_;
};

// An incident as a team robot's task: kind "incident" (or "cancel_incident"), its id, its
// map position as the goal and its kind ("left_bag", ...) as the label (plugins/team).
RobotTask incident_task(const Incident& in);

// Reads incidents (a robot's or a monitor's side).
class IncidentSubscriber {
 public:
  static Result<std::unique_ptr<IncidentSubscriber>> create(const Participant& p, const TopicQos& qos = {});
  // Waits up to `timeout_s`, then takes every incident available; malformed ones are reported
  // in `rejected` with the reason.
  Status poll(double timeout_s, std::vector<Incident>* out, std::vector<std::string>* rejected = nullptr);

 private:
  std::unique_ptr<Reader> reader_;
};

}  // namespace vigil::dds
