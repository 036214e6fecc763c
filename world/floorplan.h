// The project's own vector floorplans (maps/*.floorplan.yaml): walls with thickness and
// height, doors cut into them, furniture such as tables, and named places. A floorplan
// rasterises to an OccupancyGrid (and exports map_server YAML + PGM) for the simulator and
// planners, and keeps its 3D facts (wall and table heights) for the renderer.
#pragma once

#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "common/geometry.h"
#include "world/map.h"
#include "world/status.h"

namespace vigil {

struct FloorplanWall {
  Vec2 from, to;
  double thickness = 0.15;  // m
  double height = 2.7;      // m
};

// A gap cut through whatever walls it crosses: a door of `width` centred at `center`, across
// a wall running at angle `yaw` (the wall's direction).
struct FloorplanDoor {
  std::string name;
  Vec2 center;
  double width = 0.9;
  double yaw = 0;
};

// Furniture is an obstacle in the occupancy grid (a table's footprint) with a height; objects
// can stand on it.
struct FloorplanFurniture {
  std::string name;
  std::string kind;  // "table", "cabinet", ...
  Pose2 pose;        // centre and yaw
  double size_x = 1.6, size_y = 0.8, height = 0.75;
};

struct Floorplan {
  std::string name;
  std::filesystem::path source;  // file it was read from
  double resolution = 0.05;      // raster resolution, m/cell
  Vec2 bounds_min, bounds_max;   // raster extent in the map frame
  std::vector<FloorplanWall> walls;
  std::vector<FloorplanDoor> doors;
  std::vector<FloorplanFurniture> furniture;
  std::map<std::string, Vec2> places;  // named places, e.g. "corridor_mid"

  // Rasterises walls (minus doors) and furniture footprints; the rest is free.
  OccupancyGrid rasterize() const;
  const FloorplanFurniture* find_furniture(const std::string& name) const;
};

// Reads a floorplan YAML file; errors name the file, line and key.
Result<Floorplan> load_floorplan(const std::filesystem::path& path);

// Rasterises and writes map_server YAML + PGM beside each other (yaml_path's stem + ".pgm").
Status export_floorplan(const Floorplan& plan, const std::filesystem::path& yaml_path);

}  // namespace vigil
