// The stereo camera model shared by the renderer and the vision code (after ROS
// image_geometry's StereoCameraModel): pinhole intrinsics of the rectified left camera, the
// baseline to the right camera, and the rig's pose in the map frame. Frames: the map and the
// camera body follow REP 103 (x forward, y left, z up); the optical frame follows OpenCV (x
// right, y down, z forward). The right camera sits `baseline` metres along the left camera's
// optical +x, so a point at depth Z has disparity d = u_left - u_right = fx * baseline / Z.
#pragma once

#include <Eigen/Geometry>

namespace vigil::vision {

// Pinhole intrinsics of a rectified camera, in pixels.
struct Intrinsics {
  int width = 640, height = 480;
  double fx = 554.256, fy = 554.256;  // 60 deg horizontal field of view at 640 px
  double cx = 319.5, cy = 239.5;      // pixel centres are at integer coordinates
  // Square pixels, principal point at the image centre, the given horizontal field of view (rad).
  static Intrinsics from_hfov(int width, int height, double hfov);
  double hfov() const;  // horizontal field of view (rad)
  double vfov() const;  // vertical field of view (rad)
};

// Where the rig is: the left camera's optical centre in the map frame, and the body's yaw
// (about z, counter-clockwise), pitch (about the body's y; positive looks down) and roll (about
// the body's x), applied in that order (R = Rz(yaw) * Ry(pitch) * Rx(roll)).
struct CameraPose {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  double yaw = 0, pitch = 0, roll = 0;
  // Maps optical-frame coordinates of the left camera to the map frame.
  Eigen::Isometry3d map_from_optical() const;
};

class StereoCameraModel {
 public:
  StereoCameraModel() = default;
  StereoCameraModel(const Intrinsics& left, double baseline, const CameraPose& pose);

  const Intrinsics& intrinsics() const { return k_; }
  double baseline() const { return baseline_; }
  const CameraPose& pose() const { return pose_; }
  const Eigen::Isometry3d& map_from_optical() const { return map_from_optical_; }
  const Eigen::Isometry3d& optical_from_map() const { return optical_from_map_; }

  // Left-image pixel of a point in the left optical frame; false when it is not in front (z <= 0).
  bool project(const Eigen::Vector3d& p_optical, Eigen::Vector2d* pixel) const;
  // Left-image pixel of a map-frame point; false when it is behind the camera.
  bool project_map(const Eigen::Vector3d& p_map, Eigen::Vector2d* pixel) const;
  // The optical-frame point at pixel (u, v) and depth z (along the optical axis).
  Eigen::Vector3d back_project(double u, double v, double z) const;
  // The same point in the map frame.
  Eigen::Vector3d back_project_map(double u, double v, double z) const;
  // Disparity (px) of a point at depth z (m), and back; 0 disparity or depth maps to infinity.
  double disparity_from_depth(double z) const;
  double depth_from_disparity(double d) const;

 private:
  Intrinsics k_;
  double baseline_ = 0.09;
  CameraPose pose_;
  Eigen::Isometry3d map_from_optical_ = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d optical_from_map_ = Eigen::Isometry3d::Identity();
};

}  // namespace vigil::vision
