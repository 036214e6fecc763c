// Tests `vigil eval` as a user runs it: on a run folder built by hand (ground_truth.jsonl and
// tracks.jsonl whose metrics are worked out below) it writes eval.json with the overall and
// per-class figures, keeps eval.json's other keys, and gives the same bytes twice; the range,
// field-of-view, class and scenario-camera options; `--mot-gt/--mot-test` prints py-motmetrics' figures as
// JSON; bad input (missing or malformed files, missing options) exits 2 naming file and line.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "tests/test_util.h"

namespace vigil {
namespace {

namespace fs = std::filesystem;
using test::Output;
using test::slurp;
using test::vigil_cmd;

fs::path temp_dir(const std::string& name) { return test::fresh_temp_dir("eval", name); }

std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4f", v);
  return buf;
}

std::string track_line(int64_t t_ns, const std::string& camera, int id, const std::string& cls, double x, double y) {
  return "{\"t_ns\":" + std::to_string(t_ns) + ",\"camera\":\"" + camera + "\",\"id\":" + std::to_string(id) +
         ",\"class\":\"" + cls + "\",\"x\":" + num(x) + ",\"y\":" + num(y) +
         ",\"vx\":0.0000,\"vy\":0.0000,\"height\":1.0000,\"width\":0.5000,\"confidence\":0.9000}\n";
}

// A run of ten 100 ms ticks: person A walks along y = 2 from x = 1 (0.1 m per tick), bag1
// stands at (5, 2), robot r1 at (8, 2). Camera cam_a reports at the ticks:
//   track 1 on A (0.1 m off) for ticks 0-4, then track 2 for ticks 5-9: one switch;
//   track 3 on bag1 (0.2 m off) except at tick 3: one miss, one fragmentation;
//   track 4, a person at (20, 20) at tick 7: one false positive; r1 untracked: ten misses.
// Overall: 30 ground-truth instances, 19 matched, 11 missed, 1 false positive, 1 switch:
//   MOTA = 1 - (11 + 1 + 1) / 30 = 17/30; MOTP = (10 * 0.1 + 9 * 0.2) / 19 m;
//   IDTP = 5 (A with track 1 or 2) + 9 (bag1 with track 3) = 14 of 30 truths and 20 tracks:
//   IDF1 = 28/50, IDP = 14/20, IDR = 14/30; MT 2 (A, bag1), ML 1 (r1).
// person: MOTA 1 - 2/10, IDF1 10/21; bag: MOTA 0.9, MOTP 0.2, 1 fragmentation; robot: MOTA 0.
fs::path make_run(const std::string& name) {
  const fs::path dir = temp_dir(name);
  std::ofstream gt(dir / "ground_truth.jsonl", std::ios::binary);
  std::ofstream tr(dir / "tracks.jsonl", std::ios::binary);
  for (int k = 0; k < 10; ++k) {
    const int64_t t = k * 100000000LL;
    const double ax = 1.0 + 0.1 * k;
    gt << "{\"type\":\"tick\",\"t_ns\":" << t << ",\"entities\":["
       << "{\"id\":\"r1\",\"kind\":\"robot\",\"x\":8.0000,\"y\":2.0000,\"yaw\":0.0000,\"odom\":[8.0000,2.0000,0.0000]},"
       << "{\"id\":\"A\",\"kind\":\"person\",\"x\":" << num(ax) << ",\"y\":2.0000,\"yaw\":0.0000},"
       << "{\"id\":\"bag1\",\"kind\":\"bag\",\"x\":5.0000,\"y\":2.0000,\"z\":0.0000,\"yaw\":0.0000}]}\n";
    tr << track_line(t, "cam_a", k < 5 ? 1 : 2, "person", ax, 2.1);
    if (k != 3) tr << track_line(t, "cam_a", 3, "bag", 5.2, 2.0);
    if (k == 7) tr << track_line(t, "cam_a", 4, "person", 20, 20);
  }
  gt << "{\"type\":\"action\",\"t_ns\":0,\"person\":\"A\",\"action\":\"appear\"}\n";
  gt << "{\"type\":\"event\",\"kind\":\"left_bag\",\"t_ns\":500000000,\"confirmed_ns\":900000000,\"people\":[\"A\"],"
        "\"object\":\"bag1\",\"owner\":\"A\",\"x\":5.0000,\"y\":2.0000,\"z\":0.0000}\n";
  return dir;
}

TEST(EvalCli, EventsArePrecisionRecallLatencyAndErrorPerKind) {
  // One true left bag (due at 0.9 s at (5, 2)); reports: that left bag 0.6 s late and 0.1 m off,
  // a cancellation (not a report), and a false bag_taken. No tracks.jsonl: events alone are enough.
  const fs::path run = make_run("events");
  fs::remove(run / "tracks.jsonl");
  {
    std::ofstream ev(run / "events.jsonl", std::ios::binary);
    ev << R"({"t_ns":1500000000,"id":1,"kind":"left_bag","camera":"cam_a","map":[5.1,2.0,0.2],"people":[1],"confidence":0.9})" "\n"
       << R"({"t_ns":1600000000,"id":1,"kind":"left_bag","cancelled":true,"camera":"cam_a","map":[5.1,2.0,0.2]})" "\n"
       << R"({"t_ns":1700000000,"id":2,"kind":"bag_taken","camera":"cam_a","map":[9.0,2.0,0.2],"people":[3]})" "\n";
  }
  Output o = vigil_cmd("eval " + run.string());
  ASSERT_EQ(o.code, 0) << o.out;
  EXPECT_NE(o.out.find("left_bag"), std::string::npos) << o.out;
  std::ifstream f(run / "eval.json");
  const auto j = nlohmann::json::parse(f);
  ASSERT_TRUE(j.contains("events")) << j.dump(2);
  EXPECT_FALSE(j.contains("tracking"));
  const auto& e = j["events"];
  EXPECT_EQ(e["truth"], 1);
  EXPECT_EQ(e["reported"], 2);
  EXPECT_EQ(e["matched"], 1);
  EXPECT_DOUBLE_EQ(e["precision"].get<double>(), 0.5);
  EXPECT_DOUBLE_EQ(e["recall"].get<double>(), 1.0);
  const auto& lb = e["per_kind"]["left_bag"];
  EXPECT_NEAR(lb["latency_s"].get<double>(), 0.6, 1e-9);
  EXPECT_NEAR(lb["localisation_error_m"].get<double>(), 0.1, 1e-9);
  EXPECT_DOUBLE_EQ(e["per_kind"]["bag_taken"]["precision"].get<double>(), 0.0);
  EXPECT_EQ(e["false_reports"].size(), 1u);
  // A malformed events line names the file, line and key.
  {
    std::ofstream ev(run / "events.jsonl", std::ios::binary);
    ev << R"({"t_ns":1500000000,"id":1,"kind":"left_bag","camera":"cam_a","map":[5.1,2.0,0.2]})" "\n"
       << R"({"t_ns":1500000000,"id":2,"kind":"fire","camera":"cam_a","map":[5.1,2.0,0.2]})" "\n";
  }
  o = vigil_cmd("eval " + run.string());
  EXPECT_EQ(o.code, 2) << o.out;
  EXPECT_NE(o.out.find("events.jsonl:2: kind"), std::string::npos) << o.out;
}

}  // namespace

