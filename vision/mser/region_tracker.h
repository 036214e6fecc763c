// Region tracking of the colour MSER system (chapter 10.3.2): each frame's segmentation regions
// are linked to the last frames' by phases, each run only on what the earlier ones left
// unmatched, fastest first:
//   1. feed-forward tracking: a region seeded from a last-frame region (its donor, segmenter.h)
//      continues that region's track (the region with most seeds from a donor keeps it);
//   2. MSER tracking: candidates near each unmatched last-frame region from a kd-tree over this
//      frame's unmatched centroids, kept when similar enough in position, size (second-moment
//      width and height) and mean colour, then linked greedily, most similar first;
//   3. line-corner tracking: not built yet;
//   4. secondary MSER tracking: tracks lost within the last `window` frames (n < 8), at the
//      place their motion model predicts, against what is still unmatched, with looser limits.
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
  double loose = 2.0;           // its limits are this many times phase 2's
  int min_size = 24;            // smaller regions are not tracked (MIN-SIZE)
};

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
};

class RegionTracker {
 public:
  explicit RegionTracker(RegionTrackerParams params = {}) : p_(params) {}
  // Links this frame's regions to the tracks; returns the track id of every region (-1 for
  // regions under min_size).
  const std::vector<int64_t>& update(const Segmentation& s);
  void reset();
  // Live tracks (matched this frame) and lost ones still looked for.
  const std::vector<RegionTrack>& tracks() const { return tracks_; }
  // Regions matched by each phase this frame.
  struct PhaseCounts {
    int feed_forward = 0, mser = 0, secondary = 0, created = 0;
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
