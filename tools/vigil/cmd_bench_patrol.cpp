// vigil bench patrol: multi-robot patrolling (plugins/team, planning/patrol) with the real
// navigator (MCL, two-level planner, pure pursuit) on the real DIAG_labs and DIAG_floor1 maps
// and their patrolling_sim graphs: per strategy and team size, the idleness over the run (the
// intervals between successive visits of a vertex after its first, measured on the robots'
// true positions), beside the reference: the shortest closed walk through every vertex over
// (robots x speed).
#include <chrono>
#include <cstdio>
#include <fstream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "planning/patrol/idleness.h"
#include "planning/patrol/patrol_graph.h"
#include "planning/patrol/tour.h"
#include "plugins/builtin.h"
#include "tools/vigil/commands.h"
#include "tools/vigil/plugin_search.h"
#include "world/map.h"
#include "world/team_bus.h"
#include "world/topdown.h"
#include "world/world.h"

namespace vigil::cli {
namespace {

namespace fs = std::filesystem;
using namespace planning::patrol;

struct PatrolBenchOptions {
  std::vector<std::string> maps;
  std::vector<int> robots{1, 2, 4, 6, 8, 12};
  std::vector<std::string> strategies{"cyclic", "partition", "greedy"};
  double seconds = 1800, speed = 1.0, physics_hz = 10, visit_radius = 0.5;
  uint64_t seed = 1;
  std::string json, trace, pictures;
  std::vector<std::string> set;  // extra team parameters, name=value
};

struct MapCase {
  std::string name;
  fs::path map, graph;
};

std::vector<MapCase> bench_maps(const std::vector<std::string>& names) {
  const fs::path src = VIGIL_SOURCE_DIR;
  std::vector<MapCase> out;
  for (const std::string& n : names) {
    if (n == "dis_labs") {
      out.push_back({n, src / "maps" / "dis_labs.yaml", src / "maps" / "dis_labs.graph"});
    } else {
      const fs::path dir = src / ".." / "shared" / "data" / "maps" / n;
      out.push_back({n, dir / (n + ".yaml"), dir / (n + ".graph")});
    }
  }
  return out;
}

// The longest interval between successive visits of one vertex, and who made them.
struct WorstInterval {
  int vertex = -1;
  double from = 0, to = 0;
  std::string before, after;
};

WorstInterval worst_interval(std::vector<Visit> visits) {
  std::stable_sort(visits.begin(), visits.end(), [](const Visit& a, const Visit& b) { return a.t < b.t; });
  std::map<int, const Visit*> last;
  WorstInterval w;
  for (const Visit& v : visits) {
    auto it = last.find(v.vertex);
    if (it != last.end() && v.t - it->second->t > w.to - w.from) w = {v.vertex, it->second->t, v.t, it->second->robot, v.robot};
    last[v.vertex] = &v;
  }
  return w;
}

}  // namespace

void add_bench_patrol_command(CLI::App* bench) {
  auto o = std::make_shared<PatrolBenchOptions>();
  auto* cmd = bench->add_subcommand("patrol", "Patrol idleness per strategy and team size, real navigator on the real maps");
  cmd->add_option("--maps", o->maps, "DIAG_labs, DIAG_floor1 (../shared/data) or dis_labs (default: the DIAG maps when present)")
      ->delimiter(',');
  cmd->add_option("--robots", o->robots, "team sizes")->delimiter(',');
  cmd->add_option("--strategies", o->strategies, "cyclic, partition, greedy")->delimiter(',');
  cmd->add_option("--seconds", o->seconds, "simulated seconds per run")->capture_default_str();
  cmd->add_option("--speed", o->speed, "robots' cruise and top speed (m/s)")->capture_default_str();
  cmd->add_option("--physics-hz", o->physics_hz, "physics rate")->capture_default_str();
  cmd->add_option("--visit-radius", o->visit_radius, "a vertex is visited within this distance (m)")->capture_default_str();
  cmd->add_option("--seed", o->seed, "seed")->capture_default_str();
  cmd->add_option("--json", o->json, "also write the results as JSON to this file");
  cmd->add_option("--trace", o->trace,
                  "write every visit, the robots' true positions (each second) and their events (failed goals, team changes) of every run as CSV to this file")
      ->capture_default_str();
  cmd->add_option("--pictures", o->pictures,
                  "write a top-down picture of every run to this folder: the graph, each vertex in the colour of the robot "
                  "that visited it most (so a partition's regions show), the robots where the run ended");
  cmd->add_option("--set", o->set, "extra team controller parameters NAME=VALUE (numbers or true/false), e.g. spacing_hold=false")
      ->delimiter(',');
  cmd->callback([o] {
    std::vector<std::string> names = o->maps;
    if (names.empty()) {
      const fs::path shared = fs::path(VIGIL_SOURCE_DIR) / ".." / "shared" / "data" / "maps";
      if (fs::exists(shared / "DIAG_labs")) names = {"DIAG_labs", "DIAG_floor1"};
      else {
        std::printf("../shared/data not found beside the checkout: benchmarking on maps/dis_labs only\n");
        names = {"dis_labs"};
      }
    }
    const fs::path urdf = fs::path(VIGIL_SOURCE_DIR) / "maps" / "robots" / "erratic.urdf";
    nlohmann::ordered_json results = nlohmann::ordered_json::array();
    std::ofstream trace;
    if (!o->trace.empty()) {
      trace.open(o->trace);
      trace << "map,strategy,robots,kind,t,robot,vertex,x,y,event,mode,detail\n";
    }
    for (const MapCase& mc : bench_maps(names)) {
      auto graph = PatrolGraph::read(mc.graph);
      if (!graph) throw Exit{report(graph.error())};
      GraphDistances dist(*graph);
      const ClosedWalk tour = closed_walk(*graph, dist);
      std::printf("vigil bench patrol: %s, %zu vertices, shortest closed walk %.1f m, %.1f m/s, %.0f s simulated, "
                  "physics %.0f Hz, visits within %.1f m (true positions)\n",
                  mc.name.c_str(), graph->size(), tour.length, o->speed, o->seconds, o->physics_hz, o->visit_radius);
      std::printf("%-10s %6s %9s %9s %9s %7s %9s %9s %9s %7s %7s %6s %6s %8s\n", "strategy", "robots", "ref s", "avg s",
                  "worst s", "std s", "avg/ref", "worst/ref", "intervals", "interf", "failed", "walls", "robots", "wall s");
      std::printf("(walls, robots: contacts of a robot's body with a wall, with another robot)\n");
      std::printf("(worst: the longest interval between visits, or the longest a vertex waited at the end if longer)\n");
      std::vector<Vec2> vertices;
      for (const auto& v : graph->vertices()) vertices.push_back(v.position);
      for (const std::string& strategy : o->strategies) {
        for (int n : o->robots) {
          Scenario sc;
          sc.file = mc.graph.string();
          sc.name = "bench_patrol";
          sc.map = mc.map;
          sc.duration = o->seconds;
          sc.seed = o->seed;
          sc.physics_rate_hz = o->physics_hz;
          for (int k = 0; k < n; ++k) {
            RobotSpec r;
            r.id = "robot" + std::to_string(k + 1);
            r.urdf = urdf;
            // Spread over the vertex list (patrolling_sim starts robots at chosen vertices).
            const Vec2 p = graph->vertex(static_cast<size_t>(k) * graph->size() / static_cast<size_t>(n)).position;
            r.start = {p.x, p.y, 0.0};
            r.controller = "team";
            r.params["graph"] = {fs::absolute(mc.graph).string(), 0};
            r.params["strategy"] = {strategy, 0};
            r.params["speed"] = {o->speed, 0};
            r.params["visit_radius"] = {o->visit_radius, 0};
            for (const std::string& kv : o->set) {
              const auto eq = kv.find('=');
              if (eq == std::string::npos) throw Exit{report(bad_input("", 0, "--set", "'" + kv + "' is not NAME=VALUE"))};
              const std::string name = kv.substr(0, eq), value = kv.substr(eq + 1);
              if (value == "true" || value == "false") r.params[name] = {value == "true", 0};
              else {
                char* end = nullptr;
                const double x = std::strtod(value.c_str(), &end);
                if (end != value.c_str() && *end == '\0') r.params[name] = {x, 0};
                else r.params[name] = {value, 0};
              }
            }
            r.max_speed = o->speed;
            r.ranger.enabled = true;
            r.ranger.samples = 271;
            r.ranger.fov = 270 * M_PI / 180;
            r.ranger.range_max = 20;
            r.ranger.noise_std = 0.01;
            r.odometry.error_x = r.odometry.error_y = 0.01;
            r.odometry.error_yaw = 0.1;
            sc.robots.push_back(r);
          }
          WorldOptions wo;
          wo.plugins = builtin_plugin_registry();
          wo.plugin_dirs = plugin_search_path();
          auto world = World::create(sc, wo);
          if (!world) throw Exit{report(world.error())};
          LocalTeamBus bus;
          VisitDetector visits(vertices, o->visit_radius);
          InterferenceCounter interf(2.0);
          const SimTime sample_every = from_seconds(0.2);
          SimTime next_sample = 0;
          int failed = 0;
          const auto t0 = std::chrono::steady_clock::now();
          while (!(*world)->finished()) {
            if (Status s = (*world)->advance(); !s) throw Exit{report(s.error())};
            bus.exchange(**world);
            for (const RobotReport& rep : (*world)->drain_reports()) {
              failed += rep.event == "goal_failed";
              if (trace.is_open() && !rep.event.empty() && rep.event != "goal_started" && rep.event != "goal_reached") {
                trace << mc.name << ',' << strategy << ',' << n << ",event," << to_seconds((*world)->time()) << ','
                      << rep.robot << ",-1," << rep.pose.x << ',' << rep.pose.y << ',' << rep.event << ',' << rep.mode
                      << ",\"" << rep.detail << "\"\n";
              }
            }
            if ((*world)->time() >= next_sample) {
              std::vector<std::pair<std::string, Vec2>> at;
              for (const RobotEntity& r : (*world)->robots()) {
                visits.observe(r.spec.id, to_seconds((*world)->time()), r.pose.position());
                at.push_back({r.spec.id, r.pose.position()});
              }
              interf.observe(at);
              if (trace.is_open() && (*world)->time() % from_seconds(1.0) == 0) {
                for (const auto& [id, q] : at) {
                  trace << mc.name << ',' << strategy << ',' << n << ",pose," << to_seconds((*world)->time()) << ','
                        << id << ",-1," << q.x << ',' << q.y << '\n';
                }
              }
              next_sample += sample_every;
            }
          }
          const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
          IdlenessStats st = idleness(visits.visits(), static_cast<int>(graph->size()), o->seconds);
          // A vertex left alone for the rest of the run counts with the time it has waited (the
          // worst idleness of patrolling_sim's monitor is the longest any vertex was idle).
          const double worst_interval_s = st.worst;
          st.worst = std::max(st.worst, st.longest_open);
          // Where the worst interval was: the vertex, when it ended and the robots either side.
          WorstInterval wi = worst_interval(visits.visits());
          if (trace.is_open()) {
            for (const Visit& v : visits.visits()) {
              trace << mc.name << ',' << strategy << ',' << n << ",visit," << v.t << ',' << v.robot << ',' << v.vertex
                    << ",0,0\n";
            }
          }
          if (!o->pictures.empty()) {
            fs::create_directories(o->pictures);
            TopdownRenderer top(**world);
            cv::Mat img = top.draw(**world);
            for (size_t a = 0; a < graph->size(); ++a) {
              for (const GraphEdge& e : graph->vertex(a).edges) {
                if (static_cast<size_t>(e.to) > a) {
                  cv::line(img, top.to_px(graph->vertex(a).position), top.to_px(graph->vertex(static_cast<size_t>(e.to)).position),
                           cv::Scalar(160, 160, 160), 1, cv::LINE_AA);
                }
              }
            }
            // Each vertex in the colour of the robot that visited it most.
            std::map<int, std::map<std::string, int>> by;
            for (const Visit& v : visits.visits()) ++by[v.vertex][v.robot];
            for (size_t a = 0; a < graph->size(); ++a) {
              cv::Scalar colour(0, 0, 0);
              int most = 0;
              for (const auto& [robot, count] : by[static_cast<int>(a)]) {
                if (count > most) {
                  most = count;
                  const int k = std::atoi(robot.c_str() + std::min<size_t>(robot.size(), 5));
                  const double hue = std::fmod(k * 0.381966, 1.0) * 180.0;  // golden-ratio hues
                  cv::Mat hsv(1, 1, CV_8UC3, cv::Scalar(hue, 220, 210)), bgr;
                  cv::cvtColor(hsv, bgr, cv::COLOR_HSV2BGR);
                  const cv::Vec3b c = bgr.at<cv::Vec3b>(0, 0);
                  colour = cv::Scalar(c[0], c[1], c[2]);
                }
              }
              cv::circle(img, top.to_px(graph->vertex(a).position), 6, colour, cv::FILLED, cv::LINE_AA);
            }
            char caption[160];
            std::snprintf(caption, sizeof caption, "%s, %s, %d robots: vertices by their most frequent visitor", mc.name.c_str(),
                          strategy.c_str(), n);
            cv::putText(img, caption, {10, img.rows - 12}, cv::FONT_HERSHEY_SIMPLEX, 0.6, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
            cv::imwrite((fs::path(o->pictures) / (mc.name + "_" + strategy + "_" + std::to_string(n) + ".png")).string(), img);
          }
          const double ref = tour.length / (n * o->speed);
          int wall_contacts = 0, robot_contacts = 0;
          for (const ContactRecord& c : (*world)->contacts()) {
            wall_contacts += c.other_kind == "wall";
            robot_contacts += c.other_kind == "robot";
          }
          std::printf("%-10s %6d %9.1f %9.1f %9.1f %7.1f %9.2f %9.2f %9d %7d %7d %6d %6d %8.1f%s\n", strategy.c_str(), n,
                      ref, st.average, st.worst, st.stddev, st.average / ref, st.worst / ref, st.intervals, interf.count(),
                      failed, wall_contacts, robot_contacts, wall, st.unvisited ? "  (unvisited vertices!)" : "");
          if (wi.vertex >= 0) {
            std::printf("%-10s %6s worst: vertex %d, %.1f s to %.1f s (%s, then %s)\n", "", "", wi.vertex, wi.from, wi.to,
                        wi.before.c_str(), wi.after.c_str());
          }
          std::fflush(stdout);
          results.push_back({{"map", mc.name}, {"strategy", strategy}, {"robots", n}, {"reference_s", ref},
                             {"average_s", st.average}, {"worst_s", st.worst}, {"worst_interval_s", worst_interval_s},
                             {"longest_open_s", st.longest_open}, {"stddev_s", st.stddev},
                             {"median_s", st.median}, {"intervals", st.intervals}, {"visits", st.visits},
                             {"unvisited", st.unvisited}, {"interferences", interf.count()}, {"goals_failed", failed},
                             {"wall_contacts", wall_contacts}, {"robot_contacts", robot_contacts},
                             {"tour_m", tour.length}, {"wall_seconds", wall},
                             {"worst_interval", {{"vertex", wi.vertex}, {"from_s", wi.from}, {"to_s", wi.to},
                                                 {"robot_before", wi.before}, {"robot_after", wi.after}}}});
        }
      }
    }
    if (!o->json.empty()) {
      std::ofstream f(o->json);
      f << results.dump(2) << "\n";
    }
  });
}

}  // namespace vigil::cli
