// Tests of world/scenario.h: a complete scenario parses to the right values (degrees become
// radians, places resolve through the floorplan, defaults per object kind); every kind of bad
// input gives an error naming the file, the line and the key; and a bounded, deterministic
// fuzz run over mutations of a good scenario never crashes or hangs and always returns either a
// scenario or an error with a message. Scenarios and their floorplan are written inline into a
// temporary folder, so nothing here depends on maps/.
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "tests/test_util.h"
#include "world/scenario.h"

namespace vigil {
namespace {

namespace fs = std::filesystem;

// A 12 x 8 m floor: two rooms split by a wall at x = 6 with a door, a desk in the west room.
constexpr const char* kFloorplan = R"(name: test_lab
resolution: 0.1
bounds: {min: [0, 0], max: [12, 8]}
walls:
  - polyline: [[0.5, 0.5], [11.5, 0.5], [11.5, 7.5], [0.5, 7.5]]
    closed: true
  - {from: [6.0, 0.5], to: [6.0, 7.5]}
doors:
  - {name: middle_door, center: [6.0, 4.0], width: 1.2, yaw_deg: 90}
furniture:
  - {name: desk, kind: table, pose: [3.0, 6.0, 0], size: [1.2, 0.6, 0.75]}
places:
  west: [2.0, 2.0]
  east: [10.0, 2.0]
  doorway: [6.0, 4.0]
  desk_front: [3.0, 5.2]
  exit: [11.0, 4.0]
)";

// A good scenario that uses every section.
constexpr const char* kGood = R"(# every section of the format
name: unit_good
map: lab.floorplan.yaml
duration: 60
seed: 42
physics_rate_hz: 50
record_rate_hz: 10
rules:
  left_bag_distance: 2.5
  left_bag_time: 4
  exchange_distance: 1.0
places:
  bag_spot: [4.0, 3.0]
cameras:
  - id: cam_west
    position: [1.0, 1.0, 2.5]
    yaw_deg: 45
    pitch_deg: 20
    resolution: [320, 240]
    hfov_deg: 70
    plugin: wander
    params: {k: 4, learn: true, label: west, ratio: "0.5", thresholds: [1, 2.5], names: [a, b], none: []}
  - id: cam_east
    position: [11.0, 1.0, 2.5]
    yaw_deg: 135
    resolution: [320, 240]
    fx: 400
    cx: 160
    cy: 120
robots:
  - id: r1
    urdf: robot.urdf
    start: {place: west, yaw_deg: 90}
    controller: waypoint_follower
    params:
      waypoints: [west, east]
      speed: 0.4
    ranger: {range_max: 10, fov_deg: 180, samples: 181}
    odometry: {error: [0.01, 0.02, 0.03], noise_std: 0.05}
    max_speed: 0.8
    max_turn_rate_deg: 90
  - id: r2
    urdf: robot.urdf
    start: [9.0, 6.0, -90]
people:
  - id: alice
    start: west
    shirt: "#C03030"
    script:
      - walk_to: bag_spot
        speed: 0.8
      - put_down: bag1
        to: [4.2, 3.0]
      - walk_to: [10.0, 3.0]
        at: 20
      - wait: 5
      - leave: exit
  - id: bob
    start: east
    appear_at: 10
    script:
      - walk_to: bag_spot
      - pick_up: bag1
        duration: 2
      - walk_to: desk_front
      - touch: laptop1
objects:
  - id: bag1
    kind: bag
    carried_by: alice
    owner: alice
  - id: laptop1
    kind: laptop
    on: desk
    owner: alice
    authorised: false
  - id: book1
    kind: book
    on: desk
    at: [3.3, 6.1]
  - id: box1
    kind: box
    at: [8.0, 2.0]
    size: [0.5, 0.5, 0.5]
    colour: "#00FF00"
)";

constexpr double kDeg = M_PI / 180.0;

// Writes text to a file.
void write_file(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

// 1-based line of the first occurrence of `needle` in `text` (0 when absent).
int line_of(const std::string& text, const std::string& needle) {
  const size_t pos = text.find(needle);
  if (pos == std::string::npos) return 0;
  return 1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<long>(pos), '\n'));
}

// `text` with the single occurrence of `from` replaced by `to` (fails the test otherwise).
std::string replace_once(const std::string& text, const std::string& from, const std::string& to) {
  const size_t pos = text.find(from);
  EXPECT_NE(pos, std::string::npos) << "test bug: '" << from << "' not in the scenario";
  EXPECT_EQ(text.find(from, pos + 1), std::string::npos) << "test bug: '" << from << "' occurs twice";
  if (pos == std::string::npos) return text;
  return text.substr(0, pos) + to + text.substr(pos + from.size());
}

class ScenarioTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = fs::temp_directory_path() / ("vigil_scenario_test_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    write_file(dir_ / "lab.floorplan.yaml", kFloorplan);
    write_file(dir_ / "broken.floorplan.yaml", "name: broken\nbounds: {min: [0, 0], max: [4, 4]}\nwalls: 3\n");
    write_file(dir_ / "robot.urdf", "<robot name=\"test\"/>\n");
  }
  static void TearDownTestSuite() {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }

  // Parses text as dir/scenario.yaml.
  static Result<Scenario> parse(const std::string& text, const ScenarioContext& ctx = {}) {
    return parse_scenario(text, dir_ / "scenario.yaml", ctx);
  }

  // Expects `text` to fail at `line` (0: do not check) with `key` and a message containing `what`.
  static void expect_error(const std::string& text, int line, const std::string& key, const std::string& what,
                           const ScenarioContext& ctx = {}) {
    auto r = parse(text, ctx);
    ASSERT_FALSE(r.ok()) << "expected an error about " << key << ": " << what;
    const Error& e = r.error();
    EXPECT_EQ(e.kind, ErrorKind::kBadInput) << e.str();
    EXPECT_NE(e.str().find("scenario.yaml"), std::string::npos) << e.str();
    if (line > 0) {
      EXPECT_EQ(e.line, line) << e.str();
    }
    EXPECT_EQ(e.key, key) << e.str();
    EXPECT_NE(e.str().find(what), std::string::npos) << "message lacks '" << what << "': " << e.str();
  }

  static fs::path dir_;
};

fs::path ScenarioTest::dir_;

