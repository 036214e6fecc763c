// Tracking plan-view templates (chapter section 10.4.3, after Harville 2004): one Kalman filter per
// object with position, velocity and shape (height, footprint width) in its state; the object's
// height and occupancy templates (tau_H, tau_O: template_size x template_size cells, 40 by
// default) cut from the plan-view maps around it; correspondence by the match score of eq. 10.8
// over a search zone around the Kalman prediction:
//
//   phi(i, X) = rho * SAD(tau_H, H_masked(X)) + omega * SAD(tau_O, theta_sm(X))
//             + beta * |X - X_pred| + alpha * sum_{j < i} theta_j(X)
//
// with rho = w_height / sum(tau_H) and omega = w_occupancy / sum(tau_O), so both SADs are the
// fraction of the template that does not match and contribute alike (an object that vanished
// scores w_height + w_occupancy); beta per metre from the prediction; and the last term the
// share of the occupancy near X already taken by the objects matched before i this frame
// (theta_j: the occupancy near object j, weighted by a Gaussian of sigma core_sigma around it,
// and weighted again around X), so two tracks do not converge on one object. The best (lowest)
// score is compared with track_threshold: only below it is the state updated. The measurement is
// the object's centre of mass near the best match (a Gaussian-weighted mean of theta_sm; with
// measure_blob_centre, then, on a blob that is the track's alone, the mean of that blob's cells
// within a template window around it, re-centred a few times), its
// height (highest masked cell near it) and width (extent of its connected blob across the
// camera's line of sight, as depth errors smear blobs along it), and the
// templates are then cut again centred on that measured position, not on the prediction (so
// they do not slide), blended into the old ones at template_rate.
//
// Tracks are processed oldest first. Connected blobs of the plan-view mask that no track
// explains are born as new (tentative) tracks, reported once matched min_hits times; a coasting
// track (missed frames) near an unexplained blob re-acquires it instead (so a person who bends or
// is half occluded keeps their id); a track is deleted after max_missed frames without a match
// (a tentative one at its first miss), or when its prediction leaves the grid. A missing track is
// reported for report_missed frames only (its position is a guess that soon goes stale), then kept
// unreported until deleted, ready to re-acquire its object.
//
// A blob touching the border of the grid with its centre of mass within birth_border_margin of
// it is an object only partly inside the plan view (most often one entering across the far range
// limit, where stereo depth is poorest and smears the blob out to the border): its centre, shape
// and templates are those of the cut part, and a track born on it stays on the border while the
// object walks in. No track is born from such a blob; the object gets its track once it is
// inside (a blob well inside that only reaches the border by a thin tail of depth noise is
// fine), and a track already following an object keeps it up to and across the border.
//
// Nor is a track born from a blob that lies in the image behind a track seen this frame, 0.25 m to
// birth_shadow_depth behind it along the line of sight: stereo smears the two together along
// that line, so the new blob still carries a sliver of the one in front (a bag just put down
// behind its owner, born with the owner's leg, classed robot). It is born once the two are apart.
//
// A still thing beside a tracked object, in one blob with it (a bag put down beside its owner,
// who stays), would be explained by the owner's track and never born. So the cells of a blob a
// track explains that lie farther than split_radius from every track on it, across the line of
// sight (stereo smears along it), are residuals (the track's measured width is no guide: it
// spans the merged blob); residual cells that stay occupied split_still_frames frames running (a
// carried bag moves with its carrier and never does), taken where they are now lower than
// classes.bag_max_height (things put down; taller cells are part of someone: an arm over a table,
// a shoulder, a standing person's body smeared by stereo past split_radius, which would otherwise
// join a bag's cells into a residual as tall as a person), that make up a birth's area and
// height with no track near, are born as a track of their own (the stereo-shadow and border
// rules apply). The price: the low fringe of someone standing still, past split_radius across
// the line of sight and of a bag's area, would be born too.
//
// Occlusion explains a disappearance only when the occluder was there when it happened: a track
// lost in the open (its first missed frame not occluded) stays missing even if a track later
// passes in front of it (often the same object re-found by a new track). Nor is a track born
// within split_window frames and reacquire_max of it an occluder: that is most often its own
// object found again by a second track (the blob jumped beyond its reach as stereo smear at the
// far range resolved), and holding the first as hidden behind the second reports a ghost for
// seconds.
//
// A bag missed while its predicted place is still on a blob (hold_bag_on_blob) is held there as
// hidden too, not lost: something stands on its place and only the bag's templates failed to
// match, most often because it is in one blob with its owner who turns and starts off beside it
// (smeared together in depth, and the owner's own track missing for those frames, so no
// occluder). A bag does not walk; one picked up leaves its place empty once its carrier is off,
// and is then missing as any other track.
//
// Occlusion (figure 10.6): a track missed while another track seen this frame stands between it
// and the camera (in the plan view: nearer the camera, across its line of sight, and tall enough
// to hide at least half of its height from the camera's height) is occluded rather than missing
// and is kept for up to max_occluded frames (max_occluded_bag for a bag), so a bag or a person
// hidden for a while by someone walking in front, or standing there, keeps its id. While
// occluded, a track is fully updated only on a good match (score under occluded_match *
// track_threshold); on a weaker one only its position is, loosely,
// from the visible part (a partial view would drag its shape and templates); a blob near it is
// taken as its visible part (no birth). A coasting track keeps its velocity unless it is slow or a
// bag (held still: bags do not walk, and slow apparent motion is mostly blob transients), or its
// velocity when last measured was not known to differ from zero (coast_min_sigmas): a track
// measured for a handful of frames, such as one born on a bag while it is being put down, would
// otherwise drift off on the velocity of its birth.
//
// Each track has a class from its height and width (person, bag, robot; classify_track), voted
// over its frames with a slow decay (class_vote_decay). Positions: the measured centre of mass is
// moved away from the camera by visible_surface_offset (see the parameter); the templates stay
// centred on the centre of mass. A measurement failing the Mahalanobis gate on position and
// height is not used. On a blob that also lies under another track's prediction (two objects
// merged, such as a robot passing a bag) only the position is measured: the blob's extent and
// highest point may be the other object's.
//
// Frames must come in increasing stamp order and with the grid the tracker was made for;
// anything else is an Error (kBadInput) and leaves the tracker as it was.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "common/status.h"
#include "vision/plan_view.h"
#include "vision/track.h"

