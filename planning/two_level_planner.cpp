#include "planning/two_level_planner.h"

#include <algorithm>
#include <cmath>

#include <ompl/geometric/PathGeometric.h>

#include "planning/grid/any_angle.h"
#include "planning/ompl_space.h"

namespace vigil::planning {
namespace {

bool finite(Vec2 p) { return std::isfinite(p.x) && std::isfinite(p.y); }

// The point at arc length s along a polyline (clamped), and the index of the segment it is on.
Vec2 point_at(const std::vector<Vec2>& path, double s, size_t* segment) {
  for (size_t i = 1; i < path.size(); ++i) {
    const double L = (path[i] - path[i - 1]).norm();
    if (s <= L || i + 1 == path.size()) {
      *segment = i;
      const double t = L > 0 ? std::clamp(s / L, 0.0, 1.0) : 1.0;
      return path[i - 1] + (path[i] - path[i - 1]) * t;
    }
    s -= L;
  }
  *segment = path.size() - 1;
  return path.back();
}

}  // namespace

Status TwoLevelParams::check(const std::string& file, int line) const {
  auto bad = [&](const char* key, const std::string& what) { return Status(bad_input(file, line, key, what)); };
  if (!(robot_radius >= 0.01 && robot_radius <= 5)) return bad("robot_radius", "must be in [0.01, 5] m");
  if (!(start_recovery >= 0 && start_recovery <= 5)) return bad("start_recovery", "must be in [0, 5] m");
  if (!(goal_tolerance >= 0 && goal_tolerance <= 5)) return bad("goal_tolerance", "must be in [0, 5] m");
  if (!(obstacle_margin >= 0 && obstacle_margin <= 2)) return bad("obstacle_margin", "must be in [0, 2] m");
  if (route_shortcuts < 0 || route_shortcuts > 10000) return bad("route_shortcuts", "must be in [0, 10000]");
  if (Status s = roadmap.check(file, line); !s) return s;
  return motion.check(file, line);
}

Result<std::unique_ptr<TwoLevelPlanner>> TwoLevelPlanner::create(const OccupancyGrid& grid,
                                                                 const TwoLevelParams& params,
                                                                 const std::filesystem::path& roadmap_cache) {
  if (Status s = params.check(); !s) return s.error();
  if (grid.width() == 0 || grid.height() == 0) return bad_input("", 0, "map", "the map is empty");
  std::unique_ptr<TwoLevelPlanner> p(new TwoLevelPlanner());
  p->params_ = params;
  p->inflated_ = std::make_unique<InflatedGrid>(grid, params.robot_radius);
  auto rm = roadmap_cache.empty() ? Roadmap::build(*p->inflated_, params.roadmap)
                                  : Roadmap::build_cached(*p->inflated_, params.roadmap, roadmap_cache);
  if (!rm) return rm.error();
  p->roadmap_ = std::move(*rm);
  return p;
}

std::vector<Vec2> TwoLevelPlanner::tighten(const std::vector<Vec2>& route) const {
  std::vector<Vec2> pts = shorten_by_line_of_sight(*inflated_, route);
  if (pts.size() <= 2 || params_.route_shortcuts == 0) return pts;
  // OMPL's shortcutting moves the corners onto the walls' inflated edge (partial shortcuts
  // between points inside segments), then string pulling drops what became redundant.
  const InflatedGrid& g = *inflated_;
  auto si = make_plane_space(
      g.lower(), g.upper(), [&g](Vec2 p) { return g.is_free(p); },
      [&g](Vec2 a, Vec2 b) { return g.segment_free(a, b); },
      static_cast<uint32_t>(params_.roadmap.seed * 2654435761u + 17));
  ompl::geometric::PathGeometric path(si);
  for (const Vec2& p : pts) {
    ompl::base::State* s = si->allocState();
    set_state_point(s, p);
    path.append(s);
    si->freeState(s);
  }
  SeededPathSimplifier simplifier(si, static_cast<uint32_t>(params_.roadmap.seed + 7));
  simplifier.shortcutPath(path, static_cast<unsigned>(params_.route_shortcuts));
  std::vector<Vec2> out = shorten_by_line_of_sight(g, path_points(path));
  out.front() = route.front();
  out.back() = route.back();
  return path_length(out) <= path_length(pts) ? out : pts;
}

PlanResult TwoLevelPlanner::plan(Vec2 start, Vec2 goal, const LocalObstacles* obstacles) const {
  PlanResult r;
  const InflatedGrid& g = *inflated_;
  const OccupancyGrid& grid = g.grid();
  int cx, cy;
  if (!finite(start) || !grid.world_to_cell(start, &cx, &cy)) {
    r.outcome = PlanOutcome::kInvalidStart;
    r.detail = "start is outside the map";
    return r;
  }
  if (!finite(goal) || !grid.world_to_cell(goal, &cx, &cy)) {
    r.outcome = PlanOutcome::kInvalidGoal;
    r.detail = "goal is outside the map";
    return r;
  }
  Vec2 s = start, t = goal;
  if (!g.is_free(s)) {
    auto moved = g.nearest_free(s, params_.start_recovery);
    if (!moved) {
      r.outcome = PlanOutcome::kInvalidStart;
      r.detail = "start is inside an obstacle or closer to one than the robot's radius";
      return r;
    }
    s = *moved;
  }
  if (!g.is_free(t)) {
    auto moved = grid.is_free(t) ? g.nearest_free(t, params_.goal_tolerance) : std::nullopt;
    if (!moved) {
      r.outcome = PlanOutcome::kInvalidGoal;
      r.detail = grid.is_free(t) ? "goal is too close to a wall for the robot" : "goal is inside a wall or unknown space";
      return r;
    }
    t = *moved;
  }
  if (g.component(s) != g.component(t)) {
    r.outcome = PlanOutcome::kNoPath;
    r.detail = "goal is not reachable from the start in the free space";
    return r;
  }
  // Topological level.
  auto route = roadmap_.route(s, t);
  if (!route) {
    // Start or goal sees no milestone (a pocket PRM never sampled): the grid reference.
    AnyAnglePlanner reference(g);
    ReferencePath ref = reference.plan(s, t);
    if (!ref.found) {
      r.outcome = PlanOutcome::kNoPath;
      r.detail = "no route on the roadmap or the grid";
      return r;
    }
    route = ref.points;
  }
  r.route = *route;
  std::vector<Vec2> path = tighten(*route);
  if (!(s == start)) path.insert(path.begin(), start);
  if (!(t == goal)) path.push_back(goal);
  r.outcome = PlanOutcome::kExact;

  // Motion level: inside the window around the start, the route against what the laser sees.
  if (obstacles && !obstacles->empty()) {
    const double half = params_.motion.window / 2;
    auto inside = [&](Vec2 p) { return std::abs(p.x - s.x) <= half && std::abs(p.y - s.y) <= half; };
    bool blocked = false;
    for (size_t i = 1; i < path.size() && !blocked; ++i) {
      blocked = !obstacles->segment_free(path[i - 1], path[i]);
      if (!inside(path[i])) break;
    }
    if (blocked) {
      r.used_motion_level = true;
      const double total = path_length(path);
      // Walk the path in 10 cm steps inside the window: the first point blocked by what the
      // laser sees, then the first free point after it is the local goal. When nothing after
      // it is free inside the window (a person on the goal), the last free point before it,
      // and the result is approximate.
      constexpr double kStep = 0.1;
      std::optional<Vec2> last_free_before, local_goal;
      size_t seg = 1;
      bool seen_block = false;
      for (double a = 0;; a = std::min(a + kStep, total)) {
        size_t sg;
        const Vec2 p = point_at(path, a, &sg);
        if (!inside(p)) break;
        const bool free = g.is_free(p) && obstacles->point_free(p);
        if (!free) {
          seen_block = true;
        } else if (!seen_block) {
          last_free_before = p;
        } else {
          local_goal = p;
          seg = sg;
          break;
        }
        if (a >= total) break;
      }
      if (!seen_block) {
        // The points are clear but a segment grazes an obstacle: aim past the window's part.
        for (double a = total;; a -= kStep) {
          size_t sg;
          const Vec2 p = point_at(path, std::max(a, 0.0), &sg);
          if (inside(p) && g.is_free(p) && obstacles->point_free(p)) {
            local_goal = p;
            seg = sg;
            break;
          }
          if (a <= 0) break;
        }
      }
      bool approximate = false;
      if (!local_goal && last_free_before && !(*last_free_before == s)) {
        local_goal = last_free_before;
        approximate = true;
      }
      if (!local_goal) {
        r.outcome = PlanOutcome::kNoPath;
        r.detail = "the way ahead is blocked by obstacles the laser sees";
        r.path.clear();
        return r;
      }
      const Vec2 lo{s.x - half, s.y - half}, hi{s.x + half, s.y + half};
      // A start already within the clearance of an obstacle (someone walked up to the robot)
      // plans with the clearance it has.
      LocalObstacles relaxed;
      const LocalObstacles* obs = obstacles;
      const double d0 = obstacles->distance(s);
      if (d0 < obstacles->clearance()) {
        relaxed = LocalObstacles(obstacles->points(), std::max(0.0, d0 - 0.02));
        obs = &relaxed;
      }
      MotionResult m = plan_local_motion(g, *obs, s, *local_goal, lo, hi, params_.motion);
      if (!has_path(m.outcome)) {
        r.outcome = m.outcome == PlanOutcome::kTimeout ? PlanOutcome::kTimeout : PlanOutcome::kNoPath;
        r.detail = "the motion level found no way around the obstacles in its window";
        r.path.clear();
        return r;
      }
      std::vector<Vec2> joined = m.path;
      if (!(s == start)) joined.insert(joined.begin(), start);
      if (!approximate) {
        // The rest of the route from the local goal on.
        for (size_t i = seg; i < path.size(); ++i) {
          if (!(path[i] == joined.back())) joined.push_back(path[i]);
        }
      } else {
        r.outcome = PlanOutcome::kApproximate;
      }
      path = std::move(joined);
    }
  }
  r.path = std::move(path);
  r.length = path_length(r.path);
  return r;
}

}  // namespace vigil::planning
