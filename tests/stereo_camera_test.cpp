// The simulator's cameras as frame sources and during runs: the rendered source delivers frames
// at the camera's rate with the world stepped to each one, SGBM disparity from the rendered pair
// agrees with the ground truth, the camera rig renders every camera at its rate during a run,
// feeds consumers and writes byte-identical videos, and bad specs are clear errors.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <opencv2/core.hpp>
#include <opencv2/videoio.hpp>

#include "plugins/builtin.h"
#include "plugins/stereo_camera/stereo_camera.h"
#include "tests/test_util.h"
#include "world/runner.h"
#include "world/sha256.h"

namespace vigil::render {
namespace {

namespace fs = std::filesystem;

std::string scenario_path(const std::string& name) { return (test::source_dir() / "scenarios" / (name + ".yaml")).string(); }

Scenario load(const std::string& name) {
  auto s = load_scenario(scenario_path(name));
  EXPECT_TRUE(s.ok()) << (s.ok() ? "" : s.error().str());
  return *s;
}

std::string file_sha(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return sha256_hex(ss.str());
}

TEST(RenderedSource, DeliversFramesAtTheCameraRateWithTheWorldSteppedToEach) {
  RenderedSourceOptions o;
  o.max_frames = 4;
  auto src = RenderedStereoSource::open(load("dis_left_bag"), "cam_corridor", o);
  ASSERT_TRUE(src.ok()) << src.error().str();
  EXPECT_TRUE((*src)->is_stereo());
  ASSERT_TRUE((*src)->camera_model().has_value());
  EXPECT_NEAR((*src)->camera_model()->baseline(), 0.09, 1e-12);
  EXPECT_NE((*src)->describe().find("cam_corridor"), std::string::npos);
  vision::StereoFrame f;
  int n = 0;
  for (;;) {
    auto more = (*src)->next(&f);
    ASSERT_TRUE(more.ok()) << more.error().str();
    if (!*more) break;
    EXPECT_EQ(f.index, n);
    // 15 Hz: frame n at the first physics step at or after n / 15 s (100 Hz steps).
    const SimTime tick = from_seconds(n / 15.0);
    EXPECT_GE(f.stamp_ns, tick);
    EXPECT_LT(f.stamp_ns, tick + from_seconds(0.01) + 1);
    EXPECT_EQ((*src)->world().time(), f.stamp_ns);
    EXPECT_EQ(f.left.size(), cv::Size(640, 480));
    EXPECT_EQ(f.right.size(), cv::Size(640, 480));
    EXPECT_EQ(f.depth.type(), CV_32F);
    EXPECT_EQ(f.labels.type(), CV_32S);
    ++n;
  }
  EXPECT_EQ(n, 4);
}

TEST(RenderedSource, SgbmDisparityFromTheRenderedPairAgreesWithTheTruth) {
  // The same instant twice: ground-truth disparity, then SGBM on the rendered pair.
  auto truth = open_any_frame_source("render:" + scenario_path("dis_left_bag") + ";camera=cam_corridor;frames=1");
  ASSERT_TRUE(truth.ok()) << truth.error().str();
  auto sgbm = open_any_frame_source("render:" + scenario_path("dis_left_bag") +
                                    ";camera=cam_corridor;frames=1;disparity=sgbm;num_disparities=64");
  ASSERT_TRUE(sgbm.ok()) << sgbm.error().str();
  EXPECT_NE((*sgbm)->describe().find("SGBM"), std::string::npos);
  vision::StereoFrame t, m;
  ASSERT_TRUE((*truth)->next(&t).ok());
  ASSERT_TRUE((*sgbm)->next(&m).ok());
  ASSERT_EQ(cv::norm(t.left, m.left, cv::NORM_INF), 0);  // same rendering
  // Where both are valid (and inside SGBM's search range), most pixels agree within 1 px.
  int valid = 0, good = 0;
  for (int r = 0; r < t.disparity.rows; ++r) {
    for (int c = 64; c < t.disparity.cols; ++c) {
      const float dt = t.disparity.at<float>(r, c), dm = m.disparity.at<float>(r, c);
      if (dt <= 0 || dt >= 63 || dm <= 0) continue;
      ++valid;
      if (std::abs(dt - dm) <= 1.0f) ++good;
      // Depth follows from disparity through the same model.
      ASSERT_NEAR(m.depth.at<float>(r, c), (*sgbm)->camera_model()->depth_from_disparity(dm), 1e-3);
    }
  }
  std::printf("SGBM on the rendered corridor: %d pixels valid in both, %.1f%% within 1 px of the truth\n", valid,
              100.0 * good / std::max(valid, 1));
  ASSERT_GT(valid, 640 * 480 / 3);
  EXPECT_GT(static_cast<double>(good) / valid, 0.85) << good << " of " << valid;
}

TEST(RenderedSource, EndsWithTheScenario) {
  Scenario sc = load("dis_left_bag");
  sc.duration = 0.2;  // ticks at 0, 1/15, 2/15, 3/15 s
  auto src = RenderedStereoSource::open(sc, "cam_lab");
  ASSERT_TRUE(src.ok()) << src.error().str();
  // Run-time duration is applied by World::create from the scenario.
  vision::StereoFrame f;
  int n = 0;
  while (true) {
    auto more = (*src)->next(&f);
    ASSERT_TRUE(more.ok());
    if (!*more) break;
    ++n;
  }
  EXPECT_EQ(n, 4);
}

TEST(RenderedSource, BadSpecsAreClearErrors) {
  struct Case {
    std::string spec, expect;
  };
  const std::string sc = scenario_path("dis_left_bag");
  const std::vector<Case> cases = {
      {"render:" + sc + ";camera=cam_roof", "cam_roof"},
      {"render:" + sc + ";frames=0", "frames"},
      {"render:" + sc + ";frames=abc", "frames"},
      {"render:" + sc + ";disparity=magic", "magic"},
      {"render:" + sc + ";num_disparities=64", "disparity=sgbm"},
      {"render:" + sc + ";colour=1", "colour"},
      {"render:/no/such/scenario.yaml", "scenario.yaml"},
  };
  for (const Case& c : cases) {
    auto s = open_any_frame_source(c.spec);
    ASSERT_FALSE(s.ok()) << c.spec;
    EXPECT_NE(s.error().str().find(c.expect), std::string::npos) << c.spec << " gave: " << s.error().str();
  }
  // Other schemes go to the vision library.
  auto v = open_any_frame_source("video:/no/such.avi");
  ASSERT_FALSE(v.ok());
  EXPECT_NE(v.error().str().find("/no/such.avi"), std::string::npos);
}

// Counts frames and checks their stamps for one camera.
struct FrameLog {
  std::vector<SimTime> stamps;
  std::vector<SimTime> world_times;
};

TEST(CameraRig, RendersEveryCameraAtItsRateFeedsConsumersAndWritesVideos) {
  Scenario sc = load("dis_left_bag");
  sc.duration = 1.0;
  const fs::path out = fs::temp_directory_path() / "vigil_rig_test";
  fs::remove_all(out);
  std::map<std::string, FrameLog> logs;
  std::map<std::string, cv::Mat> last_left;
  CameraRig rig;
  rig.add_consumer("", [&](const CameraSpec& cam, const vision::StereoFrame& f, const World& w) {
    last_left[cam.id] = f.left.clone();
    logs[cam.id].stamps.push_back(f.stamp_ns);
    logs[cam.id].world_times.push_back(w.time());
    EXPECT_EQ(f.index, static_cast<int64_t>(logs[cam.id].stamps.size()) - 1);
    return Status::Ok();
  });
  RunOptions ro;
  ro.world.plugins = builtin_plugin_registry();
  ro.out_dir = out;
  ro.observers.push_back(&rig);
  auto sum = run_scenario(sc, ro);
  ASSERT_TRUE(sum.ok()) << sum.error().str();
  ASSERT_EQ(logs.size(), 2u);
  for (const auto& [id, log] : logs) {
    // 0, 1/15, ..., 15/15 s: 16 frames in one second at 15 Hz.
    EXPECT_EQ(log.stamps.size(), 16u) << id;
    EXPECT_EQ(log.stamps, log.world_times) << id;
    EXPECT_EQ(rig.frames().at(id), 16) << id;
    // H.264 in MP4 by default: every frame there, at the camera's size, close to what was rendered.
    cv::VideoCapture cap((out / "cameras" / (id + ".mp4")).string());
    ASSERT_TRUE(cap.isOpened()) << id;
    EXPECT_EQ(static_cast<int>(cap.get(cv::CAP_PROP_FRAME_COUNT)), 16) << id;
    EXPECT_EQ(static_cast<int>(cap.get(cv::CAP_PROP_FRAME_WIDTH)), 640);
    EXPECT_EQ(static_cast<int>(cap.get(cv::CAP_PROP_FRAME_HEIGHT)), 480);
    cv::Mat decoded;
    int n = 0;
    while (cap.read(decoded)) ++n;
    EXPECT_EQ(n, 16) << id;
    EXPECT_FALSE(fs::exists(out / "cameras" / (id + ".avi"))) << id;
  }
  // The last frame the rig rendered against the last one decoded: H.264 at CRF 23 keeps the look.
  {
    cv::VideoCapture cap((out / "cameras" / "cam_corridor.mp4").string());
    cv::Mat f, last;
    while (cap.read(f)) last = f.clone();
    ASSERT_FALSE(last.empty());
    ASSERT_EQ(last.size(), last_left["cam_corridor"].size());
    EXPECT_GT(cv::PSNR(last, last_left["cam_corridor"]), 30.0);
  }
  // Same scenario, same seed: the same bytes in the camera videos.
  const std::string first = file_sha(out / "cameras" / "cam_corridor.mp4");
  CameraRig again;
  ro.observers = {&again};
  ASSERT_TRUE(run_scenario(sc, ro).ok());
  EXPECT_EQ(file_sha(out / "cameras" / "cam_corridor.mp4"), first);
  // AVI on request: MJPEG, also byte-identical run to run.
  fs::remove_all(out);
  CameraRigOptions avi_options;
  avi_options.video_format = VideoFormat::kAvi;
  CameraRig avi(avi_options), avi_again(avi_options);
  ro.observers = {&avi};
  ASSERT_TRUE(run_scenario(sc, ro).ok());
  cv::VideoCapture mjpg((out / "cameras" / "cam_corridor.avi").string());
  ASSERT_TRUE(mjpg.isOpened());
  EXPECT_EQ(static_cast<int>(mjpg.get(cv::CAP_PROP_FRAME_COUNT)), 16);
  EXPECT_EQ(static_cast<int>(mjpg.get(cv::CAP_PROP_FOURCC)), cv::VideoWriter::fourcc('M', 'J', 'P', 'G'));
  const std::string avi_first = file_sha(out / "cameras" / "cam_corridor.avi");
  ro.observers = {&avi_again};
  ASSERT_TRUE(run_scenario(sc, ro).ok());
  EXPECT_EQ(file_sha(out / "cameras" / "cam_corridor.avi"), avi_first);
  fs::remove_all(out);
}

// Cameras on threads of their own (the default) or one after the other: the same frames reach
// the workers and, in camera order, the consumers; each worker runs before its camera's
// consumers see the frame.
TEST(CameraRig, CameraThreadsGiveTheSameFramesInTheSameOrder) {
  Scenario sc = load("dis_left_bag");
  sc.duration = 0.6;
  for (auto& c : sc.cameras) {
    c.width = 160;
    c.height = 120;
  }
  auto run = [&](bool threads, std::vector<std::string>* order) {
    CameraRigOptions o;
    o.video = false;
    o.camera_threads = threads;
    CameraRig rig(o);
    std::map<std::string, std::string> worked;  // camera -> the hash its worker saw last
    std::map<std::string, std::string> hashes;
    for (const char* id : {"cam_corridor", "cam_lab"}) worked[id];
    rig.add_worker("", [&worked](const CameraSpec& cam, const vision::StereoFrame& f, const World&) {
      // Each camera's worker writes only its own entry (made before the run).
      worked.at(cam.id) = sha256_hex(std::string_view(reinterpret_cast<const char*>(f.left.data), f.left.total() * f.left.elemSize()));
      return Status::Ok();
    });
    rig.add_consumer("", [&](const CameraSpec& cam, const vision::StereoFrame& f, const World&) {
      const std::string h = sha256_hex(std::string_view(reinterpret_cast<const char*>(f.left.data), f.left.total() * f.left.elemSize()));
      EXPECT_EQ(worked.at(cam.id), h) << "the consumer ran before the worker on " << cam.id;
      order->push_back(cam.id + ":" + std::to_string(f.index) + ":" + h);
      return Status::Ok();
    });
    RunOptions ro;
    ro.world.plugins = builtin_plugin_registry();
    ro.video = false;
    ro.observers = {&rig};
    auto sum = run_scenario(sc, ro);
    EXPECT_TRUE(sum.ok()) << (sum.ok() ? "" : sum.error().str());
  };
  std::vector<std::string> threaded, serial;
  run(true, &threaded);
  run(false, &serial);
  ASSERT_EQ(threaded.size(), 2u * 10u);  // 0 .. 0.6 s at 15 Hz, both cameras
  EXPECT_EQ(threaded, serial);
  for (size_t i = 0; i < threaded.size(); ++i)
    EXPECT_EQ(threaded[i].rfind(i % 2 == 0 ? "cam_corridor" : "cam_lab", 0), 0u) << threaded[i];
}

TEST(CameraRig, CamerasAtDifferentRatesTickEachAtItsOwn) {
  Scenario sc = load("dis_left_bag");
  sc.duration = 1.0;
  for (auto& c : sc.cameras) {
    if (c.id == "cam_lab") c.rate_hz = 5;  // cam_corridor stays at 15 Hz
    c.width = 160;                          // small frames: the test is about timing
    c.height = 120;
  }
  std::map<std::string, std::vector<SimTime>> stamps;
  CameraRigOptions o;
  o.video = false;
  CameraRig rig(o);
  rig.add_consumer("", [&](const CameraSpec& cam, const vision::StereoFrame& f, const World& w) {
    EXPECT_EQ(f.stamp_ns, w.time());
    stamps[cam.id].push_back(f.stamp_ns);
    return Status::Ok();
  });
  RunOptions ro;
  ro.world.plugins = builtin_plugin_registry();
  ro.video = false;
  ro.observers = {&rig};
  ASSERT_TRUE(run_scenario(sc, ro).ok());
  // 0, 0.2, ..., 1.0 s: 6 frames at 5 Hz; 16 at 15 Hz.
  ASSERT_EQ(stamps["cam_lab"].size(), 6u);
  for (size_t i = 0; i < 6; ++i) EXPECT_EQ(stamps["cam_lab"][i], static_cast<SimTime>(i) * 200'000'000);
  EXPECT_EQ(stamps["cam_corridor"].size(), 16u);
}

TEST(CameraRig, ConsumerErrorsStopTheRun) {
  Scenario sc = load("dis_left_bag");
  sc.duration = 1.0;
  CameraRigOptions o;
  o.video = false;
  CameraRig rig(o);
  EXPECT_FALSE(CameraRig(o).active());
  rig.add_consumer("cam_lab", [](const CameraSpec&, const vision::StereoFrame& f, const World&) -> Status {
    if (f.index == 3) return bad_input("cam_lab", 0, "frame", "consumer refused frame 3");
    return Status::Ok();
  });
  EXPECT_TRUE(rig.active());
  RunOptions ro;
  ro.world.plugins = builtin_plugin_registry();
  ro.observers.push_back(&rig);
  auto sum = run_scenario(sc, ro);
  ASSERT_FALSE(sum.ok());
  EXPECT_NE(sum.error().str().find("frame 3"), std::string::npos);
  // Only the camera with a consumer was rendered.
  EXPECT_EQ(rig.frames().count("cam_corridor"), 0u);
}

}  // namespace
}  // namespace vigil::render
