// vigil export-mcap: a run as an MCAP file with Foxglove's schemas, read back with the mcap
// reader (tools/check_mcap.py, the same virtual environment) and checked against the run's files:
// topics, schemas, message counts, time order, and decoded values.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "tests/test_util.h"

namespace fs = std::filesystem;
using vigil::test::Output;
using vigil::test::slurp;
using vigil::test::vigil_cmd;

namespace {

fs::path scenario(const std::string& name) { return vigil::test::source_dir() / "scenarios" / (name + ".yaml"); }

// Lines of a JSON Lines file, optionally only those whose "type" is `type`.
std::vector<nlohmann::json> lines_of(const fs::path& p, const std::string& type = "") {
  std::vector<nlohmann::json> out;
  std::istringstream in(slurp(p));
  for (std::string l; std::getline(in, l);) {
    if (l.empty()) continue;
    auto j = nlohmann::json::parse(l);
    if (type.empty() || j.value("type", "") == type) out.push_back(j);
  }
  return out;
}

}  // namespace

TEST(Mcap, ExportsTheRunWithFoxgloveSchemasInTimeOrderAndItReadsBack) {
  const fs::path dir = vigil::test::fresh_temp_dir("mcap", "run");
  const fs::path run = dir / "run";
  // 14 s of dis_left_bag (A comes into view at 11 s) with the cameras rendered (their videos become images) and the truth sensor.
  Output o = vigil_cmd("run " + scenario("dis_left_bag").string() + " --sensor truth --duration 14 --out " + run.string() + " --quiet");
  ASSERT_EQ(o.code, 0) << o.out;
  o = vigil_cmd("export-mcap " + run.string() + " --image-rate 2");
  ASSERT_EQ(o.code, 0) << o.out;
  ASSERT_TRUE(fs::exists(run / "run.mcap")) << o.out;
  const std::string tools = (vigil::test::source_dir() / "tools" / "export_mcap.sh").string();
  const Output check = vigil::test::shell("bash " + tools + " --check " + (run / "run.mcap").string() + " --at 5", false);
  ASSERT_EQ(check.code, 0) << check.out;
  const auto j = nlohmann::json::parse(check.out);
  EXPECT_TRUE(j["time_ordered"].get<bool>());
  const auto& topics = j["topics"];
  auto count = [&](const std::string& t) { return topics.contains(t) ? topics[t]["count"].get<int>() : -1; };
  auto schema = [&](const std::string& t) { return topics.contains(t) ? topics[t]["schema"].get<std::string>() : std::string(); };

  // Every topic protobuf with a Foxglove schema and its messages in time order.
  for (const auto& [name, t] : topics.items()) {
    EXPECT_EQ(t["message_encoding"], "protobuf") << name;
    EXPECT_EQ(t["schema_encoding"], "protobuf") << name;
    EXPECT_EQ(t["schema"].get<std::string>().rfind("foxglove.", 0), 0u) << name;
    EXPECT_TRUE(t["ordered"].get<bool>()) << name;
  }
  EXPECT_EQ(schema("/map"), "foxglove.Grid");
  EXPECT_EQ(count("/map"), 1);
  EXPECT_EQ(schema("/tf"), "foxglove.FrameTransforms");
  EXPECT_EQ(schema("/cameras"), "foxglove.SceneUpdate");
  // One entity update per ground-truth tick.
  EXPECT_EQ(schema("/truth/entities"), "foxglove.SceneUpdate");
  EXPECT_EQ(count("/truth/entities"), static_cast<int>(lines_of(run / "ground_truth.jsonl", "tick").size()));
  // Each robot's believed pose per report, and each scan.
  std::map<std::string, int> reports, scans;
  for (const auto& r : lines_of(run / "robots.jsonl")) ++reports[r["robot"].get<std::string>()];
  for (const auto& s : lines_of(run / "scans.jsonl")) ++scans[s["robot"].get<std::string>()];
  ASSERT_EQ(reports.size(), 2u);
  ASSERT_EQ(scans.size(), 2u);
  for (const auto& [robot, n] : reports) {
    EXPECT_EQ(schema("/robots/" + robot + "/pose"), "foxglove.PoseInFrame");
    EXPECT_EQ(count("/robots/" + robot + "/pose"), n) << robot;
    EXPECT_EQ(schema("/robots/" + robot + "/path"), "foxglove.SceneUpdate");
    EXPECT_EQ(count("/robots/" + robot + "/path"), n) << robot;
  }
  for (const auto& [robot, n] : scans) {
    EXPECT_EQ(schema("/robots/" + robot + "/scan"), "foxglove.LaserScan");
    EXPECT_EQ(count("/robots/" + robot + "/scan"), n) << robot;
  }
  // Tracks: one update per camera tick that had tracks.
  std::map<std::string, std::set<int64_t>> stamps;
  for (const auto& t : lines_of(run / "tracks.jsonl")) stamps[t["camera"].get<std::string>()].insert(t["t_ns"].get<int64_t>());
  ASSERT_FALSE(stamps.empty());
  for (const auto& [cam, s] : stamps) {
    EXPECT_EQ(schema("/cameras/" + cam + "/tracks"), "foxglove.SceneUpdate");
    EXPECT_EQ(count("/cameras/" + cam + "/tracks"), static_cast<int>(s.size())) << cam;
  }
  // Images at 2 Hz from each camera's video over 14 s: 0, 0.5, ..., 14.0 s.
  for (const char* cam : {"cam_corridor", "cam_lab"}) {
    EXPECT_EQ(schema(std::string("/cameras/") + cam + "/image"), "foxglove.CompressedImage");
    EXPECT_EQ(count(std::string("/cameras/") + cam + "/image"), 29) << cam;
  }
  EXPECT_EQ(j["image"]["format"], "jpeg");
  EXPECT_TRUE(j["image"]["jpeg"].get<bool>());
  // Decoded: the grid covers the map, a scan has the scenario's samples, and at 5 s each entity
  // is where the ground truth has it.
  EXPECT_GT(j["map"]["cells"].get<int>(), 1000);
  EXPECT_EQ(j["map"]["frame_id"], "map");
  const auto first_scan = lines_of(run / "scans.jsonl").front();
  EXPECT_EQ(j["scan"]["ranges"].get<size_t>(), first_scan["ranges"].size());
  ASSERT_TRUE(j.contains("entities_at"));
  int compared = 0;
  for (const auto& tick : lines_of(run / "ground_truth.jsonl", "tick")) {
    if (tick["t_ns"].get<int64_t>() != 5'000'000'000) continue;
    for (const auto& e : tick["entities"]) {
      const std::string id = e["id"];
      ASSERT_TRUE(j["entities_at"].contains(id)) << id;
      EXPECT_NEAR(j["entities_at"][id][0].get<double>(), e["x"].get<double>(), 1e-3) << id;
      EXPECT_NEAR(j["entities_at"][id][1].get<double>(), e["y"].get<double>(), 1e-3) << id;
      ++compared;
    }
  }
  EXPECT_GE(compared, 3);
  // Every message ends within the run.
  for (const auto& [name, t] : topics.items()) EXPECT_LE(t["last_ns"].get<int64_t>(), 14'000'000'000) << name;

  // Bad input: a broken line names the file and line; a folder that is not a run, exit 2.
  {
    std::ofstream r(run / "robots.jsonl", std::ios::app);
    r << "{\"t_ns\": 1, \"robot\": \"robot1\"\n";
  }
  o = vigil_cmd("export-mcap " + run.string() + " --out " + (dir / "bad.mcap").string());
  EXPECT_EQ(o.code, 2) << o.out;
  EXPECT_NE(o.out.find("robots.jsonl:"), std::string::npos) << o.out;
  o = vigil_cmd("export-mcap " + (dir / "nothing").string());
  EXPECT_EQ(o.code, 2) << o.out;
  fs::remove_all(dir);
}
