// The colour MSER system (mser_system.h) as a vision::Tracker on one calibrated camera: it uses
// the left image only, and puts each confirmed image object into the map frame with the
// camera's pose and the floor plane, as a mono camera must (chapter 10.3 tracks in the image;
// the platform wants positions in the building's frame).
//
// Map frame. The box's bottom edge is where the object stands: the ray through its middle
// meets the floor (z = 0) at the near side of the footprint, and the centre lies half the
// footprint further along the line of sight (half the width, at most `max_footprint` / 2). The object's depth along the optical axis gives its width
// (box width x depth / fx) and its height (the ray through the box's top, at the footprint's
// distance). An object whose box touches the image's bottom edge has no floor contact in view:
// a tall box (a person close to the camera) is placed by its top at a person's height
// (`cut_person_height`), anything else is not reported, nor is an object whose foot ray does
// not meet the floor within `max_range`. The
// class comes from height and width with the plan-view tracker's classifier (person, bag,
// robot, unknown), voted over the track's frames. Velocity: the footprint's displacement over the last second.
// A still bag unseen for a moment is held at its place (`hold_time`, Track::measured false).
//
// Surfaces (table tops from the floor plan): a box's bottom ray that meets a surface inside its
// outline before the floor stands on it; classed by its height above the surface; taller than
// a bag above it, it is someone behind the table, placed by the head. Once the background is
// learned, the learned regions lying on a surface, 0.1 to 0.5 m wide, whose colour differs from
// the surface's own (its largest learned region's) by more than the background's colour limit,
// are the objects present at the start: reported every frame as still bags (ids from kStartIds + 1), so the activity
// rules give them no owner.
#pragma once

#include <deque>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "vision/mser/mser_system.h"
#include "vision/planview_tracker.h"
#include "vision/reid.h"
#include "vision/stereo_camera_model.h"
#include "vision/tracker.h"

