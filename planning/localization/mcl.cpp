#include "planning/localization/mcl.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace vigil::planning {
namespace {

constexpr double kNegInf = -std::numeric_limits<double>::infinity();

Status check(double v, double lo, double hi, const char* key) {
  if (!std::isfinite(v) || v < lo || v > hi)
    return bad_input("", 0, key, "must be a number in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
  return Status::Ok();
}

Status check_count(int v, int lo, int hi, const char* key) {
  if (v < lo || v > hi)
    return bad_input("", 0, key, "must be an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
  return Status::Ok();
}

// log(e^a + e^b), exact for -inf arguments.
double log_add(double a, double b) {
  if (a == kNegInf) return b;
  if (b == kNegInf) return a;
  const double m = std::max(a, b);
  return m + std::log1p(std::exp(-std::abs(a - b)));
}

// KLD-sampling's bound on the sample count for k occupied bins (Fox 2003, eq. 8.? / table 8.4).
int kld_bound(int k, double err, double z, int lo, int hi) {
  if (k <= 1) return lo;
  const double km1 = k - 1;
  const double a = 2.0 / (9.0 * km1);
  const double b = 1.0 - a + std::sqrt(a) * z;
  const double n = std::ceil(km1 / (2.0 * err) * b * b * b);
  if (!(n < hi)) return hi;
  return std::max(lo, static_cast<int>(n));
}

constexpr uint64_t kCoordMask = (1ull << 21) - 1;
uint64_t pack_bin(int64_t ix, int64_t iy, int64_t it) {
  return ((static_cast<uint64_t>(ix + (1 << 20)) & kCoordMask) << 42) |
         ((static_cast<uint64_t>(iy + (1 << 20)) & kCoordMask) << 21) | (static_cast<uint64_t>(it) & kCoordMask);
}

}  // namespace

Status validate(const MclParams& p) {
  if (auto s = check_count(p.particles, 1, 1000000, "particles"); !s) return s;
  if (auto s = check_count(p.min_particles, 1, 1000000, "min_particles"); !s) return s;
  if (auto s = check_count(p.max_particles, 1, 1000000, "max_particles"); !s) return s;
  if (p.kld && p.max_particles < p.min_particles)
    return bad_input("", 0, "max_particles", "must be at least min_particles");
  if (auto s = check(p.kld_err, 1e-4, 1.0, "kld_err"); !s) return s;
  if (auto s = check(p.kld_z, 0.01, 10.0, "kld_z"); !s) return s;
  if (auto s = check(p.kld_bin_xy, 0.01, 10.0, "kld_bin_xy"); !s) return s;
  if (auto s = check(p.kld_bin_yaw, 0.01, M_PI, "kld_bin_yaw"); !s) return s;
  if (auto s = check(p.alpha1, 0, 10, "alpha1"); !s) return s;
  if (auto s = check(p.alpha2, 0, 10, "alpha2"); !s) return s;
  if (auto s = check(p.alpha3, 0, 10, "alpha3"); !s) return s;
  if (auto s = check(p.alpha4, 0, 10, "alpha4"); !s) return s;
  if (!std::isfinite(p.laser_pose.x) || !std::isfinite(p.laser_pose.y) || !std::isfinite(p.laser_pose.yaw))
    return bad_input("", 0, "laser_pose", "must be finite");
  if (auto s = check_count(p.max_beams, 1, 100000, "max_beams"); !s) return s;
  if (auto s = validate(p.field, "field."); !s) return s;
  if (auto s = check(p.likelihood_exponent, 1e-3, 1.0, "likelihood_exponent"); !s) return s;
  if (auto s = check(p.min_ess_fraction, 0.0, 1.0, "min_ess_fraction"); !s) return s;
  if (auto s = check(p.update_min_d, 0, 100, "update_min_d"); !s) return s;
  if (auto s = check(p.update_min_a, 0, 2 * M_PI, "update_min_a"); !s) return s;
  if (auto s = check_count(p.resample_interval, 1, 1000, "resample_interval"); !s) return s;
  if (auto s = check(p.recovery_alpha_slow, 0, 1, "recovery_alpha_slow"); !s) return s;
  if (auto s = check(p.recovery_alpha_fast, 0, 1, "recovery_alpha_fast"); !s) return s;
  if ((p.recovery_alpha_slow > 0 || p.recovery_alpha_fast > 0) && !(p.recovery_alpha_fast > p.recovery_alpha_slow))
    return bad_input("", 0, "recovery_alpha_fast", "must exceed recovery_alpha_slow (or both be 0 to disable recovery)");
  if (auto s = check(p.recovery_max_share, 0, 1, "recovery_max_share"); !s) return s;
  if (auto s = check(p.recovery_drop, 0, 10, "recovery_drop"); !s) return s;
  if (auto s = check(p.occlusion_range, 0, 50, "occlusion_range"); !s) return s;
  if (auto s = check(p.beam_skip_distance, 0, 10, "beam_skip_distance"); !s) return s;
  if (auto s = check(p.beam_skip_threshold, 0, 1, "beam_skip_threshold"); !s) return s;
  if (auto s = check(p.beam_skip_error_threshold, 0, 1, "beam_skip_error_threshold"); !s) return s;
  if (auto s = check_count(p.recovery_persistence, 1, 1000, "recovery_persistence"); !s) return s;
  if (auto s = check_count(p.injection_candidates, 1, 10000, "injection_candidates"); !s) return s;
  if (auto s = check(p.injection_margin, 0, 10, "injection_margin"); !s) return s;
  if (auto s = check_count(p.global_candidates, 0, 100000000, "global_candidates"); !s) return s;
  if (auto s = check(p.converged_spread, 0.01, 100, "converged_spread"); !s) return s;
  if (auto s = check(p.converged_weight, 0, 1, "converged_weight"); !s) return s;
  return Status::Ok();
}

// ---- the shared map data ----------------------------------------------------------------

Result<std::shared_ptr<const MclMap>> MclMap::build(const OccupancyGrid& map, const LikelihoodFieldParams& params,
                                                    bool exclude_exterior) {
  auto field = LikelihoodField::build(map, params);
  if (!field) return field.error();
  std::shared_ptr<MclMap> m(new MclMap());
  m->field_ = std::move(*field);
  m->width_ = map.width();
  m->height_ = map.height();
  m->exclude_exterior_ = exclude_exterior;
  const int w = m->width_, h = m->height_;
  const size_t n = static_cast<size_t>(w) * h;
  const auto& cells = map.cells();
  const uint8_t kFree = static_cast<uint8_t>(Cell::kFree);
  m->free_bits_.assign((n + 63) / 64, 0);
  for (size_t i = 0; i < n; ++i)
    if (cells[i] == kFree) m->free_bits_[i >> 6] |= uint64_t{1} << (i & 63);
  // The exterior: free cells 4-connected to the border, the flood fill passing only where the
  // clearance is >= kDoorGap (so not through doorways up to 2 kDoorGap wide), then grown by
  // kDoorGap over free cells to reach the cells along the outer walls.
  std::vector<uint8_t> outside;
  if (exclude_exterior) {
    constexpr double kDoorGap = 0.6;
    const LikelihoodField& lf = m->field_;
    outside.assign(n, 0);
    std::vector<int32_t> stack, front;
    auto open = [&](int cx, int cy) { return lf.distance(cx, cy) >= kDoorGap; };
    auto seed = [&](int cx, int cy) {
      const size_t i = static_cast<size_t>(cy) * w + cx;
      if (cells[i] == kFree && !outside[i] && open(cx, cy)) outside[i] = 1, stack.push_back(static_cast<int32_t>(i));
    };
    for (int x = 0; x < w; ++x) seed(x, 0), seed(x, h - 1);
    for (int y = 0; y < h; ++y) seed(0, y), seed(w - 1, y);
    while (!stack.empty()) {
      const int i = stack.back();
      stack.pop_back();
      front.push_back(i);
      const int cx = i % w, cy = i / w;
      if (cx > 0) seed(cx - 1, cy);
      if (cx + 1 < w) seed(cx + 1, cy);
      if (cy > 0) seed(cx, cy - 1);
      if (cy + 1 < h) seed(cx, cy + 1);
    }
    // Grow by kDoorGap (breadth first over free cells).
    const int steps = static_cast<int>(std::ceil(kDoorGap / map.resolution()));
    std::vector<int32_t> next;
    for (int k = 0; k < steps && !front.empty(); ++k) {
      next.clear();
      for (int i : front) {
        const int cx = i % w, cy = i / w;
        const int nb[4][2] = {{cx - 1, cy}, {cx + 1, cy}, {cx, cy - 1}, {cx, cy + 1}};
        for (const auto& q : nb) {
          if (q[0] < 0 || q[1] < 0 || q[0] >= w || q[1] >= h) continue;
          const size_t j = static_cast<size_t>(q[1]) * w + q[0];
          if (cells[j] == kFree && !outside[j]) outside[j] = 1, next.push_back(static_cast<int32_t>(j));
        }
      }
      front.swap(next);
    }
  }
  for (size_t i = 0; i < n; ++i)
    if (cells[i] == kFree && (outside.empty() || !outside[i])) m->sample_cells_.push_back(static_cast<int32_t>(i));
  if (m->sample_cells_.empty())
    return bad_input("", 0, "map", exclude_exterior ? "the map has no free cells inside (exclude_exterior)"
                                                    : "the map has no free cells");
  // The quantised, tiled log table: q = round((log p - floor) / quantum), 0 = the floor.
  const auto& table = m->field_.log_table();
  const float floor_log = m->field_.floor_log();
  float top = floor_log;
  for (float v : table) top = std::max(top, v);
  m->quantum_ = top > floor_log ? (top - floor_log) / 255.0f : 1.0f;
  m->tiles_x_ = (w + 7) / 8;
  const int tiles_y = (h + 7) / 8;
  m->tiles_.assign(static_cast<size_t>(m->tiles_x_) * tiles_y * 64, 0);
  for (int cy = 0; cy < h; ++cy)
    for (int cx = 0; cx < w; ++cx) {
      const float v = table[static_cast<size_t>(cy) * w + cx];
      const long q = std::lround((v - floor_log) / m->quantum_);
      m->tiles_[m->tile_index(cx, cy)] = static_cast<uint8_t>(std::clamp(q, 0L, 255L));
    }
  return std::shared_ptr<const MclMap>(std::move(m));
}

size_t MclMap::memory_bytes() const {
  return sizeof(*this) + field_.log_table().capacity() * sizeof(float) * 2 + tiles_.capacity() +
         free_bits_.capacity() * sizeof(uint64_t) + sample_cells_.capacity() * sizeof(int32_t);
}

size_t MonteCarloLocalization::memory_bytes() const {
  return sizeof(*this) + (particles_.capacity() + scratch_.capacity()) * sizeof(Particle) +
         weights_.capacity() * sizeof(double) + ll_.capacity() * sizeof(float) +
         (beam_ex_.capacity() + beam_ey_.capacity()) * sizeof(float) + cand_.capacity() * sizeof(Pose2) +
         cand_ll_.capacity() * sizeof(float) + cand_w_.capacity() * sizeof(double) +
         bin_keys_.capacity() * sizeof(uint64_t) + bin_slots_.capacity() * sizeof(int32_t) +
         bin_parent_.capacity() * sizeof(int32_t) + bin_key_of_.capacity() * sizeof(uint64_t) +
         bin_acc_.capacity() * sizeof(double) + bin_slot_of_.capacity() * sizeof(int32_t) +
         particle_bin_.capacity() * sizeof(int32_t) + injected_.capacity();
}

// ---- creation ----------------------------------------------------------------------------

Result<MonteCarloLocalization> MonteCarloLocalization::create(const OccupancyGrid& map, const MclParams& params) {
  if (auto s = validate(params); !s) return s;
  auto shared = MclMap::build(map, params.field, params.exclude_exterior);
  if (!shared) return shared.error();
  return create(std::move(*shared), params);
}

Result<MonteCarloLocalization> MonteCarloLocalization::create(std::shared_ptr<const MclMap> map,
                                                              const MclParams& params) {
  if (auto s = validate(params); !s) return s;
  if (!map) return bad_input("", 0, "map", "is null");
  const auto& f = map->field().params();
  if (f.sigma_hit != params.field.sigma_hit || f.z_hit != params.field.z_hit || f.z_rand != params.field.z_rand ||
      f.max_range != params.field.max_range || f.max_distance != params.field.max_distance ||
      f.unknown_as_floor != params.field.unknown_as_floor)
    return bad_input("", 0, "field", "differs from the shared map's likelihood-field parameters");
  MonteCarloLocalization m;
  m.params_ = params;
  m.map_ = std::move(map);
  m.rng_ = Rng::stream(params.seed, "mcl");
  const int cap = std::max(params.particles, params.kld ? params.max_particles : 1);
  m.particles_.reserve(cap);
  m.scratch_.reserve(cap);
  m.weights_.reserve(cap);
  m.ll_.reserve(cap);
  m.injected_.reserve(cap);
  m.particle_bin_.reserve(cap);
  m.bin_bits_ = 4;
  while ((1 << m.bin_bits_) < 2 * cap) ++m.bin_bits_;
  m.bin_slots_.assign(size_t{1} << m.bin_bits_, -1);
  m.bin_keys_.assign(size_t{1} << m.bin_bits_, 0);
  m.bin_parent_.reserve(cap);
  m.bin_key_of_.reserve(cap);
  m.bin_slot_of_.reserve(cap);
  m.bin_acc_.reserve(static_cast<size_t>(cap) * 5);
  m.yaw_bins_ = std::max(1, static_cast<int>(std::ceil(2 * M_PI / params.kld_bin_yaw - 1e-9)));
  m.beam_ex_.reserve(params.max_beams);
  m.beam_ey_.reserve(params.max_beams);
  return m;
}

// ---- initialisation ---------------------------------------------------------------------

Status MonteCarloLocalization::initialize(Pose2 mean, Vec3 stddev) {
  if (!std::isfinite(mean.x) || !std::isfinite(mean.y) || !std::isfinite(mean.yaw))
    return bad_input("", 0, "mean", "must be finite");
  if (!(stddev.x >= 0 && stddev.y >= 0 && stddev.z >= 0) || !std::isfinite(stddev.x) || !std::isfinite(stddev.y) ||
      !std::isfinite(stddev.z))
    return bad_input("", 0, "stddev", "must be finite and >= 0");
  const int n = params_.kld ? params_.max_particles : params_.particles;
  particles_.resize(n);
  for (auto& p : particles_) {
    p.pose.x = mean.x + stddev.x * rng_.normal();
    p.pose.y = mean.y + stddev.y * rng_.normal();
    p.pose.yaw = wrap_angle(mean.yaw + stddev.z * rng_.normal());
    p.log_weight = 0;
  }
  injected_.assign(n, 0);
  have_odom_ = false;
  force_update_ = true;
  have_avgs_ = false;
  global_pending_ = false;
  drop_run_ = 0;
  updates_since_resample_ = 0;
  compute_estimate();
  return Status::Ok();
}

Pose2 MonteCarloLocalization::random_free_pose() {
  const auto& cells = map_->sample_cells();
  const size_t k = std::min(cells.size() - 1, static_cast<size_t>(rng_.uniform() * cells.size()));
  const int idx = cells[k];
  const int cx = idx % map_->width(), cy = idx / map_->width();
  const double res = map_->field().resolution();
  const Vec2 o = map_->field().origin();
  Pose2 p;
  p.x = o.x + (cx + rng_.uniform()) * res;
  p.y = o.y + (cy + rng_.uniform()) * res;
  p.yaw = wrap_angle(rng_.uniform(-M_PI, M_PI));
  return p;
}

Status MonteCarloLocalization::set_crowd_options(double occlusion_range, bool beam_skip) {
  MclParams p = params_;
  p.occlusion_range = occlusion_range;
  p.beam_skip = beam_skip;
  if (Status s = validate(p); !s) return s;
  params_ = p;
  return Status::Ok();
}

void MonteCarloLocalization::initialize_global() {
  const int n = params_.kld ? params_.max_particles : params_.particles;
  particles_.resize(n);
  for (auto& p : particles_) {
    p.pose = random_free_pose();
    p.log_weight = 0;
  }
  injected_.assign(n, 0);
  have_odom_ = false;
  force_update_ = true;
  have_avgs_ = false;
  global_pending_ = params_.global_candidates > 0;
  drop_run_ = 0;
  updates_since_resample_ = 0;
  compute_estimate();
}

// ---- the update --------------------------------------------------------------------------

bool MonteCarloLocalization::update(Pose2 odometry, const LaserScan* scan) {
  if (particles_.empty()) return false;
  if (!have_odom_) {
    last_odom_ = odometry;
    have_odom_ = true;
    if (!force_update_ || !scan) return false;
  } else {
    const double dx = odometry.x - last_odom_.x, dy = odometry.y - last_odom_.y;
    const double da = wrap_angle(odometry.yaw - last_odom_.yaw);
    const bool moved = std::hypot(dx, dy) >= params_.update_min_d || std::abs(da) >= params_.update_min_a;
    if ((!moved && !force_update_) || !scan) return false;
    sample_motion(last_odom_, odometry);
    last_odom_ = odometry;
  }
  force_update_ = false;
  ++stats_.filter_updates;
  const bool beams = prepare_beams(*scan);
  if (beams && global_pending_) {
    // Global initialisation guided by the first scan: these particles are already a draw by
    // its likelihood, so it is not applied again.
    global_pending_ = false;
    global_from_scan();
    compute_estimate();
    updates_since_resample_ = 0;
    return true;
  }
  if (beams) measure();
  compute_estimate();
  if (++updates_since_resample_ >= params_.resample_interval) {
    resample();
    updates_since_resample_ = 0;
  }
  return true;
}

// sample_motion_model_odometry (Probabilistic Robotics table 5.6), applied to every particle.
void MonteCarloLocalization::sample_motion(Pose2 from, Pose2 to) {
  const double dx = to.x - from.x, dy = to.y - from.y;
  const double trans = std::hypot(dx, dy);
  const double rot1 = trans < 0.01 ? 0.0 : wrap_angle(std::atan2(dy, dx) - from.yaw);
  const double rot2 = wrap_angle(to.yaw - from.yaw - rot1);
  // Driving backwards is a small rotation, not a half turn, for the noise.
  const double r1 = std::min(std::abs(rot1), M_PI - std::abs(rot1));
  const double r2 = std::min(std::abs(rot2), M_PI - std::abs(rot2));
  const double sd_rot1 = params_.alpha1 * r1 + params_.alpha2 * trans;
  const double sd_trans = params_.alpha3 * trans + params_.alpha4 * (r1 + r2);
  const double sd_rot2 = params_.alpha1 * r2 + params_.alpha2 * trans;
  for (auto& p : particles_) {
    const double h1 = rot1 - sd_rot1 * rng_.normal();
    const double t = trans - sd_trans * rng_.normal();
    const double h2 = rot2 - sd_rot2 * rng_.normal();
    const double a = p.pose.yaw + h1;
    p.pose.x += t * std::cos(a);
    p.pose.y += t * std::sin(a);
    p.pose.yaw = wrap_angle(a + h2);
  }
}

// log sum exp of the log-weights of the held (not just injected) particles.
double MonteCarloLocalization::held_log_sum() const {
  double mx = kNegInf;
  for (size_t j = 0; j < particles_.size(); ++j)
    if (!injected_[j]) mx = std::max(mx, particles_[j].log_weight);
  if (mx == kNegInf) return kNegInf;
  double sum = 0;
  for (size_t j = 0; j < particles_.size(); ++j)
    if (!injected_[j]) sum += std::exp(particles_[j].log_weight - mx);
  return mx + std::log(sum);
}

// The scan's beams, subsampled to max_beams, as endpoints in the robot frame in cell units;
// false when no beam is usable.
bool MonteCarloLocalization::prepare_beams(const LaserScan& scan) {
  const int n = static_cast<int>(scan.ranges.size());
  const int m = std::min(params_.max_beams, n);
  const double max_r = std::min(scan.range_max > 0 ? scan.range_max : params_.field.max_range, params_.field.max_range);
  const double inv_res = 1.0 / map_->field().resolution();
  const Pose2 lp = params_.laser_pose;
  beam_ex_.clear();
  beam_ey_.clear();
  for (int k = 0; k < m; ++k) {
    const int i = m == 1 ? 0 : static_cast<int>(static_cast<int64_t>(k) * (n - 1) / (m - 1));
    const double r = scan.ranges[i];
    if (!std::isfinite(r) || r < scan.range_min || r >= max_r) continue;  // max-range beams skipped
    const double a = lp.yaw + scan.angle_min + i * scan.angle_increment;
    beam_ex_.push_back(static_cast<float>((lp.x + r * std::cos(a)) * inv_res));
    beam_ey_.push_back(static_cast<float>((lp.y + r * std::sin(a)) * inv_res));
  }
  return !beam_ex_.empty();
}

// Per pose, the scan's log-likelihood: one byte a beam from the tiled quantised table, summed
// as integers (exact, so the order does not matter), a pose off the free space scoring as if
// no beam hit (the robot cannot stand in a wall or in unknown space). `stride` in bytes.
void MonteCarloLocalization::score(const Pose2* poses, size_t n, size_t stride, float* out) const {
  const MclMap& map = *map_;
  const int nb = static_cast<int>(beam_ex_.size());
  const float* ex = beam_ex_.data();
  const float* ey = beam_ey_.data();
  const Vec2 o = map.field().origin();
  const double inv_res = 1.0 / map.field().resolution();
  const int w = map.width(), h = map.height();
  const float wf = static_cast<float>(w), hf = static_cast<float>(h);
  const uint8_t* tiles = map.tiles();
  const size_t tx = static_cast<size_t>(map.tiles_x());
  const double floor_log = map.field().floor_log(), quantum = map.quantum();
  const float hit_all = static_cast<float>(nb * floor_log);
  const char* base = reinterpret_cast<const char*>(poses);
  for (size_t j = 0; j < n; ++j) {
    const Pose2& q = *reinterpret_cast<const Pose2*>(base + j * stride);
    const float c = static_cast<float>(std::cos(q.yaw)), s = static_cast<float>(std::sin(q.yaw));
    const float u0 = static_cast<float>((q.x - o.x) * inv_res), v0 = static_cast<float>((q.y - o.y) * inv_res);
    int32_t sum = 0;
    for (int b = 0; b < nb; ++b) {
      const float u = u0 + c * ex[b] - s * ey[b], v = v0 + s * ex[b] + c * ey[b];
      if (u >= 0.0f && v >= 0.0f && u < wf && v < hf) {
        const int iu = static_cast<int>(u), iv = static_cast<int>(v);
        sum += tiles[((static_cast<size_t>(iv >> 3) * tx + static_cast<size_t>(iu >> 3)) << 6) | ((iv & 7) << 3) | (iu & 7)];
      }
    }
    float ll = static_cast<float>(nb * floor_log + quantum * sum);
    const bool inside = u0 >= 0 && v0 >= 0 && u0 < wf && v0 < hf;
    if (!inside || !map.is_free(static_cast<int>(u0), static_cast<int>(v0))) ll += hit_all;
    out[j] = ll;
  }
}

// The per-beam mean log-likelihood of the scan at `q` over the beams that are not short
// (a short beam ends within occlusion_range in a free cell, reached over free cells from the
// laser: a body close in front); `kept` counts the rest.

double MonteCarloLocalization::fit_without_occlusions(const Pose2& q, int* kept) const {
  const MclMap& map = *map_;
  const Vec2 o = map.field().origin();
  const double inv_res = 1.0 / map.field().resolution();
  const int w = map.width(), h = map.height();
  const double c = std::cos(q.yaw), s = std::sin(q.yaw);
  const double u0 = (q.x - o.x) * inv_res, v0 = (q.y - o.y) * inv_res;
  const Pose2 lp = params_.laser_pose;
  const double lu = u0 + (c * lp.x - s * lp.y) * inv_res, lv = v0 + (s * lp.x + c * lp.y) * inv_res;
  const double floor_log = map.field().floor_log(), quantum = map.quantum();
  const double near2 = std::pow(params_.occlusion_range * inv_res, 2);
  double sum = 0;
  int n = 0;
  for (size_t b = 0; b < beam_ex_.size(); ++b) {
    const double u = u0 + c * beam_ex_[b] - s * beam_ey_[b], v = v0 + s * beam_ex_[b] + c * beam_ey_[b];
    if (!(u >= 0 && v >= 0 && u < w && v < h)) {
      sum += floor_log;
      ++n;
      continue;
    }
    // March from the laser to the end in half-cell steps over the free bits.
    const double du = u - lu, dv = v - lv;
    bool short_beam = du * du + dv * dv < near2 && map.is_free(static_cast<int>(u), static_cast<int>(v));
    if (short_beam) {
      const int steps = static_cast<int>(std::ceil(2.0 * std::max(std::abs(du), std::abs(dv))));
      for (int k = 1; k < steps && short_beam; ++k) {
        const double f = static_cast<double>(k) / steps;
        const double pu = lu + f * du, pv = lv + f * dv;
        if (pu < 0 || pv < 0 || pu >= w || pv >= h || !map.is_free(static_cast<int>(pu), static_cast<int>(pv))) short_beam = false;
      }
    }
    const int qv = map.quantised(static_cast<int>(u), static_cast<int>(v));
    // A short beam that still lands near a wall (in the upper half of the table) is kept.
    if (short_beam && qv < 128) continue;
    const double ll = floor_log + quantum * qv;
    sum += ll;
    ++n;
  }
  *kept = n;
  return n ? sum / n : kNegInf;
}

// Beam skipping (nav2 AMCL's do_beamskip): a beam whose endpoint lies within
// beam_skip_distance of an obstacle for fewer than beam_skip_threshold of the particles is
// something the map does not hold (a robot, a person) and is left out of this update, unless
// more than beam_skip_error_threshold of the beams would go (then the filter, not the world, is
// probably wrong, and every beam is used).
void MonteCarloLocalization::skip_beams() {
  const size_t np = particles_.size();
  const size_t nb = beam_ex_.size();
  if (np == 0 || nb == 0) return;
  const MclMap& map = *map_;
  const LikelihoodField& f = map.field();
  const Vec2 o = f.origin();
  const double inv_res = 1.0 / f.resolution();
  const int w = map.width(), h = map.height();
  std::vector<int> agree(nb, 0);
  for (size_t j = 0; j < np; ++j) {
    const Pose2& q = particles_[j].pose;
    const double c = std::cos(q.yaw), s = std::sin(q.yaw);
    const double u0 = (q.x - o.x) * inv_res, v0 = (q.y - o.y) * inv_res;
    for (size_t b = 0; b < nb; ++b) {
      const double u = u0 + c * beam_ex_[b] - s * beam_ey_[b], v = v0 + s * beam_ex_[b] + c * beam_ey_[b];
      if (u >= 0 && v >= 0 && u < w && v < h && f.distance(static_cast<int>(u), static_cast<int>(v)) < params_.beam_skip_distance) {
        ++agree[b];
      }
    }
  }
  std::vector<float> kx, ky;
  for (size_t b = 0; b < nb; ++b) {
    if (agree[b] >= params_.beam_skip_threshold * static_cast<double>(np)) {
      kx.push_back(beam_ex_[b]);
      ky.push_back(beam_ey_[b]);
    }
  }
  stats_.last_skipped = static_cast<int>(nb - kx.size());
  if (kx.empty() || static_cast<double>(nb - kx.size()) > params_.beam_skip_error_threshold * static_cast<double>(nb)) {
    stats_.last_skipped = 0;
    return;
  }
  beam_ex_.swap(kx);
  beam_ey_.swap(ky);
}

// The likelihood-field measurement update: per particle the tempered scan log-likelihood;
// then the augmented-MCL averages (table 8.3) over the held particles' per-beam means.
void MonteCarloLocalization::measure() {
  const size_t np = particles_.size();
  ll_.resize(np);
  if (params_.beam_skip) skip_beams();
  score(&particles_[0].pose, np, sizeof(Particle), ll_.data());
  const double gamma_max = params_.likelihood_exponent;
  const bool recovery = params_.recovery_alpha_fast > 0;
  if (recovery) {
    // The scan's fit under the best held hypothesis: the largest per-beam mean log-likelihood
    // among the held particles (not the weighted mean, which particles resampled from a
    // wrong injection would pull down while a good hypothesis survives).
    const double inv_nb = 1.0 / static_cast<double>(beam_ex_.size());
    double best = kNegInf;
    size_t jbest = 0;
    for (size_t j = 0; j < np; ++j) {
      if (!injected_[j] && inv_nb * ll_[j] > best) {
        best = inv_nb * ll_[j];
        jbest = j;
      }
    }
    // Beams that end in free space short of the map's walls (the ray to the end crosses free
    // cells only) are what an unmapped body in front of the laser gives - a person, a robot, a
    // bag: no evidence that the pose is wrong. The gate judges the fit on the other beams, and
    // holds (no injection) when too few are left.
    if (best != kNegInf && params_.occlusion_range > 0) {
      int kept = 0;
      const double fit = fit_without_occlusions(particles_[jbest].pose, &kept);
      if (kept < std::max(8, static_cast<int>(beam_ex_.size()) / 4)) {
        best = kNegInf;
        drop_run_ = 0;
      } else {
        best = fit;
      }
    }
    if (best != kNegInf) {
      held_best_ = best;
      const double log_avg = best;
      if (!have_avgs_) {
        stats_.w_slow = stats_.w_fast = log_avg;
        have_avgs_ = true;
      } else {
        const double as = params_.recovery_alpha_slow, af = params_.recovery_alpha_fast;
        stats_.w_slow = log_add(std::log1p(-as) + stats_.w_slow, as > 0 ? std::log(as) + log_avg : kNegInf);
        stats_.w_fast = log_add(std::log1p(-af) + stats_.w_fast, std::log(af) + log_avg);
      }
      drop_run_ = stats_.w_fast < stats_.w_slow - params_.recovery_drop ? drop_run_ + 1 : 0;
    }
  }
  // Tempering: the largest exponent up to likelihood_exponent that keeps the effective sample
  // size at min_ess_fraction of the particles (bisection on the exponent's logarithm).
  auto ess = [&](double g) {
    double mx = kNegInf;
    for (size_t j = 0; j < np; ++j) mx = std::max(mx, particles_[j].log_weight + g * ll_[j]);
    double s1 = 0, s2 = 0;
    for (size_t j = 0; j < np; ++j) {
      const double e = std::exp(particles_[j].log_weight + g * ll_[j] - mx);
      s1 += e;
      s2 += e * e;
    }
    return s1 * s1 / s2;
  };
  double gamma = gamma_max;
  const double target = params_.min_ess_fraction * static_cast<double>(np);
  if (params_.min_ess_fraction > 0 && ess(gamma_max) < target) {
    double lo = std::log(gamma_max) - 12, hi = std::log(gamma_max);
    for (int it = 0; it < 10; ++it) {
      const double mid = 0.5 * (lo + hi);
      if (ess(std::exp(mid)) < target) hi = mid; else lo = mid;
    }
    gamma = std::exp(lo);
  }
  stats_.last_exponent = gamma;
  for (size_t j = 0; j < np; ++j) particles_[j].log_weight += gamma * ll_[j];
}

namespace {
// The largest exponent g in [1e-5, 1] (bisection on log g) for which the weights exp(g * ll)
// keep an effective sample size >= target; the weights, normalised, into w.
void temper_to_ess(const std::vector<float>& ll, double target, std::vector<double>* w) {
  const size_t n = ll.size();
  double mx = -std::numeric_limits<double>::infinity();
  for (float v : ll) mx = std::max(mx, static_cast<double>(v));
  w->resize(n);
  auto fill = [&](double g) {
    double s1 = 0, s2 = 0;
    for (size_t j = 0; j < n; ++j) {
      const double e = std::exp(g * (ll[j] - mx));
      (*w)[j] = e;
      s1 += e;
      s2 += e * e;
    }
    return std::pair{s1, s1 * s1 / s2};
  };
  double lo = std::log(1e-5), hi = 0;
  if (fill(1.0).second < target) {
    for (int it = 0; it < 14; ++it) {
      const double mid = 0.5 * (lo + hi);
      if (fill(std::exp(mid)).second < target) hi = mid; else lo = mid;
    }
  } else {
    lo = 0;
  }
  const double s1 = fill(std::exp(lo)).first;
  for (auto& v : *w) v /= s1;
}

// Low-variance resampling of `count` indices from normalised weights w, offset u in [0, 1).
template <typename F>
void systematic_draw(const std::vector<double>& w, int count, double u, F&& take) {
  if (count <= 0 || w.empty()) return;
  const double step = 1.0 / count;
  u *= step;
  double c = w[0];
  size_t i = 0;
  const size_t last = w.size() - 1;
  for (int k = 0; k < count; ++k, u += step) {
    while (u > c && i < last) c += w[++i];
    take(k, i);
  }
}
}  // namespace

// Up to `count` poses by the current scan: injection_candidates uniform free poses per pose
// wanted, scored, tempered to an effective sample size of `count`, drawn systematically; none
// unless the best candidate beats the best held particle by injection_margin per beam.
// Returns how many were drawn.
int MonteCarloLocalization::draw_guided(int count, Particle* out) {
  if (count <= 0) return 0;
  const size_t k = static_cast<size_t>(count) * params_.injection_candidates;
  if (k <= static_cast<size_t>(count) || beam_ex_.empty()) {
    for (int j = 0; j < count; ++j) out[j] = Particle{random_free_pose(), 0.0};
    return count;
  }
  cand_.resize(k);
  for (auto& c : cand_) c = random_free_pose();
  cand_ll_.resize(k);
  score(cand_.data(), k, sizeof(Pose2), cand_ll_.data());
  float top = cand_ll_[0];
  for (float v : cand_ll_) top = std::max(top, v);
  int drawn = 0;
  if (top / static_cast<double>(beam_ex_.size()) > held_best_ + params_.injection_margin) {
    temper_to_ess(cand_ll_, count, &cand_w_);
    systematic_draw(cand_w_, count, rng_.uniform(), [&](int j, size_t i) { out[j] = Particle{cand_[i], 0.0}; });
    drawn = count;
  }
  // Release the scratch: per-filter memory stays O(particles) between injections.
  std::vector<Pose2>().swap(cand_);
  std::vector<float>().swap(cand_ll_);
  std::vector<double>().swap(cand_w_);
  return drawn;
}

// Global initialisation from the first scan: global_candidates uniform free poses, scored,
// tempered to an effective sample size of the particle count, drawn systematically.
void MonteCarloLocalization::global_from_scan() {
  const int n = static_cast<int>(particles_.size());
  const size_t k = std::max<size_t>(params_.global_candidates, static_cast<size_t>(n));
  cand_.resize(k);
  for (auto& c : cand_) c = random_free_pose();
  cand_ll_.resize(k);
  score(cand_.data(), k, sizeof(Pose2), cand_ll_.data());
  temper_to_ess(cand_ll_, n, &cand_w_);
  systematic_draw(cand_w_, n, rng_.uniform(), [&](int j, size_t i) { particles_[j] = Particle{cand_[i], 0.0}; });
  std::fill(injected_.begin(), injected_.end(), 0);
  std::vector<Pose2>().swap(cand_);
  std::vector<float>().swap(cand_ll_);
  std::vector<double>().swap(cand_w_);
}

// Normalised weights of the particles into weights_.
void MonteCarloLocalization::normalise() {
  double mx = kNegInf;
  for (const auto& p : particles_) mx = std::max(mx, p.log_weight);
  weights_.resize(particles_.size());
  double sum = 0;
  for (size_t j = 0; j < particles_.size(); ++j) sum += weights_[j] = std::exp(particles_[j].log_weight - mx);
  const double inv = 1.0 / sum;
  for (auto& w : weights_) w *= inv;
}

// Low-variance resampling (table 4.4) of `count` particles from the weighted set into out.
void MonteCarloLocalization::systematic(int count, std::vector<Particle>* out) {
  out->resize(count);
  if (count == 0) return;
  const double step = 1.0 / count;
  double u = rng_.uniform() * step;
  double c = weights_[0];
  size_t i = 0;
  const size_t last = particles_.size() - 1;
  for (int k = 0; k < count; ++k, u += step) {
    while (u > c && i < last) c += weights_[++i];
    (*out)[k].pose = particles_[i].pose;
    (*out)[k].log_weight = 0;
  }
}

void MonteCarloLocalization::resample() {
  normalise();
  int n = params_.particles;
  if (params_.kld) {
    // KLD sampling: the bins a full-size draw occupies set the count (Fox 2003).
    systematic(params_.max_particles, &scratch_);
    clear_bins();
    for (const auto& p : scratch_) bin_of(p.pose);
    n = kld_bound(bins_used_, params_.kld_err, params_.kld_z, params_.min_particles, params_.max_particles);
  }
  // Augmented MCL: the share of random particles (table 8.3, line 9), a stratified count.
  // Injected only after w_fast stayed below w_slow - recovery_drop for recovery_persistence updates.
  int n_rand = 0;
  if (params_.recovery_alpha_fast > 0 && have_avgs_ && drop_run_ >= params_.recovery_persistence) {
    const double deficit = stats_.w_slow - stats_.w_fast - params_.recovery_drop;
    const double p_rand = std::min(params_.recovery_max_share, std::max(0.0, 1.0 - std::exp(-deficit)));
    n_rand = std::min(n, static_cast<int>(std::floor(p_rand * n + rng_.uniform())));
  }
  if (n_rand > 0) {
    scratch_.resize(n_rand);
    n_rand = draw_guided(n_rand, scratch_.data());
    cand_.resize(n_rand);
    for (int k = 0; k < n_rand; ++k) cand_[k] = scratch_[k].pose;
  }
  systematic(n - n_rand, &scratch_);
  scratch_.resize(n);
  for (int k = 0; k < n_rand; ++k) scratch_[n - n_rand + k] = Particle{cand_[k], 0.0};
  std::vector<Pose2>().swap(cand_);
  particles_.swap(scratch_);
  injected_.assign(n, 0);
  std::fill(injected_.begin() + (n - n_rand), injected_.end(), 1);
  stats_.last_injected = n_rand;
  stats_.injected += n_rand;
  ++stats_.resamplings;
}

// ---- bins, clusters and the estimate ---------------------------------------------------

void MonteCarloLocalization::clear_bins() {
  for (int32_t slot : bin_slot_of_) bin_slots_[slot] = -1;
  bin_slot_of_.clear();
  bin_key_of_.clear();
  bins_used_ = 0;
}

int MonteCarloLocalization::find_bin(uint64_t key) const {
  const size_t mask = bin_slots_.size() - 1;
  size_t slot = static_cast<size_t>((key * 0x9E3779B97F4A7C15ull) >> (64 - bin_bits_));
  while (true) {
    const int32_t id = bin_slots_[slot];
    if (id < 0) return -1;
    if (bin_keys_[slot] == key) return id;
    slot = (slot + 1) & mask;
  }
}

uint64_t MonteCarloLocalization::bin_key(const Pose2& p) const {
  const int64_t ix = static_cast<int64_t>(std::floor(p.x / params_.kld_bin_xy));
  const int64_t iy = static_cast<int64_t>(std::floor(p.y / params_.kld_bin_xy));
  int64_t it = static_cast<int64_t>(std::floor((p.yaw + M_PI) / params_.kld_bin_yaw));
  it = ((it % yaw_bins_) + yaw_bins_) % yaw_bins_;
  return pack_bin(ix, iy, it);
}

int MonteCarloLocalization::bin_of(const Pose2& p) {
  const uint64_t key = bin_key(p);
  const size_t mask = bin_slots_.size() - 1;
  size_t slot = static_cast<size_t>((key * 0x9E3779B97F4A7C15ull) >> (64 - bin_bits_));
  while (true) {
    const int32_t id = bin_slots_[slot];
    if (id < 0) break;
    if (bin_keys_[slot] == key) return id;
    slot = (slot + 1) & mask;
  }
  const int id = bins_used_++;
  bin_slots_[slot] = id;
  bin_keys_[slot] = key;
  bin_slot_of_.push_back(static_cast<int32_t>(slot));
  bin_key_of_.push_back(key);
  return id;
}

namespace {
int find_root(std::vector<int32_t>& parent, int a) {
  while (parent[a] != a) {
    parent[a] = parent[parent[a]];
    a = parent[a];
  }
  return a;
}
}  // namespace

// Clusters: occupied bins joined when adjacent (26-neighbourhood, heading wrapping round);
// the estimate is the weighted mean of the heaviest one.
void MonteCarloLocalization::compute_estimate() {
  estimate_ = MclEstimate{};
  if (particles_.empty()) return;
  normalise();
  clear_bins();
  const size_t np = particles_.size();
  particle_bin_.resize(np);
  for (size_t j = 0; j < np; ++j) particle_bin_[j] = bin_of(particles_[j].pose);
  const int nbins = bins_used_;
  bin_parent_.resize(nbins);
  for (int b = 0; b < nbins; ++b) bin_parent_[b] = b;
  for (int b = 0; b < nbins; ++b) {
    const uint64_t key = bin_key_of_[b];
    const int64_t ix = static_cast<int64_t>((key >> 42) & kCoordMask) - (1 << 20);
    const int64_t iy = static_cast<int64_t>((key >> 21) & kCoordMask) - (1 << 20);
    const int64_t it = static_cast<int64_t>(key & kCoordMask);
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dt = -1; dt <= 1; ++dt) {
          if (!dx && !dy && !dt) continue;
          const int64_t t = ((it + dt) % yaw_bins_ + yaw_bins_) % yaw_bins_;
          const int other = find_bin(pack_bin(ix + dx, iy + dy, t));
          if (other < 0) continue;
          const int ra = find_root(bin_parent_, b), rb = find_root(bin_parent_, other);
          if (ra != rb) bin_parent_[std::max(ra, rb)] = std::min(ra, rb);
        }
  }
  // Per cluster (indexed by root bin): weight, and x, y, cos, sin weighted sums.
  bin_acc_.assign(static_cast<size_t>(nbins) * 5, 0.0);
  for (size_t j = 0; j < np; ++j) {
    const int r = find_root(bin_parent_, particle_bin_[j]);
    particle_bin_[j] = r;
    const double w = weights_[j];
    const Pose2& q = particles_[j].pose;
    double* a = &bin_acc_[static_cast<size_t>(r) * 5];
    a[0] += w;
    a[1] += w * q.x;
    a[2] += w * q.y;
    a[3] += w * std::cos(q.yaw);
    a[4] += w * std::sin(q.yaw);
  }
  int best = -1, clusters = 0;
  for (int b = 0; b < nbins; ++b) {
    if (bin_parent_[b] != b) continue;
    ++clusters;
    if (best < 0 || bin_acc_[static_cast<size_t>(b) * 5] > bin_acc_[static_cast<size_t>(best) * 5]) best = b;
  }
  const double* a = &bin_acc_[static_cast<size_t>(best) * 5];
  const double W = a[0];
  MclEstimate e;
  e.clusters = clusters;
  e.cluster_weight = W;
  e.pose = {a[1] / W, a[2] / W, std::atan2(a[4], a[3])};
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (size_t j = 0; j < np; ++j) {
    if (particle_bin_[j] != best) continue;
    const Pose2& q = particles_[j].pose;
    const Eigen::Vector3d d(q.x - e.pose.x, q.y - e.pose.y, wrap_angle(q.yaw - e.pose.yaw));
    cov += weights_[j] * (d * d.transpose());
  }
  cov /= W;
  e.covariance = cov;
  e.stddev = {std::sqrt(cov(0, 0)), std::sqrt(cov(1, 1)), std::sqrt(cov(2, 2))};
  e.converged = W >= params_.converged_weight && e.stddev.x <= params_.converged_spread &&
                e.stddev.y <= params_.converged_spread;
  estimate_ = e;
}

}  // namespace vigil::planning
