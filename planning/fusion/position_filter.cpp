#include "planning/fusion/position_filter.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

namespace vigil::planning::fusion {

PositionFilter::PositionFilter(uint64_t seed, PositionFilterParams params, std::function<bool(double, double)> free)
    : rng_(seed), p_(params), free_(std::move(free)) {}

Eigen::Matrix2d PositionFilter::floor_cov(const Eigen::Matrix2d& cov) const {
  Eigen::Matrix2d c = 0.5 * (cov + cov.transpose());
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(c);
  Eigen::Vector2d ev = es.eigenvalues().cwiseMax(p_.min_std * p_.min_std);
  return es.eigenvectors() * ev.asDiagonal() * es.eigenvectors().transpose();
}

void PositionFilter::init(const Eigen::Vector2d& mean, const Eigen::Matrix2d& cov) {
  const Eigen::Matrix2d c = floor_cov(cov);
  const Eigen::Matrix2d L = c.llt().matrixL();
  const int n = std::max(1, p_.particles);
  x_.clear();
  x_.reserve(n);
  for (int i = 0; i < n; ++i) {
    Eigen::Vector2d q = mean;
    // Out of walls: a few draws, then the mean itself (the report's own place).
    for (int k = 0; k < 20; ++k) {
      const Eigen::Vector2d d = mean + L * Eigen::Vector2d(rng_.normal(), rng_.normal());
      if (allowed(d)) {
        q = d;
        break;
      }
    }
    x_.push_back(q);
  }
  w_.assign(x_.size(), 1.0 / static_cast<double>(x_.size()));
  updates_ = 0;
}

bool PositionFilter::update(const Eigen::Vector2d& mean, const Eigen::Matrix2d& cov) {
  if (!initialized()) {
    init(mean, cov);
    return true;
  }
  const Eigen::Matrix2d info = floor_cov(cov).inverse();
  std::vector<double> lw(x_.size());
  double best = -std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < x_.size(); ++i) {
    const Eigen::Vector2d d = x_[i] - mean;
    lw[i] = std::log(std::max(w_[i], 1e-300)) - 0.5 * d.dot(info * d);
    best = std::max(best, lw[i]);
  }
  // No particle within about 6 standard deviations of the report: it does not fit.
  double sum = 0;
  std::vector<double> w(x_.size());
  for (size_t i = 0; i < x_.size(); ++i) {
    w[i] = std::exp(lw[i] - best);
    sum += w[i];
  }
  double max_md = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < x_.size(); ++i) {
    const Eigen::Vector2d d = x_[i] - mean;
    max_md = std::min(max_md, d.dot(info * d));
  }
  if (!(sum > 0) || max_md > 36.0) return false;
  for (size_t i = 0; i < x_.size(); ++i) w_[i] = w[i] / sum;
  ++updates_;
  if (effective_sample_size() < 0.5 * static_cast<double>(x_.size())) resample();
  return true;
}

void PositionFilter::resample() {
  const size_t n = x_.size();
  std::vector<Eigen::Vector2d> next;
  next.reserve(n);
  const double step = 1.0 / static_cast<double>(n);
  double u = rng_.uniform() * step, c = w_[0];
  size_t i = 0;
  for (size_t m = 0; m < n; ++m) {
    while (u > c && i + 1 < n) c += w_[++i];
    Eigen::Vector2d q = x_[i];
    const Eigen::Vector2d j = q + p_.roughening * Eigen::Vector2d(rng_.normal(), rng_.normal());
    if (allowed(j)) q = j;
    next.push_back(q);
    u += step;
  }
  x_.swap(next);
  w_.assign(n, step);
}

Eigen::Vector2d PositionFilter::mean() const {
  Eigen::Vector2d m = Eigen::Vector2d::Zero();
  for (size_t i = 0; i < x_.size(); ++i) m += w_[i] * x_[i];
  return m;
}

Eigen::Matrix2d PositionFilter::covariance() const {
  const Eigen::Vector2d m = mean();
  Eigen::Matrix2d c = Eigen::Matrix2d::Zero();
  for (size_t i = 0; i < x_.size(); ++i) c += w_[i] * (x_[i] - m) * (x_[i] - m).transpose();
  return c;
}

double PositionFilter::major_std() const {
  if (!initialized()) return 0;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(covariance());
  return std::sqrt(std::max(0.0, es.eigenvalues().maxCoeff()));
}

double PositionFilter::effective_sample_size() const {
  double s = 0;
  for (double w : w_) s += w * w;
  return s > 0 ? 1.0 / s : 0.0;
}

}  // namespace vigil::planning::fusion
