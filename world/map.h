// Occupancy maps: loading (ROS map_server YAML + PGM/PNG, Stage worldfile floorplans), the
// grid queries the simulator and planners need (cell lookup, ray casting, free-space
// checks), and the conversion of occupied cells into wall rectangles for Box2D.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "world/geometry.h"
#include "world/status.h"

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

 private:
  size_t index(int cx, int cy) const { return static_cast<size_t>(cy) * width_ + cx; }
  int width_ = 0, height_ = 0;
  double resolution_ = 0.05;
  Pose2 origin_;
  std::vector<uint8_t> cells_;  // row-major, row 0 at the bottom (smallest y)
};

// Loads a ROS map_server YAML file and the PGM (P5/P2) or PNG image it names, relative to the
// YAML's folder (`image`, `resolution`, `origin` with yaw 0, `negate`, `occupied_thresh`,
// `free_thresh`, optional `mode`: trinary, or scale read as trinary; raw is refused). With
// p = (255 - grey) / 255 (grey / 255 if negate): p > occupied_thresh is occupied, p < free_thresh
// free, else unknown. Errors name the YAML file, line and key, or the image file.
Result<OccupancyGrid> load_map_yaml(const std::filesystem::path& yaml_path);

// Loads the `floorplan` of a Stage worldfile (`bitmap`, `size`, `pose`): the bitmap scaled to
// `size` metres and centred at `pose`. Dark pixels (< 50% grey) are walls, as in Stage; the rest
// is free. `include`s and other blocks are ignored; cells must be square (within 2%).
Result<OccupancyGrid> load_stage_world(const std::filesystem::path& world_path);

// Loads either format, chosen by extension (.yaml/.yml or .world).
Result<OccupancyGrid> load_map(const std::filesystem::path& path);

// Writes map_server YAML + PGM (free 254, occupied 0, unknown 205; thresholds 0.65 / 0.196).
// The PGM is named after the YAML (`map.yaml` -> `map.pgm`) and written beside it.
Status save_map_yaml(const OccupancyGrid& grid, const std::filesystem::path& yaml_path);

// An axis-aligned wall rectangle in the map frame.
struct WallBox {
  Vec2 min, max;
};

// Covers every occupied cell with axis-aligned rectangles (runs along rows merged with equal
// runs in the rows above), so walls become few Box2D bodies. Unknown cells are not walls.
std::vector<WallBox> extract_wall_boxes(const OccupancyGrid& grid);

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

 private:
  const OccupancyGrid* grid_;
  double clearance_;
  std::vector<float> dist_;  // per-cell clearance in metres
};

}  // namespace vigil
