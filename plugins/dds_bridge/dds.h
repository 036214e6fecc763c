// Vigil over Cyclone DDS (C API, idlc-generated types from vigil_msgs.idl): a domain with the
// shipped loopback configuration, typed writers and readers of the four topics, and the
// conversions between the messages and Vigil's own types.
//
// QoS (the same on writers and readers, so they match): RELIABLE, TRANSIENT_LOCAL durability,
// KEEP_LAST history of `depth` samples per instance and a writer-side durability history of the
// same depth, over partition "vigil.<session>". What that promises: while a writer lives, every
// sample it wrote reaches every matched reader, in order, resending lost packets; a reader that
// joins late (or a server restarted after a crash) receives, on matching, the last `depth`
// samples of each instance the writer still holds. Nothing survives the writer's own process:
// there is no persistent durability service. Sessions keep concurrent runs on one machine apart.
#pragma once

#include <dds/dds.h>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "common/status.h"
#include "vigil_msgs.h"
#include "vision/event.h"

namespace vigil::dds {

// The shipped Cyclone configuration: loopback only, no multicast, unicast discovery of the
// participants on 127.0.0.1 (plugins/dds_bridge/cyclonedds-loopback.xml holds the same text).
const std::string& loopback_config();
// A configuration file's text; errors name the file.
Result<std::string> read_config(const std::filesystem::path& path);

struct DomainOptions {
  uint32_t domain_id = 0;
  std::string config;        // Cyclone XML; empty = loopback_config()
  std::string session = "vigil";  // the partition is "vigil.<session>"
};

// A DDS domain (created once per process and id, with its configuration) and one participant.
class Participant {
 public:
  static Result<std::unique_ptr<Participant>> create(const DomainOptions& options = {});
  ~Participant();
  Participant(const Participant&) = delete;
  Participant& operator=(const Participant&) = delete;
  dds_entity_t handle() const { return participant_; }
  const DomainOptions& options() const { return options_; }

 private:
  Participant() = default;
  dds_entity_t participant_ = 0;
  DomainOptions options_;
};

struct TopicQos {
  int depth = 1000;  // samples kept per instance (history and durability)
};

enum class Topic { kCameraEvents, kMapEvents, kRobotState, kTaskAssignments, kTeam };
const char* topic_name(Topic t);  // "vigil_camera_events", ...

// A writer or reader of one topic. Untyped underneath; the typed helpers below convert.
class Endpoint {
 public:
  ~Endpoint();
  Endpoint(const Endpoint&) = delete;
  Endpoint& operator=(const Endpoint&) = delete;
  dds_entity_t handle() const { return entity_; }

 protected:
  Endpoint() = default;
  Status open(const Participant& p, Topic topic, bool writer, const TopicQos& qos);
  dds_entity_t topic_ = 0, entity_ = 0, publisher_or_subscriber_ = 0;
};

class Writer : public Endpoint {
 public:
  static Result<std::unique_ptr<Writer>> create(const Participant& p, Topic topic, const TopicQos& qos = {});
  // Writes one generated sample of the writer's topic type.
  Status write_raw(const void* sample);
  // Unregisters (and so disposes) the instance whose key fields `sample` holds: the writer and
  // the readers drop its history, a late joiner no longer receives it.
  Status unregister_raw(const void* sample);
  // Waits until at least `n` readers have matched (or the timeout passes); returns the number.
  int wait_for_readers(int n, double timeout_s);
};

class Reader : public Endpoint {
 public:
  ~Reader();
  static Result<std::unique_ptr<Reader>> create(const Participant& p, Topic topic, const TopicQos& qos = {});
  // Waits until data is available or the timeout passes; true when there is data.
  bool wait(double timeout_s);
  // Takes every available valid sample, calling `fn` with each (a pointer to the generated type).
  template <class Fn>
  Status take_each(Fn fn);

 private:
  dds_entity_t waitset_ = 0, condition_ = 0;  // made on the first wait()
  Status take_batch(void** samples, dds_sample_info_t* infos, int max, int* got);
  Status return_loan(void** samples, int got);
};

template <class Fn>
Status Reader::take_each(Fn fn) {
  constexpr int kBatch = 64;
  for (;;) {
    void* samples[kBatch] = {};
    dds_sample_info_t infos[kBatch];
    int got = 0;
    if (Status s = take_batch(samples, infos, kBatch, &got); !s) return s;
    for (int i = 0; i < got; ++i) {
      if (infos[i].valid_data) fn(samples[i], infos[i]);
    }
    if (Status s = return_loan(samples, got); !s) return s;
    if (got < kBatch) return Status::Ok();
  }
}

// ---- Conversions ----

// A camera event (kind, id, camera-frame position, tracks...) to its message; the strings point
// into `e`, which must outlive the message. `people` is filled from `people_buf`.
vigil_msgs_CameraEvent to_message(const vision::Event& e, std::vector<int32_t>* people_buf);
// The message to an event (map_position left zero), rejecting malformed content: an unknown
// kind, an empty camera, non-finite numbers, a confidence outside [0, 1]. The error's key names
// the field.
Result<vision::Event> from_message(const vigil_msgs_CameraEvent& m);

// An incident of the video server: an event in the map frame, merged over cameras.
struct Incident {
  uint64_t id = 0;
  vision::EventKind kind = vision::EventKind::kLeftBag;
  bool cancelled = false;
  int64_t stamp_ns = 0;
  vision::Point3 position;              // map frame
  std::vector<std::string> cameras;     // reporting cameras, first first
  std::vector<uint64_t> camera_event_ids;
  std::string object;
  double confidence = 0;
  std::vector<int> people;              // the first report's track ids (not sent: per camera)
  vision::Point3 camera_position;       // the first report's camera-frame position (not sent)
  // As an Event for events.jsonl: id = incident, camera = first camera, map position.
  vision::Event as_event() const;
};

// Owns the buffers a MapEvent message points into.
struct MapEventMessage {
  vigil_msgs_MapEvent msg{};
  std::vector<char*> camera_ptrs;
  std::vector<uint64_t> ids;
  std::string text;
};
void to_message(const Incident& in, MapEventMessage* out);
Result<Incident> from_message(const vigil_msgs_MapEvent& m);

}  // namespace vigil::dds
