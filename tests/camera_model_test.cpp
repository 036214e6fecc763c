// Tests of vision/stereo_camera_model: intrinsics from a field of view, projection and back
// projection in the optical frame, disparity <-> depth, and the pose conventions that tie the
// camera to the map frame (REP 103 body, OpenCV optical frame, yaw/pitch/roll as documented).
#include "vision/stereo_camera_model.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

namespace vigil::vision {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

StereoCameraModel model_at(const CameraPose& pose) {
  return StereoCameraModel(Intrinsics::from_hfov(640, 480, 60 * kDeg), 0.09, pose);
}

Eigen::Vector2d project_map(const StereoCameraModel& m, const Eigen::Vector3d& p) {
  Eigen::Vector2d px(NAN, NAN);
  EXPECT_TRUE(m.project_map(p, &px)) << "point " << p.transpose() << " is behind the camera";
  return px;
}

TEST(Intrinsics, FromHorizontalFieldOfView) {
  const Intrinsics k = Intrinsics::from_hfov(640, 480, 60 * kDeg);
  EXPECT_NEAR(k.fx, 320.0 / std::tan(30 * kDeg), 1e-9);  // 554.256...
  EXPECT_DOUBLE_EQ(k.fy, k.fx);
  EXPECT_DOUBLE_EQ(k.cx, 319.5);
  EXPECT_DOUBLE_EQ(k.cy, 239.5);
  EXPECT_NEAR(k.hfov(), 60 * kDeg, 1e-12);
  EXPECT_NEAR(k.vfov(), 2 * std::atan(240.0 / k.fy), 1e-12);
}

TEST(Intrinsics, DefaultIsTheVidereRigAt640x480) {
  const Intrinsics k;
  EXPECT_EQ(k.width, 640);
  EXPECT_EQ(k.height, 480);
  EXPECT_NEAR(k.fx, Intrinsics::from_hfov(640, 480, 60 * kDeg).fx, 1e-3);
}

TEST(StereoCameraModel, ProjectBackProjectRoundTrip) {
  const StereoCameraModel m = model_at({});
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0, 640), v(0, 480), z(0.3, 40);
  for (int i = 0; i < 200; ++i) {
    const double pu = u(rng), pv = v(rng), pz = z(rng);
    const Eigen::Vector3d p = m.back_project(pu, pv, pz);
    EXPECT_DOUBLE_EQ(p.z(), pz);
    Eigen::Vector2d px;
    ASSERT_TRUE(m.project(p, &px));
    EXPECT_NEAR(px.x(), pu, 1e-9);
    EXPECT_NEAR(px.y(), pv, 1e-9);
  }
  // A point on the optical axis lands on the principal point; one behind does not project.
  Eigen::Vector2d px;
  ASSERT_TRUE(m.project({0, 0, 3}, &px));
  EXPECT_DOUBLE_EQ(px.x(), 319.5);
  EXPECT_DOUBLE_EQ(px.y(), 239.5);
  EXPECT_FALSE(m.project({0, 0, -1}, &px));
  EXPECT_FALSE(m.project({1, 0, 0}, &px));
  // Optical x is right and y is down.
  ASSERT_TRUE(m.project({1, 0, 10}, &px));
  EXPECT_NEAR(px.x(), 319.5 + m.intrinsics().fx * 0.1, 1e-9);
  ASSERT_TRUE(m.project({0, 1, 10}, &px));
  EXPECT_NEAR(px.y(), 239.5 + m.intrinsics().fy * 0.1, 1e-9);
}

TEST(StereoCameraModel, DisparityDepth) {
  const StereoCameraModel m = model_at({});
  const double fb = m.intrinsics().fx * 0.09;
  for (double z : {0.5, 1.0, 2.5, 7.0, 30.0}) {
    EXPECT_NEAR(m.disparity_from_depth(z), fb / z, 1e-12);
    EXPECT_NEAR(m.depth_from_disparity(m.disparity_from_depth(z)), z, 1e-12);
  }
  EXPECT_NEAR(m.disparity_from_depth(1.0), 554.256 * 0.09, 1e-3);  // ~49.9 px at 1 m
  EXPECT_TRUE(std::isinf(m.disparity_from_depth(0)));
  EXPECT_TRUE(std::isinf(m.depth_from_disparity(0)));
  EXPECT_TRUE(std::isinf(m.depth_from_disparity(-3)));
}

TEST(StereoCameraModel, IdentityPoseLooksAlongMapX) {
  const StereoCameraModel m = model_at({});
  const Eigen::Vector2d centre = project_map(m, {5, 0, 0});
  EXPECT_NEAR(centre.x(), 319.5, 1e-9);
  EXPECT_NEAR(centre.y(), 239.5, 1e-9);
  EXPECT_LT(project_map(m, {5, 1, 0}).x(), 319.5);  // map +y is the camera's left
  EXPECT_NEAR(project_map(m, {5, 1, 0}).y(), 239.5, 1e-9);
  EXPECT_LT(project_map(m, {5, 0, 1}).y(), 239.5);  // map +z is up in the image
  EXPECT_NEAR(project_map(m, {5, 0, 1}).x(), 319.5, 1e-9);
  Eigen::Vector2d px;
  EXPECT_FALSE(m.project_map({-5, 0, 0}, &px));  // behind
  // Depth along the optical axis is the map x distance.
  EXPECT_NEAR((m.optical_from_map() * Eigen::Vector3d(5, 2, -1)).z(), 5, 1e-12);
}

