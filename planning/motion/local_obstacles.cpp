#include "planning/motion/local_obstacles.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace vigil::planning {

LocalObstacles::LocalObstacles(std::vector<Vec2> points, double clearance)
    : points_(std::move(points)), clearance_(clearance) {
  lo_ = {std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()};
  hi_ = {-lo_.x, -lo_.y};
  for (const Vec2& p : points_) {
    lo_ = {std::min(lo_.x, p.x), std::min(lo_.y, p.y)};
    hi_ = {std::max(hi_.x, p.x), std::max(hi_.y, p.y)};
  }
}

LocalObstacles LocalObstacles::from_scan(const LaserScan& scan, Pose2 laser_pose, const InflatedGrid& map,
                                         double clearance, double wall_tolerance, double max_range) {
  std::vector<Vec2> pts;
  const double limit = std::min(max_range, scan.range_max - 1e-3);
  for (size_t i = 0; i < scan.ranges.size(); ++i) {
    const double r = scan.ranges[i];
    if (!std::isfinite(r) || r < scan.range_min || r >= limit) continue;
    const double a = laser_pose.yaw + scan.angle_min + static_cast<double>(i) * scan.angle_increment;
    const Vec2 p{laser_pose.x + r * std::cos(a), laser_pose.y + r * std::sin(a)};
    // A return on (or just in front of) a mapped wall is the map, not an obstacle.
    if (map.clearance().at_point(map.grid(), p) <= wall_tolerance) continue;
    pts.push_back(p);
  }
  return LocalObstacles(std::move(pts), clearance);
}

double LocalObstacles::distance(Vec2 p) const {
  double best = std::numeric_limits<double>::infinity();
  for (const Vec2& q : points_) best = std::min(best, (q - p).norm());
  return best;
}

bool LocalObstacles::segment_free(Vec2 a, Vec2 b) const { return segment_free(a, b, clearance_); }

bool LocalObstacles::segment_free(Vec2 a, Vec2 b, double c) const {
  if (points_.empty()) return true;
  // Whole segment's box, grown by the clearance, misses every point: free.
  if (std::max(a.x, b.x) + c < lo_.x || std::min(a.x, b.x) - c > hi_.x || std::max(a.y, b.y) + c < lo_.y ||
      std::min(a.y, b.y) - c > hi_.y) {
    return true;
  }
  const Vec2 d = b - a;
  const double len2 = d.dot(d);
  const double c2 = c * c;
  for (const Vec2& q : points_) {
    const double t = len2 > 0 ? std::clamp((q - a).dot(d) / len2, 0.0, 1.0) : 0.0;
    const Vec2 e = a + d * t - q;
    if (e.dot(e) < c2) return false;
  }
  return true;
}

}  // namespace vigil::planning
