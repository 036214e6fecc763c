// vigil bench allocate: the response mode's task allocator (planning/allocation) on seeded
// random instances on the real maps: robots and incidents at random free places of the largest
// region, priorities 1 to 3, a third of the robots busy (0 to 30 s to leave what they do),
// costs the two-level planner's path lengths at 1 m/s. Per size: our total cost over the
// Hungarian optimum on the same costs (mean, worst) and the time per allocation, ours and the
// reference's, measured in the same run.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>

#include "common/rng.h"
#include "planning/allocation/allocation.h"
#include "planning/two_level_planner.h"
#include "tools/vigil/commands.h"
#include "world/floorplan.h"
#include "world/map.h"

namespace vigil::cli {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2];
}

}  // namespace

void add_bench_allocate_command(CLI::App* bench) {
  struct Opts {
    std::vector<int> sizes{10, 30, 100};
    int instances = 10;
    uint64_t seed = 1;
    std::vector<std::string> maps;
    std::string json;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = bench->add_subcommand("allocate", "Task allocation (greedy with priorities) beside the Hungarian optimum");
  cmd->add_option("--sizes", o->sizes, "robots = incidents per instance")->delimiter(',');
  cmd->add_option("--instances", o->instances, "seeded instances per size and map")->check(CLI::Range(1, 10000));
  cmd->add_option("--seed", o->seed, "seed")->capture_default_str();
  cmd->add_option("--map", o->maps, "maps (default: the DIAG maps when present, else maps/dis_labs.floorplan.yaml)");
  cmd->add_option("--json", o->json, "also write the results as JSON to this file");
  cmd->callback([o] {
    std::vector<fs::path> maps;
    const fs::path src = VIGIL_SOURCE_DIR;
    for (const auto& m : o->maps) maps.push_back(m);
    if (maps.empty()) {
      for (const char* m : {"DIAG_labs", "DIAG_floor1"}) {
        const auto p = src / ".." / "shared" / "data" / "maps" / m / (std::string(m) + ".yaml");
        if (fs::exists(p)) maps.push_back(p);
      }
      if (maps.empty()) maps.push_back(src / "maps" / "dis_labs.floorplan.yaml");
    }
    nlohmann::ordered_json results = nlohmann::ordered_json::array();
    std::printf("%-12s %6s %9s %10s %10s %12s %12s %12s\n", "map", "size", "instances", "mean ratio", "worst ratio",
                "ours ms", "Hungarian ms", "costs s");
    for (const fs::path& mp : maps) {
      const std::string name = mp.filename().string().starts_with("dis_labs") ? "dis_labs" : mp.stem().string();
      Result<OccupancyGrid> grid = mp.string().ends_with(".floorplan.yaml")
                                       ? [&]() -> Result<OccupancyGrid> {
                                           auto fp = load_floorplan(mp);
                                           if (!fp) return fp.error();
                                           return fp->rasterize();
                                         }()
                                       : load_map(mp);
      if (!grid) throw Exit{report(grid.error())};
      planning::TwoLevelParams tp;
      tp.robot_radius = 0.38;
      tp.roadmap.seed = o->seed;
      auto planner = planning::TwoLevelPlanner::create(*grid, tp, {});
      if (!planner) throw Exit{report(planner.error())};
      const planning::InflatedGrid& g = (*planner)->inflated();
      int largest = 0;
      for (int c = 1; c < g.component_count(); ++c)
        if (g.component_area(c) > g.component_area(largest)) largest = c;
      for (int n : o->sizes) {
        Rng rng = Rng::stream(o->seed, "bench-allocate-" + name + "-" + std::to_string(n));
        std::vector<double> ratios, ours_ms, ref_ms, cost_s;
        for (int inst = 0; inst < o->instances; ++inst) {
          auto sample = [&]() {
            for (;;) {
              const Vec2 p{rng.uniform(g.lower().x, g.upper().x), rng.uniform(g.lower().y, g.upper().y)};
              if (g.is_free(p) && g.component(p) == largest) return p;
            }
          };
          std::vector<Vec2> robots, tasks;
          std::vector<double> busy;
          for (int i = 0; i < n; ++i) {
            robots.push_back(sample());
            busy.push_back(rng.uniform() < 1.0 / 3 ? rng.uniform(0, 30) : 0.0);
          }
          std::vector<int> priority;
          for (int j = 0; j < n; ++j) {
            tasks.push_back(sample());
            priority.push_back(1 + static_cast<int>(rng.uniform() * 3) % 3);
          }
          const auto t0 = Clock::now();
          CostMatrix c(n, n);
          for (int i = 0; i < n; ++i) {
            for (int j = 0; j < n; ++j) {
              const auto r = (*planner)->plan(robots[i], tasks[j], nullptr);
              c.at(i, j) = planning::has_path(r.outcome) ? r.length / 1.0 + busy[i] : std::numeric_limits<double>::infinity();
            }
          }
          cost_s.push_back(ms_since(t0) / 1000);
          planning::allocation::Assignment ours, ref;
          std::vector<double> t_ours, t_ref;
          for (int rep = 0; rep < 5; ++rep) {
            auto a = Clock::now();
            ours = planning::allocation::greedy_assign(c, priority);
            t_ours.push_back(ms_since(a));
            a = Clock::now();
            ref = planning::allocation::optimal_assign(c, priority);
            t_ref.push_back(ms_since(a));
          }
          ratios.push_back(ref.total_cost > 0 ? ours.total_cost / ref.total_cost : 1.0);
          ours_ms.push_back(median(t_ours));
          ref_ms.push_back(median(t_ref));
        }
        double mean = 0;
        for (double r : ratios) mean += r;
        mean /= ratios.size();
        const double worst = *std::max_element(ratios.begin(), ratios.end());
        std::printf("%-12s %6d %9d %10.4f %10.4f %12.3f %12.3f %12.2f\n", name.c_str(), n, o->instances, mean, worst,
                    median(ours_ms), median(ref_ms), median(cost_s));
        std::fflush(stdout);
        results.push_back({{"map", name}, {"size", n}, {"instances", o->instances}, {"mean_ratio", mean},
                           {"worst_ratio", worst}, {"ours_ms", median(ours_ms)}, {"hungarian_ms", median(ref_ms)},
                           {"costs_s", median(cost_s)}});
      }
    }
    if (!o->json.empty()) {
      std::ofstream f(o->json);
      f << results.dump(2) << "\n";
    }
  });
}

}  // namespace vigil::cli
