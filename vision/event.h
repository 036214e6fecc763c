// Events: the incidents the surveillance system exists to report (chapter 10.5, 10.6.1), as the
// activity rules emit them from tracks, as `vigil run` writes them (DIR/events.jsonl), as the DDS
// messages carry them, and as the chapter's camera PCs sent them to the video server: a string
// with the event's name and its 3D coordinates ("left bag 21.02 3.48 0.25").
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "common/status.h"

namespace vigil::vision {

enum class EventKind {
  kLeftBag,             // the owner moved more than D metres from their bag for T seconds
  kBagTaken,            // a person other than the owner moved away with a bag (theft)
  kExchange,            // a bag passed from its owner to another person, both present
  kUnauthorisedObject,  // a person handled an object they may not (the chapter's "allert")
};

// "left_bag", "bag_taken", "exchange", "unauthorised_object" (the ground truth's names).
std::string_view to_string(EventKind k);
std::optional<EventKind> parse_event_kind(std::string_view s);
// The chapter's names: "left bag", "bag taken", "exchange", "allert".
std::string_view chapter_name(EventKind k);

struct Point3 {
  double x = 0, y = 0, z = 0;
};

struct Event {
  uint64_t id = 0;            // unique per camera over a run (1, 2, ...)
  EventKind kind = EventKind::kLeftBag;
  bool cancelled = false;     // true: withdraws the earlier event with this id (owner took the bag back)
  int64_t stamp_ns = 0;       // time of the frame on which the rule fired
  std::string camera;         // the camera whose tracks raised it
  Point3 camera_position;     // m, the camera's optical frame (x right, y down, z forward)
  Point3 map_position;        // m, the building's map frame
  int object_track = -1;      // the object's track id (-1: none, e.g. a marked object not tracked)
  std::string object;         // the object's name when it is a marked one (see WatchedObject), else ""
  std::vector<int> people;    // track ids: left_bag: owner; bag_taken: taker; exchange: giver, receiver;
                              // unauthorised_object: the person handling it
  double confidence = 0;      // 0..1
};

// The chapter's string form: "<name> <x> <y> <z>" with the map-frame position in metres to the
// millimetre, e.g. "left bag 21.020 3.480 0.250". A cancellation is "cancel <name> <x> <y> <z>".
std::string format_event_string(const Event& e);
// Reads the string form back (kind, cancelled, map position; other fields stay default). Errors
// name `source` and the key at fault ("name" or "x"/"y"/"z").
Result<Event> parse_event_string(std::string_view text, const std::string& source = "");

// One JSON object per line (events.jsonl): every field above.
std::string format_event_json(const Event& e);
// Parses one line; errors name `file`, `line` and the key at fault.
Result<Event> parse_event_json(std::string_view text, const std::string& file = "", int line = 0);
// Reads a whole events.jsonl.
Result<std::vector<Event>> read_events_jsonl(const std::string& path);

}  // namespace vigil::vision
