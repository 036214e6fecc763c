#include "vision/planview_tracker.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <numeric>

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>

namespace vigil::vision {
namespace {

using Vec6 = Eigen::Matrix<double, 6, 1>;
using Mat6 = Eigen::Matrix<double, 6, 6>;
using Vec4 = Eigen::Matrix<double, 4, 1>;
using Mat4 = Eigen::Matrix<double, 4, 4>;
using Mat46 = Eigen::Matrix<double, 4, 6>;

std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

Error param_error(const std::string& key, const std::string& message) { return bad_input("", 0, key, message); }

std::string grid_str(const PlanViewGrid& g) {
  return std::to_string(g.cols) + "x" + std::to_string(g.rows) + " cells of " + num(g.cell) + " m from (" +
         num(g.x_min) + ", " + num(g.y_min) + ")";
}

constexpr int kLanes = 8;  // partial sums kept apart so the compiler vectorises without reassociating

// Rows [r0, r1) of eq. 10.8's sums for one window: |tau_o - occ|, |tau_h - hgt| and, with claims,
// claim * gauss, accumulated per lane. The same source is compiled twice, for the baseline and for
// AVX2 (picked at run time); lanes never mix, so both give the same bits.
struct SadRows {
  const float* occ;    // map row of the window's first row, at its first column
  const float* hgt;
  const float* claim;  // null without claims
  size_t map_step;     // floats between map rows
  const float* tau_o;  // template rows, T floats each
  const float* tau_h;
  const float* gauss;
  int T;
};

// Eight float lanes as one value (GCC/Clang vector extension: one AVX register, or two SSE ones).
// The helpers are internal and inlined: GCC's note that passing such a value by value depends on
// -mavx (-Wpsabi) does not apply.
#pragma GCC diagnostic ignored "-Wpsabi"
typedef float F8 __attribute__((vector_size(32)));
typedef int I8 __attribute__((vector_size(32)));
static_assert(kLanes == 8, "the SAD kernel works on 8 lanes");

inline F8 load8(const float* p) {
  F8 v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
inline F8 abs8(F8 v) { return reinterpret_cast<F8>(reinterpret_cast<I8>(v) & 0x7fffffff); }

inline void sad_rows_impl(const SadRows& a, int r0, int r1, float* out_o, float* out_h, float* out_c) {
  F8 vo = load8(out_o), vh = load8(out_h), vc = load8(out_c);
  const int T = a.T, blocks = T / kLanes * kLanes;
  for (int r = r0; r < r1; ++r) {
    const size_t mrow = static_cast<size_t>(r) * a.map_step, trow = static_cast<size_t>(r) * T;
    const float* mo = a.occ + mrow;
    const float* mh = a.hgt + mrow;
    const float* to = a.tau_o + trow;
    const float* th = a.tau_h + trow;
    for (int k = 0; k < blocks; k += kLanes) {
      vo += abs8(load8(to + k) - load8(mo + k));
      vh += abs8(load8(th + k) - load8(mh + k));
    }
    for (int k = blocks; k < T; ++k) {
      vo[0] += std::abs(to[k] - mo[k]);
      vh[0] += std::abs(th[k] - mh[k]);
    }
    if (a.claim) {
      const float* mc = a.claim + mrow;
      const float* g = a.gauss + trow;
      for (int k = 0; k < blocks; k += kLanes) vc += load8(mc + k) * load8(g + k);
      for (int k = blocks; k < T; ++k) vc[0] += mc[k] * g[k];
    }
  }
  std::memcpy(out_o, &vo, sizeof vo);
  std::memcpy(out_h, &vh, sizeof vh);
  std::memcpy(out_c, &vc, sizeof vc);
}

void sad_rows_portable(const SadRows& a, int r0, int r1, float* acc_o, float* acc_h, float* acc_c) {
  sad_rows_impl(a, r0, r1, acc_o, acc_h, acc_c);
}

#if defined(__x86_64__) && defined(__GNUC__)
__attribute__((target("avx2"))) void sad_rows_avx2(const SadRows& a, int r0, int r1, float* acc_o, float* acc_h,
                                                   float* acc_c) {
  sad_rows_impl(a, r0, r1, acc_o, acc_h, acc_c);
}
#endif

using SadRowsFn = void (*)(const SadRows&, int, int, float*, float*, float*);

bool& exhaustive_flag() {
  static bool exhaustive = false;
  return exhaustive;
}

SadRowsFn pick_sad_rows() {
#if defined(__x86_64__) && defined(__GNUC__)
  static const bool avx2 = __builtin_cpu_supports("avx2");
  if (avx2 && !exhaustive_flag()) return &sad_rows_avx2;
#endif
  return &sad_rows_portable;
}

// One connected blob of the plan-view mask.
struct Blob {
  double mass = 0;           // sum of theta_sm (occupancy units)
  double cx = 0, cy = 0;     // centre of mass, cells
  double max_height = 0;     // m
  double sxx = 0, sxy = 0, syy = 0;  // occupancy-weighted second moments (cells^2, about the origin)
  bool on_border = false;    // a cell of it lies on the grid's outermost rows or columns
};

}  // namespace

TrackClass classify_track(double h, double w, const ClassifierParams& p) {
  if (h >= p.person_min_height && h <= p.person_max_height) return TrackClass::kPerson;
  if (h >= p.robot_min_height && h < p.robot_max_height && (h >= p.bag_max_height || w >= p.robot_min_width))
    return TrackClass::kRobot;
  if (h >= p.bag_min_height && h < p.bag_max_height && w < p.robot_min_width) return TrackClass::kBag;
  return TrackClass::kUnknown;
}

Status PlanViewTrackerParams::validate() const {
  auto pos = [](double v) { return v > 0 && std::isfinite(v); };
  auto nonneg = [](double v) { return v >= 0 && std::isfinite(v); };
  if (template_size < 4 || template_size > 400)
    return param_error("template_size", "must be 4 to 400 cells, got " + std::to_string(template_size));
  if (!nonneg(w_height)) return param_error("w_height", "must be >= 0");
  if (!nonneg(w_occupancy) || !(w_height + w_occupancy > 0))
    return param_error("w_occupancy", "must be >= 0, and w_height + w_occupancy > 0");
  if (!nonneg(beta)) return param_error("beta", "must be >= 0");
  if (!nonneg(alpha)) return param_error("alpha", "must be >= 0");
  if (!pos(track_threshold)) return param_error("track_threshold", "must be positive, got " + num(track_threshold));
  if (!nonneg(search_sigmas)) return param_error("search_sigmas", "must be >= 0");
  if (!pos(search_min)) return param_error("search_min", "must be positive");
  if (!pos(search_max) || search_max < search_min || search_max > 10)
    return param_error("search_max", "must be in [search_min, 10] m, got " + num(search_max));
  if (!pos(core_sigma)) return param_error("core_sigma", "must be positive");
  if (!pos(height_radius)) return param_error("height_radius", "must be positive");
  if (!(template_rate > 0 && template_rate <= 1))
    return param_error("template_rate", "must be in (0, 1], got " + num(template_rate));
  if (min_hits < 1) return param_error("min_hits", "must be at least 1");
  if (max_missed < 1) return param_error("max_missed", "must be at least 1");
  if (max_occluded < 0) return param_error("max_occluded", "must be >= 0");
  if (max_occluded_bag < 0) return param_error("max_occluded_bag", "must be >= 0");
  if (std::isnan(top_cut_margin)) return param_error("top_cut_margin", "must be a number (negative: off)");
  if (report_missed < 0) return param_error("report_missed", "must be >= 0");
  if (!(gate >= 0) || !std::isfinite(gate)) return param_error("gate", "must be >= 0 (0 = none)");
  if (!(occluded_position_noise > 0)) return param_error("occluded_position_noise", "must be positive");
  if (!(reacquire_max >= 0)) return param_error("reacquire_max", "must be >= 0");
  if (!(coast_hold_speed >= 0) || !std::isfinite(coast_hold_speed))
    return param_error("coast_hold_speed", "must be >= 0 m/s");
  if (!(coast_velocity_decay >= 0) || !std::isfinite(coast_velocity_decay))
    return param_error("coast_velocity_decay", "must be >= 0 s (0 = none)");
  if (!(occluded_match >= 0 && occluded_match <= 1)) return param_error("occluded_match", "must be in [0, 1]");
  if (!(visible_surface_offset >= 0) || visible_surface_offset > 2)
    return param_error("visible_surface_offset", "must be in [0, 2] m, got " + num(visible_surface_offset));
  if (!nonneg(birth_min_area)) return param_error("birth_min_area", "must be >= 0");
  if (!nonneg(birth_min_height)) return param_error("birth_min_height", "must be >= 0");
  if (!(class_vote_decay > 0 && class_vote_decay <= 1))
    return param_error("class_vote_decay", "must be in (0, 1], got " + num(class_vote_decay));
  if (!nonneg(birth_border_margin)) return param_error("birth_border_margin", "must be >= 0");
  if (!nonneg(birth_shadow_depth)) return param_error("birth_shadow_depth", "must be >= 0");
  if (split_window < 0) return param_error("split_window", "must be >= 0");
  if (split_still_frames < 0 || split_still_frames > 60000)
    return param_error("split_still_frames", "must be 0 to 60000 frames, got " + std::to_string(split_still_frames));
  if (!nonneg(split_radius)) return param_error("split_radius", "must be >= 0");
  if (!nonneg(coast_min_sigmas)) return param_error("coast_min_sigmas", "must be >= 0");
  if (!nonneg(explain_distance)) return param_error("explain_distance", "must be >= 0");
  if (!nonneg(reacquire_distance)) return param_error("reacquire_distance", "must be >= 0");
  if (!pos(accel_noise)) return param_error("accel_noise", "must be positive");
  if (!pos(height_noise)) return param_error("height_noise", "must be positive");
  if (!pos(width_noise)) return param_error("width_noise", "must be positive");
  if (!pos(position_noise)) return param_error("position_noise", "must be positive");
  if (!pos(shape_measurement_noise)) return param_error("shape_measurement_noise", "must be positive");
  if (!pos(initial_velocity_sigma)) return param_error("initial_velocity_sigma", "must be positive");
  return Status::Ok();
}

// ---------------------------------------------------------------------------------------------

struct PlanViewTracker::Impl {
  struct Trk {
    int id = 0;
    Vec6 x = Vec6::Zero();  // x, y, vx, vy (map), height, width
    Mat6 P = Mat6::Identity();
    std::vector<float> tau_o, tau_h;
    double sum_o = 0, sum_h = 0, core_o = 0;  // sums of the templates; occupancy weighted by the core Gaussian
    int hits = 0, misses = 0, occluded = 0;
    bool confirmed = false;
    bool missed = false;   // this frame
    bool updated = false;  // this frame
    bool born = false;     // this frame
    bool hidden = false;   // this frame: missed while occluded (see occluded())
    bool coast_still = false;  // while coasting: held still (velocity not known to differ from zero)
    int64_t updated_frame = 0;  // frame count when last updated (measured, fully or in part)
    int64_t born_frame = 0;                             // frame count at birth
    Eigen::Vector2d born_at = Eigen::Vector2d::Zero();  // map position at birth
    int label = 0;         // this frame: blob under the predicted position (0: none)
    double score = std::numeric_limits<double>::quiet_NaN();
    double confidence = 0;
    std::array<double, 4> votes{};
    TrackClass cls = TrackClass::kUnknown;
    bool top_cut = false;  // at its last full measurement, its top reached the view's ceiling
  };

