// Monte Carlo localisation of one robot on a known occupancy grid (the chapter's sec. 10.6.2,
// after Marchetti et al. 2006; the filter as nav2 AMCL users run it). Probabilistic Robotics
// (Thrun, Burgard, Fox 2005) gives the pieces:
//   - motion: sample_motion_model_odometry (table 5.6), noise standard deviations
//       rot1: alpha1*|rot1| + alpha2*trans, trans: alpha3*trans + alpha4*(|rot1| + |rot2|),
//       rot2: alpha1*|rot2| + alpha2*trans  (linear in the motion, as AMCL's "diff" model);
//   - measurement: the likelihood field (sec. 6.4, planning/localization/likelihood_field.h),
//     quantised to one byte a cell in 8 x 8-cell tiles (MclMap, shared between filters),
//     over `max_beams` evenly spaced beams, summed as log-likelihoods and tempered by
//     `likelihood_exponent` (beams are not independent; AMCL tempers by cubing per-beam terms),
//     lowered further when the scan would leave fewer than min_ess_fraction effective particles
//     (adaptive tempering: in global localisation hypotheses die over several scans, not one);
//     a particle off the free space scores as if no beam hit;
//   - resampling: low-variance (systematic) resampling (table 4.4) every `resample_interval`
//     filter updates, optionally with KLD-sampling's adaptive count (Fox 2003; table 8.4);
//   - recovery: augmented MCL (table 8.3), gated: short- and long-term averages of the best
//     held particle's per-beam log-likelihood; once w_fast stays below w_slow by recovery_drop
//     for recovery_persistence updates, a share of the resampled particles is drawn from
//     uniform free poses by the current scan (sensor-guided, as mixture MCL), and only if such
//     a pose fits better than the held ones by injection_margin per beam;
//   - global localisation: initialize_global() scores global_candidates uniform free poses
//     with the first scan and keeps the particle count of them.
// The filter updates only after the robot moved update_min_d or turned update_min_a since the
// last update. The estimate is the weighted mean of the heaviest cluster of particles (bins of
// kld_bin_xy x kld_bin_yaw joined when adjacent), heading by circular mean, with covariance.
// Deterministic: every random number comes from one Rng seeded by MclParams::seed.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <vector>

#include "common/geometry.h"
#include "common/laser_scan.h"
#include "common/occupancy_grid.h"
#include "common/rng.h"
#include "common/status.h"
#include "planning/localization/likelihood_field.h"

