// The motion level of the two-level planner (chapter 10.6.2): OMPL's RRTConnect in a square
// window of the fine grid around the robot, against the static map inflated by the robot's
// radius plus the obstacles its laser sees now, then OMPL's path simplification (shortcuts and
// vertex reduction, seeded) and line-of-sight shortening. Bounded by an iteration count (so the
// same query gives the same path on any machine) and, as a guard, by wall time.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/geometry.h"
#include "common/status.h"
#include "planning/grid/inflated_grid.h"
#include "planning/motion/local_obstacles.h"
#include "planning/plan_status.h"

namespace vigil::planning {

struct MotionParams {
  double window = 12.0;        // side of the square planning window around the robot (m) [2, 200]
  int max_iterations = 20000;  // RRTConnect iterations before giving up (timeout) [10, 1e7]
  double time_limit = 0.25;    // wall-time guard (s) [0.001, 60]
  double range = 1.5;          // RRTConnect's step (m) [0.05, 50]
  int simplify_steps = 40;     // shortcut attempts of the simplifier [0, 10000]
  uint64_t seed = 1;
  Status check(const std::string& file = {}, int line = 0) const;
};

struct MotionResult {
  PlanOutcome outcome = PlanOutcome::kNoPath;
  std::vector<Vec2> path;
  size_t iterations = 0;
};

// Plans from `start` to `goal` inside [lo, hi] (clipped to the map).
MotionResult plan_local_motion(const InflatedGrid& map, const LocalObstacles& obstacles, Vec2 start, Vec2 goal,
                               Vec2 lo, Vec2 hi, const MotionParams& params);

}  // namespace vigil::planning