  const PlanViewGrid grid;
  const PlanViewTrackerParams p;
  const int T, half, pad;
  std::vector<float> gauss;  // T x T, core Gaussian centred on (half, half)
  cv::Mat occ, hgt, claim;   // padded copies (pad cells of zeros around the grid)
  cv::Rect copied;           // grid rect copied into occ/hgt last frame
  cv::Mat ceiling;           // this frame's PlanView::ceiling (empty: not known)
  std::vector<cv::Rect> claimed;  // padded rects written in `claim` this frame
  cv::Mat labels;            // connected blobs of the mask over view.active (CV_32S)
  cv::Point label_origin;
  std::vector<Blob> blobs;   // index = label
  std::vector<Trk> tracks;
  Eigen::Vector2d camera = Eigen::Vector2d::Zero();  // map frame
  double camera_height = 0;                          // m above the floor
  double smoothing = 0;  // cells
  int next_id = 1;
  int64_t frame = 0;  // frames tracked since creation or reset
  cv::Mat still_age;  // CV_16U per grid cell: frames running it has been a still residual
  cv::Rect still_rect;  // where still_age may be non-zero (the last labelled rectangle)
  bool have_stamp = false;
  int64_t last_stamp = 0;

  Impl(const PlanViewGrid& g, const PlanViewTrackerParams& prm)
      : grid(g),
        p(prm),
        T(prm.template_size),
        half(prm.template_size / 2),
        pad(prm.template_size / 2 + static_cast<int>(std::ceil(prm.search_max / g.cell)) + 4) {
    gauss.resize(static_cast<size_t>(T) * T);
    const double s = p.core_sigma / grid.cell;
    for (int r = 0; r < T; ++r)
      for (int k = 0; k < T; ++k) {
        const double d2 = (r - half) * (r - half) + (k - half) * (k - half);
        gauss[static_cast<size_t>(r) * T + k] = static_cast<float>(std::exp(-0.5 * d2 / (s * s)));
      }
    occ = cv::Mat::zeros(grid.rows + 2 * pad, grid.cols + 2 * pad, CV_32F);
    hgt = cv::Mat::zeros(occ.size(), CV_32F);
    claim = cv::Mat::zeros(occ.size(), CV_32F);
  }

  // Padded-map pointer of grid cell (col, row).
  const float* at(const cv::Mat& m, int col, int row) const { return m.ptr<float>(row + pad) + col + pad; }
  float* at(cv::Mat& m, int col, int row) { return m.ptr<float>(row + pad) + col + pad; }
  // Window of cells centred on (col, row) is safely inside the padded maps.
  bool window_ok(int col, int row) const {
    return col - half >= -pad && row - half >= -pad && col - half + T <= grid.cols + pad &&
           row - half + T <= grid.rows + pad;
  }

  void copy_maps(const PlanView& v) {
    if (!copied.empty()) {
      const cv::Rect r(copied.x + pad, copied.y + pad, copied.width, copied.height);
      occ(r).setTo(0);
      hgt(r).setTo(0);
    }
    copied = v.active & cv::Rect(0, 0, grid.cols, grid.rows);
    if (!copied.empty()) {
      const cv::Rect r(copied.x + pad, copied.y + pad, copied.width, copied.height);
      v.occupancy_smoothed(copied).copyTo(occ(r));
      v.height_masked(copied).copyTo(hgt(r));
    }
  }

  void find_blobs(const PlanView& v) {
    blobs.clear();
    label_origin = copied.tl();
    if (copied.empty()) {
      labels.release();
      return;
    }
    const int n = cv::connectedComponents(v.mask(copied), labels, 8, CV_32S);
    blobs = blob_moments(labels, copied.tl(), n);
    for (Blob& b : blobs) {
      if (b.mass > 0) {
        b.cx /= b.mass;
        b.cy /= b.mass;
      }
    }
  }

  // Distance (m) from cell position c to the nearest edge of the grid.
  double border_distance(const Eigen::Vector2d& c) const {
    const double cells = std::min({c.x() + 0.5, c.y() + 0.5, grid.cols - 0.5 - c.x(), grid.rows - 0.5 - c.y()});
    return std::max(0.0, cells) * grid.cell;
  }