TEST_F(ScenarioTest, GoodScenarioParsesWithTheRightValues) {
  auto r = parse(kGood);
  ASSERT_TRUE(r.ok()) << r.error().str();
  const Scenario& s = *r;
  EXPECT_EQ(s.name, "unit_good");
  EXPECT_EQ(s.map, (dir_ / "lab.floorplan.yaml").lexically_normal());
  EXPECT_DOUBLE_EQ(s.duration, 60);
  EXPECT_EQ(s.seed, 42u);
  EXPECT_DOUBLE_EQ(s.physics_rate_hz, 50);
  EXPECT_DOUBLE_EQ(s.record_rate_hz, 10);
  EXPECT_DOUBLE_EQ(s.rules.left_bag_distance, 2.5);
  EXPECT_DOUBLE_EQ(s.rules.left_bag_time, 4);
  EXPECT_DOUBLE_EQ(s.rules.exchange_distance, 1.0);
  // Places: the floorplan's five plus the scenario's own.
  EXPECT_EQ(s.places.size(), 6u);
  EXPECT_EQ(s.places.at("bag_spot"), (Vec2{4.0, 3.0}));
  EXPECT_EQ(s.places.at("exit"), (Vec2{11.0, 4.0}));
  ASSERT_EQ(s.furniture.count("desk"), 1u);
  EXPECT_EQ(s.furniture.at("desk"), (Pose2{3.0, 6.0, 0.0}));

  ASSERT_EQ(s.cameras.size(), 2u);
  const CameraSpec& c0 = s.cameras[0];
  EXPECT_EQ(c0.id, "cam_west");
  EXPECT_EQ(c0.position, (Vec3{1.0, 1.0, 2.5}));
  EXPECT_NEAR(c0.yaw, 45 * kDeg, 1e-12);
  EXPECT_NEAR(c0.pitch, 20 * kDeg, 1e-12);
  EXPECT_DOUBLE_EQ(c0.roll, 0);
  EXPECT_EQ(c0.width, 320);
  EXPECT_EQ(c0.height, 240);
  ASSERT_TRUE(c0.hfov.has_value());
  EXPECT_NEAR(*c0.hfov, 70 * kDeg, 1e-12);
  EXPECT_FALSE(c0.fx.has_value());
  EXPECT_DOUBLE_EQ(c0.baseline, 0.09);
  EXPECT_DOUBLE_EQ(c0.rate_hz, 15);
  EXPECT_EQ(c0.plugin, "wander");
  EXPECT_EQ(c0.line, line_of(kGood, "- id: cam_west"));
  // Parameters keep their YAML types and lines.
  ASSERT_EQ(c0.params.size(), 7u);
  EXPECT_EQ(std::get<double>(c0.params.at("k").value), 4.0);
  EXPECT_EQ(std::get<bool>(c0.params.at("learn").value), true);
  EXPECT_EQ(std::get<std::string>(c0.params.at("label").value), "west");
  EXPECT_EQ(std::get<std::string>(c0.params.at("ratio").value), "0.5");  // quoted: a string
  EXPECT_EQ(std::get<std::vector<double>>(c0.params.at("thresholds").value), (std::vector<double>{1, 2.5}));
  EXPECT_EQ(std::get<std::vector<std::string>>(c0.params.at("names").value), (std::vector<std::string>{"a", "b"}));
  EXPECT_TRUE(std::get<std::vector<std::string>>(c0.params.at("none").value).empty());
  EXPECT_EQ(c0.params.at("k").line, line_of(kGood, "params: {k: 4"));
  const CameraSpec& c1 = s.cameras[1];
  EXPECT_NEAR(c1.yaw, 135 * kDeg, 1e-12);
  EXPECT_FALSE(c1.hfov.has_value());
  ASSERT_TRUE(c1.fx && c1.fy && c1.cx && c1.cy);
  EXPECT_DOUBLE_EQ(*c1.fx, 400);
  EXPECT_DOUBLE_EQ(*c1.fy, 400);  // square pixels by default
  EXPECT_DOUBLE_EQ(*c1.cx, 160);

  ASSERT_EQ(s.robots.size(), 2u);
  const RobotSpec& r1 = s.robots[0];
  EXPECT_EQ(r1.urdf, (dir_ / "robot.urdf").lexically_normal());
  EXPECT_EQ(r1.start_place, "west");
  EXPECT_DOUBLE_EQ(r1.start.x, 2.0);
  EXPECT_DOUBLE_EQ(r1.start.y, 2.0);
  EXPECT_NEAR(r1.start.yaw, M_PI / 2, 1e-12);
  EXPECT_EQ(r1.controller, "waypoint_follower");
  EXPECT_EQ(std::get<std::vector<std::string>>(r1.params.at("waypoints").value),
            (std::vector<std::string>{"west", "east"}));
  EXPECT_EQ(r1.params.at("speed").line, line_of(kGood, "speed: 0.4"));
  EXPECT_TRUE(r1.ranger.enabled);
  EXPECT_DOUBLE_EQ(r1.ranger.range_max, 10);
  EXPECT_DOUBLE_EQ(r1.ranger.range_min, 0.02);  // default
  EXPECT_NEAR(r1.ranger.fov, M_PI, 1e-12);
  EXPECT_EQ(r1.ranger.samples, 181);
  EXPECT_DOUBLE_EQ(r1.odometry.error_y, 0.02);
  EXPECT_DOUBLE_EQ(r1.odometry.noise_std, 0.05);
  EXPECT_DOUBLE_EQ(r1.max_speed, 0.8);
  EXPECT_NEAR(r1.max_turn_rate, M_PI / 2, 1e-12);
  const RobotSpec& r2 = s.robots[1];
  EXPECT_EQ(r2.start_place, "");
  EXPECT_NEAR(r2.start.yaw, -M_PI / 2, 1e-12);
  EXPECT_FALSE(r2.ranger.enabled);
  EXPECT_DOUBLE_EQ(r2.max_speed, 0.5);  // default

  ASSERT_EQ(s.people.size(), 2u);
  const PersonSpec& alice = s.people[0];
  EXPECT_EQ(alice.start.place, "west");
  EXPECT_EQ(alice.start.point, (Vec2{2.0, 2.0}));
  EXPECT_EQ(alice.shirt, "#c03030");
  EXPECT_EQ(alice.trousers, "#303030");
  EXPECT_FALSE(alice.appear_at.has_value());
  ASSERT_EQ(alice.script.size(), 5u);
  EXPECT_EQ(alice.script[0].kind, ActionKind::kWalkTo);
  EXPECT_EQ(alice.script[0].target.place, "bag_spot");
  EXPECT_EQ(alice.script[0].target.point, (Vec2{4.0, 3.0}));
  EXPECT_TRUE(alice.script[0].has_target);
  EXPECT_DOUBLE_EQ(*alice.script[0].speed, 0.8);
  EXPECT_EQ(alice.script[1].kind, ActionKind::kPutDown);
  EXPECT_EQ(alice.script[1].object, "bag1");
  EXPECT_TRUE(alice.script[1].has_target);
  EXPECT_EQ(alice.script[1].target.point, (Vec2{4.2, 3.0}));
  EXPECT_DOUBLE_EQ(alice.script[1].duration, 1.0);  // default hand time
  EXPECT_EQ(alice.script[2].target.place, "");
  EXPECT_DOUBLE_EQ(*alice.script[2].at, 20);
  EXPECT_EQ(alice.script[2].line, line_of(kGood, "- walk_to: [10.0, 3.0]"));
  EXPECT_EQ(alice.script[3].kind, ActionKind::kWait);
  EXPECT_DOUBLE_EQ(alice.script[3].duration, 5);
  EXPECT_EQ(alice.script[4].kind, ActionKind::kLeave);
  EXPECT_EQ(alice.script[4].target.place, "exit");
  const PersonSpec& bob = s.people[1];
  EXPECT_DOUBLE_EQ(*bob.appear_at, 10);
  EXPECT_EQ(bob.script[1].kind, ActionKind::kPickUp);
  EXPECT_DOUBLE_EQ(bob.script[1].duration, 2);
  EXPECT_FALSE(bob.script[1].has_target);
  EXPECT_EQ(bob.script[3].kind, ActionKind::kTouch);
  EXPECT_EQ(bob.script[3].object, "laptop1");

  ASSERT_EQ(s.objects.size(), 4u);
  const ObjectSpec& bag = s.objects[0];
  EXPECT_EQ(bag.kind, ObjectKind::kBag);
  EXPECT_EQ(bag.carried_by, "alice");
  EXPECT_EQ(bag.position.point, (Vec2{2.0, 2.0}));  // where its carrier starts
  EXPECT_EQ(bag.owner, "alice");
  EXPECT_TRUE(bag.authorised);
  const ObjectSpec& laptop = s.objects[1];
  EXPECT_EQ(laptop.kind, ObjectKind::kLaptop);
  EXPECT_EQ(laptop.on, "desk");
  EXPECT_EQ(laptop.position.point, (Vec2{3.0, 6.0}));  // the desk's centre
  EXPECT_FALSE(laptop.authorised);
  EXPECT_DOUBLE_EQ(laptop.size_z, 0.03);  // laptop default size
  EXPECT_EQ(s.objects[2].position.point, (Vec2{3.3, 6.1}));
  const ObjectSpec& box = s.objects[3];
  EXPECT_DOUBLE_EQ(box.size_x, 0.5);
  EXPECT_EQ(box.colour, "#00ff00");
  EXPECT_EQ(box.line, line_of(kGood, "- id: box1"));
}

