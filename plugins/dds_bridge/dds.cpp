#include "plugins/dds_bridge/dds.h"

#include <chrono>
#include <cstring>
#include <cmath>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>
#include <thread>

namespace vigil::dds {

namespace {

std::string dds_error(const std::string& what, dds_return_t rc) {
  return what + " failed: " + dds_strretcode(rc);
}

// One Cyclone domain per id and process, shared by the participants made here.
struct DomainEntry {
  dds_entity_t domain = 0;
  std::string config;
  int users = 0;
};
std::mutex g_domains_mutex;
std::map<uint32_t, DomainEntry>& domains() {
  static std::map<uint32_t, DomainEntry> d;
  return d;
}

const dds_topic_descriptor_t* descriptor(Topic t) {
  switch (t) {
    case Topic::kCameraEvents: return &vigil_msgs_CameraEvent_desc;
    case Topic::kMapEvents: return &vigil_msgs_MapEvent_desc;
    case Topic::kRobotState: return &vigil_msgs_RobotState_desc;
    case Topic::kTaskAssignments: return &vigil_msgs_TaskAssignment_desc;
    case Topic::kTeam: return &vigil_msgs_TeamMessage_desc;
  }
  return nullptr;
}

dds_qos_t* make_qos(const TopicQos& q) {
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_SECS(10));
  dds_qset_durability(qos, DDS_DURABILITY_TRANSIENT_LOCAL);
  dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, q.depth);
  dds_qset_durability_service(qos, 0, DDS_HISTORY_KEEP_LAST, q.depth, DDS_LENGTH_UNLIMITED, DDS_LENGTH_UNLIMITED,
                              DDS_LENGTH_UNLIMITED);
  return qos;
}

bool finite(const vigil_msgs_Point3& p) { return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z); }

// The kind as its raw 32 bits: a malformed sample may hold any value, and loading a value
// outside the enumeration as the enum type is undefined behaviour (found by UBSan).
int32_t raw_kind(const vigil_msgs_EventKind& k) {
  int32_t v = 0;
  std::memcpy(&v, &k, sizeof v);
  return v;
}

std::optional<vision::EventKind> kind_from(int32_t k) {
  switch (k) {
    case vigil_msgs_LEFT_BAG: return vision::EventKind::kLeftBag;
    case vigil_msgs_BAG_TAKEN: return vision::EventKind::kBagTaken;
    case vigil_msgs_EXCHANGE: return vision::EventKind::kExchange;
    case vigil_msgs_UNAUTHORISED_OBJECT: return vision::EventKind::kUnauthorisedObject;
    default: return std::nullopt;
  }
}

vigil_msgs_EventKind kind_to(vision::EventKind k) {
  switch (k) {
    case vision::EventKind::kLeftBag: return vigil_msgs_LEFT_BAG;
    case vision::EventKind::kBagTaken: return vigil_msgs_BAG_TAKEN;
    case vision::EventKind::kExchange: return vigil_msgs_EXCHANGE;
    case vision::EventKind::kUnauthorisedObject: return vigil_msgs_UNAUTHORISED_OBJECT;
  }
  return vigil_msgs_LEFT_BAG;
}

}  // namespace

const std::string& loopback_config() {
  static const std::string cfg =
      "<CycloneDDS><Domain id=\"any\">"
      "<General><Interfaces><NetworkInterface address=\"127.0.0.1\"/></Interfaces>"
      "<AllowMulticast>false</AllowMulticast></General>"
      "<Discovery><ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>40</MaxAutoParticipantIndex>"
      "<Peers><Peer address=\"127.0.0.1\"/></Peers></Discovery>"
      "</Domain></CycloneDDS>";
  return cfg;
}

Result<std::string> read_config(const std::filesystem::path& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) return bad_input(path.string(), 0, "", "cannot open the Cyclone DDS configuration");
  std::stringstream ss;
  ss << f.rdbuf();
  std::string text = ss.str();
  if (text.find("<CycloneDDS") == std::string::npos)
    return bad_input(path.string(), 1, "", "not a Cyclone DDS configuration (no <CycloneDDS> element)");
  return text;
}

