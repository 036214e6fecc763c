// The navigator controller (plugins/navigator) in whole runs: it reaches its goals on the DIS
// map with a bag put down on its patrol line and people crossing its path, without touching
// anyone or anything; it localises with MCL (the estimate it reports, not the truth, is what it
// drives on); tasks reach it through the world's inbox and its reports leave through the
// outbox; bad goals and bad parameters give an outcome or an error, never a hang; the world
// records robot contacts; runs repeat byte for byte.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "plugins/builtin.h"
#include "tests/test_util.h"
#include "world/navigation_eval.h"
#include "world/runner.h"
#include "world/scenario.h"
#include "world/sha256.h"

namespace vigil {
namespace {

namespace fs = std::filesystem;

Result<Scenario> inline_scenario(const std::string& text) {
  return parse_scenario(text, test::source_dir() / "scenarios" / "inline_navigator.yaml");
}

const char* kCorridorRobot = R"(
name: nav_inline
map: ../maps/dis_labs.floorplan.yaml
duration: 40
seed: 3
physics_rate_hz: 100
record_rate_hz: 10
robots:
  - id: robot1
    urdf: ../maps/robots/erratic.urdf
    start: {place: patrol_2, yaw_deg: 0}
    controller: navigator
    params: {points: [POINTS], loop: false, speed: 0.4}
    ranger: {range_max: 20, fov_deg: 270, samples: 271, noise_std: 0.01, rate_hz: 10}
    odometry: {error: [0.01, 0.01, 0.1]}
)";

std::string with_points(const std::string& pts, const std::string& extra = "") {
  std::string s = kCorridorRobot;
  s.replace(s.find("POINTS"), 6, pts);
  return s + extra;
}

struct NavRun {
  RunSummary summary;
  fs::path dir;
  NavigationFigures nav;
  std::vector<RobotReport> reports;
};

NavRun run(const Scenario& sc, const std::string& name, std::function<void(World&)> before_step = nullptr) {
  NavRun r;
  r.dir = test::fresh_temp_dir("navigator", name);
  RunOptions ro;
  ro.world.plugins = builtin_plugin_registry();
  ro.out_dir = r.dir;
  ro.video = false;
  ro.before_step = std::move(before_step);
  ro.on_report = [&r](const RobotReport& rep) { r.reports.push_back(rep); };
  auto sum = run_scenario(sc, ro);
  EXPECT_TRUE(sum.ok()) << sum.error().str();
  if (!sum.ok()) return r;
  r.summary = *sum;
  auto nav = evaluate_navigation(r.dir / "ground_truth.jsonl", r.dir / "robots.jsonl");
  EXPECT_TRUE(nav.ok()) << nav.error().str();
  if (nav.ok()) r.nav = *nav;
  return r;
}

TEST(Navigator, PatrolsRoundABagAndPastPeopleWithoutContact) {
  auto sc = load_scenario(test::source_dir() / "scenarios" / "dis_patrol_bag.yaml");
  ASSERT_TRUE(sc.ok()) << sc.error().str();
  NavRun r = run(*sc, "patrol_bag");
  ASSERT_EQ(r.nav.robots.size(), 1u);
  const auto& f = r.nav.robots[0];
  EXPECT_EQ(r.nav.contacts_with_people_or_objects, 0);
  EXPECT_EQ(r.nav.contacts_with_walls, 0);
  EXPECT_EQ(f.goals_failed, 0) << (f.failures.empty() ? "" : f.failures[0]);
  EXPECT_GE(f.goals_reached, 4);  // the whole loop at least once in 120 s
  EXPECT_GT(f.localized_reports, 100);
  EXPECT_LE(f.position_rms, 0.10);
  EXPECT_LE(f.heading_rms, 3.0 * M_PI / 180);
  // Going round the bag and waiting for people costs time, but not much.
  EXPECT_LT(f.median_time_ratio, 1.6);
  // The left bag is still in the ground truth (the robot does not carry it off).
  bool left_bag = false;
  for (const auto& line : {test::slurp(r.dir / "ground_truth.jsonl")})
    left_bag = line.find("\"kind\":\"left_bag\"") != std::string::npos;
  EXPECT_TRUE(left_bag);
  fs::remove_all(r.dir);
}

// dis_lab_unauthorised: robot1 waits and steers round people at the lab's door with bodies close
// in front of its laser. Its filter must not take them for a sign of being lost: with the
// navigator's crowd options off (occlusion_range 0, no beam skipping, the defaults before
// 2026-12-06) the recovery injected a pose 13 m off, in another corridor turned 90 degrees, and
// the robot drove on it for the rest of the run, reporting itself localised.
TEST(Navigator, StaysLocalisedAmongPeopleAtTheLabDoor) {
  auto sc = load_scenario(test::source_dir() / "scenarios" / "dis_lab_unauthorised.yaml");
  ASSERT_TRUE(sc.ok()) << sc.error().str();
  auto worst = [&](bool crowd) {
    Scenario s = *sc;
    if (!crowd)
      for (auto& r : s.robots) r.params["occlusion_range"] = {0.0, 0}, r.params["beam_skip"] = {false, 0};
    NavRun r = run(s, crowd ? "lab_crowd" : "lab_plain");
    double w = 0;
    for (const auto& f : r.nav.robots) {
      EXPECT_GT(f.localized_reports, 100) << f.robot;
      w = std::max(w, f.position_worst);
    }
    fs::remove_all(r.dir);
    return w;
  };
  EXPECT_LT(worst(true), 0.3);
  // The failure this guards against, with the options off (a figure, not asserted: a better
  // filter may one day do without them).
  std::printf("[lab door] worst localisation error without the crowd options: %.2f m\n", worst(false));
}

TEST(Navigator, RepeatsByteForByte) {
  std::string text = with_points("26.0, 3.1, 12.0, 7.0");
  text.replace(text.find("duration: 40"), 12, "duration: 90");
  auto sc = inline_scenario(text);
  ASSERT_TRUE(sc.ok()) << sc.error().str();
  NavRun a = run(*sc, "det_a"), b = run(*sc, "det_b");
  EXPECT_EQ(a.summary.ground_truth_sha256, b.summary.ground_truth_sha256);
  EXPECT_EQ(sha256_hex(test::slurp(a.dir / "robots.jsonl")), sha256_hex(test::slurp(b.dir / "robots.jsonl")));
  EXPECT_FALSE(test::slurp(a.dir / "robots.jsonl").empty());
  // Into the lab through its 1 m door and to the table's side: both goals reached.
  ASSERT_EQ(a.nav.robots.size(), 1u);
  EXPECT_EQ(a.nav.robots[0].goals_reached, 2);
  fs::remove_all(a.dir);
  fs::remove_all(b.dir);
}

TEST(Navigator, TasksComeThroughTheInboxAndReportsGoOut) {
  // No patrol: it idles until a goto task arrives at 2 s, then one that cannot be reached.
  auto sc = inline_scenario(with_points(""));
  ASSERT_TRUE(sc.ok()) << sc.error().str();
  bool sent = false, sent_bad = false;
  NavRun r = run(*sc, "inbox", [&](World& w) {
    if (!sent && w.time() >= 2 * kNsPerSecond) {
      RobotTask t;
      t.id = 7;
      t.kind = "goto";
      t.goal = {21.0, 3.1};
      t.label = "incident-1";
      ASSERT_TRUE(w.post_task("robot1", t).ok());
      EXPECT_FALSE(w.post_task("nobody", t).ok());
      sent = true;
    }
    if (!sent_bad && w.time() >= 25 * kNsPerSecond) {
      RobotTask t;
      t.id = 8;
      t.kind = "goto";
      t.goal = {16.0, 4.2};  // on the corridor's north wall
      ASSERT_TRUE(w.post_task("robot1", t).ok());
      RobotTask odd;
      odd.id = 9;
      odd.kind = "dance";
      ASSERT_TRUE(w.post_task("robot1", odd).ok());
      sent_bad = true;
    }
  });
  bool started = false, reached = false, failed_wall = false, rejected = false;
  for (const auto& rep : r.reports) {
    if (rep.event == "goal_started" && rep.task_id == 7) started = true;
    if (rep.event == "goal_reached" && rep.task_id == 7) {
      reached = true;
      EXPECT_LT(std::hypot(rep.pose.x - 21.0, rep.pose.y - 3.1), 0.35);
      EXPECT_EQ(rep.detail, "incident-1");
      EXPECT_LT(to_seconds(rep.stamp), 25.0);
    }
    if (rep.event == "goal_failed" && rep.task_id == 8) {
      failed_wall = true;
      EXPECT_NE(rep.detail.find("invalid_goal"), std::string::npos) << rep.detail;
    }
    if (rep.event == "task_rejected" && rep.task_id == 9) rejected = true;
  }
  EXPECT_TRUE(started);
  EXPECT_TRUE(reached);
  EXPECT_TRUE(failed_wall);
  EXPECT_TRUE(rejected);
  fs::remove_all(r.dir);
}

// DIAG_floor1, a room north of vertex 45, and a goal far to the west (the greedy run's
// vertex 0): the way out runs down the room's west wall, and the path's first corner is 0.3 m from the wall the robot faces there. A forward check
// that stopped the full safety distance short of walls stalled the robot at that corner for
// ever (greedy patrol at theta 1, docs/PERFORMANCE.md); mapped walls now stop it only
// `map_safety_distance` short, and the path turns before the wall.
TEST(Navigator, LeavesARoomWhosePathTurnsCloseToTheWallAhead) {
  VIGIL_REQUIRE_SHARED_DATA();
  const fs::path map = test::shared_data() / "maps" / "DIAG_floor1" / "DIAG_floor1.yaml";
  std::string text = R"(
name: nav_room_exit
map: MAP
duration: 200
seed: 1
physics_rate_hz: 10
places: {room: [95.0, 40.66]}
robots:
  - id: robot1
    urdf: ../maps/robots/erratic.urdf
    start: {place: room, yaw_deg: 130}
    controller: navigator
    max_speed: 1.0
    params: {points: [10.4, 19.3], loop: false, speed: 1.0}
    ranger: {range_max: 20, fov_deg: 270, samples: 271, noise_std: 0.01, rate_hz: 10}
    odometry: {error: [0.01, 0.01, 0.1]}
)";
  text.replace(text.find("MAP"), 3, map.string());
  auto sc = inline_scenario(text);
  ASSERT_TRUE(sc.ok()) << sc.error().str();
  NavRun r = run(*sc, "room_exit");
  ASSERT_EQ(r.nav.robots.size(), 1u);
  const auto& f = r.nav.robots[0];
  EXPECT_EQ(f.goals_reached, 1) << (f.failures.empty() ? "" : f.failures[0]);
  EXPECT_EQ(f.goals_failed, 0) << (f.failures.empty() ? "" : f.failures[0]);
  EXPECT_EQ(r.nav.contacts_with_walls, 0);
  fs::remove_all(r.dir);
}

