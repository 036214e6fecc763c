// Tests world/world and world/runner: people never pass through walls, carried objects stay with
// their carrier, the derived ground-truth events (left bag, bag taken, exchange, unauthorised
// object) match what the scripts make people do, robots obey velocity commands and odometry
// drifts as configured, and the same scenario and seed give the same ground-truth hash.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "plugins/builtin.h"
#include "tests/test_util.h"
#include "world/runner.h"
#include "world/world.h"

namespace vigil {
namespace {

namespace fs = std::filesystem;

// A 24 x 12 m room split by a wall at x = 12 with a 1.2 m door at y = 6.
fs::path write_test_map() {
  const fs::path dir = fs::temp_directory_path() / ("vigil_world_test_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  OccupancyGrid g(480, 240, 0.05, Pose2{0, 0, 0});
  for (int y = 0; y < 240; ++y) {
    for (int x = 0; x < 480; ++x) {
      const bool border = x < 2 || y < 2 || x >= 478 || y >= 238;
      const bool inner = x >= 238 && x < 242 && !(y >= 108 && y < 132);
      if (border || inner) g.set(x, y, Cell::kOccupied);
    }
  }
  const fs::path yaml = dir / "room.yaml";
  EXPECT_TRUE(save_map_yaml(g, yaml).ok());
  return yaml;
}

PlaceRef at(double x, double y) {
  PlaceRef p;
  p.point = {x, y};
  return p;
}

Action walk(double x, double y) {
  Action a;
  a.kind = ActionKind::kWalkTo;
  a.target = at(x, y);
  return a;
}
Action act(ActionKind k, const std::string& obj, double seconds = 1.0) {
  Action a;
  a.kind = k;
  a.object = obj;
  a.duration = seconds;
  return a;
}
Action wait_s(double s) {
  Action a;
  a.kind = ActionKind::kWait;
  a.duration = s;
  return a;
}

Scenario base_scenario(double duration) {
  static const fs::path map = write_test_map();
  Scenario sc;
  sc.file = "world_test.yaml";
  sc.name = "world_test";
  sc.map = map;
  sc.duration = duration;
  sc.seed = 3;
  return sc;
}

PersonSpec person(const std::string& id, double x, double y) {
  PersonSpec p;
  p.id = id;
  p.start = at(x, y);
  return p;
}

ObjectSpec object(const std::string& id, ObjectKind kind, double x, double y) {
  ObjectSpec o;
  o.id = id;
  o.kind = kind;
  o.position = at(x, y);
  o.size_x = o.size_y = 0.3;
  return o;
}

std::unique_ptr<World> make_world(const Scenario& sc) {
  WorldOptions wo;
  wo.plugins = builtin_plugin_registry();
  wo.plugin_dirs = {test::plugin_dir()};
  auto w = World::create(sc, wo);
  EXPECT_TRUE(w.ok()) << (w.ok() ? "" : w.error().str());
  return w.ok() ? std::move(*w) : nullptr;
}

// Runs to the end, calling `check` after every step.
template <class F>
void run(World& w, F check) {
  while (!w.finished()) {
    Status s = w.advance();
    ASSERT_TRUE(s.ok()) << s.error().str();
    check(w);
  }
}

}  // namespace

TEST(World, PeopleNeverPassThroughWallsAndReachTheirGoal) {
  Scenario sc = base_scenario(40);
  PersonSpec a = person("A", 3, 3);
  a.script = {walk(20, 9), walk(3, 10)};
  PersonSpec b = person("B", 20, 3);
  b.script = {walk(3, 9)};  // crosses A at the door
  sc.people = {a, b};
  auto w = make_world(sc);
  ASSERT_TRUE(w);
  bool a_crossed = false;
  run(*w, [&](const World& world) {
    for (const auto& p : world.people()) {
      // Body inside free space (Box2D allows a few mm of contact slop).
      ASSERT_TRUE(world.map().is_free_disc(p.pose.position(), p.spec.radius - 0.03))
          << p.spec.id << " at " << p.pose.x << ", " << p.pose.y << " t=" << to_seconds(world.time());
    }
    if (world.people()[0].pose.x > 12.5) a_crossed = true;
  });
  EXPECT_TRUE(a_crossed);
  EXPECT_NEAR(w->people()[0].pose.x, 3, 0.3);
  EXPECT_NEAR(w->people()[0].pose.y, 10, 0.3);
  EXPECT_NEAR(w->people()[1].pose.x, 3, 0.3);
  EXPECT_NEAR(w->people()[1].pose.y, 9, 0.3);
}

TEST(World, LeftBagThenBagTaken) {
  Scenario sc = base_scenario(60);
  PersonSpec a = person("A", 2, 6);
  a.script = {walk(8, 6), act(ActionKind::kPutDown, "bag1"), walk(20, 3), wait_s(60)};
  PersonSpec b = person("B", 9, 10);
  Action start = walk(9, 9);
  start.at = 30.0;
  Action leave;
  leave.kind = ActionKind::kLeave;
  leave.target = at(22, 10);
  b.script = {start, act(ActionKind::kPickUp, "bag1"), leave};
  sc.people = {a, b};
  ObjectSpec bag = object("bag1", ObjectKind::kBag, 0, 0);
  bag.carried_by = "A";
  bag.owner = "A";
  sc.objects = {bag};
  auto w = make_world(sc);
  ASSERT_TRUE(w);
  SimTime put_down = -1;
  run(*w, [&](const World& world) {
    const auto& o = world.objects()[0];
    if (o.carrier >= 0) {
      const auto& c = world.people()[o.carrier];
      ASSERT_LT((o.pose.position() - c.pose.position()).norm(), 0.6) << "carried bag left its carrier";
    }
    if (put_down < 0 && o.carrier < 0) put_down = world.time();
  });
  ASSERT_GT(put_down, 0);
  ASSERT_EQ(w->events().size(), 2u);
  const auto& left = w->events()[0];
  EXPECT_EQ(left.kind, "left_bag");
  EXPECT_EQ(left.people, std::vector<std::string>{"A"});
  EXPECT_EQ(left.object, "bag1");
  // Set down at A's right side where it was carried, A facing +x at (8, 6).
  EXPECT_NEAR(left.where.x, 8.0, 0.3);
  EXPECT_NEAR(left.where.y, 5.55, 0.3);
  // A walks about 1.2 m/s: more than 3 m away roughly 2.5 s after the drop, confirmed 5 s later.
  EXPECT_GT(left.t, put_down);
  EXPECT_LT(left.t, put_down + from_seconds(5));
  EXPECT_EQ(left.confirmed - left.t, from_seconds(sc.rules.left_bag_time));
  const auto& taken = w->events()[1];
  EXPECT_EQ(taken.kind, "bag_taken");
  EXPECT_EQ(taken.people, std::vector<std::string>{"B"});
  EXPECT_EQ(taken.owner, "A");
  EXPECT_GT(taken.t, from_seconds(30));
  // B left with the bag: both gone.
  EXPECT_TRUE(w->people()[1].gone);
  EXPECT_FALSE(w->objects()[0].present);
}

// A walk whose last point lies beside a bag on the floor: the bag's repulsion holds the walker
// about 0.14 m off the point, which it had never counted as reached, so the walk (and the
// pick-up after it) never ended. Found by the soak (tools/soak.sh); now the walker, held near
// the point without progress for a stuck window, has arrived.
TEST(World, AWalkEndingBesideABagEndsAndThePickUpFollows) {
  Scenario sc = base_scenario(40);
  PersonSpec t = person("T", 16, 6);
  t.script = {walk(9.15, 6.0), act(ActionKind::kPickUp, "bag1"), walk(16, 6)};
  sc.people = {t};
  ObjectSpec bag = object("bag1", ObjectKind::kBag, 9.0, 5.56);
  sc.objects = {bag};
  auto w = make_world(sc);
  ASSERT_TRUE(w);
  SimTime picked = -1;
  run(*w, [&](const World& world) {
    if (picked < 0 && world.objects()[0].carrier == 0) picked = world.time();
  });
  ASSERT_GT(picked, 0) << "the walker never arrived beside the bag, so never picked it up";
  EXPECT_LT(picked, from_seconds(15));
  EXPECT_LT((w->people()[0].pose.position() - Vec2{16, 6}).norm(), 0.3) << "and walked on with it";
}

TEST(World, HandOverNearTheOwnerIsAnExchangeNotALeftBag) {
  Scenario sc = base_scenario(30);
  PersonSpec a = person("A", 2, 6);
  a.script = {walk(6, 6), act(ActionKind::kPutDown, "bag1"), wait_s(30)};
  PersonSpec b = person("B", 8, 3);
  Action go = walk(7.2, 4.8);
  go.at = 10.0;
  b.script = {go, act(ActionKind::kPickUp, "bag1"), walk(10, 3)};
  sc.people = {a, b};
  ObjectSpec bag = object("bag1", ObjectKind::kBag, 0, 0);
  bag.carried_by = "A";
  sc.objects = {bag};
  auto w = make_world(sc);
  ASSERT_TRUE(w);
  run(*w, [](const World&) {});
  ASSERT_EQ(w->events().size(), 1u);
  EXPECT_EQ(w->events()[0].kind, "exchange");
  EXPECT_EQ(w->events()[0].people, (std::vector<std::string>{"A", "B"}));
}

TEST(World, TouchingAnUnauthorisedObjectRaisesAnEventOwnObjectsDoNot) {
  Scenario sc = base_scenario(40);
  PersonSpec p = person("P", 14, 6);
  p.script = {act(ActionKind::kTouch, "book", 2), act(ActionKind::kPickUp, "bottle"),
              act(ActionKind::kPutDown, "bottle"), act(ActionKind::kTouch, "laptop", 2)};
  sc.people = {p};
  ObjectSpec book = object("book", ObjectKind::kBook, 16, 6);
  book.owner = "P";
  book.authorised = false;
  ObjectSpec bottle = object("bottle", ObjectKind::kBottle, 16, 4);
  bottle.authorised = true;
  ObjectSpec laptop = object("laptop", ObjectKind::kLaptop, 20, 8);
  laptop.authorised = false;
  sc.objects = {book, bottle, laptop};
  auto w = make_world(sc);
  ASSERT_TRUE(w);
  run(*w, [](const World&) {});
  ASSERT_EQ(w->events().size(), 1u);
  EXPECT_EQ(w->events()[0].kind, "unauthorised_object");
  EXPECT_EQ(w->events()[0].object, "laptop");
  EXPECT_NEAR(w->events()[0].where.x, 20, 1e-6);
  // The person walked to within reach of the laptop to touch it.
  size_t touches = 0;
  for (const auto& a : w->actions()) touches += a.action == "touch";
  EXPECT_EQ(touches, 2u);
}

TEST(World, UnreachablePlaceIsAnErrorNamingTheScenarioLine) {
  Scenario sc = base_scenario(20);
  PersonSpec p = person("P", 3, 3);
  Action a = walk(30, 30);  // outside the map
  a.line = 17;
  p.script = {a};
  sc.people = {p};
  auto w = make_world(sc);
  ASSERT_TRUE(w);
  Status s;
  while (!w->finished() && s.ok()) s = w->advance();
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().str().find("world_test.yaml:17"), std::string::npos) << s.error().str();
  EXPECT_NE(s.error().str().find("cannot reach"), std::string::npos);
}

TEST(World, TwoPeopleReachingForOneBagIsAnErrorForTheSecond) {
  Scenario sc = base_scenario(20);
  PersonSpec a = person("A", 5, 6);
  Action pa = act(ActionKind::kPickUp, "bag1", 1.0);
  pa.line = 11;
  a.script = {pa};
  PersonSpec b = person("B", 7, 6);
  Action pb = act(ActionKind::kPickUp, "bag1", 3.0);  // slower hands: A gets it first
  pb.line = 14;
  b.script = {pb};
  sc.people = {a, b};
  sc.objects = {object("bag1", ObjectKind::kBag, 6, 6)};
  auto w = make_world(sc);
  ASSERT_TRUE(w);
  Status s;
  while (!w->finished() && s.ok()) s = w->advance();
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().str().find("world_test.yaml:14"), std::string::npos) << s.error().str();
  EXPECT_EQ(w->objects()[0].carrier, 0);
}