namespace vigil::planning {

// Filter parameters with defaults; ranges as OMPL's declareParam ("min:step:max").
struct MclParams {
  uint64_t seed = 1;                // the filter's random stream
  // Particle count: fixed, or adaptive by KLD sampling between min and max.
  int particles = 500;              // fixed count                            "1:1:1000000"
  bool kld = false;                 // adaptive count (nav2 AMCL's behaviour)
  int min_particles = 500;          // KLD lower bound                        "1:1:1000000"
  int max_particles = 5000;         // KLD upper bound, and global init count "1:1:1000000"
  double kld_err = 0.01;            // KLD bound epsilon (pf_err)             "0.0001:0.001:1."
  double kld_z = 0.99;              // KLD normal quantile z (pf_z, as nav2)  "0.01:0.01:10."
  double kld_bin_xy = 0.5;          // m, histogram/cluster bin size          "0.01:0.05:10."
  double kld_bin_yaw = 10 * M_PI / 180;  // rad, histogram/cluster bin size   "0.01:0.01:3.14"
  // Odometry motion model (table 5.6), standard deviations linear in the motion.
  double alpha1 = 0.2;              // rotation noise from rotation           "0.:0.01:10."
  double alpha2 = 0.1;              // rotation noise from translation (rad/m) "0.:0.01:10."
  double alpha3 = 0.1;              // translation noise from translation     "0.:0.01:10."
  double alpha4 = 0.05;             // translation noise from rotation (m/rad) "0.:0.01:10."
  // Laser model.
  Pose2 laser_pose;                 // the laser in the robot frame
  int max_beams = 60;               // beams used per scan, evenly subsampled "1:1:100000"
  LikelihoodFieldParams field;      // sigma_hit 0.2, z_hit 0.95, z_rand 0.05, max_range 20
  double likelihood_exponent = 0.3; // tempering of the scan log-likelihood   "0.001:0.01:1."
  // Adaptive tempering: the exponent is lowered (never raised) so that the effective sample
  // size after a scan stays >= this share of the particles; 0 disables.   "0.:0.01:1."
  double min_ess_fraction = 0.5;
  // When to update.
  double update_min_d = 0.2;        // m                                      "0.:0.01:100."
  double update_min_a = 0.2;        // rad                                    "0.:0.01:6.3"
  int resample_interval = 1;        // filter updates per resampling          "1:1:1000"
  // Augmented MCL; alpha_slow = alpha_fast = 0 disables the injection. The averages are of the
  // held particles' per-beam mean log-likelihood (a geometric mean per beam, so the number of
  // valid beams does not move them).
  double recovery_alpha_slow = 0.001;  //                                     "0.:0.001:1."
  double recovery_alpha_fast = 0.1;    // must exceed alpha_slow when enabled  "0.:0.01:1."
  // Cap on the share injected at one resampling, so some hypotheses always carry over.
  double recovery_max_share = 0.3;     //                                      "0.:0.01:1."
  // Injection gate: nothing is injected unless w_fast is below w_slow by more than
  // recovery_drop (nats per beam) for recovery_persistence filter updates in a row; then the
  // share is min(max_share, 1 - exp(w_fast - w_slow + recovery_drop)).
  double recovery_drop = 0.4;          // nats per beam                        "0.:0.05:10."
  int recovery_persistence = 3;        // updates in a row                     "1:1:1000"
  // Beams ending within this range in free space, short of the map's walls (a person or robot
  // close in front), do not count against the fit the gate judges; too few others left holds
  // the gate. Off (0) by default: a filter that may have converged on a wrong but similar place
  // needs those beams to leave it (global localisation); on for tracking among moving robots.
  double occlusion_range = 0.0;        // m                                    "0.:0.5:50."
  // Beam skipping (nav2 AMCL do_beamskip, its defaults): beams most particles cannot explain
  // are left out of an update. Off by default (as AMCL); on for robots among robots.
  bool beam_skip = false;
  double beam_skip_distance = 0.5;         // m                                "0.:0.05:10."
  double beam_skip_threshold = 0.3;        // share of particles that must agree "0.:0.05:1."
  double beam_skip_error_threshold = 0.9;  // more beams skipped: use them all   "0.:0.05:1."
  // Sensor-guided sampling (as Thrun et al.'s mixture MCL proposes): a random particle is the
  // pick, by the current scan's likelihood, among `injection_candidates` uniform free poses per
  // particle needed; global initialisation scores `global_candidates` uniform poses with the
  // first scan and keeps max_particles (`particles` without KLD) of them. 1 / 0 = plain uniform.
  int injection_candidates = 20;       // per injected particle                "1:1:10000"
  // ... and only when the best candidate fits the scan better than the best held particle by
  // this much (nats per beam): where no pose explains the scan well (beams through unmapped
  // space, clutter) the gate opens but nothing better exists, so a good track is kept.
  double injection_margin = 0.2;       // nats per beam                        "0.:0.05:10."
  int global_candidates = 200000;      // 0: particles stay uniform            "0:1:100000000"
  // Uniform sampling (global init, injection) leaves out the free cells 4-connected to the grid
  // border (outside a floorplan's building). Used by create(map, params) when it builds the
  // map data; a shared MclMap carries its own choice.
  bool exclude_exterior = false;
  // converged(): the heaviest cluster holds this much weight with this position spread.
  double converged_spread = 0.5;    // m, max std of x and y                  "0.01:0.01:100."
  double converged_weight = 0.8;    // share of the weight                    "0.:0.01:1."
};

// Checks every parameter; the error names the key.
Status validate(const MclParams& p);

// The map-derived data of the filter, built once and shared (read-only, thread-safe to read)
// by any number of filters on the same map: the likelihood field, a quantised copy of its log
// table laid out in 8 x 8-cell tiles (one byte a cell, one 64-byte cache line a tile), the
// free-cell mask and the list of free cells uniform sampling draws from.
class MclMap {
 public:
  // `exclude_exterior`: leave out of the sampling list the free cells 4-connected to the grid
  // border (flood fill from the border over free cells); they stay free for the filter.
  static Result<std::shared_ptr<const MclMap>> build(const OccupancyGrid& map, const LikelihoodFieldParams& params,
                                                     bool exclude_exterior = false);

