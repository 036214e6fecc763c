// The planners of planning/: a conformance suite run on every planner (ours, plain OMPL PRM and
// RRTConnect, the grid reference) on the DIS floorplan and, when present, the real DIAG SLAM
// maps: all queries with a path solved, every path free on the inflated grid, the same path for
// the same seed where the planner promises it. Then the two-level planner's own behaviour:
// outcomes for bad queries (never a hang), going around laser-seen obstacles, roadmap caching
// and the pieces it is built from (clearance field, inflated grid, Lazy Theta*).
#include <gtest/gtest.h>

#include <cmath>

#include "common/rng.h"
#include "planning/grid/any_angle.h"
#include "planning/grid/clearance_field.h"
#include "planning/path_planner.h"
#include "planning/two_level_planner.h"
#include "tests/test_util.h"
#include "world/floorplan.h"
#include "world/map.h"

namespace vigil::planning {
namespace {

OccupancyGrid dis_map() {
  auto fp = load_floorplan(test::source_dir() / "maps" / "dis_labs.floorplan.yaml");
  EXPECT_TRUE(fp.ok());
  return fp->rasterize();
}

// A 20 x 10 m room with a wall across the middle and a 1.2 m gap at its top end.
OccupancyGrid wall_with_gap() {
  OccupancyGrid g(200, 100, 0.1, {0, 0, 0});
  for (int x = 0; x < 200; ++x) g.set(x, 0, Cell::kOccupied), g.set(x, 99, Cell::kOccupied);
  for (int y = 0; y < 100; ++y) g.set(0, y, Cell::kOccupied), g.set(199, y, Cell::kOccupied);
  for (int y = 0; y < 86; ++y) g.set(100, y, Cell::kOccupied), g.set(101, y, Cell::kOccupied);
  return g;
}

std::vector<std::pair<Vec2, Vec2>> queries(const InflatedGrid& g, int n, uint64_t seed) {
  Rng rng(seed);
  int largest = 0;
  for (int c = 1; c < g.component_count(); ++c)
    if (g.component_area(c) > g.component_area(largest)) largest = c;
  std::vector<std::pair<Vec2, Vec2>> out;
  while (static_cast<int>(out.size()) < n) {
    const Vec2 a{rng.uniform(g.lower().x, g.upper().x), rng.uniform(g.lower().y, g.upper().y)};
    const Vec2 b{rng.uniform(g.lower().x, g.upper().x), rng.uniform(g.lower().y, g.upper().y)};
    if (g.component(a) == largest && g.component(b) == largest) out.emplace_back(a, b);
  }
  return out;
}

void expect_path_free(const InflatedGrid& g, const PlanResult& r, Vec2 s, Vec2 t, const std::string& who) {
  ASSERT_GE(r.path.size(), 2u) << who;
  EXPECT_EQ(r.path.front(), s) << who;
  EXPECT_EQ(r.path.back(), t) << who;
  for (size_t k = 1; k < r.path.size(); ++k)
    ASSERT_TRUE(g.segment_free(r.path[k - 1], r.path[k])) << who << " segment " << k;
  EXPECT_NEAR(r.length, path_length(r.path), 1e-9) << who;
}

// The conformance suite: every planner on one map.
void run_conformance(const OccupancyGrid& map, int n, const std::string& map_name) {
  TwoLevelParams params;
  auto ours = TwoLevelPlanner::create(map, params);
  ASSERT_TRUE(ours.ok()) << ours.error().str();
  const InflatedGrid& g = (*ours)->inflated();
  std::vector<std::unique_ptr<PathPlanner>> planners;
  planners.push_back(wrap_two_level(**ours));
  planners.push_back(make_grid_reference(g));
  planners.push_back(make_ompl_baseline(g, OmplBaseline::kPrm, 2.0));
  planners.push_back(make_ompl_baseline(g, OmplBaseline::kRrtConnect, 2.0));
  const auto qs = queries(g, n, 7);
  std::vector<double> optimum;
  auto reference = make_grid_reference(g);
  for (const auto& [s, t] : qs) optimum.push_back(reference->plan(s, t).length);
  for (auto& p : planners) {
    int solved = 0;
    for (size_t i = 0; i < qs.size(); ++i) {
      const auto [s, t] = qs[i];
      const PlanResult r = p->plan(s, t);
      if (r.outcome != PlanOutcome::kExact) continue;
      ++solved;
      expect_path_free(g, r, s, t, map_name + " / " + p->name());
      if (p->deterministic()) {
        const PlanResult again = p->plan(s, t);
        EXPECT_EQ(again.path, r.path) << p->name() << " is not repeatable";
      }
      // Nothing beats the reference by more than grid rounding.
      EXPECT_GE(r.length, optimum[i] * 0.97) << p->name();
    }
    // Plain OMPL planners stop on wall time: on a loaded machine they may miss one.
    if (p->deterministic()) EXPECT_EQ(solved, n) << map_name << " / " << p->name();
    else EXPECT_GE(solved, n - 2) << map_name << " / " << p->name();
  }
}

TEST(PlannerConformance, DisFloorplan) { run_conformance(dis_map(), 12, "dis_labs"); }

TEST(PlannerConformance, RealDiagMaps) {
  if (!test::have_shared_data()) GTEST_SKIP() << "../shared/data is absent: the real DIAG maps are not here";
  for (const char* m : {"DIAG_labs", "DIAG_floor1"}) {
    auto grid = load_map(test::shared_data() / "maps" / m / (std::string(m) + ".yaml"));
    ASSERT_TRUE(grid.ok()) << grid.error().str();
    run_conformance(*grid, 8, m);
  }
}

TEST(TwoLevelPlanner, SameSeedSameRoadmapOtherSeedOtherRoadmap) {
  const OccupancyGrid map = dis_map();
  TwoLevelParams p;
  auto a = TwoLevelPlanner::create(map, p);
  auto b = TwoLevelPlanner::create(map, p);
  p.roadmap.seed = 2;
  auto c = TwoLevelPlanner::create(map, p);
  ASSERT_TRUE(a.ok() && b.ok() && c.ok());
  EXPECT_EQ((*a)->roadmap().nodes(), (*b)->roadmap().nodes());
  EXPECT_EQ((*a)->roadmap().edges(), (*b)->roadmap().edges());
  EXPECT_NE((*a)->roadmap().nodes(), (*c)->roadmap().nodes());
  EXPECT_EQ((*a)->roadmap().stats().components, 1u);
}

TEST(TwoLevelPlanner, BadQueriesGetAnOutcomeNotAHang) {
  const OccupancyGrid map = wall_with_gap();
  auto planner = TwoLevelPlanner::create(map, {});
  ASSERT_TRUE(planner.ok());
  const auto& p = **planner;
  EXPECT_EQ(p.plan({-5, 5}, {15, 5}).outcome, PlanOutcome::kInvalidStart);          // outside the map
  EXPECT_EQ(p.plan({5, 5}, {50, 5}).outcome, PlanOutcome::kInvalidGoal);            // outside the map
  EXPECT_EQ(p.plan({5, 5}, {10.05, 5}).outcome, PlanOutcome::kInvalidGoal);         // inside the wall
  EXPECT_EQ(p.plan({NAN, 5}, {15, 5}).outcome, PlanOutcome::kInvalidStart);
  EXPECT_EQ(p.plan({5, 5}, {15, NAN}).outcome, PlanOutcome::kInvalidGoal);
  const PlanResult ok = p.plan({5, 5}, {15, 5});
  ASSERT_EQ(ok.outcome, PlanOutcome::kExact);
  EXPECT_GT(ok.length, 2 * std::hypot(5.0, 3.9) - 0.1);  // round the wall's end at y 8.6
  // A start inside the inflation margin (0.2 m from a wall) is recovered, not refused.
  EXPECT_EQ(p.plan({9.75, 5}, {15, 5}).outcome, PlanOutcome::kExact);
  // Close the gap: the two halves are separate, answered before any search.
  OccupancyGrid closed = map;
  for (int y = 0; y < 100; ++y) closed.set(100, y, Cell::kOccupied);
  auto cp = TwoLevelPlanner::create(closed, {});
  ASSERT_TRUE(cp.ok());
  const PlanResult none = (*cp)->plan({5, 5}, {15, 5});
  EXPECT_EQ(none.outcome, PlanOutcome::kNoPath);
  EXPECT_FALSE(none.detail.empty());
  EXPECT_TRUE(none.path.empty());
}

TEST(TwoLevelPlanner, BadParametersNameTheKey) {
  TwoLevelParams p;
  p.robot_radius = -1;
  EXPECT_NE(p.check("s.yaml", 3).error().str().find("robot_radius"), std::string::npos);
  p = {};
  p.roadmap.neighbours = 0;
  EXPECT_NE(p.check().error().key, "");
  EXPECT_EQ(p.check().error().key, "roadmap.neighbours");
  p = {};
  p.motion.window = 1e9;
  EXPECT_EQ(p.check().error().key, "motion.window");
  const OccupancyGrid empty;
  EXPECT_FALSE(TwoLevelPlanner::create(empty, {}).ok());
  const OccupancyGrid walls(20, 20, 0.1, {0, 0, 0}, Cell::kOccupied);
  EXPECT_FALSE(TwoLevelPlanner::create(walls, {}).ok());
}

TEST(TwoLevelPlanner, GoesAroundWhatTheLaserSeesWithRrtConnect) {
  const OccupancyGrid map = dis_map();
  auto planner = TwoLevelPlanner::create(map, {});
  ASSERT_TRUE(planner.ok());
  const auto& p = **planner;
  // Along the corridor (y 2.0 .. 4.2), a bag-sized cluster of laser points on the straight line.
  const Vec2 s{16, 3.1}, t{26, 3.1};
  std::vector<Vec2> bag;
  for (double x = 20.8; x <= 21.2; x += 0.05) bag.push_back({x, 3.05}), bag.push_back({x, 3.35});
  const LocalObstacles obstacles(bag, p.obstacle_clearance());
  const PlanResult r = p.plan(s, t, &obstacles);
  ASSERT_EQ(r.outcome, PlanOutcome::kExact) << r.detail;
  EXPECT_TRUE(r.used_motion_level);
  for (size_t k = 1; k < r.path.size(); ++k) {
    EXPECT_TRUE(p.inflated().segment_free(r.path[k - 1], r.path[k]));
    EXPECT_TRUE(obstacles.segment_free(r.path[k - 1], r.path[k])) << "segment " << k << " hits the bag";
  }
  EXPECT_LT(r.length, 10.0 * 1.2);
  // Same query, same path.
  EXPECT_EQ(p.plan(s, t, &obstacles).path, r.path);
  // A wall of people across the whole corridor: no way round in the window.
  std::vector<Vec2> crowd;
  for (double y = 2.0; y <= 4.2; y += 0.05) crowd.push_back({21.0, y});
  const LocalObstacles blocked(crowd, p.obstacle_clearance());
  const PlanResult b = p.plan(s, t, &blocked);
  EXPECT_FALSE(b.outcome == PlanOutcome::kExact) << to_string(b.outcome);
  // Someone standing on the goal: the path ends short of it (approximate), clear of them.
  std::vector<Vec2> on_goal;
  for (double a = 0; a < 6.28; a += 0.3) on_goal.push_back({t.x + 0.25 * std::cos(a), t.y + 0.25 * std::sin(a)});
  const LocalObstacles person(on_goal, p.obstacle_clearance());
  const PlanResult q = p.plan({22, 3.1}, t, &person);
  ASSERT_EQ(q.outcome, PlanOutcome::kApproximate) << to_string(q.outcome);
  EXPECT_GE(person.distance(q.path.back()), p.obstacle_clearance() - 1e-9);
}

TEST(TwoLevelPlanner, RoadmapCacheRoundTripsExactly) {
  const OccupancyGrid map = dis_map();
  const auto dir = test::fresh_temp_dir("planner", "cache");
  const auto file = dir / "dis.roadmap";
  auto built = TwoLevelPlanner::create(map, {}, file);
  ASSERT_TRUE(built.ok());
  EXPECT_FALSE((*built)->roadmap().stats().from_cache);
  ASSERT_TRUE(std::filesystem::exists(file));
  auto loaded = TwoLevelPlanner::create(map, {}, file);
  ASSERT_TRUE(loaded.ok());
  EXPECT_TRUE((*loaded)->roadmap().stats().from_cache);
  EXPECT_EQ((*loaded)->roadmap().nodes(), (*built)->roadmap().nodes());
  EXPECT_EQ((*loaded)->plan({6, 3.1}, {12, 8}).path, (*built)->plan({6, 3.1}, {12, 8}).path);
  // Another radius does not reuse it.
  TwoLevelParams wide;
  wide.robot_radius = 0.35;
  auto other = TwoLevelPlanner::create(map, wide, file);
  ASSERT_TRUE(other.ok());
  EXPECT_FALSE((*other)->roadmap().stats().from_cache);
  // A corrupt cache is rebuilt, not trusted.
  { std::ofstream(file) << "vigil-roadmap 1\nfingerprint garbage\n"; }
  auto rebuilt = TwoLevelPlanner::create(map, {}, file);
  ASSERT_TRUE(rebuilt.ok());
  EXPECT_FALSE((*rebuilt)->roadmap().stats().from_cache);
  std::filesystem::remove_all(dir);
}

TEST(ClearanceField, ExactEuclideanDistances) {
  OccupancyGrid g(30, 20, 0.1, {0, 0, 0});
  g.set(10, 10, Cell::kOccupied);
  const ClearanceField f(g);
  EXPECT_FLOAT_EQ(f.at(10, 10), 0.0f);
  EXPECT_FLOAT_EQ(f.at(13, 14), 0.5f);                 // 3-4-5
  EXPECT_NEAR(f.at(11, 11), std::sqrt(2.0) * 0.1, 1e-6);
  EXPECT_FLOAT_EQ(f.at(0, 10), 0.1f);                  // the grid's edge is one cell outside
  EXPECT_FLOAT_EQ(f.at(29, 0), 0.1f);
}

TEST(AnyAngle, StraightWhereNothingIsInTheWayAndTautRoundACorner) {
  const OccupancyGrid map = wall_with_gap();
  const InflatedGrid g(map, 0.3);
  AnyAnglePlanner p(g);
  const ReferencePath straight = p.plan({2, 2}, {8, 7});
  ASSERT_TRUE(straight.found);
  EXPECT_EQ(straight.points.size(), 2u);
  EXPECT_NEAR(straight.length, std::hypot(6.0, 5.0), 1e-9);
  const ReferencePath round = p.plan({5, 5}, {15, 5});
  ASSERT_TRUE(round.found);
  // Taut: via the inflated wall end at about (10.05, 8.6 + 0.3): within a cell of that bound.
  const double bound = 2 * std::hypot(5.05, 3.9);
  EXPECT_GT(round.length, bound - 0.1);
  EXPECT_LT(round.length, bound + 0.2);
}

}  // namespace
}  // namespace vigil::planning
