// Tests "your own stereo rig" end to end, through the command line as a user runs it
// (docs/RIG.md): `vigil calibrate stereo` on the real chessboard pairs and on chessboard views
// rendered in the simulator with a known answer; `vigil calibrate floor` on rendered frames of
// the empty corridor; recorded frames with the calibrated rig file through `vigil track` scored
// against the rendered-source run, and through `vigil camera-node` raising the scenario's event;
// and bad input (no board, mismatched pairs, no floor, a rig file without its pose or a key).
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "tests/test_util.h"
#include "vision/stereo_calibration.h"

namespace vigil {
namespace {

namespace fs = std::filesystem;
using test::Output;
using test::vigil_cmd;

constexpr double kDeg = M_PI / 180;

class RigTest : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = test::fresh_temp_dir("rig", ::testing::UnitTest::GetInstance()->current_test_info()->name()); }
  // Recordings are hundreds of megabytes: kept only when a test failed, to look at.
  void TearDown() override {
    if (!HasFailure()) fs::remove_all(dir_);
  }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  static std::string scenario(const std::string& name) { return (test::source_dir() / "scenarios" / (name + ".yaml")).string(); }

  // dis_left_bag's cameras in the empty building (no robots, people or objects), `seconds` long;
  // `pitch_deg` replaces the corridor camera's pitch when given.
  std::string empty_scenario(const std::string& name, double seconds, std::optional<int> pitch_deg = std::nullopt) const {
    std::string text = test::slurp(scenario("dis_left_bag"));
    text = text.substr(0, text.find("\nrobots:"));
    text = std::regex_replace(text, std::regex("\\.\\./maps/"), (test::source_dir() / "maps").string() + "/");
    text = std::regex_replace(text, std::regex("duration: [0-9.]+"), "duration: " + std::to_string(seconds));
    if (pitch_deg) text = std::regex_replace(text, std::regex("pitch_deg: 15"), "pitch_deg: " + std::to_string(*pitch_deg));
    std::ofstream(path(name)) << text << "\n";
    return path(name);
  }

  // Renders `frames` frames of a scenario camera into DIR (left_%06d.png, right_%06d.png, rig.yaml).
  void render(const std::string& sc, const std::string& dir, int frames) const {
    const Output o = vigil_cmd("render " + sc + " --camera cam_corridor --frames " + std::to_string(frames) + " --out " + dir);
    ASSERT_EQ(o.code, 0) << o.out;
  }

  static std::string pairs(const std::string& dir, const std::string& rig) {
    return "stereo:" + dir + "/left_%06d.png," + dir + "/right_%06d.png," + rig;
  }

  // The rendered rig file with its pose removed: what `vigil calibrate stereo` would hand over.
  std::string bare_rig(const std::string& from, const std::string& name) const {
    auto c = vision::load_stereo_calibration(from);
    EXPECT_TRUE(c.ok()) << c.error().str();
    c->pose.reset();
    EXPECT_TRUE(vision::save_stereo_calibration(path(name), *c).ok());
    return path(name);
  }

  fs::path dir_;
};

vision::StereoCalibration load(const std::string& p) {
  auto c = vision::load_stereo_calibration(p);
  EXPECT_TRUE(c.ok()) << c.error().str();
  return c.ok() ? *c : vision::StereoCalibration{};
}

// "RMS reprojection error X px (stereo)" from the command's output.
double printed_rms(const std::string& out) {
  std::smatch m;
  if (!std::regex_search(out, m, std::regex("RMS reprojection error ([0-9.]+) px \\(stereo\\)"))) return -1;
  return std::stod(m[1]);
}

