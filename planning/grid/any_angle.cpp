#include "planning/grid/any_angle.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <queue>

namespace vigil::planning {

AnyAnglePlanner::AnyAnglePlanner(const InflatedGrid& grid) : grid_(&grid) {
  const size_t n = static_cast<size_t>(grid.width()) * grid.height();
  g_.assign(n, std::numeric_limits<double>::infinity());
  parent_.assign(n, -1);
  closed_.assign(n, 0);
}

ReferencePath AnyAnglePlanner::plan(Vec2 start, Vec2 goal) {
  ReferencePath out;
  const InflatedGrid& ig = *grid_;
  const OccupancyGrid& grid = ig.grid();
  int sx, sy, gx, gy;
  if (!grid.world_to_cell(start, &sx, &sy) || !grid.world_to_cell(goal, &gx, &gy)) return out;
  if (!ig.cell_free(sx, sy) || !ig.cell_free(gx, gy)) return out;
  if (ig.component_of_cell(sx, sy) != ig.component_of_cell(gx, gy)) return out;
  for (int32_t i : touched_) {
    g_[i] = std::numeric_limits<double>::infinity();
    parent_[i] = -1;
    closed_[i] = 0;
  }
  touched_.clear();
  const int w = ig.width();
  const int32_t s_index = sy * w + sx, g_index = gy * w + gx;
  if (s_index == g_index) {
    out.found = true;
    out.points = {start, goal};
    out.length = (goal - start).norm();
    return out;
  }
  // The start and goal cells stand for the exact start and goal points.
  auto pos = [&](int32_t i) {
    if (i == s_index) return start;
    if (i == g_index) return goal;
    return grid.cell_center(i % w, i / w);
  };
  auto visible = [&](int32_t a, int32_t b) { return ig.segment_free(pos(a), pos(b)); };
  struct Entry {
    double f, g;
    int32_t index;
  };
  auto worse = [](const Entry& a, const Entry& b) {
    if (a.f != b.f) return a.f > b.f;
    if (a.g != b.g) return a.g < b.g;
    return a.index > b.index;
  };
  std::priority_queue<Entry, std::vector<Entry>, decltype(worse)> open(worse);
  auto touch = [&](int32_t i) {
    if (std::isinf(g_[i]) && parent_[i] < 0) touched_.push_back(i);
  };
  touch(s_index);
  g_[s_index] = 0;
  parent_[s_index] = s_index;
  open.push({(goal - start).norm(), 0, s_index});
  static const int kDx[8] = {1, -1, 0, 0, 1, 1, -1, -1};
  static const int kDy[8] = {0, 0, 1, -1, 1, -1, 1, -1};
  auto neighbour_ok = [&](int cx, int cy, int k) {
    const int nx = cx + kDx[k], ny = cy + kDy[k];
    if (!ig.cell_free(nx, ny)) return false;
    if (k >= 4 && (!ig.cell_free(nx, cy) || !ig.cell_free(cx, ny))) return false;
    return true;
  };
  while (!open.empty()) {
    const Entry e = open.top();
    open.pop();
    const int32_t s = e.index;
    if (closed_[s] || e.g != g_[s]) continue;
    const int cx = s % w, cy = s / w;
    // Lazy Theta*: the parent was assumed visible when s was pushed; check it now, and fall
    // back to the best closed neighbour when it is not.
    if (s != s_index && !visible(parent_[s], s)) {
      double best = std::numeric_limits<double>::infinity();
      int32_t best_parent = -1;
      for (int k = 0; k < 8; ++k) {
        if (!neighbour_ok(cx, cy, k)) continue;
        const int32_t n = (cy + kDy[k]) * w + (cx + kDx[k]);
        if (!closed_[n]) continue;
        const double c = g_[n] + (pos(n) - pos(s)).norm();
        if (c < best) {
          best = c;
          best_parent = n;
        }
      }
      if (best_parent < 0) continue;  // cannot happen for a cell reached through a neighbour
      parent_[s] = best_parent;
      g_[s] = best;
    }
    closed_[s] = 1;
    ++out.expanded;
    if (s == g_index) break;
    const int32_t ps = parent_[s];
    const Vec2 pp = pos(ps);
    for (int k = 0; k < 8; ++k) {
      if (!neighbour_ok(cx, cy, k)) continue;
      const int32_t n = (cy + kDy[k]) * w + (cx + kDx[k]);
      if (closed_[n]) continue;
      const double ng = g_[ps] + (pos(n) - pp).norm();
      if (ng < g_[n]) {
        touch(n);
        g_[n] = ng;
        parent_[n] = ps;
        open.push({ng + (goal - pos(n)).norm(), ng, n});
      }
    }
  }
  if (!closed_[g_index]) return out;
  std::vector<Vec2> pts;
  for (int32_t c = g_index;; c = parent_[c]) {
    pts.push_back(pos(c));
    if (c == s_index) break;
  }
  std::reverse(pts.begin(), pts.end());
  out.points = shorten_by_line_of_sight(ig, pts);
  out.length = path_length(out.points);
  out.found = true;
  return out;
}

std::vector<Vec2> shorten_by_line_of_sight(const InflatedGrid& grid, const std::vector<Vec2>& path) {
  if (path.size() <= 2) return path;
  std::vector<Vec2> kept{path.front()};
  size_t anchor = 0;
  for (size_t i = 1; i + 1 < path.size(); ++i) {
    if (!grid.segment_free(path[anchor], path[i + 1])) {
      kept.push_back(path[i]);
      anchor = i;
    }
  }
  kept.push_back(path.back());
  return kept;
}

}  // namespace vigil::planning
