// vigil bench plan: the two-level planner beside plain OMPL PRM and RRTConnect on the same
// seeded random queries in the same run, with every length over the any-angle grid reference
// (Lazy Theta*) on the same inflated grid. Maps: the DIS floorplan and, when ../shared/data is
// present, the real DIAG_floor1 and DIAG_labs SLAM maps.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>

#include "common/rng.h"
#include "planning/grid/grid_astar.h"
#include "planning/path_planner.h"
#include "tools/vigil/commands.h"
#include "world/floorplan.h"
#include "world/map.h"

namespace vigil::cli {
namespace {

struct PlanQuery {
  Vec2 start, goal;
};

// `n` pairs of free points (for the robot) in the same connected region, at least 1 m apart.
std::vector<PlanQuery> random_queries(const planning::InflatedGrid& g, int n, uint64_t seed) {
  Rng rng = Rng::stream(seed, "bench-plan-queries");
  std::vector<PlanQuery> out;
  auto sample = [&]() {
    for (;;) {
      const Vec2 p{rng.uniform(g.lower().x, g.upper().x), rng.uniform(g.lower().y, g.upper().y)};
      if (g.is_free(p)) return p;
    }
  };
  // The largest region holds the queries (other regions are pockets behind closed doors).
  int largest = 0;
  for (int c = 1; c < g.component_count(); ++c)
    if (g.component_area(c) > g.component_area(largest)) largest = c;
  while (static_cast<int>(out.size()) < n) {
    const Vec2 a = sample(), b = sample();
    if (g.component(a) != largest || g.component(b) != largest || (a - b).norm() < 1.0) continue;
    out.push_back({a, b});
  }
  return out;
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const size_t i = std::min(v.size() - 1, static_cast<size_t>(q * (v.size() - 1) + 0.5));
  return v[i];
}

struct MapCase {
  std::string name;
  std::filesystem::path path;
};

Result<OccupancyGrid> load_any_map(const std::filesystem::path& p) {
  const std::string s = p.filename().string();
  if (s.size() > 15 && s.ends_with(".floorplan.yaml")) {
    auto fp = load_floorplan(p);
    if (!fp) return fp.error();
    return fp->rasterize();
  }
  return load_map(p);
}

}  // namespace

void add_bench_plan_command(CLI::App* bench) {
  struct Opts {
    int queries = 200;
    uint64_t seed = 1;
    double radius = 0.3;
    double ompl_time = 1.0;
    std::vector<std::string> maps;
    std::string json;
    bool no_baselines = false;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = bench->add_subcommand("plan", "Two-level planner beside plain OMPL PRM / RRTConnect on random queries");
  cmd->add_option("--queries", o->queries, "random start/goal pairs per map")->check(CLI::Range(1, 100000));
  cmd->add_option("--seed", o->seed, "seed of the queries and the roadmap");
  cmd->add_option("--radius", o->radius, "robot radius (m)")->check(CLI::Range(0.05, 2.0));
  cmd->add_option("--ompl-time", o->ompl_time, "time limit per query of the plain OMPL planners (s)");
  cmd->add_option("--map", o->maps, "maps (default: maps/dis_labs.floorplan.yaml and the DIAG maps if present)");
  cmd->add_flag("--no-baselines", o->no_baselines, "only ours and the reference");
  cmd->add_option("--json", o->json, "also write the results as JSON to this file");
  cmd->callback([o] {
    std::vector<MapCase> cases;
    const std::filesystem::path src = VIGIL_SOURCE_DIR;
    if (o->maps.empty()) {
      cases.push_back({"dis_labs", src / "maps" / "dis_labs.floorplan.yaml"});
      for (const char* m : {"DIAG_floor1", "DIAG_labs"}) {
        const auto p = src / ".." / "shared" / "data" / "maps" / m / (std::string(m) + ".yaml");
        if (std::filesystem::exists(p)) cases.push_back({m, p});
        else std::printf("(%s skipped: %s not found)\n", m, p.string().c_str());
      }
    } else {
      for (const auto& m : o->maps) cases.push_back({std::filesystem::path(m).stem().string(), m});
    }
    nlohmann::ordered_json results = nlohmann::ordered_json::array();
    std::printf("%-12s %-48s %8s %10s %10s %10s %10s\n", "map", "planner", "solved", "median ms", "p95 ms",
                "med len/opt", "worst len/opt");
    for (const auto& mc : cases) {
      auto grid = load_any_map(mc.path);
      if (!grid) throw Exit{report(grid.error())};
      planning::TwoLevelParams params;
      params.robot_radius = o->radius;
      params.roadmap.seed = o->seed;
      params.motion.seed = o->seed;
      auto ours = planning::TwoLevelPlanner::create(*grid, params);
      if (!ours) throw Exit{report(ours.error())};
      const auto& st = (*ours)->roadmap().stats();
      std::printf("%-12s roadmap: %zu milestones (%zu PRM + bridges %zu), %zu edges, %zu components, built in %.0f ms\n",
                  mc.name.c_str(), st.nodes, st.prm_nodes, st.bridges, st.edges, st.components,
                  st.build_seconds * 1e3);
      const planning::InflatedGrid& ig = (*ours)->inflated();
      const auto queries = random_queries(ig, o->queries, o->seed);
      // Reference lengths first.
      auto reference = planning::make_grid_reference(ig);
      std::vector<double> optimum(queries.size(), 0);
      for (size_t i = 0; i < queries.size(); ++i) optimum[i] = reference->plan(queries[i].start, queries[i].goal).length;
      std::vector<std::unique_ptr<planning::PathPlanner>> planners;
      planners.push_back(planning::wrap_two_level(**ours));
      if (!o->no_baselines) {
        planners.push_back(planning::make_ompl_baseline(ig, planning::OmplBaseline::kPrm, o->ompl_time,
                                                        static_cast<uint32_t>(o->seed)));
        planners.push_back(planning::make_ompl_baseline(ig, planning::OmplBaseline::kRrtConnect, o->ompl_time,
                                                        static_cast<uint32_t>(o->seed)));
      }
      // The scripted people's grid A* (8-connected, then line of sight) on the same queries:
      // its figure was a time bound in tests/map_test.cpp.
      {
        const planning::GridPathPlanner people(*grid, o->radius);
        std::vector<double> ms;
        int found = 0;
        for (const auto& q : queries) {
          const auto t0 = std::chrono::steady_clock::now();
          found += !people.plan(q.start, q.goal).empty();
          ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
        }
        std::printf("%-12s %-48s %4d/%-3zu %10.3f %10.3f\n", mc.name.c_str(), "grid A* (scripted people's paths)", found,
                    queries.size(), percentile(ms, 0.5), percentile(ms, 0.95));
        results.push_back({{"map", mc.name},
                           {"planner", "grid A* (scripted people)"},
                           {"queries", queries.size()},
                           {"solved", found},
                           {"median_ms", percentile(ms, 0.5)},
                           {"p95_ms", percentile(ms, 0.95)}});
      }
      for (auto& planner : planners) {
        std::vector<double> ms, ratio;
        int solved = 0, invalid_paths = 0;
        for (size_t i = 0; i < queries.size(); ++i) {
          const auto t0 = std::chrono::steady_clock::now();
          const planning::PlanResult r = planner->plan(queries[i].start, queries[i].goal);
          ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
          if (r.outcome != planning::PlanOutcome::kExact) continue;
          bool valid = true;
          for (size_t k = 1; k < r.path.size(); ++k) valid = valid && ig.segment_free(r.path[k - 1], r.path[k]);
          if (!valid) {
            ++invalid_paths;
            continue;
          }
          ++solved;
          if (optimum[i] > 0) ratio.push_back(r.length / optimum[i]);
        }
        const double worst = ratio.empty() ? 0 : *std::max_element(ratio.begin(), ratio.end());
        std::printf("%-12s %-48s %4d/%-3zu %10.3f %10.3f %10.4f %10.4f%s\n", mc.name.c_str(), planner->name().c_str(),
                    solved, queries.size(), percentile(ms, 0.5), percentile(ms, 0.95), percentile(ratio, 0.5), worst,
                    invalid_paths ? "  (some paths not free!)" : "");
        results.push_back({{"map", mc.name},
                           {"planner", planner->name()},
                           {"queries", queries.size()},
                           {"solved", solved},
                           {"invalid_paths", invalid_paths},
                           {"median_ms", percentile(ms, 0.5)},
                           {"p95_ms", percentile(ms, 0.95)},
                           {"median_length_ratio", percentile(ratio, 0.5)},
                           {"worst_length_ratio", worst},
                           {"roadmap_nodes", st.nodes},
                           {"roadmap_build_ms", st.build_seconds * 1e3}});
      }
    }
    std::printf("targets for ours: every query solved, median <= 5 ms, p95 <= 20 ms, median length <= 1.05x optimum\n");
    std::printf("peer (MISSION.md): OMPL 1.5 PRM query on a 3k-node roadmap 8-9 ms, RRTConnect 0.5-0.8 ms on 60 x 20 m\n");
    if (!o->json.empty()) {
      std::ofstream f(o->json);
      f << results.dump(2) << "\n";
      if (!f) throw Exit{report(bad_input(o->json, 0, "--json", "cannot write"))};
    }
  });
}

}  // namespace vigil::cli