TEST_F(RigTest, CalibrateStereoOnTheRealChessboardPairs) {
  VIGIL_REQUIRE_SHARED_DATA();
  const std::string real = (test::shared_data() / "real").string();
  const std::string files = "--left '" + real + "/left%02d.jpg' --right '" + real + "/right%02d.jpg' --board 9x6 --square 0.025";
  // With the library's former fixed corner window (11 px): the library's own figure, 0.44 px.
  const Output fixed = vigil_cmd("calibrate stereo " + files + " --corner-window 11 --out " + path("fixed.yaml"));
  ASSERT_EQ(fixed.code, 0) << fixed.out;
  std::vector<std::string> left, right;
  for (int i : {1, 2, 3, 4, 5, 6, 7, 8, 9, 11, 12, 13, 14}) {
    char name[32];
    std::snprintf(name, sizeof name, "/left%02d.jpg", i);
    left.push_back(real + name);
    std::snprintf(name, sizeof name, "/right%02d.jpg", i);
    right.push_back(real + name);
  }
  vision::ChessboardParams board;
  board.subpixel_window = 11;
  vision::StereoCalibrationReport rep;
  ASSERT_TRUE(vision::calibrate_stereo_chessboard(left, right, board, &rep).ok());
  EXPECT_NEAR(printed_rms(fixed.out), rep.stereo_rms, 6e-4) << fixed.out;
  EXPECT_NEAR(printed_rms(fixed.out), 0.44, 0.01) << fixed.out;
  // Every pair is listed with its own errors.
  const std::regex per_pair("reprojection RMS [0-9.]+ px left");
  EXPECT_EQ(std::distance(std::sregex_iterator(fixed.out.begin(), fixed.out.end(), per_pair), std::sregex_iterator()), 13)
      << fixed.out;

  // The default window follows the corner spacing: better corners, a lower RMS.
  const Output o = vigil_cmd("calibrate stereo " + files + " --out " + path("rig/rig.yaml"));
  ASSERT_EQ(o.code, 0) << o.out;
  const double rms = printed_rms(o.out);
  EXPECT_GT(rms, 0.05);
  EXPECT_LT(rms, printed_rms(fixed.out)) << o.out;
  const vision::StereoCalibration c = load(path("rig/rig.yaml"));
  EXPECT_TRUE(c.has_rectification());
  EXPECT_FALSE(c.pose.has_value());
  EXPECT_NEAR(c.rms, rms, 6e-4);
  const cv::Mat picture = cv::imread(path("rig/rig_rectified.png"));
  EXPECT_EQ(picture.size(), cv::Size(1280, 480));
}

