#include "plugins/dds_bridge/event_server.h"

#include <algorithm>
#include <cmath>

namespace vigil::dds {

IncidentMerger::IncidentMerger(std::vector<ServerCamera> cameras, MergeParams params,
                               std::function<bool(double, double)> inside_map)
    : cameras_(std::move(cameras)), params_(params), inside_map_(std::move(inside_map)) {}

IncidentMerger::Outcome IncidentMerger::add(const vision::Event& e) {
  Outcome out;
  const auto cam = std::find_if(cameras_.begin(), cameras_.end(), [&](const ServerCamera& c) { return c.id == e.camera; });
  if (cam == cameras_.end()) {
    out.what = Outcome::kRejected;
    out.reason = "event " + std::to_string(e.id) + " from unknown camera '" + e.camera + "'";
    return out;
  }
  const auto key = std::make_pair(e.camera, e.id);
  const std::string who = "event " + std::to_string(e.id) + " of camera " + e.camera;

  if (e.cancelled) {
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
    // Withdrawn when every camera that reported it has withdrawn its report.
    bool all = true;
    for (size_t i = 0; i < in.cameras.size(); ++i) all = all && cancelled_reports_[{in.cameras[i], in.camera_event_ids[i]}];
    if (!all || in.cancelled) {
      out.what = Outcome::kIgnored;
      out.reason = who + ": cancelled; other cameras still report incident " + std::to_string(in.id);
      return out;
    }
    in.cancelled = true;
    in.stamp_ns = std::max(in.stamp_ns, e.stamp_ns);
    out.what = Outcome::kCancelled;
    out.incident = in;
    return out;
  }

  if (report_to_incident_.count(key)) {
    out.what = Outcome::kIgnored;
    out.reason = who + ": duplicate";
    return out;
  }
  const Eigen::Vector3d p =
      cam->model.map_from_optical() * Eigen::Vector3d(e.camera_position.x, e.camera_position.y, e.camera_position.z);
  if (!std::isfinite(p.x()) || !std::isfinite(p.y()) || !std::isfinite(p.z()) || !inside_map_(p.x(), p.y())) {
    out.what = Outcome::kRejected;
    char buf[160];
    std::snprintf(buf, sizeof buf, ": at (%.2f, %.2f, %.2f) in the map frame, outside the map", p.x(), p.y(), p.z());
    out.reason = who + buf;
    return out;
  }
  // Another camera's report of the same incident?
  for (size_t i = 0; i < incidents_.size(); ++i) {
    Incident& in = incidents_[i];
    if (in.cancelled || in.kind != e.kind) continue;
    if (std::find(in.cameras.begin(), in.cameras.end(), e.camera) != in.cameras.end()) continue;
    if (std::abs(e.stamp_ns - in.stamp_ns) * 1e-9 > params_.merge_time_s) continue;
    if (std::hypot(p.x() - in.position.x, p.y() - in.position.y) > params_.merge_distance) continue;
    in.cameras.push_back(e.camera);
    in.camera_event_ids.push_back(e.id);
    in.confidence = std::max(in.confidence, e.confidence);
    report_to_incident_[key] = i;
    out.what = Outcome::kMerged;
    out.incident = in;
    out.reason = who + ": merged into incident " + std::to_string(in.id);
    return out;
  }
  Incident in;
  in.id = static_cast<uint64_t>(cam - cameras_.begin() + 1) * 1000000ULL + e.id;
  in.kind = e.kind;
  in.stamp_ns = e.stamp_ns;
  in.position = {p.x(), p.y(), p.z()};
  in.cameras = {e.camera};
  in.camera_event_ids = {e.id};
  in.object = e.object;
  in.confidence = e.confidence;
  in.people = e.people;
  in.camera_position = e.camera_position;
  report_to_incident_[key] = incidents_.size();
  incidents_.push_back(in);
  out.what = Outcome::kNew;
  out.incident = in;
  return out;
}

Result<std::unique_ptr<CameraEventPublisher>> CameraEventPublisher::create(const Participant& p, const TopicQos& qos) {
  auto w = Writer::create(p, Topic::kCameraEvents, qos);
  if (!w) return w.error();
  std::unique_ptr<CameraEventPublisher> pub(new CameraEventPublisher());
  pub->writer_ = std::move(*w);
  return pub;
}

Status CameraEventPublisher::publish(const vision::Event& e) {
  std::vector<int32_t> people;
  const vigil_msgs_CameraEvent m = to_message(e, &people);
  return writer_->write_raw(&m);
}

Result<std::unique_ptr<EventServer>> EventServer::create(const Participant& p, IncidentMerger merger, const TopicQos& qos) {
  std::unique_ptr<EventServer> s(new EventServer(std::move(merger)));
  auto r = Reader::create(p, Topic::kCameraEvents, qos);
  if (!r) return r.error();
  s->reader_ = std::move(*r);
  auto w = Writer::create(p, Topic::kMapEvents, qos);
  if (!w) return w.error();
  s->writer_ = std::move(*w);
  return s;
}

Status EventServer::poll(double timeout_s, Log* log) {
  if (timeout_s > 0) reader_->wait(timeout_s);
  std::vector<Result<vision::Event>> got;
  if (Status s = reader_->take_each([&](const void* sample, const dds_sample_info_t&) {
        got.push_back(from_message(*static_cast<const vigil_msgs_CameraEvent*>(sample)));
      });
      !s)
    return s;
  for (auto& r : got) {
    ++log->received;
    if (!r) {
      log->rejected.push_back("malformed camera event: " + r.error().key + ": " + r.error().message);
      continue;
    }
    const IncidentMerger::Outcome o = merger_.add(*r);
    switch (o.what) {
      case IncidentMerger::Outcome::kNew:
      case IncidentMerger::Outcome::kCancelled: {
        MapEventMessage m;
        to_message(o.incident, &m);
        if (Status s = writer_->write_raw(&m.msg); !s) return s;
        log->published.push_back(o.incident);
        break;
      }
      case IncidentMerger::Outcome::kRejected:
        log->rejected.push_back(o.reason);
        break;
      case IncidentMerger::Outcome::kMerged:
      case IncidentMerger::Outcome::kIgnored:
        log->ignored.push_back(o.reason);
        break;
    }
  }
  return Status::Ok();
}

Result<std::unique_ptr<IncidentSubscriber>> IncidentSubscriber::create(const Participant& p, const TopicQos& qos) {
  auto r = Reader::create(p, Topic::kMapEvents, qos);
  if (!r) return r.error();
  std::unique_ptr<IncidentSubscriber> s(new IncidentSubscriber());
  s->reader_ = std::move(*r);
  return s;
}

Status IncidentSubscriber::poll(double timeout_s, std::vector<Incident>* out, std::vector<std::string>* rejected) {
  if (timeout_s > 0) reader_->wait(timeout_s);
  return reader_->take_each([&](const void* sample, const dds_sample_info_t&) {
    auto in = from_message(*static_cast<const vigil_msgs_MapEvent*>(sample));
    if (in) {
      out->push_back(std::move(*in));
    } else if (rejected) {
      rejected->push_back("malformed incident: " + in.error().key + ": " + in.error().message);
    }
  });
}

}  // namespace vigil::dds