  int label_at_cell(const Eigen::Vector2d& c) const {
    return label_at(static_cast<int>(std::lround(c.x())), static_cast<int>(std::lround(c.y())));
  }
  int label_at(int col, int row) const {
    if (labels.empty()) return 0;
    const int r = row - label_origin.y, k = col - label_origin.x;
    if (r < 0 || k < 0 || r >= labels.rows || k >= labels.cols) return 0;
    return labels.at<int>(r, k);
  }

  // Eq. 10.8 at window centre (col, row) for track t; `pred` = predicted cell position.
  // Every term is non-negative and the sums only grow row by row, so the score of the rows seen so
  // far is a lower bound of the full score: once it reaches `bound` the window cannot be the best
  // one and +inf is returned early (exact: the bound is combined in the same order as the score).
  double score_at(const Trk& t, int col, int row, const Eigen::Vector2d& pred, bool claims,
                  double bound = std::numeric_limits<double>::infinity()) const {
    const double dist = p.beta * std::hypot(col - pred.x(), row - pred.y()) * grid.cell;
    auto combine = [&](const float* ao, const float* ah, const float* ac) {
      double so = 0, sh = 0, sc = 0;
      for (int q = 0; q < kLanes; ++q) {
        so += ao[q];
        sh += ah[q];
        sc += ac[q];
      }
      double s = 0;
      if (p.w_height > 0) s += t.sum_h > 0 ? p.w_height * sh / t.sum_h : p.w_height;
      if (p.w_occupancy > 0) s += t.sum_o > 0 ? p.w_occupancy * so / t.sum_o : p.w_occupancy;
      s += dist;
      if (claims && t.core_o > 0) s += p.alpha * sc / t.core_o;
      return s;
    };
    float acc_o[kLanes] = {}, acc_h[kLanes] = {}, acc_c[kLanes] = {};
    if (combine(acc_o, acc_h, acc_c) >= bound) return std::numeric_limits<double>::infinity();
    const int x0 = col - half, y0 = row - half;
    const SadRows rows{at(occ, x0, y0), at(hgt, x0, y0), claims ? at(claim, x0, y0) : nullptr,
                       occ.step1(), t.tau_o.data(), t.tau_h.data(), gauss.data(), T};
    const SadRowsFn sad_rows = pick_sad_rows();
    constexpr int kChunk = 8;  // rows between bound checks
    for (int r = 0; r < T; r += kChunk) {
      sad_rows(rows, r, std::min(T, r + kChunk), acc_o, acc_h, acc_c);
      if (r + kChunk < T && combine(acc_o, acc_h, acc_c) >= bound) return std::numeric_limits<double>::infinity();
    }
    return combine(acc_o, acc_h, acc_c);
  }

  // Gaussian-weighted centre of mass of theta_sm near `c` (cells), a few mean-shift steps.
  Eigen::Vector2d centre_of_mass(Eigen::Vector2d c) const {
    const double s = p.core_sigma / grid.cell;
    const int rad = std::min(half, static_cast<int>(std::ceil(2.5 * s)));
    for (int it = 0; it < 4; ++it) {
      const int ci = static_cast<int>(std::lround(c.x())), cj = static_cast<int>(std::lround(c.y()));
      if (!window_ok(ci, cj)) break;
      double w = 0, wx = 0, wy = 0;
      for (int dj = -rad; dj <= rad; ++dj) {
        const float* o = at(occ, ci - rad, cj + dj);
        for (int di = -rad; di <= rad; ++di) {
          const double v = o[di + rad];
          if (v <= 0) continue;
          const double ex = ci + di - c.x(), ey = cj + dj - c.y();
          const double g = v * std::exp(-0.5 * (ex * ex + ey * ey) / (s * s));
          w += g;
          wx += g * (ci + di);
          wy += g * (cj + dj);
        }
      }
      if (w <= 0) break;
      const Eigen::Vector2d n(wx / w, wy / w);
      // Stay where a whole template window can be cut.
      if (!window_ok(static_cast<int>(std::lround(n.x())), static_cast<int>(std::lround(n.y())))) break;
      const bool done = (n - c).norm() < 0.05;
      c = n;
      if (done) break;
    }
    return c;
  }

  // Centre of mass of the blob at cell `c` (see blob_near) over its cells within a template window,
  // the window re-centred on the result a few times: the measured centre of an object whose blob
  // is its own. The Gaussian mean shift of centre_of_mass stops anywhere on a plateau, and stereo
  // at long range smears a person into a plateau along the line of sight, where a track would stay
  // on the part it was on (lagging a walking person by half a metre). The window bounds the pull
  // of whatever else the blob may hold. Not for bags (see measure_and_update). `c` itself when no
  // blob is there.
  Eigen::Vector2d blob_centre(Eigen::Vector2d c) const {
    const int label = blob_near(c);
    if (!label) return c;
    for (int it = 0; it < 3; ++it) {
      const int ci = static_cast<int>(std::lround(c.x())), cj = static_cast<int>(std::lround(c.y()));
      double w = 0, sx = 0, sy = 0;
      for (int dj = -half; dj < T - half; ++dj)
        for (int di = -half; di < T - half; ++di) {
          if (label_at(ci + di, cj + dj) != label) continue;
          const double v = *at(occ, ci + di, cj + dj);
          w += v;
          sx += v * (ci + di);
          sy += v * (cj + dj);
        }
      if (w <= 0) break;
      const Eigen::Vector2d n(sx / w, sy / w);
      if (!window_ok(static_cast<int>(std::lround(n.x())), static_cast<int>(std::lround(n.y())))) break;
      const bool done = (n - c).norm() < 0.5;
      c = n;
      if (done) break;
    }
    return c;
  }

  // Highest masked cell within height_radius of `c`.
  double height_near(const Eigen::Vector2d& c) const {
    const int rad = std::min(half, static_cast<int>(std::ceil(p.height_radius / grid.cell)));
    const int ci = static_cast<int>(std::lround(c.x())), cj = static_cast<int>(std::lround(c.y()));
    double best = 0;
    for (int dj = -rad; dj <= rad; ++dj) {
      if (cj + dj < -pad || cj + dj >= grid.rows + pad) continue;
      for (int di = -rad; di <= rad; ++di) {
        if (di * di + dj * dj > rad * rad || ci + di < -pad || ci + di >= grid.cols + pad) continue;
        best = std::max(best, static_cast<double>(*at(hgt, ci + di, cj + dj)));
      }
    }
    return best;
  }

  // Map-frame offset from the centre of mass of an object's visible surface (at map point m) to
  // its centre: away from the camera, at most half its width.
  Eigen::Vector2d surface_offset(const Eigen::Vector2d& m, double width) const {
    const double off = std::min(p.visible_surface_offset, 0.5 * std::max(0.0, width));
    const Eigen::Vector2d d = m - camera;
    const double n = d.norm();
    return n > 1e-9 && off > 0 ? Eigen::Vector2d(d / n * off) : Eigen::Vector2d::Zero();
  }
  // Cell where the track's templates are centred, from its state.
  Eigen::Vector2d template_cell(const Trk& t) const {
    const Eigen::Vector2d s = t.x.head<2>();
    const Eigen::Vector2d m = s - surface_offset(s, t.x(5));
    return grid.to_cell(m.x(), m.y());
  }

  // Label of the blob at cell `c`: the blob under it, or the strongest one within core_sigma
  // (0: none).
  int blob_near(const Eigen::Vector2d& c) const {
    const int ci = static_cast<int>(std::lround(c.x())), cj = static_cast<int>(std::lround(c.y()));
    int label = label_at(ci, cj);
    if (!label) {
      const int rad = static_cast<int>(std::ceil(p.core_sigma / grid.cell));
      double best = 0;
      for (int dj = -rad; dj <= rad; ++dj)
        for (int di = -rad; di <= rad; ++di) {
          const int l = label_at(ci + di, cj + dj);
          if (!l) continue;
          const double v = *at(occ, ci + di, cj + dj);
          if (v > best) {
            best = v;
            label = l;
          }
        }
    }
    return label;
  }