TEST_F(ScenarioTest, DefaultsOfAMinimalScenario) {
  auto r = parse("map: lab.floorplan.yaml\nduration: 5\n");
  ASSERT_TRUE(r.ok()) << r.error().str();
  EXPECT_EQ(r->name, "scenario");  // the file's stem
  EXPECT_EQ(r->seed, 1u);
  EXPECT_DOUBLE_EQ(r->physics_rate_hz, 100);
  EXPECT_DOUBLE_EQ(r->record_rate_hz, 10);
  EXPECT_DOUBLE_EQ(r->rules.left_bag_time, 5);
  EXPECT_TRUE(r->cameras.empty() && r->robots.empty() && r->people.empty() && r->objects.empty());
  // A camera with neither hfov_deg nor fx gets the 60 degree default.
  auto c = parse("map: lab.floorplan.yaml\nduration: 5\ncameras:\n  - {id: c, position: [1, 1, 2]}\n");
  ASSERT_TRUE(c.ok()) << c.error().str();
  EXPECT_NEAR(*c->cameras[0].hfov, 60 * kDeg, 1e-12);
  EXPECT_EQ(c->cameras[0].width, 640);
}

TEST_F(ScenarioTest, LoadScenarioReadsAFileAndNamesMissingOnes) {
  write_file(dir_ / "on_disk.yaml", kGood);
  auto r = load_scenario(dir_ / "on_disk.yaml");
  ASSERT_TRUE(r.ok()) << r.error().str();
  EXPECT_EQ(r->people.size(), 2u);
  auto missing = load_scenario(dir_ / "no_such.yaml");
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().str().find("no_such.yaml"), std::string::npos) << missing.error().str();
}

TEST_F(ScenarioTest, SyntaxErrorsNameTheLine) {
  const std::string text = replace_once(kGood, "    pitch_deg: 20\n", "    pitch_deg: [20\n");
  auto r = parse(text);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().str().find("scenario.yaml:"), std::string::npos) << r.error().str();
  EXPECT_NE(r.error().message.find("YAML syntax error"), std::string::npos) << r.error().str();
  EXPECT_GE(r.error().line, line_of(text, "pitch_deg: [20")) << r.error().str();
  // A tab-indented line: yaml-cpp's mark points at it.
  const std::string tabbed = replace_once(kGood, "  left_bag_time: 4\n", "\tleft_bag_time: 4\n");
  auto t = parse(tabbed);
  ASSERT_FALSE(t.ok());
  EXPECT_EQ(t.error().line, line_of(tabbed, "\tleft_bag_time")) << t.error().str();
}

TEST_F(ScenarioTest, EmptyAndNonMappingFilesAreErrors) {
  expect_error("", 0, "", "empty file");
  expect_error("# only a comment\n", 0, "", "empty file");
  expect_error("- a\n- b\n", 1, "", "expected a mapping");
  expect_error("just words\n", 1, "", "expected a mapping");
  // The second document is reported at its "---".
  expect_error("map: lab.floorplan.yaml\nduration: 5\n---\nmap: x\n", 3, "", "more than one YAML document");
}

// yaml-cpp 0.7's LoadAll loops forever, allocating, on a stray ',' where a document starts.
TEST_F(ScenarioTest, StrayTokensThatHangYamlCppAreErrors) {
  expect_error(",", 1, "", "YAML syntax error: unexpected \",\"");
  expect_error("# comment\n, map: x\n", 2, "", "YAML syntax error");
  expect_error("&anchor ,\n", 1, "", "YAML syntax error");
  expect_error("map: lab.floorplan.yaml\nduration: 5\n---\n,\n", 0, "", "YAML");
}