namespace vigil::vision {

// Class from height (m above the floor) and footprint width (m): person when the height is in
// [person_min_height, person_max_height]; robot when the height is in [robot_min_height,
// robot_max_height) and either at least bag_max_height or the width at least robot_min_width;
// bag when lower than bag_max_height (and at least bag_min_height) with a width under
// robot_min_width; unknown otherwise. Defaults from the simulator's figures: people 1.5 to 2.0 m
// tall, bags 0.4 x 0.2 x 0.4 m, the Erratic robot 0.40 x 0.41 m with a mast to about 0.78 m.
struct ClassifierParams {
  double person_min_height = 1.2, person_max_height = 2.1;
  double bag_min_height = 0.1, bag_max_height = 0.7;
  double robot_min_height = 0.3, robot_max_height = 1.2, robot_min_width = 0.5;
};
TrackClass classify_track(double height, double width, const ClassifierParams& p = {});

struct PlanViewTrackerParams {
  std::string camera;             // Track::camera of the tracks produced
  int template_size = 40;         // cells, tau_H and tau_O (chapter: 40)
  // Correspondence (eq. 10.8).
  double w_height = 1.0;          // weight of the normalised height SAD (rho * sum(tau_H))
  double w_occupancy = 1.0;       // weight of the normalised occupancy SAD (omega * sum(tau_O))
  double beta = 1.0;              // per metre between X and the prediction
  double alpha = 1.0;             // on the share of occupancy near X claimed by earlier tracks
  double track_threshold = 1.4;   // update only when the best score is below this...
  double gate = 16.3;             // ...and the measured position and height are within this squared
                                  // Mahalanobis distance of the prediction (chi^2, 3 dof, 99.9%; 0 = none)
  double search_sigmas = 3.0;     // search zone radius: this many predicted position sigmas...
  double search_min = 0.12;       // ...but at least this (m)...
  double search_max = 0.6;        // ...and at most this (m)
  double core_sigma = 0.15;       // m, Gaussian for the centre of mass and the claims
  double height_radius = 0.25;    // m around the centre where the object's height is read
  double template_rate = 0.7;     // share of the new templates blended in at each update (1 = replace)
  // The camera sees only an object's near side, so the centre of mass of its plan-view blob lies
  // in front of its true centre: the measurement is moved this far (m; at most half the object's
  // width) away from the camera. 0 = the chapter's plain centre of mass.
  double visible_surface_offset = 0.1;
  // Off by default (experimental). On a blob that is the track's alone (no other track's
  // prediction on it), and for a track not classed bag, the measured centre continues from the
  // local Gaussian mean shift to the mean of the blob's cells within a template window, re-centred
  // up to 3 times: the mean shift stops anywhere on a plateau, and SGBM at 6 to 8 m smears a
  // walking person into a plateau up to a metre long along the line of sight, where the track lags
  // on its far part. On rendered SGBM it lifts person MOTA from 0.87 to 0.90 in dis_left_bag and
  // dis_bag_taken, but a person picking up a bag in dis_bag_stay then leaves a stale bag track
  // behind (a false left_bag) and dis_occlusion loses more; see docs/TRACKING.md.
  bool measure_blob_centre = false;
  // Life cycle.
  int min_hits = 3;               // matches before a track is reported
  int max_missed = 15;            // frames without a match before a track is deleted...
  int max_occluded = 75;          // ...or frames while occluded (see the header comment),
  int max_occluded_bag = 150;     // or, for a bag (which does not walk), this many: its owner may
                                  // stand in front of it for longer than a passer-by would
  int report_missed = 4;          // a missing track (not occluded) is reported for at most this many
                                  // frames, then kept unreported (for re-acquisition) to max_missed
  bool hold_bag_on_blob = true;   // a bag missed while its place is still on a blob is held as hidden
                                  // (see the header comment)
  double coast_hold_speed = 0.3;  // m/s: a coasting track slower than this, or a bag, is held still
  double coast_min_sigmas = 2.0;  // ...or one whose speed at its last measurement was under this many
                                  // standard deviations of its velocity along itself (0 = off)
  double coast_velocity_decay = 0;  // s, time constant of the velocity's decay while coasting (0 = none)
  double occluded_match = 0.25;   // an occluded track is fully updated under this * track_threshold;
  double occluded_position_noise = 0.1;  // above, only its position, with this noise (m)
  double birth_min_area = 0.04;   // m^2 of visible surface (occupancy sum * cell^2) for a new track
  double birth_min_height = 0.1;  // m, tallest cell of a blob for a new track
  double birth_border_margin = 0.25;  // m: no birth from a blob touching the grid's border with its
                                     // centre this close to it (see the header comment; 0 = off)
  double birth_shadow_depth = 1.0;  // m: no birth from a blob hidden behind a track seen this frame
                                    // and less than this behind it (see the header comment; 0 = off)
  int split_window = 15;          // frames: a track born this recently beside a missed one does not
                                  // occlude it (see the header comment; 0 = off)
  int split_still_frames = 15;    // frames a still residual must stay before its birth (0 = off; see the
                                  // header comment)
  double split_radius = 0.3;      // m across the line of sight from a track's centre where residuals
                                  // start (a person's half shoulder width and an arm)
  double explain_distance = 0.3;  // m: a blob whose centre is this close to a track is that track's
  double reacquire_distance = 0.6;  // m: a coasting track this close to an unexplained blob takes it,
  double reacquire_max = 1.0;       // or up to this far as its prediction's 3 sigma grows
  // Kalman filter (state x, y, vx, vy, height, width; measurement x, y, height, width).
  double accel_noise = 2.0;       // m/s^2, white acceleration driving the velocity
  double height_noise = 0.1;      // m/sqrt(s), random walk of the height (a person's is steady)
  double width_noise = 0.3;       // m/sqrt(s), random walk of the width (blobs merge and split)
  double position_noise = 0.03;   // m, measured centre of mass
  double shape_measurement_noise = 0.05;  // m, measured height and width
  double initial_velocity_sigma = 1.0;    // m/s at birth
  // Classes. In the plan view a robot shows its mast: every robot track of the shipped and of
  // 22 generated rendered runs had a median height of 0.76 to 0.86 m, while a bag 6 to 7 m away
  // whose long side faces the camera measures 0.50 to 0.51 m across (two generated bags were
  // classed robot by width, and their events missed). So below bag_max_height the width makes a
  // robot only from 0.8 m (robot_min_width); a robot whose mast is not seen is told apart by the
  // position it reports of itself (the vision sensor host), not by shape.
  ClassifierParams classes = plan_view_classes();
  static ClassifierParams plan_view_classes() {
    ClassifierParams c;
    c.robot_min_width = 0.8;
    return c;
  }
  // Per frame, the decay of the class votes: their memory is about 1 / (1 - decay) frames, long
  // enough that a few seconds of a merged blob (a robot passing a bag) do not flip an established
  // class, short enough that a wrong first impression (an object entering half seen) is corrected.
  double class_vote_decay = 0.99;
  // A track whose measured top comes within this of the camera's view ceiling at its place
  // (PlanView::ceiling: the top of the image cuts it, so its height is only a lower bound) is
  // reported with Track::top_cut, until a full measurement says otherwise (a new track starts
  // without it; shared, coasting and occluded frames keep the last). Negative: never.
  double top_cut_margin = 0.1;
  // Checks every field; the error's key is the field's name.
  Status validate() const;
};

class PlanViewTracker {
 public:
  // A tracker for plan views on `grid`, or the Error naming the bad parameter.
  static Result<PlanViewTracker> create(const PlanViewGrid& grid, const PlanViewTrackerParams& params = {});
  PlanViewTracker(PlanViewTracker&&) noexcept;
  PlanViewTracker& operator=(PlanViewTracker&&) noexcept;
  ~PlanViewTracker();

