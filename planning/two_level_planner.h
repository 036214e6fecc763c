// The two-level planner of chapter 10.6.2 (after Calisi et al. 2005, as in OpenRDK): a
// topological level that searches a probabilistic roadmap (OMPL PRM) over the map inflated by
// the robot's radius for a coarse route, and a motion level that plans with OMPL RRTConnect in
// a local window of the fine grid along that route against what the laser sees now, then
// simplifies. A query answers with an outcome (PlanOutcome), never an exception or a hang:
// points outside the map or in a wall, and goals in another part of the free space, are
// answered before any search.
#pragma once

#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "common/geometry.h"
#include "common/occupancy_grid.h"
#include "common/status.h"
#include "planning/grid/inflated_grid.h"
#include "planning/motion/local_obstacles.h"
#include "planning/motion/local_planner.h"
#include "planning/plan_status.h"
#include "planning/roadmap/roadmap.h"

namespace vigil::planning {

struct TwoLevelParams {
  double robot_radius = 0.3;      // disc that covers the footprint (m) [0.01, 5]
  double start_recovery = 0.5;    // a start inside the inflation margin moves to free space this near (m) [0, 5]
  double goal_tolerance = 0.5;    // a goal inside the margin (not in a wall) moves this near (m) [0, 5]
  double obstacle_margin = 0.1;   // extra distance kept from laser-seen obstacles (m) [0, 2]
  int route_shortcuts = 60;       // OMPL shortcut attempts on the route [0, 10000]
  RoadmapParams roadmap;
  MotionParams motion;
  Status check(const std::string& file = {}, int line = 0) const;
};

struct PlanResult {
  PlanOutcome outcome = PlanOutcome::kNoPath;
  std::vector<Vec2> path;     // start ... goal (or the closest point reached, if approximate)
  std::vector<Vec2> route;    // the topological route it followed
  double length = 0;          // m
  bool used_motion_level = false;  // RRTConnect ran (something blocked the route)
  std::string detail;         // why, for outcomes without a path
};

class TwoLevelPlanner {
 public:
  // Builds the inflated grid and the roadmap (loaded from `roadmap_cache` when it holds this
  // map's roadmap; saved there otherwise). The grid must outlive the planner.
  static Result<std::unique_ptr<TwoLevelPlanner>> create(const OccupancyGrid& grid, const TwoLevelParams& params,
                                                         const std::filesystem::path& roadmap_cache = {});

  // A path from start to goal on the static map, then around `obstacles` (may be null) within
  // the motion window around the start.
  PlanResult plan(Vec2 start, Vec2 goal, const LocalObstacles* obstacles = nullptr) const;

  const InflatedGrid& inflated() const { return *inflated_; }
  const Roadmap& roadmap() const { return roadmap_; }
  const TwoLevelParams& params() const { return params_; }
  // Clearance kept from laser-seen obstacles: robot radius + obstacle margin.
  double obstacle_clearance() const { return params_.robot_radius + params_.obstacle_margin; }

 private:
  TwoLevelPlanner() = default;
  std::vector<Vec2> tighten(const std::vector<Vec2>& route) const;
  TwoLevelParams params_;
  std::unique_ptr<InflatedGrid> inflated_;
  Roadmap roadmap_;
};

}  // namespace vigil::planning
