// The colour MSER system (mser_system.h) as a vision::Tracker on one calibrated camera: it uses
// the left image only, and puts each confirmed image object into the map frame with the
// camera's pose and the floor plane, as a mono camera must (chapter 10.3 tracks in the image;
// the platform wants positions in the building's frame).
//
// Map frame. The box's bottom edge is where the object stands: the ray through its middle
// meets the floor (z = 0) at the near side of the footprint, and the centre lies half a width
// further along the line of sight. The object's depth along the optical axis gives its width
// (box width x depth / fx) and its height (the ray through the box's top, at the footprint's
// distance). An object whose box touches the image's bottom edge, or whose foot ray does not
// meet the floor within `max_range`, has no floor contact in view and is not reported. The
// class comes from height and width with the plan-view tracker's classifier (person, bag,
// robot, unknown), voted over the track's frames. Velocity: the footprint's motion, smoothed.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "vision/mser/mser_system.h"
#include "vision/planview_tracker.h"
#include "vision/stereo_camera_model.h"
#include "vision/tracker.h"

namespace vigil::vision::mser {

struct MserTrackerParams {
  std::string camera;            // Track::camera of the tracks produced
  MserSystemParams system;
  ClassifierParams classes;
  double max_range = 12;         // m from the camera to the foot point
  double velocity_smoothing = 0.3;  // weight of the newest velocity measurement
  double class_vote_decay = 0.95;   // per frame
  Status validate() const;
};

class MserTracker : public Tracker {
 public:
  static Result<MserTracker> create(const StereoCameraModel& camera, const MserTrackerParams& params = {});

  std::string_view name() const override { return "mser"; }
  bool needs_depth() const override { return false; }
  Result<std::vector<Track>> process(const StereoFrame& frame) override;
  void reset() override;
  cv::Mat annotate(const StereoFrame& frame, const std::vector<Track>& tracks) const override;

  const MserSystem& system() const { return system_; }
  const StereoCameraModel& camera() const { return camera_; }
  // The map-frame footprint of an image box (false: no floor contact in view); for tests.
  bool box_to_map(const cv::Rect& box, double* x, double* y, double* width, double* height) const;

 private:
  MserTracker(const StereoCameraModel& camera, const MserTrackerParams& p) : camera_(camera), p_(p), system_(p.system) {}
  struct History {
    int64_t stamp_ns = 0;
    double x = 0, y = 0, vx = 0, vy = 0;
    std::map<TrackClass, double> votes;
  };
  StereoCameraModel camera_;
  MserTrackerParams p_;
  MserSystem system_;
  std::map<int64_t, History> history_;
  int64_t id_offset_ = 0;  // ids after a reset continue above the last
  int64_t max_id_ = 0;
  int64_t last_stamp_ = INT64_MIN;
};

}  // namespace vigil::vision::mser
