// Tests of world/floorplan.h: rasterisation rules on small inline floorplans (wall thickness,
// doors, furniture, determinism), errors with file/line/key for bad floorplan files, and the
// project's DIS labs floorplan (maps/dis_labs.floorplan.yaml): it loads, the committed
// map_server pair maps/dis_labs.{yaml,pgm} equals a fresh export byte for byte, every named
// place has 0.3 m of clearance, and the corridor arms, doors and table have the stated sizes.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "tests/test_util.h"
#include "world/floorplan.h"
#include "world/map.h"
#include "planning/grid/grid_astar.h"

namespace vigil {
namespace {

namespace fs = std::filesystem;
using planning::GridPathPlanner;

// Reads a whole file as bytes.
std::string read_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// Writes text to a file.
void write_file(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

// 1-based line of the first occurrence of `needle` (0 when absent).
int line_of(const std::string& text, const std::string& needle) {
  const size_t pos = text.find(needle);
  if (pos == std::string::npos) return 0;
  return 1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<long>(pos), '\n'));
}

// A temporary folder removed at the end of the test.
class TempDir {
 public:
  explicit TempDir(const std::string& tag)
      : path_(fs::temp_directory_path() / ("vigil_floorplan_test_" + tag + "_" + std::to_string(::getpid()))) {
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

fs::path dis_labs() { return test::source_dir() / "maps" / "dis_labs.floorplan.yaml"; }

// Loads a floorplan written inline.
Result<Floorplan> load_text(const TempDir& dir, const std::string& text, const std::string& name = "t.floorplan.yaml") {
  write_file(dir.path() / name, text);
  return load_floorplan(dir.path() / name);
}

// Cell state at a map point (kUnknown outside the grid).
Cell cell_at(const OccupancyGrid& g, Vec2 p) {
  int cx = 0, cy = 0;
  if (!g.world_to_cell(p, &cx, &cy)) return Cell::kUnknown;
  return g.at(cx, cy);
}

constexpr const char* kSmall = R"(name: small
resolution: 0.05
bounds: {min: [0, 0], max: [4, 3]}
walls:
  - {from: [0.5, 1.0], to: [3.5, 1.0]}             # default 0.15 thick
  - {from: [0.5, 2.0], to: [3.5, 2.0], thickness: 0.3, height: 1.0}
  - polyline: [[3.8, 0.2], [3.9, 0.2], [3.9, 0.3]]
doors:
  - {name: d, center: [2.0, 1.0], width: 0.6}
furniture:
  - {name: t, kind: table, pose: [1.0, 2.5, 90], size: [0.4, 0.2, 0.7]}
places:
  a: [0.2, 0.2]
)";

TEST(FloorplanTest, ReadsEveryFieldOfASmallPlan) {
  TempDir dir("fields");
  auto plan = load_text(dir, kSmall);
  ASSERT_TRUE(plan.ok()) << plan.error().str();
  EXPECT_EQ(plan->name, "small");
  EXPECT_EQ(plan->source, dir.path() / "t.floorplan.yaml");
  EXPECT_EQ(plan->bounds_max, (Vec2{4, 3}));
  ASSERT_EQ(plan->walls.size(), 4u);  // the polyline gives two
  EXPECT_DOUBLE_EQ(plan->walls[0].thickness, 0.15);
  EXPECT_DOUBLE_EQ(plan->walls[0].height, 2.7);
  EXPECT_DOUBLE_EQ(plan->walls[1].thickness, 0.3);
  EXPECT_DOUBLE_EQ(plan->walls[1].height, 1.0);
  ASSERT_EQ(plan->doors.size(), 1u);
  EXPECT_DOUBLE_EQ(plan->doors[0].width, 0.6);
  ASSERT_NE(plan->find_furniture("t"), nullptr);
  EXPECT_NEAR(plan->find_furniture("t")->pose.yaw, M_PI / 2, 1e-12);
  EXPECT_EQ(plan->find_furniture("nothing"), nullptr);
  EXPECT_EQ(plan->places.at("a"), (Vec2{0.2, 0.2}));
}

TEST(FloorplanTest, RasterisesWallsDoorsAndFurniture) {
  TempDir dir("raster");
  auto plan = load_text(dir, kSmall);
  ASSERT_TRUE(plan.ok()) << plan.error().str();
  const OccupancyGrid g = plan->rasterize();
  EXPECT_EQ(g.width(), 80);
  EXPECT_EQ(g.height(), 60);
  EXPECT_DOUBLE_EQ(g.resolution(), 0.05);
  // A 0.15 m wall on a cell boundary: centres within 0.075 m, i.e. 4 cells (0.925..1.075).
  int thick = 0;
  for (int cy = 0; cy < g.height(); ++cy) {
    if (g.at(10, cy) == Cell::kOccupied && std::abs(g.cell_center(10, cy).y - 1.0) < 0.5) ++thick;
  }
  EXPECT_EQ(thick, 4);
  // 0.3 m thick: centres within 0.15 m of y = 2 (1.875 .. 2.125).
  EXPECT_EQ(cell_at(g, {1.0, 2.13}), Cell::kOccupied);
  EXPECT_EQ(cell_at(g, {1.0, 2.16}), Cell::kFree);
  // The door clears 0.6 m of the first wall, centred at x = 2.
  EXPECT_EQ(cell_at(g, {2.0, 1.0}), Cell::kFree);
  EXPECT_EQ(cell_at(g, {1.72, 1.0}), Cell::kFree);
  EXPECT_EQ(cell_at(g, {1.68, 1.0}), Cell::kOccupied);
  EXPECT_EQ(cell_at(g, {2.32, 1.0}), Cell::kOccupied);
  // The table, turned 90 degrees: 0.2 m along x, 0.4 m along y.
  EXPECT_EQ(cell_at(g, {1.0, 2.5}), Cell::kOccupied);
  EXPECT_EQ(cell_at(g, {1.0, 2.68}), Cell::kOccupied);
  EXPECT_EQ(cell_at(g, {1.0, 2.72}), Cell::kFree);
  EXPECT_EQ(cell_at(g, {1.12, 2.5}), Cell::kFree);
  // Deterministic.
  EXPECT_EQ(plan->rasterize().cells(), g.cells());
}

TEST(FloorplanTest, ThinDiagonalWallsBlockRaysAndPaths) {
  TempDir dir("diagonal");
  auto plan = load_text(dir, R"(name: diagonal
resolution: 0.05
bounds: {min: [0, 0], max: [4, 4]}
walls:
  - {from: [0.0, 0.3], to: [4.0, 3.7], thickness: 0.01}
)");
  ASSERT_TRUE(plan.ok()) << plan.error().str();
  const OccupancyGrid g = plan->rasterize();
  auto line_y = [](double x) { return 0.3 + 0.85 * x; };
  const Vec2 below{3.0, 1.0};  // under the line
  for (double a = 0.0; a < M_PI; a += 0.01) {
    const double d = g.raycast(below, a, 10.0);
    const Vec2 hit{below.x + d * std::cos(a), below.y + d * std::sin(a)};
    EXPECT_LT(hit.y, line_y(hit.x) + 0.15) << "a ray at " << a << " rad leaked through a 1 cm wall";
  }
  // The wall is 4-connected, so an 8-connected grid path cannot slip between diagonal cells.
  for (int cx = 0; cx + 1 < g.width(); ++cx) {
    for (int cy = 0; cy + 1 < g.height(); ++cy) {
      const bool a = g.at(cx, cy) == Cell::kOccupied, b = g.at(cx + 1, cy + 1) == Cell::kOccupied;
      const bool c = g.at(cx + 1, cy) == Cell::kOccupied, d = g.at(cx, cy + 1) == Cell::kOccupied;
      ASSERT_FALSE(a && b && !c && !d) << "diagonal-only joint at cell " << cx << ", " << cy;
    }
  }
  GridPathPlanner planner(g, 0.0);
  EXPECT_TRUE(planner.plan(below, {1.0, 3.0}).empty());
}

TEST(FloorplanTest, BadFilesNameFileLineAndKey) {
  TempDir dir("bad");
  struct Case {
    std::string text, needle, key, what;
  };
  const std::string head = "name: bad\nbounds: {min: [0, 0], max: [10, 10]}\n";
  const Case cases[] = {
      {"name: bad\nbounds: {min: [0, 0], max: [10, 10]}\ncolour: red\n", "colour", "colour",
       "unknown key (allowed: name, resolution, bounds"},
      {"name: bad\n", "name", "bounds", "missing required key"},
      {"name: bad\nbounds: {min: [0, 0], max: [10, -1]}\n", "bounds", "bounds.max", "greater than min"},
      {"name: bad\nresolution: 0\nbounds: {min: [0, 0], max: [10, 10]}\n", "resolution", "resolution", "between"},
      {"name: bad\nresolution: 0.001\nbounds: {min: [0, 0], max: [1000, 1000]}\n", "bounds", "bounds.max",
       "cells (at most"},
      {head + "walls:\n  - {from: [1, 1], to: [1, x]}\n", "to:", "walls[0].to[1]", "expected a number"},
      {head + "walls:\n  - {from: [1, 1], to: [20, 1]}\n", "to:", "walls[0].to", "outside the bounds"},
      {head + "walls:\n  - {from: [1, 1], to: [1, 1]}\n", "to:", "walls[0].to", "zero-length"},
      {head + "walls:\n  - {from: [1, 1]}\n", "from:", "walls[0].to", "missing required key"},
      {head + "walls:\n  - {from: [1, 1], to: [2, 1], thickness: -0.1}\n", "thickness", "walls[0].thickness",
       "greater than 0"},
      {head + "walls:\n  - polyline: [[1, 1]]\n", "polyline", "walls[0].polyline", "at least 2 points"},
      {head + "walls:\n  - {from: [1, 1], to: [2, 1], closed: true}\n", "closed", "walls[0].closed", "only to a polyline"},
      {head + "walls:\n  - {from: [1, 1], to: [5, 1]}\ndoors:\n  - {name: d, center: [3, 4], width: 1}\n", "center: [3, 4]",
       "doors[0].center", "does not lie on any wall"},
      {head + "walls:\n  - {from: [1, 1], to: [5, 1]}\ndoors:\n  - {center: [3, 1], width: 1}\n", "center: [3, 1]",
       "doors[0].name", "missing required key"},
      {head + "walls:\n  - {from: [1, 1], to: [5, 1]}\ndoors:\n  - {name: d, center: [3, 1], yaw: 90}\n", "yaw: 90",
       "doors[0].yaw", "use yaw_deg"},
      {head + "furniture:\n  - {name: t, pose: [1, 1, 0], size: [1, 1]}\n", "size", "furniture[0].size",
       "list of 3 numbers"},
      {head + "furniture:\n  - {name: t, pose: [1, 1]}\n  - {name: t, pose: [2, 2]}\n", "pose: [2, 2]",
       "furniture[1].name", "duplicate furniture name"},
      {head + "places:\n  a: [1, 1]\n  b: [1, .nan]\n", "b:", "places.b[1]", "finite"},
      {head + "places:\n  a: [1, 1]\n  a: [2, 2]\n", "a: [2, 2]", "places.a", "duplicate key"},
      {head + "walls: [\n", "walls", "", "YAML syntax error"},
  };
  for (const Case& c : cases) {
    auto r = load_text(dir, c.text, "bad.floorplan.yaml");
    ASSERT_FALSE(r.ok()) << "accepted:\n" << c.text;
    const Error& e = r.error();
    EXPECT_NE(e.str().find("bad.floorplan.yaml"), std::string::npos) << e.str();
    if (c.what != "YAML syntax error") {
      EXPECT_EQ(e.line, line_of(c.text, c.needle)) << e.str();
    }
    EXPECT_EQ(e.key, c.key) << e.str();
    EXPECT_NE(e.str().find(c.what), std::string::npos) << "lacks '" << c.what << "': " << e.str();
  }
  auto missing = load_floorplan(dir.path() / "none.floorplan.yaml");
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().str().find("none.floorplan.yaml"), std::string::npos);
}

class DisLabsTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    auto plan = load_floorplan(dis_labs());
    ASSERT_TRUE(plan.ok()) << plan.error().str();
    plan_ = new Floorplan(std::move(*plan));
    grid_ = new OccupancyGrid(plan_->rasterize());
  }
  static void TearDownTestSuite() {
    delete plan_;
    delete grid_;
  }
  static Floorplan* plan_;
  static OccupancyGrid* grid_;
};