// rules.handling_zones: the operator marks furniture of the map; anything else names the item.
TEST_F(ScenarioTest, HandlingZonesNameFurnitureOfTheMap) {
  std::string t = replace_once(kGood, "  exchange_distance: 1.0\n", "  exchange_distance: 1.0\n  handling_zones: [desk]\n");
  auto r = parse(t);
  ASSERT_TRUE(r.ok()) << r.error().str();
  EXPECT_EQ(r->rules.handling_zones, std::vector<std::string>{"desk"});
  t = replace_once(kGood, "  exchange_distance: 1.0\n", "  exchange_distance: 1.0\n  handling_zones: [desk, bench]\n");
  expect_error(t, line_of(t, "handling_zones"), "rules.handling_zones[1]", "'bench' is not a piece of furniture of the map");
  t = replace_once(kGood, "  exchange_distance: 1.0\n", "  exchange_distance: 1.0\n  handling_zones: desk\n");
  expect_error(t, line_of(t, "handling_zones"), "rules.handling_zones", "expected a list of furniture names");
}

TEST_F(ScenarioTest, UnknownKeysAtEveryLevelListTheAllowedOnes) {
  std::string t = replace_once(kGood, "seed: 42\n", "seed: 42\nspeed_up: 2\n");
  expect_error(t, line_of(t, "speed_up"), "speed_up", "unknown key (allowed: name, map, duration");
  t = replace_once(kGood, "  left_bag_time: 4\n", "  left_bag_tme: 4\n");
  expect_error(t, line_of(t, "left_bag_tme"), "rules.left_bag_tme", "allowed: left_bag_distance");
  t = replace_once(kGood, "    pitch_deg: 20\n", "    pitch_deg: 20\n    zoom: 2\n");
  expect_error(t, line_of(t, "zoom"), "cameras[0].zoom", "unknown key");
  t = replace_once(kGood, "fov_deg: 180,", "fov_deg: 180, beams: 3,");
  expect_error(t, line_of(t, "beams"), "robots[0].ranger.beams", "allowed: range_min");
  t = replace_once(kGood, "      - wait: 5\n", "      - wait: 5\n        colour: 3\n");
  expect_error(t, line_of(t, "colour: 3"), "people[0].script[3].colour", "allowed: walk_to, wait, pick_up");
  t = replace_once(kGood, "      - wait: 5\n", "      - wait: 5\n        speed: 3\n");
  expect_error(t, line_of(t, "speed: 3"), "people[0].script[3].speed", "does not apply to wait (options: at)");
  t = replace_once(kGood, "    authorised: false\n", "    authorized: false\n");
  expect_error(t, line_of(t, "authorized"), "objects[1].authorized", "allowed: id, kind, at");
  // Angle keys without _deg get a hint.
  t = replace_once(kGood, "    yaw_deg: 135\n", "    yaw: 135\n");
  expect_error(t, line_of(t, "yaw: 135"), "cameras[1].yaw", "use yaw_deg");
  // Duplicate keys.
  t = replace_once(kGood, "duration: 60\n", "duration: 60\nduration: 30\n");
  expect_error(t, line_of(t, "duration: 30"), "duration", "duplicate key (first given at line 4)");
}

TEST_F(ScenarioTest, WrongTypesAndMissingKeys) {
  std::string t = replace_once(kGood, "duration: 60\n", "duration: soon\n");
  expect_error(t, 4, "duration", "expected a number, got \"soon\"");
  t = replace_once(kGood, "seed: 42\n", "seed: -3\n");
  expect_error(t, 5, "seed", "expected a whole number");
  t = replace_once(kGood, "    resolution: [320, 240]\n    hfov_deg", "    resolution: [320.5, 240]\n    hfov_deg");
  expect_error(t, line_of(t, "320.5"), "cameras[0].resolution[0]", "whole number");
  t = replace_once(kGood, "    position: [1.0, 1.0, 2.5]\n", "    position: [1.0, 1.0]\n");
  expect_error(t, line_of(t, "position: [1.0, 1.0]"), "cameras[0].position", "list of 3 numbers");
  t = replace_once(kGood, "    authorised: false\n", "    authorised: maybe\n");
  expect_error(t, line_of(t, "maybe"), "objects[1].authorised", "expected true or false");
  t = replace_once(kGood, "cameras:\n  - id: cam_west", "cameras:\n  - ident: cam_west");
  expect_error(t, line_of(t, "ident"), "cameras[0].ident", "unknown key");
  t = replace_once(kGood, "map: lab.floorplan.yaml\n", "");
  expect_error(t, line_of(t, "name: unit_good"), "map", "missing required key");  // the mapping's first line
  t = replace_once(kGood, "    urdf: robot.urdf\n    start: {place", "    start: {place");
  expect_error(t, line_of(t, "- id: r1"), "robots[0].urdf", "missing required key");
  t = replace_once(kGood, "places:\n  bag_spot: [4.0, 3.0]\n", "places: [4.0, 3.0]\n");
  expect_error(t, line_of(t, "places:"), "places", "expected a mapping");
  t = replace_once(kGood, "      - wait: 5\n", "      - wait\n");
  expect_error(t, line_of(t, "- wait"), "people[0].script[3]", "expected a step such as");
}