TEST_F(RigTest, RenderedChessboardViewsGiveBackTheScenarioCamera) {
  const std::string views = path("views");
  Output o = vigil_cmd("render " + scenario("dis_left_bag") + " --camera cam_corridor --chessboard 9x6 --square 0.06 --views 24 --out " +
                       views);
  ASSERT_EQ(o.code, 0) << o.out;
  o = vigil_cmd("calibrate stereo --left '" + views + "/left_%06d.png' --right '" + views +
                "/right_%06d.png' --board 9x6 --square 0.06 --out " + path("rig.yaml"));
  ASSERT_EQ(o.code, 0) << o.out;
  EXPECT_NE(o.out.find("used 24 of 24 pairs"), std::string::npos) << o.out;
  const vision::StereoCalibration truth = load(views + "/rig.yaml");  // the camera's ideal rig
  const vision::StereoCalibration c = load(path("rig.yaml"));
  const double fx = truth.K1.at<double>(0, 0), baseline = -truth.T.at<double>(0);
  for (const cv::Mat* k : {&c.K1, &c.K2}) {
    EXPECT_NEAR(k->at<double>(0, 0), fx, 0.01 * fx);
    EXPECT_NEAR(k->at<double>(1, 1), fx, 0.01 * fx);
    EXPECT_NEAR(k->at<double>(0, 2), truth.K1.at<double>(0, 2), 2.0);
    EXPECT_NEAR(k->at<double>(1, 2), truth.K1.at<double>(1, 2), 2.0);
  }
  EXPECT_NEAR(cv::norm(c.T), baseline, 0.01 * baseline);
  // The same views as two lossless videos (a rig that records video): every frame pair used.
  {
    cv::VideoWriter lv(path("left.avi"), cv::CAP_FFMPEG, cv::VideoWriter::fourcc('F', 'F', 'V', '1'), 15, cv::Size(640, 480));
    cv::VideoWriter rv(path("right.avi"), cv::CAP_FFMPEG, cv::VideoWriter::fourcc('F', 'F', 'V', '1'), 15, cv::Size(640, 480));
    ASSERT_TRUE(lv.isOpened() && rv.isOpened());
    for (int i = 0; i < 24; ++i) {
      char name[32];
      std::snprintf(name, sizeof name, "/left_%06d.png", i);
      lv.write(cv::imread(views + name));
      std::snprintf(name, sizeof name, "/right_%06d.png", i);
      rv.write(cv::imread(views + name));
    }
    lv.write(cv::imread(views + "/left_000000.png"));  // one frame more on the left
  }
  const Output video = vigil_cmd("calibrate stereo --left " + path("left.avi") + " --right " + path("right.avi") +
                                 " --every 1 --board 9x6 --square 0.06 --out " + path("video/rig.yaml"));
  EXPECT_EQ(video.code, 2) << video.out;  // the left video is one frame longer
  EXPECT_NE(video.out.find("before the other one"), std::string::npos) << video.out;
  {
    cv::VideoWriter lv(path("left.avi"), cv::CAP_FFMPEG, cv::VideoWriter::fourcc('F', 'F', 'V', '1'), 15, cv::Size(640, 480));
    for (int i = 0; i < 24; ++i) {
      char name[32];
      std::snprintf(name, sizeof name, "/left_%06d.png", i);
      lv.write(cv::imread(views + name));
    }
  }
  const Output video2 = vigil_cmd("calibrate stereo --left " + path("left.avi") + " --right " + path("right.avi") +
                                  " --every 1 --board 9x6 --square 0.06 --out " + path("video/rig.yaml"));
  ASSERT_EQ(video2.code, 0) << video2.out;
  EXPECT_NE(video2.out.find("used 24 of 24 pairs"), std::string::npos) << video2.out;
  EXPECT_NEAR(printed_rms(video2.out), printed_rms(o.out), 0.01) << video2.out;

  std::cout << "round trip: fx " << c.K1.at<double>(0, 0) << " (truth " << fx << "), cx " << c.K1.at<double>(0, 2) << ", cy "
            << c.K1.at<double>(1, 2) << " (truth " << truth.K1.at<double>(0, 2) << ", " << truth.K1.at<double>(1, 2)
            << "), baseline " << cv::norm(c.T) << " m (truth " << baseline << "), RMS " << printed_rms(o.out) << " px\n";
}

TEST_F(RigTest, FloorFitOnTheEmptyCorridorGivesTheCameraHeightPitchAndRoll) {
  const std::string frames = path("empty");
  render(empty_scenario("empty.yaml", 2), frames, 5);
  const vision::StereoCalibration truth = load(frames + "/rig.yaml");
  ASSERT_TRUE(truth.pose.has_value());
  const std::string rig = bare_rig(frames + "/rig.yaml", "bare.yaml");
  // Without a pose the rig cannot give map-frame tracks.
  Output o = vigil_cmd("track --source '" + pairs(frames, rig) + ";disparity=sgbm' --out " + path("t") + " --quiet");
  EXPECT_EQ(o.code, 2) << o.out;
  EXPECT_NE(o.out.find("calibrate floor"), std::string::npos) << o.out;

  o = vigil_cmd("calibrate floor --source '" + pairs(frames, rig) + ";disparity=sgbm' --position 27,3.9 --heading 180 --out " +
                path("rig.yaml"));
  ASSERT_EQ(o.code, 0) << o.out;
  const vision::StereoCalibration c = load(path("rig.yaml"));
  ASSERT_TRUE(c.pose.has_value());
  EXPECT_NEAR(c.pose->position.z(), truth.pose->position.z(), 0.02) << o.out;
  EXPECT_NEAR(c.pose->pitch, truth.pose->pitch, 0.5 * kDeg) << o.out;
  EXPECT_NEAR(c.pose->roll, truth.pose->roll, 0.5 * kDeg) << o.out;
  EXPECT_DOUBLE_EQ(c.pose->position.x(), 27);
  EXPECT_NEAR(c.pose->yaw, M_PI, 1e-9);
  std::cout << o.out;

  // Placed from two floor points instead: the pixels where the map points (23, 3.3) and (21, 4.5)
  // are seen.
  const vision::StereoCameraModel model = *vision::rectified_camera_model(truth, *truth.pose);
  std::string points;
  for (const Eigen::Vector3d& p : {Eigen::Vector3d(23, 3.3, 0), Eigen::Vector3d(21, 4.5, 0)}) {
    Eigen::Vector2d px;
    ASSERT_TRUE(model.project_map(p, &px));
    points += " --floor-point " + std::to_string(px.x()) + "," + std::to_string(px.y()) + "," + std::to_string(p.x()) + "," +
              std::to_string(p.y());
  }
  o = vigil_cmd("calibrate floor --source '" + pairs(frames, rig) + ";disparity=sgbm'" + points + " --out " + path("placed.yaml"));
  ASSERT_EQ(o.code, 0) << o.out;
  const vision::StereoCalibration placed = load(path("placed.yaml"));
  ASSERT_TRUE(placed.pose.has_value());
  EXPECT_NEAR(placed.pose->position.x(), 27, 0.05) << o.out;
  EXPECT_NEAR(placed.pose->position.y(), 3.9, 0.05) << o.out;
  EXPECT_NEAR(std::remainder(placed.pose->yaw - M_PI, 2 * M_PI), 0, 0.5 * kDeg) << o.out;
}

