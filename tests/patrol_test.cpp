// planning/patrol: graph files, tours, strategies, idleness.
#include <gtest/gtest.h>

#include <numeric>
#include <set>

#include "common/rng.h"
#include "planning/patrol/idleness.h"
#include "planning/patrol/patrol_graph.h"
#include "planning/patrol/strategy.h"
#include "planning/patrol/tour.h"
#include "tests/test_util.h"

namespace vigil::planning::patrol {
namespace {

// A 3-vertex path graph in patrolling_sim's format: 0 -- 1 -- 2, 20 px apart at 0.1 m/px.
const char* kPath3 = "3\n100\n100\n0.1\n0\n0\n\n0\n10\n10\n1\n1\nE\n20\n\n1\n30\n10\n2\n0\nW\n20\n2\nE\n20\n\n2\n50\n10\n1\n1\nW\n20\n";

TEST(PatrolGraph, ReadsPatrollingSimFormat) {
  auto g = PatrolGraph::parse(kPath3, "path3.graph");
  ASSERT_TRUE(g) << g.error().str();
  ASSERT_EQ(g->size(), 3u);
  EXPECT_DOUBLE_EQ(g->vertex(1).position.x, 3.0);
  EXPECT_DOUBLE_EQ(g->vertex(1).position.y, 1.0);
  ASSERT_EQ(g->vertex(1).edges.size(), 2u);
  EXPECT_DOUBLE_EQ(g->vertex(1).edges[1].cost, 2.0);
  EXPECT_DOUBLE_EQ(g->total_edge_cost(), 4.0);
  EXPECT_EQ(g->nearest({4.9, 1.2}), 2);
  // Written back and read again: the same graph.
  auto again = PatrolGraph::parse(g->to_text(100, 100), "again");
  ASSERT_TRUE(again) << again.error().str();
  EXPECT_DOUBLE_EQ(again->total_edge_cost(), 4.0);
  EXPECT_EQ(again->vertex(2).position, g->vertex(2).position);
}

TEST(PatrolGraph, BrokenFilesNameTheLineAndWhat) {
  struct Case {
    std::string text, want;
    int line;
  };
  const std::vector<Case> cases = {
      {"3\n100\n100\nx\n0\n0\n", "'x' is not a number", 4},
      {"2\n100\n100\n0.1\n0\n0\n0\n1\n1\n1\n1\nE\n5\n0\n1\n1\n1\n0\nW\n5\n", "ids must be 0..n-1", 14},
      {"2\n100\n100\n0.1\n0\n0\n0\n1\n1\n1\n7\nE\n5\n", "whole number from 0 to 1", 11},
      {"2\n100\n100\n0.1\n0\n0\n0\n1\n1\n1\n1\nQ\n5\n1\n2\n2\n1\n0\nW\n5\n", "not a compass letter", 12},
      {"2\n100\n100\n0.1\n0\n0\n0\n1\n1\n1\n1\nE\n-5\n1\n2\n2\n1\n0\nW\n5\n", "must not be negative", 13},
      {"2\n100\n100\n0.1\n0\n0\n0\n1\n1\n1\n1\nE\n5\n", "the file ends", 13},
      {"2\n100\n100\n0.1\n0\n0\n0\n1\n1\n1\n1\nE\n5\n1\n2\n2\n0\n", "not listed back", 0},
      {"3\n100\n100\n0.1\n0\n0\n0\n1\n1\n1\n1\nE\n5\n1\n2\n2\n1\n0\nW\n5\n2\n9\n9\n0\n", "in pieces", 0},
  };
  for (const Case& c : cases) {
    auto g = PatrolGraph::parse(c.text, "bad.graph");
    ASSERT_FALSE(g) << c.want;
    EXPECT_NE(g.error().str().find(c.want), std::string::npos) << g.error().str();
    EXPECT_EQ(g.error().file, "bad.graph");
    if (c.line) {
      EXPECT_EQ(g.error().line, c.line) << g.error().str();
    }
  }
  auto missing = PatrolGraph::read("/nonexistent/x.graph");
  ASSERT_FALSE(missing);
  EXPECT_NE(missing.error().str().find("cannot open"), std::string::npos);
}

TEST(Tour, ClosedWalkOfATreeTraversesEveryEdgeTwice) {
  // A star: centre 0 and four arms of different lengths.
  auto g = PatrolGraph::from_edges({{0, 0}, {3, 0}, {0, 2}, {-4, 0}, {0, -1}}, {{0, 1}, {0, 2}, {0, 3}, {0, 4}});
  ASSERT_TRUE(g);
  GraphDistances d(*g);
  const ClosedWalk w = closed_walk(*g, d);
  EXPECT_NEAR(w.length, 2 * g->total_edge_cost(), 1e-9);
  // Consecutive walk vertices are neighbours, every vertex is on it.
  std::vector<int> seen(g->size(), 0);
  for (size_t i = 0; i < w.vertices.size(); ++i) {
    const int a = w.vertices[i], b = w.vertices[(i + 1) % w.vertices.size()];
    ++seen[a];
    EXPECT_NEAR(d.cost(a, b), (g->vertex(a).position - g->vertex(b).position).norm(), 1e-9);
  }
  for (int s : seen) EXPECT_GE(s, 1);
}

TEST(Tour, FindsTheOptimumOnSmallInstances) {
  // Random points in the plane (complete graph, Euclidean): compare with brute force.
  Rng rng(7);
  for (int trial = 0; trial < 20; ++trial) {
    const int n = 7;
    std::vector<Vec2> p;
    for (int i = 0; i < n; ++i) p.push_back({rng.uniform(0, 10), rng.uniform(0, 10)});
    CostMatrix c(n);
    for (int a = 0; a < n; ++a)
      for (int b = 0; b < n; ++b) c.set(a, b, (p[a] - p[b]).norm());
    std::vector<int> all(n);
    std::iota(all.begin(), all.end(), 0);
    const std::vector<int> t = solve_tour(c, all);
    ASSERT_EQ(t.size(), static_cast<size_t>(n));
    std::vector<int> perm(all.begin() + 1, all.end());
    double best = 1e18;
    do {
      std::vector<int> q{0};
      q.insert(q.end(), perm.begin(), perm.end());
      best = std::min(best, tour_cost(c, q));
    } while (std::next_permutation(perm.begin(), perm.end()));
    EXPECT_LE(tour_cost(c, t), best * 1.02 + 1e-9) << "trial " << trial;
  }
}

TEST(Tour, RealDiagGraphsMatchThePublishedReference) {
  VIGIL_REQUIRE_SHARED_DATA();
  // MISSION.md: about 155 m on DIAG_labs (a tree: twice its edges) and 413 m on DIAG_floor1.
  for (auto [name, ref] : {std::pair<const char*, double>{"DIAG_labs", 155.0}, {"DIAG_floor1", 413.0}}) {
    auto g = PatrolGraph::read(test::shared_data() / "maps" / name / (std::string(name) + ".graph"));
    ASSERT_TRUE(g) << g.error().str();
    GraphDistances d(*g);
    const ClosedWalk w = closed_walk(*g, d);
    EXPECT_LE(w.length, ref * 1.01) << name;
    EXPECT_GE(w.length, ref * 0.97) << name;
  }
}

std::shared_ptr<const PatrolSetup> line_setup(int n, double spacing) {
  std::vector<Vec2> p;
  std::vector<std::pair<int, int>> e;
  for (int i = 0; i < n; ++i) p.push_back({i * spacing, 0});
  for (int i = 0; i + 1 < n; ++i) e.push_back({i, i + 1});
  auto g = PatrolGraph::from_edges(p, e);
  return PatrolSetup::make(*g, {}, 1.0);
}

TEST(Strategy, CyclicSpreadsTheTeamEvenlyAndFollowsTheWalk) {
  // A ring of 8 vertices 1 m apart... as a cycle graph.
  std::vector<Vec2> p;
  std::vector<std::pair<int, int>> e;
  for (int i = 0; i < 8; ++i) p.push_back({std::cos(i * M_PI / 4) * 4, std::sin(i * M_PI / 4) * 4});
  for (int i = 0; i < 8; ++i) e.push_back({i, (i + 1) % 8});
  auto setup = PatrolSetup::make(*PatrolGraph::from_edges(p, e), {}, 1.0);
  ASSERT_EQ(setup->tour.vertices.size(), 8u);
  // Two robots both near vertex 0: one keeps it, the other goes to the far side.
  std::vector<int> starts;
  for (int me = 0; me < 2; ++me) {
    auto s = make_strategy("cyclic", setup);
    ASSERT_TRUE(s);
    (*s)->set_team({"a", "b"}, {p[0], p[0] + Vec2{0.1, 0}}, me);
    PatrolKnowledge k;
    k.last_visit.assign(8, 0);
    const int first = (*s)->next(-1, p[0], k);
    starts.push_back(first);
    // Then it walks the ring one neighbour at a time.
    int at = first;
    for (int step = 0; step < 10; ++step) {
      const int nx = (*s)->next(at, p[at], k);
      EXPECT_NE(nx, at);
      EXPECT_NEAR(setup->distances.cost(at, nx), (p[at] - p[nx]).norm(), 1e-9);
      at = nx;
    }
  }
  EXPECT_NEAR(setup->distances.cost(starts[0], starts[1]), setup->tour.length / 2, 1e-6);
}

// A comb: a spine of 6 vertices 4 m apart with a 1 m stub at each (a tree like DIAG_labs').
std::shared_ptr<const PatrolSetup> comb_setup() {
  std::vector<Vec2> p;
  std::vector<std::pair<int, int>> e;
  for (int i = 0; i < 6; ++i) p.push_back({i * 4.0, 0});
  for (int i = 0; i < 6; ++i) p.push_back({i * 4.0, 1.0});
  for (int i = 0; i + 1 < 6; ++i) e.push_back({i, i + 1});
  for (int i = 0; i < 6; ++i) e.push_back({i, i + 6});
  return PatrolSetup::make(*PatrolGraph::from_edges(p, e), {}, 1.0);
}

TEST(Strategy, CyclicFormationGivesEveryMemberItsOwnEvenSlot) {
  auto setup = comb_setup();
  const double L = setup->tour.length;
  ASSERT_NEAR(L, 2 * (20.0 + 6.0), 1e-9);
  for (int n : {2, 3, 4, 6}) {
    std::vector<std::string> names;
    std::vector<Vec2> where;
    for (int k = 0; k < n; ++k) {
      names.push_back("r" + std::to_string(k));
      where.push_back(setup->graph.vertex(static_cast<size_t>((k * 5) % 12)).position + Vec2{0.1, 0.05});
    }
    std::vector<double> slots;
    for (int me = 0; me < n; ++me) {
      auto s = make_strategy("cyclic", setup);
      ASSERT_TRUE(s);
      (*s)->set_team(names, where, me);
      slots.push_back((*s)->phase(0));  // the arc of the walk vertex it heads for first
    }
    std::sort(slots.begin(), slots.end());
    for (int k = 0; k < n; ++k) {
      const double gap = std::fmod(slots[(k + 1) % n] - slots[k] + L, L);
      // Each heads for the first walk vertex at or after its slot: within an edge (4 m) of even.
      EXPECT_NEAR(gap, L / n, 4.0 + 1e-6) << n << " robots";
    }
  }
}

TEST(Strategy, CyclicPaceSlowsTheRobotNearerTheOneAhead) {
  EXPECT_DOUBLE_EQ(spacing_pace(10, 10, 10, 2.0, 0.3), 1.0);   // even
  EXPECT_DOUBLE_EQ(spacing_pace(12, 8, 10, 2.0, 0.3), 1.0);    // nearer the one behind: full speed
  EXPECT_NEAR(spacing_pace(8, 12, 10, 2.0, 0.3), 0.6, 1e-9);   // 1 - 2 x 4 / 20
  EXPECT_NEAR(spacing_pace(8, 12, 10, 2.0, 0.3, 0.1), 0.7, 1e-9);  // a tenth of the spacing tolerated
  EXPECT_DOUBLE_EQ(spacing_pace(9.6, 10.4, 10, 2.0, 0.3, 0.1), 1.0);
  EXPECT_DOUBLE_EQ(spacing_pace(1, 19, 10, 2.0, 0.3), 0.3);    // never slower than min_pace
  auto setup = comb_setup();
  const double L = setup->tour.length;
  StrategyParams sp;
  sp.pace_band = 0;
  auto s = make_strategy("cyclic", setup, sp);
  ASSERT_TRUE(s);
  (*s)->set_team({"a"}, {setup->graph.vertex(0).position}, 0);
  const double at = (*s)->phase(0);
  EXPECT_NEAR((*s)->phase(1.5), std::fmod(at - 1.5 + L, L), 1e-9);
  EXPECT_DOUBLE_EQ((*s)->pace(at, {}), 1.0);                                    // alone
  EXPECT_DOUBLE_EQ((*s)->pace(at, {std::fmod(at + L / 2, L)}), 1.0);            // even
  EXPECT_LT((*s)->pace(at, {std::fmod(at + L / 4, L)}), 1.0);                   // a quarter ahead
  EXPECT_DOUBLE_EQ((*s)->pace(at, {std::fmod(at + 3 * L / 4, L)}), 1.0);        // a quarter behind
  EXPECT_DOUBLE_EQ((*s)->pace(at, {-1.0}), 1.0);                                // a mate off the walk
  // Other strategies have no shared walk.
  auto g = make_strategy("greedy", setup);
  EXPECT_LT((*g)->phase(0), 0);
  EXPECT_DOUBLE_EQ((*g)->pace(0, {1.0}), 1.0);
  sp.min_pace = 2;
  EXPECT_FALSE(make_strategy("cyclic", setup, sp));
}

TEST(Strategy, PartitionGivesEachRobotItsOwnRegion) {
  auto setup = line_setup(10, 2.0);
  std::vector<std::set<int>> regions(2);
  for (int me = 0; me < 2; ++me) {
    auto s = make_strategy("partition", setup);
    (*s)->set_team({"a", "b"}, {{0, 0}, {18, 0}}, me);
    PatrolKnowledge k;
    k.last_visit.assign(10, 0);
    int at = -1;
    for (int step = 0; step < 30; ++step) {
      at = (*s)->next(at, {}, k);
      regions[me].insert(at);
    }
  }
  // Together they cover the line; each covers less than all of it.
  std::set<int> all = regions[0];
  all.insert(regions[1].begin(), regions[1].end());
  EXPECT_EQ(all.size(), 10u);
  EXPECT_LT(regions[0].size(), 10u);
  EXPECT_LT(regions[1].size(), 10u);
  EXPECT_TRUE(regions[0].count(0));
  EXPECT_TRUE(regions[1].count(9));
}

TEST(Strategy, GreedyTradesIdlenessAgainstTravelAndAvoidsOthersTargets) {
  auto setup = line_setup(5, 10.0);  // 0..40 m
  auto s = make_strategy("greedy", setup, {1.0});
  ASSERT_TRUE(s);
  PatrolKnowledge k;
  k.now = 100;
  k.last_visit = {100, 90, 95, 20, 0};
  // From 0: vertex 3 (idle 80, 30 s away: 50) beats 4 (idle 100, 40 s: 60)? 4 wins: 60 > 50.
  EXPECT_EQ((*s)->next(0, {0, 0}, k), 4);
  // Another robot is heading for 4: the next best.
  k.others["b"] = {4, 130};
  EXPECT_EQ((*s)->next(0, {0, 0}, k), 3);
  // A larger theta prefers what is near.
  auto near = make_strategy("greedy", setup, {5.0});
  k.others.clear();
  EXPECT_EQ((*near)->next(0, {0, 0}, k), 1);
  EXPECT_FALSE(make_strategy("spiral", setup));
  EXPECT_NE(make_strategy("spiral", setup).error().str().find("cyclic, partition, greedy"), std::string::npos);
}

TEST(Idleness, IntervalsAfterTheFirstVisit) {
  std::vector<Visit> v = {{0, 0, "a"}, {10, 0, "a"}, {30, 0, "b"}, {5, 1, "a"}, {25, 1, "b"}};
  const IdlenessStats s = idleness(v, 3, 40);
  EXPECT_EQ(s.visits, 5);
  EXPECT_EQ(s.intervals, 3);  // 10, 20 on vertex 0; 20 on vertex 1
  EXPECT_NEAR(s.average, 50.0 / 3, 1e-9);
  EXPECT_DOUBLE_EQ(s.worst, 20);
  EXPECT_DOUBLE_EQ(s.median, 20);
  EXPECT_NEAR(s.stddev, std::sqrt((std::pow(10 - 50.0 / 3, 2) + 2 * std::pow(20 - 50.0 / 3, 2)) / 3), 1e-9);
  EXPECT_EQ(s.unvisited, 1);
  EXPECT_DOUBLE_EQ(s.longest_open, 40);
  EXPECT_DOUBLE_EQ(s.vertex_average[0], 15);
}

TEST(Idleness, VisitsNeedLeavingBeforeCountingAgain) {
  VisitDetector det({{0, 0}, {10, 0}}, 1.0);
  // Drives from 0 to 10 and back, sampled every 0.5 m, lingering near 10.
  double t = 0;
  for (double x = 0; x <= 10; x += 0.5) det.observe("a", t++, {x, 0});
  det.observe("a", t++, {9.2, 0});  // still within 1.5 r of 10: not a new visit
  det.observe("a", t++, {10, 0});
  for (double x = 10; x >= 0; x -= 0.5) det.observe("a", t++, {x, 0});
  ASSERT_EQ(det.visits().size(), 3u);
  EXPECT_EQ(det.visits()[0].vertex, 0);
  EXPECT_EQ(det.visits()[1].vertex, 1);
  EXPECT_EQ(det.visits()[2].vertex, 0);
  InterferenceCounter ic(2.0);
  ic.observe({{"a", {0, 0}}, {"b", {5, 0}}});
  ic.observe({{"a", {0, 0}}, {"b", {1.5, 0}}});
  ic.observe({{"a", {0, 0}}, {"b", {2.2, 0}}});  // not yet apart
  ic.observe({{"a", {0, 0}}, {"b", {1.0, 0}}});
  ic.observe({{"a", {0, 0}}, {"b", {3.0, 0}}});
  ic.observe({{"a", {0, 0}}, {"b", {1.0, 0}}});
  EXPECT_EQ(ic.count(), 2);
}

}  // namespace
}  // namespace vigil::planning::patrol