  // True when the blob `label` also lies under another live track's predicted position: a merged
  // blob of several objects (a robot passing by a bag, a person by another).
  bool shared_blob(const Trk& t, int label) const {
    if (!label) return false;
    for (const Trk& o : tracks)
      if (&o != &t && o.label == label) return true;
    return false;
  }

  // Width of the blob at `c`: the blob under the centre, or the strongest one near it; the
  // occupancy-weighted extent (see weighted_extent) of its cells within the template window.
  // Negative when no blob is there.
  double width_near(const Eigen::Vector2d& c) const {
    const int ci = static_cast<int>(std::lround(c.x())), cj = static_cast<int>(std::lround(c.y()));
    const int label = blob_near(c);
    if (!label) return -1;
    double w = 0, sx = 0, sy = 0, sxx = 0, sxy = 0, syy = 0;
    for (int dj = -half; dj < T - half; ++dj)
      for (int di = -half; di < T - half; ++di) {
        if (label_at(ci + di, cj + dj) != label) continue;
        const double v = *at(occ, ci + di, cj + dj), x = di, y = dj;
        w += v;
        sx += v * x;
        sy += v * y;
        sxx += v * x * x;
        sxy += v * x * y;
        syy += v * y * y;
      }
    if (w <= 0) return -1;
    return weighted_extent(w, sx, sy, sxx, sxy, syy, ci + sx / w, cj + sy / w);
  }

  // Extent (m) across the camera's line of sight of a weighted cell distribution centred on cell
  // (cx, cy): sqrt(12 variance), the smoothing's variance removed, plus one cell. Across, because
  // depth errors smear a blob along the line of sight, and that side is the one the camera sees.
  double weighted_extent(double w, double sx, double sy, double sxx, double sxy, double syy, double cx,
                         double cy) const {
    const double mx = sx / w, my = sy / w;
    const double a = sxx / w - mx * mx, b = sxy / w - mx * my, c = syy / w - my * my;
    Eigen::Vector2d d = grid.to_map(cx, cy) - camera;
    const double n = d.norm();
    double var;
    if (n > 1e-6) {
      d /= n;
      const Eigen::Vector2d q(-d.y(), d.x());  // across the line of sight
      var = a * q.x() * q.x() + 2 * b * q.x() * q.y() + c * q.y() * q.y();
    } else {
      var = 0.5 * (a + c) + std::sqrt(std::max(0.0, 0.25 * (a - c) * (a - c) + b * b));
    }
    return (std::sqrt(12.0 * std::max(0.0, var - smoothing * smoothing)) + 1.0) * grid.cell;
  }

  // Cuts the templates centred on cell `c` and blends them in at `rate`.
  void cut_templates(Trk& t, const Eigen::Vector2d& c, double rate) {
    const int ci = static_cast<int>(std::lround(c.x())), cj = static_cast<int>(std::lround(c.y()));
    const size_t n = static_cast<size_t>(T) * T;
    if (t.tau_o.size() != n) {
      t.tau_o.assign(n, 0.0f);
      t.tau_h.assign(n, 0.0f);
      rate = 1.0;
    }
    const float a = static_cast<float>(rate), b = static_cast<float>(1.0 - rate);
    double so = 0, sh = 0, sc = 0;
    for (int r = 0; r < T; ++r) {
      const float* mo = at(occ, ci - half, cj - half + r);
      const float* mh = at(hgt, ci - half, cj - half + r);
      float* to = t.tau_o.data() + static_cast<size_t>(r) * T;
      float* th = t.tau_h.data() + static_cast<size_t>(r) * T;
      const float* g = gauss.data() + static_cast<size_t>(r) * T;
      for (int k = 0; k < T; ++k) {
        to[k] = b * to[k] + a * mo[k];
        th[k] = b * th[k] + a * mh[k];
        so += to[k];
        sh += th[k];
        sc += to[k] * g[k];
      }
    }
    t.sum_o = so;
    t.sum_h = sh;
    t.core_o = sc;
  }

  // Mass, centre, tallest cell and second moments of each of the n labelled parts of `parts`
  // (label 0: none), whose cell (0, 0) is grid cell `origin`, weighted by this frame's occupancy.
  std::vector<Blob> blob_moments(const cv::Mat& parts, cv::Point origin, int n) const {
    std::vector<Blob> out(std::max(n, 1));
    for (int r = 0; r < parts.rows; ++r) {
      const int* l = parts.ptr<int>(r);
      const int row = r + origin.y;
      const float* o = at(occ, origin.x, row);
      const float* h = at(hgt, origin.x, row);
      for (int k = 0; k < parts.cols; ++k) {
        if (!l[k]) continue;
        Blob& b = out[l[k]];
        const double col = k + origin.x;
        b.mass += o[k];
        b.cx += o[k] * col;
        b.cy += o[k] * row;
        b.max_height = std::max(b.max_height, static_cast<double>(h[k]));
        b.sxx += o[k] * col * col;
        b.sxy += o[k] * col * row;
        b.syy += o[k] * static_cast<double>(row) * row;
        if (row == 0 || row == grid.rows - 1 || col == 0 || col == grid.cols - 1) b.on_border = true;
      }
    }
    return out;
  }

  // Adds the occupancy near the object at cell `c` to the claims of this frame.
  void add_claim(const Eigen::Vector2d& c) {
    const int ci = static_cast<int>(std::lround(c.x())), cj = static_cast<int>(std::lround(c.y()));
    if (!window_ok(ci, cj)) return;
    for (int r = 0; r < T; ++r) {
      const float* o = at(occ, ci - half, cj - half + r);
      float* cl = at(claim, ci - half, cj - half + r);
      const float* g = gauss.data() + static_cast<size_t>(r) * T;
      for (int k = 0; k < T; ++k) cl[k] += o[k] * g[k];
    }
    claimed.emplace_back(ci - half + pad, cj - half + pad, T, T);
  }

  void clear_claims() {
    for (const cv::Rect& r : claimed) claim(r).setTo(0);
    claimed.clear();
  }

  void predict(Trk& t, double dt) {
    if (dt <= 0) return;
    Mat6 F = Mat6::Identity();
    F(0, 2) = F(1, 3) = dt;
    const double q = p.accel_noise * p.accel_noise;
    Mat6 Q = Mat6::Zero();
    for (int a = 0; a < 2; ++a) {
      Q(a, a) = q * dt * dt * dt * dt / 4;
      Q(a, a + 2) = Q(a + 2, a) = q * dt * dt * dt / 2;
      Q(a + 2, a + 2) = q * dt * dt;
    }
    Q(4, 4) = p.height_noise * p.height_noise * dt;
    Q(5, 5) = p.width_noise * p.width_noise * dt;
    t.x = F * t.x;
    t.P = F * t.P * F.transpose() + Q;
  }

  // Position-only update (a partly hidden object: its shape is not measured); false when the
  // measurement fails the gate.
  bool correct_position(Trk& t, const Eigen::Vector2d& z, double sigma) {
    Eigen::Matrix<double, 2, 6> H = Eigen::Matrix<double, 2, 6>::Zero();
    H(0, 0) = H(1, 1) = 1;
    const Eigen::Matrix2d R = Eigen::Matrix2d::Identity() * sigma * sigma;
    const Eigen::Vector2d y = z - H * t.x;
    const Eigen::Matrix2d S = H * t.P * H.transpose() + R;
    if (p.gate > 0 && y.dot(S.inverse() * y) > p.gate) return false;
    const Eigen::Matrix<double, 6, 2> K = t.P * H.transpose() * S.inverse();
    t.x += K * y;
    const Mat6 I_KH = Mat6::Identity() - K * H;
    t.P = I_KH * t.P * I_KH.transpose() + K * R * K.transpose();
    return true;
  }