TEST_F(ScenarioTest, RangesDurationsRatesAndNonFiniteNumbers) {
  expect_error(replace_once(kGood, "duration: 60\n", "duration: 0\n"), 4, "duration", "greater than 0");
  expect_error(replace_once(kGood, "duration: 60\n", "duration: -5\n"), 4, "duration", "greater than 0");
  expect_error(replace_once(kGood, "duration: 60\n", "duration: .inf\n"), 4, "duration", "finite");
  expect_error(replace_once(kGood, "physics_rate_hz: 50\n", "physics_rate_hz: 0\n"), 6, "physics_rate_hz",
               "greater than 0");
  expect_error(replace_once(kGood, "record_rate_hz: 10\n", "record_rate_hz: 80\n"), 7, "record_rate_hz",
               "must not exceed physics_rate_hz");
  std::string t = replace_once(kGood, "    yaw_deg: 45\n", "    yaw_deg: .nan\n");
  expect_error(t, line_of(t, ".nan"), "cameras[0].yaw_deg", "finite");
  t = replace_once(kGood, "    cy: 120\n", "    cy: 120\n    rate_hz: -1\n");
  expect_error(t, line_of(t, "rate_hz: -1"), "cameras[1].rate_hz", "greater than 0");
  // A camera cannot tick faster than the world steps: frames are taken after physics steps.
  t = replace_once(kGood, "    cy: 120\n", "    cy: 120\n    rate_hz: 60\n");
  expect_error(t, line_of(t, "rate_hz: 60"), "cameras[1].rate_hz", "must not exceed physics_rate_hz");
  t = replace_once(kGood, "samples: 181", "samples: 1e300");
  expect_error(t, line_of(t, "1e300"), "robots[0].ranger.samples", "between 1 and 100000");
  t = replace_once(kGood, "range_max: 10,", "range_max: 10, range_min: 12,");
  expect_error(t, line_of(t, "range_min: 12"), "robots[0].ranger.range_max", "greater than range_min");
  t = replace_once(kGood, "    hfov_deg: 70\n", "    hfov_deg: 70\n    fx: 300\n");
  expect_error(t, line_of(t, "hfov_deg: 70"), "cameras[0].hfov_deg", "not both");
  t = replace_once(kGood, "      - wait: 5\n", "      - wait: -1\n");
  expect_error(t, line_of(t, "wait: -1"), "people[0].script[3].wait", "must not be negative");
}

TEST_F(ScenarioTest, DuplicateIdsAcrossEntities) {
  std::string t = replace_once(kGood, "  - id: bob\n", "  - id: r2\n");
  expect_error(t, line_of(t, "  - id: r2\n    start: east"), "people[1].id",
               "duplicate id 'r2' (already used by the robot at line " +
                   std::to_string(line_of(t, "  - id: r2\n    urdf")) + ")");
  t = replace_once(kGood, "  - id: box1\n", "  - id: cam_east\n");
  expect_error(t, line_of(t, "  - id: cam_east\n    kind"), "objects[3].id", "already used by the camera");
}

TEST_F(ScenarioTest, MapFilesThatAreMissingOrBroken) {
  std::string t = replace_once(kGood, "map: lab.floorplan.yaml\n", "map: nowhere.floorplan.yaml\n");
  expect_error(t, 3, "map", "does not exist");
  t = replace_once(kGood, "map: lab.floorplan.yaml\n", "map: broken.floorplan.yaml\n");
  // The loader's own message (file, line 3, key walls) is included.
  expect_error(t, 3, "map", "cannot load map: " + (dir_ / "broken.floorplan.yaml").string() + ":3: walls:");
  // A map_server YAML that is broken, through load_map.
  write_file(dir_ / "bad_server.yaml", "resolution: 0.05\n");
  t = replace_once(kGood, "map: lab.floorplan.yaml\n", "map: bad_server.yaml\n");
  expect_error(t, 3, "map", "cannot load map: " + (dir_ / "bad_server.yaml").string());
}

TEST_F(ScenarioTest, PlacesAndFreeSpace) {
  std::string t = replace_once(kGood, "      - walk_to: desk_front\n", "      - walk_to: nowhere\n");
  expect_error(t, line_of(t, "walk_to: nowhere"), "people[1].script[2].walk_to",
               "unknown place 'nowhere' (known: bag_spot, desk_front");
  t = replace_once(kGood, "start: [9.0, 6.0, -90]", "start: [6.0, 2.0, -90]");  // on the middle wall
  expect_error(t, line_of(t, "[6.0, 2.0, -90]"), "robots[1].start", "inside a wall");
  t = replace_once(kGood, "    start: east\n", "    start: [50, 2]\n");
  expect_error(t, line_of(t, "[50, 2]"), "people[1].start", "outside the map");
  t = replace_once(kGood, "    at: [8.0, 2.0]\n", "    at: [3.0, 6.0]\n");  // on the desk's footprint
  expect_error(t, line_of(t, "at: [3.0, 6.0]"), "objects[3].at", "inside a wall or obstacle");
  // put_down may target the floor or a table top, but not a wall.
  EXPECT_TRUE(parse(replace_once(kGood, "        to: [4.2, 3.0]\n", "        to: [3.2, 6.1]\n")).ok());
  t = replace_once(kGood, "        to: [4.2, 3.0]\n", "        to: [6.0, 3.0]\n");
  expect_error(t, line_of(t, "to: [6.0, 3.0]"), "people[0].script[1].to", "put_down position (6, 3) is inside a wall");
  t = replace_once(kGood, "      - walk_to: [10.0, 3.0]\n", "      - walk_to: [11.5, 3.0]\n");
  expect_error(t, line_of(t, "[11.5, 3.0]"), "people[0].script[2].walk_to", "inside a wall");
  t = replace_once(kGood, "  bag_spot: [4.0, 3.0]\n", "  bag_spot: [4.0, 3.0]\n  west: [1, 1]\n");
  expect_error(t, line_of(t, "west: [1, 1]"), "places.west", "already defined by the map");
  // Objects on furniture are exempt from the free-space check but must be on it.
  t = replace_once(kGood, "    at: [3.3, 6.1]\n", "    at: [5.0, 6.1]\n");
  expect_error(t, line_of(t, "[5.0, 6.1]"), "objects[2].at", "is not on 'desk'");
  t = replace_once(kGood, "    on: desk\n    owner", "    on: sofa\n    owner");
  expect_error(t, line_of(t, "on: sofa"), "objects[1].on", "unknown furniture 'sofa' (known: desk)");
}