TEST_F(RigTest, BadInputNamesTheFileAndKey) {
  // No board anywhere: every pair is named, exit 2.
  fs::create_directories(path("blank"));
  for (int i = 0; i < 3; ++i) {
    char name[32];
    for (const char* side : {"left", "right"}) {
      std::snprintf(name, sizeof name, "/%s%d.png", side, i);
      ASSERT_TRUE(cv::imwrite(path("blank") + name, cv::Mat(120, 160, CV_8UC3, cv::Scalar(128, 128, 128))));
    }
  }
  const std::string blank = path("blank");
  Output o = vigil_cmd("calibrate stereo --left '" + blank + "/left%d.png' --right '" + blank + "/right%d.png' --out " + path("r.yaml"));
  EXPECT_EQ(o.code, 2) << o.out;
  EXPECT_NE(o.out.find("skipped left0.png: board not found in either view"), std::string::npos) << o.out;
  EXPECT_NE(o.out.find("only 0 of 3"), std::string::npos) << o.out;
  EXPECT_FALSE(fs::exists(path("r.yaml")));
  // Mismatched pair counts.
  fs::remove(blank + "/right2.png");
  o = vigil_cmd("calibrate stereo --left '" + blank + "/left%d.png' --right '" + blank + "/right%d.png' --out " + path("r.yaml"));
  EXPECT_EQ(o.code, 2) << o.out;
  EXPECT_NE(o.out.find("--right"), std::string::npos) << o.out;
  EXPECT_NE(o.out.find("2 right images but 3 left"), std::string::npos) << o.out;
  // Mismatched sizes name the image.
  ASSERT_TRUE(cv::imwrite(blank + "/right2.png", cv::Mat(100, 160, CV_8UC3, cv::Scalar(128, 128, 128))));
  o = vigil_cmd("calibrate stereo --left '" + blank + "/left%d.png' --right '" + blank + "/right%d.png' --out " + path("r.yaml"));
  EXPECT_EQ(o.code, 2) << o.out;
  EXPECT_NE(o.out.find("right2.png"), std::string::npos) << o.out;
  EXPECT_NE(o.out.find("160x100"), std::string::npos) << o.out;
  // A malformed board.
  o = vigil_cmd("calibrate stereo --left '" + blank + "/left%d.png' --right '" + blank + "/right%d.png' --board 9by6 --out " +
                path("r.yaml"));
  EXPECT_EQ(o.code, 2) << o.out;
  EXPECT_NE(o.out.find("--board"), std::string::npos) << o.out;

  // A camera looking up at the ceiling: no floor to fit.
  const std::string up = path("up");
  render(empty_scenario("up.yaml", 1, -50), up, 2);
  const std::string rig = bare_rig(up + "/rig.yaml", "up_bare.yaml");
  o = vigil_cmd("calibrate floor --source '" + pairs(up, rig) + ";disparity=sgbm' --position 27,3.9 --heading 180 --out " +
                path("f.yaml"));
  EXPECT_EQ(o.code, 2) << o.out;
  EXPECT_NE(o.out.find("floor"), std::string::npos) << o.out;
  EXPECT_FALSE(fs::exists(path("f.yaml")));
  // No disparity asked for; no heading given.
  o = vigil_cmd("calibrate floor --source '" + pairs(up, rig) + "' --position 27,3.9 --heading 180 --out " + path("f.yaml"));
  EXPECT_EQ(o.code, 2) << o.out;
  EXPECT_NE(o.out.find("disparity=sgbm"), std::string::npos) << o.out;
  o = vigil_cmd("calibrate floor --source '" + pairs(up, rig) + ";disparity=sgbm' --position 27,3.9 --out " + path("f.yaml"));
  EXPECT_EQ(o.code, 2) << o.out;
  EXPECT_NE(o.out.find("--heading"), std::string::npos) << o.out;

  // A rig file missing a key: the file and the key are named.
  std::string text = test::slurp(up + "/rig.yaml");
  const size_t at = text.find("pose_roll_deg");
  ASSERT_NE(at, std::string::npos);
  text.erase(at, text.find('\n', at) - at + 1);
  std::ofstream(path("partial.yaml")) << text;
  o = vigil_cmd("track --source '" + pairs(up, path("partial.yaml")) + ";disparity=sgbm' --out " + path("t") + " --quiet");
  EXPECT_EQ(o.code, 2) << o.out;
  EXPECT_NE(o.out.find("partial.yaml"), std::string::npos) << o.out;
  EXPECT_NE(o.out.find("pose_roll_deg"), std::string::npos) << o.out;
  o = vigil_cmd("camera-node " + scenario("dis_left_bag") + " --camera cam_corridor --sensor planview --source '" +
                pairs(up, rig) + "' --duration 1");
  EXPECT_EQ(o.code, 2) << o.out;
  EXPECT_NE(o.out.find("pose"), std::string::npos) << o.out;
}

