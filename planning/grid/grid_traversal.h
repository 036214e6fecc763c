// Exact traversal of the grid cells a segment crosses (Amanatides-Woo), shared by the people's
// grid paths and the planners' segment checks. Points are in cell units: (x, y) lies in cell
// (floor x, floor y). Where the segment passes exactly through a cell corner, both side cells
// are checked.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>

#include "common/geometry.h"

namespace vigil::planning {

// Walks from cell (cx, cy) (p's) to cell (ex, ey) (q's), asking `ok(x, y)` of every cell on the
// way, the first included; false at the first cell it refuses. `max_steps` bounds the walk.
template <class Ok>
bool cells_along_segment(Vec2 p, Vec2 q, int cx, int cy, int ex, int ey, int max_steps, Ok ok) {
  if (!ok(cx, cy)) return false;
  const double dx = q.x - p.x, dy = q.y - p.y;
  const int step_x = dx > 0 ? 1 : (dx < 0 ? -1 : 0), step_y = dy > 0 ? 1 : (dy < 0 ? -1 : 0);
  const double inf = std::numeric_limits<double>::infinity();
  for (int guard = 0; guard < max_steps && (cx != ex || cy != ey); ++guard) {
    const double tx = step_x == 0 ? inf : ((step_x > 0 ? cx + 1 : cx) - p.x) / dx;
    const double ty = step_y == 0 ? inf : ((step_y > 0 ? cy + 1 : cy) - p.y) / dy;
    if (std::min(tx, ty) > 1.0) break;
    if (std::abs(tx - ty) < 1e-9) {
      if (!ok(cx + step_x, cy) || !ok(cx, cy + step_y)) return false;
      cx += step_x;
      cy += step_y;
    } else if (tx < ty) {
      cx += step_x;
    } else {
      cy += step_y;
    }
    if (!ok(cx, cy)) return false;
  }
  return true;
}

}  // namespace vigil::planning
