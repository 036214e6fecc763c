// Tests world/plugin and the shipped plugins: a controller loads from its shared library by
// name (and from the static registry), declared parameters are checked with file/line/key
// errors, an unknown plugin is a clear error, and the loaded waypoint_follower drives a robot
// through its waypoints around a wall.
#include <gtest/gtest.h>

#include <unistd.h>

#include "plugins/builtin.h"
#include "tests/test_util.h"
#include "world/plugin.h"
#include "world/world.h"

namespace vigil {
namespace {

namespace fs = std::filesystem;

std::map<std::string, ParamEntry> entries(std::initializer_list<std::pair<const std::string, ParamEntry>> l) {
  return std::map<std::string, ParamEntry>(l);
}

}  // namespace

TEST(PluginRegistry, LoadsWaypointFollowerFromItsSharedLibrary) {
  PluginRegistry reg;
  register_builtin_plugins(reg);
  reg.add_search_dir(test::plugin_dir());
  reg.set_prefer_shared(true);
  ASSERT_TRUE(fs::exists(test::plugin_dir() / "libvigil_plugin_waypoint_follower.so"));
  auto p = reg.create("waypoint_follower");
  ASSERT_TRUE(p.ok()) << p.error().str();
  EXPECT_EQ(reg.origin("waypoint_follower"), (test::plugin_dir() / "libvigil_plugin_waypoint_follower.so").string());
  std::vector<std::string> names;
  for (const auto& s : (*p)->params()) names.push_back(s.name);
  EXPECT_NE(std::find(names.begin(), names.end(), "waypoints"), names.end());
  auto w = reg.create("wander");
  ASSERT_TRUE(w.ok()) << w.error().str();
  EXPECT_NE(reg.origin("wander").find(".so"), std::string::npos);
}

TEST(PluginRegistry, BuiltinsWithoutSearchPathAndUnknownNames) {
  PluginRegistry reg;
  register_builtin_plugins(reg);
  EXPECT_TRUE(reg.exists("waypoint_follower"));
  auto p = reg.create("waypoint_follower");
  ASSERT_TRUE(p.ok());
  EXPECT_EQ(reg.origin("waypoint_follower"), "builtin");
  EXPECT_FALSE(reg.exists("no_such_plugin"));
  auto bad = reg.create("no_such_plugin");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().str().find("no_such_plugin"), std::string::npos);
}

