// Evaluation of a run's map-frame tracks (tracks.jsonl, vision/track_io.h) against the
// simulator's ground truth (the `tick` lines of ground_truth.jsonl, docs/OUTPUTS.md) with the
// MOT metrics of vision/mot_metrics.h on Euclidean distances in metres. This is what
// `vigil eval RUN_DIR` computes; docs/EVALUATION.md describes it for users.
//
// Frames are the camera's frame times: every distinct track stamp, plus every ground-truth tick
// with no track stamp within 3/4 of a camera frame period of it (the tracker reported nothing
// then, so whatever was there is missed; 3/4 rather than 1/2 absorbs the jitter of camera
// frames that fall on physics steps). At a frame time t the ground truth is the set of entities
// of the tick nearest to t (the earlier one on a tie), each at its position linearly
// interpolated between the two ticks around t when it is in both, else at its position in the
// nearest tick. Track stamps more than half a tick period outside the ground truth's time span
// are skipped. Ground-truth kinds are evaluated as track classes: person, bag and robot as
// themselves, every other object (laptop, book, bottle, box, ...) as `unknown`.
// The overall figures match tracks to ground truth whatever their classes; the per-class
// figures match only ground truth and tracks of that class.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "common/status.h"
#include "vision/mot_metrics.h"
#include "vision/track.h"

namespace vigil::vision {

struct GroundTruthEntity {
  std::string id, kind;  // kind: robot, person, bag, laptop, book, bottle, box
  double x = 0, y = 0;   // m, map frame
  bool carried = false;  // an object in someone's hands (has carried_by)
};

struct GroundTruthTick {
  int64_t t_ns = 0;
  std::vector<GroundTruthEntity> entities;
};

// The tick lines of a ground_truth.jsonl in file order (other lines skipped). Ticks must come in
// increasing time. Errors name the file, the line and the key (e.g. "entities[2].x").
Result<std::vector<GroundTruthTick>> load_ground_truth_ticks(const std::filesystem::path& path);

// The class a ground-truth kind is evaluated as: person, bag, robot, else unknown.
TrackClass track_class_of_kind(std::string_view kind);

struct MapTrackEvalOptions {
  double match_distance = 0.5;      // m: a track and an entity can match within this distance
  std::string camera;               // only this camera's tracks; "" = all cameras' tracks together
  std::optional<double> max_range;  // m: only ground truth and tracks within this of (camera_x, camera_y)
  double camera_x = 0, camera_y = 0;  // m, map frame
  // rad: only ground truth and tracks whose bearing from (camera_x, camera_y) is within this
  // of camera_yaw (half the camera's horizontal field of view)
  std::optional<double> half_fov;
  double camera_yaw = 0;            // rad, heading of the optical axis in the map frame
  // Only ground truth for which this is true (null: all); `vigil eval --in-view` gives "not
  // behind a wall of the map as the camera sees it". Tracks are not filtered by it: a track behind
  // a wall is the tracker's error.
  std::function<bool(double x, double y)> truth_visible;
  std::vector<TrackClass> classes;  // only these classes, ground truth and tracks; empty = all
  bool exclude_carried = false;     // leave out objects while someone carries them
  double camera_period_s = 0;       // camera frame period; 0 = the commonest gap between track stamps
};

struct MapTrackEvalResult {
  MotMetrics overall;                                        // class-agnostic matching
  std::vector<std::pair<TrackClass, MotMetrics>> per_class;  // classes with ground truth or tracks
  std::vector<std::string> cameras;                          // cameras whose tracks were evaluated
  int64_t frames = 0;               // frames evaluated
  int64_t frames_without_tracks = 0;  // ground-truth ticks added as frames with no track
  int64_t skipped_track_stamps = 0;   // track stamps outside the ground truth's time span
  double camera_period_s = 0;       // the period used
};

// Evaluates `tracks` against `ground_truth` (see the top of this file). Bad options, a camera
// with no tracks, or a (camera, id) twice at one stamp are bad-input errors.
Result<MapTrackEvalResult> evaluate_map_tracks(const std::vector<GroundTruthTick>& ground_truth,
                                               const std::vector<Track>& tracks, const MapTrackEvalOptions& options);

}  // namespace vigil::vision