const char* topic_name(Topic t) {
  switch (t) {
    case Topic::kCameraEvents: return "vigil_camera_events";
    case Topic::kMapEvents: return "vigil_events";
    case Topic::kRobotState: return "vigil_robot_state";
    case Topic::kTaskAssignments: return "vigil_task_assignments";
    case Topic::kTeam: return "vigil_team";
  }
  return "?";
}

Result<std::unique_ptr<Participant>> Participant::create(const DomainOptions& options) {
  if (options.session.empty()) return bad_input("", 0, "session", "must not be empty");
  if (options.domain_id > 232) return bad_input("", 0, "domain", "DDS domain ids go from 0 to 232");
  std::unique_ptr<Participant> p(new Participant());
  p->options_ = options;
  if (p->options_.config.empty()) p->options_.config = loopback_config();
  {
    std::lock_guard<std::mutex> lock(g_domains_mutex);
    DomainEntry& d = domains()[options.domain_id];
    if (d.users == 0) {
      const dds_entity_t dom = dds_create_domain(options.domain_id, p->options_.config.c_str());
      if (dom < 0) {
        domains().erase(options.domain_id);
        return bad_input("", 0, "config", dds_error("creating DDS domain " + std::to_string(options.domain_id) + " with the given configuration", dom));
      }
      d.domain = dom;
      d.config = p->options_.config;
    } else if (d.config != p->options_.config) {
      return bad_input("", 0, "config", "DDS domain " + std::to_string(options.domain_id) +
                                            " is already open in this process with another configuration");
    }
    ++d.users;
  }
  p->participant_ = dds_create_participant(options.domain_id, nullptr, nullptr);
  if (p->participant_ < 0) {
    const dds_return_t rc = p->participant_;
    p->participant_ = 0;
    return internal_error(dds_error("dds_create_participant", rc));
  }
  return p;
}

Participant::~Participant() {
  if (participant_ > 0) dds_delete(participant_);
  std::lock_guard<std::mutex> lock(g_domains_mutex);
  auto it = domains().find(options_.domain_id);
  if (it != domains().end() && --it->second.users <= 0) {
    dds_delete(it->second.domain);
    domains().erase(it);
  }
}

Endpoint::~Endpoint() {
  // Deleting the publisher or subscriber deletes the writer or reader; the topic is the
  // participant's and goes with it.
  if (publisher_or_subscriber_ > 0) dds_delete(publisher_or_subscriber_);
}

Status Endpoint::open(const Participant& p, Topic topic, bool writer, const TopicQos& q) {
  if (q.depth < 1) return bad_input("", 0, "depth", "the history depth must be at least 1");
  dds_qos_t* qos = make_qos(q);
  topic_ = dds_create_topic(p.handle(), descriptor(topic), topic_name(topic), qos, nullptr);
  if (topic_ < 0) {
    dds_delete_qos(qos);
    return internal_error(dds_error("dds_create_topic", topic_));
  }
  dds_qos_t* group = dds_create_qos();
  const std::string partition = "vigil." + p.options().session;
  dds_qset_partition1(group, partition.c_str());
  publisher_or_subscriber_ = writer ? dds_create_publisher(p.handle(), group, nullptr)
                                    : dds_create_subscriber(p.handle(), group, nullptr);
  dds_delete_qos(group);
  if (publisher_or_subscriber_ < 0) {
    dds_delete_qos(qos);
    const dds_return_t rc = publisher_or_subscriber_;
    publisher_or_subscriber_ = 0;
    return internal_error(dds_error(writer ? "dds_create_publisher" : "dds_create_subscriber", rc));
  }
  entity_ = writer ? dds_create_writer(publisher_or_subscriber_, topic_, qos, nullptr)
                   : dds_create_reader(publisher_or_subscriber_, topic_, qos, nullptr);
  dds_delete_qos(qos);
  if (entity_ < 0) return internal_error(dds_error(writer ? "dds_create_writer" : "dds_create_reader", entity_));
  return Status::Ok();
}

