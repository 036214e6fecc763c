// The likelihood-field beam model of a laser (Thrun, Burgard and Fox, Probabilistic Robotics,
// sec. 6.4, table 6.3), precomputed per map cell. A beam's endpoint z at distance d from the
// nearest occupied cell has
//   p(z) = z_hit * N(d; 0, sigma_hit^2) + z_rand / max_range                       (eq. 6.33)
// with d capped at max_distance; points outside the map get the floor z_rand / max_range, and
// unknown cells the value of their distance (as AMCL: a SLAM map's walls are thin, with unknown
// cells behind them, so an endpoint a few cm past a wall still fits) or, with
// unknown_as_floor, the floor. The table holds log p(z) as float, so a beam costs one lookup and a
// scan's log-likelihood is a sum. Max-range beams are the caller's to skip (sec. 6.4.1).
#pragma once

#include <cstdint>
#include <vector>

#include "common/geometry.h"
#include "common/occupancy_grid.h"
#include "common/status.h"

namespace vigil::planning {

// Parameters of the beam model, with defaults (range: min:step:max, as OMPL's declareParam).
struct LikelihoodFieldParams {
  double sigma_hit = 0.2;     // m, std of the hit Gaussian              "0.01:0.01:5."
  double z_hit = 0.95;        // weight of the hit Gaussian              "0.:0.01:1."
  double z_rand = 0.05;       // weight of the uniform floor (must be > 0) "0.001:0.01:1."
  double max_range = 20.0;    // m, the laser's maximum range (laser_max_range) "0.1:0.1:1000."
  double max_distance = 2.0;  // m, cap on the distance to the nearest obstacle "0.05:0.05:100."
  bool unknown_as_floor = false;  // unknown cells score the floor instead of their distance
};

// Checks the parameters; the error names the key (`prefix` + field name).
Status validate(const LikelihoodFieldParams& p, const std::string& prefix = "");

class LikelihoodField {
 public:
  LikelihoodField() = default;
  // Builds the table for `map` (exact Euclidean distance transform to the occupied cells).
  static Result<LikelihoodField> build(const OccupancyGrid& map, const LikelihoodFieldParams& params);

  int width() const { return width_; }
  int height() const { return height_; }
  double resolution() const { return resolution_; }
  Vec2 origin() const { return origin_; }
  const LikelihoodFieldParams& params() const { return params_; }
  // log p(z) at the floor (outside the map; unknown cells with unknown_as_floor).
  float floor_log() const { return floor_log_; }
  // log p(z) of a beam ending at map point p.
  float log_likelihood(Vec2 p) const {
    return log_at_cell_coords((p.x - origin_.x) * inv_res_, (p.y - origin_.y) * inv_res_);
  }
  // log p(z) for a point given in cell units ((p - origin) / resolution): the hot-loop form.
  float log_at_cell_coords(double u, double v) const {
    if (!(u >= 0.0 && v >= 0.0 && u < w_d_ && v < h_d_)) return floor_log_;
    return table_[static_cast<size_t>(static_cast<int>(v)) * width_ + static_cast<int>(u)];
  }
  // Distance (m, capped) from cell (cx, cy) to the nearest occupied cell; the caller checks bounds.
  float distance(int cx, int cy) const { return dist_[static_cast<size_t>(cy) * width_ + cx]; }
  const std::vector<float>& log_table() const { return table_; }

 private:
  LikelihoodFieldParams params_;
  int width_ = 0, height_ = 0;
  double w_d_ = 0, h_d_ = 0;
  double resolution_ = 0.05, inv_res_ = 20;
  Vec2 origin_;
  float floor_log_ = 0;
  std::vector<float> table_;  // log p(z) per cell, row-major, row 0 at the bottom
  std::vector<float> dist_;   // capped distance per cell
};

}  // namespace vigil::planning
