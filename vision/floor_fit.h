// The rig's pose over the floor, from stereo depth of the empty scene: the plan-view tracker
// (chapter section 10.4) needs the camera's height, pitch and roll over the ground plane to turn
// its point cloud into plan-view maps, and a user with their own rig has no other way to measure
// them well. A robust plane fit (RANSAC over three-point samples, then weighted least squares on
// the inliers) finds the floor among the 3D points of the left disparity maps; the floor is the
// largest plane below the camera whose upward normal lies within `max_tilt` of the image's up
// direction, so walls and the ceiling are never taken for it.
//
// With n the floor's unit normal in the left optical frame (pointing up, towards the camera) and
// h the camera's height over it, CameraPose (vision/stereo_camera_model.h: R = Rz(yaw) Ry(pitch)
// Rx(roll), positive pitch looks down) gives, in the body frame (x forward, y left, z up),
// n_body = (n.z, -n.x, -n.y) = (-sin pitch, sin roll cos pitch, cos roll cos pitch), hence
// pitch = asin(-n_body.x) and roll = atan2(n_body.y, n_body.z). Position in the floor plane and
// heading are not observable from the floor alone: the user gives them, or two image points of
// known map position on the floor (place_rig_from_floor_points).
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "common/status.h"
#include "vision/stereo_camera_model.h"

namespace vigil::vision {

struct FloorFitParams {
  double min_range = 0.5;         // m: nearer points are not used
  double max_range = 10.0;        // m: farther points are not used (depth error grows as Z^2)
  double inlier_distance = 0.02;  // m from the plane at 1 m depth; the band widens as
  double inlier_growth = 0.002;   // m per m^2 of depth (stereo depth error grows as Z^2)
  double max_tilt_deg = 60;       // the floor's normal within this of the image's up (-y)
  double min_height = 0.1;        // m: the camera is at least this far above the floor
  int iterations = 400;           // RANSAC samples
  int stride = 2;                 // use every stride-th pixel in each direction
  int max_points = 200000;        // pooled points kept (evenly subsampled beyond this)
  int min_inliers = 500;          // fewer inliers: the floor is not visible
  double min_inlier_fraction = 0.1;  // nor when fewer than this share of the points lie on it (a
                                     // plane slicing walls and furniture along lines)
  uint64_t seed = 1;              // the RANSAC sample stream (same points, same fit)
};

struct FloorFit {
  Eigen::Vector3d normal = Eigen::Vector3d(0, -1, 0);  // optical frame, unit, pointing up
  double height = 0;  // m, the left optical centre above the floor
  double pitch = 0;   // rad, positive looks down
  double roll = 0;    // rad
  int points = 0;     // 3D points considered
  int inliers = 0;    // points within the band of the final plane
  double rms = 0;     // m, RMS distance of the inliers from the plane
};

// 3D points (left optical frame, metres) of a disparity map (CV_32F, pixels; <= 0 invalid) with
// the rig's intrinsics and baseline, every `stride`-th pixel, depth within [min_range, max_range].
void disparity_points(const cv::Mat& disparity, const StereoCameraModel& model, const FloorFitParams& params,
                      std::vector<Eigen::Vector3f>* out);

// Fits the floor to points in the left optical frame. Errors (kBadInput, key "floor") when no
// plane with enough inliers is found below the camera: the floor is not visible.
Result<FloorFit> fit_floor(const std::vector<Eigen::Vector3f>& points, const FloorFitParams& params = {});

// The rig's pose from a floor fit, its map position (x, y) and heading (yaw, rad).
CameraPose pose_from_floor(const FloorFit& fit, double x, double y, double yaw);

// A floor point seen in the left image at `pixel` whose map position is `map`.
struct FloorCorrespondence {
  Eigen::Vector2d pixel;
  Eigen::Vector2d map;
};

// Places a rig whose height, pitch and roll are known (`fit`) from two (or more) floor points:
// each pixel's ray meets the floor in the rig's own level frame, and the 2D rigid transform that
// best maps those points to their map positions gives x, y and the heading. `residual` (m)
// receives the RMS misfit. Errors when a ray does not meet the floor ahead of the camera or the
// points coincide.
Result<CameraPose> place_rig_from_floor_points(const FloorFit& fit, const Intrinsics& intrinsics,
                                               const std::vector<FloorCorrespondence>& points,
                                               double* residual = nullptr);

}  // namespace vigil::vision
