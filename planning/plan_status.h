// Outcomes of a planning query, after OMPL's PlannerStatus: a result that is not an error
// (an unreachable goal is an answer, not a failure of the program).
#pragma once

namespace vigil::planning {

enum class PlanOutcome {
  kExact,         // a collision-free path from start to goal
  kApproximate,   // a collision-free path that ends short of the goal (closest reachable point)
  kTimeout,       // the motion level ran out of its iteration or time budget
  kNoPath,        // start and goal are valid but not connected in the free space
  kInvalidStart,  // the start is outside the map or inside an obstacle (beyond recovery distance)
  kInvalidGoal,   // the goal is outside the map or inside an obstacle
};

inline const char* to_string(PlanOutcome o) {
  switch (o) {
    case PlanOutcome::kExact: return "exact";
    case PlanOutcome::kApproximate: return "approximate";
    case PlanOutcome::kTimeout: return "timeout";
    case PlanOutcome::kNoPath: return "no_path";
    case PlanOutcome::kInvalidStart: return "invalid_start";
    case PlanOutcome::kInvalidGoal: return "invalid_goal";
  }
  return "?";
}

// True for outcomes that carry a usable path.
inline bool has_path(PlanOutcome o) { return o == PlanOutcome::kExact || o == PlanOutcome::kApproximate; }

}  // namespace vigil::planning