  // Gate on the measured position and height: Mahalanobis distance of the innovation.
  bool passes_gate(const Trk& t, const Vec4& z) const {
    if (p.gate <= 0) return true;
    Eigen::Matrix<double, 3, 6> H = Eigen::Matrix<double, 3, 6>::Zero();
    H(0, 0) = H(1, 1) = H(2, 4) = 1;
    Eigen::Matrix3d R = Eigen::Matrix3d::Zero();
    R(0, 0) = R(1, 1) = p.position_noise * p.position_noise;
    R(2, 2) = p.shape_measurement_noise * p.shape_measurement_noise;
    const Eigen::Vector3d y = z.head<3>() - H * t.x;
    const Eigen::Matrix3d S = H * t.P * H.transpose() + R;
    return y.dot(S.inverse() * y) <= p.gate;
  }

  void correct(Trk& t, const Vec4& z) {
    Mat46 H = Mat46::Zero();
    H(0, 0) = H(1, 1) = H(2, 4) = H(3, 5) = 1;
    Mat4 R = Mat4::Zero();
    R(0, 0) = R(1, 1) = p.position_noise * p.position_noise;
    R(2, 2) = R(3, 3) = p.shape_measurement_noise * p.shape_measurement_noise;
    const Vec4 y = z - H * t.x;
    const Mat4 S = H * t.P * H.transpose() + R;
    const Eigen::Matrix<double, 6, 4> K = t.P * H.transpose() * S.inverse();
    t.x += K * y;
    const Mat6 I_KH = Mat6::Identity() - K * H;
    t.P = I_KH * t.P * I_KH.transpose() + K * R * K.transpose();  // Joseph form: stays symmetric
  }

  void vote(Trk& t) {
    const TrackClass c = classify_track(t.x(4), t.x(5), p.classes);
    for (double& v : t.votes) v *= p.class_vote_decay;
    t.votes[static_cast<int>(c)] += 1.0;
    int best = 0;
    for (int k = 1; k < 4; ++k)
      if (t.votes[k] > t.votes[best]) best = k;
    t.cls = static_cast<TrackClass>(best);
  }

  // True when a top at `height` (m) measured around cell `c` reaches the camera's view ceiling
  // there (within top_cut_margin): the image's top edge cuts the object.
  bool reaches_ceiling(const Eigen::Vector2d& c, double height) const {
    if (ceiling.empty() || p.top_cut_margin < 0) return false;
    const int col = std::clamp(static_cast<int>(std::lround(c.x())), 0, ceiling.cols - 1);
    const int row = std::clamp(static_cast<int>(std::lround(c.y())), 0, ceiling.rows - 1);
    return height >= ceiling.at<float>(row, col) - p.top_cut_margin;
  }

  // Measures the object at cell `c` (centre of mass, height, width) and updates the track.
  // False (and nothing changed) when the measurement fails the gate.
  // On a blob shared with another track (see shared_blob) only the position is measured: the
  // blob's extent and its highest point near the centre may be the other object's, and would
  // drag the shape (and so the class) and the templates.
  bool measure_and_update(Trk& t, const Eigen::Vector2d& start, double rate, bool gated) {
    Eigen::Vector2d c = centre_of_mass(start);
    const bool shared = shared_blob(t, blob_near(c));
    // A bag on a blob shared with someone (put down beside them): the merged blob's centre of
    // mass is pulled to the person's bulk; the templates' best match is the bag's own place.
    if (shared && t.cls == TrackClass::kBag) c = start;
    // A bag does not walk, so it has no lag to catch up with, and the blob under a bag grows
    // mostly by merging with someone next to it (a person picking it up whose track is not on
    // the blob yet, a robot passing): a bag keeps the local centre.
    if (p.measure_blob_centre && !shared && t.cls != TrackClass::kBag) c = blob_centre(c);
    const Eigen::Vector2d m = grid.to_map(c.x(), c.y());
    double w = shared ? -1 : width_near(c);
    if (w < 0) w = t.x(5);
    const Eigen::Vector2d centre = m + surface_offset(m, w);
    const Vec4 z(centre.x(), centre.y(), shared ? t.x(4) : height_near(c), w);
    if (gated && t.confirmed && !passes_gate(t, z)) return false;
    if (shared) {
      if (!correct_position(t, centre, p.position_noise)) return false;
    } else {
      correct(t, z);
      cut_templates(t, c, rate);
      t.top_cut = reaches_ceiling(c, z(2));
    }
    add_claim(c);
    t.updated = true;
    t.updated_frame = frame;
    t.missed = false;
    ++t.hits;
    t.misses = 0;
    t.occluded = 0;
    if (t.hits >= p.min_hits) t.confirmed = true;
    vote(t);
    return true;
  }

  void match(Trk& t) {
    const Eigen::Vector2d pred = template_cell(t);
    const int pc = static_cast<int>(std::lround(pred.x())), pr = static_cast<int>(std::lround(pred.y()));
    const double sigma = std::sqrt(std::max(t.P(0, 0), t.P(1, 1)));
    const double radius = std::clamp(p.search_sigmas * sigma, p.search_min, p.search_max);
    const int rc = std::max(1, static_cast<int>(std::ceil(radius / grid.cell)));
    const int step = rc > 6 ? 2 : 1;
    const bool claims = !claimed.empty() && p.alpha > 0;
    double best = std::numeric_limits<double>::infinity();
    int bc = pc, br = pr;
    // When the predicted window is one of the candidates, its score bounds the search from the
    // start: a window scoring above it cannot win, and one equal to it is still scored in full
    // (the first minimum in raster order wins, as without the bound).
    const bool pred_in_scan = rc % step == 0 && window_ok(pc, pr);
    const bool prune = !exhaustive_flag();
    const double seed = pred_in_scan && prune ? score_at(t, pc, pr, pred, claims) : best;
    auto consider = [&](int c, int r) {
      if (!window_ok(c, r)) return;
      const double bound =
          prune ? std::min(best, std::nextafter(seed, std::numeric_limits<double>::infinity())) : std::numeric_limits<double>::infinity();
      const double s = score_at(t, c, r, pred, claims, bound);
      if (s < best) {
        best = s;
        bc = c;
        br = r;
      }
    };
    for (int dr = -rc; dr <= rc; dr += step)
      for (int dc = -rc; dc <= rc; dc += step)
        if (dc * dc + dr * dr <= rc * rc + 1) consider(pc + dc, pr + dr);
    if (step > 1) {
      const int c0 = bc, r0 = br;
      for (int dr = -step; dr <= step; ++dr)
        for (int dc = -step; dc <= step; ++dc)
          if (dc || dr) consider(c0 + dc, r0 + dr);
    }
    t.score = best;
    // An occluded object whose templates match only in part is measured loosely, position only:
    // the visible part's shape would drag its shape and templates.
    const bool partial = best >= p.occluded_match * p.track_threshold && t.confirmed && occluded(t);
    bool ok = false;
    if (best < p.track_threshold && !partial) {
      ok = measure_and_update(t, Eigen::Vector2d(bc, br), p.template_rate, true);
      if (ok) t.confidence = std::clamp(1.0 - 0.5 * best / p.track_threshold, 0.0, 1.0);
    } else if (best < p.track_threshold) {
      const Eigen::Vector2d c = centre_of_mass(Eigen::Vector2d(bc, br));
      const Eigen::Vector2d m = grid.to_map(c.x(), c.y());
      ok = correct_position(t, m + surface_offset(m, t.x(5)), p.occluded_position_noise);
      if (ok) {
        add_claim(c);
        t.updated = true;
        t.updated_frame = frame;
        t.missed = false;
        t.misses = 0;
        t.confidence = 0.5 * std::clamp(1.0 - 0.5 * best / p.track_threshold, 0.0, 1.0);
      }
    }
    if (!ok) {
      t.missed = true;  // missing or occluded: decided once every track is matched
      t.confidence *= 0.8;
    }
  }

