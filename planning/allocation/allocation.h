// Task allocation for the response mode (chapter 10.6): every incident becomes a task with a
// priority by kind and a map position; each robot's cost for a task is its planned travel time
// to it (the planner's path length over its speed, not the straight line) plus what leaving its
// current activity costs; utility is priority first, then least cost (Iocchi, Nardi, Piaggio,
// Sgorbissa 2003: utility-based task assignment).
//
// greedy_assign: priority levels highest first; within a level, repeatedly the free robot and
// open task of least cost; then a local search (swap the tasks of two robots, or hand a task to
// a free robot, when that lowers the total) until no move improves. optimal_assign: the
// Hungarian method on the same costs, priorities respected the same way (a task of a higher
// level is never left open for one of a lower level) - the reference for evaluation.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "common/linear_assignment.h"

namespace vigil::planning::allocation {

struct Assignment {
  std::vector<std::pair<int, int>> pairs;  // (robot, task), sorted by robot
  double total_cost = 0;                   // sum of the pairs' costs
  int improvements = 0;                    // local-search moves taken (greedy)
};

// `cost` is robots x tasks (not finite: the robot cannot serve the task); `priority` one per
// task (larger first). With as many robots as tasks or more, every task gets a robot.
Assignment greedy_assign(const CostMatrix& cost, const std::vector<int>& priority, bool local_search = true);
Assignment optimal_assign(const CostMatrix& cost, const std::vector<int>& priority);

// The default priorities by incident kind: bag taken, then unauthorised object, then left bag
// (then exchange); a scenario may set its own.
int default_priority(const std::string& kind);

}  // namespace vigil::planning::allocation