TEST(EvalCli, RunFolderMetricsMatchTheHandWorkedValues) {
  const fs::path run = make_run("hand");
  const Output o = vigil_cmd("eval " + run.string());
  ASSERT_EQ(o.code, 0) << o.out;
  for (const char* s : {"MOTA", "IDF1", "person", "bag", "robot", "eval.json"}) EXPECT_NE(o.out.find(s), std::string::npos) << s << "\n" << o.out;
  const auto j = nlohmann::json::parse(slurp(run / "eval.json"));
  const auto& t = j.at("tracking");
  EXPECT_EQ(t["frames"], 10);
  EXPECT_EQ(t["cameras"], nlohmann::json::array({"cam_a"}));
  EXPECT_NEAR(t["mota"].get<double>(), 17.0 / 30.0, 1e-9);
  EXPECT_NEAR(t["motp_m"].get<double>(), 2.8 / 19.0, 1e-6);
  EXPECT_NEAR(t["idf1"].get<double>(), 0.56, 1e-9);
  EXPECT_NEAR(t["idp"].get<double>(), 0.7, 1e-9);
  EXPECT_NEAR(t["idr"].get<double>(), 14.0 / 30.0, 1e-9);
  EXPECT_EQ(t["id_switches"], 1);
  EXPECT_EQ(t["fragmentations"], 1);
  EXPECT_EQ(t["false_positives"], 1);
  EXPECT_EQ(t["misses"], 11);
  EXPECT_EQ(t["matches"], 19);
  EXPECT_EQ(t["ground_truth_count"], 30);
  EXPECT_EQ(t["mostly_tracked"], 2);
  EXPECT_EQ(t["partially_tracked"], 0);
  EXPECT_EQ(t["mostly_lost"], 1);
  EXPECT_EQ(t["unique_objects"], 3);
  EXPECT_EQ(t["unique_tracks"], 4);
  EXPECT_EQ(t["tracks_file"], "tracks.jsonl");
  EXPECT_TRUE(t["camera"].is_null());
  const auto& pc = t.at("per_class");
  EXPECT_NEAR(pc["person"]["mota"].get<double>(), 0.8, 1e-9);
  EXPECT_NEAR(pc["person"]["idf1"].get<double>(), 10.0 / 21.0, 1e-9);
  EXPECT_EQ(pc["person"]["id_switches"], 1);
  EXPECT_NEAR(pc["bag"]["mota"].get<double>(), 0.9, 1e-9);
  EXPECT_NEAR(pc["bag"]["motp_m"].get<double>(), 0.2, 1e-6);
  EXPECT_EQ(pc["bag"]["fragmentations"], 1);
  EXPECT_NEAR(pc["robot"]["mota"].get<double>(), 0.0, 1e-12);
  EXPECT_TRUE(pc["robot"]["motp_m"].is_null());  // no matches: no mean distance
  EXPECT_FALSE(pc.contains("unknown"));
}

