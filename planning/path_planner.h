// One interface for every point-to-point planner on an inflated grid, so the same conformance
// suite (tests/planner_test.cpp) and benchmark (vigil bench plan) run them all, as OMPL's
// tests/base/PlannerTest.h does: our two-level planner, plain OMPL PRM and RRTConnect as users
// run them out of the box, and the any-angle grid reference.
#pragma once

#include <memory>
#include <string>

#include "common/geometry.h"
#include "planning/grid/inflated_grid.h"
#include "planning/two_level_planner.h"

namespace vigil::planning {

class PathPlanner {
 public:
  virtual ~PathPlanner() = default;
  virtual std::string name() const = 0;
  // Same query, same seed, same path (plain OMPL planners stop on wall time, so they are not).
  virtual bool deterministic() const = 0;
  virtual PlanResult plan(Vec2 start, Vec2 goal) = 0;
};

// Our two-level planner (not owned).
std::unique_ptr<PathPlanner> wrap_two_level(const TwoLevelPlanner& planner);

// Plain OMPL on the same inflated grid and checks: PRM (one roadmap kept across queries, grown
// by solve() as OMPL does) or RRTConnect, each query solved within `time_limit` seconds and
// simplified with OMPL's PathSimplifier::simplifyMax.
enum class OmplBaseline { kPrm, kRrtConnect };
std::unique_ptr<PathPlanner> make_ompl_baseline(const InflatedGrid& grid, OmplBaseline kind, double time_limit = 1.0,
                                                uint32_t seed = 1);

// Lazy Theta* + line-of-sight shortening: the length reference.
std::unique_ptr<PathPlanner> make_grid_reference(const InflatedGrid& grid);

}  // namespace vigil::planning
