// The stereo plan-view vision system of chapter section 10.4 as one object: the YUV + depth
// Gaussian-mixture foreground (10.4.1), the plan-view maps (10.4.2) and the Kalman template
// tracker (10.4.3), fed stereo frames (colour and depth) from any frame source, rendered or
// recorded, with the annotated view for videos.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "common/occupancy_grid.h"
#include "common/status.h"
#include "vision/frame_source.h"
#include "vision/plan_view.h"
#include "vision/planview_tracker.h"
#include "vision/reid.h"
#include "vision/stereo_camera_model.h"
#include "vision/track.h"
#include "vision/tracker.h"
#include "vision/yuvd_background.h"

namespace vigil::vision {

// Stereo depth at a depth discontinuity (a person's outline against the far background) is a mix
// of the two surfaces: block matching and the smoothness paths of SGBM give the outline pixels
// depths in between, which the plan view smears behind the object along the line of sight (and
// at the far end of that smear the tracker would find a second object). A foreground pixel is
// therefore left out of the plan view when it lies more than edge_tolerance_px disparity pixels
// (as a depth, Z^2 / (fx b) * edge_tolerance_px, plus edge_tolerance_m) behind the nearest
// valid depth within edge_radius pixels: it is not on the near surface. 0 radius = no filter.
struct DepthEdgeFilterParams {
  int edge_radius = 0;             // px, half side of the window (0 = off)
  double edge_tolerance_px = 1.0;  // disparity pixels behind the window's nearest depth
  double edge_tolerance_m = 0.1;   // plus this (m)
  Status validate() const;
};

// Where the system asks for depth (Tracker::depth_wanted). Stereo matching is most of a frame's
// cost, and the plan view only ever uses foreground pixels; a foreground pixel is one whose colour
// or depth differs from the background, and (camouflage aside) colour alone finds where that can
// be. So with foreground_only the system asks for depth where the frame's colour differs from
// the background model (YuvdBackground::colour_changes; the matcher grows it by a few pixels,
// StereoMatcher::compute_in), and everywhere on the first full_first frames (which give the
// background its depth) and on one frame in full_every after them (which keep it learning).
struct DepthRegionParams {
  bool foreground_only = false;
  int full_first = 10;  // frames
  int full_every = 60;  // frames; 0 = never after the first
  Status validate() const;
};

// Objects present at the start. The background model learns the first frame as the empty scene,
// so whatever stands there then (a bag left before the cameras started, a parked robot, someone
// waiting) would be background for good. Given the building's map (set_static_map: walls and
// furniture), the first frame's points that stand above the floor in free space, at least
// wall_margin from anything the map holds, in plan-view blobs of at least the tracker's birth
// area and height, are not the building: their pixels' background depth becomes that of what the
// map says is behind them along the pixel's ray (the first wall or furniture its foot crosses,
// else the floor), so they are foreground, nearer than the background, and tracked like anything
// that came later; when such a thing leaves, what it uncovers matches that depth, or lies farther
// (a ray passing over low furniture) and is relearnt. Without a map nothing changes.
struct StartObjectParams {
  bool enabled = true;
  double wall_margin = 0.3;  // m from the map's occupied cells (walls, furniture): SGBM spreads a
                             // wall's points over a few centimetres to decimetres
  Status validate() const;
};

struct PlanViewSystemParams {
  YuvdBackgroundParams background;
  StartObjectParams start;
  DepthRegionParams depth_region;
  DepthEdgeFilterParams depth_filter;
  PlanViewParams plan;
  PlanViewTrackerParams tracking;  // tracking.camera names the tracks' camera
  ReidParams reid;                 // people who come back keep their id (vision/reid.h)
};

class PlanViewSystem : public Tracker {
 public:
  static Result<PlanViewSystem> create(const StereoCameraModel& camera, const PlanViewSystemParams& params = {});

  // One frame: needs frame.left (8-bit BGR) and frame.depth (CV_32F metres, invalid 0/NaN/inf)
  // of the camera's size, stamps increasing. Returns the tracks reported on this frame.
  Result<std::vector<Track>> process(const StereoFrame& frame) override;
  std::string_view name() const override { return "planview"; }
  bool needs_depth() const override { return true; }
  cv::Mat depth_wanted(const StereoFrame& frame) override;
  // Forgets the background model and every track (track ids keep counting up).
  void reset() override;
  // The building as the map holds it (walls and furniture occupied), for the objects present at
  // the start (StartObjectParams). An empty grid forgets it. Takes effect on the first frame
  // learnt after it is set (after create() or reset()).
  void set_static_map(const OccupancyGrid& map) override;
  // Pixels of the first frame taken for objects present at the start (CV_8UC1, 255), empty when
  // none were looked for.
  const cv::Mat& start_objects() const { return start_mask_; }

  const cv::Mat& foreground() const { return foreground_; }
  const PlanView& plan_view() const { return pipeline_.plan_view(); }
  const StereoCameraModel& camera() const { return camera_; }
  // People re-identified so far (a new track that took a lost person's id).
  int reidentified() const { return reid_.reidentified(); }

  // The annotated view of the last frame: the camera view with the tracks drawn (a box around
  // each track's projected cylinder, id and class), the foreground mask, and the plan-view
  // occupancy and height maps below, in one BGR image.
  cv::Mat annotate(const StereoFrame& frame, const std::vector<Track>& tracks) const override;

 private:
  PlanViewSystem(StereoCameraModel camera, YuvdBackground bg, PlanViewPipeline pipeline, DepthEdgeFilterParams df,
                 DepthRegionParams region, StartObjectParams start, ReidParams reid)
      : camera_(std::move(camera)), background_(std::move(bg)), pipeline_(std::move(pipeline)), filter_(df),
        region_(region), start_(start), reid_params_(reid), reid_(reid) {}
  // The tracker's tracks of this frame renamed to identities: people's colours measured where
  // they stand apart from other people in the image, then the Reidentifier.
  void reidentify(const StereoFrame& frame, const cv::Mat& mask, std::vector<Track>* tracks);
  // Drops the foreground pixels that are not on the near surface (see DepthEdgeFilterParams)
  // from plan_mask_.
  void filter_depth_edges(const cv::Mat& depth);
  // The first frame's pixels on things standing in the map's free space (StartObjectParams), and
  // their background depth: the floor along each pixel's ray.
  Status find_start_objects(const cv::Mat& depth, cv::Mat* floor_depth);
  StereoCameraModel camera_;
  YuvdBackground background_;
  PlanViewPipeline pipeline_;
  DepthEdgeFilterParams filter_;
  DepthRegionParams region_;
  StartObjectParams start_;
  ReidParams reid_params_;
  Reidentifier reid_;
  cv::Mat clearance_;  // distance (m) from the static map's occupied cells, CV_32F; empty: no map
  OccupancyGrid static_map_;
  cv::Mat start_mask_;
  cv::Mat changed_;
  cv::Mat foreground_, plan_mask_, near_depth_;
};

// Draws the tracks on a camera image: the projected box of each track's cylinder (width,
// height), its id and class.
void draw_tracks_on_view(cv::Mat* bgr, const StereoCameraModel& camera, const std::vector<Track>& tracks);

}  // namespace vigil::vision
