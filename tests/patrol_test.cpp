// planning/patrol: graph files, tours, balanced partitions, strategies, idleness.
#include <gtest/gtest.h>

#include <functional>
#include <limits>
#include <numeric>
#include <set>

#include "common/rng.h"
#include "planning/patrol/idleness.h"
#include "planning/patrol/partition.h"
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
  EXPECT_DOUBLE_EQ((*s)->pace(at, {{"b", std::fmod(at + L / 2, L)}}), 1.0);            // even
  EXPECT_LT((*s)->pace(at, {{"b", std::fmod(at + L / 4, L)}}), 1.0);                   // a quarter ahead
  EXPECT_DOUBLE_EQ((*s)->pace(at, {{"b", std::fmod(at + 3 * L / 4, L)}}), 1.0);        // a quarter behind
  EXPECT_DOUBLE_EQ((*s)->pace(at, {{"b", -1.0}}), 1.0);                         // a mate off the walk
  // Other strategies have no shared walk.
  auto g = make_strategy("greedy", setup);
  EXPECT_LT((*g)->phase(0), 0);
  EXPECT_DOUBLE_EQ((*g)->pace(0, {{"b", 1.0}}), 1.0);
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
  // The line cut in the middle: a at the west end gets 0..4, b at the east end 5..9, no
  // vertex shared.
  EXPECT_EQ(regions[0], (std::set<int>{0, 1, 2, 3, 4}));
  EXPECT_EQ(regions[1], (std::set<int>{5, 6, 7, 8, 9}));
  // The same members in other places get the other regions.
  auto s = make_strategy("partition", setup);
  (*s)->set_team({"a", "b"}, {{18, 0}, {0, 0}}, 0);
  PatrolKnowledge k;
  k.last_visit.assign(10, 0);
  EXPECT_GE((*s)->next(-1, {}, k), 5);
}

// A random tree (each vertex joined to an earlier one), sometimes with a few extra edges.
PatrolGraph random_graph(Rng& rng, int n, int extra) {
  std::vector<Vec2> p;
  std::vector<std::pair<int, int>> e;
  for (int i = 0; i < n; ++i) p.push_back({rng.uniform(0, 30), rng.uniform(0, 30)});
  for (int i = 1; i < n; ++i) e.push_back({static_cast<int>(rng.uniform(0, i - 1e-9)), i});
  for (int x = 0; x < extra; ++x) {
    const int a = static_cast<int>(rng.uniform(0, n - 1e-9)), b = static_cast<int>(rng.uniform(0, n - 1e-9));
    if (a == b || std::find(e.begin(), e.end(), std::pair<int, int>{a, b}) != e.end() ||
        std::find(e.begin(), e.end(), std::pair<int, int>{b, a}) != e.end()) {
      continue;
    }
    e.push_back({a, b});
  }
  return *PatrolGraph::from_edges(p, e);
}

bool region_connected(const PatrolGraph& g, const std::vector<int>& region, int r) {
  std::vector<int> in;
  for (size_t v = 0; v < region.size(); ++v) {
    if (region[v] == r) in.push_back(static_cast<int>(v));
  }
  if (in.empty()) return false;
  std::set<int> seen{in[0]};
  std::vector<int> stack{in[0]};
  while (!stack.empty()) {
    const int v = stack.back();
    stack.pop_back();
    for (const GraphEdge& e : g.vertex(static_cast<size_t>(v)).edges) {
      if (region[static_cast<size_t>(e.to)] == r && seen.insert(e.to).second) stack.push_back(e.to);
    }
  }
  return seen.size() == in.size();
}

TEST(Partition, RegionsAreConnectedDisjointAndEachWalkVisitsItsRegion) {
  Rng rng(7);
  for (int trial = 0; trial < 40; ++trial) {
    const int n = 6 + trial % 25, k = 1 + trial % 7;
    const PatrolGraph g = random_graph(rng, n, trial % 3 == 0 ? 4 : 0);
    GraphDistances d(g);
    const GraphPartition p = partition_graph(g, d, k);
    ASSERT_EQ(p.count(), std::min(k, n)) << "trial " << trial;
    ASSERT_EQ(p.region.size(), static_cast<size_t>(n));
    double longest = 0;
    for (int r = 0; r < p.count(); ++r) {
      EXPECT_TRUE(region_connected(g, p.region, r)) << "trial " << trial << " region " << r;
      std::set<int> in, walked(p.walks[r].vertices.begin(), p.walks[r].vertices.end());
      for (int v = 0; v < n; ++v) {
        if (p.region[v] == r) in.insert(v);
      }
      EXPECT_FALSE(in.empty()) << "trial " << trial << " region " << r;
      for (int v : in) EXPECT_TRUE(walked.count(v)) << "trial " << trial << " region " << r << " vertex " << v;
      longest = std::max(longest, p.walks[r].length);
    }
    EXPECT_DOUBLE_EQ(p.longest, longest);
    // The same inputs, the same regions.
    EXPECT_EQ(partition_graph(g, d, k).region, p.region);
  }
}

