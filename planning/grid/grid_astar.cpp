#include "planning/grid/grid_astar.h"

#include "planning/grid/grid_traversal.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <queue>

namespace vigil::planning {

namespace {

constexpr double kSqrt2 = 1.4142135623730951;

// Search state over every cell, shared by the searches of one query: only the cells a search
// touched are reset before the next, so a short search costs little on a large grid.
struct SearchSpace {
  explicit SearchSpace(size_t n)
      : g(n, std::numeric_limits<double>::infinity()), closed(n, 0), parent(n, -1) {}
  void reset() {
    for (int64_t i : touched) {
      g[i] = std::numeric_limits<double>::infinity();
      closed[i] = 0;
      parent[i] = -1;
    }
    touched.clear();
  }
  std::vector<double> g;
  std::vector<uint8_t> closed;
  std::vector<int32_t> parent;
  std::vector<int64_t> touched;
};

// Best-first search over the grid (A* with `heuristic`, Dijkstra when it is 0), 8-connected
// with octile step costs, never cutting a corner past an impassable cell. Stops at the first
// cell popped for which `is_goal` holds and returns it (-1 when none is reachable); `parent`
// then leads back to `start`. The open list is ordered by f, then larger g (deeper first), then
// cell index, so the result is deterministic.
template <class Passable, class IsGoal, class Heuristic>
int64_t best_first(int width, int height, int64_t start, Passable passable, IsGoal is_goal,
                   Heuristic heuristic, SearchSpace* space) {
  space->reset();
  auto& g = space->g;
  auto& closed = space->closed;
  auto& parent = space->parent;
  struct Entry {
    double f, g;
    int64_t index;
  };
  auto worse = [](const Entry& a, const Entry& b) {
    if (a.f != b.f) return a.f > b.f;
    if (a.g != b.g) return a.g < b.g;
    return a.index > b.index;
  };
  std::priority_queue<Entry, std::vector<Entry>, decltype(worse)> open(worse);
  g[start] = 0;
  space->touched.push_back(start);
  open.push({heuristic(start), 0, start});
  static const int kDx[8] = {1, -1, 0, 0, 1, 1, -1, -1};
  static const int kDy[8] = {0, 0, 1, -1, 1, -1, 1, -1};
  while (!open.empty()) {
    const Entry e = open.top();
    open.pop();
    if (closed[e.index]) continue;
    closed[e.index] = 1;
    if (is_goal(e.index)) return e.index;
    const int cx = static_cast<int>(e.index % width), cy = static_cast<int>(e.index / width);
    for (int k = 0; k < 8; ++k) {
      const int nx = cx + kDx[k], ny = cy + kDy[k];
      if (nx < 0 || ny < 0 || nx >= width || ny >= height) continue;
      const int64_t ni = static_cast<int64_t>(ny) * width + nx;
      if (closed[ni] || !passable(ni)) continue;
      if (k >= 4 && (!passable(static_cast<int64_t>(cy) * width + nx) ||
                     !passable(static_cast<int64_t>(ny) * width + cx))) {
        continue;  // no squeezing diagonally between two blocked cells
      }
      const double ng = e.g + (k >= 4 ? kSqrt2 : 1.0);
      if (ng < g[ni]) {
        if (std::isinf(g[ni])) space->touched.push_back(ni);
        g[ni] = ng;
        parent[ni] = static_cast<int32_t>(e.index);
        open.push({ng + heuristic(ni), ng, ni});
      }
    }
  }
  return -1;
}

// Cells from the search's start to `end`, following `parent`.
std::vector<int64_t> trace_back(const std::vector<int32_t>& parent, int64_t end) {
  std::vector<int64_t> cells;
  for (int64_t c = end; c >= 0; c = parent[c]) cells.push_back(c);
  std::reverse(cells.begin(), cells.end());
  return cells;
}

}  // namespace

GridPathPlanner::GridPathPlanner(const OccupancyGrid& grid, double clearance)
    : grid_(&grid), clearance_(std::max(clearance, 0.0)), clearance_field_(grid) {}

double GridPathPlanner::clearance_at(Vec2 p) const {
  return clearance_field_.at_point(*grid_, p);
}

std::vector<Vec2> GridPathPlanner::plan(Vec2 start, Vec2 goal) const {
  const OccupancyGrid& grid = *grid_;
  const int w = grid.width(), h = grid.height();
  int sx, sy, gx, gy;
  if (!grid.world_to_cell(start, &sx, &sy) || !grid.world_to_cell(goal, &gx, &gy)) return {};
  if (grid.at(sx, sy) != Cell::kFree || grid.at(gx, gy) != Cell::kFree) return {};
  if (sx == gx && sy == gy) return {start, goal};

  const auto& cells = grid.cells();
  const uint8_t kFreeByte = static_cast<uint8_t>(Cell::kFree);
  // Clearance is stored in float; a micrometre of slack keeps exact thresholds passable.
  const float need = static_cast<float>(clearance_ - 1e-6);
  auto free_cell = [&](int64_t i) { return cells[i] == kFreeByte; };
  auto clear_cell = [&](int64_t i) { return cells[i] == kFreeByte && clearance_field_.at_index(static_cast<size_t>(i)) >= need; };
  const int64_t s_index = static_cast<int64_t>(sy) * w + sx;
  const int64_t g_index = static_cast<int64_t>(gy) * w + gx;
  SearchSpace space(static_cast<size_t>(w) * h);
  auto zero = [](int64_t) { return 0.0; };

  // From a start or goal inside the clearance margin, the nearest clear cell over free cells.
  auto leave_margin = [&](int64_t from) -> std::vector<int64_t> {
    if (clear_cell(from)) return {from};
    const int64_t found = best_first(w, h, from, free_cell, clear_cell, zero, &space);
    if (found < 0) return {};
    return trace_back(space.parent, found);
  };
  const std::vector<int64_t> lead_in = leave_margin(s_index);
  if (lead_in.empty()) return {};
  std::vector<int64_t> lead_out = leave_margin(g_index);
  if (lead_out.empty()) return {};
  std::reverse(lead_out.begin(), lead_out.end());  // now from the clear cell to the goal

  const int64_t a = lead_in.back(), b = lead_out.front();
  const int bx = static_cast<int>(b % w), by = static_cast<int>(b / w);
  auto octile = [&](int64_t i) {
    const double dx = std::abs(static_cast<int>(i % w) - bx), dy = std::abs(static_cast<int>(i / w) - by);
    return std::max(dx, dy) + (kSqrt2 - 1.0) * std::min(dx, dy);
  };
  const int64_t reached = best_first(w, h, a, clear_cell, [&](int64_t i) { return i == b; }, octile, &space);
  if (reached < 0) return {};
  const std::vector<int64_t> middle = trace_back(space.parent, reached);

  const double res = grid.resolution();
  const Pose2 o = grid.origin();
  auto to_cell_units = [&](Vec2 p) { return Vec2{(p.x - o.x) / res, (p.y - o.y) / res}; };
  auto centre_units = [&](int64_t i) { return Vec2{(i % w) + 0.5, (i / w) + 0.5}; };

  // True when every cell the segment p->q (cell units) touches passes `ok`: an exact grid
  // traversal; where it passes exactly through a cell corner both side cells are checked.
  auto line_of_sight = [&](Vec2 p, Vec2 q, auto ok) {
    const int cx = std::clamp(static_cast<int>(std::floor(p.x)), 0, w - 1);
    const int cy = std::clamp(static_cast<int>(std::floor(p.y)), 0, h - 1);
    const int ex = std::clamp(static_cast<int>(std::floor(q.x)), 0, w - 1);
    const int ey = std::clamp(static_cast<int>(std::floor(q.y)), 0, h - 1);
    return cells_along_segment(p, q, cx, cy, ex, ey, 4 * (w + h), [&](int x, int y) {
      return x >= 0 && y >= 0 && x < w && y < h && ok(static_cast<int64_t>(y) * w + x);
    });
  };

  // Shortens one stretch: the points are `first`, the centres of the stretch's first cell, of
  // every cell where its direction changes and of its last cell, then `last`; each consecutive
  // pair is joined through passable cells. Then every point the previous kept point can see
  // past is dropped, so each kept segment has been checked or is one of those joins.
  auto shorten = [&](Vec2 first, const std::vector<int64_t>& stretch, Vec2 last, auto ok) {
    std::vector<Vec2> pts{first};
    auto add = [&](Vec2 p) {
      if (!(pts.back() == p)) pts.push_back(p);
    };
    for (size_t i = 0; i < stretch.size(); ++i) {
      if (i > 0 && i + 1 < stretch.size() && stretch[i] - stretch[i - 1] == stretch[i + 1] - stretch[i]) {
        continue;  // straight on
      }
      add(centre_units(stretch[i]));
    }
    add(last);
    std::vector<Vec2> kept{pts.front()};
    size_t anchor = 0;
    for (size_t i = 1; i + 1 < pts.size(); ++i) {
      if (!line_of_sight(pts[anchor], pts[i + 1], ok)) {
        kept.push_back(pts[i]);
        anchor = i;
      }
    }
    if (pts.size() > 1) kept.push_back(pts.back());
    return kept;
  };

  // Three stretches: start -> first clear cell over free cells, the A* path between clear
  // cells, last clear cell -> goal over free cells.
  const Vec2 su = to_cell_units(start), gu = to_cell_units(goal);
  std::vector<Vec2> out_units;
  auto append = [&](const std::vector<Vec2>& part) {
    for (const Vec2& p : part) {
      if (out_units.empty() || !(out_units.back() == p)) out_units.push_back(p);
    }
  };
  const Vec2 a_point = lead_in.size() == 1 ? su : centre_units(a);
  const Vec2 b_point = lead_out.size() == 1 ? gu : centre_units(b);
  if (lead_in.size() > 1) append(shorten(su, lead_in, a_point, free_cell));
  append(shorten(a_point, middle, b_point, clear_cell));
  if (lead_out.size() > 1) append(shorten(b_point, lead_out, gu, free_cell));

  std::vector<Vec2> path;
  path.reserve(out_units.size());
  for (size_t i = 0; i < out_units.size(); ++i) {
    if (i == 0) {
      path.push_back(start);
    } else if (i + 1 == out_units.size()) {
      path.push_back(goal);
    } else {
      path.push_back({o.x + out_units[i].x * res, o.y + out_units[i].y * res});
    }
  }
  return path;
}

}  // namespace vigil::planning