  // Tracks the frame taken at stamp_ns: the confirmed tracks alive after it (matched this frame or
  // coasting on their prediction, with a lower confidence), ordered by id. Errors: a stamp not
  // after the previous frame's, a plan view of another grid (size, origin or cell).
  Result<std::vector<Track>> update(const PlanView& view, int64_t stamp_ns);

  // Forgets every track (ids keep counting up).
  void reset();
  const PlanViewGrid& grid() const { return grid_; }
  const PlanViewTrackerParams& params() const { return params_; }
  // Tracks alive now, tentative ones included.
  int live_tracks() const;
  // The last frame's best match score per live track id (NaN when the track was born this frame).
  std::vector<std::pair<int, double>> last_scores() const;

 private:
  struct Impl;
  PlanViewTracker(const PlanViewGrid& grid, const PlanViewTrackerParams& params);
  PlanViewGrid grid_;
  PlanViewTrackerParams params_;
  std::unique_ptr<Impl> impl_;
};

// Plan-view maps, then tracks, of one camera: the builder and the tracker together.
class PlanViewPipeline {
 public:
  static Result<PlanViewPipeline> create(const StereoCameraModel& camera, const PlanViewParams& plan = {},
                                         const PlanViewTrackerParams& tracking = {});
  // One frame: foreground mask and depth as PlanViewBuilder::build takes them.
  Result<std::vector<Track>> process(const cv::Mat& foreground, const cv::Mat& depth, int64_t stamp_ns);
  const PlanView& plan_view() const { return view_; }
  const PlanViewBuilder& builder() const { return builder_; }
  const PlanViewTracker& tracker() const { return tracker_; }
  // Forgets every track (ids keep counting up).
  void reset() { tracker_.reset(); view_ = PlanView{}; }

