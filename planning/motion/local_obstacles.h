// What the robot's laser sees now that the static map does not hold (people, bags, robots),
// as points in the map frame, and the checks the motion level plans against: a disc robot of
// radius r keeps `radius + margin` from every point.
#pragma once

#include <vector>

#include "common/geometry.h"
#include "common/laser_scan.h"
#include "common/occupancy_grid.h"
#include "planning/grid/inflated_grid.h"

namespace vigil::planning {

class LocalObstacles {
 public:
  LocalObstacles() = default;
  LocalObstacles(std::vector<Vec2> points, double clearance);
  // Laser returns (laser at `laser_pose` in the map frame) farther than `wall_tolerance` from
  // every occupied cell of the static map, within `max_range`: the unmapped obstacles.
  static LocalObstacles from_scan(const LaserScan& scan, Pose2 laser_pose, const InflatedGrid& map,
                                  double clearance, double wall_tolerance = 0.15, double max_range = 6.0);

  bool empty() const { return points_.empty(); }
  const std::vector<Vec2>& points() const { return points_; }
  double clearance() const { return clearance_; }  // required distance from a point (m)
  // Distance from p to the nearest point (+inf when none).
  double distance(Vec2 p) const;
  bool point_free(Vec2 p) const { return distance(p) >= clearance_; }
  // True when the segment keeps the clearance from every point.
  bool segment_free(Vec2 a, Vec2 b) const;
  // The same with another clearance.
  bool segment_free(Vec2 a, Vec2 b, double clearance) const;

 private:
  std::vector<Vec2> points_;
  double clearance_ = 0;
  Vec2 lo_, hi_;  // bounding box of the points
};

}  // namespace vigil::planning