TEST_F(ScenarioTest, ScriptsAndObjectsReferToThingsThatExist) {
  std::string t = replace_once(kGood, "      - touch: laptop1\n", "      - touch: phone9\n");
  expect_error(t, line_of(t, "touch: phone9"), "people[1].script[3].touch", "unknown object 'phone9'");
  t = replace_once(kGood, "      - touch: laptop1\n", "      - touch: r1\n");
  expect_error(t, line_of(t, "touch: r1"), "people[1].script[3].touch", "'r1' is a robot, not an object");
  t = replace_once(kGood, "    owner: alice\n    authorised", "    owner: carol\n    authorised");
  expect_error(t, line_of(t, "owner: carol"), "objects[1].owner", "unknown person 'carol'");
  t = replace_once(kGood, "    carried_by: alice\n", "    carried_by: cam_west\n");
  expect_error(t, line_of(t, "carried_by: cam_west"), "objects[0].carried_by", "is a camera, not a person");
  // bob picks up the bag alice starts carrying and never puts down.
  t = replace_once(kGood, "      - put_down: bag1\n        to: [4.2, 3.0]\n", "");
  expect_error(t, line_of(t, "pick_up: bag1"), "people[1].script[1].pick_up",
               "starts carried by 'alice', who never puts it down");
  // put_down of something not held.
  t = replace_once(kGood, "      - touch: laptop1\n", "      - put_down: laptop1\n");
  expect_error(t, line_of(t, "put_down: laptop1"), "people[1].script[3].put_down", "is not carrying 'laptop1'");
  // `at` is a time; a put_down place is `to`.
  t = replace_once(kGood, "        to: [4.2, 3.0]\n", "        at: [4.2, 3.0]\n");
  expect_error(t, line_of(t, "at: [4.2, 3.0]"), "people[0].script[1].at", "use 'to:'");
  t = replace_once(kGood, "      - leave: exit\n", "      - leave: exit\n      - wait: 1\n");
  expect_error(t, line_of(t, "wait: 1\n"), "people[0].script[5]", "no step can follow 'leave'");
  t = replace_once(kGood, "      - wait: 5\n", "      - wait: 5\n        walk_to: west\n");
  expect_error(t, line_of(t, "walk_to: west"), "people[0].script[3].walk_to", "a step does only one thing");
  t = replace_once(kGood, "    kind: box\n", "    kind: crate\n");
  expect_error(t, line_of(t, "kind: crate"), "objects[3].kind", "unknown object kind 'crate'");
  t = replace_once(kGood, "    at: [8.0, 2.0]\n", "");
  expect_error(t, line_of(t, "- id: box1"), "objects[3]", "an object needs 'at'");
}

TEST_F(ScenarioTest, PluginsUrdfsAndColours) {
  ScenarioContext ctx;
  ctx.plugin_exists = [](const std::string& name) { return name == "wander" || name == "waypoint_follower"; };
  ASSERT_TRUE(parse(kGood, ctx).ok());
  std::string t = replace_once(kGood, "    plugin: wander\n", "    plugin: planview\n");
  expect_error(t, line_of(t, "plugin: planview"), "cameras[0].plugin", "unknown plugin 'planview'", ctx);
  EXPECT_TRUE(parse(t).ok()) << "without plugin_exists, plugin names are not checked";
  t = replace_once(kGood, "    controller: waypoint_follower\n", "    controller: teleop\n");
  expect_error(t, line_of(t, "controller: teleop"), "robots[0].controller", "unknown plugin 'teleop'", ctx);
  t = replace_once(kGood, "    urdf: robot.urdf\n    start: [9.0", "    urdf: robots/missing.urdf\n    start: [9.0");
  expect_error(t, line_of(t, "missing.urdf"), "robots[1].urdf", "URDF file '" + (dir_ / "robots/missing.urdf").string());
  t = replace_once(kGood, "    shirt: \"#C03030\"\n", "    shirt: red\n");
  expect_error(t, line_of(t, "shirt: red"), "people[0].shirt", "#rrggbb");
  t = replace_once(kGood, "    shirt: \"#C03030\"\n", "    shirt: #C03030\n");
  expect_error(t, line_of(t, "shirt: #C03030"), "people[0].shirt", "quote it");
  t = replace_once(kGood, "    colour: \"#00FF00\"\n", "    colour: \"#00FF0G\"\n");
  expect_error(t, line_of(t, "#00FF0G"), "objects[3].colour", "6 hex digits");
}

