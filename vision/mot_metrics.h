// Multi-object-tracking metrics: CLEAR MOT (Bernardin and Stiefelhagen 2008) and the identity
// metrics IDF1 / IDP / IDR (Ristani et al. 2016), computed the way py-motmetrics 1.4.0 computes
// them, so figures compare with published MOTChallenge results. Also a MOTChallenge text loader.
//
// The evaluator is fed one frame at a time with the ground-truth objects and the tracker's
// hypotheses present in that frame, each with an id and either an image box (x, y, w, h in
// pixels; distance 1 - IoU) or a map-frame point (x, y in metres; Euclidean distance). A pair
// can match when its distance is at most MotParams::max_distance. Per frame:
//   1. an object keeps the hypothesis it was last matched to (in whatever earlier frame) when
//      that hypothesis is present and still within the threshold (a MATCH);
//   2. the remaining objects and hypotheses are matched by a minimum-cost assignment over the
//      pairs within the threshold (as many pairs as possible, then the least total distance;
//      common/linear_assignment.h); a pair is a SWITCH when the object's last match was another
//      hypothesis, else a MATCH;
//   3. objects left over are MISSes (false negatives), hypotheses left over FALSE POSITIVES.
// From these: MOTA = 1 - (misses + false positives + switches) / ground-truth count; MOTP =
// mean distance of the matched pairs (1 - IoU for boxes, as py-motmetrics reports it; metres
// for points); fragmentations = times an object's track goes from tracked to missed and is
// picked up again; mostly tracked / partially tracked / mostly lost = objects tracked in at
// least 80% / 20% to 80% / under 20% of the frames they appear in.
// Identity metrics match whole trajectories once, globally: each object to at most one
// hypothesis, maximising IDTP, the number of frames in which the matched pair is within the
// threshold (py-motmetrics' min-cost formulation with fnmatrix + fpmatrix has the same optima);
// IDFN = ground-truth count - IDTP, IDFP = hypothesis count - IDTP, IDP = IDTP / (IDTP + IDFP),
// IDR = IDTP / (IDTP + IDFN), IDF1 = 2 IDTP / (ground-truth count + hypothesis count).
// Ratios whose denominator is zero are NaN.
#pragma once

#include <cstdint>
#include <limits>
#include <map>
#include <string>
#include <string_view>
#include <unordered_map>
#include <unordered_set>
#include <utility>
#include <vector>

#include "common/status.h"

namespace vigil::vision {

enum class MotDistance {
  kBoxIou,          // image boxes; distance 1 - IoU
  kPointEuclidean,  // map-frame points; distance in metres
};

struct MotParams {
  MotDistance distance = MotDistance::kBoxIou;
  // A pair can match when its distance is at most this: 1 - IoU for boxes (0.5: IoU >= 0.5, the
  // MOTChallenge convention), metres for points.
  double max_distance = 0.5;
  // False (py-motmetrics 1.4.0): step 1 keeps an object's last match whenever both are present
  // and within the threshold, however many frames ago the match was made. True: only when the
  // match was made in the immediately preceding frame; otherwise the pair goes to the
  // assignment (a stricter variant; it changes num_transfer on TUD-Campus, 3 instead of 2).
  bool keep_only_consecutive_matches = false;
  // Keep every frame's events (events()), for inspection and tests.
  bool record_events = false;
};

// One ground-truth object or hypothesis in a frame.
struct MotItem {
  int64_t id = 0;
  double x = 0, y = 0;  // box: left, top (px); point: map-frame x, y (m)
  double w = 0, h = 0;  // box: width, height (px); unused for points
};

enum class MotEventType { kMatch, kSwitch, kMiss, kFalsePositive };
std::string_view to_string(MotEventType t);  // "MATCH", "SWITCH", "MISS", "FP"

struct MotEvent {
  int64_t frame = 0;
  MotEventType type = MotEventType::kMatch;
  int64_t object = -1;      // -1 for a false positive
  int64_t hypothesis = -1;  // -1 for a miss
  double distance = std::numeric_limits<double>::quiet_NaN();  // matches and switches only
};

// The figures, named as py-motmetrics names them.
struct MotMetrics {
  int64_t num_frames = 0;
  int64_t num_objects = 0;        // ground-truth count: objects summed over frames
  int64_t num_predictions = 0;    // hypotheses summed over frames
  int64_t num_matches = 0;        // MATCH events
  int64_t num_switches = 0;       // SWITCH events (IDSW)
  int64_t num_detections = 0;     // matches + switches (CLEAR TP)
  int64_t num_false_positives = 0;
  int64_t num_misses = 0;
  int64_t num_fragmentations = 0;
  int64_t num_transfer = 0;       // a hypothesis matched to another object than its last one
  int64_t num_ascend = 0;         // a switch to a hypothesis never matched before
  int64_t num_migrate = 0;        // a transfer to an object never matched before
  int64_t num_unique_objects = 0;
  int64_t num_unique_hypotheses = 0;
  int64_t mostly_tracked = 0, partially_tracked = 0, mostly_lost = 0;
  int64_t idtp = 0, idfp = 0, idfn = 0;
  double mota = 0, motp = 0;      // motp: mean distance of matches and switches
  double recall = 0, precision = 0;
  double idf1 = 0, idp = 0, idr = 0;
};

class MotEvaluator {
 public:
  explicit MotEvaluator(MotParams params = {});

