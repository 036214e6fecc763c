// Object models of the colour MSER system (chapter 10.3.4, "Object Modelling"): an object (the
// set of its foreground regions) is described by many invariant features of low individual
// value, stored in a hash table, and recognised by a vote that must agree on its size and place.
//
// Features. A feature value compares two positive quantities a and b as the chapter's
//   v = 1 - a/b if a < b, else -(1 - b/a)        (in -1..1, 0 when equal)
//   - MSER-pair (4-D), for regions i and j: v1 = (red_i/grn_i) vs (red_j/grn_j), v2 = (blu_i/grn_i)
//     vs (blu_j/grn_j), v3 = sqrt(area_i) vs sqrt(area_j), v4 = the distance between their
//     centroids vs the sum of their ellipses' diameters along the line joining the centroids
//     (the ellipse of the second moments, whose axis-aligned diameters are the region's width and
//     height, 2 sqrt(variance)). Invariant to translation, scale and rotation of the object, and
//     v1, v2 to a brightness change. Stored in both orders (i, j) and (j, i); looked up in one.
//   - MSER-individual (3-D): v1 = red vs grn, v2 = blu vs grn, v3 = 2 straightness - 1, where
//     straightness is the share of the region's boundary on lines (the chapter's curvature
//     measure: 1 for a region bound by lines, a parallelogram; 0 for one not bound by lines; the
//     caller measures it, 0 when unknown). Colours get 1 added before a ratio (no zero division).
//   - Size-position (for the vote only): per region, sqrt(area) over sqrt(the object's area, the
//     sum of its regions'), and its position in the object: its offset from the object's centre
//     (area-weighted centroid) in units of sqrt(the object's area) (the chapter's vertical
//     position, in both axes: people stand upright, so the offset is not rotated).
//
// Hash table. Each feature value is quantised into bins of `bin` (so 8 per dimension by
// default); the key is the feature type and its bins; a key maps to the (model, region or pair)
// entries with that key. A lookup probes the feature's cell and, in each dimension where the
// value lies within `probe` of a bin edge, the neighbouring cell too (at most 16 cells): a
// constant-time search. A probed entry counts when every dimension is within `tolerance`.
//
// Recognition. Every matched feature votes for its model with the object scale (sqrt of area)
// and centre it implies: a region of area A at c matched to a model region of size-position
// (s, d) implies scale S = sqrt(A) / s and centre c - S d; a pair implies them from its two
// regions' summed sizes and mean offset. Per model, the vote with the most votes agreeing with it
// (scales within a ratio of `scale_agree`, centres within `centre_agree` of the scale) is its
// tally, counting each query feature once. The winner is the model with the highest tally, if
// that is at least `min_votes` and `min_fraction` of the smaller of the two objects' feature
// counts. Ties go to the lower id. Deterministic: no iteration over the hash table.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <unordered_map>
#include <vector>

#include <opencv2/core.hpp>

#include "vision/mser/segmenter.h"

namespace vigil::vision::mser {

// A foreground region as the object model sees it.
struct ModelRegion {
  cv::Point2f centroid;
  float cxx = 0, cyy = 0, cxy = 0;  // second moments (covariance, px^2)
  float area = 0;                   // pixels
  cv::Vec3f colour;                 // mean, BGR
  float straightness = 0;           // share of its boundary on lines (0..1)
  static ModelRegion from(const Region& r, float straightness = 0);
};

struct ObjectModelParams {
  double bin = 0.25;          // feature quantisation step (values in -1..1)
  double probe = 0.06;        // a value this close to a bin edge probes the neighbour cell too
  double tolerance = 0.1;     // a probed entry matches when every dimension is within this
  double scale_agree = 1.25;  // votes agree: scales within this ratio ...
  double centre_agree = 0.25; // ... and centres within this many times the scale
  int min_votes = 4;          // a winner has at least this many agreeing votes ...
  double min_fraction = 0.3;  // ... and this share of the smaller object's features
  int max_regions = 20;       // an object's largest regions are used (pairs grow quadratically)
};

// The chapter's comparison of two positive quantities: 1 - a/b if a < b, else -(1 - b/a).
float compare_value(double a, double b);
// The diameter of a region's second-moment ellipse along a unit direction (its width along x).
double diameter_along(const ModelRegion& r, cv::Point2f direction);
std::array<float, 4> pair_feature(const ModelRegion& a, const ModelRegion& b);
std::array<float, 3> individual_feature(const ModelRegion& r);

// An object's features: its regions' size-position and the pair and individual features.
struct ObjectDescription {
  std::vector<ModelRegion> regions;  // the largest, at most max_regions, largest first
  float scale = 0;                   // sqrt(the regions' summed area)
  cv::Point2f centre;                // area-weighted centroid
  std::vector<float> size;           // per region: sqrt(area) / scale
  std::vector<cv::Point2f> offset;   // per region: (centroid - centre) / scale
  std::vector<std::array<int, 2>> pairs;  // every ordered pair (i, j), i != j
  std::vector<std::array<float, 4>> pair_features;
  std::vector<std::array<float, 3>> individual_features;
  int feature_count() const { return static_cast<int>(pairs.size() / 2 + individual_features.size()); }
};
// False with `error` when there is no region, or a region has no area or non-finite values.
bool describe_object(const std::vector<ModelRegion>& regions, const ObjectModelParams& params,
                     ObjectDescription* out, std::string* error = nullptr);

struct Recognition {
  bool recognised = false;
  int64_t id = 0;       // the winning model
  int votes = 0;        // its agreeing votes (not recognised: the best tally of any model)
  float scale = 0;      // the object's scale (sqrt of area) and centre the votes agree on
  cv::Point2f centre;
  int candidates = 0;   // models that received a vote
};

// The models of known objects, in a hash table of their features.
class ObjectModels {
 public:
  explicit ObjectModels(ObjectModelParams params = {}) : p_(params) {}
  // Adds (or replaces) the model of object `id` from its regions. False with `error` on bad
  // regions (describe_object's reasons).
  bool add(int64_t id, const std::vector<ModelRegion>& regions, std::string* error = nullptr);
  bool remove(int64_t id);
  bool contains(int64_t id) const { return models_.count(id) > 0; }
  size_t size() const { return models_.size(); }
  void clear();
  // The known object these regions show, if any (an empty or bad set: not recognised, with
  // `error` when bad).
  Recognition recognise(const std::vector<ModelRegion>& regions, std::string* error = nullptr) const;
  // Entries in the hash table (both orders of every pair, and every region).
  size_t entries() const { return entries_; }
  const ObjectModelParams& params() const { return p_; }

 private:
  struct Entry {
    int64_t model;
    int a, b;  // model regions (b = -1: an individual feature)
  };
  template <size_t N>
  void probe_keys(int type, const std::array<float, N>& v, std::vector<uint64_t>* keys) const;
  template <size_t N>
  uint64_t key_of(int type, const std::array<float, N>& v) const;
  void rebuild();

  ObjectModelParams p_;
  std::map<int64_t, ObjectDescription> models_;
  std::unordered_map<uint64_t, std::vector<Entry>> table_;  // looked up only, never iterated
  size_t entries_ = 0;
};

}  // namespace vigil::vision::mser
