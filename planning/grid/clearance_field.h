// The clearance field of an occupancy grid: for every cell, the Euclidean distance (m) between
// its centre and the centre of the nearest cell that is not free (occupied or unknown; the
// grid's edge counts as unknown). Exact squared distances by the separable transform of
// Felzenszwalb and Huttenlocher ("Distance transforms of sampled functions", 2012), so
// inflation by a robot's radius is a threshold on this field.
#pragma once

#include <vector>

#include "common/occupancy_grid.h"

namespace vigil::planning {

class ClearanceField {
 public:
  ClearanceField() = default;
  explicit ClearanceField(const OccupancyGrid& grid);

  int width() const { return width_; }
  int height() const { return height_; }
  // Clearance of cell (cx, cy) in metres; the caller checks bounds.
  float at(int cx, int cy) const { return dist_[static_cast<size_t>(cy) * width_ + cx]; }
  float at_index(size_t i) const { return dist_[i]; }
  // Clearance at a map point; 0 outside the grid.
  double at_point(const OccupancyGrid& grid, Vec2 p) const;
  const std::vector<float>& values() const { return dist_; }

 private:
  int width_ = 0, height_ = 0;
  std::vector<float> dist_;
};

// Squared Euclidean distance transform in place over a w x h row-major array: cells holding 0
// are sites, others must hold a large value (>= (w + h)^2); afterwards each holds the squared
// distance in cells to its nearest site.
void squared_distance_transform(std::vector<double>& f, int w, int h);

}  // namespace vigil::planning