  // True when a track seen this frame stands between the camera and t, across its line of sight,
  // and tall enough to hide at least half of t's height (a bag in front of a person does not).
  bool occluded(const Trk& t) const {
    const Eigen::Vector2d s = t.x.head<2>() - camera;
    const double range = s.norm();
    if (range < 1e-6) return false;
    const Eigen::Vector2d u = s / range;
    for (const Trk& o : tracks) {
      // Occluders: confirmed tracks matched this frame, or matched last frame and not yet processed.
      if (&o == &t || !o.confirmed || o.missed || o.misses > 0 || o.occluded > 0) continue;
      // Born beside t moments ago: t's own object found again by a second track (its blob moved
      // or split beyond t's reach), not another object in front of it.
      if (p.split_window > 0 && o.born_frame > t.born_frame && frame - o.born_frame <= p.split_window &&
          (o.born_at - t.x.head<2>()).norm() < p.reacquire_max)
        continue;
      const Eigen::Vector2d q = o.x.head<2>() - camera;
      const double along = q.dot(u);
      const double across = std::abs(q.x() * u.y() - q.y() * u.x());
      if (!(along > 0.05 && along < range - 0.1 && across < 0.5 * (o.x(5) + t.x(5)) + 0.1)) continue;
      // Height on t up to which the line from the camera over o's top is blocked.
      const double hidden = camera_height + (o.x(4) - camera_height) * range / along;
      if (hidden >= 0.5 * t.x(4)) return true;
    }
    return false;
  }

  // True when t is a bag whose predicted place is still on a blob: something stands there (the
  // bag, in one blob with its owner who turns and starts off beside it, smeared together in
  // depth), only the bag's templates did not match. A bag does not walk; one picked up leaves its
  // place empty once its carrier is off.
  bool merged(const Trk& t) const { return p.hold_bag_on_blob && t.cls == TrackClass::kBag && t.label > 0; }

  // True when a track updated this frame stands in front of map point m (an object of width w),
  // 0.25 m to birth_shadow_depth nearer the camera, overlapping it in the image.
  bool in_shadow_of_track(const Eigen::Vector2d& m, double w) const {
    if (p.birth_shadow_depth <= 0) return false;
    const Eigen::Vector2d s = m - camera;
    const double range = s.norm();
    if (range < 1e-6) return false;
    const Eigen::Vector2d u = s / range;
    for (const Trk& o : tracks) {
      if (!o.updated || !o.confirmed) continue;
      const Eigen::Vector2d q = o.x.head<2>() - camera;
      const double along = q.dot(u);
      const double across = std::abs(q.x() * u.y() - q.y() * u.x());
      // Behind it (side by side is the blobs' business), and close enough to be smeared together.
      if (along > 0.05 && range - along > 0.25 && range - along < p.birth_shadow_depth &&
          across < 0.5 * (o.x(5) + w) + 0.1)
        return true;
    }
    return false;
  }

  void count_misses(double dt) {
    const double decay = p.coast_velocity_decay > 0 ? std::exp(-dt / p.coast_velocity_decay) : 1.0;
    for (Trk& t : tracks) {
      if (!t.missed || t.updated) continue;
      // Coasting: a slow track, or a bag (bags do not walk), is held still: its apparent motion
      // is mostly a transient of blobs merging, splitting or being hidden; a person or a robot
      // keeps its velocity, optionally decaying. So is a track whose velocity, when it was last
      // measured, was not known to differ from zero (under coast_min_sigmas standard deviations
      // along itself): a track measured for a few frames only has a velocity of blob transients.
      if (t.updated_frame == frame - 1) {  // the first miss since it was last measured
        const Eigen::Vector2d v = t.x.segment<2>(2);
        const double speed2 = v.squaredNorm();
        const double var = speed2 > 0 ? v.dot(t.P.block<2, 2>(2, 2) * v) / speed2 : 0.0;
        t.coast_still = p.coast_min_sigmas > 0 && speed2 < p.coast_min_sigmas * p.coast_min_sigmas * var;
      }
      if (t.coast_still || t.x.segment<2>(2).norm() < p.coast_hold_speed || t.cls == TrackClass::kBag)
        t.x.segment<2>(2).setZero();
      t.x(2) *= decay;
      t.x(3) *= decay;
      // Lost in the open (a miss not occluded): missing until matched again, whatever passes.
      // A bag (which does not walk) may still find its occluder within report_missed frames of
      // its first miss: someone who steps in front of it as a new track (their old one lost
      // behind something, or just arrived) is confirmed only min_hits frames after it hides it.
      const bool may_hide = t.misses == 0 || (t.cls == TrackClass::kBag && t.misses <= p.report_missed);
      t.hidden = t.confirmed && may_hide && (occluded(t) || merged(t));
      if (t.hidden)
        ++t.occluded;
      else
        ++t.misses;
    }
  }

  void births() {
    const double cell2 = grid.cell * grid.cell;
    for (size_t k = 1; k < blobs.size(); ++k) {
      const Blob& b = blobs[k];
      if (b.mass * cell2 < p.birth_min_area || b.max_height < p.birth_min_height) continue;
      const Eigen::Vector2d bc(b.cx, b.cy);
      const Eigen::Vector2d bm_surface = grid.to_map(b.cx, b.cy);
      const double bw = weighted_extent(b.mass, b.cx * b.mass, b.cy * b.mass, b.sxx, b.sxy, b.syy, b.cx, b.cy);
      const Eigen::Vector2d bm = bm_surface + surface_offset(bm_surface, bw);
      bool explained = false;
      for (const Trk& t : tracks) {
        if (!t.updated) continue;
        const Eigen::Vector2d tc = template_cell(t);
        if ((t.x.head<2>() - bm).norm() < p.explain_distance ||
            label_at(static_cast<int>(std::lround(tc.x())), static_cast<int>(std::lround(tc.y()))) ==
                static_cast<int>(k)) {
          explained = true;
          break;
        }
      }
      if (explained) continue;
      // A coasting track near it takes it back.
      Trk* nearest = nullptr;
      double nd = std::numeric_limits<double>::infinity();
      for (Trk& t : tracks) {
        if (t.updated) continue;
        const double d = (t.x.head<2>() - bm).norm();
        // The reach grows with the prediction's uncertainty while the track coasts.
        const double reach = std::max(p.reacquire_distance,
                                      std::min(p.reacquire_max, 3.0 * std::sqrt(std::max(t.P(0, 0), t.P(1, 1)))));
        if (d < reach && d < nd) {
          nd = d;
          nearest = &t;
        }
      }
      if (nearest && nearest->confirmed && occluded(*nearest)) continue;  // the visible part of a hidden object
      if (nearest) {
        nearest->tau_o.clear();  // shape changed beyond the templates: cut them afresh
        measure_and_update(*nearest, bc, 1.0, false);
        nearest->confidence = 0.5;
        continue;
      }
      if (b.on_border && border_distance(bc) < p.birth_border_margin) continue;  // partly outside: not yet
      if (in_shadow_of_track(bm, bw)) continue;  // mixed with the object just in front: not yet
      add_track(bm, bc, b.max_height, bw);
    }
  }

  // A new tentative track at map point bm (templates cut around cell bc).
  void add_track(const Eigen::Vector2d& bm, const Eigen::Vector2d& bc, double height, double width) {
    {
      Trk t;
      t.id = next_id++;
      t.x << bm.x(), bm.y(), 0, 0, height, width;
      const double pv = p.position_noise * p.position_noise, vv = p.initial_velocity_sigma * p.initial_velocity_sigma,
                   sv = p.shape_measurement_noise * p.shape_measurement_noise;
      t.P = Vec6(pv, pv, vv, vv, sv, sv).asDiagonal();
      cut_templates(t, bc, 1.0);
      add_claim(bc);
      t.hits = 1;
      t.confirmed = p.min_hits <= 1;
      t.updated = true;
      t.updated_frame = frame;
      t.born = true;
      t.born_frame = frame;
      t.born_at = bm;
      t.confidence = 0.5;
      vote(t);
      tracks.push_back(std::move(t));
    }
  }

