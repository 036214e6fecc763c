#include "planning/ompl_space.h"

#include <cmath>
#include <mutex>

#include <ompl/base/MotionValidator.h>
#include <ompl/base/StateValidityChecker.h>
#include <ompl/base/spaces/RealVectorStateSpace.h>
#include <ompl/util/Console.h>

namespace ob = ompl::base;

namespace vigil::planning {
namespace {

class SeededPlaneSampler : public ob::RealVectorStateSampler {
 public:
  SeededPlaneSampler(const ob::StateSpace* space, uint32_t seed) : ob::RealVectorStateSampler(space) {
    rng_.setLocalSeed(seed);
  }
};

class PredicateValidity : public ob::StateValidityChecker {
 public:
  PredicateValidity(const ob::SpaceInformationPtr& si, PointCheck check)
      : ob::StateValidityChecker(si), check_(std::move(check)) {}
  bool isValid(const ob::State* s) const override { return check_(state_point(s)); }

 private:
  PointCheck check_;
};

class PredicateMotion : public ob::MotionValidator {
 public:
  PredicateMotion(const ob::SpaceInformationPtr& si, PointCheck point, SegmentCheck seg)
      : ob::MotionValidator(si), point_(std::move(point)), seg_(std::move(seg)) {}
  bool checkMotion(const ob::State* a, const ob::State* b) const override {
    const bool ok = seg_(state_point(a), state_point(b));
    if (!ok) ++invalid_;
    else ++valid_;
    return ok;
  }
  bool checkMotion(const ob::State* a, const ob::State* b, std::pair<ob::State*, double>& last) const override {
    const Vec2 p = state_point(a), q = state_point(b);
    if (seg_(p, q)) {
      ++valid_;
      return true;
    }
    ++invalid_;
    // The last valid point, to a centimetre, by bisection on the segment's free prefix.
    double lo = 0, hi = 1;
    const double len = (q - p).norm();
    while ((hi - lo) * len > 0.01) {
      const double mid = 0.5 * (lo + hi);
      if (seg_(p, p + (q - p) * mid)) lo = mid;
      else hi = mid;
    }
    if (last.first) set_state_point(last.first, p + (q - p) * lo);
    last.second = lo;
    return false;
  }

 private:
  PointCheck point_;
  SegmentCheck seg_;
};

}  // namespace

void quiet_ompl() {
  static std::once_flag once;
  std::call_once(once, [] { ompl::msg::setLogLevel(ompl::msg::LOG_ERROR); ompl::msg::noOutputHandler(); });
}

Vec2 state_point(const ob::State* s) {
  const auto* r = s->as<ob::RealVectorStateSpace::StateType>();
  return {r->values[0], r->values[1]};
}

void set_state_point(ob::State* s, Vec2 p) {
  auto* r = s->as<ob::RealVectorStateSpace::StateType>();
  r->values[0] = p.x;
  r->values[1] = p.y;
}

std::vector<Vec2> path_points(const ompl::geometric::PathGeometric& path) {
  std::vector<Vec2> out;
  out.reserve(path.getStateCount());
  for (size_t i = 0; i < path.getStateCount(); ++i) out.push_back(state_point(path.getState(i)));
  return out;
}

ob::SpaceInformationPtr make_plane_space(Vec2 lo, Vec2 hi, PointCheck point_free, SegmentCheck segment_free,
                                         uint32_t seed) {
  quiet_ompl();
  auto space = std::make_shared<ob::RealVectorStateSpace>(2);
  ob::RealVectorBounds bounds(2);
  bounds.setLow(0, lo.x);
  bounds.setLow(1, lo.y);
  bounds.setHigh(0, hi.x);
  bounds.setHigh(1, hi.y);
  space->setBounds(bounds);
  space->setStateSamplerAllocator(
      [seed](const ob::StateSpace* s) -> ob::StateSamplerPtr { return std::make_shared<SeededPlaneSampler>(s, seed); });
  auto si = std::make_shared<ob::SpaceInformation>(space);
  si->setStateValidityChecker(std::make_shared<PredicateValidity>(si, point_free));
  si->setMotionValidator(std::make_shared<PredicateMotion>(si, point_free, segment_free));
  si->setup();
  return si;
}

SeededPathSimplifier::SeededPathSimplifier(const ob::SpaceInformationPtr& si, uint32_t seed)
    : ompl::geometric::PathSimplifier(si) {
  rng_.setLocalSeed(seed);
}

}  // namespace vigil::planning
