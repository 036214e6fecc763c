// The reference shortest path for planner benchmarks and tests: Lazy Theta* (Nash, Koenig and
// Tovey, AAAI 2010), an any-angle A* over the inflated grid's cell centres whose parents may
// be any visible ancestor, followed by line-of-sight shortening. Its paths are within a
// fraction of a percent of the true Euclidean shortest path on grids like ours, and exactly on
// the same free cells the planners use, so length ratios against it mean something.
#pragma once

#include <cstdint>
#include <vector>

#include "common/geometry.h"
#include "planning/grid/inflated_grid.h"

namespace vigil::planning {

struct ReferencePath {
  bool found = false;
  std::vector<Vec2> points;  // start ... goal
  double length = 0;         // m
  size_t expanded = 0;       // cells expanded
};

class AnyAnglePlanner {
 public:
  explicit AnyAnglePlanner(const InflatedGrid& grid);  // the grid must outlive the planner
  // Shortest path between two free points; not found when either is not free or they are not
  // connected.
  ReferencePath plan(Vec2 start, Vec2 goal);

 private:
  const InflatedGrid* grid_;
  std::vector<double> g_;
  std::vector<int32_t> parent_;
  std::vector<uint8_t> closed_;
  std::vector<int32_t> touched_;
};

// Drops every interior point that the previous kept point can see past (greedy string
// pulling); never lengthens the path.
std::vector<Vec2> shorten_by_line_of_sight(const InflatedGrid& grid, const std::vector<Vec2>& path);

}  // namespace vigil::planning