TEST(StereoCameraModel, PositionShiftsTheOpticalCentre) {
  CameraPose pose;
  pose.position = {2, -1, 1.5};
  const StereoCameraModel m = model_at(pose);
  const Eigen::Vector2d px = project_map(m, {7, -1, 1.5});
  EXPECT_NEAR(px.x(), 319.5, 1e-9);
  EXPECT_NEAR(px.y(), 239.5, 1e-9);
  EXPECT_TRUE((m.map_from_optical().translation() - pose.position).norm() < 1e-12);
}

TEST(StereoCameraModel, YawNinetyLooksAlongMapY) {
  CameraPose pose;
  pose.yaw = 90 * kDeg;
  const StereoCameraModel m = model_at(pose);
  const Eigen::Vector2d px = project_map(m, {0, 5, 0});
  EXPECT_NEAR(px.x(), 319.5, 1e-9);
  EXPECT_NEAR(px.y(), 239.5, 1e-9);
  Eigen::Vector2d behind;
  EXPECT_FALSE(m.project_map({0, -5, 0}, &behind));
  // Facing +y, the camera's left is map -x.
  EXPECT_LT(project_map(m, {-1, 5, 0}).x(), 319.5);
  EXPECT_GT(project_map(m, {1, 5, 0}).x(), 319.5);
}

TEST(StereoCameraModel, PositivePitchLooksDown) {
  CameraPose pose;
  pose.position = {0, 0, 2};
  pose.pitch = std::atan2(2.0, 4.0);  // aim at the floor point (4, 0, 0)
  const StereoCameraModel m = model_at(pose);
  const Eigen::Vector2d px = project_map(m, {4, 0, 0});
  EXPECT_NEAR(px.x(), 319.5, 1e-9);
  EXPECT_NEAR(px.y(), 239.5, 1e-9);
  // The same point seen with a level camera is below the image centre.
  CameraPose level = pose;
  level.pitch = 0;
  EXPECT_GT(project_map(model_at(level), {4, 0, 0}).y(), 239.5 + 100);
}

TEST(StereoCameraModel, RollTurnsTheImage) {
  CameraPose pose;
  pose.roll = 90 * kDeg;
  const StereoCameraModel m = model_at(pose);
  // A roll of +90 deg about the body's x carries its left (+y) to map up (+z): a point above
  // the camera is now on the image's left, on the centre row.
  EXPECT_LT(project_map(m, {5, 0, 1}).x(), 319.5);
  EXPECT_NEAR(project_map(m, {5, 0, 1}).y(), 239.5, 1e-9);
}

TEST(StereoCameraModel, MapRoundTripWithArbitraryPose) {
  CameraPose pose;
  pose.position = {12.3, -4.5, 1.8};
  pose.yaw = 2.1;
  pose.pitch = 0.35;
  pose.roll = -0.2;
  const StereoCameraModel m = model_at(pose);
  // map_from_optical is a rigid transform and the inverse of optical_from_map.
  const Eigen::Matrix3d r = m.map_from_optical().linear();
  EXPECT_NEAR((r * r.transpose() - Eigen::Matrix3d::Identity()).norm(), 0, 1e-12);
  EXPECT_NEAR(r.determinant(), 1, 1e-12);
  EXPECT_TRUE((m.optical_from_map() * m.map_from_optical()).matrix().isIdentity(1e-12));
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0, 640), v(0, 480), z(0.5, 25);
  for (int i = 0; i < 200; ++i) {
    const double pu = u(rng), pv = v(rng), pz = z(rng);
    const Eigen::Vector3d p_map = m.back_project_map(pu, pv, pz);
    Eigen::Vector2d px;
    ASSERT_TRUE(m.project_map(p_map, &px));
    EXPECT_NEAR(px.x(), pu, 1e-8);
    EXPECT_NEAR(px.y(), pv, 1e-8);
    EXPECT_NEAR((m.optical_from_map() * p_map).z(), pz, 1e-9);
  }
  // The optical axis in the map frame is the body's forward direction after yaw then pitch.
  const Eigen::Vector3d forward = m.map_from_optical().linear() * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d expected(std::cos(2.1) * std::cos(0.35), std::sin(2.1) * std::cos(0.35),
                                 -std::sin(0.35));
  EXPECT_NEAR((forward - expected).norm(), 0, 1e-12);
}

TEST(StereoCameraModel, RightCameraSeesSmallerU) {
  // The right camera sits `baseline` along optical +x: a point at depth Z appears fx*b/Z pixels
  // further left in the right image (d = u_left - u_right).
  const StereoCameraModel m = model_at({});
  const Eigen::Vector3d p(0.4, -0.2, 3.0);
  Eigen::Vector2d left, right;
  ASSERT_TRUE(m.project(p, &left));
  ASSERT_TRUE(m.project(p - Eigen::Vector3d(m.baseline(), 0, 0), &right));
  EXPECT_NEAR(left.x() - right.x(), m.disparity_from_depth(3.0), 1e-9);
  EXPECT_NEAR(left.y(), right.y(), 1e-12);
}

}  // namespace
}  // namespace vigil::vision