TEST(World, RobotOdometryDriftsByItsBias) {
  Scenario sc = base_scenario(25);
  RobotSpec r;
  r.id = "r1";
  r.urdf = test::source_dir() / "maps/robots/erratic.urdf";
  r.start = {3, 6, 0};
  r.controller = "waypoint_follower";
  r.params["points"] = {std::vector<double>{9, 6}, 1};
  r.params["loop"] = {false, 1};
  r.odometry.error_x = 0.05;
  r.odometry.error_yaw = 0.1;
  sc.robots = {r};
  auto w = make_world(sc);
  ASSERT_TRUE(w);
  run(*w, [](const World& world) {
    ASSERT_TRUE(world.map().is_free(world.robots()[0].pose.position()));
  });
  const auto& st = w->robots()[0].state;
  const Pose2 truth = w->robots()[0].pose;
  // waypoint_follower drives on its odometry: that reached the waypoint (0.4 m/s for about 6 m).
  EXPECT_NEAR(st.odometry.x, 9, 0.35);
  EXPECT_NEAR(st.odometry.y, 6, 0.35);
  // Odometry follows the true path with the drawn bias: off, but within 5% of the distance.
  const double odo_err = (st.odometry.position() - truth.position()).norm();
  EXPECT_GT(odo_err, 1e-4);
  EXPECT_LT(odo_err, 0.05 * 6 + 0.05);
}

