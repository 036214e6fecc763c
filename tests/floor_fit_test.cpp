// Tests the floor fit (vision/floor_fit.h) on synthetic point clouds of a known rig: the floor's
// height, pitch and roll come back beside walls and a ceiling that hold more points than the
// floor; a scene without a floor is refused; the rig is placed from two floor points; and the
// rig file carries the pose (save, load, all-or-nothing keys, the frame source's pose= option).
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include <opencv2/imgcodecs.hpp>

#include "common/rng.h"
#include "tests/test_util.h"
#include "vision/floor_fit.h"
#include "vision/image_sources.h"
#include "vision/stereo_calibration.h"

namespace vigil::vision {
namespace {

constexpr double kDeg = M_PI / 180;

// Points of a corridor seen by a rig at `pose`: the floor (z = 0), two walls (y = +-1.5) and a
// ceiling (z = 2.7) ahead of the camera, each within 10 m, with Gaussian noise along the view ray
// growing as depth squared (as stereo's does); in the left optical frame.
std::vector<Eigen::Vector3f> corridor_points(const CameraPose& pose, int floor_n, int wall_n, uint64_t seed,
                                             double wall_bottom = 0) {
  const Eigen::Isometry3d optical_from_map = pose.map_from_optical().inverse();
  Rng rng(seed);
  std::vector<Eigen::Vector3f> out;
  auto add = [&](const Eigen::Vector3d& p_map) {
    Eigen::Vector3d p = optical_from_map * p_map;
    if (p.z() < 0.5 || p.z() > 10) return;
    p *= 1 + rng.normal(0, 0.002 * p.z());
    out.push_back(p.cast<float>());
  };
  const double fwd = std::cos(pose.yaw), side = std::sin(pose.yaw);
  for (int i = 0; i < floor_n; ++i) {
    const double a = rng.uniform(1, 10), b = rng.uniform(-1.5, 1.5);
    add({pose.position.x() + a * fwd - b * side, pose.position.y() + a * side + b * fwd, 0});
  }
  for (int i = 0; i < wall_n; ++i) {
    const double a = rng.uniform(1, 10), h = rng.uniform(wall_bottom, 2.7);
    for (double b : {-1.5, 1.5}) add({pose.position.x() + a * fwd - b * side, pose.position.y() + a * side + b * fwd, h});
    const double c = rng.uniform(-1.5, 1.5);
    add({pose.position.x() + a * fwd - c * side, pose.position.y() + a * side + c * fwd, 2.7});
  }
  return out;
}

CameraPose rig_pose() {
  CameraPose p;
  p.position = {3, -2, 2.4};
  p.yaw = 30 * kDeg;
  p.pitch = 18 * kDeg;
  p.roll = 2 * kDeg;
  return p;
}

TEST(FloorFit, FindsTheFloorBesideLargerWallsAndTheCeiling) {
  const CameraPose truth = rig_pose();
  // More wall and ceiling points than floor points: the tilt rule, not the count, picks the floor.
  const auto pts = corridor_points(truth, 8000, 6000, 7);
  auto fit = fit_floor(pts);
  ASSERT_TRUE(fit.ok()) << fit.error().str();
  EXPECT_NEAR(fit->height, truth.position.z(), 0.01);
  EXPECT_NEAR(fit->pitch, truth.pitch, 0.2 * kDeg);
  EXPECT_NEAR(fit->roll, truth.roll, 0.2 * kDeg);
  EXPECT_GT(fit->inliers, 6000);
  // Same points, same fit (seeded samples).
  auto again = fit_floor(pts);
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(again->height, fit->height);
  EXPECT_EQ(again->pitch, fit->pitch);
}

TEST(FloorFit, NoFloorInViewIsRefused) {
  CameraPose up = rig_pose();
  up.pitch = -60 * kDeg;  // looking at the ceiling: the upper walls and the ceiling only (the
                          // walls' foot would give the floor away)
  auto pts = corridor_points(up, 0, 6000, 3, 1.0);
  auto fit = fit_floor(pts);
  ASSERT_FALSE(fit.ok()) << pts.size() << " points, height " << fit->height << " pitch " << fit->pitch / kDeg
                         << " inliers " << fit->inliers;
  EXPECT_EQ(fit.error().key, "floor");
  auto none = fit_floor({});
  ASSERT_FALSE(none.ok());
  EXPECT_NE(none.error().message.find("disparity"), std::string::npos) << none.error().str();
}

TEST(FloorFit, PlacesTheRigFromTwoFloorPoints) {
  const CameraPose truth = rig_pose();
  const StereoCameraModel model(Intrinsics{}, 0.09, truth);
  FloorFit fit;
  fit.height = truth.position.z();
  fit.pitch = truth.pitch;
  fit.roll = truth.roll;
  std::vector<FloorCorrespondence> pairs;
  for (const Eigen::Vector3d& p : {Eigen::Vector3d(7, 1, 0), Eigen::Vector3d(5, 1.5, 0), Eigen::Vector3d(8, 0, 0)}) {
    Eigen::Vector2d px;
    ASSERT_TRUE(model.project_map(p, &px));
    pairs.push_back({px, p.head<2>()});
  }
  double residual = 1;
  auto placed = place_rig_from_floor_points(fit, model.intrinsics(), pairs, &residual);
  ASSERT_TRUE(placed.ok()) << placed.error().str();
  EXPECT_NEAR(placed->position.x(), truth.position.x(), 1e-6);
  EXPECT_NEAR(placed->position.y(), truth.position.y(), 1e-6);
  EXPECT_NEAR(placed->yaw, truth.yaw, 1e-8);
  EXPECT_LT(residual, 1e-6);
  // A pixel above the horizon does not meet the floor.
  pairs[0].pixel = {320, 0};
  EXPECT_FALSE(place_rig_from_floor_points(fit, model.intrinsics(), pairs).ok());
  EXPECT_FALSE(place_rig_from_floor_points(fit, model.intrinsics(), {pairs[1]}).ok());
}

class RigFileTest : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = test::fresh_temp_dir("rigfile", ::testing::UnitTest::GetInstance()->current_test_info()->name()); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  std::filesystem::path dir_;
};

TEST_F(RigFileTest, ThePoseIsSavedLoadedAndUsedByTheFrameSource) {
  StereoCalibration c = ideal_calibration(StereoCameraModel(Intrinsics::from_hfov(96, 64, 1.0), 0.1, rig_pose()));
  ASSERT_TRUE(save_stereo_calibration(path("rig.yaml"), c).ok());
  auto loaded = load_stereo_calibration(path("rig.yaml"));
  ASSERT_TRUE(loaded.ok()) << loaded.error().str();
  ASSERT_TRUE(loaded->pose.has_value());
  EXPECT_TRUE(loaded->pose->position.isApprox(rig_pose().position, 1e-12));
  EXPECT_NEAR(loaded->pose->pitch, rig_pose().pitch, 1e-12);
  EXPECT_NEAR(loaded->pose->roll, rig_pose().roll, 1e-12);

  cv::Mat img(64, 96, CV_8UC3, cv::Scalar(100, 120, 140));
  for (const char* f : {"l0.png", "r0.png"}) ASSERT_TRUE(cv::imwrite(path(f), img));
  auto src = open_frame_source("stereo:" + path("l%d.png") + "," + path("r%d.png") + "," + path("rig.yaml"));
  ASSERT_TRUE(src.ok()) << src.error().str();
  EXPECT_TRUE((*src)->has_pose());
  EXPECT_TRUE((*src)->camera_model()->pose().position.isApprox(rig_pose().position, 1e-12));
  // pose= overrides the file's (degrees).
  auto over = open_frame_source("stereo:" + path("l%d.png") + "," + path("r%d.png") + "," + path("rig.yaml") +
                                ";pose=1,2,3,90,10,0");
  ASSERT_TRUE(over.ok()) << over.error().str();
  EXPECT_TRUE((*over)->camera_model()->pose().position.isApprox(Eigen::Vector3d(1, 2, 3)));
  EXPECT_NEAR((*over)->camera_model()->pose().yaw, 90 * kDeg, 1e-12);
  // Without a pose anywhere the source says so.
  c.pose.reset();
  ASSERT_TRUE(save_stereo_calibration(path("bare.yaml"), c).ok());
  auto bare = open_frame_source("stereo:" + path("l%d.png") + "," + path("r%d.png") + "," + path("bare.yaml"));
  ASSERT_TRUE(bare.ok());
  EXPECT_FALSE((*bare)->has_pose());
  // A malformed pose option names the key.
  auto bad = open_frame_source("stereo:" + path("l%d.png") + "," + path("r%d.png") + "," + path("rig.yaml") + ";pose=1,2,3");
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().key, "pose");
}

