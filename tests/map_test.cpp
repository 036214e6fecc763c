// Tests of world/map: loading the real DIS/DIAG maps (map_server YAML and Stage worldfile),
// grid queries (cells, free discs, exact ray casting), wall rectangles, the grid path planner,
// saving, and the errors every malformed map file must give (file, line and key named).
#include "world/map.h"
#include "planning/grid/grid_astar.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <iostream>
#include <random>
#include <string>
#include <vector>

#include <unistd.h>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "tests/test_util.h"

namespace vigil {
namespace {

namespace fs = std::filesystem;
using planning::GridPathPlanner;

fs::path labs_dir() { return test::shared_data() / "maps" / "DIAG_labs"; }
fs::path floor1_dir() { return test::shared_data() / "maps" / "DIAG_floor1"; }

// Cell counts of the real maps, obtained once with a few lines of Python (not with this code):
// parse the PGM header (skipping its GIMP comment), take the w*h bytes after it and apply
// map_server's rule p = (255 - v) / 255, occupied if p > occupied_thresh, free if
// p < free_thresh, unknown otherwise, with the thresholds of each YAML (labs 0.40/0.10,
// floor1 0.60/0.40); Stage's rule is v < 128 occupied, the rest free.
constexpr size_t kLabsFree = 128601, kLabsOccupied = 9173, kLabsUnknown = 662226;
constexpr size_t kLabsStageOccupied = 8126;
constexpr size_t kFloor1Free = 326965, kFloor1Occupied = 24111, kFloor1Unknown = 1770827;

// The centre of pixel (px, py), py counted from the bottom as in the .graph files, on a map
// whose origin is (0, 0) at 0.05 m per pixel.
Vec2 graph_pixel(int px, int py) { return {(px + 0.5) * 0.05, (py + 0.5) * 0.05}; }

// Every point along the path, every res/20, is on a free cell (and has `clearance` if > 0).
void expect_path_clear(const OccupancyGrid& grid, const GridPathPlanner& planner,
                       const std::vector<Vec2>& path, double clearance) {
  const double step = grid.resolution() / 20;
  for (size_t i = 0; i + 1 < path.size(); ++i) {
    const Vec2 a = path[i], b = path[i + 1];
    const int n = std::max(1, static_cast<int>(std::ceil((b - a).norm() / step)));
    for (int k = 0; k <= n; ++k) {
      const Vec2 p = a + (b - a) * (static_cast<double>(k) / n);
      ASSERT_TRUE(grid.is_free(p)) << "segment " << i << " crosses a non-free cell at (" << p.x << ", "
                                   << p.y << ")";
      if (clearance > 0) {
        ASSERT_GE(planner.clearance_at(p), clearance - 1e-6)
            << "segment " << i << " enters the clearance margin at (" << p.x << ", " << p.y << ")";
      }
    }
  }
}

double path_length(const std::vector<Vec2>& path) {
  double len = 0;
  for (size_t i = 0; i + 1 < path.size(); ++i) len += (path[i + 1] - path[i]).norm();
  return len;
}

// ---------------------------------------------------------------------------------------------
// Real maps

TEST(RealMaps, DiagLabsYamlHasTheExpectedSizeAndCells) {
  VIGIL_REQUIRE_SHARED_DATA();
  auto grid = load_map_yaml(labs_dir() / "DIAG_labs.yaml");
  ASSERT_TRUE(grid.ok()) << grid.error().str();
  EXPECT_EQ(grid->width(), 1000);
  EXPECT_EQ(grid->height(), 800);
  EXPECT_DOUBLE_EQ(grid->resolution(), 0.05);
  EXPECT_EQ(grid->origin(), (Pose2{0, 0, 0}));
  EXPECT_EQ(grid->count(Cell::kFree), kLabsFree);
  EXPECT_EQ(grid->count(Cell::kOccupied), kLabsOccupied);
  EXPECT_EQ(grid->count(Cell::kUnknown), kLabsUnknown);

  // Patrol graph vertex 8 at pixel (190, 442): (9.525, 22.125) m, in the west corridor.
  const Vec2 corridor = graph_pixel(190, 442);
  EXPECT_NEAR(corridor.x, 9.525, 1e-12);
  EXPECT_NEAR(corridor.y, 22.125, 1e-12);
  EXPECT_TRUE(grid->is_free(corridor));
  int cx = -1, cy = -1;
  ASSERT_TRUE(grid->world_to_cell(corridor, &cx, &cy));
  EXPECT_EQ(cx, 190);
  EXPECT_EQ(cy, 442);
  // The same row 27 pixels east, pixel (217, 442), grey 92 in the PGM, is the corridor's wall;
  // pixel (27, 442), grey 0, the wall far to the west.
  EXPECT_EQ(grid->at(217, 442), Cell::kOccupied);
  EXPECT_FALSE(grid->is_free(graph_pixel(217, 442)));
  EXPECT_EQ(grid->at(27, 442), Cell::kOccupied);
  // A ray east from the vertex stops at that wall: 217 - 190.5 cells.
  EXPECT_NEAR(grid->raycast(corridor, 0.0, 20.0), (217 - 190.5) * 0.05, 1e-9);
  // Outside the grid is never free.
  EXPECT_FALSE(grid->is_free({-0.01, 1.0}));
  EXPECT_FALSE(grid->is_free({50.0, 1.0}));
}

TEST(RealMaps, DiagLabsWorldfileAgreesWithTheYaml) {
  VIGIL_REQUIRE_SHARED_DATA();
  auto yaml = load_map_yaml(labs_dir() / "DIAG_labs.yaml");
  auto world = load_map(labs_dir() / "DIAG_labs.world");
  ASSERT_TRUE(yaml.ok()) << yaml.error().str();
  ASSERT_TRUE(world.ok()) << world.error().str();
  ASSERT_EQ(world->width(), 1000);
  ASSERT_EQ(world->height(), 800);
  EXPECT_NEAR(world->resolution(), 0.05, 1e-12);
  EXPECT_NEAR(world->origin().x, 0.0, 1e-9);
  EXPECT_NEAR(world->origin().y, 0.0, 1e-9);
  // Stage has no unknown space: its walls are the darkest pixels, everything else is free.
  EXPECT_EQ(world->count(Cell::kUnknown), 0u);
  EXPECT_EQ(world->count(Cell::kOccupied), kLabsStageOccupied);
  size_t free_agree = 0, wall_agree = 0;
  for (int cy = 0; cy < 800; ++cy) {
    for (int cx = 0; cx < 1000; ++cx) {
      if (yaml->at(cx, cy) == Cell::kFree && world->at(cx, cy) == Cell::kFree) ++free_agree;
      if (world->at(cx, cy) == Cell::kOccupied && yaml->at(cx, cy) == Cell::kOccupied) ++wall_agree;
    }
  }
  // Every map_server free cell is free for Stage and every Stage wall is a map_server wall.
  EXPECT_EQ(free_agree, kLabsFree);
  EXPECT_EQ(wall_agree, kLabsStageOccupied);
}

TEST(RealMaps, DiagFloor1LoadsAndPlansAcrossTheFloorQuickly) {
  VIGIL_REQUIRE_SHARED_DATA();
  auto grid = load_map(floor1_dir() / "DIAG_floor1.yaml");
  ASSERT_TRUE(grid.ok()) << grid.error().str();
  EXPECT_EQ(grid->width(), 2289);
  EXPECT_EQ(grid->height(), 927);
  EXPECT_EQ(grid->count(Cell::kFree), kFloor1Free);
  EXPECT_EQ(grid->count(Cell::kOccupied), kFloor1Occupied);
  EXPECT_EQ(grid->count(Cell::kUnknown), kFloor1Unknown);

  const GridPathPlanner planner(*grid, 0.3);
  // Patrol graph vertices 2 (219, 728), at the west end, and 56 (2067, 746), at the east end.
  const Vec2 west = graph_pixel(219, 728), east = graph_pixel(2067, 746);
  // Its time is a benchmark figure (`vigil bench plan`, "grid A*"), not a test's.
  const auto path = planner.plan(west, east);
  ASSERT_GE(path.size(), 3u);
  EXPECT_EQ(path.front(), west);
  EXPECT_EQ(path.back(), east);
  EXPECT_GT(path_length(path), (east - west).norm());
  expect_path_clear(*grid, planner, path, 0.3);
}

// ---------------------------------------------------------------------------------------------
// Grid queries

TEST(Grid, CellsAndCentresFollowTheOrigin) {
  OccupancyGrid grid(10, 5, 0.5, Pose2{-2.0, 1.0, 0});
  EXPECT_DOUBLE_EQ(grid.size_x(), 5.0);
  EXPECT_DOUBLE_EQ(grid.size_y(), 2.5);
  int cx = -1, cy = -1;
  ASSERT_TRUE(grid.world_to_cell({-2.0, 1.0}, &cx, &cy));
  EXPECT_EQ(cx, 0);
  EXPECT_EQ(cy, 0);
  ASSERT_TRUE(grid.world_to_cell({0.74, 2.26}, &cx, &cy));
  EXPECT_EQ(cx, 5);
  EXPECT_EQ(cy, 2);
  EXPECT_FALSE(grid.world_to_cell({3.0, 1.5}, &cx, &cy));   // x = origin + 5.0: past the edge
  EXPECT_FALSE(grid.world_to_cell({-2.01, 1.5}, &cx, &cy));
  EXPECT_FALSE(grid.world_to_cell({0.0, std::nan("")}, &cx, &cy));
  EXPECT_EQ(grid.cell_center(5, 2), (Vec2{0.75, 2.25}));
  grid.set(5, 2, Cell::kOccupied);
  grid.set(6, 2, Cell::kUnknown);
  EXPECT_FALSE(grid.is_free({0.75, 2.25}));
  EXPECT_TRUE(grid.is_free({0.75, 2.8}));
  EXPECT_EQ(grid.count(Cell::kFree), 48u);
  EXPECT_EQ(grid.count(Cell::kOccupied), 1u);
  EXPECT_EQ(grid.count(Cell::kUnknown), 1u);
}

TEST(Grid, FingerprintTellsMapsApartByContentNotAddress) {
  // Caches of roadmaps and likelihood fields key on it: a map freed and another built at the
  // same address must not get the first one's roadmap (vigil bench patrol over two maps did).
  OccupancyGrid a(20, 10, 0.05, Pose2{1.0, 2.0, 0});
  OccupancyGrid same(20, 10, 0.05, Pose2{1.0, 2.0, 0});
  EXPECT_EQ(a.fingerprint(), same.fingerprint());
  OccupancyGrid wall = a;
  wall.set(3, 4, Cell::kOccupied);
  EXPECT_NE(a.fingerprint(), wall.fingerprint());
  EXPECT_NE(a.fingerprint(), OccupancyGrid(20, 10, 0.05, Pose2{1.0, 2.5, 0}).fingerprint());
  EXPECT_NE(a.fingerprint(), OccupancyGrid(10, 20, 0.05, Pose2{1.0, 2.0, 0}).fingerprint());
  EXPECT_NE(a.fingerprint(), OccupancyGrid(20, 10, 0.1, Pose2{1.0, 2.0, 0}).fingerprint());
}

TEST(Grid, FreeDiscTouchesOnlyCellsWithinTheRadius) {
  OccupancyGrid grid(20, 20, 0.1, Pose2{});
  grid.set(10, 10, Cell::kOccupied);  // covers [1.0, 1.1) x [1.0, 1.1)
  // From (0.75, 1.05) the occupied cell's nearest side is 0.25 away.
  EXPECT_TRUE(grid.is_free_disc({0.75, 1.05}, 0.24));
  EXPECT_FALSE(grid.is_free_disc({0.75, 1.05}, 0.26));
  // Diagonal: the cell's corner (1.0, 1.0) is 0.2*sqrt(2) = 0.283 from (0.8, 0.8).
  EXPECT_TRUE(grid.is_free_disc({0.8, 0.8}, 0.28));
  EXPECT_FALSE(grid.is_free_disc({0.8, 0.8}, 0.29));
  // The grid's edge counts as not free.
  EXPECT_TRUE(grid.is_free_disc({0.3, 0.5}, 0.29));
  EXPECT_FALSE(grid.is_free_disc({0.3, 0.5}, 0.31));
  EXPECT_FALSE(grid.is_free_disc({1.05, 1.05}, 0.0));
  EXPECT_TRUE(grid.is_free_disc({0.3, 0.3}, 0.0));
}

// A 10 x 10 m grid at 5 cm with a square ring of walls: columns 50 and 150 and rows 50 and
// 150, between those rows and columns.
OccupancyGrid ring_grid() {
  OccupancyGrid grid(200, 200, 0.05, Pose2{});
  for (int i = 50; i <= 150; ++i) {
    grid.set(50, i, Cell::kOccupied);
    grid.set(150, i, Cell::kOccupied);
    grid.set(i, 50, Cell::kOccupied);
    grid.set(i, 150, Cell::kOccupied);
  }
  return grid;
}

TEST(Raycast, HitsWallsExactlyAlongAxesAndDiagonals) {
  const OccupancyGrid grid = ring_grid();
  const Vec2 p{5.01, 5.013};
  // Walls: x in [2.5, 2.55) and [7.5, 7.55); y likewise.
  EXPECT_NEAR(grid.raycast(p, 0.0, 20), 7.5 - 5.01, 1e-9);
  EXPECT_NEAR(grid.raycast(p, M_PI, 20), 5.01 - 2.55, 1e-9);
  EXPECT_NEAR(grid.raycast(p, M_PI / 2, 20), 7.5 - 5.013, 1e-9);
  EXPECT_NEAR(grid.raycast(p, -M_PI / 2, 20), 5.013 - 2.55, 1e-9);
  // Diagonals reach whichever wall's line comes first.
  EXPECT_NEAR(grid.raycast(p, M_PI / 4, 20), (7.5 - 5.013) * std::sqrt(2.0), 1e-9);
  EXPECT_NEAR(grid.raycast(p, 3 * M_PI / 4, 20), (5.01 - 2.55) * std::sqrt(2.0), 1e-9);
  EXPECT_NEAR(grid.raycast(p, -M_PI / 4, 20), (5.013 - 2.55) * std::sqrt(2.0), 1e-9);
  EXPECT_NEAR(grid.raycast(p, -3 * M_PI / 4, 20), (5.01 - 2.55) * std::sqrt(2.0), 1e-9);
  // Capped at max_range; zero from inside a wall or outside the grid.
  EXPECT_DOUBLE_EQ(grid.raycast(p, 0.0, 1.0), 1.0);
  EXPECT_DOUBLE_EQ(grid.raycast({7.52, 5.0}, 0.0, 20), 0.0);
  EXPECT_DOUBLE_EQ(grid.raycast({-1.0, 5.0}, 0.0, 20), 0.0);
  // Outside the ring, a ray runs to the grid's edge.
  EXPECT_NEAR(grid.raycast({8.0, 5.0}, 0.0, 20), 2.0, 1e-9);
}

TEST(Raycast, UnknownBlocksOnlyWhenAsked) {
  OccupancyGrid grid = ring_grid();
  for (int cy = 51; cy < 150; ++cy) grid.set(120, cy, Cell::kUnknown);  // x in [6.0, 6.05)
  const Vec2 p{5.01, 5.013};
  EXPECT_NEAR(grid.raycast(p, 0.0, 20, false), 7.5 - 5.01, 1e-9);
  EXPECT_NEAR(grid.raycast(p, 0.0, 20, true), 6.0 - 5.01, 1e-9);
}

TEST(Raycast, MatchesAFineMarchOnRandomObstacles) {
  OccupancyGrid grid(80, 60, 0.05, Pose2{-1.0, 0.5, 0});
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> pick_x(0, 79), pick_y(0, 59);
  for (int i = 0; i < 300; ++i) grid.set(pick_x(rng), pick_y(rng), Cell::kOccupied);
  std::uniform_real_distribution<double> ux(-1.0, 3.0), uy(0.5, 3.5), ua(-M_PI, M_PI);
  const double step = 1e-4;
  int rays = 0;
  while (rays < 200) {
    const Vec2 p{ux(rng), uy(rng)};
    if (!grid.is_free(p)) continue;
    const double angle = ua(rng);
    const Vec2 d{std::cos(angle), std::sin(angle)};
    // March until the point leaves the free cells: the true distance is within one step before.
    double marched = 0;
    while (grid.is_free(p + d * marched)) marched += step;
    const double cast = grid.raycast(p, angle, 100.0);
    ASSERT_LE(cast, marched + 1e-9) << "ray " << rays;
    ASSERT_GE(cast, marched - step - 1e-9) << "ray " << rays;
    ++rays;
  }
}

// ---------------------------------------------------------------------------------------------
// Wall boxes

// How many boxes cover each cell.
std::vector<int> coverage(const OccupancyGrid& grid, const std::vector<WallBox>& boxes) {
  std::vector<int> count(static_cast<size_t>(grid.width()) * grid.height(), 0);
  const double r = grid.resolution();
  for (const WallBox& b : boxes) {
    const int x0 = static_cast<int>(std::lround((b.min.x - grid.origin().x) / r));
    const int x1 = static_cast<int>(std::lround((b.max.x - grid.origin().x) / r));
    const int y0 = static_cast<int>(std::lround((b.min.y - grid.origin().y) / r));
    const int y1 = static_cast<int>(std::lround((b.max.y - grid.origin().y) / r));
    EXPECT_LT(x0, x1);
    EXPECT_LT(y0, y1);
    for (int y = std::max(y0, 0); y < std::min(y1, grid.height()); ++y) {
      for (int x = std::max(x0, 0); x < std::min(x1, grid.width()); ++x) ++count[y * grid.width() + x];
    }
  }
  return count;
}

TEST(WallBoxes, CoverExactlyTheOccupiedCellsOnce) {
  OccupancyGrid grid(70, 45, 0.1, Pose2{2.0, -3.0, 0});
  std::mt19937 rng(11);
  std::bernoulli_distribution wall(0.3), unknown(0.1);
  for (int cy = 0; cy < 45; ++cy) {
    for (int cx = 0; cx < 70; ++cx) {
      if (wall(rng)) grid.set(cx, cy, Cell::kOccupied);
      else if (unknown(rng)) grid.set(cx, cy, Cell::kUnknown);
    }
  }
  for (int cy = 5; cy < 15; ++cy) {
    for (int cx = 20; cx < 40; ++cx) grid.set(cx, cy, Cell::kOccupied);  // one solid block
  }
  const auto boxes = extract_wall_boxes(grid);
  const auto count = coverage(grid, boxes);
  for (int cy = 0; cy < 45; ++cy) {
    for (int cx = 0; cx < 70; ++cx) {
      ASSERT_EQ(count[cy * 70 + cx], grid.at(cx, cy) == Cell::kOccupied ? 1 : 0) << cx << "," << cy;
    }
  }
  EXPECT_LT(boxes.size(), grid.count(Cell::kOccupied));
  // Deterministic order: by bottom edge, then left edge.
  for (size_t i = 1; i < boxes.size(); ++i) {
    const bool ordered = boxes[i - 1].min.y < boxes[i].min.y ||
                         (boxes[i - 1].min.y == boxes[i].min.y && boxes[i - 1].min.x < boxes[i].min.x);
    ASSERT_TRUE(ordered) << i;
  }
}

TEST(WallBoxes, StraightWallsBecomeOneBoxEach) {
  OccupancyGrid grid(100, 50, 0.05, Pose2{1.0, 2.0, 0});
  for (int cx = 5; cx < 95; ++cx) grid.set(cx, 10, Cell::kOccupied);  // a long thin wall
  for (int cy = 20; cy < 23; ++cy) {
    for (int cx = 10; cx < 80; ++cx) grid.set(cx, cy, Cell::kOccupied);  // a thick wall
  }
  for (int cy = 30; cy < 45; ++cy) grid.set(3, cy, Cell::kOccupied);  // a vertical wall
  grid.set(50, 40, Cell::kUnknown);                                   // not a wall
  const auto boxes = extract_wall_boxes(grid);
  ASSERT_EQ(boxes.size(), 3u);
  EXPECT_NEAR(boxes[0].min.x, 1.0 + 5 * 0.05, 1e-12);
  EXPECT_NEAR(boxes[0].min.y, 2.0 + 10 * 0.05, 1e-12);
  EXPECT_NEAR(boxes[0].max.x, 1.0 + 95 * 0.05, 1e-12);
  EXPECT_NEAR(boxes[0].max.y, 2.0 + 11 * 0.05, 1e-12);
  EXPECT_NEAR(boxes[1].min.y, 2.0 + 20 * 0.05, 1e-12);
  EXPECT_NEAR(boxes[1].max.y, 2.0 + 23 * 0.05, 1e-12);
  EXPECT_NEAR(boxes[2].min.x, 1.0 + 3 * 0.05, 1e-12);
  EXPECT_NEAR(boxes[2].max.x, 1.0 + 4 * 0.05, 1e-12);
  EXPECT_NEAR(boxes[2].max.y, 2.0 + 45 * 0.05, 1e-12);
  EXPECT_TRUE(extract_wall_boxes(OccupancyGrid(10, 10, 0.1, Pose2{})).empty());
}

// ---------------------------------------------------------------------------------------------
// Path planner

// A 6 x 4 m room at 5 cm with a wall across x in [2.9, 3.1) from the floor up to y = 3.0.
OccupancyGrid wall_room() {
  OccupancyGrid grid(120, 80, 0.05, Pose2{});
  for (int cy = 0; cy < 60; ++cy) {
    for (int cx = 58; cx < 62; ++cx) grid.set(cx, cy, Cell::kOccupied);
  }
  return grid;
}

TEST(Planner, GoesAroundAWallWithoutCrossingIt) {
  const OccupancyGrid grid = wall_room();
  const GridPathPlanner planner(grid, 0.2);
  const Vec2 start{1.0, 1.0}, goal{5.0, 1.0};
  const auto path = planner.plan(start, goal);
  ASSERT_GE(path.size(), 3u);
  EXPECT_EQ(path.front(), start);
  EXPECT_EQ(path.back(), goal);
  expect_path_clear(grid, planner, path, 0.2);
  double top = 0;
  for (const Vec2& p : path) top = std::max(top, p.y);
  EXPECT_GE(top, 3.0 + 0.15);  // passes above the wall's end (y = 3.0), keeping its distance
  // Over the wall's top corners and back is 2 * hypot(1.9, 2.0) + 0.2 = 5.72 m; the clearance
  // adds a little.
  EXPECT_GT(path_length(path), 5.72);
  EXPECT_LT(path_length(path), 6.1);
  // Same cell: the straight segment.
  EXPECT_EQ(planner.plan({1.0, 1.0}, {1.01, 1.01}), (std::vector<Vec2>{{1.0, 1.0}, {1.01, 1.01}}));
}

TEST(Planner, ClearanceFieldIsTheDistanceToTheNearestNonFreeCell) {
  const OccupancyGrid grid = wall_room();
  const GridPathPlanner planner(grid, 0.2);
  EXPECT_NEAR(planner.clearance_at(grid.cell_center(50, 30)), 8 * 0.05, 1e-6);   // wall at cx 58
  EXPECT_NEAR(planner.clearance_at(grid.cell_center(60, 65)), 6 * 0.05, 1e-6);   // wall top cy 59
  EXPECT_NEAR(planner.clearance_at(grid.cell_center(70, 75)), 5 * 0.05, 1e-6);   // edge: row 80
  EXPECT_NEAR(planner.clearance_at(grid.cell_center(65, 64)), std::hypot(4, 5) * 0.05, 1e-6);  // corner
  EXPECT_DOUBLE_EQ(planner.clearance_at(grid.cell_center(59, 10)), 0.0);
  EXPECT_DOUBLE_EQ(planner.clearance_at({-1.0, 1.0}), 0.0);
}

TEST(Planner, ReturnsNothingWhenTheGoalIsEnclosed) {
  OccupancyGrid grid(120, 80, 0.05, Pose2{});
  for (int i = 70; i <= 110; ++i) {  // a closed square of walls around (4.5, 2.5)
    grid.set(i, 30, Cell::kOccupied);
    grid.set(i, 70, Cell::kOccupied);
  }
  for (int i = 30; i <= 70; ++i) {
    grid.set(70, i, Cell::kOccupied);
    grid.set(110, i, Cell::kOccupied);
  }
  const GridPathPlanner planner(grid, 0.1);
  EXPECT_TRUE(planner.plan({1.0, 1.0}, {4.5, 2.5}).empty());
  EXPECT_TRUE(planner.plan({4.5, 2.5}, {1.0, 1.0}).empty());
  EXPECT_FALSE(planner.plan({4.0, 2.0}, {5.0, 3.0}).empty());  // inside to inside is fine
  EXPECT_TRUE(planner.plan({1.0, 1.0}, {3.52, 2.5}).empty());  // goal on a wall
  EXPECT_TRUE(planner.plan({1.0, 1.0}, {7.0, 2.5}).empty());   // goal off the grid
  // No cell of the 6 x 4 m room is 2.5 m from every wall and edge: nowhere to go.
  const GridPathPlanner wide(grid, 2.5);
  EXPECT_TRUE(wide.plan({1.0, 1.0}, {2.0, 1.0}).empty());
}

TEST(Planner, TakesANarrowGapOnlyWhenTheClearanceFits) {
  // A full-height wall at x in [2.9, 3.1) with a 0.4 m gap (rows 10..17) near the bottom and a
  // 1 m gap (rows 50..69) higher up.
  OccupancyGrid grid(120, 80, 0.05, Pose2{});
  for (int cy = 0; cy < 80; ++cy) {
    if ((cy >= 10 && cy < 18) || (cy >= 50 && cy < 70)) continue;
    for (int cx = 58; cx < 62; ++cx) grid.set(cx, cy, Cell::kOccupied);
  }
  const Vec2 start{1.0, 0.7}, goal{5.0, 0.7};
  auto highest = [](const std::vector<Vec2>& path) {
    double top = -1;
    for (const Vec2& p : path) top = std::max(top, p.y);
    return top;
  };
  const GridPathPlanner slim(grid, 0.1);
  const auto low = slim.plan(start, goal);
  ASSERT_FALSE(low.empty());
  expect_path_clear(grid, slim, low, 0.1);
  EXPECT_LT(highest(low), 1.0);
  EXPECT_LT(path_length(low), 4.2);

  const GridPathPlanner broad(grid, 0.3);
  const auto high = broad.plan(start, goal);
  ASSERT_FALSE(high.empty());
  expect_path_clear(grid, broad, high, 0.3);
  EXPECT_GT(highest(high), 2.5);
}

TEST(Planner, LeavesAStartInsideTheMarginByTheNearestClearCell) {
  const OccupancyGrid grid = wall_room();
  const GridPathPlanner planner(grid, 0.3);
  const Vec2 start{2.82, 1.0};  // 0.08 m from the wall's face: free but inside the margin
  const Vec2 goal{0.5, 3.2};    // clear: 0.55 m from the left edge, 0.8 m from the top
  ASSERT_LT(planner.clearance_at(start), 0.3);
  const auto path = planner.plan(start, goal);
  ASSERT_GE(path.size(), 2u);
  EXPECT_EQ(path.front(), start);
  EXPECT_EQ(path.back(), goal);
  expect_path_clear(grid, planner, path, 0.0);
  // The second point is where the margin is left, about 0.3 m west of the wall.
  ASSERT_GE(path.size(), 3u);
  EXPECT_GE(planner.clearance_at(path[1]), 0.3 - 1e-6);
  EXPECT_NEAR(path[1].y, 1.0, 0.05);
  EXPECT_GT(path[1].x, 2.5);
  // From there on the clearance holds.
  expect_path_clear(grid, planner, std::vector<Vec2>(path.begin() + 1, path.end()), 0.3);
  // A start on a wall or off the grid has no path.
  EXPECT_TRUE(planner.plan({3.0, 1.0}, goal).empty());
  EXPECT_TRUE(planner.plan({-0.5, 1.0}, goal).empty());
}

TEST(Planner, NeverCrossesAWallOnRandomClutter) {
  OccupancyGrid grid(80, 80, 0.05, Pose2{-2.0, -2.0, 0});
  std::mt19937 rng(3);
  std::bernoulli_distribution wall(0.25);
  for (int cy = 0; cy < 80; ++cy) {
    for (int cx = 0; cx < 80; ++cx) {
      if (wall(rng)) grid.set(cx, cy, Cell::kOccupied);
    }
  }
  const GridPathPlanner planner(grid, 0.0);
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  int found = 0, tried = 0;
  while (tried < 60) {
    const Vec2 a{u(rng), u(rng)}, b{u(rng), u(rng)};
    if (!grid.is_free(a) || !grid.is_free(b)) continue;
    ++tried;
    const auto path = planner.plan(a, b);
    if (path.empty()) continue;
    ++found;
    EXPECT_EQ(path.front(), a);
    EXPECT_EQ(path.back(), b);
    expect_path_clear(grid, planner, path, 0.0);
  }
  EXPECT_GT(found, 10);
  // The same query gives the same path.
  const Vec2 a{-1.9, -1.9};
  EXPECT_EQ(planner.plan(a, {1.9, 1.9}), planner.plan(a, {1.9, 1.9}));
}

// ---------------------------------------------------------------------------------------------
// Files: formats, saving, errors

class MapFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    static int counter = 0;
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("vigil_map_test_" + std::to_string(::getpid()) + "_" + std::to_string(counter++) + "_" +
            info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path write(const std::string& name, const std::string& text) {
    const fs::path p = dir_ / name;
    std::ofstream out(p, std::ios::binary);
    out << text;
    return p;
  }
  // A 4 x 2 P5 PGM: top row 0 254 205 100, bottom row 255 0 254 230.
  fs::path write_small_pgm(const std::string& name) {
    const unsigned char px[8] = {0, 254, 205, 100, 255, 0, 254, 230};
    return write(name, "P5\n# made by a test\n4 2\n255\n" + std::string(reinterpret_cast<const char*>(px), 8));
  }
  // A map YAML naming `image`, with the given extra lines after the common ones.
  fs::path write_yaml(const std::string& name, const std::string& body) { return write(name, body); }

  // Loads `yaml` and expects an error whose text contains every one of `parts`.
  void expect_error(const fs::path& file, const std::vector<std::string>& parts) {
    auto r = load_map(file);
    ASSERT_FALSE(r.ok()) << "loaded " << file << " without an error";
    EXPECT_EQ(r.error().kind, ErrorKind::kBadInput) << r.error().str();
    for (const auto& part : parts) {
      EXPECT_NE(r.error().str().find(part), std::string::npos)
          << "error \"" << r.error().str() << "\" does not mention \"" << part << "\"";
    }
  }

  fs::path dir_;
};

constexpr const char* kGoodYaml =
    "image: small.pgm\n"
    "resolution: 0.5\n"
    "origin: [-1.0, 2.0, 0.0]\n"
    "negate: 0\n"
    "occupied_thresh: 0.65\n"
    "free_thresh: 0.196\n";

TEST_F(MapFiles, ReadsPgmWithMapServerThresholds) {
  write_small_pgm("small.pgm");
  auto grid = load_map(write_yaml("small.yaml", kGoodYaml));
  ASSERT_TRUE(grid.ok()) << grid.error().str();
  ASSERT_EQ(grid->width(), 4);
  ASSERT_EQ(grid->height(), 2);
  EXPECT_EQ(grid->origin(), (Pose2{-1.0, 2.0, 0}));
  // Image row 0 is the grid's top row (cy = 1). 100 -> p = 0.608: unknown; 230 -> 0.098: free.
  EXPECT_EQ(grid->at(0, 1), Cell::kOccupied);
  EXPECT_EQ(grid->at(1, 1), Cell::kFree);
  EXPECT_EQ(grid->at(2, 1), Cell::kUnknown);
  EXPECT_EQ(grid->at(3, 1), Cell::kUnknown);
  EXPECT_EQ(grid->at(0, 0), Cell::kFree);
  EXPECT_EQ(grid->at(1, 0), Cell::kOccupied);
  EXPECT_EQ(grid->at(2, 0), Cell::kFree);
  EXPECT_EQ(grid->at(3, 0), Cell::kFree);

  // negate: dark is free. 0 -> p = 0 free; 254 -> 0.996 occupied; 205 -> 0.80 occupied;
  // 100 -> 0.39 unknown; 230 -> 0.90 occupied.
  std::string negated = kGoodYaml;
  negated.replace(negated.find("negate: 0"), 9, "negate: 1");
  auto neg = load_map(write_yaml("neg.yaml", negated));
  ASSERT_TRUE(neg.ok()) << neg.error().str();
  EXPECT_EQ(neg->at(0, 1), Cell::kFree);
  EXPECT_EQ(neg->at(1, 1), Cell::kOccupied);
  EXPECT_EQ(neg->at(2, 1), Cell::kOccupied);
  EXPECT_EQ(neg->at(3, 1), Cell::kUnknown);
  EXPECT_EQ(neg->at(3, 0), Cell::kOccupied);

  // mode: scale keeps three states, so it reads like trinary.
  auto scale = load_map(write_yaml("scale.yaml", std::string(kGoodYaml) + "mode: scale\n"));
  ASSERT_TRUE(scale.ok()) << scale.error().str();
  EXPECT_EQ(scale->cells(), grid->cells());
}

TEST_F(MapFiles, ReadsAsciiPgmSixteenBitPgmAndPng) {
  // P2 with comments and maxval 15: 0 -> occupied, 15 -> free, 12 (204/255) -> unknown.
  write("ascii.pgm", "P2\n# comment\n3 1 # another\n15\n0 15\n12\n");
  std::string yaml = kGoodYaml;
  yaml.replace(yaml.find("small.pgm"), 9, "ascii.pgm");
  auto ascii = load_map(write_yaml("ascii.yaml", yaml));
  ASSERT_TRUE(ascii.ok()) << ascii.error().str();
  ASSERT_EQ(ascii->width(), 3);
  EXPECT_EQ(ascii->at(0, 0), Cell::kOccupied);
  EXPECT_EQ(ascii->at(1, 0), Cell::kFree);
  EXPECT_EQ(ascii->at(2, 0), Cell::kUnknown);

  // 16-bit P5, big-endian: 0, 65535, 52685 (= 205 * 257).
  const unsigned char px16[6] = {0x00, 0x00, 0xff, 0xff, 0xcd, 0xcd};
  write("deep.pgm", "P5 3 1 65535\n" + std::string(reinterpret_cast<const char*>(px16), 6));
  yaml = kGoodYaml;
  yaml.replace(yaml.find("small.pgm"), 9, "deep.pgm");
  auto deep = load_map(write_yaml("deep.yaml", yaml));
  ASSERT_TRUE(deep.ok()) << deep.error().str();
  EXPECT_EQ(deep->at(0, 0), Cell::kOccupied);
  EXPECT_EQ(deep->at(1, 0), Cell::kFree);
  EXPECT_EQ(deep->at(2, 0), Cell::kUnknown);

  // PNG, grey and colour (colour is averaged over its channels).
  cv::Mat grey(2, 3, CV_8U);
  grey.at<uint8_t>(0, 0) = 0;
  grey.at<uint8_t>(0, 1) = 255;
  grey.at<uint8_t>(0, 2) = 205;
  grey.at<uint8_t>(1, 0) = 254;
  grey.at<uint8_t>(1, 1) = 254;
  grey.at<uint8_t>(1, 2) = 10;
  ASSERT_TRUE(cv::imwrite((dir_ / "grey.png").string(), grey));
  cv::Mat colour;
  cv::Mat channels[3] = {grey.clone(), grey.clone(), grey.clone()};
  channels[0].at<uint8_t>(0, 1) = 0;  // (0 + 255 + 255) / 3 = 170: p = 0.33, unknown
  cv::merge(channels, 3, colour);
  ASSERT_TRUE(cv::imwrite((dir_ / "colour.png").string(), colour));
  for (const char* name : {"grey.png", "colour.png"}) {
    yaml = kGoodYaml;
    yaml.replace(yaml.find("small.pgm"), 9, name);
    auto png = load_map(write_yaml(std::string(name) + ".yaml", yaml));
    ASSERT_TRUE(png.ok()) << png.error().str();
    ASSERT_EQ(png->width(), 3);
    ASSERT_EQ(png->height(), 2);
    EXPECT_EQ(png->at(0, 1), Cell::kOccupied);
    EXPECT_EQ(png->at(1, 1), std::string(name) == "grey.png" ? Cell::kFree : Cell::kUnknown);
    EXPECT_EQ(png->at(2, 1), Cell::kUnknown);
    EXPECT_EQ(png->at(0, 0), Cell::kFree);
    EXPECT_EQ(png->at(2, 0), Cell::kOccupied);
  }
}

TEST_F(MapFiles, SaveThenLoadGivesTheSameGridAndBytes) {
  OccupancyGrid grid(37, 23, 0.1, Pose2{-3.5, 2.25, 0});
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> state(0, 2);
  for (int cy = 0; cy < 23; ++cy) {
    for (int cx = 0; cx < 37; ++cx) {
      const int s = state(rng);
      grid.set(cx, cy, s == 0 ? Cell::kFree : s == 1 ? Cell::kOccupied : Cell::kUnknown);
    }
  }
  const fs::path yaml = dir_ / "saved.yaml";
  ASSERT_TRUE(save_map_yaml(grid, yaml).ok());
  ASSERT_TRUE(fs::exists(dir_ / "saved.pgm"));
  auto back = load_map(yaml);
  ASSERT_TRUE(back.ok()) << back.error().str();
  EXPECT_EQ(back->width(), grid.width());
  EXPECT_EQ(back->height(), grid.height());
  EXPECT_EQ(back->resolution(), grid.resolution());
  EXPECT_EQ(back->origin(), grid.origin());
  EXPECT_EQ(back->cells(), grid.cells());

  auto slurp = [](const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  const std::string yaml_text = slurp(yaml), pgm_bytes = slurp(dir_ / "saved.pgm");
  EXPECT_EQ(yaml_text,
            "image: saved.pgm\nresolution: 0.1\norigin: [-3.5, 2.25, 0]\nnegate: 0\n"
            "occupied_thresh: 0.65\nfree_thresh: 0.196\n");
  EXPECT_EQ(pgm_bytes.substr(0, 13), "P5\n37 23\n255\n");
  // Saving again writes the same bytes.
  ASSERT_TRUE(save_map_yaml(*back, yaml).ok());
  EXPECT_EQ(slurp(yaml), yaml_text);
  EXPECT_EQ(slurp(dir_ / "saved.pgm"), pgm_bytes);
}

TEST_F(MapFiles, ReadsAStageFloorplanAmongOtherBlocks) {
  // 8 x 4 pixels: the top row 0 0 127 128 255 255 255 255, the rest 255 except one 100.
  std::string px(32, static_cast<char>(255));
  px[0] = 0;
  px[1] = 0;
  px[2] = 127;
  px[3] = static_cast<char>(128);
  px[3 * 8 + 7] = 100;  // bottom-right pixel
  write("tiny.pgm", "P5\n8 4\n255\n" + px);
  const fs::path world = write("cave.world",
                               "# a comment mentioning floorplan ( bitmap \"nope.pgm\" )\n"
                               "include \"floorplan.inc\"\n"
                               "define block model ( size [1 1 1] bitmap \"nope.png\" )\n"
                               "window ( size [600 500] center [0 0] )\n"
                               "resolution 0.02\n"
                               "floorplan   # the map\n"
                               "(\n"
                               "  name \"cave\"\n"
                               "  size [4.0 2.0 0.8]\n"
                               "  pose [1.0 -1.0 0 0.000]\n"
                               "  bitmap \"tiny.pgm\"   # trailing comment\n"
                               "  model ( size [1 1 1] )\n"
                               ")\n"
                               "block ( pose [0 0 0 0] )\n");
  auto grid = load_map(world);
  ASSERT_TRUE(grid.ok()) << grid.error().str();
  ASSERT_EQ(grid->width(), 8);
  ASSERT_EQ(grid->height(), 4);
  EXPECT_DOUBLE_EQ(grid->resolution(), 0.5);
  EXPECT_EQ(grid->origin(), (Pose2{-1.0, -2.0, 0}));
  EXPECT_EQ(grid->at(0, 3), Cell::kOccupied);
  EXPECT_EQ(grid->at(1, 3), Cell::kOccupied);
  EXPECT_EQ(grid->at(2, 3), Cell::kOccupied);
  EXPECT_EQ(grid->at(3, 3), Cell::kFree);
  EXPECT_EQ(grid->at(7, 0), Cell::kOccupied);
  EXPECT_EQ(grid->count(Cell::kOccupied), 4u);
  EXPECT_EQ(grid->count(Cell::kUnknown), 0u);
}

TEST_F(MapFiles, YamlErrorsNameFileLineAndKey) {
  ::testing::internal::CaptureStderr();  // the library must not print, even for broken images
  write_small_pgm("small.pgm");
  const std::string f = (dir_ / "m.yaml").string();
  auto with = [&](const std::string& from, const std::string& to) {
    std::string y = kGoodYaml;
    y.replace(y.find(from), from.size(), to);
    return write_yaml("m.yaml", y);
  };
  // Missing file.
  expect_error(dir_ / "absent.yaml", {(dir_ / "absent.yaml").string(), "not found"});
  // Bad YAML syntax: an unclosed flow list on line 3.
  expect_error(with("origin: [-1.0, 2.0, 0.0]", "origin: [-1.0, 2.0, 0.0"), {f + ":", "invalid YAML"});
  // Not a mapping.
  expect_error(write_yaml("m.yaml", "- just\n- a list\n"), {f, "expected a mapping"});
  // Missing key.
  expect_error(with("resolution: 0.5\n", ""), {f, "resolution: missing required key"});
  expect_error(with("free_thresh: 0.196\n", ""), {f, "free_thresh: missing"});
  // Wrong types.
  expect_error(with("resolution: 0.5", "resolution: fine"), {f + ":2: resolution: expected a number"});
  expect_error(with("origin: [-1.0, 2.0, 0.0]", "origin: 3"), {f + ":3: origin: expected a list"});
  expect_error(with("origin: [-1.0, 2.0, 0.0]", "origin: [a, 2.0, 0.0]"), {f + ":3: origin[0]:"});
  expect_error(with("image: small.pgm", "image: [small.pgm]"), {f + ":1: image:"});
  expect_error(with("negate: 0", "negate: 2"), {f + ":4: negate: expected 0 or 1"});
  // Bad values.
  expect_error(with("resolution: 0.5", "resolution: 0"), {f + ":2: resolution: must be positive"});
  expect_error(with("resolution: 0.5", "resolution: -0.05"), {f + ":2: resolution:"});
  expect_error(with("origin: [-1.0, 2.0, 0.0]", "origin: [-1.0, 2.0, 0.5]"),
               {f + ":3: origin:", "yaw", "not supported"});
  expect_error(with("occupied_thresh: 0.65", "occupied_thresh: 1.5"), {f + ":5: occupied_thresh: must be in [0, 1]"});
  expect_error(with("free_thresh: 0.196", "free_thresh: -0.1"), {f + ":6: free_thresh: must be in [0, 1]"});
  expect_error(with("free_thresh: 0.196", "free_thresh: 0.7"), {f + ":6: free_thresh: must be below"});
  expect_error(with("free_thresh: 0.196", "free_thresh: 0.65"), {f + ":6: free_thresh: must be below"});
  expect_error(write_yaml("m.yaml", std::string(kGoodYaml) + "mode: raw\n"), {f + ":7: mode:", "raw"});
  // Image problems name the image file and where the YAML named it.
  const std::string missing = (dir_ / "gone.pgm").string();
  expect_error(with("small.pgm", "gone.pgm"), {missing, "not found", f + ":1"});
  write("cut.pgm", "P5\n10 10\n255\n" + std::string(40, 'x'));
  expect_error(with("small.pgm", "cut.pgm"), {(dir_ / "cut.pgm").string(), "truncated"});
  write("head.pgm", "P5\n10 ten\n255\n");
  expect_error(with("small.pgm", "head.pgm"), {(dir_ / "head.pgm").string(), "corrupt PGM header"});
  write("bad.png", std::string("\x89PNG\r\n\x1a\n", 8) + "this is not really a png at all");
  expect_error(with("small.pgm", "bad.png"), {(dir_ / "bad.png").string(), "corrupt PNG"});
  {
    // A real PNG cut short, and one with a damaged byte in its pixel data.
    cv::Mat img(20, 30, CV_8U, cv::Scalar(254));
    std::vector<uchar> png;
    ASSERT_TRUE(cv::imencode(".png", img, png));
    const std::string good(png.begin(), png.end());
    write("short.png", good.substr(0, good.size() / 2));
    expect_error(with("small.pgm", "short.png"), {(dir_ / "short.png").string(), "corrupt PNG", "truncated"});
    std::string damaged = good;
    const size_t idat = damaged.find("IDAT");
    ASSERT_NE(idat, std::string::npos);
    damaged[idat + 6] = static_cast<char>(damaged[idat + 6] ^ 0x5a);
    write("damaged.png", damaged);
    expect_error(with("small.pgm", "damaged.png"), {(dir_ / "damaged.png").string(), "checksum"});
    write("fine.png", good);
    auto fine = load_map(with("small.pgm", "fine.png"));
    ASSERT_TRUE(fine.ok()) << fine.error().str();
    EXPECT_EQ(fine->count(Cell::kFree), 600u);
  }
  write("note.txt", "hello");
  expect_error(with("small.pgm", "note.txt"), {(dir_ / "note.txt").string(), "unrecognised"});
  // Unknown extension.
  expect_error(write("m.txt", kGoodYaml), {(dir_ / "m.txt").string(), "unknown map format"});
  EXPECT_EQ(::testing::internal::GetCapturedStderr(), "");
}

TEST_F(MapFiles, StageErrorsNameFileLineAndKey) {
  write_small_pgm("small.pgm");
  const std::string f = (dir_ / "w.world").string();
  auto world = [&](const std::string& body) { return write("w.world", body); };
  expect_error(dir_ / "none.world", {(dir_ / "none.world").string(), "not found"});
  expect_error(world("include \"a.inc\"\nwindow ( size [1 1] )\n"), {f, "floorplan", "no floorplan"});
  expect_error(world("floorplan\n(\n  size [2 1 1]\n)\n"), {f + ":1: floorplan.bitmap: missing"});
  expect_error(world("floorplan (\n  bitmap \"small.pgm\"\n)\n"), {f + ":1: floorplan.size: missing"});
  expect_error(world("floorplan (\n bitmap small.pgm\n size [2 1 1]\n)\n"),
               {f + ":2: floorplan.bitmap: expected a quoted file name"});
  expect_error(world("floorplan (\n bitmap \"small.pgm\"\n size [2 x 1]\n)\n"),
               {f + ":3: floorplan.size: expected a number"});
  expect_error(world("floorplan (\n bitmap \"small.pgm\"\n size [2 1 1]\n pose [0 0 0 90]\n)\n"),
               {f + ":4: floorplan.pose:", "rotated"});
  // 4 x 2 pixels into 2 x 3 m: the cells would not be square.
  expect_error(world("floorplan (\n bitmap \"small.pgm\"\n size [2 3 1]\n)\n"),
               {f + ":3: floorplan.size:", "aspect"});
  expect_error(world("\nfloorplan (\n bitmap \"small.pgm\"\n size [2 1 1]\n"), {f + ":2:", "unclosed"});
  expect_error(world("floorplan (\n bitmap \"small.pgm\n)\n"), {f + ":2:", "unterminated string"});
  expect_error(world("floorplan (\n bitmap \"gone.png\"\n size [2 1 1]\n)\n"),
               {(dir_ / "gone.png").string(), "not found", f + ":2"});
  // And a good one loads.
  auto ok = load_map(world("floorplan (\n bitmap \"small.pgm\"\n size [2 1 1]\n pose [1 0.5 0 0]\n)\n"));
  ASSERT_TRUE(ok.ok()) << ok.error().str();
  EXPECT_DOUBLE_EQ(ok->resolution(), 0.5);
  EXPECT_EQ(ok->origin(), (Pose2{0, 0, 0}));
}

}  // namespace
}  // namespace vigil
