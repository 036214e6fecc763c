// planning/allocation: the greedy allocator with priorities against the Hungarian reference.
#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <map>
#include <memory>
#include <numeric>

#include "common/rng.h"
#include "planning/allocation/allocation.h"

namespace vigil::planning::allocation {
namespace {

CostMatrix random_costs(Rng& rng, int robots, int tasks) {
  CostMatrix c(robots, tasks);
  // Points in a 50 x 40 m plane, costs their distances (a metric, as path lengths are).
  std::vector<std::pair<double, double>> r, t;
  for (int i = 0; i < robots; ++i) r.push_back({rng.uniform(0, 50), rng.uniform(0, 40)});
  for (int j = 0; j < tasks; ++j) t.push_back({rng.uniform(0, 50), rng.uniform(0, 40)});
  for (int i = 0; i < robots; ++i)
    for (int j = 0; j < tasks; ++j) c.at(i, j) = std::hypot(r[i].first - t[j].first, r[i].second - t[j].second);
  return c;
}

// Brute force over robot permutations (robots >= tasks).
double brute_force(const CostMatrix& c) {
  std::vector<int> perm(c.rows);
  std::iota(perm.begin(), perm.end(), 0);
  double best = 1e18;
  do {
    double s = 0;
    for (int t = 0; t < c.cols; ++t) s += c.at(perm[t], t);
    best = std::min(best, s);
  } while (std::next_permutation(perm.begin(), perm.end()));
  return best;
}

TEST(Allocation, HungarianReferenceIsOptimalAndGreedyIsClose) {
  Rng rng(11);
  double worst = 1;
  for (int trial = 0; trial < 30; ++trial) {
    const int robots = 4 + trial % 4, tasks = 3 + trial % 3;
    const CostMatrix c = random_costs(rng, robots, std::min(tasks, robots));
    const std::vector<int> pr(c.cols, 1);
    const Assignment opt = optimal_assign(c, pr), gr = greedy_assign(c, pr);
    EXPECT_NEAR(opt.total_cost, brute_force(c), 1e-9) << trial;
    ASSERT_EQ(gr.pairs.size(), static_cast<size_t>(c.cols));
    EXPECT_GE(gr.total_cost, opt.total_cost - 1e-9);
    worst = std::max(worst, gr.total_cost / opt.total_cost);
  }
  EXPECT_LE(worst, 1.2);
}

TEST(Allocation, LocalSearchMendsWhatGreedyGetsWrong) {
  // Greedy takes the cheapest pair first (robot 0 -> task 0, cost 1) and leaves robot 1 with
  // task 1 at 10; swapping gives 2 + 2.
  CostMatrix c(2, 2);
  c.at(0, 0) = 1;
  c.at(0, 1) = 2;
  c.at(1, 0) = 2;
  c.at(1, 1) = 10;
  EXPECT_DOUBLE_EQ(greedy_assign(c, {1, 1}, false).total_cost, 11);
  const Assignment a = greedy_assign(c, {1, 1});
  EXPECT_DOUBLE_EQ(a.total_cost, 4);
  EXPECT_EQ(a.improvements, 1);
}

TEST(Allocation, HigherPriorityTasksAreServedFirstWhenRobotsAreShort) {
  // One robot, two tasks: the bag taken (3) wins over the nearer left bag (1).
  CostMatrix c(1, 2);
  c.at(0, 0) = 5;   // left bag, near
  c.at(0, 1) = 40;  // bag taken, far
  const std::vector<int> pr = {default_priority("left_bag"), default_priority("bag_taken")};
  for (const Assignment& a : {greedy_assign(c, pr), optimal_assign(c, pr)}) {
    ASSERT_EQ(a.pairs.size(), 1u);
    EXPECT_EQ(a.pairs[0].second, 1);
  }
  EXPECT_GT(default_priority("bag_taken"), default_priority("unauthorised_object"));
  EXPECT_GT(default_priority("unauthorised_object"), default_priority("left_bag"));
}

TEST(Allocation, ForbiddenPairsAreNeverAssigned) {
  CostMatrix c(2, 2);
  c.at(0, 0) = std::numeric_limits<double>::infinity();  // robot 0 cannot reach task 0
  c.at(0, 1) = 1;
  c.at(1, 0) = 3;
  c.at(1, 1) = 1;
  for (const Assignment& a : {greedy_assign(c, {1, 1}), optimal_assign(c, {1, 1})}) {
    ASSERT_EQ(a.pairs.size(), 2u);
    for (auto [r, t] : a.pairs) EXPECT_TRUE(std::isfinite(c.at(r, t)));
    EXPECT_DOUBLE_EQ(a.total_cost, 4);
  }
}

}  // namespace
}  // namespace vigil::planning::allocation

#include "planning/allocation/token_passing.h"

