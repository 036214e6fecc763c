// Grid paths: 8-connected A* with octile costs over the cells that keep a clearance from walls,
// shortened by line of sight. Scripted people walk these paths; the planners use the same search
// for their references. (Moved from world/map.cpp; behaviour unchanged.)
#pragma once

#include <vector>

#include "common/geometry.h"
#include "common/occupancy_grid.h"
#include "planning/grid/clearance_field.h"

namespace vigil::planning {

// Paths on the grid for scripted people: A* (8-connected, octile distance) over cells whose
// clearance from walls and unknown space is at least `clearance` metres, then shortened by
// line-of-sight. The clearance field is computed once at construction; the grid must outlive
// the planner. Clearance is measured between cell centres, and the grid's edge counts as unknown.
class GridPathPlanner {
 public:
  GridPathPlanner(const OccupancyGrid& grid, double clearance);
  // Map points from start to goal (both included), or empty when no path exists. A start or
  // goal inside the clearance margin (but in free space) is allowed: the path leaves it by the
  // nearest cell that has the clearance.
  std::vector<Vec2> plan(Vec2 start, Vec2 goal) const;
  // Clearance (metres to the nearest non-free cell) at a point; 0 outside the grid.
  double clearance_at(Vec2 p) const;
  const ClearanceField& clearance_field() const { return clearance_field_; }

 private:
  const OccupancyGrid* grid_;
  double clearance_;
  ClearanceField clearance_field_;
};

}  // namespace vigil::planning