Floorplan* DisLabsTest::plan_ = nullptr;
OccupancyGrid* DisLabsTest::grid_ = nullptr;

TEST_F(DisLabsTest, Loads) {
  ASSERT_NE(plan_, nullptr);
  EXPECT_EQ(plan_->name, "dis_labs");
  EXPECT_DOUBLE_EQ(plan_->resolution, 0.05);
  EXPECT_EQ(plan_->bounds_min, (Vec2{0, 0}));
  EXPECT_EQ(plan_->bounds_max, (Vec2{44, 32}));
  EXPECT_EQ(grid_->width(), 880);
  EXPECT_EQ(grid_->height(), 640);
  EXPECT_EQ(plan_->doors.size(), 8u);
  EXPECT_EQ(plan_->places.size(), 21u);
  for (const auto& w : plan_->walls) {
    EXPECT_DOUBLE_EQ(w.thickness, 0.15);
    EXPECT_DOUBLE_EQ(w.height, 2.7);
  }
}

TEST_F(DisLabsTest, CommittedMapEqualsAFreshExport) {
  TempDir dir("export");
  const fs::path out = dir.path() / "dis_labs.yaml";
  ASSERT_TRUE(export_floorplan(*plan_, out).ok());
  const fs::path committed = test::source_dir() / "maps";
  ASSERT_TRUE(fs::exists(committed / "dis_labs.pgm")) << "run: vigil map export maps/dis_labs.floorplan.yaml maps/dis_labs.yaml";
  EXPECT_EQ(read_bytes(out), read_bytes(committed / "dis_labs.yaml"))
      << "maps/dis_labs.yaml is stale: run vigil map export maps/dis_labs.floorplan.yaml maps/dis_labs.yaml";
  EXPECT_TRUE(read_bytes(dir.path() / "dis_labs.pgm") == read_bytes(committed / "dis_labs.pgm"))
      << "maps/dis_labs.pgm is stale: run vigil map export maps/dis_labs.floorplan.yaml maps/dis_labs.yaml";
  // And the committed pair loads back to the same grid.
  auto loaded = load_map(committed / "dis_labs.yaml");
  ASSERT_TRUE(loaded.ok()) << loaded.error().str();
  EXPECT_EQ(loaded->cells(), grid_->cells());
}