namespace vigil::planning::allocation {
namespace {

// Robots on a line; a router that delivers each step's messages the next step, dropping what
// `drop` says.
struct TokenWorld {
  std::map<std::string, double> where;
  std::map<std::string, std::unique_ptr<TokenAgent>> agents;
  std::function<bool(const TokenMessage&, int)> drop = [](const TokenMessage&, int) { return false; };
  int delivered = 0, dropped = 0;
  explicit TokenWorld(std::map<std::string, double> w) : where(std::move(w)) {
    std::vector<std::string> names;
    for (auto& [n, x] : where) names.push_back(n);
    for (auto& n : names) {
      agents[n] = std::make_unique<TokenAgent>(n, TokenParams{}, [this](const std::string& r, const TokenTask& t) {
        return std::abs(where.at(r) - t.where.x);
      });
      agents[n]->set_members(names);
    }
  }
  double clock = 0;  // run() carries on from where the last one stopped
  int step = 0;
  void run(double seconds, double dt = 0.05) {
    const double end = clock + seconds;
    for (double& t = clock; t < end; t += dt, ++step) {
      std::vector<TokenMessage> all;
      for (auto& [n, a] : agents) {
        a->tick(t);
        for (auto& m : a->take_outbox()) all.push_back(m);
      }
      for (auto& m : all) {
        for (auto& [n, a] : agents) {
          if (n == m.from || (!m.to.empty() && m.to != n)) continue;
          if (drop(m, step)) {
            ++dropped;
            continue;
          }
          ++delivered;
          a->receive(m, t + dt);
        }
      }
    }
  }
  std::vector<std::string> keepers_of(uint64_t id) const {
    std::vector<std::string> k;
    for (auto& [n, a] : agents)
      for (auto& t : a->kept())
        if (t.id == id) k.push_back(n);
    return k;
  }
};

TEST(TokenPassing, TheTokenEndsWithTheBestPlacedRobot) {
  TokenWorld w({{"a", 0}, {"b", 10}, {"c", 20}, {"d", 30}});
  w.agents["a"]->create({7, "bag_taken", 3, {27, 0}}, 0);  // heard first by a, far from it
  w.run(2);
  EXPECT_EQ(w.keepers_of(7), std::vector<std::string>{"d"});
  for (auto& [n, a] : w.agents) EXPECT_EQ(a->keepers().at(7), "d") << n;  // everyone knows
}

TEST(TokenPassing, ALostTokenIsSentAgainAndTheAssignmentOnlyDelayed) {
  TokenWorld w({{"a", 0}, {"b", 10}, {"c", 20}});
  bool lost = false;
  w.drop = [&](const TokenMessage& m, int) {
    if (m.kind == "token" && !lost) return lost = true;  // the first token never arrives
    return false;
  };
  w.agents["a"]->create({9, "left_bag", 1, {19, 0}}, 0);
  w.run(3);
  EXPECT_TRUE(lost);
  EXPECT_EQ(w.keepers_of(9), std::vector<std::string>{"c"});
}

TEST(TokenPassing, ASilentRobotIsSkippedAndTheTaskNeverDropped) {
  TokenWorld w({{"a", 0}, {"b", 10}, {"c", 20}});
  w.drop = [](const TokenMessage& m, int) { return m.to == "c" || m.from == "c"; };  // c is down
  w.agents["a"]->create({4, "bag_taken", 3, {20, 0}}, 0);
  w.run(5);
  const auto k = w.keepers_of(4);
  ASSERT_EQ(k.size(), 1u);
  EXPECT_EQ(k[0], "b");  // the next best of those who answer
  // Every message lost both ways still ends with a keeper: the holder itself.
  TokenWorld alone({{"a", 0}, {"b", 10}});
  alone.drop = [](const TokenMessage&, int) { return true; };
  alone.agents["a"]->create({5, "left_bag", 1, {10, 0}}, 0);
  alone.run(5);
  EXPECT_EQ(alone.keepers_of(5), std::vector<std::string>{"a"});
}

TEST(TokenPassing, DuplicatesAndLateAcksLeaveOneKeeper) {
  TokenWorld w({{"a", 0}, {"b", 10}, {"c", 20}});
  // Acks are lost for a while: tokens are resent, copies arrive, b is finally skipped by a
  // while it already decided.
  w.drop = [](const TokenMessage& m, int step) { return m.kind == "ack" && step < 60; };
  w.agents["a"]->create({3, "bag_taken", 3, {12, 0}}, 0);
  w.run(6);
  EXPECT_EQ(w.keepers_of(3), std::vector<std::string>{"b"});  // the better of the two that decided
}

// Two robots cut off from each other both keep one task (each created its token and heard
// nothing back). When the link comes back, the keepers' repeated announcements leave one of
// them with it within a keep period: the lost first announcement only delayed that.
TEST(TokenPassing, TwoKeepersCutOffFromEachOtherEndWithOneWhenTheLinkReturns) {
  TokenWorld w({{"a", 0}, {"b", 10}});
  w.drop = [](const TokenMessage&, int step) { return step < 100; };  // 5 s of silence
  w.agents["a"]->create({6, "bag_taken", 3, {0, 0}}, 0);
  w.agents["b"]->create({6, "bag_taken", 3, {0, 0}}, 0);
  w.run(4.9);
  EXPECT_EQ(w.keepers_of(6), (std::vector<std::string>{"a", "b"})) << "cut off, both serve it";
  w.drop = [](const TokenMessage&, int) { return false; };
  w.run(1.2);
  EXPECT_EQ(w.keepers_of(6), std::vector<std::string>{"a"});
  EXPECT_EQ(w.agents["b"]->keepers().at(6), "a");
}

}  // namespace
}  // namespace vigil::planning::allocation
