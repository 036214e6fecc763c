// Tracks: what every tracker in Vigil emits (the plan-view tracker, the MSER tracker, the fast
// ground-truth sensor model), in the building's map frame, one record per track per camera tick.
// The event rules, the evaluation (vigil eval) and the DDS messages all consume this one type.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace vigil::vision {

enum class TrackClass { kUnknown, kPerson, kBag, kRobot };

// "unknown", "person", "bag", "robot".
std::string_view to_string(TrackClass c);
// The inverse of to_string; nullopt for anything else.
std::optional<TrackClass> parse_track_class(std::string_view s);

struct Track {
  int64_t stamp_ns = 0;       // time of the frame the track was updated on (simulated or capture time)
  std::string camera;         // id of the camera (or source) that produced it
  int id = 0;                 // track id, unique per camera over the run, never reused
  TrackClass cls = TrackClass::kUnknown;
  double x = 0, y = 0;        // m, map frame: centre of the footprint on the floor
  double vx = 0, vy = 0;      // m/s, map frame
  double height = 0;          // m, top of the object above the floor
  double width = 0;           // m, footprint extent (largest side)
  double confidence = 0;      // 0..1
  bool measured = true;       // false: not seen on this frame; position and size are the tracker's
                              // prediction (a track coasting after a miss, or held while occluded)
  bool top_cut = false;       // the object reaches above the camera's view here (the top of the
                              // image cuts it): `height` is a lower bound, and `cls` from it a guess
  int hand_on = 0;            // the id of a track (an object) this one's hand is seen on, this
                              // frame; 0: none, or the tracker does not see hands (Tracker::sees_hands)
};

}  // namespace vigil::vision