 private:
  PlanViewPipeline(PlanViewBuilder b, PlanViewTracker t) : builder_(std::move(b)), tracker_(std::move(t)) {}
  PlanViewBuilder builder_;
  PlanViewTracker tracker_;
  PlanView view_;
};

// Drawing, for the annotated video. Images are BGR, map +x to the right and +y up, `scale`
// pixels per cell.
struct PlanViewDrawOptions {
  int scale = 1;                   // pixels per cell
  double occupancy_max = 0;        // occupancy shown at full colour (0 = the frame's 99th percentile)
  double height_max = 2.2;         // m shown at full colour
  bool draw_tracks = true;         // circle of the width, id and class, velocity over 1 s
  bool draw_camera = true;         // the camera's position when inside the grid
};
// The occupancy map (theta_sm) as a colour image (black = empty), with tracks.
cv::Mat draw_occupancy_map(const PlanView& view, const std::vector<Track>& tracks, const PlanViewDrawOptions& o = {});
// The masked height map as a colour image (black = empty), with tracks.
cv::Mat draw_height_map(const PlanView& view, const std::vector<Track>& tracks, const PlanViewDrawOptions& o = {});
// Both side by side (occupancy left, height right) with a title bar.
cv::Mat draw_plan_view(const PlanView& view, const std::vector<Track>& tracks, const PlanViewDrawOptions& o = {});
// Pixel of a map point in the images above.
cv::Point2d plan_view_pixel(const PlanViewGrid& grid, double x, double y, int scale = 1);

namespace detail {
// Tests only: score every candidate window in full with the portable kernel (no early exit by the
// bound, no AVX2). The fast search gives the same tracks; this lets a test check it.
void planview_tracker_exhaustive_search(bool exhaustive);
}  // namespace detail

}  // namespace vigil::vision
