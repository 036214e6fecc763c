#include "vision/floor_fit.h"

#include <algorithm>
#include <cmath>
#include <string>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include "common/rng.h"

namespace vigil::vision {

namespace {

struct Plane {
  Eigen::Vector3d n = Eigen::Vector3d(0, -1, 0);  // unit, pointing up (n.y < 0 in the optical frame)
  double d = 0;                                    // n . p + d = 0; d is the camera's height
};

double band(const FloorFitParams& p, double z) { return p.inlier_distance + p.inlier_growth * z * z; }

// Orients a plane so its normal points up (towards -y in the optical frame).
Plane oriented(Eigen::Vector3d n, double d) {
  if (n.y() > 0) {
    n = -n;
    d = -d;
  }
  return {n, d};
}

bool acceptable(const Plane& pl, const FloorFitParams& p) {
  const double cos_tilt = std::cos(p.max_tilt_deg * M_PI / 180.0);
  return -pl.n.y() >= cos_tilt && pl.d >= p.min_height;
}

// Weighted least-squares plane through the points within the band of `pl`; false when too few.
bool refine(const std::vector<Eigen::Vector3f>& pts, const FloorFitParams& p, Plane* pl, int* count, double* rms) {
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  double wsum = 0;
  int n = 0;
  for (const auto& q : pts) {
    const Eigen::Vector3d x = q.cast<double>();
    const double tol = band(p, x.z());
    if (std::abs(pl->n.dot(x) + pl->d) > tol) continue;
    const double w = 1.0 / (tol * tol);
    c += w * x;
    wsum += w;
    ++n;
  }
  if (n < 3) return false;
  c /= wsum;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& q : pts) {
    const Eigen::Vector3d x = q.cast<double>();
    const double tol = band(p, x.z());
    if (std::abs(pl->n.dot(x) + pl->d) > tol) continue;
    const Eigen::Vector3d e = x - c;
    cov += (1.0 / (tol * tol)) * e * e.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
  const Eigen::Vector3d normal = es.eigenvectors().col(0).normalized();  // smallest eigenvalue
  *pl = oriented(normal, -normal.dot(c));
  // Count and RMS against the refined plane.
  double ss = 0;
  int k = 0;
  for (const auto& q : pts) {
    const Eigen::Vector3d x = q.cast<double>();
    const double r = pl->n.dot(x) + pl->d;
    if (std::abs(r) > band(p, x.z())) continue;
    ss += r * r;
    ++k;
  }
  *count = k;
  *rms = k > 0 ? std::sqrt(ss / k) : 0;
  return true;
}

}  // namespace

void disparity_points(const cv::Mat& disparity, const StereoCameraModel& model, const FloorFitParams& params,
                      std::vector<Eigen::Vector3f>* out) {
  if (disparity.empty() || disparity.type() != CV_32F) return;
  const Intrinsics& k = model.intrinsics();
  const double fb = k.fx * model.baseline();
  const int stride = std::max(1, params.stride);
  for (int v = 0; v < disparity.rows; v += stride) {
    const float* row = disparity.ptr<float>(v);
    for (int u = 0; u < disparity.cols; u += stride) {
      const float d = row[u];
      if (!(d > 0) || !std::isfinite(d)) continue;
      const double z = fb / d;
      if (z < params.min_range || z > params.max_range) continue;
      out->emplace_back(static_cast<float>((u - k.cx) * z / k.fx), static_cast<float>((v - k.cy) * z / k.fy),
                        static_cast<float>(z));
    }
  }
}

Result<FloorFit> fit_floor(const std::vector<Eigen::Vector3f>& all, const FloorFitParams& p) {
  if (p.iterations < 1 || p.min_inliers < 3 || !(p.inlier_distance > 0) || p.inlier_growth < 0)
    return bad_input("", 0, "floor", "floor fit parameters out of range");
  // Evenly subsample to at most max_points, then score samples on a smaller even subset.
  std::vector<Eigen::Vector3f> pts;
  const size_t keep = static_cast<size_t>(std::max(3, p.max_points));
  if (all.size() > keep) {
    pts.reserve(keep);
    for (size_t i = 0; i < keep; ++i) pts.push_back(all[i * all.size() / keep]);
  } else {
    pts = all;
  }
  if (static_cast<int>(pts.size()) < p.min_inliers)
    return bad_input("", 0, "floor",
                     "only " + std::to_string(pts.size()) + " valid depth points within " +
                         std::to_string(p.max_range) + " m (need " + std::to_string(p.min_inliers) +
                         "): is the disparity computed (disparity=sgbm) and the floor in view?");
  std::vector<Eigen::Vector3f> scoring;
  const size_t score_n = std::min<size_t>(pts.size(), 20000);
  for (size_t i = 0; i < score_n; ++i) scoring.push_back(pts[i * pts.size() / score_n]);

  Rng rng(p.seed);
  Plane best;
  int best_count = -1;
  for (int it = 0; it < p.iterations; ++it) {
    const Eigen::Vector3d a = pts[rng.next() % pts.size()].cast<double>();
    const Eigen::Vector3d b = pts[rng.next() % pts.size()].cast<double>();
    const Eigen::Vector3d c = pts[rng.next() % pts.size()].cast<double>();
    Eigen::Vector3d n = (b - a).cross(c - a);
    const double len = n.norm();
    if (!(len > 1e-9)) continue;
    n /= len;
    const Plane pl = oriented(n, -n.dot(a));
    if (!acceptable(pl, p)) continue;
    int count = 0;
    for (const auto& q : scoring) {
      const Eigen::Vector3d x = q.cast<double>();
      if (std::abs(pl.n.dot(x) + pl.d) <= band(p, x.z())) ++count;
    }
    if (count > best_count) {
      best_count = count;
      best = pl;
    }
  }
  if (best_count < 0)
    return bad_input("", 0, "floor",
                     "no plane below the camera faces up within " + std::to_string(p.max_tilt_deg) +
                         " degrees of the image's up direction: is the floor in view?");
  FloorFit fit;
  fit.points = static_cast<int>(all.size());
  int count = 0;
  double rms = 0;
  for (int round = 0; round < 3; ++round) {
    if (!refine(pts, p, &best, &count, &rms)) break;
  }
  // Counted on the kept points; scale to the pooled count.
  const double scale = static_cast<double>(all.size()) / static_cast<double>(pts.size());
  fit.inliers = static_cast<int>(std::lround(count * scale));
  if (count < p.min_inliers || count < p.min_inlier_fraction * static_cast<double>(pts.size()) || !acceptable(best, p))
    return bad_input("", 0, "floor",
                     "the best floor plane holds only " + std::to_string(count) + " of " + std::to_string(pts.size()) +
                         " points (need " + std::to_string(p.min_inliers) + " and " +
                         std::to_string(static_cast<int>(100 * p.min_inlier_fraction)) +
                         " %): is the floor in view and the scene empty?");
  fit.normal = best.n;
  fit.height = best.d;
  fit.rms = rms;
  const Eigen::Vector3d nb(best.n.z(), -best.n.x(), -best.n.y());
  fit.pitch = std::asin(std::clamp(-nb.x(), -1.0, 1.0));
  fit.roll = std::atan2(nb.y(), nb.z());
  return fit;
}

CameraPose pose_from_floor(const FloorFit& fit, double x, double y, double yaw) {
  CameraPose pose;
  pose.position = {x, y, fit.height};
  pose.yaw = yaw;
  pose.pitch = fit.pitch;
  pose.roll = fit.roll;
  return pose;
}

Result<CameraPose> place_rig_from_floor_points(const FloorFit& fit, const Intrinsics& k,
                                               const std::vector<FloorCorrespondence>& pairs, double* residual) {
  if (pairs.size() < 2) return bad_input("", 0, "floor_points", "need at least two floor points");
  const CameraPose level = pose_from_floor(fit, 0, 0, 0);
  const Eigen::Matrix3d rot = level.map_from_optical().linear();
  std::vector<Eigen::Vector2d> local;
  for (size_t i = 0; i < pairs.size(); ++i) {
    const Eigen::Vector3d ray = rot * Eigen::Vector3d((pairs[i].pixel.x() - k.cx) / k.fx, (pairs[i].pixel.y() - k.cy) / k.fy, 1);
    if (!(ray.z() < -1e-6))
      return bad_input("", 0, "floor_points",
                       "point " + std::to_string(i + 1) + ": the ray through pixel (" + std::to_string(pairs[i].pixel.x()) +
                           ", " + std::to_string(pairs[i].pixel.y()) + ") does not meet the floor (above the horizon)");
    const double t = fit.height / -ray.z();
    local.emplace_back(t * ray.x(), t * ray.y());
  }
  Eigen::Vector2d ca = Eigen::Vector2d::Zero(), cm = Eigen::Vector2d::Zero();
  for (size_t i = 0; i < pairs.size(); ++i) {
    ca += local[i];
    cm += pairs[i].map;
  }
  ca /= static_cast<double>(pairs.size());
  cm /= static_cast<double>(pairs.size());
  double sin_sum = 0, cos_sum = 0, spread = 0;
  for (size_t i = 0; i < pairs.size(); ++i) {
    const Eigen::Vector2d a = local[i] - ca, m = pairs[i].map - cm;
    sin_sum += a.x() * m.y() - a.y() * m.x();
    cos_sum += a.x() * m.x() + a.y() * m.y();
    spread += m.squaredNorm();
  }
  if (!(spread > 1e-6)) return bad_input("", 0, "floor_points", "the floor points' map positions coincide");
  const double yaw = std::atan2(sin_sum, cos_sum);
  const Eigen::Rotation2Dd r(yaw);
  const Eigen::Vector2d t = cm - r * ca;
  double ss = 0;
  for (size_t i = 0; i < pairs.size(); ++i) ss += (r * local[i] + t - pairs[i].map).squaredNorm();
  if (residual) *residual = std::sqrt(ss / static_cast<double>(pairs.size()));
  return pose_from_floor(fit, t.x(), t.y(), yaw);
}

}  // namespace vigil::vision
