// Occupancy map files: loading (ROS map_server YAML + PGM/PNG, Stage worldfile floorplans) into
// the shared OccupancyGrid (common/occupancy_grid.h), writing them, and the conversion of occupied
// cells into wall rectangles for Box2D.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "common/geometry.h"
#include "common/occupancy_grid.h"
#include "world/status.h"

namespace vigil {

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

// What the simulator makes of a loaded map before it builds walls: specks of at most 12
// 4-connected unknown cells away from the grid's edge become free (SLAM maps sprinkle them inside
// rooms), then every unknown cell next to a free one becomes occupied (SLAM maps leave gaps where
// the robot saw no wall, so nothing walks, drives or sees off the known map). World::create and
// the tools that draw a finished run (vigil report, vigil export-mcap) call it.
void prepare_simulation_map(OccupancyGrid* map);

// An axis-aligned wall rectangle in the map frame.
struct WallBox {
  Vec2 min, max;
};

// Covers every occupied cell with axis-aligned rectangles (runs along rows merged with equal
// runs in the rows above), so walls become few Box2D bodies. Unknown cells are not walls.
std::vector<WallBox> extract_wall_boxes(const OccupancyGrid& grid);

}  // namespace vigil
