// Tests the `vigil` command line as a user runs it: `vigil run` writes ground_truth.jsonl,
// summary.json and the top-down video, twice with the same seed gives identical bytes and hash,
// another seed with noise gives another hash; every shipped scenario validates; malformed
// scenarios exit 2 with a message naming the file and line or key.
#include <gtest/gtest.h>

#include <opencv2/videoio.hpp>

#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <map>
#include <set>
#include <sstream>

#include "tests/test_util.h"
#include "world/sha256.h"

namespace vigil {
namespace {

namespace fs = std::filesystem;
using test::Output;
using test::slurp;
using test::vigil_cmd;

fs::path temp_dir(const std::string& name) { return test::fresh_temp_dir("cli", name); }

fs::path scenario(const std::string& name) { return test::source_dir() / "scenarios" / (name + ".yaml"); }

}  // namespace

TEST(Cli, EveryShippedScenarioValidates) {
  std::string files;
  int n = 0;
  for (const auto& e : fs::directory_iterator(test::source_dir() / "scenarios")) {
    if (e.path().extension() != ".yaml") continue;
    if (e.path().filename().string().rfind("many_robots", 0) == 0 && !test::have_shared_data()) continue;
    files += " " + e.path().string();
    ++n;
  }
  ASSERT_GE(n, 3);
  const Output o = vigil_cmd("validate" + files);
  EXPECT_EQ(o.code, 0) << o.out;
}

// The soak's memory log (tools/soak.sh): a sample every 10 s of simulated time, the picture and
// the figures beside it, and the same ground truth as without it; an unwritable log is exit 2.
TEST(Cli, RunMemoryLogSamplesEveryTenSimulatedSeconds) {
  const fs::path a = temp_dir("mem_a"), b = temp_dir("mem_b");
  const std::string sc = scenario("dis_patrol_team").string();
  const Output with = vigil_cmd("run " + sc + " --out " + a.string() + " --duration 35 --no-video --quiet --memory-log " +
                                (a / "memory.csv").string());
  ASSERT_EQ(with.code, 0) << with.out;
  EXPECT_NE(with.out.find("memory: "), std::string::npos) << with.out;
  std::istringstream csv(slurp(a / "memory.csv"));
  std::string line;
  std::getline(csv, line);
  EXPECT_EQ(line, "sim_s,wall_s,rss_mb,heap_mb");
  std::vector<double> times;
  while (std::getline(csv, line)) {
    double t = 0, wall = 0, mb = 0, heap = 0;
    ASSERT_EQ(std::sscanf(line.c_str(), "%lf,%lf,%lf,%lf", &t, &wall, &mb, &heap), 4) << line;
    // glibc's heap in use; 0 under AddressSanitizer, whose allocator replaces malloc.
    EXPECT_GE(heap, 0.0);
    EXPECT_LT(heap, mb * 2);
    EXPECT_GT(mb, 10.0) << "a resident set of a few MB is not this process's";
    times.push_back(t);
  }
  ASSERT_EQ(times.size(), 5u) << "0, 10, 20, 30 s and the end";
  EXPECT_NEAR(times[1], 10.0, 0.05);
  EXPECT_NEAR(times.back(), 35.0, 0.05);
  EXPECT_TRUE(fs::exists(a / "memory.png"));
  const auto fig = nlohmann::json::parse(slurp(a / "memory.json"));
  EXPECT_EQ(fig["samples"], 5);
  EXPECT_TRUE(fig.contains("slope_mb_per_hour"));
  const Output without = vigil_cmd("run " + sc + " --out " + b.string() + " --duration 35 --no-video --quiet");
  ASSERT_EQ(without.code, 0) << without.out;
  EXPECT_EQ(slurp(a / "ground_truth.jsonl"), slurp(b / "ground_truth.jsonl"));
  const Output bad = vigil_cmd("run " + sc + " --out " + b.string() + " --duration 1 --quiet --memory-log /proc/no/such.csv");
  EXPECT_EQ(bad.code, 2) << bad.out;
  EXPECT_NE(bad.out.find("--memory-log"), std::string::npos) << bad.out;
}

TEST(Cli, RunWritesOutputsAndIsDeterministic) {
  const fs::path a = temp_dir("run_a"), b = temp_dir("run_b"), c = temp_dir("run_c");
  const std::string sc = scenario("dis_left_bag").string();
  const Output first = vigil_cmd("run " + sc + " --out " + a.string() + " --duration 8 --quiet");
  ASSERT_EQ(first.code, 0) << first.out;
  const Output second = vigil_cmd("run " + sc + " --out " + b.string() + " --duration 8 --no-video --quiet");
  ASSERT_EQ(second.code, 0) << second.out;
  for (const char* f : {"ground_truth.jsonl", "summary.json", "topdown.mp4", "topdown.png", "cameras/cam_corridor.mp4",
                        "cameras/cam_lab.mp4"})
    EXPECT_TRUE(fs::exists(a / f)) << f;
  EXPECT_FALSE(fs::exists(b / "topdown.mp4"));
  const Output mkv = vigil_cmd("run " + sc + " --out " + c.string() + " --video-format mkv --quiet");
  EXPECT_EQ(mkv.code, 2) << mkv.out;
  EXPECT_NE(mkv.out.find("--video-format"), std::string::npos) << mkv.out;
  EXPECT_FALSE(fs::exists(b / "cameras"));
  const std::string gt_a = slurp(a / "ground_truth.jsonl"), gt_b = slurp(b / "ground_truth.jsonl");
  ASSERT_FALSE(gt_a.empty());
  EXPECT_EQ(gt_a, gt_b);
  const auto sum_a = nlohmann::json::parse(slurp(a / "summary.json"));
  const auto sum_b = nlohmann::json::parse(slurp(b / "summary.json"));
  for (const char* key : {"sim_seconds", "wall_seconds", "real_time_factor", "steps", "seed", "ground_truth_sha256"})
    EXPECT_TRUE(sum_a.contains(key)) << key;
  EXPECT_EQ(sum_a["ground_truth_sha256"], sha256_hex(gt_a));
  EXPECT_EQ(sum_a["ground_truth_sha256"], sum_b["ground_truth_sha256"]);
  EXPECT_DOUBLE_EQ(sum_a["sim_seconds"].get<double>(), 8.0);
  // The shipped scenarios have laser noise and odometry error: another seed, other bytes.
  const Output third = vigil_cmd("run " + sc + " --out " + c.string() + " --duration 8 --seed 99 --no-video --no-scans --quiet");
  ASSERT_EQ(third.code, 0) << third.out;
  // The robots' laser scans: the same bytes for the same seed, one line per scan at the laser's
  // rate (10 Hz, 2 robots, 8 s), the scenario's 271 samples; --no-scans writes none.
  const std::string scans_a = slurp(a / "scans.jsonl");
  EXPECT_EQ(scans_a, slurp(b / "scans.jsonl"));
  EXPECT_FALSE(fs::exists(c / "scans.jsonl"));
  {
    std::istringstream in(scans_a);
    std::map<std::string, int> per_robot;
    for (std::string l; std::getline(in, l);) {
      const auto j = nlohmann::json::parse(l);
      ++per_robot[j["robot"].get<std::string>()];
      EXPECT_EQ(j["ranges"].size(), 271u);
      EXPECT_EQ(j["laser"].size(), 3u);
    }
    ASSERT_EQ(per_robot.size(), 2u);
    for (const auto& [robot, n] : per_robot) EXPECT_NEAR(n, 80, 1) << robot;
  }
  const auto sum_c = nlohmann::json::parse(slurp(c / "summary.json"));
  EXPECT_EQ(sum_c["seed"], 99);
  EXPECT_NE(sum_c["ground_truth_sha256"], sum_a["ground_truth_sha256"]);
  // Each line is JSON with a type; ticks list entities with id, kind and pose.
  std::istringstream lines(gt_a);
  std::string line;
  ASSERT_TRUE(std::getline(lines, line));
  const auto tick = nlohmann::json::parse(line);
  EXPECT_EQ(tick["type"], "tick");
  ASSERT_FALSE(tick["entities"].empty());
  for (const char* key : {"id", "kind", "x", "y", "yaw"}) EXPECT_TRUE(tick["entities"][0].contains(key)) << key;
}

TEST(Cli, ShippedScenariosProduceTheirScriptedEvents) {
  struct Case {
    const char* name;
    std::vector<std::string> kinds;
  };
  const std::vector<Case> cases = {
      {"dis_left_bag", {"left_bag"}},
      {"dis_bag_taken", {"left_bag", "bag_taken"}},
      {"dis_lab_unauthorised", {"unauthorised_object"}},
  };
  for (const auto& c : cases) {
    const fs::path out = temp_dir(std::string("events_") + c.name);
    const Output o = vigil_cmd("run " + scenario(c.name).string() + " --out " + out.string() + " --no-video --quiet");
    ASSERT_EQ(o.code, 0) << c.name << ": " << o.out;
    std::vector<std::string> kinds;
    std::istringstream lines(slurp(out / "ground_truth.jsonl"));
    std::string line;
    while (std::getline(lines, line)) {
      const auto j = nlohmann::json::parse(line);
      if (j["type"] == "event") kinds.push_back(j["kind"]);
    }
    EXPECT_EQ(kinds, c.kinds) << c.name;
  }
}

TEST(Cli, BenchSimReportsRealTimeFactorsBesideStage) {
  const fs::path out = temp_dir("bench") / "bench.json";
  const Output o = vigil_cmd("bench sim --robots 1,5 --seconds 2 --map " +
                             (test::source_dir() / "maps" / "dis_labs.yaml").string() + " --json " + out.string());
  ASSERT_EQ(o.code, 0) << o.out;
  EXPECT_NE(o.out.find("Stage (2008)"), std::string::npos) << o.out;
  const auto j = nlohmann::json::parse(slurp(out));
  ASSERT_EQ(j.size(), 2u);
  EXPECT_EQ(j[1]["robots"], 5);
  EXPECT_DOUBLE_EQ(j[1]["sim_seconds"].get<double>(), 2.0);
  EXPECT_GT(j[1]["real_time_factor"].get<double>(), 0.0);
}

TEST(Cli, RunWithAVisionSensorOnACameraWritesTracks) {
  // dis_left_bag with the fast ground-truth sensor on cam_corridor, written beside the shipped one
  // so its relative paths still resolve.
  std::string text = slurp(scenario("dis_left_bag"));
  const std::string anchor = "    rate_hz: 15\n";
  const size_t at = text.find(anchor);
  ASSERT_NE(at, std::string::npos);
  text.insert(at + anchor.size(), "    plugin: truth\n    params:\n      position_noise: 0.02\n");
  const fs::path sc = test::source_dir() / "scenarios" / ("tmp_cli_truth_" + std::to_string(::getpid()) + ".yaml");
  std::ofstream(sc) << text;
  const fs::path out = temp_dir("truth_run");
  const Output o = vigil_cmd("run " + sc.string() + " --out " + out.string() + " --no-video --quiet");
  std::string broken = text;
  broken.replace(broken.find("plugin: truth"), 13, "plugin: wander");
  std::ofstream(sc) << broken;
  const Output wrong = vigil_cmd("run " + sc.string() + " --out " + temp_dir("truth_wrong").string() + " --no-video --quiet");
  fs::remove(sc);
  ASSERT_EQ(o.code, 0) << o.out;
  ASSERT_TRUE(fs::exists(out / "tracks.jsonl"));
  std::istringstream lines(slurp(out / "tracks.jsonl"));
  std::string line;
  int n = 0;
  std::set<std::string> classes;
  while (std::getline(lines, line)) {
    const auto j = nlohmann::json::parse(line);
    EXPECT_EQ(j["camera"], "cam_corridor");
    classes.insert(j["class"].get<std::string>());
    ++n;
  }
  EXPECT_GT(n, 100);
  EXPECT_TRUE(classes.count("person"));
  EXPECT_TRUE(classes.count("bag"));
  EXPECT_EQ(wrong.code, 2) << wrong.out;
  EXPECT_NE(wrong.out.find("not a vision sensor"), std::string::npos) << wrong.out;
}

// With videos on, each frame sensor's annotated view is written beside the camera's own video;
// --no-video writes neither.
TEST(Cli, RunWritesEachTrackerSAnnotatedViewBesideTheCameraVideo) {
  const fs::path out = temp_dir("mser_video"), quiet = temp_dir("mser_no_video");
  const Output o = vigil_cmd("run " + scenario("dis_left_bag").string() + " --sensor mser --duration 2 --out " + out.string() +
                             " --quiet");
  ASSERT_EQ(o.code, 0) << o.out;
  for (const char* cam : {"cam_corridor", "cam_lab"}) {
    const fs::path v = out / "cameras" / (std::string(cam) + "_mser.mp4");
    ASSERT_TRUE(fs::exists(v)) << v;
    // The view and the segmentation side by side: at least twice the camera's width, one frame
    // per camera frame.
    cv::VideoCapture annotated(v.string()), raw((out / "cameras" / (std::string(cam) + ".mp4")).string());
    ASSERT_TRUE(annotated.isOpened() && raw.isOpened()) << v;
    EXPECT_GE(annotated.get(cv::CAP_PROP_FRAME_WIDTH), 2 * raw.get(cv::CAP_PROP_FRAME_WIDTH));
    cv::Mat frame;
    int frames = 0;
    while (annotated.read(frame)) ++frames;
    EXPECT_EQ(frames, static_cast<int>(raw.get(cv::CAP_PROP_FRAME_COUNT))) << v;
  }
  const Output n = vigil_cmd("run " + scenario("dis_left_bag").string() + " --sensor mser --duration 1 --no-video --out " +
                             quiet.string() + " --quiet");
  ASSERT_EQ(n.code, 0) << n.out;
  EXPECT_FALSE(fs::exists(quiet / "cameras" / "cam_corridor_mser.mp4"));
  EXPECT_TRUE(fs::exists(quiet / "tracks.jsonl"));
}

TEST(Cli, RunWithSensorOnEveryCameraWritesEventsAndEvalScoresThem) {
  const fs::path out = temp_dir("sensor_run");
  Output o = vigil_cmd("run " + scenario("dis_bag_taken").string() + " --sensor truth --out " + out.string() + " --no-video --quiet");
  ASSERT_EQ(o.code, 0) << o.out;
  for (const char* f : {"tracks.jsonl", "camera_events.jsonl", "events.jsonl"}) EXPECT_TRUE(fs::exists(out / f)) << f;
  o = vigil_cmd("eval " + out.string());
  ASSERT_EQ(o.code, 0) << o.out;
  EXPECT_NE(o.out.find("bag_taken"), std::string::npos) << o.out;
  const auto e = nlohmann::json::parse(slurp(out / "eval.json"))["events"];
  EXPECT_EQ(e["truth"], 2);
  EXPECT_EQ(e["matched"], 2);
  EXPECT_DOUBLE_EQ(e["precision"].get<double>(), 1.0);
  o = vigil_cmd("run " + scenario("dis_bag_taken").string() + " --sensor blobs --out " + out.string() + " --no-video --quiet");
  EXPECT_EQ(o.code, 2) << o.out;
  EXPECT_NE(o.out.find("--sensor: 'blobs' is not a vision sensor"), std::string::npos) << o.out;
}

TEST(Cli, TrackRunsThePlanViewPipelineOnARenderedSource) {
  const fs::path out = temp_dir("track");
  const Output o = vigil_cmd("track --source 'render:" + scenario("dis_left_bag").string() +
                             ";camera=cam_corridor;frames=20;disparity=sgbm' --out " + out.string() + " --quiet");
  ASSERT_EQ(o.code, 0) << o.out;
  EXPECT_NE(o.out.find("20 frames"), std::string::npos) << o.out;
  EXPECT_TRUE(fs::exists(out / "tracks.jsonl"));
  EXPECT_TRUE(fs::exists(out / "annotated.mp4"));
  EXPECT_TRUE(fs::exists(out / "annotated_last.png"));
  // AVI on request; an unknown format is bad input naming the option.
  const Output avi = vigil_cmd("track --source 'render:" + scenario("dis_left_bag").string() +
                               ";camera=cam_corridor;frames=3;disparity=sgbm' --video-format avi --out " + out.string() + " --quiet");
  ASSERT_EQ(avi.code, 0) << avi.out;
  EXPECT_TRUE(fs::exists(out / "annotated.avi"));
  const Output webm = vigil_cmd("track --source 'render:" + scenario("dis_left_bag").string() +
                                ";camera=cam_corridor;frames=3' --video-format webm --out " + out.string() + " --quiet");
  EXPECT_EQ(webm.code, 2) << webm.out;
  EXPECT_NE(webm.out.find("--video-format"), std::string::npos) << webm.out;
  // A mono source has no depth: a clear error, exit 2.
  const fs::path g = test::source_dir() / "tests" / "golden" / "dis_left_bag_cam_corridor_t12_left.png";
  const Output mono = vigil_cmd("track --source 'images:" + g.string() + "' --out " + out.string() + " --quiet");
  EXPECT_EQ(mono.code, 2) << mono.out;
  EXPECT_NE(mono.out.find("calibrated stereo source"), std::string::npos) << mono.out;
  const Output missing = vigil_cmd("track --source 'video:/no/such.avi' --out " + out.string() + " --quiet");
  EXPECT_EQ(missing.code, 2) << missing.out;
  EXPECT_NE(missing.out.find("/no/such.avi"), std::string::npos) << missing.out;
}

TEST(Cli, BenchMserTimesTheWholeSystemBesideColourMserOnTheSameFrames) {
  const fs::path out = temp_dir("bench_mser") / "mser.json";
  const Output o = vigil_cmd("bench mser --frames 12 --sizes 160x120 --video /no/such.avi --json " + out.string());
  ASSERT_EQ(o.code, 0) << o.out;
  EXPECT_NE(o.out.find("real-video rows are skipped"), std::string::npos) << o.out;
  EXPECT_NE(o.out.find("whole system (lines, tree, expansion, feed-forward, 4 tracking phases)"), std::string::npos) << o.out;
  const auto j = nlohmann::json::parse(slurp(out));
  ASSERT_EQ(j["speed"].size(), 1u);  // the rendered lab at one size
  const auto& row = j["speed"][0];
  EXPECT_EQ(row["width"], 160);
  EXPECT_GT(row["system_median_ms"].get<double>(), 0.0);
  EXPECT_GT(row["system_colour_mser_median_ms"].get<double>(), 0.0);
  EXPECT_LE(row["system_speedup_over_colour_faster_median"].get<double>(), row["system_speedup_over_colour"].get<double>() + 1e-9);
  // The pipeline is the system and more.
  EXPECT_GE(row["pipeline_median_ms"].get<double>(), row["system_median_ms"].get<double>());
  ASSERT_EQ(j["quality"].size(), 3u);
  for (const auto& q : j["quality"]) EXPECT_GT(q["boundary_recall"].get<double>(), 0.0) << q.dump();
  const Output bad = vigil_cmd("bench mser --sizes 320by240 --video /no/such.avi");
  EXPECT_EQ(bad.code, 2) << bad.out;
  EXPECT_NE(bad.out.find("--sizes"), std::string::npos) << bad.out;
}

TEST(Cli, BenchRenderReportsPairsPerSecondBesideThePlainScene) {
  const fs::path out = temp_dir("bench_render") / "render.json";
  const Output o = vigil_cmd("bench render --pairs 3 --sizes 160x120,80x60 --at 5 --json " + out.string());
  ASSERT_EQ(o.code, 0) << o.out;
  EXPECT_NE(o.out.find("plain, 50 primitives"), std::string::npos) << o.out;
  const auto j = nlohmann::json::parse(slurp(out));
  ASSERT_EQ(j.size(), 2u);
  EXPECT_EQ(j[0]["width"], 160);
  EXPECT_EQ(j[1]["height"], 60);
  EXPECT_EQ(j[0]["plain_scene_primitives"], 50);
  EXPECT_GT(j[0]["primitives"].get<int>(), 100);  // the corridor with ten people
  EXPECT_GT(j[0]["pairs_per_second"].get<double>(), 0.0);
  EXPECT_GT(j[0]["plain_scene_pairs_per_second"].get<double>(), 0.0);
  const Output bad = vigil_cmd("bench render --sizes 640by480");
  EXPECT_EQ(bad.code, 2) << bad.out;
  EXPECT_NE(bad.out.find("--sizes"), std::string::npos) << bad.out;
}

TEST(Cli, BenchStereoTimesOurMatcherBesideOpenCv) {
  // The rendered golden pair stands in for aloe, so this runs without ../shared/data.
  const fs::path g = test::source_dir() / "tests" / "golden";
  const fs::path out = temp_dir("bench_stereo") / "stereo.json";
  const Output o = vigil_cmd("bench stereo --repeats 2 --left " + (g / "dis_left_bag_cam_corridor_t12_left.png").string() +
                             " --right " + (g / "dis_left_bag_cam_corridor_t12_right.png").string() + " --json " +
                             out.string());
  ASSERT_EQ(o.code, 0) << o.out;
  const auto j = nlohmann::json::parse(slurp(out));
  ASSERT_EQ(j.size(), 3u);
  EXPECT_EQ(j[0]["matcher"], "SGBM");
  EXPECT_EQ(j[1]["matcher"], "BM");
  EXPECT_EQ(j[2]["matcher"], "SGBM+h");  // with the half-pixel pass: two SGBM passes
  EXPECT_EQ(j[0]["width"], 640);
  EXPECT_GT(j[1]["opencv_direct_median_ms"].get<double>(), 0.0);
  const Output bad = vigil_cmd("bench stereo --left /no/such.png --right /no/such.png");
  EXPECT_EQ(bad.code, 2) << bad.out;
  EXPECT_NE(bad.out.find("/no/such.png"), std::string::npos) << bad.out;
}

TEST(Cli, MalformedScenariosExitTwoNamingFileAndLineOrKey) {
  const fs::path dir = temp_dir("bad");
  const std::string map = (test::source_dir() / "maps" / "dis_labs.floorplan.yaml").string();
  struct Case {
    const char* name;
    std::string text;
    std::string expect;  // must appear in the message
  };
  const std::string head = "name: bad\nmap: " + map + "\nduration: 10\n";
  const std::vector<Case> cases = {
      {"empty", "", "empty.yaml"},
      {"syntax", "name: [unclosed\nmap: x\n", "syntax.yaml:"},
      {"unknown_key", head + "durration: 5\n", "unknown_key.yaml:4"},
      {"wrong_type", "name: bad\nmap: " + map + "\nduration: soon\n", "wrong_type.yaml:3"},
      {"missing_map", "name: bad\nmap: /nonexistent/map.yaml\nduration: 10\n", "missing_map.yaml:2"},
      {"negative_duration", "name: bad\nmap: " + map + "\nduration: -5\n", "duration"},
      {"unknown_place", head + "people:\n  - id: A\n    start: nowhere_at_all\n", "nowhere_at_all"},
  };
  for (const auto& c : cases) {
    const fs::path f = dir / (std::string(c.name) + ".yaml");
    std::ofstream(f) << c.text;
    const Output o = vigil_cmd("validate " + f.string());
    EXPECT_EQ(o.code, 2) << c.name << ": " << o.out;
    EXPECT_NE(o.out.find(c.expect), std::string::npos) << c.name << ": " << o.out;
    const Output r = vigil_cmd("run " + f.string() + " --out " + (dir / "out").string() + " --quiet");
    EXPECT_EQ(r.code, 2) << c.name << ": " << r.out;
  }
  // An unknown controller plugin.
  const fs::path f = dir / "plugin.yaml";
  std::ofstream(f) << head << "robots:\n  - id: r1\n    urdf: " << (test::source_dir() / "maps/robots/erratic.urdf").string()
                   << "\n    start: patrol_1\n    controller: no_such_controller\n";
  const Output o = vigil_cmd("validate " + f.string());
  EXPECT_EQ(o.code, 2) << o.out;
  EXPECT_NE(o.out.find("no_such_controller"), std::string::npos) << o.out;
  EXPECT_NE(o.out.find("plugin.yaml:"), std::string::npos) << o.out;
}

}  // namespace vigil
