#include "common/occupancy_grid.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace vigil {


OccupancyGrid::OccupancyGrid(int width, int height, double resolution, Pose2 origin, Cell fill)
    : width_(std::max(width, 0)),
      height_(std::max(height, 0)),
      resolution_(resolution),
      origin_(origin),
      cells_(static_cast<size_t>(std::max(width, 0)) * static_cast<size_t>(std::max(height, 0)),
             static_cast<uint8_t>(fill)) {}

bool OccupancyGrid::world_to_cell(Vec2 p, int* cx, int* cy) const {
  const double u = (p.x - origin_.x) / resolution_;
  const double v = (p.y - origin_.y) / resolution_;
  if (!(u >= 0 && v >= 0 && u < width_ && v < height_)) return false;  // also rejects NaN
  *cx = std::min(static_cast<int>(u), width_ - 1);
  *cy = std::min(static_cast<int>(v), height_ - 1);
  return true;
}

Vec2 OccupancyGrid::cell_center(int cx, int cy) const {
  return {origin_.x + (cx + 0.5) * resolution_, origin_.y + (cy + 0.5) * resolution_};
}

bool OccupancyGrid::is_free(Vec2 p) const {
  int cx, cy;
  return world_to_cell(p, &cx, &cy) && at(cx, cy) == Cell::kFree;
}

bool OccupancyGrid::is_free_disc(Vec2 p, double radius) const {
  if (!is_free(p)) return false;
  if (!(radius > 0)) return true;
  // Work in cell units: a cell counts when its square comes strictly closer than r to p.
  const double u = (p.x - origin_.x) / resolution_;
  const double v = (p.y - origin_.y) / resolution_;
  const double r = radius / resolution_;
  // A cell beyond an edge, level with p, lies within r exactly when the disc crosses that edge.
  if (u - r < 0 || v - r < 0 || u + r > width_ || v + r > height_) return false;
  const int x0 = static_cast<int>(std::floor(u - r)), x1 = std::min(static_cast<int>(u + r), width_ - 1);
  const int y0 = static_cast<int>(std::floor(v - r)), y1 = std::min(static_cast<int>(v + r), height_ - 1);
  const double r2 = r * r;
  for (int cy = y0; cy <= y1; ++cy) {
    const double dy = std::max({cy - v, 0.0, v - (cy + 1)});
    for (int cx = x0; cx <= x1; ++cx) {
      const double dx = std::max({cx - u, 0.0, u - (cx + 1)});
      if (dx * dx + dy * dy < r2 && at(cx, cy) != Cell::kFree) return false;
    }
  }
  return true;
}

double OccupancyGrid::raycast(Vec2 from, double angle, double max_range, bool unknown_blocks) const {
  if (!(max_range > 0)) return 0;
  int cx, cy;
  if (!world_to_cell(from, &cx, &cy)) return 0;
  auto blocks = [&](int x, int y) {
    const Cell c = at(x, y);
    return c == Cell::kOccupied || (unknown_blocks && c == Cell::kUnknown);
  };
  if (blocks(cx, cy)) return 0;
  // Amanatides-Woo: walk the cells the ray enters, in order, in cell units. The parameter of
  // each next boundary is recomputed from the integer cell index so no error accumulates.
  const double dx = std::cos(angle), dy = std::sin(angle);
  const double u = (from.x - origin_.x) / resolution_;
  const double v = (from.y - origin_.y) / resolution_;
  const int step_x = dx > 0 ? 1 : (dx < 0 ? -1 : 0);
  const int step_y = dy > 0 ? 1 : (dy < 0 ? -1 : 0);
  const double inf = std::numeric_limits<double>::infinity();
  auto next_x = [&] { return step_x == 0 ? inf : ((step_x > 0 ? cx + 1 : cx) - u) / dx; };
  auto next_y = [&] { return step_y == 0 ? inf : ((step_y > 0 ? cy + 1 : cy) - v) / dy; };
  const double max_t = max_range / resolution_;
  while (true) {
    const double tx = next_x(), ty = next_y();
    double t;
    if (tx < ty) {
      t = tx;
      cx += step_x;
    } else {
      t = ty;
      cy += step_y;
    }
    if (t >= max_t) return max_range;
    if (!in_bounds(cx, cy) || blocks(cx, cy)) return t * resolution_;
  }
}

size_t OccupancyGrid::count(Cell c) const {
  return static_cast<size_t>(std::count(cells_.begin(), cells_.end(), static_cast<uint8_t>(c)));
}

uint64_t OccupancyGrid::fingerprint() const {
  uint64_t h = 1469598103934665603ull;
  auto mix = [&h](const void* data, size_t n) {
    const auto* b = static_cast<const uint8_t*>(data);
    for (size_t i = 0; i < n; ++i) h = (h ^ b[i]) * 1099511628211ull;
  };
  const double geometry[5] = {static_cast<double>(width_), static_cast<double>(height_), resolution_, origin_.x, origin_.y};
  mix(geometry, sizeof geometry);
  mix(cells_.data(), cells_.size());
  return h;
}

}  // namespace vigil