// Applies one random edit of the kinds a hand-edited file suffers.
std::string mutate(const std::string& text, std::mt19937& rng) {
  std::string s = text;
  auto pick = [&](size_t n) { return n == 0 ? size_t{0} : std::uniform_int_distribution<size_t>(0, n - 1)(rng); };
  static const std::string kSpecial = "[]{}:,-#&*!|>'\"%@`?\t\n .0123456789";
  const int edits = 1 + static_cast<int>(pick(3));
  for (int e = 0; e < edits && !s.empty(); ++e) {
    switch (pick(8)) {
      case 0: s[pick(s.size())] = static_cast<char>(pick(256)); break;                  // any byte
      case 1: s[pick(s.size())] = kSpecial[pick(kSpecial.size())]; break;               // YAML syntax
      case 2: {                                                                         // delete a run
        const size_t at = pick(s.size());
        s.erase(at, 1 + pick(std::min<size_t>(40, s.size() - at)));
        break;
      }
      case 3: s.resize(pick(s.size())); break;                                          // truncate
      case 4:
      case 5:
      case 6: {                                                                         // line edits
        std::vector<std::string> lines;
        size_t start = 0;
        while (start <= s.size()) {
          const size_t nl = s.find('\n', start);
          lines.push_back(s.substr(start, nl == std::string::npos ? std::string::npos : nl - start));
          if (nl == std::string::npos) break;
          start = nl + 1;
        }
        const size_t i = pick(lines.size());
        const int kind = static_cast<int>(pick(4));
        if (kind == 0) {
          lines.insert(lines.begin() + static_cast<long>(i), lines[i]);  // duplicate
        } else if (kind == 1) {
          lines[i] = std::string(pick(7), ' ') + lines[i];  // indent more
        } else if (kind == 2) {
          const size_t n = std::min(lines[i].find_first_not_of(' '), lines[i].size());
          lines[i].erase(0, pick(n + 1));  // indent less
        } else {
          std::swap(lines[i], lines[pick(lines.size())]);  // swap two lines
        }
        s.clear();
        for (size_t k = 0; k < lines.size(); ++k) s += lines[k] + (k + 1 < lines.size() ? "\n" : "");
        break;
      }
      case 7: s.insert(pick(s.size() + 1), 1, kSpecial[pick(kSpecial.size())]); break;  // insert
    }
  }
  return s;
}

TEST_F(ScenarioTest, FuzzedScenariosNeverCrashOrHang) {
  std::mt19937 rng(20240611);
  ScenarioContext ctx;
  ctx.plugin_exists = [](const std::string& name) { return name == "wander" || name == "waypoint_follower"; };
  // Bounded by count, not by time: a hang shows as ctest's timeout, a slow machine only runs longer.
  int runs = 0, ok = 0, errors = 0;
  for (; runs < 3000; ++runs) {
    const std::string text = mutate(kGood, rng);
    auto r = parse(text, ctx);
    if (r.ok()) {
      ++ok;
    } else {
      ++errors;
      ASSERT_FALSE(r.error().message.empty()) << "empty message for input:\n" << text;
      ASSERT_FALSE(r.error().str().empty());
    }
  }
  RecordProperty("runs", runs);
  // Both outcomes occur: mutations in comments or values stay valid, most break something.
  EXPECT_GT(ok, 0);
  EXPECT_GT(errors, runs / 2);
}

}  // namespace
}  // namespace vigil

namespace vigil {
namespace {

TEST(FindCamera, ReturnsTheCameraOrListsTheKnownOnes) {
  Scenario sc;
  sc.file = "s.yaml";
  CameraSpec a, b;
  a.id = "cam_a";
  b.id = "cam_b";
  sc.cameras = {a, b};
  auto found = find_camera(sc, "cam_b");
  ASSERT_TRUE(found.ok());
  EXPECT_EQ((*found)->id, "cam_b");
  auto missing = find_camera(sc, "cam_c", "--camera");
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.error().key, "--camera");
  EXPECT_EQ(missing.error().file, "s.yaml");
  EXPECT_NE(missing.error().message.find("cameras: cam_a, cam_b"), std::string::npos) << missing.error().message;
  sc.cameras.clear();
  EXPECT_NE(find_camera(sc, "x").error().message.find("cameras: none"), std::string::npos);
}

}  // namespace
}  // namespace vigil