TEST(Navigator, BadParametersNameTheKey) {
  auto sc = inline_scenario(with_points("26.0, 3.1") + "");
  ASSERT_TRUE(sc.ok());
  Scenario bad = *sc;
  bad.robots[0].params["localization"] = {std::string("gps"), 0};
  RunOptions ro;
  ro.world.plugins = builtin_plugin_registry();
  auto r = run_scenario(bad, ro);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().str().find("params.localization"), std::string::npos) << r.error().str();
  Scenario wall = *sc;
  wall.robots[0].params["points"] = {std::vector<double>{16.0, 4.2}, 0};
  r = run_scenario(wall, ro);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().str().find("not in free space"), std::string::npos) << r.error().str();
  // A blind robot cannot localise or see people: refused, not driven.
  Scenario blind = *sc;
  blind.robots[0].ranger.enabled = false;
  r = run_scenario(blind, ro);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().str().find("ranger"), std::string::npos) << r.error().str();
}

TEST(World, RecordsContactsOfARobotThatPushes) {
  // waypoint_follower with no avoidance drives straight into a bag on the corridor floor.
  auto sc = inline_scenario(R"(
name: push_inline
map: ../maps/dis_labs.floorplan.yaml
duration: 20
seed: 1
robots:
  - id: pusher
    urdf: ../maps/robots/erratic.urdf
    start: {place: patrol_2, yaw_deg: 0}
    controller: waypoint_follower
    params: {points: [24.0, 3.1], loop: false, speed: 0.5, avoid_distance: 0}
objects:
  - {id: bag1, kind: bag, at: [19.0, 3.1]}
)");
  ASSERT_TRUE(sc.ok()) << sc.error().str();
  RunOptions ro;
  ro.world.plugins = builtin_plugin_registry();
  const fs::path dir = test::fresh_temp_dir("navigator", "push");
  ro.out_dir = dir;
  ro.video = false;
  ASSERT_TRUE(run_scenario(*sc, ro).ok());
  const std::string gt = test::slurp(dir / "ground_truth.jsonl");
  EXPECT_NE(gt.find("\"type\":\"contact\",\"robot\":\"pusher\",\"other\":\"bag1\",\"other_kind\":\"object\""),
            std::string::npos);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace vigil
