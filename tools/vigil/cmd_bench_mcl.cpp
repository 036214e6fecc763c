// vigil bench mcl: Monte Carlo localisation (planning/localization/mcl.h) on the DIS labs
// floorplan and, when present, the real DIAG_labs and DIAG_floor1 SLAM maps: time per filter
// update for 500 / 1000 / 2000 particles on 60 and 180 beams, the memory of the shared map
// data and of one filter, and per seed (start, odometry bias and filter seed) over a simulated
// patrol the tracking error (RMS position and heading, worst), the global-localisation
// convergence time and the kidnap recovery time, beside nav2 AMCL's values.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "common/rng.h"
#include "planning/grid/clearance_field.h"
#include "planning/localization/mcl.h"
#include "tools/vigil/commands.h"
#include "world/kinematic_robot.h"
#include "world/floorplan.h"
#include "world/map.h"
#include "world/ranger.h"

namespace vigil::cli {
namespace {

namespace fs = std::filesystem;
using planning::MclMap;
using planning::MclParams;
using planning::MonteCarloLocalization;

constexpr double kDt = 0.1, kSpeed = 0.4, kTurn = 1.0;
const Pose2 kLaser{0.12, 0.0, 0.0};
constexpr double kInf = std::numeric_limits<double>::infinity();


// The same simulated robot as tests/mcl_test.cpp: unicycle through looping waypoints, or
// wandering by its true laser; Stage-like odometry with a per-robot bias on the x, y and yaw
// increments (the scenarios draw it uniform in [-e, e], e = 0.01, 0.01, 0.1); a 271-beam
// 270-degree 20 m laser with 1 cm noise each 0.1 s.
class SimRobot : public KinematicRobot {
 public:
  SimRobot(const OccupancyGrid& map, Pose2 start, std::vector<Vec2> loop, int samples, Vec3 bias = {0.01, -0.01, 0.1},
           uint64_t noise_seed = 7)
      : KinematicRobot(map, start, loop, loop.empty() ? RouteEnd::kWander : RouteEnd::kLoop, options(samples, bias, noise_seed)) {}
  const LaserScan& last_scan() const { return scan(); }

