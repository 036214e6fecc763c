#include "planning/grid/inflated_grid.h"

#include "planning/grid/grid_traversal.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <limits>

namespace vigil::planning {

InflatedGrid::InflatedGrid(const OccupancyGrid& grid, double radius)
    : grid_(&grid), radius_(std::max(radius, 0.0)), clearance_(grid) {
  const int w = grid.width(), h = grid.height();
  const size_t n = static_cast<size_t>(w) * h;
  free_.assign(n, 0);
  // Clearance is stored in float; a micrometre of slack keeps exact thresholds passable.
  const float need = static_cast<float>(radius_ - 1e-6);
  const auto& cells = grid.cells();
  for (size_t i = 0; i < n; ++i) {
    free_[i] = cells[i] == static_cast<uint8_t>(Cell::kFree) && clearance_.at_index(i) >= need;
    free_count_ += free_[i];
  }
  // Components: breadth-first flood fill, 8-connected without cutting corners.
  component_.assign(n, -1);
  std::vector<int64_t> queue;
  for (size_t start = 0; start < n; ++start) {
    if (!free_[start] || component_[start] >= 0) continue;
    const int id = components_++;
    int64_t cells_in = 0;
    queue.clear();
    queue.push_back(static_cast<int64_t>(start));
    component_[start] = id;
    for (size_t q = 0; q < queue.size(); ++q) {
      const int64_t i = queue[q];
      ++cells_in;
      const int cx = static_cast<int>(i % w), cy = static_cast<int>(i / w);
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
          if (!dx && !dy) continue;
          const int nx = cx + dx, ny = cy + dy;
          if (!cell_free(nx, ny)) continue;
          if (dx && dy && (!cell_free(cx + dx, cy) || !cell_free(cx, cy + dy))) continue;
          const size_t ni = static_cast<size_t>(ny) * w + nx;
          if (component_[ni] >= 0) continue;
          component_[ni] = id;
          queue.push_back(static_cast<int64_t>(ni));
        }
      }
    }
    component_cells_.push_back(cells_in);
  }
}

bool InflatedGrid::is_free(Vec2 p) const {
  int cx, cy;
  return grid_->world_to_cell(p, &cx, &cy) && cell_free(cx, cy);
}

bool InflatedGrid::segment_free(Vec2 a, Vec2 b) const {
  const double res = grid_->resolution();
  const Pose2 o = grid_->origin();
  const Vec2 p{(a.x - o.x) / res, (a.y - o.y) / res};
  const Vec2 q{(b.x - o.x) / res, (b.y - o.y) / res};
  if (!(p.x >= 0 && p.y >= 0 && q.x >= 0 && q.y >= 0 && p.x < width() && q.x < width() && p.y < height() &&
        q.y < height())) {
    return false;  // also NaN
  }
  return cells_along_segment(p, q, static_cast<int>(p.x), static_cast<int>(p.y), static_cast<int>(q.x),
                             static_cast<int>(q.y), 4 * (width() + height()),
                             [this](int x, int y) { return cell_free(x, y); });
}

std::optional<Vec2> InflatedGrid::nearest_free(Vec2 p, double max_distance) const {
  int sx, sy;
  if (!grid_->world_to_cell(p, &sx, &sy)) return std::nullopt;
  if (cell_free(sx, sy)) return p;
  const int r = static_cast<int>(std::ceil(max_distance / grid_->resolution()));
  // Rings of growing Chebyshev radius; within a ring the nearest by Euclidean distance, ties
  // by scan order, so the answer is deterministic.
  for (int ring = 1; ring <= r; ++ring) {
    double best = std::numeric_limits<double>::infinity();
    std::optional<Vec2> found;
    for (int dy = -ring; dy <= ring; ++dy) {
      for (int dx = -ring; dx <= ring; ++dx) {
        if (std::max(std::abs(dx), std::abs(dy)) != ring) continue;
        if (!cell_free(sx + dx, sy + dy)) continue;
        const Vec2 c = grid_->cell_center(sx + dx, sy + dy);
        const double d = (c - p).norm();
        if (d < best && d <= max_distance) {
          best = d;
          found = c;
        }
      }
    }
    if (found) return found;
  }
  return std::nullopt;
}

int InflatedGrid::component(Vec2 p) const {
  int cx, cy;
  if (!grid_->world_to_cell(p, &cx, &cy)) return -1;
  return component_of_cell(cx, cy);
}

double InflatedGrid::component_area(int c) const {
  if (c < 0 || c >= components_) return 0;
  return static_cast<double>(component_cells_[c]) * grid_->resolution() * grid_->resolution();
}

uint64_t InflatedGrid::fingerprint() const {
  uint64_t h = 1469598103934665603ull;
  auto mix = [&](uint64_t v) {
    for (int i = 0; i < 8; ++i) h = (h ^ ((v >> (8 * i)) & 0xff)) * 1099511628211ull;
  };
  mix(static_cast<uint64_t>(width()));
  mix(static_cast<uint64_t>(height()));
  mix(static_cast<uint64_t>(std::llround(grid_->resolution() * 1e9)));
  mix(static_cast<uint64_t>(std::llround(grid_->origin().x * 1e6)));
  mix(static_cast<uint64_t>(std::llround(grid_->origin().y * 1e6)));
  mix(static_cast<uint64_t>(std::llround(radius_ * 1e6)));
  for (uint8_t f : free_) h = (h ^ f) * 1099511628211ull;
  return h;
}

double path_length(const std::vector<Vec2>& path) {
  double L = 0;
  for (size_t i = 1; i < path.size(); ++i) L += (path[i] - path[i - 1]).norm();
  return L;
}

}  // namespace vigil::planning