TEST_F(DisLabsTest, EveryPlaceHasClearance) {
  for (const auto& [name, p] : plan_->places) {
    if (name == "lab_table") continue;  // an object position: the table's own centre
    EXPECT_TRUE(grid_->is_free_disc(p, 0.3)) << name << " at (" << p.x << ", " << p.y << ")";
  }
  // The exemption is deliberate: lab_table is on the table.
  EXPECT_EQ(cell_at(*grid_, plan_->places.at("lab_table")), Cell::kOccupied);
}

TEST_F(DisLabsTest, CorridorArmsHaveTheStatedSize) {
  const double wall = 0.2;  // a 0.15 m wall on a cell boundary rasterises 4 cells thick
  const double tol = 0.06;
  // Horizontal arm: 2.2 m between wall centrelines, 39 m between the end walls.
  const Vec2 mid = plan_->places.at("corridor_mid");
  EXPECT_NEAR(grid_->raycast(mid, M_PI / 2, 10) + grid_->raycast(mid, -M_PI / 2, 10), 2.2 - wall, tol);
  const Vec2 off_door{21.0, 3.9};  // beside the exits, so the end walls are hit
  EXPECT_NEAR(grid_->raycast(off_door, 0, 60) + grid_->raycast(off_door, M_PI, 60), 39.0 - wall, tol);
  // Vertical arm: 1.8 m wide, 27 m long.
  const Vec2 north = plan_->places.at("corridor_north");
  EXPECT_NEAR(grid_->raycast(north, 0, 10) + grid_->raycast(north, M_PI, 10), 1.8 - wall, tol);
  const Vec2 off_exit{2.2, 15.0};
  EXPECT_NEAR(grid_->raycast(off_exit, M_PI / 2, 60) + grid_->raycast(off_exit, -M_PI / 2, 60), 27.0 - wall, tol);
  // From the corner the free run along +x reaches the east end (out through the exit doorway
  // on the corridor's axis, to the map's edge at 44 m; beside it, to the end wall).
  const Vec2 corner = plan_->places.at("corridor_corner");
  EXPECT_NEAR(grid_->raycast(corner, 0, 60), 44.0 - corner.x, tol);
  EXPECT_NEAR(grid_->raycast({corner.x, 2.4}, 0, 60), 41.0 - wall / 2 - corner.x, tol);
  EXPECT_NEAR(grid_->raycast({2.3, corner.y}, M_PI / 2, 60), 29.0 - wall / 2 - corner.y, tol);
}

