// Particle-filter fusion of an event's position (chapter 10.6.2: "a Particle Filter for the
// sensor filters and event detection layer"). Each camera's report of one event is a map-frame
// position with a covariance that follows from how the camera measured it (a stereo camera is
// sure of the bearing and unsure of the range, by far the most at a distance); the filter keeps
// a set of weighted particles over the event's place on the floor plan, weighs them by every
// report's Gaussian likelihood, keeps them out of walls (an object cannot stand inside one), and
// resamples (systematic) when the effective sample size falls below half. Two cameras seeing the
// event from different sides sharpen the belief where their uncertainty ellipses cross.
// Deterministic for a seed.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include <Eigen/Core>

#include "common/rng.h"

namespace vigil::planning::fusion {

struct PositionFilterParams {
  int particles = 500;
  double roughening = 0.01;  // m: jitter after resampling (keeps the set from collapsing)
  double min_std = 0.02;     // m: a report is never taken for surer than this
};

class PositionFilter {
 public:
  // `free(x, y)`: whether a point may hold the event (inside the map, not in a wall); null:
  // everywhere.
  PositionFilter(uint64_t seed, PositionFilterParams params = {}, std::function<bool(double, double)> free = nullptr);

  // Starts the belief from the first report: particles drawn from N(mean, cov), out of walls.
  void init(const Eigen::Vector2d& mean, const Eigen::Matrix2d& cov);
  // Weighs the particles by another report. False (belief unchanged) when no particle is
  // plausible under it (a report inconsistent with the belief: the caller decides).
  bool update(const Eigen::Vector2d& mean, const Eigen::Matrix2d& cov);

  bool initialized() const { return !x_.empty(); }
  Eigen::Vector2d mean() const;
  Eigen::Matrix2d covariance() const;
  // The larger standard deviation of the belief (m): its longest axis.
  double major_std() const;
  double effective_sample_size() const;
  int updates() const { return updates_; }
  const std::vector<Eigen::Vector2d>& particles() const { return x_; }
  const std::vector<double>& weights() const { return w_; }

 private:
  void resample();
  Eigen::Matrix2d floor_cov(const Eigen::Matrix2d& cov) const;
  bool allowed(const Eigen::Vector2d& p) const { return !free_ || free_(p.x(), p.y()); }

  Rng rng_;
  PositionFilterParams p_;
  std::function<bool(double, double)> free_;
  std::vector<Eigen::Vector2d> x_;
  std::vector<double> w_;
  int updates_ = 0;
};

}  // namespace vigil::planning::fusion