// The best connected partition into k regions by enumeration (small graphs only): the fewest
// regions under `min_size` vertices (a star's leaves cannot all have a second vertex), then
// the least longest walk.
struct Best {
  int undersized = 1 << 30;
  double longest = std::numeric_limits<double>::infinity();
};
Best best_partition(const PatrolGraph& g, const GraphDistances& d, int k, int min_size) {
  const int n = static_cast<int>(g.size());
  const CostMatrix c = CostMatrix::from(d);
  std::vector<int> region(static_cast<size_t>(n), 0);
  Best best;
  // Region labels in first-use order (region of vertex 0 is 0, ...), so each partition once.
  std::function<void(int, int)> go = [&](int v, int used) {
    if (v == n) {
      if (used != k) return;
      Best here;
      here.undersized = 0;
      here.longest = 0;
      for (int r = 0; r < k; ++r) {
        std::vector<int> in;
        for (int u = 0; u < n; ++u) {
          if (region[static_cast<size_t>(u)] == r) in.push_back(u);
        }
        if (!region_connected(g, region, r)) return;
        here.undersized += static_cast<int>(in.size()) < min_size;
        here.longest = std::max(here.longest, in.size() <= 1 ? 0.0 : tour_cost(c, solve_tour(c, in)));
      }
      if (here.undersized < best.undersized || (here.undersized == best.undersized && here.longest < best.longest)) best = here;
      return;
    }
    for (int r = 0; r <= std::min(used, k - 1); ++r) {
      region[static_cast<size_t>(v)] = r;
      go(v + 1, std::max(used, r + 1));
    }
  };
  go(0, 0);
  return best;
}

TEST(Partition, LongestRegionWalkNearTheBestOnSmallGraphs) {
  Rng rng(3);
  double worst_ratio = 1, sum_ratio = 0;
  int cases = 0;
  for (int trial = 0; trial < 24; ++trial) {
    const int n = 7 + trial % 4, k = 2 + trial % 3;
    const PatrolGraph g = random_graph(rng, n, trial % 4 == 0 ? 2 : 0);
    GraphDistances d(g);
    const GraphPartition p = partition_graph(g, d, k);
    const int min_size = n >= 2 * k ? 2 : 1;
    const Best best = best_partition(g, d, k, min_size);
    ASSERT_TRUE(std::isfinite(best.longest));
    int undersized = 0;
    for (int r = 0; r < k; ++r) undersized += std::count(p.region.begin(), p.region.end(), r) < min_size;
    EXPECT_EQ(undersized, best.undersized) << "trial " << trial;
    if (undersized != best.undersized) {
      for (size_t v = 0; v < g.size(); ++v) {
        std::printf("v%zu r%d:", v, p.region[v]);
        for (auto& e : g.vertex(v).edges) std::printf(" %d(%.1f)", e.to, e.cost);
        std::printf("\n");
      }
    }
    if (undersized != best.undersized) continue;
    EXPECT_GE(p.longest, best.longest - 1e-6) << "trial " << trial;
    const double ratio = best.longest > 0 ? p.longest / best.longest : 1.0;
    worst_ratio = std::max(worst_ratio, ratio);
    sum_ratio += ratio;
    ++cases;
  }
  EXPECT_LE(sum_ratio / cases, 1.03);
  EXPECT_LE(worst_ratio, 1.25);
  std::printf("partition over the enumerated best, %d graphs: mean %.3f, worst %.3f\n", cases, sum_ratio / cases, worst_ratio);
}

TEST(Partition, RealDiagGraphsSplitIntoRegionsNoLongerThanTheWalkOverTheTeam) {
  VIGIL_REQUIRE_SHARED_DATA();
  // A region's walk sets its idleness: the longest over the team size's share of the whole
  // walk is what the cyclic strategy can at best reach (measured 0.55 to 1.05).
  for (const char* name : {"DIAG_labs", "DIAG_floor1"}) {
    auto g = PatrolGraph::read(test::shared_data() / "maps" / name / (std::string(name) + ".graph"));
    ASSERT_TRUE(g) << g.error().str();
    GraphDistances d(*g);
    const double walk = closed_walk(*g, d).length;
    for (int k : {1, 2, 4, 6, 8, 12}) {
      const GraphPartition p = partition_graph(*g, d, k);
      EXPECT_LE(p.longest, 1.1 * walk / k) << name << " " << k;
    }
  }
}