  // One frame. Frame ids must increase from call to call; ids must be unique within each list.
  // Boxes must have finite coordinates and non-negative sizes. Errors are bad input naming the
  // frame and id; the evaluator is unchanged then.
  Status update(int64_t frame, const std::vector<MotItem>& objects, const std::vector<MotItem>& hypotheses);
  // One frame with a precomputed distance matrix (objects x hypotheses, row-major): entries that
  // are not finite or exceed max_distance cannot match.
  Status update(int64_t frame, const std::vector<int64_t>& object_ids, const std::vector<int64_t>& hypothesis_ids,
                const std::vector<double>& distances);

  // The metrics over every frame so far.
  MotMetrics metrics() const;
  // Every frame's events in order (only with MotParams::record_events).
  const std::vector<MotEvent>& events() const { return events_; }
  const MotParams& params() const { return params_; }

  // The distance between two items under `kind` (1 - IoU, or Euclidean metres). Two boxes with
  // no area between them have IoU 0.
  static double distance(MotDistance kind, const MotItem& a, const MotItem& b);

 private:
  struct ObjectState {
    int64_t frames = 0;           // frames the object appears in
    int64_t tracked = 0;          // of those, matched or switched
    bool ever_tracked = false;    // matched at least once so far
    bool lost_after_tracked = false;  // missed since its last match
    int64_t fragmentations = 0;
  };
  struct PairHash {
    size_t operator()(const std::pair<int64_t, int64_t>& p) const {
      return std::hash<int64_t>()(p.first) * 0x9E3779B97F4A7C15ull ^ std::hash<int64_t>()(p.second);
    }
  };

  MotParams params_;
  bool started_ = false;
  int64_t last_frame_ = 0;
  int64_t num_frames_ = 0, num_objects_ = 0, num_predictions_ = 0;
  int64_t matches_ = 0, switches_ = 0, misses_ = 0, false_positives_ = 0;
  int64_t transfers_ = 0, ascends_ = 0, migrates_ = 0;
  double distance_sum_ = 0;
  std::map<int64_t, ObjectState> objects_;                // by object id
  std::map<int64_t, int64_t> hypothesis_frames_;         // frames each hypothesis appears in
  std::unordered_map<int64_t, int64_t> last_hyp_of_object_;   // py-motmetrics `m`
  std::unordered_map<int64_t, int64_t> last_object_of_hyp_;   // py-motmetrics `res_m`
  std::unordered_map<int64_t, int64_t> last_match_frame_;     // py-motmetrics `last_match`
  std::unordered_set<int64_t> ever_matched_hyps_;             // keys of `hypHistory`
  // Frames in which an object and a hypothesis were within the threshold (identity metrics).
  std::unordered_map<std::pair<int64_t, int64_t>, int64_t, PairHash> within_;
  std::vector<MotEvent> events_;
};

// ---- MOTChallenge text files ----

// One row of a MOTChallenge file: frame, id, bb_left, bb_top, bb_width, bb_height, conf, and
// optionally x, y, z (or class, visibility), which are ignored.
struct MotChallengeRow {
  int64_t frame = 0, id = 0;
  double x = 0, y = 0, w = 0, h = 0;  // the box, px
  double confidence = 0;
  int line = 0;  // 1-based line in the file
};

struct MotChallengeLoadOptions {
  // Rows with a confidence below this are dropped. Ground truth is loaded with 1 (MOTChallenge
  // marks rows to ignore with 0), tracker output with the default (keep everything).
  double min_confidence = -std::numeric_limits<double>::infinity();
};

// Parses MOTChallenge text: one row a line, fields separated by commas (spaces around them
// allowed) or by white space; LF or CRLF line ends; blank lines skipped. At least the first 7
// fields; frame and id whole numbers; every field finite; box sizes >= 0; each (frame, id) at
// most once. Errors name `file`, the line and the column.
Result<std::vector<MotChallengeRow>> parse_mot_challenge(std::string_view text, const std::string& file,
                                                         const MotChallengeLoadOptions& options = {});
// Reads and parses a file (errors name the path).
Result<std::vector<MotChallengeRow>> load_mot_challenge(const std::string& path,
                                                        const MotChallengeLoadOptions& options = {});

// Evaluates tracker rows against ground-truth rows with box IoU over every frame that either
// names, in increasing frame order, as py-motmetrics' compare_to_groundtruth(gt, test, 'iou',
// distth=params.max_distance) does. params.distance must be kBoxIou.
Result<MotMetrics> evaluate_mot_challenge(const std::vector<MotChallengeRow>& ground_truth,
                                          const std::vector<MotChallengeRow>& hypotheses, MotParams params = {});

}  // namespace vigil::vision