TEST(EvalCli, KeepsOtherKeysOfEvalJsonAndIsDeterministic) {
  const fs::path run = make_run("keep");
  std::ofstream(run / "eval.json") << "{\"events\": {\"left_bag\": {\"precision\": 1.0}}, \"zzz\": [1, 2]}\n";
  ASSERT_EQ(vigil_cmd("eval " + run.string()).code, 0);
  const std::string first = slurp(run / "eval.json");
  const auto j = nlohmann::ordered_json::parse(first);
  std::vector<std::string> keys;
  for (const auto& item : j.items()) keys.push_back(item.key());
  EXPECT_EQ(keys, (std::vector<std::string>{"events", "zzz", "tracking"}));
  EXPECT_EQ(j["events"]["left_bag"]["precision"], 1.0);
  const Output again = vigil_cmd("eval " + run.string());
  ASSERT_EQ(again.code, 0) << again.out;
  EXPECT_EQ(slurp(run / "eval.json"), first);
}

TEST(EvalCli, RangeAndClassOptions) {
  const fs::path run = make_run("range");
  // Within 4 m of (8, 2): bag1 and r1, and only track 3.
  Output o = vigil_cmd("eval " + run.string() + " --max-range 4 --camera-xy 8,2 --camera cam_a");
  ASSERT_EQ(o.code, 0) << o.out;
  auto t = nlohmann::json::parse(slurp(run / "eval.json"))["tracking"];
  EXPECT_EQ(t["ground_truth_count"], 20);
  EXPECT_EQ(t["track_count"], 9);
  EXPECT_NEAR(t["mota"].get<double>(), 0.45, 1e-9);
  EXPECT_EQ(t["max_range_m"], 4.0);
  EXPECT_EQ(t["camera"], "cam_a");
  o = vigil_cmd("eval " + run.string() + " --classes person");
  ASSERT_EQ(o.code, 0) << o.out;
  t = nlohmann::json::parse(slurp(run / "eval.json"))["tracking"];
  EXPECT_EQ(t["ground_truth_count"], 10);
  EXPECT_NEAR(t["mota"].get<double>(), 0.8, 1e-9);
  // A tighter match distance than the 0.1 m offset of the person tracks: all of A is missed.
  o = vigil_cmd("eval " + run.string() + " --classes person --match-distance 0.05");
  ASSERT_EQ(o.code, 0) << o.out;
  t = nlohmann::json::parse(slurp(run / "eval.json"))["tracking"];
  EXPECT_EQ(t["misses"], 10);
}