TEST(Partition, ShortDeadEndsShareARegionRatherThanStrandARobot) {
  // A corridor of 6 vertices 8 m apart, each with a door 0.7 m off it: 12 vertices, but a
  // robot alone on a corridor vertex and its door shuttles 0.7 m and never leaves either far
  // enough for a visit to count. With regions of at least 3 m, 12 robots get 6 regions (one
  // per corridor vertex would be too short) with two robots on some.
  std::vector<Vec2> p;
  std::vector<std::pair<int, int>> e;
  for (int i = 0; i < 6; ++i) {
    p.push_back({8.0 * i, 0});
    p.push_back({8.0 * i, 0.7});
    e.push_back({2 * i, 2 * i + 1});
    if (i > 0) e.push_back({2 * i - 2, 2 * i});
  }
  auto g = PatrolGraph::from_edges(p, e);
  ASSERT_TRUE(g);
  GraphDistances d(*g);
  PartitionOptions o;
  o.min_walk = 3.0;
  for (int team : {2, 3, 6, 12}) {
    const GraphPartition plan = plan_regions(*g, d, team, o);
    EXPECT_EQ(plan.slots(), team) << team;
    for (int r = 0; r < plan.count(); ++r) {
      EXPECT_GE(plan.walks[r].length, 3.0 - 1e-9) << team << " region " << r;
      EXPECT_TRUE(region_connected(*g, plan.region, r)) << team;
    }
    // Each robot's share of a walk is at most the whole walk over the team (with the 10 % a
    // shared walk counts), and less than shuttling alone allows nowhere.
    const double walk = closed_walk(*g, d).length;
    EXPECT_LE(plan.longest_share(), 1.1 * walk / team + 1e-9) << team;
  }
  EXPECT_LT(plan_regions(*g, d, 12, o).count(), 12);
  // Without the least walk, 12 robots get 12 regions of one door each.
  EXPECT_EQ(plan_regions(*g, d, 12).count(), 12);
  // With short regions padded by detours (the controller drives round a point off the graph),
  // a region of one door is a robot's own again and counts as the least walk: 12 regions, and
  // a share no longer than the padded walk.
  o.pad_short = true;
  const GraphPartition padded = plan_regions(*g, d, 12, o);
  EXPECT_EQ(padded.count(), 12);
  EXPECT_LE(padded.longest_share(), 3.0 + 1e-9);
  EXPECT_EQ(plan_regions(*g, d, 6, o).count(), 6);
}

TEST(Partition, RobotsSharingARegionSpreadAlongItsWalkAndPaceOnlyWithEachOther) {
  // A ring of 8 vertices (a cycle, 4 m radius) for 2 robots, and the regions' plan of a
  // single region: they share it as the cyclic strategy shares a walk.
  std::vector<Vec2> p;
  std::vector<std::pair<int, int>> e;
  for (int i = 0; i < 8; ++i) p.push_back({std::cos(i * M_PI / 4) * 4, std::sin(i * M_PI / 4) * 4});
  for (int i = 0; i < 8; ++i) e.push_back({i, (i + 1) % 8});
  auto setup = PatrolSetup::make(*PatrolGraph::from_edges(p, e), {}, 1.0);
  StrategyParams sp;
  sp.min_region_walk = 20;  // more than half the ring: one region for both
  ASSERT_EQ(setup->partition(2, 20)->count(), 1);
  std::vector<double> phases;
  for (int me = 0; me < 2; ++me) {
    auto s = make_strategy("partition", setup, sp);
    (*s)->set_team({"a", "b"}, {p[0], p[1]}, me);
    phases.push_back((*s)->phase(0));
    // A mate of another region (not a member here) does not slow it down; its region mate does.
    const double L = setup->tour.length;
    EXPECT_DOUBLE_EQ((*s)->pace(phases.back(), {{"z", std::fmod(phases.back() + 0.05 * L, L)}}), 1.0);
    EXPECT_LT((*s)->pace(phases.back(), {{me == 0 ? "b" : "a", std::fmod(phases.back() + 0.05 * L, L)}}), 1.0);
  }
  // Half the ring apart.
  const double L = setup->tour.length, gap = std::fmod(phases[1] - phases[0] + L, L);
  EXPECT_NEAR(gap, L / 2, L / 8 + 1e-9);
}

TEST(Partition, MembersGetTheRegionsNearestThemOnePerMember) {
  auto setup = line_setup(12, 2.0);
  const auto part = setup->partition(3);
  ASSERT_EQ(part->count(), 3);
  // Three robots at the east end, the middle and the west end.
  const std::vector<int> r = assign_regions(setup->graph, setup->distances, *part, {{22, 0}, {11, 0}, {0, 0}});
  ASSERT_EQ(r.size(), 3u);
  EXPECT_EQ(std::set<int>(r.begin(), r.end()).size(), 3u);
  EXPECT_EQ(part->region[11], r[0]);
  EXPECT_EQ(part->region[0], r[2]);
  // More members than regions: the extra one gets none.
  const auto one = setup->partition(1);
  const std::vector<int> two = assign_regions(setup->graph, setup->distances, *one, {{0, 0}, {22, 0}});
  EXPECT_EQ(two[0], 0);
  EXPECT_EQ(two[1], -1);
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
