#include "vision/plan_view.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <string>

#include <opencv2/imgproc.hpp>

namespace vigil::vision {
namespace {

std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

std::string size_str(const cv::Mat& m) { return std::to_string(m.cols) + "x" + std::to_string(m.rows); }

Error param_error(const std::string& key, const std::string& message) { return bad_input("", 0, key, message); }

bool finite(double v) { return std::isfinite(v); }

// Direction (map frame, not normalised) of the ray through pixel (u, v).
Eigen::Vector3d pixel_ray(const StereoCameraModel& cam, double u, double v) {
  const Intrinsics& k = cam.intrinsics();
  return cam.map_from_optical().linear() * Eigen::Vector3d((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0);
}

}  // namespace

bool PlanViewGrid::contains(double x, double y) const {
  const Eigen::Vector2d c = to_cell(x, y);
  const double i = std::floor(c.x() + 0.5), j = std::floor(c.y() + 0.5);
  return i >= 0 && j >= 0 && i < cols && j < rows;
}

PlanViewRegion PlanViewGrid::region() const {
  return {x_min - cell / 2, y_min - cell / 2, x_min + (cols - 0.5) * cell, y_min + (rows - 0.5) * cell};
}

bool PlanViewGrid::operator==(const PlanViewGrid& o) const {
  return x_min == o.x_min && y_min == o.y_min && cell == o.cell && cols == o.cols && rows == o.rows;
}

Status PlanViewParams::validate() const {
  if (!(cell_size > 0) || !finite(cell_size))
    return param_error("cell_size", "must be a positive number of metres, got " + num(cell_size));
  if (region) {
    const PlanViewRegion& r = *region;
    if (!finite(r.x_min) || !finite(r.x_max) || !finite(r.y_min) || !finite(r.y_max) || !(r.x_max > r.x_min) ||
        !(r.y_max > r.y_min)) {
      return param_error("region", "must have x_min < x_max and y_min < y_max, got x [" + num(r.x_min) + ", " +
                                       num(r.x_max) + "], y [" + num(r.y_min) + ", " + num(r.y_max) + "]");
    }
  }
  if (!(max_range > 0) || !finite(max_range))
    return param_error("max_range", "must be positive, got " + num(max_range));
  if (!finite(floor_z)) return param_error("floor_z", "must be finite");
  if (!finite(min_height) || !finite(max_height) || !(max_height > min_height)) {
    return param_error("max_height",
                       "must be above min_height, got [" + num(min_height) + ", " + num(max_height) + "]");
  }
  if (!(max_depth >= 0) || !finite(max_depth))
    return param_error("max_depth", "must be >= 0 (0 = no limit), got " + num(max_depth));
  if (!(smooth_sigma >= 0) || smooth_sigma > 50)
    return param_error("smooth_sigma", "must be in [0, 50] cells, got " + num(smooth_sigma));
  if (!(occupancy_threshold >= 0) || !finite(occupancy_threshold)) {
    return param_error("occupancy_threshold", "must be >= 0, got " + num(occupancy_threshold));
  }
  if (max_cells <= 0) return param_error("max_cells", "must be positive");
  if (height_fill < 0 || height_fill > 20) return param_error("height_fill", "must be 0 to 20 cells");
  return Status::Ok();
}

Status check_camera_sees_floor(const StereoCameraModel& camera, double floor_z) {
  const Eigen::Vector3d c = camera.map_from_optical().translation();
  if (!(c.z() > floor_z)) {
    return bad_input("", 0, "camera.position",
                     "the camera is at z = " + num(c.z()) + " m, not above the floor (z = " + num(floor_z) +
                         "): no plan view can be built");
  }
  const Intrinsics& k = camera.intrinsics();
  // The ray's z component is linear in the normalised image coordinates: the lowest ray is at a corner.
  double lowest = std::numeric_limits<double>::infinity();
  for (const double u : {-0.5, k.width - 0.5}) {
    for (const double v : {-0.5, k.height - 0.5}) {
      const Eigen::Vector3d d = pixel_ray(camera, u, v).normalized();
      lowest = std::min(lowest, d.z());
    }
  }
  if (!(lowest < -1e-9)) {
    const Eigen::Vector3d axis = camera.map_from_optical().linear().col(2);
    const double axis_deg = std::asin(std::clamp(axis.z(), -1.0, 1.0)) * 180 / M_PI;
    const double low_deg = std::asin(std::clamp(lowest, -1.0, 1.0)) * 180 / M_PI;
    return bad_input("", 0, "camera.pose.pitch",
                     "the camera looks at or above the horizon (optical axis " + num(axis_deg) +
                         " deg above it, lowest image ray " + num(low_deg) +
                         " deg): the floor plane is behind the camera, so no plan view can be built; pitch it down");
  }
  return Status::Ok();
}

Result<PlanViewRegion> camera_footprint(const StereoCameraModel& camera, double max_range, double floor_z,
                                        double min_height, double max_height) {
  if (Status s = check_camera_sees_floor(camera, floor_z); !s) return s;
  if (!(max_range > 0)) return param_error("max_range", "must be positive, got " + num(max_range));
  const Eigen::Vector3d c = camera.map_from_optical().translation();
  const double z_lo = floor_z + min_height, z_hi = floor_z + max_height;
  const Intrinsics& k = camera.intrinsics();
  double x0 = std::numeric_limits<double>::infinity(), y0 = x0, x1 = -x0, y1 = -x0;
  auto include = [&](double x, double y) {
    x0 = std::min(x0, x);
    x1 = std::max(x1, x);
    y0 = std::min(y0, y);
    y1 = std::max(y1, y);
  };
  // The frustum inside the band and the range is convex; its extreme points lie on rays through
  // the image border (where the band's planes cut the frustum's faces) or, where the range limit
  // binds, on interior rays too: sample a grid of rays over the whole image.
  constexpr int kSamples = 64;
  auto ray = [&](double u, double v) {
    const Eigen::Vector3d d = pixel_ray(camera, u, v);
    double a = 0, b = std::numeric_limits<double>::infinity();
    if (std::abs(d.z()) < 1e-12) {
      if (c.z() < z_lo || c.z() > z_hi) return;
    } else {
      double t1 = (z_lo - c.z()) / d.z(), t2 = (z_hi - c.z()) / d.z();
      if (t1 > t2) std::swap(t1, t2);
      a = std::max(a, t1);
      b = std::min(b, t2);
    }
    const double h = d.head<2>().norm();
    if (h < 1e-12) {
      if (a <= b) include(c.x(), c.y());
      return;
    }
    b = std::min(b, max_range / h);
    if (!(a <= b)) return;
    include(c.x() + a * d.x(), c.y() + a * d.y());
    include(c.x() + b * d.x(), c.y() + b * d.y());
  };
  for (int i = 0; i <= kSamples; ++i)
    for (int j = 0; j <= kSamples; ++j)
      ray(-0.5 + static_cast<double>(i) / kSamples * k.width, -0.5 + static_cast<double>(j) / kSamples * k.height);
  if (!(x1 > x0) || !(y1 > y0)) {
    return bad_input("", 0, "camera.pose",
                     "the camera sees nothing between " + num(min_height) + " and " + num(max_height) +
                         " m above the floor within " + num(max_range) + " m");
  }
  return PlanViewRegion{x0, y0, x1, y1};
}

Result<PlanViewBuilder> PlanViewBuilder::create(const StereoCameraModel& camera, const PlanViewParams& params) {
  if (Status s = params.validate(); !s) return s;
  const Intrinsics& k = camera.intrinsics();
  if (k.width <= 0 || k.height <= 0 || !(k.fx > 0) || !(k.fy > 0)) {
    return bad_input("", 0, "camera.intrinsics",
                     "image " + std::to_string(k.width) + "x" + std::to_string(k.height) + " with fx " + num(k.fx) +
                         ", fy " + num(k.fy) + " is not a usable camera");
  }
  if (Status s = check_camera_sees_floor(camera, params.floor_z); !s) return s;
  PlanViewRegion region;
  if (params.region) {
    region = *params.region;
  } else {
    auto r = camera_footprint(camera, params.max_range, params.floor_z, params.min_height, params.max_height);
    if (!r) return r.error();
    region = *r;
  }
  PlanViewBuilder b;
  b.camera_ = camera;
  b.params_ = params;
  const double cell = params.cell_size;
  const double cols = std::ceil((region.x_max - region.x_min) / cell - 1e-9);
  const double rows = std::ceil((region.y_max - region.y_min) / cell - 1e-9);
  if (cols * rows > params.max_cells) {
    return param_error("region", "the region " + num(region.x_max - region.x_min) + " x " +
                                     num(region.y_max - region.y_min) + " m needs " + num(cols) + " x " + num(rows) +
                                     " cells of " + num(cell) + " m, more than max_cells = " +
                                     std::to_string(params.max_cells));
  }
  b.grid_.cell = cell;
  b.grid_.x_min = region.x_min + cell / 2;
  b.grid_.y_min = region.y_min + cell / 2;
  b.grid_.cols = std::max(1, static_cast<int>(cols));
  b.grid_.rows = std::max(1, static_cast<int>(rows));

  // Map point of pixel (u, v) at depth Z: C + Z * R * [(u - cx) / fx, (v - cy) / fy, 1]
  //   = C + Z * (col(u) + row(v)), col(u) = R.col(0) * (u - cx) / fx, row(v) = R.col(1) * (v - cy) / fy + R.col(2)
  // (eq. 10.5 then 10.6); x and y are kept in cell units offset so that floor() gives eq. 10.7.
  const Eigen::Matrix3d R = camera.map_from_optical().linear();
  const Eigen::Vector3d C = camera.map_from_optical().translation();
  const double inv = 1.0 / cell;
  b.col_x_.resize(k.width);
  b.col_y_.resize(k.width);
  b.col_z_.resize(k.width);
  for (int u = 0; u < k.width; ++u) {
    const Eigen::Vector3d r = R.col(0) * ((u - k.cx) / k.fx);
    b.col_x_[u] = static_cast<float>(r.x() * inv);
    b.col_y_[u] = static_cast<float>(r.y() * inv);
    b.col_z_[u] = static_cast<float>(r.z());
  }
  b.row_x_.resize(k.height);
  b.row_y_.resize(k.height);
  b.row_z_.resize(k.height);
  for (int v = 0; v < k.height; ++v) {
    const Eigen::Vector3d r = R.col(1) * ((v - k.cy) / k.fy) + R.col(2);
    b.row_x_[v] = static_cast<float>(r.x() * inv);
    b.row_y_[v] = static_cast<float>(r.y() * inv);
    b.row_z_[v] = static_cast<float>(r.z());
  }
  b.origin_x_ = static_cast<float>((C.x() - b.grid_.x_min) * inv + 0.5);
  b.origin_y_ = static_cast<float>((C.y() - b.grid_.y_min) * inv + 0.5);
  b.origin_z_ = static_cast<float>(C.z() - params.floor_z);
  b.weight_ = static_cast<float>(1.0 / (k.fx * k.fy * cell * cell));
  // The view ceiling: the point (x, y, h) is q(h) = q0 + h a in the camera's optical frame and
  // at image row v(h) = fy q.y / q.z + cy; the top edge (v = -0.5) is crossed at the h solving
  // fy (q0.y + h a.y) = (-0.5 - cy) (q0.z + h a.z).
  b.ceiling_.create(b.grid_.rows, b.grid_.cols, CV_32F);
  const Eigen::Matrix3d Rt = R.transpose();
  const Eigen::Vector3d a = Rt.col(2);
  const double top = -0.5 - k.cy, h_max = params.max_height;
  for (int r = 0; r < b.grid_.rows; ++r) {
    float* c = b.ceiling_.ptr<float>(r);
    for (int col = 0; col < b.grid_.cols; ++col) {
      const Eigen::Vector2d m = b.grid_.to_map(col, r);
      const Eigen::Vector3d q0 = Rt * (Eigen::Vector3d(m.x(), m.y(), params.floor_z) - C);
      const double den = k.fy * a.y() - top * a.z();
      double h = std::numeric_limits<double>::infinity();  // the top edge never cuts it in the band
      if (std::abs(den) > 1e-12) {
        const double cross = (top * q0.z() - k.fy * q0.y()) / den;
        // Rising above `cross` leaves the view when v falls with height there (dv/dh has the
        // sign of a.y q0.z - q0.y a.z), in front of the camera.
        if (a.y() * q0.z() - q0.y() * a.z() < 0 && q0.z() + std::max(cross, 0.0) * a.z() > 0)
          h = cross < h_max ? std::max(cross, 0.0) : h;
      }
      c[col] = static_cast<float>(h);
    }
  }
  return b;
}

Status PlanViewBuilder::build(const cv::Mat& foreground, const cv::Mat& depth, PlanView* out) const {
  if (!out) return internal_error("PlanViewBuilder::build: no output");
  const Intrinsics& k = camera_.intrinsics();
  const cv::Size size(k.width, k.height);
  if (foreground.type() != CV_8UC1) {
    return bad_input("", 0, "foreground", "must be an 8-bit single-channel mask (CV_8U), got type " +
                                              std::to_string(foreground.type()) + " of " + size_str(foreground));
  }
  if (depth.type() != CV_32FC1) {
    return bad_input("", 0, "depth", "must be a 32-bit float image (CV_32F, metres), got type " +
                                         std::to_string(depth.type()) + " of " + size_str(depth));
  }
  if (foreground.size() != size || depth.size() != size) {
    return bad_input("", 0, foreground.size() != size ? "foreground" : "depth",
                     "frame of " + size_str(foreground.size() != size ? foreground : depth) +
                         " does not match the camera's " + std::to_string(k.width) + "x" + std::to_string(k.height));
  }

  // Reuse the output: clear only what held data last time.
  const int rows = grid_.rows, cols = grid_.cols;
  const bool reuse = out->grid == grid_ && out->occupancy.rows == rows && out->occupancy.cols == cols &&
                     out->occupancy.type() == CV_32F && out->occupancy_smoothed.size() == out->occupancy.size() &&
                     out->height.size() == out->occupancy.size() &&
                     out->height_masked.size() == out->occupancy.size() &&
                     out->mask.size() == out->occupancy.size() && out->occupancy.isContinuous() &&
                     out->height.isContinuous();
  if (reuse) {
    const cv::Rect a = out->active & cv::Rect(0, 0, cols, rows);
    if (!a.empty()) {
      out->occupancy(a).setTo(0);
      out->occupancy_smoothed(a).setTo(0);
      out->height(a).setTo(0);
      out->height_masked(a).setTo(0);
      out->mask(a).setTo(0);
    }
  } else {
    out->grid = grid_;
    out->occupancy = cv::Mat::zeros(rows, cols, CV_32F);
    out->occupancy_smoothed = cv::Mat::zeros(rows, cols, CV_32F);
    out->height = cv::Mat::zeros(rows, cols, CV_32F);
    out->height_masked = cv::Mat::zeros(rows, cols, CV_32F);
    out->mask = cv::Mat::zeros(rows, cols, CV_8U);
  }
  out->active = cv::Rect();
  out->smoothing = params_.smooth_sigma;
  out->camera_xy = camera_.map_from_optical().translation().head<2>();
  out->camera_height = camera_.map_from_optical().translation().z() - params_.floor_z;
  out->ceiling = ceiling_;

  float* occ = out->occupancy.ptr<float>(0);
  float* hgt = out->height.ptr<float>(0);
  const float z_lo = static_cast<float>(params_.min_height), z_hi = static_cast<float>(params_.max_height);
  const float max_depth =
      params_.max_depth > 0 ? static_cast<float>(params_.max_depth) : std::numeric_limits<float>::max();
  const float fcols = static_cast<float>(cols), frows = static_cast<float>(rows);
  const float w0 = weight_;
  int points = 0, invalid = 0, band = 0, outside = 0;
  int i0 = cols, i1 = -1, j0 = rows, j1 = -1;
  const int W = k.width;
  for (int v = 0; v < k.height; ++v) {
    const uint8_t* m = foreground.ptr<uint8_t>(v);
    const float* d = depth.ptr<float>(v);
    const float rx = row_x_[v], ry = row_y_[v], rz = row_z_[v];
    auto one = [&](int u) {
      const float Z = d[u];
      if (!(Z > 0.0f && Z <= max_depth)) {  // also false for NaN; inf > max_depth
        ++invalid;
        return;
      }
      const float h = origin_z_ + Z * (rz + col_z_[u]);
      if (h < z_lo || h > z_hi) {
        ++band;
        return;
      }
      const float fx = origin_x_ + Z * (rx + col_x_[u]);
      const float fy = origin_y_ + Z * (ry + col_y_[u]);
      if (!(fx >= 0.0f && fx < fcols && fy >= 0.0f && fy < frows)) {
        ++outside;
        return;
      }
      const int i = static_cast<int>(fx), j = static_cast<int>(fy);
      const size_t c = static_cast<size_t>(j) * cols + i;
      occ[c] += Z * Z * w0;
      if (h > hgt[c]) hgt[c] = h;
      ++points;
      i0 = std::min(i0, i);
      i1 = std::max(i1, i);
      j0 = std::min(j0, j);
      j1 = std::max(j1, j);
    };
    int u = 0;
    for (; u + 8 <= W; u += 8) {
      uint64_t word;
      std::memcpy(&word, m + u, 8);
      if (!word) continue;
      for (int q = 0; q < 8; ++q)
        if (m[u + q]) one(u + q);
    }
    for (; u < W; ++u)
      if (m[u]) one(u);
  }
  out->points = points;
  out->invalid_depth = invalid;
  out->out_of_band = band;
  out->out_of_region = outside;
  if (points == 0) return Status::Ok();

  // Refinement: smoothing, threshold, masked height, over the touched cells and the kernel's reach.
  const double sigma = params_.smooth_sigma;
  const int radius = sigma > 0 ? static_cast<int>(std::ceil(3 * sigma)) : 0;
  const cv::Rect roi = cv::Rect(i0 - radius, j0 - radius, i1 - i0 + 1 + 2 * radius, j1 - j0 + 1 + 2 * radius) &
                       cv::Rect(0, 0, cols, rows);
  out->active = roi;
  if (radius > 0) {
    cv::GaussianBlur(out->occupancy(roi), out->occupancy_smoothed(roi), cv::Size(2 * radius + 1, 2 * radius + 1), sigma,
                     sigma, cv::BORDER_CONSTANT);
  } else {
    out->occupancy(roi).copyTo(out->occupancy_smoothed(roi));
  }
  const double thr = params_.occupancy_threshold;
  cv::compare(out->occupancy_smoothed(roi), thr, out->mask(roi), thr > 0 ? cv::CMP_GE : cv::CMP_GT);
  if (params_.height_fill > 0) {
    const int n = 2 * params_.height_fill + 1;
    cv::Mat filled;
    cv::dilate(out->height(roi), filled, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(n, n)), cv::Point(-1, -1),
               1, cv::BORDER_CONSTANT, cv::Scalar::all(0));
    filled.copyTo(out->height_masked(roi), out->mask(roi));
  } else {
    out->height(roi).copyTo(out->height_masked(roi), out->mask(roi));
  }
  return Status::Ok();
}

}  // namespace vigil::vision
