#include "world/ranger.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

namespace vigil {
namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
}

double ray_hit_circle(Vec2 o, Vec2 d, Vec2 c, double r) {
  const Vec2 oc = o - c;
  const double b = oc.dot(d);
  const double cc = oc.dot(oc) - r * r;
  if (cc <= 0) return kInf;  // origin inside
  const double disc = b * b - cc;
  if (disc < 0) return kInf;
  const double t = -b - std::sqrt(disc);
  return t >= 0 ? t : kInf;
}

double ray_hit_box(Vec2 o, Vec2 d, Vec2 c, double yaw, double hx, double hy) {
  return ray_hit_box(o, d, c, std::cos(yaw), std::sin(yaw), hx, hy);
}

double ray_hit_box(Vec2 o, Vec2 d, Vec2 c, double cs, double sn, double hx, double hy) {
  // Into the box frame, then a slab test.
  const Vec2 rel = o - c;
  const double ox = cs * rel.x + sn * rel.y, oy = -sn * rel.x + cs * rel.y;
  const double dx = cs * d.x + sn * d.y, dy = -sn * d.x + cs * d.y;
  double t0 = -kInf, t1 = kInf;
  auto slab = [&](double op, double dp, double h) {
    if (std::abs(dp) < 1e-12) {
      if (op < -h || op > h) t0 = kInf;
      return;
    }
    double a = (-h - op) / dp, b = (h - op) / dp;
    if (a > b) std::swap(a, b);
    t0 = std::max(t0, a);
    t1 = std::min(t1, b);
  };
  slab(ox, dx, hx);
  slab(oy, dy, hy);
  if (t0 > t1 || t0 < 0) return kInf;  // missed, or origin inside
  return t0;
}

ObstacleIndex::ObstacleIndex(Vec2 bounds_min, Vec2 bounds_max, double cell)
    : min_(bounds_min), cell_(cell) {
  nx_ = std::max(1, static_cast<int>(std::ceil((bounds_max.x - bounds_min.x) / cell)));
  ny_ = std::max(1, static_cast<int>(std::ceil((bounds_max.y - bounds_min.y) / cell)));
  buckets_.resize(static_cast<size_t>(nx_) * ny_);
}

void ObstacleIndex::rebuild(const std::vector<RangeObstacle>& obstacles) {
  for (auto& b : buckets_) b.clear();
  obstacles_ = obstacles;
  for (auto& ob : obstacles_) {
    ob.cos_yaw = std::cos(ob.yaw);
    ob.sin_yaw = std::sin(ob.yaw);
  }
  for (int i = 0; i < static_cast<int>(obstacles_.size()); ++i) {
    const auto& ob = obstacles_[i];
    const double r = ob.shape == RangeObstacle::Shape::kCircle ? ob.radius : std::hypot(ob.half_x, ob.half_y);
    const int x0 = std::clamp(static_cast<int>(std::floor((ob.center.x - r - min_.x) / cell_)), 0, nx_ - 1);
    const int x1 = std::clamp(static_cast<int>(std::floor((ob.center.x + r - min_.x) / cell_)), 0, nx_ - 1);
    const int y0 = std::clamp(static_cast<int>(std::floor((ob.center.y - r - min_.y) / cell_)), 0, ny_ - 1);
    const int y1 = std::clamp(static_cast<int>(std::floor((ob.center.y + r - min_.y) / cell_)), 0, ny_ - 1);
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) buckets_[static_cast<size_t>(y) * nx_ + x].push_back(i);
  }
}

double ObstacleIndex::raycast_dir(Vec2 o, Vec2 d, double max_range, int skip_owner) const {
  if (obstacles_.empty()) return kInf;
  // Amanatides-Woo over the buckets, stopping once the best hit is closer than the next cell.
  double gx = (o.x - min_.x) / cell_, gy = (o.y - min_.y) / cell_;
  int cx = static_cast<int>(std::floor(gx)), cy = static_cast<int>(std::floor(gy));
  const int step_x = d.x > 0 ? 1 : -1, step_y = d.y > 0 ? 1 : -1;
  const double tdx = std::abs(d.x) > 1e-12 ? cell_ / std::abs(d.x) : kInf;
  const double tdy = std::abs(d.y) > 1e-12 ? cell_ / std::abs(d.y) : kInf;
  double tmx = std::abs(d.x) > 1e-12 ? ((d.x > 0 ? (cx + 1 - gx) : (gx - cx)) * cell_) / std::abs(d.x) : kInf;
  double tmy = std::abs(d.y) > 1e-12 ? ((d.y > 0 ? (cy + 1 - gy) : (gy - cy)) * cell_) / std::abs(d.y) : kInf;
  double best = kInf;
  double t_enter = 0;
  while (t_enter <= max_range && t_enter < best) {
    if (cx >= 0 && cy >= 0 && cx < nx_ && cy < ny_) {
      for (int idx : buckets_[static_cast<size_t>(cy) * nx_ + cx]) {
        const auto& ob = obstacles_[idx];
        if (skip_owner >= 0 && ob.owner == skip_owner) continue;
        const double t = ob.shape == RangeObstacle::Shape::kCircle
                             ? ray_hit_circle(o, d, ob.center, ob.radius)
                             : ray_hit_box(o, d, ob.center, ob.cos_yaw, ob.sin_yaw, ob.half_x, ob.half_y);
        best = std::min(best, t);
      }
    } else if ((cx < 0 && step_x < 0) || (cx >= nx_ && step_x > 0) || (cy < 0 && step_y < 0) ||
               (cy >= ny_ && step_y > 0)) {
      break;  // left the indexed area for good
    }
    if (tmx < tmy) {
      t_enter = tmx;
      tmx += tdx;
      cx += step_x;
    } else {
      t_enter = tmy;
      tmy += tdy;
      cy += step_y;
    }
  }
  return best <= max_range ? best : kInf;
}