TEST(PluginRegistry, RefusesALibraryWithoutTheEntryPoint) {
  // A shared library that is not a plugin: any system library will do, copied under a plugin name.
  const fs::path dir = fs::temp_directory_path() / ("vigil_plugin_test_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  fs::path some_lib;
  for (const char* cand : {"/lib/x86_64-linux-gnu/libz.so.1", "/usr/lib/x86_64-linux-gnu/libz.so.1"})
    if (fs::exists(cand)) some_lib = cand;
  if (some_lib.empty()) GTEST_SKIP() << "no libz to use as a non-plugin library";
  fs::copy_file(some_lib, dir / "libvigil_plugin_fake.so", fs::copy_options::overwrite_existing);
  PluginRegistry reg;
  reg.add_search_dir(dir);
  auto p = reg.create("fake");
  ASSERT_FALSE(p.ok());
  EXPECT_NE(p.error().str().find("vigil_plugin_entry"), std::string::npos) << p.error().str();
  EXPECT_NE(p.error().str().find("libvigil_plugin_fake.so"), std::string::npos);
}

TEST(Params, CheckedAgainstTheDeclarationWithFileLineAndKey) {
  const std::vector<ParamSpec> specs = {
      {"speed", ParamType::kNumber, 0.4, 0.01, 3.0, ""},
      {"count", ParamType::kInteger, 3.0, 1, 10, ""},
      {"loop", ParamType::kBool, true, 0, 0, ""},
      {"waypoints", ParamType::kStringList, std::vector<std::string>{}, 0, 0, ""},
  };
  auto ok = resolve_params(specs, entries({{"speed", {1.5, 12}}}), "s.yaml", "robots[0].params");
  ASSERT_TRUE(ok.ok());
  EXPECT_DOUBLE_EQ(ok->number("speed"), 1.5);
  EXPECT_EQ(ok->integer("count"), 3);  // default
  EXPECT_TRUE(ok->boolean("loop"));

  auto unknown = resolve_params(specs, entries({{"sped", {1.5, 12}}}), "s.yaml", "robots[0].params");
  ASSERT_FALSE(unknown.ok());
  EXPECT_EQ(unknown.error().str().rfind("s.yaml:12: robots[0].params.sped: unknown parameter", 0), 0u)
      << unknown.error().str();
  auto range = resolve_params(specs, entries({{"speed", {9.0, 13}}}), "s.yaml", "p");
  ASSERT_FALSE(range.ok());
  EXPECT_NE(range.error().str().find("s.yaml:13: p.speed"), std::string::npos);
  auto type = resolve_params(specs, entries({{"loop", {std::string("yes"), 14}}}), "s.yaml", "p");
  ASSERT_FALSE(type.ok());
  EXPECT_NE(type.error().str().find("p.loop: expected a bool"), std::string::npos);
  auto integer = resolve_params(specs, entries({{"count", {2.5, 15}}}), "s.yaml", "p");
  ASSERT_FALSE(integer.ok());
  EXPECT_NE(integer.error().str().find("integer"), std::string::npos);
}

TEST(WaypointFollower, FromSharedLibraryDrivesAroundAWallThroughItsWaypoints) {
  // 12 x 8 m room with a wall across the middle (x = 6) open at the top.
  const fs::path dir = fs::temp_directory_path() / ("vigil_plugin_map_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  OccupancyGrid g(240, 160, 0.05, Pose2{0, 0, 0});
  for (int y = 0; y < 160; ++y)
    for (int x = 0; x < 240; ++x)
      if (x < 2 || y < 2 || x >= 238 || y >= 158 || (x >= 118 && x < 122 && y < 110)) g.set(x, y, Cell::kOccupied);
  ASSERT_TRUE(save_map_yaml(g, dir / "wall.yaml").ok());

  Scenario sc;
  sc.file = "plugin_test.yaml";
  sc.map = dir / "wall.yaml";
  sc.duration = 60;
  sc.places = {{"left", {3, 2}}, {"right", {9, 2}}};
  RobotSpec r;
  r.id = "r1";
  r.urdf = test::source_dir() / "maps/robots/erratic.urdf";
  r.start = {3, 2, 0};
  r.controller = "waypoint_follower";
  r.params["waypoints"] = {std::vector<std::string>{"right"}, 5};
  r.params["loop"] = {false, 6};
  r.params["speed"] = {0.6, 7};
  r.ranger.enabled = true;
  sc.robots = {r};
  WorldOptions wo;
  wo.plugins = builtin_plugin_registry();
  wo.plugin_dirs = {test::plugin_dir()};
  wo.prefer_shared_plugins = true;
  auto w = World::create(sc, wo);
  ASSERT_TRUE(w.ok()) << w.error().str();
  double max_y = 0;
  while (!(*w)->finished()) {
    ASSERT_TRUE((*w)->advance().ok());
    const auto& pose = (*w)->robots()[0].pose;
    max_y = std::max(max_y, pose.y);
    ASSERT_TRUE(g.is_free(pose.position()));
  }
  const auto& pose = (*w)->robots()[0].pose;
  EXPECT_NEAR(pose.x, 9, 0.35);
  EXPECT_NEAR(pose.y, 2, 0.35);
  EXPECT_GT(max_y, 5.5);  // it went round the top of the wall

  // A waypoint naming a place that does not exist is a configuration error naming the key.
  sc.robots[0].params["waypoints"] = {std::vector<std::string>{"nowhere"}, 5};
  auto bad = World::create(sc, wo);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().str().find("params.waypoints"), std::string::npos) << bad.error().str();
  EXPECT_NE(bad.error().str().find("nowhere"), std::string::npos);
}

}  // namespace vigil
