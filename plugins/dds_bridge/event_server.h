// The video server of chapter 10.6.3, over DDS: camera nodes publish the events their activity
// rules raise, in their own camera frame (topic vigil_camera_events); the server checks each
// one, transforms it into the building's map frame with the camera's pose, merges the reports of
// one incident from several cameras, and publishes incidents to the robots (topic vigil_events).
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
#include "plugins/dds_bridge/dds.h"
#include "vision/event.h"
#include "vision/stereo_camera_model.h"

namespace vigil::dds {

struct ServerCamera {
  std::string id;
  vision::StereoCameraModel model;  // pose in the map frame
};

struct MergeParams {
  double merge_distance = 1.0;  // m: reports of one kind this close...
  double merge_time_s = 5.0;    // ...and this close in time are one incident
};

// The server's logic without DDS: checks, frame change, merging, cancellation.
class IncidentMerger {
 public:
  // `inside_map(x, y)` says whether a map-frame point is inside the building's map.
  IncidentMerger(std::vector<ServerCamera> cameras, MergeParams params, std::function<bool(double, double)> inside_map);

  struct Outcome {
    enum What { kNew, kCancelled, kMerged, kIgnored, kRejected } what = kIgnored;
    Incident incident;   // kNew, kCancelled: what to publish; kMerged: the incident it joined
    std::string reason;  // kRejected, kIgnored: why
  };
  // One camera-frame event (camera_position set, map_position ignored).
  Outcome add(const vision::Event& e);
  const std::vector<Incident>& incidents() const { return incidents_; }

 private:
  std::vector<ServerCamera> cameras_;
  MergeParams params_;
  std::function<bool(double, double)> inside_map_;
  std::vector<Incident> incidents_;
  std::map<std::pair<std::string, uint64_t>, size_t> report_to_incident_;
  std::map<std::pair<std::string, uint64_t>, bool> cancelled_reports_;
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