  const LikelihoodField& field() const { return field_; }
  int width() const { return width_; }
  int height() const { return height_; }
  bool exclude_exterior() const { return exclude_exterior_; }
  // Cells uniform sampling draws from (row-major indices).
  const std::vector<int32_t>& sample_cells() const { return sample_cells_; }
  bool is_free(int cx, int cy) const {
    const size_t i = static_cast<size_t>(cy) * width_ + cx;
    return (free_bits_[i >> 6] >> (i & 63)) & 1;
  }
  // The quantised log-likelihood: log p = floor_log + q * quantum, q in 0..255.
  float quantum() const { return quantum_; }
  int quantised(int cx, int cy) const { return tiles_[tile_index(cx, cy)]; }
  const uint8_t* tiles() const { return tiles_.data(); }
  size_t tile_index(int cx, int cy) const {
    return ((static_cast<size_t>(cy >> 3) * tiles_x_ + (cx >> 3)) << 6) | ((cy & 7) << 3) | (cx & 7);
  }
  int tiles_x() const { return tiles_x_; }
  // Bytes held (tables, masks, lists).
  size_t memory_bytes() const;

 private:
  MclMap() = default;
  LikelihoodField field_;
  int width_ = 0, height_ = 0, tiles_x_ = 0;
  bool exclude_exterior_ = false;
  float quantum_ = 0;
  std::vector<uint8_t> tiles_;
  std::vector<uint64_t> free_bits_;
  std::vector<int32_t> sample_cells_;
};

// One hypothesis of the robot's pose.
struct Particle {
  Pose2 pose;
  double log_weight = 0;  // unnormalised, since the last resampling
};

// The filter's belief, summarised.
struct MclEstimate {
  Pose2 pose;                    // mean of the heaviest cluster
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  // x, y, yaw (yaw by wrapped residuals)
  Vec3 stddev;                   // square roots of the covariance's diagonal
  double cluster_weight = 0;     // share of the weight in that cluster
  int clusters = 0;              // clusters found
  bool converged = false;
};

// Counters, for benchmarks and tests.
struct MclStats {
  int64_t filter_updates = 0;    // sensor updates done
  int64_t resamplings = 0;
  int64_t injected = 0;          // random particles injected, in total
  int last_injected = 0;         // in the last resampling
  int last_skipped = 0;          // beams beam skipping left out of the last update
  double w_slow = 0, w_fast = 0; // log of the long- and short-term likelihood averages
  double last_exponent = 0;      // the likelihood exponent the last scan was weighted with
};

class MonteCarloLocalization {
 public:
  // Builds the filter on `map` (its own MclMap, with params.field and params.exclude_exterior);
  // bad parameters or a map without free cells give an error naming the key.
  static Result<MonteCarloLocalization> create(const OccupancyGrid& map, const MclParams& params);
  // A filter on shared map data: per-filter memory is then O(particles). params.field must
  // equal the map's field parameters (error "field" otherwise); params.exclude_exterior is
  // ignored (the map's choice holds).
  static Result<MonteCarloLocalization> create(std::shared_ptr<const MclMap> map, const MclParams& params);