 private:
  static Options options(int samples, Vec3 bias, uint64_t noise_seed) {
    Options o;
    o.samples = samples;
    o.bias = bias;
    o.noise_seed = noise_seed;
    return o;
  }
};

struct BenchMap {
  std::string name;
  OccupancyGrid grid;
  std::vector<Vec2> loop;  // empty: wander
  bool exterior = false;   // exclude the exterior from uniform sampling (the DIS floorplan)
  std::vector<uint8_t> inside;  // per cell: a sampling cell of the filter (free, not exterior)
  std::unique_ptr<planning::ClearanceField> cf;
  std::shared_ptr<const MclMap> shared[2];  // per parameter set
};

// A free pose with `clearance` metres around it inside the building, from a seeded sequence.
Pose2 roomy_pose(const BenchMap& m, Rng& rng, double clearance) {
  const OccupancyGrid& g = m.grid;
  for (int tries = 0; tries < 1000000; ++tries) {
    const int cx = static_cast<int>(rng.uniform() * g.width()), cy = static_cast<int>(rng.uniform() * g.height());
    if (m.cf->at(cx, cy) < clearance || !m.inside[static_cast<size_t>(cy) * g.width() + cx]) continue;
    const Vec2 c = g.cell_center(cx, cy);
    if (!g.is_free_disc(c, clearance)) continue;  // no unknown cells around either
    return {c.x, c.y, rng.uniform(-M_PI, M_PI)};
  }
  return {};
}

MclParams vigil_params(const BenchMap& m) {
  MclParams p;
  p.laser_pose = kLaser;
  p.kld = true;
  p.exclude_exterior = m.exterior;
  return p;
}

// Our filter with the values of nav2's nav2_params.yaml (KLD 500..2000, alphas 0.2, update
// every 0.25 m / 0.2 rad, z_hit 0.5, z_rand 0.5, pf_err 0.05; recovery off as nav2 ships it;
// plain uniform global initialisation).
MclParams nav2_params(const BenchMap& m) {
  MclParams p = vigil_params(m);
  p.max_particles = 2000;
  p.alpha1 = p.alpha2 = p.alpha3 = p.alpha4 = 0.2;
  p.update_min_d = 0.25;
  p.field.z_hit = 0.5;
  p.field.z_rand = 0.5;
  p.kld_err = 0.05;
  p.recovery_alpha_slow = p.recovery_alpha_fast = 0;
  p.global_candidates = 0;
  return p;
}

// One trial: a start, a per-robot odometry bias (uniform in [-e, e], e = 0.01, 0.01, 0.1), the
// filter's seed; for looping maps the loop is entered at a seed-dependent waypoint.
struct Trial {
  Pose2 start;
  Vec3 bias;
  uint64_t seed = 1;
  std::vector<Vec2> loop;
};

Trial make_trial(const BenchMap& m, int s) {
  Trial t;
  Rng rng = Rng::stream(1000 + s, m.name);
  t.bias = {rng.uniform(-0.01, 0.01), rng.uniform(-0.01, 0.01), rng.uniform(-0.1, 0.1)};
  t.seed = 1 + s;
  if (m.loop.empty()) {
    t.start = roomy_pose(m, rng, 1.0);
  } else {
    const size_t n = m.loop.size(), k = (static_cast<size_t>(s) * (n / 3 + 1)) % n;
    for (size_t i = 0; i < n; ++i) t.loop.push_back(m.loop[(k + 1 + i) % n]);
    const Vec2 a = m.loop[k], b = t.loop.front();
    t.start = {a.x, a.y, std::atan2(b.y - a.y, b.x - a.x)};
  }
  return t;
}

MonteCarloLocalization make_filter(BenchMap& m, const MclParams& p, int which) {
  if (!m.shared[which]) {
    auto sm = MclMap::build(m.grid, p.field, p.exclude_exterior);
    if (!sm) throw Exit{report(sm.error())};
    m.shared[which] = *sm;
  }
  auto mcl = MonteCarloLocalization::create(m.shared[which], p);
  if (!mcl) throw Exit{report(mcl.error())};
  return std::move(*mcl);
}

struct Timing {
  double mean_us = 0, max_us = 0;
};

// Times filter updates (motion, 60 or 180 beams, resampling, estimate) with the default
// parameters over recorded odometry and 180-beam scans, one update per 0.25 m.
Timing time_updates(BenchMap& m, int particles, int beams) {
  const Trial tr = make_trial(m, 0);
  SimRobot robot(m.grid, tr.start, tr.loop, 180, tr.bias);
  std::vector<std::pair<Pose2, LaserScan>> log;
  Pose2 last = robot.odometry();
  while (log.size() < 200 && robot.time() < 600) {
    robot.step();
    const Pose2 o = robot.odometry();
    if (std::hypot(o.x - last.x, o.y - last.y) >= 0.25 || std::abs(wrap_angle(o.yaw - last.yaw)) >= 0.2) {
      log.emplace_back(o, robot.last_scan());
      last = o;
    }
  }
  MclParams p = vigil_params(m);
  p.kld = false;
  p.particles = particles;
  p.max_beams = beams;
  p.update_min_d = p.update_min_a = 0;
  auto mcl = make_filter(m, p, 0);
  Timing t;
  double total = 0;
  for (int rep = 0; rep < 3; ++rep) {
    (void)mcl.initialize(tr.start, {0.1, 0.1, 0.05});
    mcl.update(Pose2{}, &log.front().second);
    for (const auto& [o, scan] : log) {
      const auto t0 = std::chrono::steady_clock::now();
      mcl.update(o, &scan);
      const double us = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count();
      total += us;
      t.max_us = std::max(t.max_us, us);
    }
  }
  t.mean_us = total / (3.0 * log.size());
  return t;
}

struct Patrol {
  double rms_pos = 0, rms_yaw = 0, worst = 0, mean_particles = 0;
  int updates = 0;
  int64_t injected = 0;
};

bool on_truth(const MonteCarloLocalization& mcl, const Pose2& truth) {
  const Pose2& e = mcl.estimate().pose;
  return mcl.converged() && std::hypot(e.x - truth.x, e.y - truth.y) < 0.5 && std::abs(wrap_angle(e.yaw - truth.yaw)) < 0.2;
}

// Tracking from the known start: errors over every filter update after the first 5 s.
Patrol patrol(BenchMap& m, MclParams p, int which, const Trial& tr, double seconds) {
  SimRobot robot(m.grid, tr.start, tr.loop, 271, tr.bias);
  p.seed = tr.seed;
  auto mcl = make_filter(m, p, which);
  (void)mcl.initialize(tr.start, {0.1, 0.1, 0.05});
  mcl.update(robot.odometry(), &robot.last_scan());
  Patrol r;
  double sp = 0, sy = 0, np = 0;
  while (robot.time() < seconds) {
    robot.step();
    if (!mcl.update(robot.odometry(), &robot.last_scan())) continue;
    if (robot.time() < 5) continue;
    const Pose2& e = mcl.estimate().pose;
    const double ep = std::hypot(e.x - robot.truth().x, e.y - robot.truth().y);
    const double ey = wrap_angle(e.yaw - robot.truth().yaw);
    sp += ep * ep;
    sy += ey * ey;
    np += mcl.particles().size();
    r.worst = std::max(r.worst, ep);
    ++r.updates;
  }
  r.rms_pos = std::sqrt(sp / std::max(1, r.updates));
  r.rms_yaw = std::sqrt(sy / std::max(1, r.updates));
  r.mean_particles = np / std::max(1, r.updates);
  r.injected = mcl.stats().injected;
  return r;
}

// Seconds of driving until the estimate is converged on the truth and stays so for 5 s.
double global_time(BenchMap& m, MclParams p, int which, const Trial& tr, double limit) {
  SimRobot robot(m.grid, tr.start, tr.loop, 271, tr.bias);
  p.seed = tr.seed;
  auto mcl = make_filter(m, p, which);
  mcl.initialize_global();
  mcl.update(robot.odometry(), &robot.last_scan());
  double since = -1;
  while (robot.time() < limit) {
    robot.step();
    if (!mcl.update(robot.odometry(), &robot.last_scan())) continue;
    if (on_truth(mcl, robot.truth())) {
      if (since < 0) since = robot.time();
      if (robot.time() - since >= 5) return since;
    } else {
      since = -1;
    }
  }
  return kInf;
}

// Tracks for 60 s, then carries the robot at least 5 m away (a roomy pose inside, or a loop
// waypoint on looping maps); seconds until the estimate is back on the truth (for 5 s).
double kidnap_time(BenchMap& m, MclParams p, int which, const Trial& tr, double limit) {
  SimRobot robot(m.grid, tr.start, tr.loop, 271, tr.bias);
  p.seed = tr.seed;
  auto mcl = make_filter(m, p, which);
  (void)mcl.initialize(tr.start, {0.1, 0.1, 0.05});
  mcl.update(robot.odometry(), &robot.last_scan());
  while (robot.time() < 60) {
    robot.step();
    mcl.update(robot.odometry(), &robot.last_scan());
  }
  Rng rng = Rng::stream(100 + tr.seed, "kidnap");
  if (tr.loop.empty()) {
    Pose2 to;
    do to = roomy_pose(m, rng, 0.8);
    while (std::hypot(to.x - robot.truth().x, to.y - robot.truth().y) < 5.0);
    robot.teleport(to);
  } else {
    size_t k;
    do k = std::min(tr.loop.size() - 1, static_cast<size_t>(rng.uniform() * tr.loop.size()));
    while ((tr.loop[k] - robot.truth().position()).norm() < 5.0);
    const Vec2 a = tr.loop[k], b = tr.loop[(k + 1) % tr.loop.size()];
    robot.teleport({a.x, a.y, std::atan2(b.y - a.y, b.x - a.x)}, (k + 1) % tr.loop.size());
  }
  const double t0 = robot.time();
  double since = -1;
  while (robot.time() < t0 + limit) {
    robot.step();
    if (!mcl.update(robot.odometry(), &robot.last_scan())) continue;
    if (on_truth(mcl, robot.truth())) {
      if (since < 0) since = robot.time();
      if (robot.time() - since >= 5) return since - t0;
    } else {
      since = -1;
    }
  }
  return kInf;
}

std::string secs(double s) {
  if (!std::isfinite(s)) return "not";
  char b[32];
  std::snprintf(b, sizeof b, "%.1f", s);
  return b;
}

nlohmann::ordered_json num_or_null(double v) {
  return std::isfinite(v) ? nlohmann::ordered_json(v) : nlohmann::ordered_json(nullptr);
}

}  // namespace

void add_bench_mcl_command(CLI::App* bench) {
  struct Opts {
    double patrol_seconds = 600;
    int trials = 3;
    std::string json, only = "all", maps = "dis_labs,DIAG_labs,DIAG_floor1", params = "both";
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = bench->add_subcommand("mcl", "Monte Carlo localisation: update cost, tracking error, global and kidnap times");
  cmd->add_option("--patrol-seconds", o->patrol_seconds, "simulated patrol length")->capture_default_str();
  cmd->add_option("--trials", o->trials, "seeds (start, odometry bias, filter seed) per map")->capture_default_str();
  cmd->add_option("--only", o->only, "all, timing, or localisation")->capture_default_str();
  cmd->add_option("--maps", o->maps, "comma-separated maps")->capture_default_str();
  cmd->add_option("--params", o->params, "vigil, nav2 or both")->capture_default_str();
  cmd->add_option("--json", o->json, "also write the results as JSON to this file");
  cmd->callback([o] {
    if (!(o->patrol_seconds > 0) || o->trials < 1)
      throw Exit{report(bad_input("", 0, "--patrol-seconds", "--patrol-seconds and --trials must be positive"))};
    if (o->only != "all" && o->only != "timing" && o->only != "localisation")
      throw Exit{report(bad_input("", 0, "--only", "must be all, timing or localisation"))};
    if (o->params != "both" && o->params != "vigil" && o->params != "nav2")
      throw Exit{report(bad_input("", 0, "--params", "must be vigil, nav2 or both"))};
    auto wanted = [&](const std::string& name) { return ("," + o->maps + ",").find("," + name + ",") != std::string::npos; };
    std::vector<std::unique_ptr<BenchMap>> maps;
    const fs::path src = VIGIL_SOURCE_DIR;
    if (wanted("dis_labs")) {
      auto plan = load_floorplan(src / "maps" / "dis_labs.floorplan.yaml");
      if (!plan) throw Exit{report(plan.error())};
      // The DIS patrol: the corridor, three labs and the two rooms, round and round.
      auto m = std::make_unique<BenchMap>();
      m->name = "dis_labs";
      m->grid = plan->rasterize();
      m->loop = {{6.0, 3.1},  {12.0, 3.1}, {12.0, 6.2}, {10.0, 6.2}, {14.0, 6.0}, {12.0, 3.1}, {20.0, 3.1},
                 {20.0, 7.0}, {20.0, 3.1}, {36.0, 3.1}, {36.0, 7.0}, {36.0, 3.1}, {2.9, 3.1},  {2.9, 15.0},
                 {6.5, 15.0}, {2.9, 15.0}, {2.9, 22.0}, {6.5, 22.0}, {2.9, 22.0}, {2.9, 3.1}};
      m->exterior = true;
      maps.push_back(std::move(m));
    }
    for (const char* name : {"DIAG_labs", "DIAG_floor1"}) {
      if (!wanted(name)) continue;
      const fs::path path = src / ".." / "shared" / "data" / "maps" / name / (std::string(name) + ".yaml");
      if (!fs::exists(path)) {
        std::printf("(%s not found at %s: skipped)\n", name, path.c_str());
        continue;
      }
      auto g = load_map(path);
      if (!g) throw Exit{report(g.error())};
      auto m = std::make_unique<BenchMap>();
      m->name = name;
      m->grid = std::move(*g);
      maps.push_back(std::move(m));
    }
    for (auto& m : maps) {
      m->cf = std::make_unique<planning::ClearanceField>(m->grid);
      auto sm = MclMap::build(m->grid, vigil_params(*m).field, m->exterior);
      if (!sm) throw Exit{report(sm.error())};
      m->shared[0] = *sm;
      m->inside.assign(m->grid.cells().size(), 0);
      for (int32_t i : (*sm)->sample_cells()) m->inside[i] = 1;
    }
    nlohmann::ordered_json out;
    out["timing"] = nlohmann::ordered_json::array();
    out["memory"] = nlohmann::ordered_json::array();
    out["localisation"] = nlohmann::ordered_json::array();
    std::printf("vigil bench mcl: one thread; laser 270 deg, 20 m, 1 cm noise; per-robot odometry bias uniform in\n"
                "[-e, e], e = (0.01, 0.01, 0.1) on the x, y, yaw increments\n\n");
    std::printf("Memory: map data shared by all filters on a map (MclMap), and one filter (KLD, 5000 particles at most)\n");
    std::printf("%-12s %10s %14s %14s\n", "map", "cells", "shared MB", "per filter kB");
    for (auto& m : maps) {
      auto f = make_filter(*m, vigil_params(*m), 0);
      const double shared_mb = m->shared[0]->memory_bytes() / 1e6, filter_kb = f.memory_bytes() / 1e3;
      std::printf("%-12s %10zu %14.1f %14.1f\n", m->name.c_str(), m->grid.cells().size(), shared_mb, filter_kb);
      out["memory"].push_back({{"map", m->name}, {"cells", m->grid.cells().size()}, {"shared_mb", shared_mb},
                               {"per_filter_kb", filter_kb}});
    }
    if (o->only != "localisation") {
      std::printf("\nCost of one filter update (motion + likelihood field + resampling + cluster estimate), fixed count,\n"
                  "default parameters otherwise, 180-beam scans subsampled to the beams column:\n");
      std::printf("%-12s %10s %6s %12s %12s\n", "map", "particles", "beams", "mean us", "max us");
      for (auto& m : maps) {
        for (int n : {500, 1000, 2000}) {
          for (int beams : {60, 180}) {
            const Timing t = time_updates(*m, n, beams);
            std::printf("%-12s %10d %6d %12.1f %12.1f\n", m->name.c_str(), n, beams, t.mean_us, t.max_us);
            std::fflush(stdout);
            out["timing"].push_back(
                {{"map", m->name}, {"particles", n}, {"beams", beams}, {"mean_us", t.mean_us}, {"max_us", t.max_us}});
          }
        }
      }
    }
    if (o->only != "timing") {
      std::printf("\nLocalisation per seed: tracking from the known start over a %.0f s patrol at 0.4 m/s (errors after\n"
                  "5 s; 271-beam scans at 10 Hz); global localisation and kidnap recovery times (s of driving, limit 120)\n",
                  o->patrol_seconds);
      std::printf("%-12s %-12s %5s %22s %8s %9s %8s %8s %8s %9s %8s %8s\n", "map", "parameters", "seed", "bias x,y,yaw",
                  "updates", "particles", "RMS m", "RMS deg", "worst m", "injected", "global", "kidnap");
      for (auto& m : maps) {
        for (int which = 0; which < 2; ++which) {
          if ((which == 0 && o->params == "nav2") || (which == 1 && o->params == "vigil")) continue;
          const MclParams p = which == 0 ? vigil_params(*m) : nav2_params(*m);
          const char* label = which == 0 ? "vigil" : "nav2 values";
          for (int s = 0; s < o->trials; ++s) {
            const Trial tr = make_trial(*m, s);
            const Patrol r = patrol(*m, p, which, tr, o->patrol_seconds);
            const double g = global_time(*m, p, which, tr, 120);
            const double k = kidnap_time(*m, p, which, tr, 120);
            char bias[64];
            std::snprintf(bias, sizeof bias, "%+.3f,%+.3f,%+.3f", tr.bias.x, tr.bias.y, tr.bias.z);
            std::printf("%-12s %-12s %5llu %22s %8d %9.0f %8.3f %8.2f %8.3f %9lld %8s %8s\n", m->name.c_str(), label,
                        static_cast<unsigned long long>(tr.seed), bias, r.updates, r.mean_particles, r.rms_pos,
                        r.rms_yaw * 180 / M_PI, r.worst, static_cast<long long>(r.injected), secs(g).c_str(),
                        secs(k).c_str());
            std::fflush(stdout);
            out["localisation"].push_back(
                {{"map", m->name}, {"parameters", label}, {"seed", tr.seed}, {"bias", {tr.bias.x, tr.bias.y, tr.bias.z}},
                 {"updates", r.updates}, {"mean_particles", r.mean_particles}, {"rms_position_m", r.rms_pos},
                 {"rms_heading_deg", r.rms_yaw * 180 / M_PI}, {"worst_position_m", r.worst}, {"injected", r.injected},
                 {"global_convergence_s", num_or_null(g)}, {"kidnap_recovery_s", num_or_null(k)}});
          }
        }
      }
      std::printf(
          "\n'vigil' = the defaults (KLD 500..5000, sensor-guided global initialisation and gated augmented-MCL\n"
          "injection; DIS samples only inside the building). 'nav2 values' runs this filter with nav2's\n"
          "nav2_params.yaml values (KLD 500..2000, alphas 0.2, z_hit 0.5, update 0.25 m / 0.2 rad, recovery off,\n"
          "uniform global initialisation); it is not AMCL's code. 'not' = not within 120 s.\n");
    }
    if (!o->json.empty()) {
      std::ofstream f(o->json);
      f << out.dump(2) << "\n";
    }
  });
}

}  // namespace vigil::cli