// MOTA of persons and bags (the rendered-tracking protocol of docs/MSER.md and docs/VISION.md).
double mota(const std::string& run_dir, const std::string& tracks) {
  const Output o = vigil_cmd("eval " + run_dir + " --tracks " + tracks + " --scenario " +
                             (test::source_dir() / "scenarios" / "dis_left_bag.yaml").string() +
                             " --camera cam_corridor --max-range 8 --in-view --exclude-carried --classes person bag");
  EXPECT_EQ(o.code, 0) << o.out;
  const auto j = nlohmann::json::parse(test::slurp(fs::path(run_dir) / "eval.json"), nullptr, false);
  return j.is_discarded() ? -1 : j["tracking"]["mota"].get<double>();
}

TEST_F(RigTest, RecordedFramesWithTheCalibratedRigTrackAsRenderedOnesAndFeedEvents) {
  // 1. The rig: chessboard views, calibration, then the pose from the empty corridor placed by
  //    two floor points (pixels of the recorded, unrectified left image).
  const std::string views = path("views");
  Output o = vigil_cmd("render " + scenario("dis_left_bag") + " --camera cam_corridor --chessboard 9x6 --views 24 --out " + views);
  ASSERT_EQ(o.code, 0) << o.out;
  o = vigil_cmd("calibrate stereo --left '" + views + "/left_%06d.png' --right '" + views +
                "/right_%06d.png' --board 9x6 --square 0.06 --out " + path("rig.yaml"));
  ASSERT_EQ(o.code, 0) << o.out;
  const std::string empty = path("empty");
  render(empty_scenario("empty.yaml", 2), empty, 5);
  const vision::StereoCalibration truth = load(empty + "/rig.yaml");
  const vision::StereoCameraModel true_model = *vision::rectified_camera_model(truth, *truth.pose);
  std::string points;
  for (const Eigen::Vector3d& p : {Eigen::Vector3d(23, 3.3, 0), Eigen::Vector3d(21, 4.5, 0), Eigen::Vector3d(22, 3.9, 0)}) {
    Eigen::Vector2d px;
    ASSERT_TRUE(true_model.project_map(p, &px));
    points += " --floor-point " + std::to_string(px.x()) + "," + std::to_string(px.y()) + "," + std::to_string(p.x()) + "," +
              std::to_string(p.y());
  }
  o = vigil_cmd("calibrate floor --source '" + pairs(empty, path("rig.yaml")) + ";disparity=sgbm'" + points + " --out " +
                path("rig.yaml"));
  ASSERT_EQ(o.code, 0) << o.out;
  std::cout << o.out;

  // 2. The scenario's camera frames written as files: the recording.
  const int frames = 345;  // 23 s: the bag is left at 15.9 s and due at 20.9 s
  const std::string rec = path("recording");
  render(scenario("dis_left_bag"), rec, frames);

  // 3. Tracks from the recording with the calibrated rig, with the camera's ideal rig file, and
  //    from the rendered source, scored against the same ground truth.
  o = vigil_cmd("track --source '" + pairs(rec, path("rig.yaml")) + ";disparity=sgbm' --camera-id cam_corridor --out " +
                path("recorded") + " --no-video --quiet");
  ASSERT_EQ(o.code, 0) << o.out;
  o = vigil_cmd("track --source '" + pairs(rec, rec + "/rig.yaml") + ";disparity=sgbm' --camera-id cam_corridor --out " +
                path("ideal") + " --no-video --quiet");
  ASSERT_EQ(o.code, 0) << o.out;
  o = vigil_cmd("track --source 'render:" + scenario("dis_left_bag") + ";camera=cam_corridor;disparity=sgbm;frames=" +
                std::to_string(frames) + "' --out " + path("rendered") + " --no-video --quiet");
  ASSERT_EQ(o.code, 0) << o.out;
  o = vigil_cmd("run " + scenario("dis_left_bag") + " --sensor truth --duration 23 --out " + path("truth") + " --no-video --quiet");
  ASSERT_EQ(o.code, 0) << o.out;
  const double recorded = mota(path("truth"), path("recorded/tracks.jsonl"));
  const double ideal = mota(path("truth"), path("ideal/tracks.jsonl"));
  const double rendered = mota(path("truth"), path("rendered/tracks.jsonl"));
  std::cout << "MOTA (person, bag): rendered " << rendered << ", recorded with the ideal rig " << ideal
            << ", with the calibrated rig " << recorded << "\n";
  EXPECT_GT(rendered, 0.5);
  // The same frames through files and the rig file: the same tracking.
  EXPECT_NEAR(ideal, rendered, 0.02);
  // Through the calibrated rig: the tracker sees a slightly different camera, and does no worse
  // than the rendered camera, less 0.02 (the target; measured 2026-12-06: 0.925 against
  // 0.933, docs/RIG.md). A wrong pose or scale would put every track off its truth (MOTA near or
  // below 0).
  EXPECT_GE(recorded, rendered - 0.02);

  // 4. The recording with the calibrated rig through a camera node: the left bag goes out over
  //    DDS as the rendered camera's does.
  o = vigil_cmd("camera-node " + scenario("dis_left_bag") + " --camera cam_corridor --sensor planview --source '" +
                pairs(rec, path("rig.yaml")) + "' --duration 23 --linger 0 --session rig" + std::to_string(::getpid()) +
                " --out " + path("node"));
  ASSERT_EQ(o.code, 0) << o.out;
  EXPECT_NE(o.out.find(std::to_string(frames) + " recorded frames"), std::string::npos) << o.out;
  bool found = false;
  std::ifstream events(path("node/camera_events.jsonl"));
  for (std::string line; std::getline(events, line);) {
    const auto e = nlohmann::json::parse(line, nullptr, false);
    if (e.is_discarded() || e["kind"] != "left_bag") continue;
    const double dx = e["map"][0].get<double>() - 20.887, dy = e["map"][1].get<double>() - 2.650;
    const double t = e["t_ns"].get<double>() * 1e-9;
    found = found || (std::hypot(dx, dy) < 1.0 && t > 19.9 && t < 23.0);  // due at 20.92 s (ground truth)
  }
  EXPECT_TRUE(found) << "no left_bag near (20.89, 2.65) in " << path("node/camera_events.jsonl") << "\n" << o.out;
}

}  // namespace
}  // namespace vigil
