// The laser ranger model, after Stage's ranger: `samples` beams spread over `fov`, each the
// distance to the first wall (exact traversal of the occupancy grid) or moving body (people,
// robots, objects on the floor, through a spatial hash), with optional Gaussian noise, clamped
// to [range_min, range_max].
#pragma once

#include <vector>

#include "world/geometry.h"
#include "world/map.h"
#include "world/plugin.h"
#include "world/rng.h"
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
};

// Distance along a unit ray to a disc or box, or +inf when missed (hits behind the origin
// and from inside do not count).
double ray_hit_circle(Vec2 origin, Vec2 dir, Vec2 center, double radius);
double ray_hit_box(Vec2 origin, Vec2 dir, Vec2 center, double yaw, double half_x, double half_y);

// Moving bodies bucketed in a uniform grid, rebuilt whenever scans are taken.
class ObstacleIndex {
 public:
  // `bounds_min/max`: area covered (the map's); `cell`: bucket size in metres.
  ObstacleIndex(Vec2 bounds_min, Vec2 bounds_max, double cell = 1.0);
  void rebuild(const std::vector<RangeObstacle>& obstacles);
  // Nearest hit along the ray up to `max_range`, skipping obstacles owned by `skip_owner`.
  double raycast(Vec2 origin, double angle, double max_range, int skip_owner) const;

 private:
  Vec2 min_;
  double cell_;
  int nx_, ny_;
  std::vector<RangeObstacle> obstacles_;
  std::vector<std::vector<int>> buckets_;
};

// Fills `scan` for a sensor at `sensor` (map frame); draws noise from `rng` when noise_std > 0.
void simulate_scan(const OccupancyGrid& map, const ObstacleIndex& bodies, Pose2 sensor,
                   const RangerSpec& spec, int self, Rng* rng, SimTime stamp, LaserScan* scan);

}  // namespace vigil