WallRaycaster::WallRaycaster(const OccupancyGrid& map)
    : map_(&map), width_(map.width()), height_(map.height()) {
  cv::Mat free_mask(map.height(), map.width(), CV_8U);
  for (int cy = 0; cy < height_; ++cy) {
    auto* row = free_mask.ptr<uint8_t>(cy);
    for (int cx = 0; cx < width_; ++cx) row[cx] = map.at(cx, cy) == Cell::kOccupied ? 0 : 255;
  }
  cv::Mat dist;
  cv::distanceTransform(free_mask, dist, cv::DIST_L2, cv::DIST_MASK_PRECISE, CV_32F);
  field_.resize(static_cast<size_t>(width_) * height_);
  for (size_t i = 0; i < field_.size(); ++i) {
    const float f = dist.ptr<float>()[i];
    field_[i] = static_cast<uint8_t>(std::min(255.0f, std::floor(f)));
  }
}

double WallRaycaster::raycast_dir(Vec2 from, Vec2 d, double max_range) const {
  // Everything in cell units: grid coordinates (u, v), ray parameter t.
  constexpr float kLeapCells = 3.0f;    // leap only where the nearest wall is at least this far
  constexpr float kSafetyCells = 1.5f;  // both cells' half-diagonals, rounded up
  constexpr int kExactCells = 12;       // cells walked exactly before looking at the field again
  const double res = map_->resolution();
  const double u0 = (from.x - map_->origin().x) / res, v0 = (from.y - map_->origin().y) / res;
  const double max_t = max_range / res;
  if (!(max_t > 0)) return 0;
  const int step_x = d.x > 0 ? 1 : (d.x < 0 ? -1 : 0);
  const int step_y = d.y > 0 ? 1 : (d.y < 0 ? -1 : 0);
  const double inv_x = step_x ? 1.0 / d.x : 0, inv_y = step_y ? 1.0 / d.y : 0;
  double t = 0;
  int cx = static_cast<int>(std::floor(u0)), cy = static_cast<int>(std::floor(v0));
  if (cx < 0 || cy < 0 || cx >= width_ || cy >= height_) return 0;
  if (field_[static_cast<size_t>(cy) * width_ + cx] == 0) return 0;
  while (true) {
    const float field = field_[static_cast<size_t>(cy) * width_ + cx];
    if (field >= kLeapCells) {
      // Leap, then find the cell the ray is in (never back before t).
      t += field - kSafetyCells;
      if (t >= max_t) return max_range;
      cx = static_cast<int>(std::floor(u0 + d.x * t));
      cy = static_cast<int>(std::floor(v0 + d.y * t));
      if (cx < 0 || cy < 0 || cx >= width_ || cy >= height_) break;
      continue;
    }
    // Exact traversal (Amanatides-Woo) from the current cell; boundaries recomputed from the
    // integer cell index so no error accumulates.
    for (int k = 0; k < kExactCells; ++k) {
      const double tx = step_x ? ((step_x > 0 ? cx + 1 : cx) - u0) * inv_x : INFINITY;
      const double ty = step_y ? ((step_y > 0 ? cy + 1 : cy) - v0) * inv_y : INFINITY;
      if (tx < ty) {
        t = tx;
        cx += step_x;
      } else {
        t = ty;
        cy += step_y;
      }
      if (t >= max_t) return max_range;
      if (cx < 0 || cy < 0 || cx >= width_ || cy >= height_) return t * res;  // grid edge
      if (field_[static_cast<size_t>(cy) * width_ + cx] == 0) return t * res;
    }
  }
  return std::min(max_range, t * res);
}

void simulate_scan(const WallRaycaster& walls, const ObstacleIndex& bodies, Pose2 sensor,
                   const RangerSpec& spec, int self, Rng* rng, SimTime stamp, LaserScan* scan) {
  const int n = std::max(1, spec.samples);
  scan->stamp = stamp;
  scan->range_min = spec.range_min;
  scan->range_max = spec.range_max;
  scan->angle_min = -spec.fov / 2;
  scan->angle_increment = n > 1 ? spec.fov / (n - 1) : 0;
  scan->ranges.resize(n);
  const Vec2 o = sensor.position();
  // Beam directions by rotating the first one by the increment: two sincos per scan, not one per
  // beam (the rounding this accumulates over a scan is below 1e-13 rad).
  const double a0 = sensor.yaw + scan->angle_min;
  const double ci = std::cos(scan->angle_increment), si = std::sin(scan->angle_increment);
  Vec2 d{std::cos(a0), std::sin(a0)};
  for (int i = 0; i < n; ++i, d = Vec2{ci * d.x - si * d.y, si * d.x + ci * d.y}) {
    double r = walls.raycast_dir(o, d, spec.range_max);
    r = std::min(r, bodies.raycast_dir(o, d, r, self));
    if (spec.noise_std > 0 && rng && r < spec.range_max) r += rng->normal(0.0, spec.noise_std);
    scan->ranges[i] = static_cast<float>(std::clamp(r, spec.range_min, spec.range_max));
  }
}

}  // namespace vigil