  // Still residuals (see the header comment): the cells of a blob a track explains that lie
  // farther than split_radius across the line of sight from every track seen on it this frame,
  // counted frame by frame while they stay occupied; a connected set of them occupied for
  // split_still_frames frames running, large and tall enough for a birth, with no track near it,
  // becomes a track of its own.
  void still_residual_births() {
    if (p.split_still_frames <= 0) return;
    if (still_age.empty()) still_age = cv::Mat::zeros(grid.rows, grid.cols, CV_16U);
    // Residual cells lie in blobs, so inside this frame's labelled rectangle: ages elsewhere (in
    // last frame's rectangle) drop to zero, and the work stays within the rectangle.
    const cv::Rect roi = labels.empty() ? cv::Rect() : cv::Rect(label_origin.x, label_origin.y, labels.cols, labels.rows);
    if (!still_rect.empty()) {
      if (roi.empty()) {
        still_age(still_rect).setTo(0);
      } else {
        const cv::Mat keep = still_age(roi).clone();
        still_age(still_rect).setTo(0);
        keep.copyTo(still_age(roi));
      }
    }
    still_rect = roi;
    if (roi.empty()) return;
    std::vector<std::vector<const Trk*>> on(blobs.size());
    for (const Trk& t : tracks) {
      if (!t.updated || t.born) continue;
      const int l = label_at_cell(template_cell(t));
      if (l > 0 && static_cast<size_t>(l) < on.size()) on[l].push_back(&t);
    }
    // Ages: frames running each cell has been a residual.
    cv::Mat age = still_age(roi);
    for (int r = 0; r < labels.rows; ++r) {
      const int* l = labels.ptr<int>(r);
      uint16_t* a = age.ptr<uint16_t>(r);
      for (int k = 0; k < labels.cols; ++k) {
        bool far = l[k] && !on[l[k]].empty();
        if (far) {
          const Eigen::Vector2d m = grid.to_map(k + roi.x, r + roi.y);
          for (const Trk* t : on[l[k]]) {
            // Across the line of sight only: stereo smears an object along it.
            const Eigen::Vector2d c = t->x.head<2>() - surface_offset(t->x.head<2>(), t->x(5));
            const Eigen::Vector2d u = (c - camera).normalized(), d = m - c;
            if (std::abs(d.x() * u.y() - d.y() * u.x()) <= p.split_radius) {
              far = false;
              break;
            }
          }
        }
        a[k] = far ? static_cast<uint16_t>(std::min(a[k] + 1, 60000)) : 0;
      }
    }
    // Only cells below a bag's top now: a standing person's body smeared by stereo past
    // split_radius is as still as the bag beside her and, counted with it, joined the bag's cells
    // to a residual as tall as a person, which was never born.
    cv::Mat still = age >= p.split_still_frames, parts;
    {
      cv::Mat low;
      cv::compare(hgt(cv::Rect(roi.x + pad, roi.y + pad, roi.width, roi.height)), p.classes.bag_max_height, low, cv::CMP_LT);
      still &= low;
    }
    const int n = cv::connectedComponents(still, parts, 8, CV_32S);
    if (n <= 1) return;
    std::vector<Blob> pb = blob_moments(parts, roi.tl(), n);
    const double cell2 = grid.cell * grid.cell;
    for (int k = 1; k < n; ++k) {
      Blob& b = pb[k];
      // Things put down only: a residual as tall as a bag's top or taller is a part of someone.
      if (b.mass * cell2 < p.birth_min_area || b.max_height < p.birth_min_height ||
          b.max_height >= p.classes.bag_max_height)
        continue;
      const double sx = b.cx, sy = b.cy;
      b.cx /= b.mass;
      b.cy /= b.mass;
      const Eigen::Vector2d bc(b.cx, b.cy);
      const Eigen::Vector2d surface = grid.to_map(b.cx, b.cy);
      const double bw = weighted_extent(b.mass, sx, sy, b.sxx, b.sxy, b.syy, b.cx, b.cy);
      const Eigen::Vector2d bm = surface + surface_offset(surface, bw);
      bool near = false;
      for (const Trk& t : tracks) near = near || (t.x.head<2>() - bm).norm() < p.explain_distance;
      if (near || in_shadow_of_track(bm, bw) || border_distance(bc) < p.birth_border_margin) continue;
      add_track(bm, bc, b.max_height, bw);
    }
  }
};

// ---------------------------------------------------------------------------------------------

PlanViewTracker::PlanViewTracker(const PlanViewGrid& grid, const PlanViewTrackerParams& params)
    : grid_(grid), params_(params), impl_(std::make_unique<Impl>(grid, params)) {}
PlanViewTracker::PlanViewTracker(PlanViewTracker&&) noexcept = default;
PlanViewTracker& PlanViewTracker::operator=(PlanViewTracker&&) noexcept = default;
PlanViewTracker::~PlanViewTracker() = default;

Result<PlanViewTracker> PlanViewTracker::create(const PlanViewGrid& grid, const PlanViewTrackerParams& params) {
  if (Status s = params.validate(); !s) return s;
  if (grid.cols <= 0 || grid.rows <= 0 || !(grid.cell > 0))
    return param_error("grid", "an empty plan-view grid (" + grid_str(grid) + ")");
  return PlanViewTracker(grid, params);
}

void PlanViewTracker::reset() {
  impl_->tracks.clear();
  impl_->still_age.release();
  impl_->still_rect = cv::Rect();
  impl_->frame = 0;
}

int PlanViewTracker::live_tracks() const { return static_cast<int>(impl_->tracks.size()); }

std::vector<std::pair<int, double>> PlanViewTracker::last_scores() const {
  std::vector<std::pair<int, double>> out;
  for (const auto& t : impl_->tracks)
    out.emplace_back(t.id, t.born ? std::numeric_limits<double>::quiet_NaN() : t.score);
  return out;
}

Result<std::vector<Track>> PlanViewTracker::update(const PlanView& view, int64_t stamp_ns) {
  Impl& m = *impl_;
  if (!(view.grid == grid_) || view.occupancy_smoothed.rows != grid_.rows ||
      view.occupancy_smoothed.cols != grid_.cols || view.height_masked.size() != view.occupancy_smoothed.size() ||
      view.mask.size() != view.occupancy_smoothed.size() || view.occupancy_smoothed.type() != CV_32F ||
      view.height_masked.type() != CV_32F || view.mask.type() != CV_8U) {
    return bad_input("", 0, "plan_view",
                     "plan view of " + grid_str(view.grid) + " (maps " + std::to_string(view.occupancy_smoothed.cols) +
                         "x" + std::to_string(view.occupancy_smoothed.rows) + "), but the tracker is for " +
                         grid_str(grid_));
  }
  if (m.have_stamp && stamp_ns <= m.last_stamp) {
    return bad_input("", 0, "stamp_ns",
                     "frame stamped " + std::to_string(stamp_ns) + " ns is not after the previous frame (" +
                         std::to_string(m.last_stamp) + " ns): frames must come in increasing time order");
  }
  const double dt = m.have_stamp ? (stamp_ns - m.last_stamp) * 1e-9 : 0.0;
  m.have_stamp = true;
  ++m.frame;
  m.last_stamp = stamp_ns;

  m.camera = view.camera_xy;
  m.camera_height = view.camera_height;
  m.smoothing = view.smoothing;
  m.copy_maps(view);
  m.ceiling = view.ceiling.size() == view.occupancy_smoothed.size() && view.ceiling.type() == CV_32F ? view.ceiling
                                                                                                     : cv::Mat();
  m.find_blobs(view);
  m.clear_claims();

  // Predict; tracks whose prediction left the grid are gone.
  for (auto& t : m.tracks) {
    m.predict(t, dt);
    t.updated = t.born = t.missed = t.hidden = false;
  }
  std::erase_if(m.tracks, [&](const Impl::Trk& t) { return !grid_.contains(t.x(0), t.x(1)); });
  for (auto& t : m.tracks) t.label = m.label_at_cell(m.template_cell(t));

  // Correspondence, oldest and surest first.
  std::vector<size_t> order(m.tracks.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    const auto &ta = m.tracks[a], &tb = m.tracks[b];
    if (ta.confirmed != tb.confirmed) return ta.confirmed;
    if (ta.hits != tb.hits) return ta.hits > tb.hits;
    return ta.id < tb.id;
  });
  for (size_t i : order) m.match(m.tracks[i]);