TEST(World, UnknownSpaceBorderingFreeSpaceIsAWall) {
  // A free 6 x 4 m area inside unknown space with no wall at all, as SLAM maps have in places.
  const fs::path dir = fs::temp_directory_path() / ("vigil_world_unknown_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  OccupancyGrid g(200, 120, 0.05, Pose2{0, 0, 0}, Cell::kUnknown);
  for (int y = 40; y < 80; ++y)
    for (int x = 40; x < 160; ++x) g.set(x, y, Cell::kFree);
  ASSERT_TRUE(save_map_yaml(g, dir / "island.yaml").ok());
  Scenario sc = base_scenario(30);
  sc.map = dir / "island.yaml";
  for (int i = 0; i < 3; ++i) {
    RobotSpec r;
    r.id = "r" + std::to_string(i);
    r.urdf = test::source_dir() / "maps/robots/erratic.urdf";
    r.start = {3.0 + i, 3, 0.5 + i};
    r.controller = "wander";
    r.ranger.enabled = true;
    sc.robots.push_back(r);
  }
  auto w = make_world(sc);
  ASSERT_TRUE(w);
  run(*w, [&](const World& world) {
    for (const auto& r : world.robots()) ASSERT_TRUE(g.is_free(r.pose.position())) << r.spec.id;
  });
  // The laser sees the edge of the known area as a wall.
  const auto& scan = w->robots()[0].scan;
  ASSERT_FALSE(scan.ranges.empty());
  EXPECT_LT(*std::min_element(scan.ranges.begin(), scan.ranges.end()), 4.0f);
}

TEST(World, SpecksOfUnknownInsideFreeSpaceAreFloorLargerPatchesWalls) {
  // SLAM maps leave specks of a few unseen cells in corridors; they are not pillars. A patch of
  // 4 x 4 cells (16 > 12) is kept, and sealed as a wall where it meets the free space.
  const fs::path dir = fs::temp_directory_path() / ("vigil_world_specks_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  OccupancyGrid g(200, 120, 0.05, Pose2{0, 0, 0}, Cell::kUnknown);
  for (int y = 40; y < 80; ++y)
    for (int x = 40; x < 160; ++x) g.set(x, y, Cell::kFree);
  g.set(60, 60, Cell::kUnknown);
  g.set(61, 60, Cell::kUnknown);
  g.set(61, 61, Cell::kUnknown);
  for (int y = 50; y < 54; ++y)
    for (int x = 100; x < 104; ++x) g.set(x, y, Cell::kUnknown);
  ASSERT_TRUE(save_map_yaml(g, dir / "specks.yaml").ok());
  Scenario sc = base_scenario(1);
  sc.map = dir / "specks.yaml";
  auto w = make_world(sc);
  ASSERT_TRUE(w);
  const OccupancyGrid& m = w->map();
  EXPECT_EQ(m.at(60, 60), Cell::kFree);
  EXPECT_EQ(m.at(61, 61), Cell::kFree);
  EXPECT_EQ(m.at(100, 50), Cell::kOccupied);  // patch edge, sealed
  EXPECT_EQ(m.at(39, 60), Cell::kOccupied);   // the island's rim, sealed
  fs::remove_all(dir);
}

TEST(Runner, ObserversSeeEveryStepBetweenStartAndFinish) {
  struct Counter : RunObserver {
    int starts = 0, steps = 0, finishes = 0;
    SimTime last = -1;
    bool ordered = true;
    Status start(const World& w, const fs::path&) override {
      starts++;
      ordered = ordered && w.time() == 0;
      return Status::Ok();
    }
    Status after_step(const World& w) override {
      steps++;
      ordered = ordered && w.time() > last && starts == 1 && finishes == 0;
      last = w.time();
      return Status::Ok();
    }
    Status finish(const World& w) override {
      finishes++;
      ordered = ordered && w.finished();
      return Status::Ok();
    }
  } counter;
  struct Failing : RunObserver {
    Status after_step(const World& w) override {
      return w.time() >= from_seconds(1) ? Status(internal_error("camera broke")) : Status::Ok();
    }
  } failing;
  Scenario sc = base_scenario(2);
  RunOptions ro;
  ro.world.plugins = builtin_plugin_registry();
  ro.observers = {&counter};
  auto sum = run_scenario(sc, ro);
  ASSERT_TRUE(sum.ok()) << sum.error().str();
  EXPECT_EQ(counter.starts, 1);
  EXPECT_EQ(counter.finishes, 1);
  EXPECT_EQ(counter.steps, static_cast<int>(sum->steps));
  EXPECT_TRUE(counter.ordered);
  ro.observers = {&failing};
  auto bad = run_scenario(sc, ro);
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().message, "camera broke");
}

TEST(World, SameSeedSameHashOtherSeedWithNoiseDiffers) {
  Scenario sc = base_scenario(15);
  PersonSpec a = person("A", 2, 6);
  a.script = {walk(20, 9)};
  sc.people = {a};
  for (int i = 0; i < 3; ++i) {
    RobotSpec r;
    r.id = "r" + std::to_string(i);
    r.urdf = test::source_dir() / "maps/robots/erratic.urdf";
    r.start = {4.0 + 2 * i, 3, 0.3 * i};
    r.controller = "wander";
    r.ranger.enabled = true;
    r.ranger.noise_std = 0.01;
    r.odometry.error_x = 0.02;
    r.odometry.error_yaw = 0.05;
    sc.robots.push_back(r);
  }
  RunOptions ro;
  ro.world.plugins = builtin_plugin_registry();
  ro.world.plugin_dirs = {test::plugin_dir()};
  auto first = run_scenario(sc, ro);
  auto second = run_scenario(sc, ro);
  ASSERT_TRUE(first.ok()) << first.error().str();
  ASSERT_TRUE(second.ok());
  EXPECT_EQ(first->ground_truth_sha256, second->ground_truth_sha256);
  EXPECT_EQ(first->ground_truth_sha256.size(), 64u);
  ro.seed = 4;
  auto other = run_scenario(sc, ro);
  ASSERT_TRUE(other.ok());
  EXPECT_NE(first->ground_truth_sha256, other->ground_truth_sha256);
  EXPECT_EQ(first->steps, 1500u);
}

}  // namespace vigil
