// Tests world/ranger: exact ray hits on discs and boxes, the spatial index, and whole scans in a
// room whose distances are known by hand (walls, a person in front, the robot's own body).
#include <gtest/gtest.h>

#include <cmath>

#include "world/ranger.h"
#include "common/rng.h"

namespace vigil {
namespace {

// A 10 x 6 m room with 0.1 m walls, 5 cm cells, origin (0, 0).
OccupancyGrid room() {
  OccupancyGrid g(200, 120, 0.05, Pose2{0, 0, 0});
  for (int y = 0; y < 120; ++y)
    for (int x = 0; x < 200; ++x)
      if (x < 2 || y < 2 || x >= 198 || y >= 118) g.set(x, y, Cell::kOccupied);
  return g;
}

}  // namespace

TEST(Ranger, RayHitsDiscAndBoxExactly) {
  EXPECT_NEAR(ray_hit_circle({0, 0}, {1, 0}, {5, 0}, 1.0), 4.0, 1e-12);
  EXPECT_TRUE(std::isinf(ray_hit_circle({0, 0}, {1, 0}, {5, 2}, 1.0)));   // passes by
  EXPECT_TRUE(std::isinf(ray_hit_circle({0, 0}, {-1, 0}, {5, 0}, 1.0)));  // behind
  EXPECT_NEAR(ray_hit_box({0, 0}, {1, 0}, {3, 0}, 0.0, 0.5, 0.25), 2.5, 1e-12);
  // A box turned 45 degrees presents its corner: hit at 3 - 0.5*sqrt(2).
  EXPECT_NEAR(ray_hit_box({0, 0}, {1, 0}, {3, 0}, M_PI / 4, 0.5, 0.5), 3 - 0.5 * std::sqrt(2.0), 1e-9);
  EXPECT_TRUE(std::isinf(ray_hit_box({0, 0}, {0, 1}, {3, 0}, 0.0, 0.5, 0.5)));
}

TEST(Ranger, IndexFindsNearestAndSkipsOwner) {
  ObstacleIndex idx({0, 0}, {20, 20}, 1.0);
  RangeObstacle a, b;
  a.center = {5, 5};
  a.radius = 0.5;
  a.owner = 1;
  b.center = {9, 5};
  b.radius = 0.5;
  b.owner = 2;
  idx.rebuild({a, b});
  EXPECT_NEAR(idx.raycast({1, 5}, 0.0, 20.0, -1), 3.5, 1e-9);
  EXPECT_NEAR(idx.raycast({1, 5}, 0.0, 20.0, 1), 7.5, 1e-9);  // own body skipped
  EXPECT_TRUE(std::isinf(idx.raycast({1, 5}, 0.0, 3.0, -1)));  // beyond max range
  EXPECT_TRUE(std::isinf(idx.raycast({1, 5}, M_PI / 2, 20.0, -1)));
}

TEST(Ranger, ScanInKnownRoom) {
  const OccupancyGrid g = room();
  const WallRaycaster walls(g);
  ObstacleIndex idx({0, 0}, {10, 6}, 1.0);
  RangeObstacle person;
  person.center = {5, 4.5};
  person.radius = 0.25;
  idx.rebuild({person});
  RangerSpec spec;
  spec.enabled = true;
  spec.samples = 181;
  spec.fov = M_PI;  // -90..+90 deg, 1 deg apart
  spec.range_max = 20;
  LaserScan scan;
  // Sensor at (2, 3) facing +x: wall at x = 9.9 straight ahead, side walls 2.9 m away.
  simulate_scan(walls, idx, {2, 3, 0}, spec, -1, nullptr, 0, &scan);
  ASSERT_EQ(scan.ranges.size(), 181u);
  EXPECT_NEAR(scan.angle_min, -M_PI / 2, 1e-12);
  EXPECT_NEAR(scan.ranges[90], 7.9, 0.05);
  EXPECT_NEAR(scan.ranges[0], 2.9, 0.05);
  EXPECT_NEAR(scan.ranges[180], 2.9, 0.05);
  // Facing +y from (5, 2): the person's disc at 2.5 m, nearer than the wall at 3.9 m.
  simulate_scan(walls, idx, {5, 2, M_PI / 2}, spec, -1, nullptr, 0, &scan);
  EXPECT_NEAR(scan.ranges[90], 2.25, 1e-4);
}

TEST(Ranger, NoiseIsSeededAndClamped) {
  const OccupancyGrid g = room();
  const WallRaycaster walls(g);
  ObstacleIndex idx({0, 0}, {10, 6}, 1.0);
  idx.rebuild({});
  RangerSpec spec;
  spec.samples = 50;
  spec.noise_std = 0.05;
  spec.range_max = 4.0;
  LaserScan a, b, c;
  Rng r1(7), r2(7), r3(8);
  simulate_scan(walls, idx, {2, 3, 0}, spec, -1, &r1, 0, &a);
  simulate_scan(walls, idx, {2, 3, 0}, spec, -1, &r2, 0, &b);
  simulate_scan(walls, idx, {2, 3, 0}, spec, -1, &r3, 0, &c);
  EXPECT_EQ(a.ranges, b.ranges);
  EXPECT_NE(a.ranges, c.ranges);
  for (float r : a.ranges) {
    EXPECT_GE(r, spec.range_min);
    EXPECT_LE(r, spec.range_max);
  }
}

TEST(Ranger, AcceleratedWallRaysMatchExactGridTraversal) {
  // A cluttered map: the room plus pillars and thin walls at seeded random places.
  OccupancyGrid g = room();
  Rng rng(11);
  for (int k = 0; k < 60; ++k) {
    const int x0 = static_cast<int>(rng.uniform(4, 190)), y0 = static_cast<int>(rng.uniform(4, 110));
    const int w = static_cast<int>(rng.uniform(1, 8)), h = static_cast<int>(rng.uniform(1, 8));
    for (int y = y0; y < std::min(118, y0 + h); ++y)
      for (int x = x0; x < std::min(198, x0 + w); ++x) g.set(x, y, Cell::kOccupied);
  }
  const WallRaycaster walls(g);
  int checked = 0;
  for (int k = 0; k < 5000; ++k) {
    const Vec2 o{rng.uniform(0.2, 9.8), rng.uniform(0.2, 5.8)};
    if (!g.is_free(o)) continue;
    const double a = rng.uniform(-M_PI, M_PI);
    const double max_range = rng.uniform(0.5, 12.0);
    ASSERT_NEAR(walls.raycast(o, a, max_range), g.raycast(o, a, max_range), 1e-6)
        << "from " << o.x << ", " << o.y << " angle " << a;
    ++checked;
  }
  EXPECT_GT(checked, 3000);
}

}  // namespace vigil
