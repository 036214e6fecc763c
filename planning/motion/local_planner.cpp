#include "planning/motion/local_planner.h"

#include <algorithm>
#include <chrono>

#include <ompl/base/ProblemDefinition.h>
#include <ompl/base/ScopedState.h>
#include <ompl/geometric/PathGeometric.h>
#include <ompl/geometric/planners/rrt/RRTConnect.h>

#include "planning/grid/any_angle.h"
#include "planning/ompl_space.h"

namespace ob = ompl::base;
namespace og = ompl::geometric;

namespace vigil::planning {

Status MotionParams::check(const std::string& file, int line) const {
  auto bad = [&](const char* key, const std::string& what) {
    return Status(bad_input(file, line, std::string("motion.") + key, what));
  };
  if (!(window >= 2 && window <= 200)) return bad("window", "must be in [2, 200] m");
  if (max_iterations < 10 || max_iterations > 10000000) return bad("max_iterations", "must be in [10, 1e7]");
  if (!(time_limit >= 0.001 && time_limit <= 60)) return bad("time_limit", "must be in [0.001, 60] s");
  if (!(range >= 0.05 && range <= 50)) return bad("range", "must be in [0.05, 50] m");
  if (simplify_steps < 0 || simplify_steps > 10000) return bad("simplify_steps", "must be in [0, 10000]");
  return Status::Ok();
}

MotionResult plan_local_motion(const InflatedGrid& map, const LocalObstacles& obstacles, Vec2 start, Vec2 goal,
                               Vec2 lo, Vec2 hi, const MotionParams& params) {
  MotionResult out;
  auto point_free = [&](Vec2 p) { return map.is_free(p) && obstacles.point_free(p); };
  auto segment_free = [&](Vec2 a, Vec2 b) { return map.segment_free(a, b) && obstacles.segment_free(a, b); };
  if (!point_free(start)) {
    out.outcome = PlanOutcome::kInvalidStart;
    return out;
  }
  if (!point_free(goal)) {
    out.outcome = PlanOutcome::kInvalidGoal;
    return out;
  }
  if (segment_free(start, goal)) {
    out.outcome = PlanOutcome::kExact;
    out.path = {start, goal};
    return out;
  }
  lo = {std::max(lo.x, map.lower().x), std::max(lo.y, map.lower().y)};
  hi = {std::min(hi.x, map.upper().x), std::min(hi.y, map.upper().y)};
  const uint32_t seed = static_cast<uint32_t>(params.seed ^ (params.seed >> 32));
  auto si = make_plane_space(lo, hi, point_free, segment_free, seed);
  auto pdef = std::make_shared<ob::ProblemDefinition>(si);
  ob::ScopedState<> s(si), g(si);
  set_state_point(s.get(), start);
  set_state_point(g.get(), goal);
  pdef->setStartAndGoalStates(s, g);
  auto rrt = std::make_shared<og::RRTConnect>(si);
  rrt->setRange(params.range);
  rrt->setProblemDefinition(pdef);
  rrt->setup();
  size_t iterations = 0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(params.time_limit);
  bool out_of_time = false;
  const ob::PlannerTerminationCondition ptc([&] {
    if (++iterations > static_cast<size_t>(params.max_iterations)) return true;
    if ((iterations & 63) == 0 && std::chrono::steady_clock::now() > deadline) out_of_time = true;
    return out_of_time;
  });
  const ob::PlannerStatus status = rrt->solve(ptc);
  out.iterations = iterations;
  if (status != ob::PlannerStatus::EXACT_SOLUTION) {
    out.outcome = PlanOutcome::kTimeout;
    return out;
  }
  auto& path = *pdef->getSolutionPath()->as<og::PathGeometric>();
  SeededPathSimplifier simplifier(si, seed);
  simplifier.reduceVertices(path);
  if (params.simplify_steps > 0) simplifier.shortcutPath(path, static_cast<unsigned>(params.simplify_steps));
  std::vector<Vec2> pts = path_points(path);
  // Greedy string pulling against the same checks: never longer, and the result deterministic.
  std::vector<Vec2> kept{pts.front()};
  size_t anchor = 0;
  for (size_t i = 1; i + 1 < pts.size(); ++i) {
    if (!segment_free(pts[anchor], pts[i + 1])) {
      kept.push_back(pts[i]);
      anchor = i;
    }
  }
  kept.push_back(pts.back());
  out.path = std::move(kept);
  out.outcome = PlanOutcome::kExact;
  return out;
}

}  // namespace vigil::planning
