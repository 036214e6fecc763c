#include "planning/localization/likelihood_field.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "planning/grid/clearance_field.h"

namespace vigil::planning {
namespace {

Status check(double v, double lo, double hi, const std::string& key) {
  if (!std::isfinite(v) || v < lo || v > hi)
    return bad_input("", 0, key, "must be a number in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
  return Status::Ok();
}

}  // namespace

Status validate(const LikelihoodFieldParams& p, const std::string& prefix) {
  if (auto s = check(p.sigma_hit, 1e-3, 5.0, prefix + "sigma_hit"); !s) return s;
  if (auto s = check(p.z_hit, 0.0, 1.0, prefix + "z_hit"); !s) return s;
  if (auto s = check(p.z_rand, 0.0, 1.0, prefix + "z_rand"); !s) return s;
  if (!(p.z_rand > 0)) return bad_input("", 0, prefix + "z_rand", "must be > 0 (it is the likelihood's floor)");
  if (auto s = check(p.max_range, 0.1, 1000.0, prefix + "max_range"); !s) return s;
  if (auto s = check(p.max_distance, 0.01, 100.0, prefix + "max_distance"); !s) return s;
  return Status::Ok();
}

Result<LikelihoodField> LikelihoodField::build(const OccupancyGrid& map, const LikelihoodFieldParams& params) {
  if (auto s = validate(params); !s) return s;
  if (map.width() <= 0 || map.height() <= 0) return bad_input("", 0, "map", "the map is empty");
  if (!(map.resolution() > 0) || !std::isfinite(map.resolution()))
    return bad_input("", 0, "map.resolution", "must be > 0");
  LikelihoodField lf;
  lf.params_ = params;
  lf.width_ = map.width();
  lf.height_ = map.height();
  lf.w_d_ = lf.width_;
  lf.h_d_ = lf.height_;
  lf.resolution_ = map.resolution();
  lf.inv_res_ = 1.0 / map.resolution();
  lf.origin_ = map.origin().position();
  const double floor_p = params.z_rand / params.max_range;
  lf.floor_log_ = static_cast<float>(std::log(floor_p));

  const int w = lf.width_, h = lf.height_;
  const size_t n = static_cast<size_t>(w) * h;
  const double big = static_cast<double>(w + h) * (w + h);
  std::vector<double> f(n);
  const auto& cells = map.cells();
  const uint8_t kOcc = static_cast<uint8_t>(Cell::kOccupied);
  for (size_t i = 0; i < n; ++i) f[i] = cells[i] == kOcc ? 0.0 : big;
  squared_distance_transform(f, w, h);

  // The table over distances: the Gaussian density on the capped distance (eq. 6.33).
  const double res = lf.resolution_, s2 = params.sigma_hit * params.sigma_hit;
  const double norm = params.z_hit / (std::sqrt(2.0 * M_PI) * params.sigma_hit);
  const uint8_t kUnknown = static_cast<uint8_t>(Cell::kUnknown);
  lf.table_.resize(n);
  lf.dist_.resize(n);
  for (size_t i = 0; i < n; ++i) {
    const double d = std::min(std::sqrt(f[i]) * res, params.max_distance);
    lf.dist_[i] = static_cast<float>(d);
    lf.table_[i] = params.unknown_as_floor && cells[i] == kUnknown ? lf.floor_log_
                                        : static_cast<float>(std::log(norm * std::exp(-0.5 * d * d / s2) + floor_p));
  }
  return lf;
}

}  // namespace vigil::planning