TEST_F(DisLabsTest, DoorsAreOpenAndOneMetreWide) {
  for (const auto& d : plan_->doors) {
    EXPECT_EQ(cell_at(*grid_, d.center), Cell::kFree) << d.name;
    // Across the wall, a ray through the door centre passes the wall.
    const double across = d.yaw + M_PI / 2;
    const Vec2 before{d.center.x - 0.5 * std::cos(across), d.center.y - 0.5 * std::sin(across)};
    EXPECT_GT(grid_->raycast(before, across, 1.0), 0.99) << d.name;
    // Along the wall, the gap is the door's width.
    const double along = grid_->raycast(d.center, d.yaw, 5) + grid_->raycast(d.center, d.yaw + M_PI, 5);
    EXPECT_NEAR(along, 1.0, 0.06) << d.name;
  }
}

TEST_F(DisLabsTest, TableFootprintIsOccupied) {
  const FloorplanFurniture* t = plan_->find_furniture("lab_table");
  ASSERT_NE(t, nullptr);
  EXPECT_EQ(t->kind, "table");
  EXPECT_DOUBLE_EQ(t->height, 0.75);
  for (double dx : {-0.85, 0.0, 0.85}) {
    for (double dy : {-0.4, 0.0, 0.4}) EXPECT_EQ(cell_at(*grid_, {12.0 + dx, 8.5 + dy}), Cell::kOccupied);
  }
  EXPECT_EQ(cell_at(*grid_, {12.0 + 0.95, 8.5}), Cell::kFree);
  EXPECT_EQ(cell_at(*grid_, {12.0, 8.5 + 0.5}), Cell::kFree);
}

}  // namespace
}  // namespace vigil
