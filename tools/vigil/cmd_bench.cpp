// vigil bench sim: real-time factor of the simulator with N wandering robots, each carrying a
// 180-sample laser, no cameras, on one core, beside Stage's published figures.
#include <chrono>
#include <cstdio>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "plugins/builtin.h"
#include "tools/vigil/commands.h"
#include "tools/vigil/plugin_search.h"
#include "world/map.h"
#include "common/rng.h"
#include "world/world.h"
#include "planning/grid/inflated_grid.h"

namespace vigil::cli {
namespace {

std::filesystem::path default_bench_map() {
  const std::filesystem::path src = VIGIL_SOURCE_DIR;
  const auto diag = src / ".." / "shared" / "data" / "maps" / "DIAG_floor1" / "DIAG_floor1.yaml";
  if (std::filesystem::exists(diag)) return diag;
  return src / "maps" / "dis_labs.yaml";
}

// Stage's figures (Vaughan 2008, "Massively multi-robot simulation in Stage").
const char* stage_figure(int robots) {
  if (robots <= 1) return "~1000x";
  if (robots >= 1000) return "~1x";
  return "-";
}

}  // namespace

void add_bench_command(CLI::App& app) {
  auto* bench = app.add_subcommand("bench", "Benchmarks");
  bench->require_subcommand(1);
  struct Opts {
    std::vector<int> robots{1, 10, 100, 1000};
    double seconds = 30;
    double physics_hz = 10;
    int samples = 180;
    double laser_fov_deg = 180, laser_range = 8.0;
    std::string map, urdf, json;
    uint64_t seed = 1;
    bool navigate = false;
  };
  auto o = std::make_shared<Opts>();
  auto* sim = bench->add_subcommand("sim", "Real-time factor with N robots with lasers (no cameras)");
  sim->add_option("--robots", o->robots, "robot counts to run")->delimiter(',');
  sim->add_option("--seconds", o->seconds, "simulated seconds per run");
  sim->add_option("--physics-hz", o->physics_hz, "physics rate (Stage's default interval is 100 ms = 10 Hz)");
  sim->add_option("--samples", o->samples, "laser samples per scan");
  sim->add_option("--map", o->map, "map (default: DIAG_floor1 from ../shared/data if present, else maps/dis_labs.yaml)");
  sim->add_option("--urdf", o->urdf, "robot URDF (default maps/robots/erratic.urdf)");
  sim->add_option("--json", o->json, "also write the results as JSON to this file");
  sim->add_option("--seed", o->seed, "seed");
  sim->add_flag("--navigate", o->navigate,
                "every robot runs the navigator (MCL, two-level planner, pure pursuit) back and forth between its "
                "start and another robot's, instead of wander");
  sim->callback([o] {
    const std::filesystem::path map_path = o->map.empty() ? default_bench_map() : std::filesystem::path(o->map);
    const std::filesystem::path urdf =
        o->urdf.empty() ? std::filesystem::path(VIGIL_SOURCE_DIR) / "maps" / "robots" / "erratic.urdf" : std::filesystem::path(o->urdf);
    auto grid = load_map(map_path);
    if (!grid) throw Exit{report(grid.error())};
    std::printf("vigil bench sim: map %s (%.1f x %.1f m), %d-sample laser (%.0f deg, %.0f m) at 10 Hz, physics %.0f Hz, %.0f s simulated, one thread\n",
                map_path.filename().c_str(), grid->size_x(), grid->size_y(), o->samples, o->laser_fov_deg, o->laser_range,
                o->physics_hz, o->seconds);
    std::printf("%8s %12s %12s %14s %12s %16s\n", "robots", "sim s", "wall s", "real-time x", "ms/step", "Stage (2008)");
    nlohmann::ordered_json results = nlohmann::ordered_json::array();
    for (int n : o->robots) {
      Scenario sc;
      sc.file = "bench";
      sc.name = "bench_sim_" + std::to_string(n);
      sc.map = map_path;
      sc.duration = o->seconds;
      sc.seed = o->seed;
      sc.physics_rate_hz = o->physics_hz;
      // Robots on free cells with room around them, from a seeded sequence.
      Rng rng(o->seed);
      std::vector<Vec2> placed;
      int tries = 0;
      while (static_cast<int>(placed.size()) < n && tries < 2'000'000) {
        ++tries;
        const Vec2 p{grid->origin().x + rng.uniform() * grid->size_x(), grid->origin().y + rng.uniform() * grid->size_y()};
        if (!grid->is_free_disc(p, 0.32)) continue;
        bool clash = false;
        for (const Vec2& q : placed)
          if ((q - p).norm() < 0.65) { clash = true; break; }
        if (clash) continue;
        placed.push_back(p);
        RobotSpec r;
        r.id = "r" + std::to_string(placed.size());
        r.urdf = urdf;
        r.start = {p.x, p.y, rng.uniform(-M_PI, M_PI)};
        r.controller = "wander";
        r.ranger.enabled = true;
        r.ranger.samples = o->samples;
        r.ranger.fov = o->laser_fov_deg * M_PI / 180;
        r.ranger.range_max = o->laser_range;
        r.odometry.error_x = r.odometry.error_y = 0.01;
        r.odometry.error_yaw = 0.1;
        sc.robots.push_back(r);
      }
      if (static_cast<int>(placed.size()) < n) {
        throw Exit{report(bad_input(map_path.string(), 0, "--robots", "room for only " + std::to_string(placed.size()) + " robots"))};
      }
      if (o->navigate) {
        // Back and forth between its start and a reachable point 4 to 12 m away (same part of
        // the free space for the navigator's inflated radius), from a seeded sequence.
        const planning::InflatedGrid free_space(*grid, 0.34);
        Rng goals = Rng::stream(o->seed, "bench-sim-goals");
        for (int k = 0; k < n; ++k) {
          RobotSpec& r = sc.robots[k];
          auto start = free_space.nearest_free(r.start.position(), 0.5);
          std::vector<double> pts{r.start.x, r.start.y};
          for (int t = 0; start && t < 2000; ++t) {
            const double d = goals.uniform(4.0, 12.0), a = goals.uniform(-M_PI, M_PI);
            const Vec2 g = *start + Vec2{d * std::cos(a), d * std::sin(a)};
            if (free_space.is_free(g) && free_space.component(g) == free_space.component(*start)) {
              pts = {g.x, g.y, r.start.x, r.start.y};
              break;
            }
          }
          r.controller = "navigator";
          r.params["points"] = {pts, 0};
          r.params["loop"] = {true, 0};
          r.params["speed"] = {0.5, 0};
        }
      }
      WorldOptions wo;
      wo.plugins = builtin_plugin_registry();
      wo.plugin_dirs = plugin_search_path();
      auto world = World::create(sc, wo);
      if (!world) throw Exit{report(world.error())};
      const auto t0 = std::chrono::steady_clock::now();
      while (!(*world)->finished()) {
        if (Status s = (*world)->advance(); !s) throw Exit{report(s.error())};
      }
      const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      const double simt = to_seconds((*world)->time());
      const double rtf = simt / wall;
      int reached = 0, failed = 0;
      for (const RobotReport& rep : (*world)->drain_reports()) {
        reached += rep.event == "goal_reached";
        failed += rep.event == "goal_failed";
      }
      std::printf("%8d %12.1f %12.2f %14.1f %12.3f %16s", n, simt, wall, rtf, 1000.0 * wall / (*world)->steps(),
                  o->navigate ? "-" : stage_figure(n));
      if (o->navigate) std::printf("   goals reached %d, failed %d", reached, failed);
      std::printf("\n");
      std::fflush(stdout);
      results.push_back({{"robots", n}, {"mode", o->navigate ? "navigate" : "wander"}, {"sim_seconds", simt},
                         {"wall_seconds", wall}, {"real_time_factor", rtf},
                         {"ms_per_step", 1000.0 * wall / (*world)->steps()}, {"stage_2008", o->navigate ? "-" : stage_figure(n)},
                         {"goals_reached", reached}, {"goals_failed", failed}});
    }
    if (!o->json.empty()) {
      std::ofstream f(o->json);
      f << results.dump(2) << "\n";
    }
  });
  add_bench_camera_commands(bench);
  add_bench_dds_commands(bench);
  add_bench_mcl_command(bench);
  add_bench_plan_command(bench);
  add_bench_patrol_command(bench);
  add_bench_allocate_command(bench);
  add_bench_mser_command(bench);
  add_bench_rate_command(bench);
  add_bench_video_command(bench);
}

}  // namespace vigil::cli