Result<std::unique_ptr<Writer>> Writer::create(const Participant& p, Topic topic, const TopicQos& qos) {
  std::unique_ptr<Writer> w(new Writer());
  if (Status s = w->open(p, topic, true, qos); !s) return s.error();
  return w;
}

Status Writer::write_raw(const void* sample) {
  const dds_return_t rc = dds_write(entity_, sample);
  if (rc < 0) return internal_error(dds_error("dds_write", rc));
  return Status::Ok();
}

Status Writer::unregister_raw(const void* sample) {
  const dds_return_t rc = dds_unregister_instance(entity_, sample);
  if (rc < 0) return internal_error(dds_error("dds_unregister_instance", rc));
  return Status::Ok();
}

int Writer::wait_for_readers(int n, double timeout_s) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  for (;;) {
    dds_publication_matched_status_t st{};
    if (dds_get_publication_matched_status(entity_, &st) < 0) return 0;
    if (static_cast<int>(st.current_count) >= n || std::chrono::steady_clock::now() >= end)
      return static_cast<int>(st.current_count);
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
}

Result<std::unique_ptr<Reader>> Reader::create(const Participant& p, Topic topic, const TopicQos& qos) {
  std::unique_ptr<Reader> r(new Reader());
  if (Status s = r->open(p, topic, false, qos); !s) return s.error();
  return r;
}

Reader::~Reader() {
  if (waitset_ > 0) dds_delete(waitset_);  // the read condition goes with the reader
}

bool Reader::wait(double timeout_s) {
  if (waitset_ <= 0) {
    waitset_ = dds_create_waitset(dds_get_participant(entity_));
    if (waitset_ < 0) {
      waitset_ = 0;
      return false;
    }
    condition_ = dds_create_readcondition(entity_, DDS_ANY_STATE);
    if (condition_ < 0 || dds_waitset_attach(waitset_, condition_, 0) < 0) {
      dds_delete(waitset_);
      waitset_ = 0;
      return false;
    }
  }
  const dds_return_t n = dds_waitset_wait(waitset_, nullptr, 0, static_cast<dds_duration_t>(timeout_s * 1e9));
  return n > 0;
}

Status Reader::take_batch(void** samples, dds_sample_info_t* infos, int max, int* got) {
  const dds_return_t n = dds_take(entity_, samples, infos, static_cast<size_t>(max), static_cast<uint32_t>(max));
  if (n < 0) return internal_error(dds_error("dds_take", n));
  *got = n;
  return Status::Ok();
}

Status Reader::return_loan(void** samples, int got) {
  if (got <= 0) return Status::Ok();
  const dds_return_t rc = dds_return_loan(entity_, samples, got);
  if (rc < 0) return internal_error(dds_error("dds_return_loan", rc));
  return Status::Ok();
}

// ---- Conversions ----

vigil_msgs_CameraEvent to_message(const vision::Event& e, std::vector<int32_t>* people_buf) {
  vigil_msgs_CameraEvent m{};
  m.camera = const_cast<char*>(e.camera.c_str());
  m.id = e.id;
  m.kind = kind_to(e.kind);
  m.cancelled = e.cancelled;
  m.stamp_ns = e.stamp_ns;
  m.position = {e.camera_position.x, e.camera_position.y, e.camera_position.z};
  m.object_track = e.object_track;
  m.object = const_cast<char*>(e.object.c_str());
  people_buf->assign(e.people.begin(), e.people.end());
  m.people._length = m.people._maximum = static_cast<uint32_t>(people_buf->size());
  m.people._buffer = people_buf->empty() ? nullptr : people_buf->data();
  m.people._release = false;
  m.confidence = e.confidence;
  return m;
}

