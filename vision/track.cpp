#include "vision/track.h"

namespace vigil::vision {

std::string_view to_string(TrackClass c) {
  switch (c) {
    case TrackClass::kPerson: return "person";
    case TrackClass::kBag: return "bag";
    case TrackClass::kRobot: return "robot";
    case TrackClass::kUnknown: break;
  }
  return "unknown";
}

std::optional<TrackClass> parse_track_class(std::string_view s) {
  if (s == "unknown") return TrackClass::kUnknown;
  if (s == "person") return TrackClass::kPerson;
  if (s == "bag") return TrackClass::kBag;
  if (s == "robot") return TrackClass::kRobot;
  return std::nullopt;
}

}  // namespace vigil::vision