  // Particles drawn around `mean` with independent Gaussian stddevs (x, y in m, yaw in rad);
  // `particles` of them (min_particles with KLD). Forgets the odometry reference.
  Status initialize(Pose2 mean, Vec3 stddev);
  // Global localisation: max_particles (`particles` without KLD) uniform over the free cells.
  void initialize_global();
  // Feeds the odometry pose (odometry frame) and, when there is one, a scan. The first call
  // after an initialisation sets the reference (and updates with the scan, if given); later
  // calls update the filter once the motion since the last update exceeds update_min_d or
  // update_min_a and a scan is given. Returns whether a filter update happened.
  bool update(Pose2 odometry, const LaserScan* scan);

  // Switches the options for a filter among people and robots (occlusion_range, beam_skip;
  // see MclParams) on or off from the next update: a robot whose start is unknown localises
  // without them and turns them on once localised. An out-of-range value is an error naming the
  // key, and changes nothing.
  Status set_crowd_options(double occlusion_range, bool beam_skip);

  // The current estimate (recomputed at each filter update and initialisation).
  const MclEstimate& estimate() const { return estimate_; }
  bool converged() const { return estimate_.converged; }
  const std::vector<Particle>& particles() const { return particles_; }
  const MclStats& stats() const { return stats_; }
  const MclParams& params() const { return params_; }
  const LikelihoodField& field() const { return map_->field(); }
  const std::shared_ptr<const MclMap>& map() const { return map_; }
  // Bytes this filter holds besides the shared map data: O(particles + beams).
  size_t memory_bytes() const;

 private:
  MonteCarloLocalization() = default;
  void sample_motion(Pose2 from, Pose2 to);
  bool prepare_beams(const LaserScan& scan);
  void score(const Pose2* poses, size_t n, size_t stride, float* out) const;
  void measure();
  double fit_without_occlusions(const Pose2& q, int* kept) const;
  void skip_beams();
  void global_from_scan();
  int draw_guided(int count, Particle* out);
  void resample();
  void compute_estimate();
  Pose2 random_free_pose();
  double held_log_sum() const;
  void normalise();
  void systematic(int count, std::vector<Particle>* out);
  uint64_t bin_key(const Pose2& p) const;
  int find_bin(uint64_t key) const;  // dense id of a bin, -1 when absent
  int bin_of(const Pose2& p);        // dense id of a pose's bin (inserted when new)
  void clear_bins();

  MclParams params_;
  std::shared_ptr<const MclMap> map_;
  Rng rng_;
  std::vector<Particle> particles_, scratch_;
  std::vector<double> weights_;      // normalised weights (scratch)
  std::vector<float> ll_;            // per particle: the last scan's log-likelihood
  std::vector<float> beam_ex_, beam_ey_;  // beam endpoints in the robot frame, cell units
  std::vector<Pose2> cand_;          // candidate poses (guided sampling; scratch)
  std::vector<float> cand_ll_;
  std::vector<double> cand_w_;
  // Bin table: open addressing over 64-bit keys, dense ids, union-find parents.
  std::vector<uint64_t> bin_keys_;
  std::vector<int32_t> bin_slots_;
  std::vector<int32_t> bin_parent_;
  std::vector<uint64_t> bin_key_of_;
  std::vector<double> bin_acc_;      // per bin: w, wx, wy, wcos, wsin
  std::vector<int32_t> bin_slot_of_;
  std::vector<int32_t> particle_bin_;
  std::vector<uint8_t> injected_;   // per particle: drawn at random in the last resampling
  int bin_bits_ = 0;
  int yaw_bins_ = 36;
  int bins_used_ = 0;
  bool have_odom_ = false;
  bool force_update_ = false;
  bool have_avgs_ = false;
  bool global_pending_ = false;      // initialize_global(): guide by the first scan
  int drop_run_ = 0;
  double held_best_ = 0;             // the last scan's best per-beam fit among held particles                 // updates in a row with w_fast below w_slow - recovery_drop
  Pose2 last_odom_;
  int updates_since_resample_ = 0;
  MclEstimate estimate_;
  MclStats stats_;
};

}  // namespace vigil::planning