  m.births();
  m.still_residual_births();
  m.count_misses(dt);
  std::erase_if(m.tracks, [&](const Impl::Trk& t) {
    return (!t.confirmed && t.misses > 0) || t.misses >= params_.max_missed ||
           t.occluded > (t.cls == TrackClass::kBag ? params_.max_occluded_bag : params_.max_occluded);
  });

  std::vector<Track> out;
  for (const auto& t : m.tracks) {
    // A missing track's position soon goes stale: reported for report_missed frames only.
    if (!t.confirmed || (t.missed && !t.hidden && t.misses > params_.report_missed)) continue;
    Track r;
    r.stamp_ns = stamp_ns;
    r.camera = params_.camera;
    r.id = t.id;
    r.cls = t.cls;
    r.x = t.x(0);
    r.y = t.x(1);
    r.vx = t.x(2);
    r.vy = t.x(3);
    r.height = t.x(4);
    r.width = t.x(5);
    r.confidence = t.confidence;
    r.measured = !t.missed;
    r.top_cut = t.top_cut;
    out.push_back(std::move(r));
  }
  std::sort(out.begin(), out.end(), [](const Track& a, const Track& b) { return a.id < b.id; });
  return out;
}

// ---------------------------------------------------------------------------------------------

Result<PlanViewPipeline> PlanViewPipeline::create(const StereoCameraModel& camera, const PlanViewParams& plan,
                                                  const PlanViewTrackerParams& tracking) {
  auto b = PlanViewBuilder::create(camera, plan);
  if (!b) return b.error();
  auto t = PlanViewTracker::create(b->grid(), tracking);
  if (!t) return t.error();
  return PlanViewPipeline(std::move(*b), std::move(*t));
}

Result<std::vector<Track>> PlanViewPipeline::process(const cv::Mat& foreground, const cv::Mat& depth,
                                                     int64_t stamp_ns) {
  if (Status s = builder_.build(foreground, depth, &view_); !s) return s;
  return tracker_.update(view_, stamp_ns);
}

// ---------------------------------------------------------------------------------------------

cv::Point2d plan_view_pixel(const PlanViewGrid& grid, double x, double y, int scale) {
  const Eigen::Vector2d c = grid.to_cell(x, y);
  return {(c.x() + 0.5) * scale, (grid.rows - 0.5 - c.y()) * scale};
}

namespace {

cv::Scalar class_colour(TrackClass c) {
  switch (c) {
    case TrackClass::kPerson: return {80, 220, 80};
    case TrackClass::kBag: return {0, 200, 255};
    case TrackClass::kRobot: return {255, 200, 0};
    case TrackClass::kUnknown: break;
  }
  return {200, 200, 200};
}

// Colour image of a map scaled to [0, vmax], empty cells black, +y up.
cv::Mat colourise(const cv::Mat& map, double vmax, int scale) {
  cv::Mat u8;
  map.convertTo(u8, CV_8U, vmax > 0 ? 255.0 / vmax : 0.0);
  cv::Mat colour;
  cv::applyColorMap(u8, colour, cv::COLORMAP_TURBO);
  colour.setTo(cv::Scalar::all(0), map <= 0);
  cv::flip(colour, colour, 0);
  if (scale > 1) cv::resize(colour, colour, cv::Size(), scale, scale, cv::INTER_NEAREST);
  return colour;
}

void overlay(cv::Mat& img, const PlanView& v, const std::vector<Track>& tracks, const PlanViewDrawOptions& o) {
  const int s = std::max(1, o.scale);
  if (o.draw_camera && v.grid.contains(v.camera_xy.x(), v.camera_xy.y())) {
    const cv::Point2d c = plan_view_pixel(v.grid, v.camera_xy.x(), v.camera_xy.y(), s);
    cv::drawMarker(img, c, {255, 255, 255}, cv::MARKER_TRIANGLE_UP, 12, 2);
  }
  if (!o.draw_tracks) return;
  for (const Track& t : tracks) {
    const cv::Scalar col = class_colour(t.cls);
    const cv::Point2d c = plan_view_pixel(v.grid, t.x, t.y, s);
    const int r = std::max(4, static_cast<int>(std::lround(std::max(t.width, 0.3) / 2 / v.grid.cell * s)));
    cv::circle(img, c, r, col, 2, cv::LINE_AA);
    const cv::Point2d e = plan_view_pixel(v.grid, t.x + t.vx, t.y + t.vy, s);
    cv::arrowedLine(img, c, e, col, 1, cv::LINE_AA, 0, 0.2);
    char label[64];
    std::snprintf(label, sizeof label, "%d %s %.2fm", t.id, std::string(to_string(t.cls)).c_str(), t.height);
    cv::putText(img, label, c + cv::Point2d(r + 2, -r), cv::FONT_HERSHEY_SIMPLEX, 0.4, col, 1, cv::LINE_AA);
  }
}

}  // namespace

cv::Mat draw_occupancy_map(const PlanView& v, const std::vector<Track>& tracks, const PlanViewDrawOptions& o) {
  if (v.occupancy_smoothed.empty()) return {};
  double vmax = o.occupancy_max;
  if (vmax <= 0) {
    // The 99th percentile of the non-empty cells, so one dense cell does not darken the rest.
    std::vector<float> vals;
    if (!v.active.empty()) {
      const cv::Mat roi = v.occupancy_smoothed(v.active);
      for (int r = 0; r < roi.rows; ++r) {
        const float* p = roi.ptr<float>(r);
        for (int k = 0; k < roi.cols; ++k)
          if (p[k] > 0) vals.push_back(p[k]);
      }
    }
    if (!vals.empty()) {
      const size_t i = std::min(vals.size() - 1, static_cast<size_t>(0.99 * vals.size()));
      std::nth_element(vals.begin(), vals.begin() + i, vals.end());
      vmax = vals[i];
    }
    if (vmax <= 0) vmax = 1;
  }
  cv::Mat img = colourise(v.occupancy_smoothed, vmax, std::max(1, o.scale));
  overlay(img, v, tracks, o);
  return img;
}

cv::Mat draw_height_map(const PlanView& v, const std::vector<Track>& tracks, const PlanViewDrawOptions& o) {
  if (v.height_masked.empty()) return {};
  cv::Mat img = colourise(v.height_masked, o.height_max, std::max(1, o.scale));
  overlay(img, v, tracks, o);
  return img;
}

cv::Mat draw_plan_view(const PlanView& v, const std::vector<Track>& tracks, const PlanViewDrawOptions& o) {
  const cv::Mat a = draw_occupancy_map(v, tracks, o), b = draw_height_map(v, tracks, o);
  if (a.empty() || b.empty()) return {};
  constexpr int kBar = 18, kGap = 4;
  cv::Mat out(a.rows + kBar, a.cols + kGap + b.cols, CV_8UC3, cv::Scalar::all(40));
  a.copyTo(out(cv::Rect(0, kBar, a.cols, a.rows)));
  b.copyTo(out(cv::Rect(a.cols + kGap, kBar, b.cols, b.rows)));
  cv::putText(out, "occupancy", {4, 13}, cv::FONT_HERSHEY_SIMPLEX, 0.45, {255, 255, 255}, 1, cv::LINE_AA);
  cv::putText(out, "height", {a.cols + kGap + 4, 13}, cv::FONT_HERSHEY_SIMPLEX, 0.45, {255, 255, 255}, 1, cv::LINE_AA);
  return out;
}

namespace detail {
void planview_tracker_exhaustive_search(bool exhaustive) { exhaustive_flag() = exhaustive; }
}  // namespace detail

}  // namespace vigil::vision
