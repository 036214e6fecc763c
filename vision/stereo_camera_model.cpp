#include "vision/stereo_camera_model.h"

#include <cmath>
#include <limits>

namespace vigil::vision {

Intrinsics Intrinsics::from_hfov(int width, int height, double hfov) {
  Intrinsics k;
  k.width = width;
  k.height = height;
  k.fx = k.fy = (width / 2.0) / std::tan(hfov / 2.0);
  k.cx = (width - 1) / 2.0;
  k.cy = (height - 1) / 2.0;
  return k;
}

double Intrinsics::hfov() const { return 2.0 * std::atan(width / (2.0 * fx)); }
double Intrinsics::vfov() const { return 2.0 * std::atan(height / (2.0 * fy)); }

Eigen::Isometry3d CameraPose::map_from_optical() const {
  const Eigen::Matrix3d body = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                                Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                                Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
                                   .toRotationMatrix();
  // Columns: the optical axes (x right, y down, z forward) written in the body frame.
  Eigen::Matrix3d body_from_optical;
  body_from_optical << 0, 0, 1,   //
      -1, 0, 0,                   //
      0, -1, 0;
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = body * body_from_optical;
  t.translation() = position;
  return t;
}

StereoCameraModel::StereoCameraModel(const Intrinsics& left, double baseline, const CameraPose& pose)
    : k_(left), baseline_(baseline), pose_(pose) {
  map_from_optical_ = pose.map_from_optical();
  optical_from_map_ = map_from_optical_.inverse();
}

bool StereoCameraModel::project(const Eigen::Vector3d& p, Eigen::Vector2d* pixel) const {
  if (!(p.z() > 0)) return false;
  *pixel = {k_.fx * p.x() / p.z() + k_.cx, k_.fy * p.y() / p.z() + k_.cy};
  return true;
}

bool StereoCameraModel::project_map(const Eigen::Vector3d& p_map, Eigen::Vector2d* pixel) const {
  return project(optical_from_map_ * p_map, pixel);
}

Eigen::Vector3d StereoCameraModel::back_project(double u, double v, double z) const {
  return {(u - k_.cx) * z / k_.fx, (v - k_.cy) * z / k_.fy, z};
}

Eigen::Vector3d StereoCameraModel::back_project_map(double u, double v, double z) const {
  return map_from_optical_ * back_project(u, v, z);
}

double StereoCameraModel::disparity_from_depth(double z) const {
  return z > 0 ? k_.fx * baseline_ / z : std::numeric_limits<double>::infinity();
}

double StereoCameraModel::depth_from_disparity(double d) const {
  return d > 0 ? k_.fx * baseline_ / d : std::numeric_limits<double>::infinity();
}

}  // namespace vigil::vision
