// The configuration space of a disc robot on an occupancy grid: a cell is free when its centre
// is at least `radius` from every cell that is not free (the map inflated by the robot's
// radius, through the exact clearance field). Segment checks traverse the cells exactly, so a
// segment that passes is free at grid resolution. Connected components of the free cells tell
// whether a path exists at all before any planner runs.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "common/geometry.h"
#include "common/occupancy_grid.h"
#include "planning/grid/clearance_field.h"

namespace vigil::planning {

class InflatedGrid {
 public:
  // The grid must outlive this object.
  InflatedGrid(const OccupancyGrid& grid, double radius);

  const OccupancyGrid& grid() const { return *grid_; }
  const ClearanceField& clearance() const { return clearance_; }
  double radius() const { return radius_; }
  int width() const { return grid_->width(); }
  int height() const { return grid_->height(); }

  bool cell_free(int cx, int cy) const {
    return grid_->in_bounds(cx, cy) && free_[static_cast<size_t>(cy) * width() + cx] != 0;
  }
  // True when the point is in the grid and its cell is free for the robot.
  bool is_free(Vec2 p) const;
  // True when every cell the segment a-b touches is free (exact traversal; through a cell
  // corner both side cells are checked).
  bool segment_free(Vec2 a, Vec2 b) const;
  // The centre of the nearest free cell within `max_distance` of p (breadth-first over cells),
  // or nothing.
  std::optional<Vec2> nearest_free(Vec2 p, double max_distance) const;
  // Connected component (8-connected, no corner cutting) of a free point; -1 when not free.
  int component(Vec2 p) const;
  int component_of_cell(int cx, int cy) const {
    return cell_free(cx, cy) ? component_[static_cast<size_t>(cy) * width() + cx] : -1;
  }
  int component_count() const { return components_; }
  // Free area (m^2) of a component.
  double component_area(int c) const;
  size_t free_cells() const { return free_count_; }
  // Points inside the map's bounding box (for samplers).
  Vec2 lower() const { return {grid_->origin().x, grid_->origin().y}; }
  Vec2 upper() const { return {grid_->origin().x + grid_->size_x(), grid_->origin().y + grid_->size_y()}; }
  // 64-bit fingerprint of the free cells and the radius (for roadmap caches).
  uint64_t fingerprint() const;

 private:
  const OccupancyGrid* grid_;
  double radius_;
  ClearanceField clearance_;
  std::vector<uint8_t> free_;
  std::vector<int32_t> component_;
  std::vector<int64_t> component_cells_;
  int components_ = 0;
  size_t free_count_ = 0;
};

// Length of a polyline.
double path_length(const std::vector<Vec2>& path);

}  // namespace vigil::planning