TEST_F(RigFileTest, APartialPoseNamesTheMissingKeyAndItsLine) {
  StereoCalibration c = ideal_calibration(StereoCameraModel(Intrinsics{}, 0.09, rig_pose()));
  ASSERT_TRUE(save_stereo_calibration(path("rig.yaml"), c).ok());
  // Drop pose_roll_deg.
  std::string text = test::slurp(path("rig.yaml"));
  const size_t at = text.find("pose_roll_deg");
  ASSERT_NE(at, std::string::npos);
  text.erase(at, text.find('\n', at) - at + 1);
  std::ofstream(path("partial.yaml")) << text;
  auto p = load_stereo_calibration(path("partial.yaml"));
  ASSERT_FALSE(p.ok());
  EXPECT_EQ(p.error().key, "pose_roll_deg");
  EXPECT_EQ(p.error().file, path("partial.yaml"));
  // An out-of-range pitch names its key and line.
  std::string steep = test::slurp(path("rig.yaml"));
  const size_t pitch = steep.find("pose_pitch_deg");
  steep.replace(pitch, steep.find('\n', pitch) - pitch, "pose_pitch_deg: 120.");
  std::ofstream(path("steep.yaml")) << steep;
  auto s = load_stereo_calibration(path("steep.yaml"));
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().key, "pose_pitch_deg");
  EXPECT_GT(s.error().line, 0);
}

}  // namespace
}  // namespace vigil::vision
