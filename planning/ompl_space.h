// OMPL glue for planning a disc robot's position in the plane: an R^2 state space over given
// bounds, a validity checker and an exact motion validator over caller-supplied predicates, and
// samplers seeded from our own seed (OMPL's RNGs otherwise draw from a process-wide seed
// generator, which would make roadmaps depend on what else the process planned before).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>

#include <ompl/base/SpaceInformation.h>
#include <ompl/geometric/PathGeometric.h>
#include <ompl/geometric/PathSimplifier.h>

#include "common/geometry.h"

namespace vigil::planning {

using PointCheck = std::function<bool(Vec2)>;
using SegmentCheck = std::function<bool(Vec2, Vec2)>;

// SpaceInformation over [lo, hi] with the two checks; every sampler it allocates is seeded
// with `seed`. Set up and ready to use.
ompl::base::SpaceInformationPtr make_plane_space(Vec2 lo, Vec2 hi, PointCheck point_free,
                                                 SegmentCheck segment_free, uint32_t seed);

Vec2 state_point(const ompl::base::State* s);
void set_state_point(ompl::base::State* s, Vec2 p);
std::vector<Vec2> path_points(const ompl::geometric::PathGeometric& path);

// OMPL's path simplifier with its random choices seeded.
class SeededPathSimplifier : public ompl::geometric::PathSimplifier {
 public:
  SeededPathSimplifier(const ompl::base::SpaceInformationPtr& si, uint32_t seed);
};

// Routes OMPL's console messages to nothing below warnings and keeps its output off stdout
// (called once by every planner constructor; idempotent).
void quiet_ompl();

}  // namespace vigil::planning