namespace vigil::vision::mser {

// A horizontal surface objects can lie on (a table top, from the building's floor plan).
struct Surface {
  double x = 0, y = 0, yaw = 0;   // centre and orientation (map frame)
  double size_x = 0, size_y = 0;  // m
  double height = 0;              // m above the floor
};

struct MserTrackerParams {
  std::string camera;            // Track::camera of the tracks produced
  MserSystemParams system;
  ClassifierParams classes;
  double max_range = 12;         // m from the camera to the foot point
  std::vector<Surface> surfaces;  // what an object's bottom may stand on besides the floor
  double surface_margin = 0.1;    // m around a surface's outline that still counts as on it
  // Things put down on a surface and left lying still (a book, a bottle on the table) are
  // objects from this share of the image where the camera sees a surface's top
  // (MserSystemParams::min_still_area and the small-things mask, set by create()); smaller than
  // system.min_object_area, only those placed on a surface are reported.
  double surface_min_area = 0.0005;
  double max_footprint = 0.5;     // m: the deepest footprint (a person's), whatever the box's width
  // A box whose bottom lies on a surface's far edge (this many rows below it look onto the
  // surface) is cut off by the surface, not standing where its bottom ray meets the floor.
  double edge_rows = 3;
  // Objects present at the start: background regions on a surface at least this wide (m),
  // parts closer than start_merge (m) one object.
  double start_min_width = 0.1;
  double start_merge = 0.35;
  // Given the building's map (set_static_map): things standing on the floor while the
  // background was learned. The floor's view is the pixels whose ray meets the floor in free
  // space, at least `floor_margin` (m) from anything the map holds, before any wall. There, regions whose colour is not the floor's (regions within bg_colour of it
  // cover less than `floor_colour_share` of the floor's view, or a tenth of that in fewer than
  // `floor_colour_repeats` places: a pattern's colours come back all over it), joined when they touch, whose
  // box stands on the floor clear of the map by floor_margin, at least `floor_min_height` (m)
  // tall (not a mark on the floor) and start_min_width wide, are not the scene: they leave the
  // background model (MserSystem::release_from_background) and are tracked like anything else.
  // What of them is seen against a wall rather than the floor (the head of someone standing near
  // the corridor's end) stays background.
  bool floor_start_objects = true;
  double floor_margin = 0.3;
  double floor_colour_share = 0.2;
  int floor_colour_repeats = 6;
  double floor_min_height = 0.15;
  int start_touch_px = 2;  // ...and parts whose pixels come this close in the image
  // Hands (Track::hand_on): an object present at the start is handled by the object whose box
  // holds most of its pixels that are foreground and changed colour from how it looked when
  // found (L1 over the channels above hand_change), once there are at least hand_min_pixels
  // and hand_min_share of its pixels (a hand or sleeve in front of it; someone behind it
  // changes none of its pixels).
  int hand_change = 60;
  int hand_min_pixels = 20;
  double hand_min_share = 0.01;
  // ...or an arm held out to it: the far end of someone's reach beyond their upright body
  // (its box beyond ImageObject::body, MserSystemParams::thin_column) within the thing's box grown by this
  // share of its height (a hand beside or above a bottle covers little of it). Negative: off.
  double hand_reach_margin = 0.25;
  // Feet cut off by the image's bottom edge: a box at least `cut_min_aspect` times as tall as
  // wide is placed as a person this tall (m) by its top; 0: not placed.
  double cut_person_height = 1.7;
  double cut_min_aspect = 1.2;
  double velocity_window = 1.0;  // s: velocity is the displacement over this window
  // A footprint (not a bag's) moving farther than max_speed (m/s) over the time since the last
  // fix plus jump_slack (m) has jumped (its box's bottom is another part now): the velocity restarts.
  double max_speed = 3.0;
  double jump_slack = 0.5;
  // A still bag that goes unseen while another object covers its place in the image (someone
  // in front, or beside it and merged with it) is held at its place for up to this long, not
  // measured, as the plan-view tracker holds occluded tracks; slower than hold_speed (m/s)
  // counts as still. An uncovered empty place ends it at once.
  double hold_time = 3.0;
  double hold_speed = 0.3;
  double hold_match = 0.5;  // m: a new object this close to a held bag is that bag...
  int split_gap_px = 2;     // ...if its box overlaps the bag's last box grown by this (pixels)
  int hold_min_frames = 3;  // a bag measured on fewer frames (a carried bag glimpsed) is not held
  // A still bag whose object becomes person-sized (someone reached it and their blobs merged) is
  // held as covered, and the object is the person track last seen within this many metres (plus
  // max_speed times how long ago), else a new person track.
  double merge_reach = 1.0;
  // A new object within merge_reach (plus max_speed times the time since) of a person track lost
  // at most this long ago (s) continues it.
  double resume_time = 0.5;
  double class_vote_decay = 0.99;   // per frame: a memory of about 100 frames, as the plan-view tracker's
  // People who come back: a new person track takes the identity of one lost earlier dressed
  // alike (vision/reid.h), her colours measured on the foreground in her image box, each row's
  // height above the floor taken at her distance (measure_appearance_mono), while no other
  // person's box covers a fifth of hers. Someone who walks round the table and is found again
  // as a new track stays the owner of what she put down.
  ReidParams reid;
  Status validate() const;
};

class MserTracker : public Tracker {
 public:
  static Result<MserTracker> create(const StereoCameraModel& camera, const MserTrackerParams& params = {});

  std::string_view name() const override { return "mser"; }
  bool needs_depth() const override { return false; }
  bool sees_hands() const override { return true; }
  Result<std::vector<Track>> process(const StereoFrame& frame) override;
  void reset() override;
  void set_static_map(const OccupancyGrid& map) override;
  cv::Mat annotate(const StereoFrame& frame, const std::vector<Track>& tracks) const override;

  const MserSystem& system() const { return system_; }
  // Where an image box stands in the map frame.
  struct Placement {
    double x = 0, y = 0, width = 0;
    double height = 0;      // top above the floor
    double own_height = 0;  // top above what it stands on
    double support = 0;     // what it stands on: 0 the floor, else a surface's height
    int surface = -1;       // which of MserTrackerParams::surfaces (-1: the floor)
    bool by_head = false;   // placed by its top as a person (feet out of view or behind a table)
    // Behind a table with the head out of view as well: the distance from the camera along the
    // line of sight (horizontal, m) is only known to lie in [range_min, range_max] (the table's
    // far edge, where the bottom row's ray meets the floor); x, y are at range_min. Else both 0.
    double range_min = 0, range_max = 0;
  };
  // `stature` (m, when known): a person placed by the head is this tall, else cut_person_height.
  bool place(const cv::Rect& box, Placement* out, double stature = -1) const;
  // Track ids of the objects present at the start: kStartIds + 1, + 2, ...
  static constexpr int64_t kStartIds = 1'000'000;
  // Track ids of people first seen merged with a still bag they reached (see merge_reach):
  // kMergedIds + 1, + 2, ...
  static constexpr int64_t kMergedIds = 2'000'000;
  const StereoCameraModel& camera() const { return camera_; }
  // The map-frame footprint of an image box (false: no floor contact in view); for tests.
  bool box_to_map(const cv::Rect& box, double* x, double* y, double* width, double* height) const;

