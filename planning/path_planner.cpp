#include "planning/path_planner.h"

#include <ompl/base/ProblemDefinition.h>
#include <ompl/base/ScopedState.h>
#include <ompl/geometric/PathGeometric.h>
#include <ompl/geometric/PathSimplifier.h>
#include <ompl/geometric/planners/prm/PRM.h>
#include <ompl/geometric/planners/rrt/RRTConnect.h>

#include "planning/grid/any_angle.h"
#include "planning/ompl_space.h"

namespace ob = ompl::base;
namespace og = ompl::geometric;

namespace vigil::planning {
namespace {

// The answer for a start or goal the robot cannot stand on, before any planner runs.
bool refuse_invalid(const InflatedGrid& grid, Vec2 s, Vec2 g, PlanResult* r) {
  if (!grid.is_free(s)) r->outcome = PlanOutcome::kInvalidStart;
  else if (!grid.is_free(g)) r->outcome = PlanOutcome::kInvalidGoal;
  else return false;
  return true;
}

class TwoLevelAdapter : public PathPlanner {
 public:
  explicit TwoLevelAdapter(const TwoLevelPlanner& p) : p_(&p) {}
  std::string name() const override { return "vigil two-level (PRM route + RRTConnect motion)"; }
  bool deterministic() const override { return true; }
  PlanResult plan(Vec2 s, Vec2 g) override { return p_->plan(s, g); }

 private:
  const TwoLevelPlanner* p_;
};

class OmplAdapter : public PathPlanner {
 public:
  OmplAdapter(const InflatedGrid& grid, OmplBaseline kind, double time_limit, uint32_t seed)
      : grid_(&grid), kind_(kind), time_limit_(time_limit) {
    si_ = make_plane_space(
        grid.lower(), grid.upper(), [&grid](Vec2 p) { return grid.is_free(p); },
        [&grid](Vec2 a, Vec2 b) { return grid.segment_free(a, b); }, seed);
    pdef_ = std::make_shared<ob::ProblemDefinition>(si_);
    if (kind == OmplBaseline::kPrm) {
      planner_ = std::make_shared<og::PRM>(si_);
    } else {
      planner_ = std::make_shared<og::RRTConnect>(si_);
    }
    planner_->setProblemDefinition(pdef_);
    planner_->setup();
  }
  std::string name() const override { return kind_ == OmplBaseline::kPrm ? "OMPL PRM" : "OMPL RRTConnect"; }
  bool deterministic() const override { return false; }
  PlanResult plan(Vec2 s, Vec2 g) override {
    PlanResult r;
    if (refuse_invalid(*grid_, s, g, &r)) return r;
    if (kind_ == OmplBaseline::kPrm) {
      planner_->clearQuery();  // keep the roadmap, as a multi-query PRM
    } else {
      planner_->clear();
    }
    pdef_->clearSolutionPaths();
    pdef_->clearStartStates();
    pdef_->clearGoal();
    ob::ScopedState<> a(si_), b(si_);
    set_state_point(a.get(), s);
    set_state_point(b.get(), g);
    pdef_->setStartAndGoalStates(a, b);
    const ob::PlannerStatus st = planner_->solve(ob::timedPlannerTerminationCondition(time_limit_));
    if (st != ob::PlannerStatus::EXACT_SOLUTION) {
      r.outcome = st == ob::PlannerStatus::TIMEOUT ? PlanOutcome::kTimeout : PlanOutcome::kNoPath;
      return r;
    }
    auto& path = *pdef_->getSolutionPath()->as<og::PathGeometric>();
    og::PathSimplifier simplifier(si_);
    simplifier.simplifyMax(path);
    r.path = path_points(path);
    r.length = path_length(r.path);
    r.outcome = PlanOutcome::kExact;
    return r;
  }

 private:
  const InflatedGrid* grid_;
  OmplBaseline kind_;
  double time_limit_;
  ob::SpaceInformationPtr si_;
  ob::ProblemDefinitionPtr pdef_;
  ob::PlannerPtr planner_;
};

class ReferenceAdapter : public PathPlanner {
 public:
  explicit ReferenceAdapter(const InflatedGrid& grid) : grid_(&grid), planner_(grid) {}
  std::string name() const override { return "grid reference (Lazy Theta*)"; }
  bool deterministic() const override { return true; }
  PlanResult plan(Vec2 s, Vec2 g) override {
    PlanResult r;
    if (refuse_invalid(*grid_, s, g, &r)) return r;
    ReferencePath p = planner_.plan(s, g);
    r.outcome = p.found ? PlanOutcome::kExact : PlanOutcome::kNoPath;
    r.path = p.points;
    r.length = p.length;
    return r;
  }

 private:
  const InflatedGrid* grid_;
  AnyAnglePlanner planner_;
};

}  // namespace

std::unique_ptr<PathPlanner> wrap_two_level(const TwoLevelPlanner& planner) {
  return std::make_unique<TwoLevelAdapter>(planner);
}

std::unique_ptr<PathPlanner> make_ompl_baseline(const InflatedGrid& grid, OmplBaseline kind, double time_limit,
                                                uint32_t seed) {
  return std::make_unique<OmplAdapter>(grid, kind, time_limit, seed);
}

std::unique_ptr<PathPlanner> make_grid_reference(const InflatedGrid& grid) {
  return std::make_unique<ReferenceAdapter>(grid);
}

}  // namespace vigil::planning