Result<vision::Event> from_message(const vigil_msgs_CameraEvent& m) {
  vision::Event e;
  if (!m.camera || !*m.camera) return bad_input("", 0, "camera", "empty camera id");
  e.camera = m.camera;
  const auto kind = kind_from(raw_kind(m.kind));
  if (!kind) return bad_input("", 0, "kind", "unknown event kind " + std::to_string(raw_kind(m.kind)));
  e.kind = *kind;
  e.id = m.id;
  if (e.id == 0) return bad_input("", 0, "id", "event ids start at 1");
  e.cancelled = m.cancelled;
  e.stamp_ns = m.stamp_ns;
  if (e.stamp_ns < 0) return bad_input("", 0, "stamp_ns", "negative time");
  if (!finite(m.position)) return bad_input("", 0, "position", "non-finite coordinates");
  e.camera_position = {m.position.x, m.position.y, m.position.z};
  e.object_track = m.object_track;
  e.object = m.object ? m.object : "";
  for (uint32_t i = 0; i < m.people._length; ++i) e.people.push_back(m.people._buffer[i]);
  if (!(m.confidence >= 0 && m.confidence <= 1)) return bad_input("", 0, "confidence", "must be from 0 to 1");
  e.confidence = m.confidence;
  return e;
}

vision::Event Incident::as_event() const {
  vision::Event e;
  e.id = id;
  e.kind = kind;
  e.cancelled = cancelled;
  e.stamp_ns = stamp_ns;
  e.camera = cameras.empty() ? "" : cameras.front();
  e.map_position = position;
  e.camera_position = camera_position;
  e.object = object;
  e.people = people;
  e.confidence = confidence;
  return e;
}

void to_message(const Incident& in, MapEventMessage* out) {
  out->camera_ptrs.clear();
  for (const auto& c : in.cameras) out->camera_ptrs.push_back(const_cast<char*>(c.c_str()));
  out->ids = in.camera_event_ids;
  out->text = vision::format_event_string(in.as_event());
  vigil_msgs_MapEvent& m = out->msg;
  m = {};
  m.incident = in.id;
  m.kind = kind_to(in.kind);
  m.cancelled = in.cancelled;
  m.stamp_ns = in.stamp_ns;
  m.position = {in.position.x, in.position.y, in.position.z};
  m.cameras._length = m.cameras._maximum = static_cast<uint32_t>(out->camera_ptrs.size());
  m.cameras._buffer = out->camera_ptrs.empty() ? nullptr : out->camera_ptrs.data();
  m.cameras._release = false;
  m.camera_event_ids._length = m.camera_event_ids._maximum = static_cast<uint32_t>(out->ids.size());
  m.camera_event_ids._buffer = out->ids.empty() ? nullptr : out->ids.data();
  m.camera_event_ids._release = false;
  m.object = const_cast<char*>(in.object.c_str());
  m.confidence = in.confidence;
  m.text = const_cast<char*>(out->text.c_str());
}

Result<Incident> from_message(const vigil_msgs_MapEvent& m) {
  Incident in;
  in.id = m.incident;
  if (in.id == 0) return bad_input("", 0, "incident", "incident ids start at 1");
  const auto kind = kind_from(raw_kind(m.kind));
  if (!kind) return bad_input("", 0, "kind", "unknown event kind " + std::to_string(raw_kind(m.kind)));
  in.kind = *kind;
  in.cancelled = m.cancelled;
  in.stamp_ns = m.stamp_ns;
  if (!finite(m.position)) return bad_input("", 0, "position", "non-finite coordinates");
  in.position = {m.position.x, m.position.y, m.position.z};
  for (uint32_t i = 0; i < m.cameras._length; ++i) in.cameras.push_back(m.cameras._buffer[i] ? m.cameras._buffer[i] : "");
  for (uint32_t i = 0; i < m.camera_event_ids._length; ++i) in.camera_event_ids.push_back(m.camera_event_ids._buffer[i]);
  in.object = m.object ? m.object : "";
  if (!(m.confidence >= 0 && m.confidence <= 1)) return bad_input("", 0, "confidence", "must be from 0 to 1");
  in.confidence = m.confidence;
  return in;
}

}  // namespace vigil::dds