TEST(EvalCli, CameraPositionRateAndViewFromTheScenario) {
  // cam_corridor of dis_left_bag stands at (27, 3.9) looking west (yaw 180 deg, 60 deg wide) and
  // runs at 15 Hz. P is 2 m west of it, R 2 m east (behind it), Q 17 m west.
  const fs::path run = temp_dir("scenario");
  {
    std::ofstream gt(run / "ground_truth.jsonl");
    for (int k = 0; k < 10; ++k) {
      gt << "{\"type\":\"tick\",\"t_ns\":" << k * 100000000LL << ",\"entities\":[";
      const char* sep = "";
      for (const auto& [id, x] : std::vector<std::pair<std::string, double>>{{"P", 25.0}, {"Q", 10.0}, {"R", 29.0}}) {
        gt << sep << "{\"id\":\"" << id << "\",\"kind\":\"person\",\"x\":" << num(x) << ",\"y\":3.9000,\"yaw\":0.0000}";
        sep = ",";
      }
      gt << "]}\n";
    }
    std::ofstream tr(run / "tracks.jsonl");
    for (int k = 0; k < 15; ++k) {
      const int64_t t = (k * 1000000000LL + 14) / 15;
      tr << track_line(t, "cam_corridor", 1, "person", 25.0, 3.9);
    }
  }
  const std::string scenario = (test::source_dir() / "scenarios" / "dis_left_bag.yaml").string();
  const std::string base = "eval " + run.string() + " --camera cam_corridor";
  Output o = vigil_cmd(base + " --scenario " + scenario + " --max-range 5 --in-view");
  ASSERT_EQ(o.code, 0) << o.out;
  auto t = nlohmann::json::parse(slurp(run / "eval.json"))["tracking"];
  EXPECT_EQ(t["frames"], 15);
  EXPECT_EQ(t["frames_without_tracks"], 0);
  EXPECT_NEAR(t["camera_period_s"].get<double>(), 1.0 / 15.0, 1e-9);
  EXPECT_EQ(t["in_view"], true);
  EXPECT_EQ(t["ground_truth_count"], 15);  // only P
  EXPECT_NEAR(t["mota"].get<double>(), 1.0, 1e-12);
  // Range only: R, behind the camera, counts and is missed.
  o = vigil_cmd(base + " --scenario " + scenario + " --max-range 5");
  ASSERT_EQ(o.code, 0) << o.out;
  t = nlohmann::json::parse(slurp(run / "eval.json"))["tracking"];
  EXPECT_EQ(t["ground_truth_count"], 30);
  EXPECT_NEAR(t["mota"].get<double>(), 0.5, 1e-12);
  // No filter: Q and R missed in every frame.
  ASSERT_EQ(vigil_cmd(base).code, 0);
  EXPECT_NEAR(nlohmann::json::parse(slurp(run / "eval.json"))["tracking"]["mota"].get<double>(), 1.0 / 3.0, 1e-12);
  // A camera the scenario does not have; --in-view without a scenario.
  o = vigil_cmd("eval " + run.string() + " --scenario " + scenario + " --camera cam_nowhere --max-range 5");
  EXPECT_EQ(o.code, 2) << o.out;
  EXPECT_NE(o.out.find("cam_nowhere"), std::string::npos) << o.out;
  o = vigil_cmd(base + " --in-view");
  EXPECT_EQ(o.code, 2) << o.out;
  EXPECT_NE(o.out.find("--in-view"), std::string::npos) << o.out;
}

