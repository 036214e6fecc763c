// Tests the MOT metrics (vision/mot_metrics.h) and their assignment solver
// (vision/linear_assignment.h): the solver against brute force on random small matrices with
// forbidden pairs; hand-worked frames for matches, misses, false positives, switches,
// fragmentations, the keep-previous-match rule, box IoU and point distances; the MOTChallenge
// loader and its errors; and py-motmetrics 1.4.0's figures on TUD-Campus and TUD-Stadtmitte
// (../shared/data/mot, REFERENCE_METRICS_motmetrics-1.4.0.txt) to 1e-4.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <ostream>
#include <random>

#include "tests/test_util.h"
#include "common/linear_assignment.h"
#include "vision/mot_metrics.h"

namespace vigil::vision {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// ---- assignment solver ----

struct Best {
  int count = -1;
  double cost = 0;
};

// Every partial matching: the most pairs on allowed entries, then the least cost.
void brute_force(const CostMatrix& m, int row, std::vector<char>& used, int count, double cost, Best* best) {
  if (row == m.rows) {
    if (count > best->count || (count == best->count && cost < best->cost - 1e-12)) *best = {count, cost};
    return;
  }
  brute_force(m, row + 1, used, count, cost, best);  // row left out
  for (int c = 0; c < m.cols; ++c) {
    if (used[c] || !std::isfinite(m.at(row, c))) continue;
    used[c] = 1;
    brute_force(m, row + 1, used, count + 1, cost + m.at(row, c), best);
    used[c] = 0;
  }
}

TEST(MotAssignment, MatchesBruteForceOnRandomMatrices) {
  std::mt19937 rng(12345);
  std::uniform_int_distribution<int> size(1, 6);
  std::uniform_real_distribution<double> value(-3.0, 10.0);
  std::uniform_real_distribution<double> coin(0.0, 1.0);
  for (int trial = 0; trial < 3000; ++trial) {
    CostMatrix m(size(rng), size(rng));
    const double p_forbidden = coin(rng) * 0.8;
    const bool integers = trial % 3 == 0;  // many ties
    for (double& c : m.costs) {
      if (coin(rng) < p_forbidden) {
        c = trial % 2 ? kNaN : kInf;
      } else {
        c = integers ? std::floor(value(rng) / 3) : value(rng);
      }
    }
    const auto pairs = solve_linear_assignment(m);
    std::vector<char> row_used(m.rows, 0), col_used(m.cols, 0);
    for (const auto& [r, c] : pairs) {
      ASSERT_TRUE(r >= 0 && r < m.rows && c >= 0 && c < m.cols);
      ASSERT_FALSE(row_used[r] || col_used[c]) << "row or column used twice, trial " << trial;
      row_used[r] = col_used[c] = 1;
      ASSERT_TRUE(std::isfinite(m.at(r, c))) << "forbidden pair chosen, trial " << trial;
    }
    Best best;
    std::vector<char> used(m.cols, 0);
    brute_force(m, 0, used, 0, 0.0, &best);
    ASSERT_EQ(static_cast<int>(pairs.size()), best.count) << "trial " << trial << " " << m.rows << "x" << m.cols;
    ASSERT_NEAR(assignment_cost(m, pairs), best.cost, 1e-9) << "trial " << trial << " " << m.rows << "x" << m.cols;
  }
}

TEST(MotAssignment, KnownCasesAndEdges) {
  // The classic 3x3: optimum 0->1, 1->0, 2->2 with cost 1 + 2 + 2 = 5.
  CostMatrix m(3, 3);
  m.costs = {4, 1, 3, 2, 0, 5, 3, 2, 2};
  EXPECT_EQ(solve_linear_assignment(m), (std::vector<std::pair<int, int>>{{0, 1}, {1, 0}, {2, 2}}));
  // More pairs beat a cheaper single pair: {0->0 (0)} alone costs less than {0->1, 1->0} (18),
  // but the second has two pairs.
  CostMatrix f(2, 2);
  f.costs = {0, 9, 9, kNaN};
  EXPECT_EQ(solve_linear_assignment(f), (std::vector<std::pair<int, int>>{{0, 1}, {1, 0}}));
  // Nothing allowed, nothing to assign.
  EXPECT_TRUE(solve_linear_assignment(CostMatrix(2, 3, kNaN)).empty());
  EXPECT_TRUE(solve_linear_assignment(CostMatrix(0, 4)).empty());
  // Wide and tall.
  CostMatrix w(1, 4);
  w.costs = {5, 3, kInf, 4};
  EXPECT_EQ(solve_linear_assignment(w), (std::vector<std::pair<int, int>>{{0, 1}}));
  CostMatrix t(4, 1);
  t.costs = {5, kNaN, 2, 4};
  EXPECT_EQ(solve_linear_assignment(t), (std::vector<std::pair<int, int>>{{2, 0}}));
}

// ---- hand-worked frames ----

MotItem pt(int64_t id, double x, double y = 0) { return MotItem{id, x, y, 0, 0}; }

MotParams points(double threshold = 0.5) {
  MotParams p;
  p.distance = MotDistance::kPointEuclidean;
  p.max_distance = threshold;
  p.record_events = true;
  return p;
}

std::vector<MotEventType> frame_types(const MotEvaluator& e, int64_t frame) {
  std::vector<MotEventType> out;
  for (const auto& ev : e.events())
    if (ev.frame == frame) out.push_back(ev.type);
  return out;
}

TEST(MotMetrics, SwitchWhenAnObjectChangesHypothesis) {
  MotEvaluator e(points());
  ASSERT_TRUE(e.update(1, {pt(1, 0)}, {pt(10, 0)}));
  ASSERT_TRUE(e.update(2, {pt(1, 0)}, {pt(11, 0.1)}));  // track 10 lost, 11 takes over
  ASSERT_TRUE(e.update(3, {pt(1, 0)}, {pt(11, 0.1)}));
  const MotMetrics m = e.metrics();
  EXPECT_EQ(frame_types(e, 2), std::vector<MotEventType>{MotEventType::kSwitch});
  EXPECT_EQ(frame_types(e, 3), std::vector<MotEventType>{MotEventType::kMatch});
  EXPECT_EQ(m.num_switches, 1);
  EXPECT_EQ(m.num_matches, 2);
  EXPECT_EQ(m.num_ascend, 1);  // 11 was never matched before
  EXPECT_EQ(m.num_fragmentations, 0);
  EXPECT_DOUBLE_EQ(m.mota, 1.0 - 1.0 / 3.0);
  EXPECT_NEAR(m.motp, 0.2 / 3.0, 1e-12);
  // Identity: object 1 pairs with 11 for two frames, with 10 for one.
  EXPECT_EQ(m.idtp, 2);
  EXPECT_EQ(m.idfn, 1);
  EXPECT_EQ(m.idfp, 1);
  EXPECT_DOUBLE_EQ(m.idf1, 2.0 * 2 / (3 + 3));
  EXPECT_DOUBLE_EQ(m.idp, 2.0 / 3.0);
  EXPECT_DOUBLE_EQ(m.idr, 2.0 / 3.0);
  EXPECT_EQ(m.mostly_tracked, 1);
}

TEST(MotMetrics, FragmentationWhenATrackIsLostAndResumed) {
  MotEvaluator e(points());
  ASSERT_TRUE(e.update(1, {pt(1, 0)}, {}));         // missed before ever tracked: no fragment
  ASSERT_TRUE(e.update(2, {pt(1, 0)}, {pt(7, 0)}));
  ASSERT_TRUE(e.update(3, {pt(1, 0)}, {}));         // lost...
  ASSERT_TRUE(e.update(4, {pt(1, 0)}, {}));
  ASSERT_TRUE(e.update(5, {pt(1, 0)}, {pt(7, 0)}));  // ...and resumed by the same track: a fragmentation
  ASSERT_TRUE(e.update(6, {pt(1, 0)}, {}));         // lost at the end: not counted
  const MotMetrics m = e.metrics();
  EXPECT_EQ(m.num_fragmentations, 1);
  EXPECT_EQ(m.num_switches, 0);
  EXPECT_EQ(m.num_misses, 4);
  EXPECT_EQ(m.num_matches, 2);
  EXPECT_EQ(m.partially_tracked, 1);  // 2 of 6 frames
  EXPECT_DOUBLE_EQ(m.mota, 1.0 - 4.0 / 6.0);
  EXPECT_DOUBLE_EQ(m.recall, 2.0 / 6.0);
  EXPECT_DOUBLE_EQ(m.precision, 1.0);
}

TEST(MotMetrics, FalsePositivesAndMissesBeyondTheThreshold) {
  MotEvaluator e(points());
  ASSERT_TRUE(e.update(1, {pt(1, 0)}, {pt(5, 1.0)}));  // 1 m apart: no match
  ASSERT_TRUE(e.update(2, {}, {pt(5, 0)}));            // nothing there
  const MotMetrics m = e.metrics();
  EXPECT_EQ(frame_types(e, 1), (std::vector<MotEventType>{MotEventType::kMiss, MotEventType::kFalsePositive}));
  EXPECT_EQ(m.num_false_positives, 2);
  EXPECT_EQ(m.num_misses, 1);
  EXPECT_EQ(m.num_objects, 1);
  EXPECT_DOUBLE_EQ(m.mota, 1.0 - 3.0);
  EXPECT_TRUE(std::isnan(m.motp));
  EXPECT_EQ(m.mostly_lost, 1);
  EXPECT_EQ(m.idtp, 0);
  EXPECT_DOUBLE_EQ(m.idf1, 0.0);
}

TEST(MotMetrics, KeepsThePreviousMatchWhileItIsWithinTheThreshold) {
  // Frame 2: hypothesis 20 is closer to object 1, but 10 (its match) is still within 0.5 m.
  MotEvaluator e(points());
  ASSERT_TRUE(e.update(1, {pt(1, 0)}, {pt(10, 0.3)}));
  ASSERT_TRUE(e.update(2, {pt(1, 0)}, {pt(10, 0.4), pt(20, 0.0)}));
  EXPECT_EQ(frame_types(e, 2), (std::vector<MotEventType>{MotEventType::kMatch, MotEventType::kFalsePositive}));
  EXPECT_EQ(e.events()[1].hypothesis, 10);
  // Frame 3: 10 drifts beyond the threshold; 20 takes over, a switch.
  ASSERT_TRUE(e.update(3, {pt(1, 0)}, {pt(10, 0.6), pt(20, 0.0)}));
  EXPECT_EQ(frame_types(e, 3), (std::vector<MotEventType>{MotEventType::kSwitch, MotEventType::kFalsePositive}));
  EXPECT_EQ(e.metrics().num_switches, 1);
  EXPECT_EQ(e.metrics().num_false_positives, 2);

  // Without the rule, a plain per-frame assignment would have switched in frame 2. The rule also
  // spans frames in which the object was missed (py-motmetrics 1.4.0)...
  MotEvaluator gap(points());
  ASSERT_TRUE(gap.update(1, {pt(1, 0)}, {pt(10, 0.3)}));
  ASSERT_TRUE(gap.update(2, {pt(1, 0)}, {}));
  ASSERT_TRUE(gap.update(3, {pt(1, 0)}, {pt(10, 0.4), pt(20, 0.0)}));
  EXPECT_EQ(frame_types(gap, 3), (std::vector<MotEventType>{MotEventType::kMatch, MotEventType::kFalsePositive}));
  EXPECT_EQ(gap.metrics().num_fragmentations, 1);
  // ...unless only consecutive matches are kept: then the assignment picks the closer 20.
  MotParams strict = points();
  strict.keep_only_consecutive_matches = true;
  MotEvaluator s(strict);
  ASSERT_TRUE(s.update(1, {pt(1, 0)}, {pt(10, 0.3)}));
  ASSERT_TRUE(s.update(2, {pt(1, 0)}, {}));
  ASSERT_TRUE(s.update(3, {pt(1, 0)}, {pt(10, 0.4), pt(20, 0.0)}));
  EXPECT_EQ(frame_types(s, 3), (std::vector<MotEventType>{MotEventType::kSwitch, MotEventType::kFalsePositive}));
}

TEST(MotMetrics, AssignmentMinimisesTotalDistanceAndCountsTransfers) {
  MotEvaluator e(points(1.0));
  // Greedy would give object 1 hypothesis 10 (0.1) and leave 2 unmatched; the assignment matches both.
  ASSERT_TRUE(e.update(1, {pt(1, 0), pt(2, 0.8)}, {pt(10, 0.1), pt(11, -0.5)}));
  EXPECT_EQ(frame_types(e, 1), (std::vector<MotEventType>{MotEventType::kMatch, MotEventType::kMatch}));
  EXPECT_EQ(e.events()[0].hypothesis, 11);
  EXPECT_EQ(e.events()[1].hypothesis, 10);
  EXPECT_NEAR(e.metrics().motp, (0.5 + 0.7) / 2, 1e-12);
  // Object 2 leaves; object 3 appears on hypothesis 10's position: a transfer (10 changes object)
  // and a migrate (3 was never matched), not a switch.
  ASSERT_TRUE(e.update(2, {pt(1, 0), pt(3, 5)}, {pt(10, 5), pt(11, 0)}));
  EXPECT_EQ(e.metrics().num_switches, 0);
  EXPECT_EQ(e.metrics().num_transfer, 1);
  EXPECT_EQ(e.metrics().num_migrate, 1);
}

TEST(MotMetrics, PointDistanceIsEuclideanMetresWithAnInclusiveThreshold) {
  EXPECT_DOUBLE_EQ(MotEvaluator::distance(MotDistance::kPointEuclidean, pt(1, 1, 1), pt(2, 4, 5)), 5.0);
  MotEvaluator e(points(5.0));
  ASSERT_TRUE(e.update(1, {pt(1, 0, 0), pt(2, 100, 0)}, {pt(10, 3, 4), pt(11, 103, 4.0001)}));
  const MotMetrics m = e.metrics();
  EXPECT_EQ(m.num_matches, 1);  // exactly 5 m matches, just over does not
  EXPECT_EQ(m.num_misses, 1);
  EXPECT_EQ(m.num_false_positives, 1);
  EXPECT_DOUBLE_EQ(m.motp, 5.0);
}

TEST(MotMetrics, BoxDistanceIsOneMinusIou) {
  const MotItem a{1, 0, 0, 10, 10};
  EXPECT_DOUBLE_EQ(MotEvaluator::distance(MotDistance::kBoxIou, a, a), 0.0);
  EXPECT_DOUBLE_EQ(MotEvaluator::distance(MotDistance::kBoxIou, a, MotItem{2, 5, 0, 10, 10}), 1.0 - 50.0 / 150.0);
  EXPECT_DOUBLE_EQ(MotEvaluator::distance(MotDistance::kBoxIou, a, MotItem{2, 0, 0, 10, 5}), 0.5);
  EXPECT_DOUBLE_EQ(MotEvaluator::distance(MotDistance::kBoxIou, a, MotItem{2, 20, 20, 5, 5}), 1.0);
  EXPECT_DOUBLE_EQ(MotEvaluator::distance(MotDistance::kBoxIou, MotItem{1, 0, 0, 0, 0}, MotItem{2, 0, 0, 0, 0}), 1.0);
  MotParams p;
  p.record_events = true;
  MotEvaluator e(p);
  // IoU 0.5 is a match at the MOTChallenge threshold, IoU 1/3 is not.
  ASSERT_TRUE(e.update(1, {a, MotItem{2, 100, 0, 10, 10}}, {MotItem{7, 0, 0, 10, 5}, MotItem{8, 105, 0, 10, 10}}));
  const MotMetrics m = e.metrics();
  EXPECT_EQ(m.num_matches, 1);
  EXPECT_DOUBLE_EQ(m.motp, 0.5);
  EXPECT_EQ(m.num_misses, 1);
  EXPECT_EQ(m.num_false_positives, 1);
}

TEST(MotMetrics, MostlyTrackedPartiallyTrackedMostlyLost) {
  MotEvaluator e(points());
  // Object 1 tracked 5/5, object 2 4/5 (0.8: mostly tracked), object 3 3/5, object 4 0/5.
  for (int f = 0; f < 5; ++f) {
    std::vector<MotItem> hyps = {pt(10, 0)};
    if (f > 0) hyps.push_back(pt(20, 10));
    if (f < 3) hyps.push_back(pt(30, 20));
    ASSERT_TRUE(e.update(f, {pt(1, 0), pt(2, 10), pt(3, 20), pt(4, 30)}, hyps));
  }
  const MotMetrics m = e.metrics();
  EXPECT_EQ(m.num_unique_objects, 4);
  EXPECT_EQ(m.mostly_tracked, 2);
  EXPECT_EQ(m.partially_tracked, 1);
  EXPECT_EQ(m.mostly_lost, 1);
}

TEST(MotMetrics, RejectsOutOfOrderFramesAndRepeatedIds) {
  MotEvaluator e(points());
  ASSERT_TRUE(e.update(5, {pt(1, 0)}, {}));
  const Status back = e.update(5, {pt(1, 0)}, {});
  ASSERT_FALSE(back);
  EXPECT_NE(back.error().str().find("frame 5"), std::string::npos) << back.error().str();
  const Status twice = e.update(6, {pt(1, 0), pt(1, 3)}, {});
  ASSERT_FALSE(twice);
  EXPECT_NE(twice.error().str().find("id 1 appears twice"), std::string::npos) << twice.error().str();
  EXPECT_FALSE(e.update(7, {}, {pt(3, kNaN)}));
  EXPECT_FALSE(e.update(8, {1}, {2, 3}, {0.1}));  // wrong matrix size
  EXPECT_EQ(e.metrics().num_frames, 1);  // failed updates change nothing
}

TEST(MotMetrics, PrecomputedDistances) {
  MotParams p;
  p.max_distance = kInf;  // any finite distance may match
  p.record_events = true;
  MotEvaluator e(p);
  ASSERT_TRUE(e.update(1, {1, 2}, {1, 2, 3}, {0.1, kNaN, 0.3, 0.5, 0.2, 0.3}));
  EXPECT_EQ(frame_types(e, 1), (std::vector<MotEventType>{MotEventType::kMatch, MotEventType::kMatch, MotEventType::kFalsePositive}));
  ASSERT_TRUE(e.update(2, {1, 2}, {1}, {0.2, 0.4}));
  EXPECT_EQ(frame_types(e, 2), (std::vector<MotEventType>{MotEventType::kMatch, MotEventType::kMiss}));
  EXPECT_NEAR(e.metrics().motp, (0.1 + 0.2 + 0.2) / 3, 1e-12);
}

// ---- MOTChallenge files ----

TEST(MotChallenge, ParsesRowsWithCrlfAndSpacesAndFiltersConfidence) {
  const std::string text =
      "1,1,10,20,30,40,1,-1,-1,-1\r\n"
      "1, 2, 50.5, 60, 30, 40, 0, -1, -1, -1\r\n"
      "\r\n"
      "2 1 12 20 30 40 1\n";
  auto all = parse_mot_challenge(text, "gt.txt");
  ASSERT_TRUE(all) << all.error().str();
  ASSERT_EQ(all->size(), 3u);
  EXPECT_EQ((*all)[1].id, 2);
  EXPECT_DOUBLE_EQ((*all)[1].x, 50.5);
  EXPECT_EQ((*all)[2].frame, 2);
  EXPECT_EQ((*all)[2].line, 4);
  MotChallengeLoadOptions gt;
  gt.min_confidence = 1;
  auto kept = parse_mot_challenge(text, "gt.txt", gt);
  ASSERT_TRUE(kept);
  EXPECT_EQ(kept->size(), 2u);  // the conf-0 row is ignored
}

TEST(MotChallenge, MalformedRowsNameTheFileLineAndColumn) {
  struct Case {
    std::string text, expect;
  };
  const std::vector<Case> cases = {
      {"1,1,10,20,30,40,1\n1,2,10,20,30\n", "bad.txt:2: expected at least 7 fields"},
      {"1,1,10,20,30,40,1\n\n1,2,ten,20,30,40,1\n", "bad.txt:3: bb_left: 'ten' is not a finite number"},
      {"1.5,1,10,20,30,40,1\n", "bad.txt:1: frame: '1.5' is not a whole number"},
      {"1,1,10,20,30,nan,1\n", "bad.txt:1: bb_height"},
      {"1,1,10,20,-3,40,1\n", "bad.txt:1: bb_width: negative"},
      {"1,1,10,20,30,40,\n", "bad.txt:1: conf"},
      {"1,4,10,20,30,40,1\r\n2,4,10,20,30,40,1\r\n1,4,11,20,30,40,1\r\n", "bad.txt:3: id: frame 1 lists id 4 again (first on line 1)"},
  };
  for (const auto& c : cases) {
    auto r = parse_mot_challenge(c.text, "bad.txt");
    ASSERT_FALSE(r) << c.text;
    EXPECT_EQ(r.error().kind, ErrorKind::kBadInput);
    EXPECT_NE(r.error().str().find(c.expect), std::string::npos) << r.error().str();
  }
  auto missing = load_mot_challenge("/nonexistent/gt.txt");
  ASSERT_FALSE(missing);
  EXPECT_NE(missing.error().str().find("/nonexistent/gt.txt"), std::string::npos);
}

TEST(MotChallenge, EvaluatesEveryFrameEitherFileNames) {
  // Frame 2 exists only in the ground truth (a miss), frame 3 only in the tracker output (a false positive).
  auto gt = parse_mot_challenge("1,1,0,0,10,10,1\n2,1,0,0,10,10,1\n", "gt.txt");
  auto test = parse_mot_challenge("1,5,0,0,10,10,-1\n3,5,0,0,10,10,-1\n", "test.txt");
  ASSERT_TRUE(gt && test);
  auto m = evaluate_mot_challenge(*gt, *test);
  ASSERT_TRUE(m) << m.error().str();
  EXPECT_EQ(m->num_frames, 3);
  EXPECT_EQ(m->num_matches, 1);
  EXPECT_EQ(m->num_misses, 1);
  EXPECT_EQ(m->num_false_positives, 1);
  EXPECT_DOUBLE_EQ(m->mota, 0.0);
  EXPECT_DOUBLE_EQ(m->motp, 0.0);
  MotParams pts;
  pts.distance = MotDistance::kPointEuclidean;
  EXPECT_FALSE(evaluate_mot_challenge(*gt, *test, pts));
}

// ---- py-motmetrics 1.4.0 on real sequences ----

struct Reference {
  const char* sequence;
  double idf1, idp, idr, recall, precision;
  int unique_objects, mostly_tracked, partially_tracked, mostly_lost;
  int false_positives, misses, switches, fragmentations;
  double mota, motp;
  int transfer, ascend, migrate, frames;
  int idtp, idfn, idfp;  // TrackEval's identity counts (REFERENCE_METRICS_trackeval-1.3.0.txt)
};

// REFERENCE_METRICS_motmetrics-1.4.0.txt (and TrackEval's IDTP/IDFN/IDFP, which agree).
const Reference kReferences[] = {
    {"TUD-Campus", 0.557659, 0.729730, 0.451253, 0.582173, 0.941441, 8, 1, 6, 1, 13, 150, 7, 7, 0.526462, 0.277201,
     2, 7, 2, 71, 162, 197, 60},
    {"TUD-Stadtmitte", 0.644619, 0.819760, 0.531142, 0.608997, 0.939920, 10, 5, 4, 1, 45, 452, 7, 6, 0.564014, 0.345904,
     5, 4, 2, 179, 614, 542, 135},
};

// Names the parameter in test listings.
void PrintTo(const Reference& r, std::ostream* os) { *os << r.sequence; }

class MotReference : public ::testing::TestWithParam<Reference> {};

TEST_P(MotReference, ReproducesPyMotmetrics) {
  VIGIL_REQUIRE_SHARED_DATA();
  const Reference& ref = GetParam();
  const auto dir = test::shared_data() / "mot";
  MotChallengeLoadOptions gt_opts;
  gt_opts.min_confidence = 1;  // as the reference was computed
  auto gt = load_mot_challenge((dir / (std::string(ref.sequence) + ".motmetrics_gt.txt")).string(), gt_opts);
  ASSERT_TRUE(gt) << gt.error().str();
  auto test = load_mot_challenge((dir / (std::string(ref.sequence) + ".test.txt")).string());
  ASSERT_TRUE(test) << test.error().str();
  auto r = evaluate_mot_challenge(*gt, *test);  // IoU, a pair matches when 1 - IoU <= 0.5
  ASSERT_TRUE(r) << r.error().str();
  const MotMetrics& m = *r;
  EXPECT_NEAR(m.mota, ref.mota, 1e-4);
  EXPECT_NEAR(m.motp, ref.motp, 1e-4);
  EXPECT_NEAR(m.idf1, ref.idf1, 1e-4);
  EXPECT_NEAR(m.idp, ref.idp, 1e-4);
  EXPECT_NEAR(m.idr, ref.idr, 1e-4);
  EXPECT_NEAR(m.recall, ref.recall, 1e-4);
  EXPECT_NEAR(m.precision, ref.precision, 1e-4);
  EXPECT_EQ(m.num_unique_objects, ref.unique_objects);
  EXPECT_EQ(m.mostly_tracked, ref.mostly_tracked);
  EXPECT_EQ(m.partially_tracked, ref.partially_tracked);
  EXPECT_EQ(m.mostly_lost, ref.mostly_lost);
  EXPECT_EQ(m.num_false_positives, ref.false_positives);
  EXPECT_EQ(m.num_misses, ref.misses);
  EXPECT_EQ(m.num_switches, ref.switches);
  EXPECT_EQ(m.num_fragmentations, ref.fragmentations);
  EXPECT_EQ(m.num_transfer, ref.transfer);
  EXPECT_EQ(m.num_ascend, ref.ascend);
  EXPECT_EQ(m.num_migrate, ref.migrate);
  EXPECT_EQ(m.num_frames, ref.frames);
  EXPECT_EQ(m.idtp, ref.idtp);
  EXPECT_EQ(m.idfn, ref.idfn);
  EXPECT_EQ(m.idfp, ref.idfp);
}

INSTANTIATE_TEST_SUITE_P(TUD, MotReference, ::testing::ValuesIn(kReferences),
                         [](const auto& info) {
                           std::string name = info.param.sequence;
                           for (char& c : name)
                             if (c == '-') c = '_';
                           return name;
                         });

TEST(MotMetrics, ConsecutiveOnlyVariantDiffersOnlyInTransfersOnTudCampus) {
  VIGIL_REQUIRE_SHARED_DATA();
  const auto dir = test::shared_data() / "mot";
  auto gt = load_mot_challenge((dir / "TUD-Campus.motmetrics_gt.txt").string(), {1.0});
  auto test = load_mot_challenge((dir / "TUD-Campus.test.txt").string());
  ASSERT_TRUE(gt && test);
  MotParams p;
  p.keep_only_consecutive_matches = true;
  auto m = evaluate_mot_challenge(*gt, *test, p);
  ASSERT_TRUE(m);
  EXPECT_EQ(m->num_switches, 7);
  EXPECT_NEAR(m->mota, 0.526462, 1e-4);
  EXPECT_EQ(m->num_transfer, 3);  // py-motmetrics 1.4.0 reports 2: it keeps older matches too
}

}  // namespace
}  // namespace vigil::vision