 private:
  MserTracker(const StereoCameraModel& camera, const MserTrackerParams& p)
      : camera_(camera), p_(p), system_(p.system), reid_(p.reid) {}
  struct Fix {
    int64_t stamp_ns = 0;
    double x = 0, y = 0;
  };
  // How a thing lying still looked: its pixels (mask over box) and their colours.
  struct Picture {
    cv::Rect box;
    cv::Mat mask;     // CV_8U
    cv::Mat colours;  // CV_8UC3
    int pixels = 0;
  };
  struct History {
    std::deque<Fix> trail;  // the footprint over the velocity window
    int64_t stamp_ns = 0;
    double x = 0, y = 0, vx = 0, vy = 0, width = 0, height = 0;
    TrackClass cls = TrackClass::kUnknown;
    int frames = 0;  // measured on
    cv::Rect box;    // in the image, when last measured
    std::map<TrackClass, double> votes;
    double cut_votes = 0;  // boxes cut off by the image's top, taller than a bag (decaying as votes)
    Picture picture;  // a still bag: how it looked when last seen on its own, no hand on it
    double stature = -1;  // a person's height, measured while the feet and head were in view (-1: not yet)
    Fix seen;             // the last place not inside a span only (Placement::range_min), and
    double seen_vx = 0, seen_vy = 0;  // the velocity then
    Fix spanned;          // the last place predicted inside a span
    std::deque<double> statures;  // its last measurements
    // This frame's box shows the legs (standing on the floor, feet in view) and the upper body
    // (head in view): which of her colours can be measured (reidentify).
    bool legs_in_view = false, upper_in_view = false;
  };
  // Renames `out`'s tracks to identities (reid_), given their image boxes (history `next`).
  void reidentify(int64_t stamp_ns, const cv::Mat& bgr, const std::map<int64_t, History>& next, std::vector<Track>* out);
  bool place_by_head(const cv::Rect& box, Placement* out, double stature = -1) const;
  // The surface the ray through pixel (u, v) meets first, inside its outline (-1: the floor).
  int surface_under(double u, double v) const;
  // The first surface the ray c + t dir (dir pointing down) meets within `margin` of its
  // outline, and its t (-1 and the floor's t when none).
  int first_surface(const Eigen::Vector3d& c, const Eigen::Vector3d& dir, double margin, double* t) const;
  void find_start_objects(const cv::Mat& bgr);
  // Things standing on the floor when the model was learned (see floor_start_objects): their
  // pixels (CV_8U), released from the background model. Empty without a map.
  cv::Mat find_floor_start_objects();
  struct StartObject {
    int index = 0;
    Placement place;
    cv::Rect box;     // in the image
    Picture picture;  // how it looked when found
  };
  // Track id -> the track id of the thing lying there its hand is on, this frame (see
  // hand_change); `handled` gets the things a hand is on.
  std::map<int64_t, int64_t> hands_on_objects(const cv::Mat& bgr, std::set<int64_t>* handled) const;
  std::vector<StartObject> start_objects_;
  bool start_found_ = false;
  OccupancyGrid map_;
  cv::Mat clearance_;    // map_clearance(map_); empty: no map given
  cv::Mat floor_start_;  // the pixels released as things on the floor at the start
  StereoCameraModel camera_;
  MserTrackerParams p_;
  MserSystem system_;
  std::map<int64_t, History> history_;
  Reidentifier reid_;
  std::map<int64_t, int64_t> alias_;  // the system's object id -> the track id it continues
  int64_t id_offset_ = 0;  // ids after a reset continue above the last
  int64_t merged_ids_ = 0;
  int64_t max_id_ = 0;
  int64_t last_stamp_ = INT64_MIN;
};

}  // namespace vigil::vision::mser