TEST(EvalCli, BadInputExitsTwoNamingFileAndLine) {
  // Missing tracks.jsonl.
  const fs::path run = make_run("bad");
  fs::remove(run / "tracks.jsonl");
  Output o = vigil_cmd("eval " + run.string());
  EXPECT_EQ(o.code, 2) << o.out;
  EXPECT_NE(o.out.find((run / "tracks.jsonl").string()), std::string::npos) << o.out;
  // A track line without x.
  {
    std::ofstream tr(run / "tracks.jsonl");
    tr << track_line(0, "cam_a", 1, "person", 1, 2) << track_line(0, "cam_a", 2, "person", 1, 2)
       << "{\"t_ns\":0,\"camera\":\"cam_a\",\"id\":3,\"class\":\"person\",\"y\":2.0}\n";
  }
  o = vigil_cmd("eval " + run.string());
  EXPECT_EQ(o.code, 2) << o.out;
  EXPECT_NE(o.out.find("tracks.jsonl:3: x: missing"), std::string::npos) << o.out;
  // A malformed ground-truth line.
  const fs::path run2 = make_run("bad_gt");
  {
    std::ofstream gt(run2 / "ground_truth.jsonl");
    gt << "{\"type\":\"tick\",\"t_ns\":0,\"entities\":[]}\n{\"type\":\"tick\",\"t_ns\":1,\"entities\":[{\"id\":\"A\"}]}\n";
  }
  o = vigil_cmd("eval " + run2.string());
  EXPECT_EQ(o.code, 2) << o.out;
  EXPECT_NE(o.out.find("ground_truth.jsonl:2: entities[0].kind: missing"), std::string::npos) << o.out;
  // eval.json that is not JSON is left alone.
  const fs::path run3 = make_run("bad_eval");
  std::ofstream(run3 / "eval.json") << "{not json";
  o = vigil_cmd("eval " + run3.string());
  EXPECT_EQ(o.code, 2) << o.out;
  EXPECT_NE(o.out.find("eval.json"), std::string::npos) << o.out;
  EXPECT_EQ(slurp(run3 / "eval.json"), "{not json");
  // Options.
  o = vigil_cmd("eval " + run3.string() + " --max-range 3");
  EXPECT_EQ(o.code, 2) << o.out;
  EXPECT_NE(o.out.find("--max-range"), std::string::npos) << o.out;
  o = vigil_cmd("eval " + make_run("cam").string() + " --camera cam_b");
  EXPECT_EQ(o.code, 2) << o.out;
  EXPECT_NE(o.out.find("cam_b"), std::string::npos) << o.out;
  EXPECT_NE(o.out.find("tracks.jsonl"), std::string::npos) << o.out;
  o = vigil_cmd("eval " + run3.string() + " --classes dog");
  EXPECT_EQ(o.code, 2) << o.out;
  o = vigil_cmd("eval");
  EXPECT_EQ(o.code, 2) << o.out;
  o = vigil_cmd("eval /nonexistent/run/dir");
  EXPECT_EQ(o.code, 2) << o.out;
  EXPECT_NE(o.out.find("/nonexistent/run/dir"), std::string::npos) << o.out;
}

TEST(EvalCli, MotChallengeFilesPrintPyMotmetricsFigures) {
  VIGIL_REQUIRE_SHARED_DATA();
  const fs::path mot = test::shared_data() / "mot";
  const Output o = vigil_cmd("eval --mot-gt " + (mot / "TUD-Campus.motmetrics_gt.txt").string() + " --mot-test " +
                                 (mot / "TUD-Campus.test.txt").string(),
                             /*merge_stderr=*/false);
  ASSERT_EQ(o.code, 0) << o.out;
  const auto j = nlohmann::json::parse(o.out);
  EXPECT_NEAR(j["mota"].get<double>(), 0.526462, 1e-4);
  EXPECT_NEAR(j["motp"].get<double>(), 0.277201, 1e-4);
  EXPECT_NEAR(j["idf1"].get<double>(), 0.557659, 1e-4);
  EXPECT_EQ(j["num_switches"], 7);
  EXPECT_EQ(j["num_fragmentations"], 7);
  EXPECT_EQ(j["num_frames"], 71);
}

TEST(EvalCli, MalformedMotChallengeFilesExitTwo) {
  const fs::path dir = temp_dir("mot_bad");
  std::ofstream(dir / "gt.txt") << "1,1,10,20,30,40,1,-1,-1,-1\n";
  std::ofstream(dir / "bad.txt") << "1,1,10,20,30,40,-1,-1,-1,-1\n1,2,10,20,x,40,-1,-1,-1,-1\n";
  Output o = vigil_cmd("eval --mot-gt " + (dir / "gt.txt").string() + " --mot-test " + (dir / "bad.txt").string());
  EXPECT_EQ(o.code, 2) << o.out;
  EXPECT_NE(o.out.find("bad.txt:2: bb_width"), std::string::npos) << o.out;
  o = vigil_cmd("eval --mot-gt " + (dir / "gt.txt").string() + " --mot-test " + (dir / "missing.txt").string());
  EXPECT_EQ(o.code, 2) << o.out;
  EXPECT_NE(o.out.find("missing.txt"), std::string::npos) << o.out;
  o = vigil_cmd("eval --mot-gt " + (dir / "gt.txt").string());
  EXPECT_EQ(o.code, 2) << o.out;
  // A perfect tracker on the small file.
  o = vigil_cmd("eval --mot-gt " + (dir / "gt.txt").string() + " --mot-test " + (dir / "gt.txt").string(), false);
  ASSERT_EQ(o.code, 0) << o.out;
  EXPECT_DOUBLE_EQ(nlohmann::json::parse(o.out)["mota"].get<double>(), 1.0);
}

}  // namespace vigil
