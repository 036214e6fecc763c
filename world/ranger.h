// The laser ranger model, after Stage's ranger: `samples` beams spread over `fov`, each the
// distance to the first wall (exact traversal of the occupancy grid) or moving body (people,
// robots, objects on the floor, through a spatial hash), with optional Gaussian noise, clamped
// to [range_min, range_max].
#pragma once

#include <vector>

#include "common/geometry.h"
#include "world/map.h"
#include "world/plugin.h"
#include "common/rng.h"
#include "world/scenario.h"

namespace vigil {

// A body the laser can hit: a disc or an oriented box.
struct RangeObstacle {
  enum class Shape { kCircle, kBox } shape = Shape::kCircle;
  Vec2 center;
  double yaw = 0;
  double radius = 0.25;          // circle
  double half_x = 0, half_y = 0;  // box
  int owner = -1;                // entity index, so a robot's laser skips its own body
  double cos_yaw = 1, sin_yaw = 0;  // filled by ObstacleIndex::rebuild
};

// Distance along a unit ray to a disc or box, or +inf when missed (hits behind the origin
// and from inside do not count).
double ray_hit_circle(Vec2 origin, Vec2 dir, Vec2 center, double radius);
double ray_hit_box(Vec2 origin, Vec2 dir, Vec2 center, double yaw, double half_x, double half_y);
// The same with the box's rotation given as cos and sin of its yaw.
double ray_hit_box(Vec2 origin, Vec2 dir, Vec2 center, double cos_yaw, double sin_yaw, double half_x,
                   double half_y);

// Moving bodies bucketed in a uniform grid, rebuilt whenever scans are taken.
class ObstacleIndex {
 public:
  // `bounds_min/max`: area covered (the map's); `cell`: bucket size in metres.
  ObstacleIndex(Vec2 bounds_min, Vec2 bounds_max, double cell = 1.0);
  void rebuild(const std::vector<RangeObstacle>& obstacles);
  // Nearest hit along the ray up to `max_range`, skipping obstacles owned by `skip_owner`
  // (+inf when nothing is hit).
  double raycast(Vec2 origin, double angle, double max_range, int skip_owner) const {
    return raycast_dir(origin, {std::cos(angle), std::sin(angle)}, max_range, skip_owner);
  }
  // The same with a unit direction vector.
  double raycast_dir(Vec2 origin, Vec2 dir, double max_range, int skip_owner) const;

 private:
  Vec2 min_;
  double cell_;
  int nx_, ny_;
  std::vector<RangeObstacle> obstacles_;
  std::vector<std::vector<int>> buckets_;
};

// Ray casting against the map's walls, accelerated by a distance field: in open space a ray
// leaps by the distance to the nearest wall (less a cell and a half, so no wall is skipped);
// near walls it finishes with the exact grid traversal of OccupancyGrid::raycast. Gives the
// same distances as OccupancyGrid::raycast (to floating-point rounding).
class WallRaycaster {
 public:
  explicit WallRaycaster(const OccupancyGrid& map);
  double raycast(Vec2 from, double angle, double max_range) const {
    return raycast_dir(from, {std::cos(angle), std::sin(angle)}, max_range);
  }
  // The same with a unit direction vector.
  double raycast_dir(Vec2 from, Vec2 dir, double max_range) const;

 private:
  const OccupancyGrid* map_;
  int width_ = 0, height_ = 0;
  // Per cell, the distance in cells to the nearest occupied cell centre, floored and capped at
  // 255 (0 exactly for occupied cells): one byte a cell keeps the field in cache.
  std::vector<uint8_t> field_;
};

// Fills `scan` for a sensor at `sensor` (map frame); draws noise from `rng` when noise_std > 0.
void simulate_scan(const WallRaycaster& walls, const ObstacleIndex& bodies, Pose2 sensor,
                   const RangerSpec& spec, int self, Rng* rng, SimTime stamp, LaserScan* scan);

}  // namespace vigil
