// Region tracking of the colour MSER system (chapter 10.3.2): each frame's segmentation regions
// are linked to the last frames' by phases, each run only on what the earlier ones left
// unmatched, fastest first:
//   1. feed-forward tracking: a region seeded from a last-frame region (its donor, segmenter.h)
//      continues that region's track (the region with most seeds from a donor keeps it);
//   2. MSER tracking: candidates near each unmatched last-frame region from a kd-tree over this
//      frame's unmatched centroids, kept when similar enough in position, size (second-moment
//      width and height) and mean colour, then linked greedily, most similar first;
//   3. line-corner tracking: tracks lost this frame (unmatched by phases 1-2) against the
//      regions still unmatched, by their line corners (below): the track's corners from the
//      last frame it was matched find candidates among the regions' corners (a kd-tree by
//      position), kept when the line angles, the region colours and the handedness agree; a
//      track-region pair with at least `min_corners` agreeing corners (or one strong one) is a
//      candidate link, and the links are made greedily, most similar first (phase 2's strategy);
//   4. secondary tracking: tracks lost within the last `window` frames (n < 8), at the place
//      their motion model predicts, against what is still unmatched: MSER tracking and then
//      line-corner tracking again, each with `loose` times looser limits.
//
// Line corners (10.3.2, "Line-Tracking"). The end points of the line segments (lines.h) on a
// region's boundary: a segment belongs to the regions on its two sides (the labels sampled
// `corner_side` px either side of it), and each of its end points within `corner_near` px of
// such a region's pixels is a corner of that region, with: its position; the line's angle as
// seen from the region (the direction from its right end to its left end, so 180 degrees
// rotated for the region on the other side); the region's mean colour; and its handedness,
// left or right looking out of the region across the line (the chapter's view from the region's
// centre, taken from the side the region lies on, so a concave region cannot get it wrong;
// reversed for the other side). Corners are robust to occlusion of another part of the region, so a half-hidden
// region whose size phase 2 refuses is still linked by its unchanged corners.
// A region left unmatched starts a new track. Track ids are never reused. Deterministic.
#pragma once

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "vision/mser/segmenter.h"

namespace vigil::vision::mser {

struct RegionTrackerParams {
  // MSER tracking (phase 2): the limits of a candidate.
  double max_shift = 12;        // px, plus `shift_per_size` of the region's size (width + height)
  double shift_per_size = 0.25;
  double max_size_ratio = 1.5;  // width and height each within this ratio
  double max_colour = 30;       // mean colour distance (0..441)
  // Secondary tracking (phase 4).
  int window = 7;               // frames a lost track is looked for (n < 8)
  double loose = 2.0;           // its limits are this many times phase 2's (and phase 3's)
  int min_size = 24;            // smaller regions are not tracked (MIN-SIZE)
  // Line-corner tracking (phase 3; run when update() is given the frame's lines).
  bool line_tracking = true;
  double corner_shift = 6;      // px: a corner's candidates lie within this of it
  double corner_angle = 15;     // degrees: line angles within this
  double corner_colour = 30;    // region colours within this
  int min_corners = 2;          // agreeing corners that link a track to a region ...
  double strong_shift = 1.5;    // ... or one within this many px, `strong_angle` degrees and
  double strong_angle = 5;      //     half `corner_colour`
  double corner_side = 2;       // px: where a segment's two regions are sampled, either side
  int corner_near = 2;          // px: an end point this close to a region's pixels is its corner
};

// An end point of a line segment on a region's boundary, as seen from that region.
struct LineCorner {
  cv::Point2f pos;   // px
  float angle = 0;   // radians (-pi..pi]: the line from its right end to its left end
  cv::Vec3f colour;  // the region's mean colour
  bool left = false; // the left end, looking out of the region across the line
  int region = -1;   // index into the Segmentation's regions
};

// The line corners of every region of `s` (corners[r] for region r; regions under `min_size`
// get none), from the segments of `lines`. Deterministic: segments in order, a then b.
std::vector<std::vector<LineCorner>> line_corners(const Segmentation& s, const Lines& lines,
                                                  const RegionTrackerParams& params);

// How a region got its track this frame.
enum class TrackPhase : int { kNew = 0, kFeedForward = 1, kMser = 2, kLine = 3, kSecondary = 4 };

struct RegionTrack {
  int64_t id = 0;
  int region = -1;              // index into this frame's Segmentation::regions (-1: lost)
  TrackPhase phase = TrackPhase::kNew;
  int age = 0;                  // frames since it started
  int lost = 0;                 // frames since it was last matched
  cv::Point2f centroid, velocity;  // px, px per frame
  float width = 0, height = 0;
  cv::Vec3f colour;
  std::vector<LineCorner> corners;  // its region's line corners, the last frame it was matched
};

class RegionTracker {
 public:
  explicit RegionTracker(RegionTrackerParams params = {}) : p_(params) {}
  // Links this frame's regions to the tracks; returns the track id of every region (-1 for
  // regions under min_size). With the frame's `lines` (the segmenter's), line-corner tracking
  // runs too (phase 3, and in phase 4); without them phases 1, 2 and 4's MSER tracking only.
  const std::vector<int64_t>& update(const Segmentation& s, const Lines* lines = nullptr);
  void reset();
  // Live tracks (matched this frame) and lost ones still looked for.
  const std::vector<RegionTrack>& tracks() const { return tracks_; }
  // Regions matched by each phase this frame.
  struct PhaseCounts {
    int feed_forward = 0, mser = 0, line = 0, secondary = 0, created = 0;
    int secondary_line = 0;  // of `secondary`: those linked by their line corners
  };
  const PhaseCounts& counts() const { return counts_; }

 private:
  RegionTrackerParams p_;
  std::vector<RegionTrack> tracks_;
  std::vector<int64_t> ids_;
  int64_t next_id_ = 1;
  PhaseCounts counts_;
};

}  // namespace vigil::vision::mser
