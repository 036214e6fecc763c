// One interface for Vigil's camera systems (the stereo plan-view tracker of section 10.4, the
// colour MSER system of 10.3): frames in, map-frame tracks out, reset, and an annotated picture.
// The vision sensor of plugins/vision_sensors wraps any Tracker on a scenario camera; `vigil
// track` runs one on recorded frames. A tracker sees only what its camera gives it: the frames
// and the camera's calibration, never the world.
#pragma once

#include <string_view>
#include <vector>

#include <opencv2/core.hpp>

#include "common/occupancy_grid.h"
#include "common/status.h"
#include "vision/frame_source.h"
#include "vision/track.h"

namespace vigil::vision {

// Each cell's distance (m) from the nearest cell of `map` that is not free (walls, furniture,
// unknown): CV_32F, row cy the grid's row cy (smallest y first); empty for an empty map. What a
// tracker given the building's map asks of a place: is it clear of everything the map holds?
cv::Mat map_clearance(const OccupancyGrid& map);

class Tracker {
 public:
  virtual ~Tracker() = default;
  // The system's name, as a camera's `plugin:` names it ("planview", "mser").
  virtual std::string_view name() const = 0;
  // True when process() needs frame.depth (a stereo system); false when the left image is enough.
  virtual bool needs_depth() const = 0;
  // True when the tracker reports where people's hands are (Track::hand_on): the activity
  // rules then judge handling by the hand seen on the object rather than by distance alone.
  virtual bool sees_hands() const { return false; }
  // Where this frame's depth is needed (CV_8UC1 of the frame's size, nonzero = needed), from its
  // left image, before process() is given the same frame; empty = everywhere (the default). A
  // stereo source may then match only there and say so in frame.depth_measured.
  virtual cv::Mat depth_wanted(const StereoFrame&) { return {}; }
  // The building as its map holds it (walls and furniture occupied, map frame), for a tracker
  // that can tell what is not the building in its first frame (objects present at the start).
  // Given before the first frame; the default ignores it.
  virtual void set_static_map(const OccupancyGrid&) {}
  // One frame, stamps increasing. Returns the tracks reported on this frame (map frame, the
  // tracker's camera id). Bad input (wrong size or type, a missing image) is an error naming
  // what is wrong; the tracker's state is unchanged by it.
  virtual Result<std::vector<Track>> process(const StereoFrame& frame) = 0;
  // Forgets everything learned (background, tracks); the next frame starts afresh. Track ids
  // are not reused after a reset.
  virtual void reset() = 0;
  // The last processed frame annotated for a video: the camera view with the tracks drawn and
  // the system's own intermediate pictures (BGR, any size).
  virtual cv::Mat annotate(const StereoFrame& frame, const std::vector<Track>& tracks) const = 0;
};

}  // namespace vigil::vision
