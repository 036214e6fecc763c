#include "planning/allocation/allocation.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>

namespace vigil::planning::allocation {
namespace {

double total(const CostMatrix& c, const std::vector<std::pair<int, int>>& pairs) {
  double s = 0;
  for (auto [r, t] : pairs) s += c.at(r, t);
  return s;
}

}  // namespace

int default_priority(const std::string& kind) {
  if (kind == "bag_taken") return 3;
  if (kind == "unauthorised_object") return 2;
  if (kind == "left_bag") return 1;
  return 0;
}

Assignment greedy_assign(const CostMatrix& c, const std::vector<int>& priority, bool local_search) {
  Assignment a;
  const int R = c.rows, T = c.cols;
  std::vector<int> task_of(R, -1), robot_of(T, -1);
  std::set<int, std::greater<int>> levels(priority.begin(), priority.end());
  for (int level : levels) {
    for (;;) {
      int br = -1, bt = -1;
      double bc = std::numeric_limits<double>::infinity();
      for (int t = 0; t < T; ++t) {
        if (priority[t] != level || robot_of[t] >= 0) continue;
        for (int r = 0; r < R; ++r) {
          if (task_of[r] >= 0) continue;
          const double x = c.at(r, t);
          if (std::isfinite(x) && x < bc) {
            bc = x;
            br = r;
            bt = t;
          }
        }
      }
      if (br < 0) break;
      task_of[br] = bt;
      robot_of[bt] = br;
    }
  }
  if (local_search) {
    // Moves that keep every task served: swap two robots' tasks, or give a task to a free robot.
    constexpr double kEps = 1e-9;
    for (bool improved = true; improved;) {
      improved = false;
      for (int r1 = 0; r1 < R; ++r1) {
        const int t1 = task_of[r1];
        for (int r2 = r1 + 1; r2 < R; ++r2) {
          const int t2 = task_of[r2];
          if (t1 < 0 && t2 < 0) continue;
          const double before = (t1 >= 0 ? c.at(r1, t1) : 0) + (t2 >= 0 ? c.at(r2, t2) : 0);
          const double after = (t2 >= 0 ? c.at(r1, t2) : 0) + (t1 >= 0 ? c.at(r2, t1) : 0);
          if (std::isfinite(after) && after < before - kEps) {
            task_of[r1] = t2;
            task_of[r2] = t1;
            if (t2 >= 0) robot_of[t2] = r1;
            if (t1 >= 0) robot_of[t1] = r2;
            ++a.improvements;
            improved = true;
            break;
          }
        }
      }
    }
  }
  for (int r = 0; r < R; ++r) {
    if (task_of[r] >= 0) a.pairs.push_back({r, task_of[r]});
  }
  a.total_cost = total(c, a.pairs);
  return a;
}

Assignment optimal_assign(const CostMatrix& c, const std::vector<int>& priority) {
  // Higher levels first: a bonus per level larger than any total of costs.
  double span = 0;
  for (double x : c.costs)
    if (std::isfinite(x)) span += std::abs(x);
  const double bonus = span + 1.0;
  int lo = 0;
  for (int p : priority) lo = std::min(lo, p);
  CostMatrix m = c;
  for (int r = 0; r < c.rows; ++r)
    for (int t = 0; t < c.cols; ++t)
      if (std::isfinite(m.at(r, t))) m.at(r, t) -= bonus * (priority[t] - lo);
  Assignment a;
  a.pairs = solve_linear_assignment(m);
  a.total_cost = total(c, a.pairs);
  return a;
}

}  // namespace vigil::planning::allocation
