// planning/allocation: the greedy allocator with priorities against the Hungarian reference.
#include <gtest/gtest.h>

#include <algorithm>
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
