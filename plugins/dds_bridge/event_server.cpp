#include "plugins/dds_bridge/event_server.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

namespace vigil::dds {

Eigen::Matrix2d report_covariance(const vision::StereoCameraModel& camera, const vision::Point3& p, double pixel_std,
                                  double disparity_std) {
  const double f = camera.intrinsics().fx;
  const double z = std::max(0.1, p.z);
  const double lat = z * pixel_std / f;
  const double rng = z * z * disparity_std / (f * std::max(1e-3, camera.baseline()));
  // Along the ray (not the optical axis): the point's direction carries the range error.
  const Eigen::Vector3d ray = Eigen::Vector3d(p.x, p.y, z).normalized();
  const Eigen::Matrix3d cov_o = lat * lat * (Eigen::Matrix3d::Identity() - ray * ray.transpose()) + rng * rng * ray * ray.transpose();
  const Eigen::Matrix3d R = camera.map_from_optical().linear();
  const Eigen::Matrix3d cov_m = R * cov_o * R.transpose();
  return cov_m.topLeftCorner<2, 2>();
}

namespace {

std::vector<std::string> ids_of(const std::vector<ServerCamera>& cams) {
  std::vector<std::string> ids;
  for (const auto& c : cams) ids.push_back(c.id);
  return ids;
}

Incident to_dds(const planning::fusion::Incident& f) {
  Incident in;
  in.id = f.id;
  in.kind = vision::parse_event_kind(f.kind).value_or(vision::EventKind::kLeftBag);
  in.cancelled = f.cancelled;
  in.stamp_ns = f.stamp_ns;
  in.position = {f.position.x, f.position.y, f.position.z};
  in.cameras = f.cameras;
  in.camera_event_ids = f.camera_event_ids;
  in.object = f.object;
  in.confidence = f.confidence;
  in.people = f.people;
  in.camera_position = {f.camera_position.x, f.camera_position.y, f.camera_position.z};
  return in;
}

}  // namespace

IncidentMerger::IncidentMerger(std::vector<ServerCamera> cameras, MergeParams params,
                               std::function<bool(double, double)> inside_map)
    : cameras_(std::move(cameras)), core_(ids_of(cameras_), params, std::move(inside_map)) {}

IncidentMerger::Outcome IncidentMerger::add(const vision::Event& e) {
  planning::fusion::Report r;
  r.camera = e.camera;
  r.id = e.id;
  r.kind = std::string(vision::to_string(e.kind));
  r.cancelled = e.cancelled;
  r.stamp_ns = e.stamp_ns;
  r.object = e.object;
  r.confidence = e.confidence;
  r.people = e.people;
  r.camera_position = {e.camera_position.x, e.camera_position.y, e.camera_position.z};
  const auto cam = std::find_if(cameras_.begin(), cameras_.end(), [&](const ServerCamera& c) { return c.id == e.camera; });
  if (cam != cameras_.end() && !e.cancelled) {
    const Eigen::Vector3d p =
        cam->model.map_from_optical() * Eigen::Vector3d(e.camera_position.x, e.camera_position.y, e.camera_position.z);
    r.position = {p.x(), p.y(), p.z()};
    r.covariance = report_covariance(cam->model, e.camera_position);
  }
  const auto o = core_.add(r);
  Outcome out;
  out.what = static_cast<Outcome::What>(o.what);
  out.incident = to_dds(o.incident);
  out.reason = o.reason;
  out.moved = o.moved;
  return out;
}

std::vector<Incident> IncidentMerger::incidents() const {
  std::vector<Incident> out;
  for (const auto& f : core_.incidents()) out.push_back(to_dds(f));
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
        if (o.moved) {
          // The belief moved: the incident again (same id and instance), at its fused place.
          MapEventMessage m;
          to_message(o.incident, &m);
          if (Status s = writer_->write_raw(&m.msg); !s) return s;
          log->updated.push_back(o.incident);
        }
        log->ignored.push_back(o.reason);
        break;
      case IncidentMerger::Outcome::kIgnored:
        log->ignored.push_back(o.reason);
        break;
    }
  }
  return Status::Ok();
}

RobotTask incident_task(const Incident& in) {
  RobotTask t;
  t.id = in.id;
  t.kind = in.cancelled ? "cancel_incident" : "incident";
  t.goal = {in.position.x, in.position.y};
  t.label = std::string(vision::to_string(in.kind));
  return t;
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
