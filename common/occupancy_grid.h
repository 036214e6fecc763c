// The occupancy grid every part shares: the simulator's walls, the planners' free space and the
// localisation's map. Cells as ROS nav_msgs/OccupancyGrid; cell queries and exact ray casting.
// Map file I/O lives in world/map.h.
#pragma once

#include <cstdint>
#include <vector>

#include "common/geometry.h"

namespace vigil {

// Cell states, as ROS nav_msgs/OccupancyGrid uses them.
enum class Cell : uint8_t { kFree = 0, kOccupied = 100, kUnknown = 255 };

// A 2D occupancy grid in the map frame. Cell (0, 0) is the lower-left cell, whose lower-left
// corner is at `origin`; cell (cx, cy) covers [origin.x + cx*res, origin.x + (cx+1)*res) in x,
// likewise in y. (The image's first row is the map's top, as in map_server.)
class OccupancyGrid {
 public:
  OccupancyGrid() = default;
  OccupancyGrid(int width, int height, double resolution, Pose2 origin, Cell fill = Cell::kFree);

  int width() const { return width_; }
  int height() const { return height_; }
  double resolution() const { return resolution_; }
  Pose2 origin() const { return origin_; }  // origin.yaw must be 0 (checked at load)
  double size_x() const { return width_ * resolution_; }
  double size_y() const { return height_ * resolution_; }

  bool in_bounds(int cx, int cy) const { return cx >= 0 && cy >= 0 && cx < width_ && cy < height_; }
  Cell at(int cx, int cy) const { return static_cast<Cell>(cells_[index(cx, cy)]); }
  void set(int cx, int cy, Cell c) { cells_[index(cx, cy)] = static_cast<uint8_t>(c); }
  // Cell containing a map-frame point; false when outside the grid.
  bool world_to_cell(Vec2 p, int* cx, int* cy) const;
  // Centre of a cell in the map frame.
  Vec2 cell_center(int cx, int cy) const;
  // True when the point is inside the grid and its cell is free.
  bool is_free(Vec2 p) const;
  // True when every cell within `radius` of p is free (a disc of that radius fits there).
  bool is_free_disc(Vec2 p, double radius) const;
  // Distance from `from` along `angle` to the first occupied (or, if `unknown_blocks`, unknown)
  // cell or the grid's edge, capped at max_range. Exact grid traversal (Amanatides-Woo).
  double raycast(Vec2 from, double angle, double max_range, bool unknown_blocks = false) const;

  size_t count(Cell c) const;
  const std::vector<uint8_t>& cells() const { return cells_; }
  // A hash of the size, resolution, origin and every cell (FNV-1a): what caches of data built
  // from a map key on, since a map's address can be reused by another map after it is freed.
  uint64_t fingerprint() const;

 private:
  size_t index(int cx, int cy) const { return static_cast<size_t>(cy) * width_ + cx; }
  int width_ = 0, height_ = 0;
  double resolution_ = 0.05;
  Pose2 origin_;
  std::vector<uint8_t> cells_;  // row-major, row 0 at the bottom (smallest y)
};

}  // namespace vigil
