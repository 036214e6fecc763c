// Events over real Cyclone DDS on loopback: the video server's merging logic (frame change,
// several cameras, duplicates, cancellation, checks), and publishers, the server and subscribers
// talking through DDS in this process: durable data for late subscribers, malformed messages
// rejected with a reason, sessions keeping runs apart.
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <thread>

#include "plugins/dds_bridge/dds.h"
#include "plugins/dds_bridge/event_server.h"
#include "vision/event.h"

namespace vigil::dds {
namespace {

using vision::Event;
using vision::EventKind;

vision::StereoCameraModel camera_at(double x, double y, double z, double yaw_deg, double pitch_deg) {
  vision::CameraPose pose;
  pose.position = {x, y, z};
  pose.yaw = yaw_deg * M_PI / 180;
  pose.pitch = pitch_deg * M_PI / 180;
  return vision::StereoCameraModel(vision::Intrinsics::from_hfov(640, 480, M_PI / 3), 0.09, pose);
}

std::vector<ServerCamera> two_cameras() {
  return {{"cam_a", camera_at(27, 3.9, 2.5, 180, 15)}, {"cam_b", camera_at(14, 2.5, 2.5, 0, 15)}};
}

bool inside(double x, double y) { return x >= 0 && x <= 45 && y >= 0 && y <= 30; }

// The event camera `cam` would report for a map-frame point.
Event seen_by(const ServerCamera& cam, uint64_t id, EventKind kind, double x, double y, double z, int64_t t_ns) {
  const Eigen::Vector3d q = cam.model.optical_from_map() * Eigen::Vector3d(x, y, z);
  Event e;
  e.id = id;
  e.kind = kind;
  e.camera = cam.id;
  e.stamp_ns = t_ns;
  e.camera_position = {q.x(), q.y(), q.z()};
  e.confidence = 0.8;
  e.people = {4};
  return e;
}

TEST(IncidentMerger, TransformsIntoTheMapFrameAndMergesCameras) {
  const auto cams = two_cameras();
  IncidentMerger m(cams, {}, inside);
  auto o = m.add(seen_by(cams[0], 1, EventKind::kLeftBag, 21.0, 2.7, 0.2, 20'000'000'000));
  ASSERT_EQ(o.what, IncidentMerger::Outcome::kNew) << o.reason;
  EXPECT_NEAR(o.incident.position.x, 21.0, 1e-9);
  EXPECT_NEAR(o.incident.position.y, 2.7, 1e-9);
  EXPECT_NEAR(o.incident.position.z, 0.2, 1e-9);
  EXPECT_EQ(o.incident.id, 1000001u);  // first camera, event 1
  // The other camera sees the same bag 0.3 m off, a second later: one incident.
  o = m.add(seen_by(cams[1], 5, EventKind::kLeftBag, 21.2, 2.9, 0.2, 21'000'000'000));
  ASSERT_EQ(o.what, IncidentMerger::Outcome::kMerged) << o.reason;
  EXPECT_EQ(o.incident.cameras, (std::vector<std::string>{"cam_a", "cam_b"}));
  EXPECT_EQ(o.incident.camera_event_ids, (std::vector<uint64_t>{1, 5}));
  // A different kind at the same place, or the same kind 3 m away, is another incident.
  EXPECT_EQ(m.add(seen_by(cams[1], 6, EventKind::kBagTaken, 21.2, 2.9, 0.2, 21'500'000'000)).what, IncidentMerger::Outcome::kNew);
  EXPECT_EQ(m.add(seen_by(cams[1], 7, EventKind::kLeftBag, 24.2, 2.9, 0.2, 21'500'000'000)).what, IncidentMerger::Outcome::kNew);
  // The same report again (a restarted writer's durable data) changes nothing.
  o = m.add(seen_by(cams[0], 1, EventKind::kLeftBag, 21.0, 2.7, 0.2, 20'000'000'000));
  EXPECT_EQ(o.what, IncidentMerger::Outcome::kIgnored);
  EXPECT_NE(o.reason.find("duplicate"), std::string::npos);
  EXPECT_EQ(m.incidents().size(), 3u);
}

TEST(IncidentMerger, CancelledOnlyWhenEveryReportingCameraCancels) {
  const auto cams = two_cameras();
  IncidentMerger m(cams, {}, inside);
  m.add(seen_by(cams[0], 1, EventKind::kLeftBag, 21.0, 2.7, 0.2, 20'000'000'000));
  m.add(seen_by(cams[1], 2, EventKind::kLeftBag, 21.1, 2.7, 0.2, 20'100'000'000));
  Event c = seen_by(cams[0], 1, EventKind::kLeftBag, 21.0, 2.7, 0.2, 30'000'000'000);
  c.cancelled = true;
  EXPECT_EQ(m.add(c).what, IncidentMerger::Outcome::kIgnored);
  Event c2 = seen_by(cams[1], 2, EventKind::kLeftBag, 21.1, 2.7, 0.2, 30'100'000'000);
  c2.cancelled = true;
  const auto o = m.add(c2);
  ASSERT_EQ(o.what, IncidentMerger::Outcome::kCancelled);
  EXPECT_EQ(o.incident.id, 1000001u);
  EXPECT_TRUE(o.incident.cancelled);
  EXPECT_EQ(m.add(c2).what, IncidentMerger::Outcome::kIgnored);
  Event stray = c2;
  stray.id = 99;
  EXPECT_EQ(m.add(stray).what, IncidentMerger::Outcome::kIgnored);
}

TEST(IncidentMerger, UnknownCamerasAndPlacesOutsideTheMapAreRejected) {
  const auto cams = two_cameras();
  IncidentMerger m(cams, {}, inside);
  Event e = seen_by(cams[0], 1, EventKind::kLeftBag, 21.0, 2.7, 0.2, 0);
  e.camera = "cam_x";
  auto o = m.add(e);
  EXPECT_EQ(o.what, IncidentMerger::Outcome::kRejected);
  EXPECT_NE(o.reason.find("unknown camera 'cam_x'"), std::string::npos) << o.reason;
  o = m.add(seen_by(cams[0], 2, EventKind::kLeftBag, 60.0, 2.7, 0.2, 0));
  EXPECT_EQ(o.what, IncidentMerger::Outcome::kRejected);
  EXPECT_NE(o.reason.find("outside the map"), std::string::npos) << o.reason;
  EXPECT_TRUE(m.incidents().empty());
}

TEST(DdsMessages, ConversionsRoundTripAndRejectMalformedFields) {
  Event e;
  e.id = 3;
  e.kind = EventKind::kExchange;
  e.camera = "cam_a";
  e.stamp_ns = 123;
  e.camera_position = {0.5, 1.0, 6.0};
  e.object_track = 9;
  e.people = {1, 2};
  e.confidence = 0.7;
  std::vector<int32_t> buf;
  vigil_msgs_CameraEvent m = to_message(e, &buf);
  auto back = from_message(m);
  ASSERT_TRUE(back.ok()) << back.error().str();
  EXPECT_EQ(vision::format_event_json(*back), vision::format_event_json(e));
  vigil_msgs_CameraEvent bad = m;
  bad.kind = static_cast<vigil_msgs_EventKind>(17);
  EXPECT_EQ(from_message(bad).error().key, "kind");
  bad = m;
  bad.position.y = std::nan("");
  EXPECT_EQ(from_message(bad).error().key, "position");
  bad = m;
  bad.camera = const_cast<char*>("");
  EXPECT_EQ(from_message(bad).error().key, "camera");
  bad = m;
  bad.confidence = 1.5;
  EXPECT_EQ(from_message(bad).error().key, "confidence");
  bad = m;
  bad.id = 0;
  EXPECT_EQ(from_message(bad).error().key, "id");

  Incident in;
  in.id = 1000003;
  in.kind = EventKind::kLeftBag;
  in.position = {21.02, 3.48, 0.25};
  in.cameras = {"cam_a", "cam_b"};
  in.camera_event_ids = {3, 8};
  in.confidence = 0.9;
  MapEventMessage mm;
  to_message(in, &mm);
  EXPECT_STREQ(mm.msg.text, "left bag 21.020 3.480 0.250");
  auto inb = from_message(mm.msg);
  ASSERT_TRUE(inb.ok());
  EXPECT_EQ(inb->cameras, in.cameras);
  EXPECT_EQ(inb->camera_event_ids, in.camera_event_ids);
  EXPECT_DOUBLE_EQ(inb->position.x, 21.02);
}

std::string unique_session(const char* name) { return std::string(name) + "-" + std::to_string(getpid()); }

TEST(DdsLoopback, PublisherServerSubscriberWithLateJoiner) {
  DomainOptions dom;
  dom.session = unique_session("pss");
  auto cam_p = Participant::create(dom);
  ASSERT_TRUE(cam_p.ok()) << cam_p.error().str();
  auto srv_p = Participant::create(dom);
  ASSERT_TRUE(srv_p.ok()) << srv_p.error().str();
  const auto cams = two_cameras();
  auto pub = CameraEventPublisher::create(**cam_p);
  ASSERT_TRUE(pub.ok()) << pub.error().str();
  auto server = EventServer::create(**srv_p, IncidentMerger(cams, {}, inside));
  ASSERT_TRUE(server.ok()) << server.error().str();
  ASSERT_EQ((*pub)->writer().wait_for_readers(1, 10.0), 1);

  ASSERT_TRUE((*pub)->publish(seen_by(cams[0], 1, EventKind::kLeftBag, 21.0, 2.7, 0.2, 20'000'000'000)).ok());
  ASSERT_TRUE((*pub)->publish(seen_by(cams[0], 2, EventKind::kBagTaken, 21.0, 2.7, 0.2, 30'000'000'000)).ok());
  // A malformed report, written raw: a NaN coordinate. (Cyclone itself refuses to write an
  // out-of-range enum, so a bad kind cannot reach the wire from the C API; not tried here: its
  // refusal leaks the serialisation buffer, found by LeakSanitizer, docs/RELIABILITY.md. The
  // server's check of a bad kind is fuzzed through the dds_messages entry.)
  std::vector<int32_t> buf;
  Event bad_event = seen_by(cams[0], 3, EventKind::kLeftBag, 21.0, 2.7, 0.2, 31'000'000'000);
  vigil_msgs_CameraEvent bad = to_message(bad_event, &buf);
  bad.position.x = std::nan("");
  ASSERT_TRUE((*pub)->writer().write_raw(&bad).ok());
  // And one outside the map.
  ASSERT_TRUE((*pub)->publish(seen_by(cams[0], 4, EventKind::kLeftBag, 80.0, 2.7, 0.2, 32'000'000'000)).ok());

  EventServer::Log log;
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (log.received < 4 && std::chrono::steady_clock::now() < end) {
    const Status s = (*server)->poll(0.5, &log);
    ASSERT_TRUE(s.ok()) << s.error().str();
  }
  ASSERT_EQ(log.received, 4);
  ASSERT_EQ(log.published.size(), 2u);
  EXPECT_EQ(log.published[0].kind, EventKind::kLeftBag);
  EXPECT_NEAR(log.published[0].position.x, 21.0, 1e-9);
  ASSERT_EQ(log.rejected.size(), 2u);
  EXPECT_NE(log.rejected[0].find("position"), std::string::npos) << log.rejected[0];
  EXPECT_NE(log.rejected[1].find("outside the map"), std::string::npos) << log.rejected[1];

  // A subscriber that joins after the server published still gets both incidents (durable).
  auto robot_p = Participant::create(dom);
  ASSERT_TRUE(robot_p.ok());
  auto sub = IncidentSubscriber::create(**robot_p);
  ASSERT_TRUE(sub.ok()) << sub.error().str();
  std::vector<Incident> got;
  const auto end2 = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (got.size() < 2 && std::chrono::steady_clock::now() < end2) ASSERT_TRUE((*sub)->poll(0.5, &got).ok());
  ASSERT_EQ(got.size(), 2u);
  EXPECT_EQ(got[0].id, 1000001u);
  EXPECT_EQ(got[1].kind, EventKind::kBagTaken);
  EXPECT_EQ(got[0].cameras, std::vector<std::string>{"cam_a"});

  // Another session on the same domain sees none of it.
  DomainOptions other = dom;
  other.session = unique_session("other");
  auto other_p = Participant::create(other);
  ASSERT_TRUE(other_p.ok());
  auto other_sub = IncidentSubscriber::create(**other_p);
  ASSERT_TRUE(other_sub.ok());
  std::vector<Incident> none;
  ASSERT_TRUE((*other_sub)->poll(1.0, &none).ok());
  EXPECT_TRUE(none.empty());
}

TEST(DdsLoopback, BadOptionsAreErrors) {
  DomainOptions d;
  d.session = "";
  EXPECT_EQ(Participant::create(d).error().key, "session");
  d.session = "x";
  d.domain_id = 500;
  EXPECT_EQ(Participant::create(d).error().key, "domain");
  d.domain_id = 3;
  d.config = "<CycloneDDS><Domain><General><NoSuchSetting>1</NoSuchSetting></General></Domain></CycloneDDS>";
  auto p = Participant::create(d);
  ASSERT_FALSE(p.ok());
  EXPECT_EQ(p.error().key, "config");
  EXPECT_FALSE(read_config("/nonexistent/cyclone.xml").ok());
}

}  // namespace
}  // namespace vigil::dds
