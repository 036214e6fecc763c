// vigil eval RUN_DIR [--match-distance M] [--camera ID] [--max-range M (--camera-xy X,Y | --scenario FILE)]
//                    [--in-view] [--classes person,bag] [--exclude-carried] [--camera-rate HZ] [--tracks FILE]
//   Multi-object-tracking metrics of a run's tracks.jsonl against its ground_truth.jsonl in the
//   map frame, and of its events.jsonl against the ground-truth events (precision, recall,
//   latency, localisation per kind); writes RUN_DIR/eval.json ("tracking", "events", other
//   top-level keys kept) and prints tables.
// vigil eval --mot-gt GT.txt --mot-test TEST.txt [--iou-threshold 0.5] [--gt-min-confidence 1]
//   The same metrics on MOTChallenge box files (py-motmetrics 1.4.0 figures), printed as JSON.
// Documented in docs/EVALUATION.md.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <numbers>
#include <optional>
#include <sstream>
#include <limits>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "plugins/builtin.h"
#include "tools/vigil/commands.h"
#include "planning/two_level_planner.h"
#include "world/floorplan.h"
#include "world/map.h"
#include "world/navigation_eval.h"
#include "planning/patrol/idleness.h"
#include "planning/patrol/patrol_graph.h"
#include "planning/patrol/tour.h"
#include "vision/event.h"
#include "vision/event_eval.h"
#include "vision/map_track_eval.h"
#include "vision/mot_metrics.h"
#include "vision/stereo_camera_model.h"
#include "vision/track_io.h"
#include "world/ranger.h"
#include "world/scenario.h"
#include "world/world.h"

namespace vigil::cli {
namespace {

namespace fs = std::filesystem;
using vision::MotMetrics;

// py-motmetrics' names, in the order of its default summary.
nlohmann::ordered_json motmetrics_json(const MotMetrics& m) {
  nlohmann::ordered_json j;
  j["idf1"] = m.idf1;
  j["idp"] = m.idp;
  j["idr"] = m.idr;
  j["recall"] = m.recall;
  j["precision"] = m.precision;
  j["num_unique_objects"] = m.num_unique_objects;
  j["mostly_tracked"] = m.mostly_tracked;
  j["partially_tracked"] = m.partially_tracked;
  j["mostly_lost"] = m.mostly_lost;
  j["num_false_positives"] = m.num_false_positives;
  j["num_misses"] = m.num_misses;
  j["num_switches"] = m.num_switches;
  j["num_fragmentations"] = m.num_fragmentations;
  j["mota"] = m.mota;
  j["motp"] = m.motp;
  j["num_transfer"] = m.num_transfer;
  j["num_ascend"] = m.num_ascend;
  j["num_migrate"] = m.num_migrate;
  j["num_frames"] = m.num_frames;
  j["num_objects"] = m.num_objects;
  j["num_predictions"] = m.num_predictions;
  j["num_matches"] = m.num_matches;
  j["idtp"] = m.idtp;
  j["idfp"] = m.idfp;
  j["idfn"] = m.idfn;
  return j;
}

// The map-frame figures as eval.json names them.
nlohmann::ordered_json tracking_json(const MotMetrics& m) {
  nlohmann::ordered_json j;
  j["mota"] = m.mota;
  j["motp_m"] = m.motp;
  j["idf1"] = m.idf1;
  j["idp"] = m.idp;
  j["idr"] = m.idr;
  j["recall"] = m.recall;
  j["precision"] = m.precision;
  j["id_switches"] = m.num_switches;
  j["fragmentations"] = m.num_fragmentations;
  j["false_positives"] = m.num_false_positives;
  j["misses"] = m.num_misses;
  j["matches"] = m.num_detections;
  j["ground_truth_count"] = m.num_objects;
  j["track_count"] = m.num_predictions;
  j["unique_objects"] = m.num_unique_objects;
  j["unique_tracks"] = m.num_unique_hypotheses;
  j["mostly_tracked"] = m.mostly_tracked;
  j["partially_tracked"] = m.partially_tracked;
  j["mostly_lost"] = m.mostly_lost;
  return j;
}

std::string cell(double v, int width) {
  char buf[64];
  if (std::isfinite(v)) {
    std::snprintf(buf, sizeof buf, "%*.4f", width, v);
  } else {
    std::snprintf(buf, sizeof buf, "%*s", width, "-");
  }
  return buf;
}

void print_row(const std::string& name, const MotMetrics& m) {
  std::printf("%-8s%s%s%s%s%s%s%s %6lld %4lld %4lld %4lld %6lld %6lld %5lld %5lld\n", name.c_str(), cell(m.mota, 8).c_str(),
              cell(m.motp, 8).c_str(), cell(m.idf1, 8).c_str(), cell(m.idp, 8).c_str(), cell(m.idr, 8).c_str(),
              cell(m.recall, 8).c_str(), cell(m.precision, 8).c_str(), static_cast<long long>(m.num_objects),
              static_cast<long long>(m.mostly_tracked), static_cast<long long>(m.partially_tracked),
              static_cast<long long>(m.mostly_lost), static_cast<long long>(m.num_false_positives),
              static_cast<long long>(m.num_misses), static_cast<long long>(m.num_switches),
              static_cast<long long>(m.num_fragmentations));
}

// Reads RUN_DIR/eval.json when it exists (its other keys are kept); an empty object otherwise.
Result<nlohmann::ordered_json> read_eval_json(const fs::path& path) {
  if (!fs::exists(path)) return nlohmann::ordered_json::object();
  std::ifstream f(path, std::ios::binary);
  if (!f) return bad_input(path.string(), 0, "", "cannot open file");
  std::stringstream ss;
  ss << f.rdbuf();
  auto j = nlohmann::ordered_json::parse(ss.str(), nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded() || !j.is_object())
    return bad_input(path.string(), 0, "", "not a JSON object (fix or remove it: vigil eval adds its \"tracking\" key to it)");
  return j;
}

Status write_text_file(const fs::path& path, const std::string& text) {
  const fs::path tmp = path.string() + ".tmp";
  {
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    if (!f) return bad_input(tmp.string(), 0, "", "cannot open for writing");
    f << text;
    if (!f) return internal_error("cannot write " + tmp.string());
  }
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) return internal_error("cannot replace " + path.string() + ": " + ec.message());
  return Status::Ok();
}

struct Opts {
  std::string run_dir, tracks, scenario, camera, mot_gt, mot_test, graph;
  double visit_radius = 0.5;
  double match_distance = 0.5;
  std::optional<double> max_range, camera_rate;
  std::vector<double> camera_xy;
  std::vector<std::string> classes;
  bool exclude_carried = false, in_view = false;
  double iou_threshold = 0.5;
  double gt_min_confidence = 1.0;
};

void run_mot_challenge(const Opts& o) {
  if (o.mot_gt.empty() || o.mot_test.empty())
    throw Exit{report(bad_input("", 0, o.mot_gt.empty() ? "--mot-gt" : "--mot-test", "--mot-gt and --mot-test go together"))};
  if (!o.run_dir.empty())
    throw Exit{report(bad_input("", 0, "RUN_DIR", "give either RUN_DIR or --mot-gt/--mot-test, not both"))};
  if (!(o.iou_threshold >= 0 && o.iou_threshold <= 1))
    throw Exit{report(bad_input("", 0, "--iou-threshold", "must be in [0, 1] (a pair matches when 1 - IoU <= it)"))};
  vision::MotChallengeLoadOptions gt_opts;
  gt_opts.min_confidence = o.gt_min_confidence;
  auto gt = vision::load_mot_challenge(o.mot_gt, gt_opts);
  if (!gt) throw Exit{report(gt.error())};
  auto test = vision::load_mot_challenge(o.mot_test);
  if (!test) throw Exit{report(test.error())};
  vision::MotParams params;
  params.max_distance = o.iou_threshold;
  auto m = vision::evaluate_mot_challenge(*gt, *test, params);
  if (!m) throw Exit{report(m.error())};
  std::printf("%s\n", motmetrics_json(*m).dump(2).c_str());
}

// The response to each incident: who was assigned and when, when it arrived, its travel time
// over the best travel time any robot free at that moment had (their true positions, the
// two-level planner on the scenario's map, each robot's cruise speed), and the chosen robot's
// planned cost over the best one's: eval.json "response", and a table.
void evaluate_run_response(const fs::path& dir, const std::string& scenario_file, nlohmann::ordered_json* eval) {
  ScenarioContext ctx;
  auto sc = load_scenario(scenario_file, ctx);
  if (!sc) throw Exit{report(sc.error())};
  Result<OccupancyGrid> grid = sc->map.string().ends_with(".floorplan.yaml") ? [&]() -> Result<OccupancyGrid> {
    auto fp = load_floorplan(sc->map);
    if (!fp) return fp.error();
    return fp->rasterize();
  }()
                                                                             : load_map(sc->map);
  if (!grid) throw Exit{report(grid.error())};
  planning::TwoLevelParams tp;
  tp.robot_radius = 0.38;
  auto planner = planning::TwoLevelPlanner::create(*grid, tp, {});
  if (!planner) throw Exit{report(planner.error())};
  auto read_lines = [](const fs::path& p) {
    std::vector<nlohmann::json> out;
    std::ifstream in(p);
    for (std::string l; std::getline(in, l);) {
      auto j = nlohmann::json::parse(l, nullptr, false);
      if (!j.is_discarded()) out.push_back(j);
    }
    return out;
  };
  const auto events = read_lines(dir / "events.jsonl");
  const auto reports = read_lines(dir / "robots.jsonl");
  // True positions per tick.
  std::vector<std::pair<int64_t, std::map<std::string, Vec2>>> ticks;
  std::vector<nlohmann::json> truth_events;
  for (const auto& j : read_lines(dir / "ground_truth.jsonl")) {
    if (j.value("type", "") == "event") truth_events.push_back(j);
    if (j.value("type", "") != "tick") continue;
    std::map<std::string, Vec2> at;
    for (const auto& e : j["entities"])
      if (e.value("kind", "") == "robot") at[e.value("id", "")] = {e.value("x", 0.0), e.value("y", 0.0)};
    ticks.push_back({j.value("t_ns", int64_t{0}), at});
  }
  auto positions_at = [&](int64_t t) {
    std::map<std::string, Vec2> best;
    for (const auto& [tt, at] : ticks) {
      if (tt > t) break;
      best = at;
    }
    return best;
  };
  nlohmann::ordered_json list = nlohmann::ordered_json::array();
  std::printf("response (%s)\n%-10s %-20s %-8s %9s %9s %9s %10s %10s %8s %8s\n", scenario_file.c_str(), "incident", "kind",
              "robot", "assign s", "arrive s", "travel s", "best s", "travel/best", "cost/best", "picture");
  for (const auto& ev : events) {
    if (ev.value("cancelled", false)) continue;
    const uint64_t id = ev.value("id", uint64_t{0});
    const int64_t t0 = ev.value("t_ns", int64_t{0});
    const Vec2 where{ev["map"][0].get<double>(), ev["map"][1].get<double>()};
    nlohmann::ordered_json r;
    r["incident"] = id;
    r["kind"] = ev.value("kind", "");
    const nlohmann::json* assigned = nullptr;
    const nlohmann::json* arrived = nullptr;
    for (const auto& rep : reports) {
      if (rep.value("task_id", uint64_t{0}) != id) continue;
      if (!assigned && rep.value("event", "") == "task_assigned") assigned = &rep;
      if (assigned && !arrived && rep.value("event", "") == "arrived_at_incident" && rep["robot"] == (*assigned)["robot"]) arrived = &rep;
    }
    if (!assigned) {
      r["assigned"] = false;
      list.push_back(r);
      std::printf("%-10llu %-20s %-8s   (not assigned)\n", static_cast<unsigned long long>(id), r["kind"].get<std::string>().c_str(), "-");
      continue;
    }
    const int64_t ta = (*assigned)["t_ns"].get<int64_t>();
    const std::string robot = (*assigned)["robot"];
    // Who was free (its latest report before the assignment not responding or guarding), and
    // its planned travel time from where it truly was.
    std::map<std::string, std::string> role;
    std::map<std::string, double> speed;
    for (const auto& rep : reports) {
      if (rep["t_ns"].get<int64_t>() >= ta) break;
      role[rep["robot"]] = rep.value("role", "");
      speed[rep["robot"]] = rep.value("cruise_speed", 0.0);
    }
    const auto at = positions_at(ta);
    double best = std::numeric_limits<double>::infinity(), chosen = std::numeric_limits<double>::infinity();
    for (const auto& [id_r, p] : at) {
      if (role.count(id_r) && (role[id_r] == "respond" || role[id_r] == "guard")) continue;
      const double v = speed.count(id_r) && speed[id_r] > 0 ? speed[id_r] : 1.0;
      const auto plan = (*planner)->plan(p, where, nullptr);
      if (!planning::has_path(plan.outcome)) continue;
      const double tt = plan.length / v;
      best = std::min(best, tt);
      if (id_r == robot) chosen = tt;
    }
    r["assigned"] = true;
    r["robot"] = robot;
    r["time_to_assignment_s"] = (ta - t0) * 1e-9;
    r["best_travel_s"] = std::isfinite(best) ? best : -1.0;
    r["chosen_cost_over_best"] = std::isfinite(best) && best > 0 ? chosen / best : -1.0;
    if (arrived) {
      const double travel = ((*arrived)["t_ns"].get<int64_t>() - ta) * 1e-9;
      r["arrived"] = true;
      r["travel_s"] = travel;
      r["travel_over_best"] = std::isfinite(best) && best > 0 ? travel / best : -1.0;
    } else {
      r["arrived"] = false;
    }
    // The picture: pictures/<incident>_<robot>.json; the event in view when its published
    // position and the nearest true event of its kind (ground truth) project into the image.
    const fs::path side = dir / "pictures" / (std::to_string(id) + "_" + robot + ".json");
    r["picture"] = false;
    if (fs::exists(side)) {
      std::ifstream in(side);
      auto pj = nlohmann::json::parse(in, nullptr, false);
      if (!pj.is_discarded() && pj.contains("camera") && pj.contains("image") && fs::exists(dir / "pictures" / pj["image"].get<std::string>())) {
        r["picture"] = true;
        r["picture_file"] = (fs::path("pictures") / pj["image"].get<std::string>()).string();
        const auto& c = pj["camera"];
        vision::CameraPose cp;
        cp.position = {c["position"][0].get<double>(), c["position"][1].get<double>(), c["position"][2].get<double>()};
        cp.yaw = c["yaw"].get<double>();
        cp.pitch = c["pitch"].get<double>();
        vision::Intrinsics k;
        k.width = c["width"].get<int>();
        k.height = c["height"].get<int>();
        k.fx = c["fx"].get<double>();
        k.fy = c["fy"].get<double>();
        k.cx = c["cx"].get<double>();
        k.cy = c["cy"].get<double>();
        const vision::StereoCameraModel cam(k, 0.09, cp);
        auto in_view = [&](Vec2 p) {
          Eigen::Vector2d px;
          return cam.project_map(Eigen::Vector3d(p.x, p.y, 0.3), &px) && px.x() >= 0 && px.y() >= 0 &&
                 px.x() < k.width && px.y() < k.height;
        };
        r["event_in_picture"] = in_view(where);
        // The true event of this kind nearest the published position.
        double bd = std::numeric_limits<double>::infinity();
        Vec2 truth;
        for (const auto& g : truth_events) {
          if (g.value("kind", "") != r["kind"].get<std::string>()) continue;
          const Vec2 gp{g.value("x", 0.0), g.value("y", 0.0)};
          if ((gp - where).norm() < bd) {
            bd = (gp - where).norm();
            truth = gp;
          }
        }
        if (std::isfinite(bd)) r["true_event_in_picture"] = in_view(truth);
        r["picture_entities"] = pj.value("entities", nlohmann::json::array());
      }
    }
    list.push_back(r);
    const char* pic = !r["picture"].get<bool>() ? "-" : r.value("event_in_picture", false) ? "in view" : "missed";
    std::printf("%-10llu %-20s %-8s %9.2f %9s %9s %9.1f %10s %8.2f %8s\n", static_cast<unsigned long long>(id),
                r["kind"].get<std::string>().c_str(), robot.c_str(), (ta - t0) * 1e-9,
                arrived ? std::to_string(((*arrived)["t_ns"].get<int64_t>() - t0) * 1e-9).substr(0, 6).c_str() : "-",
                arrived ? std::to_string(r["travel_s"].get<double>()).substr(0, 6).c_str() : "-", best,
                arrived ? std::to_string(r["travel_over_best"].get<double>()).substr(0, 5).c_str() : "-",
                r["chosen_cost_over_best"].get<double>(), pic);
  }
  (*eval)["response"] = list;
}

bool test_file_contains(const fs::path& p, const std::string& needle) {
  std::ifstream in(p);
  for (std::string l; std::getline(in, l);)
    if (l.find(needle) != std::string::npos) return true;
  return false;
}

// Patrol idleness of the run's robots on a patrol graph, from their true positions in the
// ground truth: eval.json "patrol", and a line. The reference is the graph's shortest closed
// walk over (robots x cruise speed), the speed from robots.jsonl (1 m/s without it).
void evaluate_run_patrol(const fs::path& gt_path, const fs::path& robots_path, const fs::path& graph_path,
                         double radius, nlohmann::ordered_json* eval) {
  auto graph = planning::patrol::PatrolGraph::read(graph_path);
  if (!graph) throw Exit{report(graph.error())};
  std::vector<Vec2> v;
  for (const auto& x : graph->vertices()) v.push_back(x.position);
  planning::patrol::VisitDetector det(v, radius);
  planning::patrol::InterferenceCounter interf(2.0);
  std::ifstream in(gt_path);
  std::string line;
  int lineno = 0;
  double end = 0;
  std::set<std::string> robots;
  while (std::getline(in, line)) {
    ++lineno;
    auto j = nlohmann::json::parse(line, nullptr, false);
    if (j.is_discarded()) throw Exit{report(bad_input(gt_path.string(), lineno, "", "not JSON"))};
    if (j.value("type", "") != "tick") continue;
    const double t = j.value("t_ns", int64_t{0}) * 1e-9;
    end = t;
    std::vector<std::pair<std::string, Vec2>> at;
    for (const auto& e : j["entities"]) {
      if (e.value("kind", "") != "robot") continue;
      const std::string id = e.value("id", "");
      const Vec2 p{e.value("x", 0.0), e.value("y", 0.0)};
      det.observe(id, t, p);
      at.push_back({id, p});
      robots.insert(id);
    }
    interf.observe(at);
  }
  double speed = 0;
  if (fs::exists(robots_path)) {
    std::ifstream rin(robots_path);
    while (std::getline(rin, line)) {
      auto j = nlohmann::json::parse(line, nullptr, false);
      if (!j.is_discarded()) speed = std::max(speed, j.value("cruise_speed", 0.0));
    }
  }
  if (speed <= 0) speed = 1.0;
  const auto st = planning::patrol::idleness(det.visits(), static_cast<int>(graph->size()), end);
  planning::patrol::GraphDistances d(*graph);
  const double tour = planning::patrol::closed_walk(*graph, d).length;
  const double ref = robots.empty() ? 0.0 : tour / (static_cast<double>(robots.size()) * speed);
  nlohmann::ordered_json p;
  p["graph"] = graph_path.string();
  p["vertices"] = graph->size();
  p["visit_radius_m"] = radius;
  p["robots"] = robots.size();
  p["tour_m"] = tour;
  p["reference_s"] = ref;
  p["average_s"] = st.average;
  p["worst_s"] = st.worst;
  p["stddev_s"] = st.stddev;
  p["median_s"] = st.median;
  p["intervals"] = st.intervals;
  p["visits"] = st.visits;
  p["unvisited"] = st.unvisited;
  p["longest_open_s"] = st.longest_open;
  p["interferences"] = interf.count();
  // Every visit as [t s, vertex, robot], for idleness over time (vigil report plots it).
  nlohmann::ordered_json log = nlohmann::ordered_json::array();
  for (const auto& vis : det.visits()) log.push_back({std::round(vis.t * 1000.0) / 1000.0, vis.vertex, vis.robot});
  p["visit_log"] = log;
  (*eval)["patrol"] = p;
  std::printf("patrol (%s, %zu vertices, %zu robots, visits within %.2f m): average idleness %.1f s, worst %.1f s, "
              "std %.1f s over %d intervals; reference %.1f s (walk %.1f m / %zu / %.2f m/s); %d unvisited; %d interferences\n",
              graph_path.filename().string().c_str(), graph->size(), robots.size(), radius, st.average, st.worst, st.stddev,
              st.intervals, ref, tour, robots.size(), speed, st.unvisited, interf.count());
}

// Localisation error, contacts and goals of the run's robots: eval.json "navigation", and a table.
void evaluate_run_navigation(const fs::path& gt_path, const fs::path& robots_path, nlohmann::ordered_json* eval) {
  auto r = evaluate_navigation(gt_path, robots_path);
  if (!r) throw Exit{report(r.error())};
  nlohmann::ordered_json nav;
  nav["robots_file"] = robots_path.filename().string();
  nav["duration_s"] = r->duration_s;
  nav["contacts_per_robot_hour"] = r->contacts_per_robot_hour;
  nav["contacts_with_people_or_objects"] = r->contacts_with_people_or_objects;
  nav["contacts_with_robots"] = r->contacts_with_robots;
  nav["contacts_with_walls"] = r->contacts_with_walls;
  nav["pushing_contacts"] = r->pushing_contacts;
  nav["pushing_contacts_per_robot_hour"] = r->pushing_contacts_per_robot_hour;
  nlohmann::ordered_json robots = nlohmann::ordered_json::array();
  std::printf("navigation (%s against %s, %.0f s)\n", robots_path.filename().string().c_str(),
              gt_path.filename().string().c_str(), r->duration_s);
  std::printf("%-10s %9s %9s %9s %9s %9s %6s %6s %6s %9s %9s %9s\n", "robot", "loc_at_s", "pos_rms", "pos_max",
              "yaw_rms", "yaw_max", "goals", "reach", "fail", "t/ideal", "t/ideal_max", "contacts");
  for (const auto& f : r->robots) {
    int touching = 0;
    nlohmann::ordered_json c = nlohmann::ordered_json::object();
    for (const auto& [kind, n] : f.contacts) {
      c[kind] = n;
      if (kind != "wall") touching += n;
    }
    robots.push_back({{"robot", f.robot},
                      {"reports", f.reports},
                      {"localized_reports", f.localized_reports},
                      {"first_localized_s", f.first_localized_s},
                      {"position_rms_m", f.position_rms},
                      {"position_worst_m", f.position_worst},
                      {"heading_rms_deg", f.heading_rms * 180 / std::numbers::pi},
                      {"heading_worst_deg", f.heading_worst * 180 / std::numbers::pi},
                      {"goals_started", f.goals_started},
                      {"goals_reached", f.goals_reached},
                      {"goals_failed", f.goals_failed},
                      {"failures", f.failures},
                      {"median_time_over_ideal", f.median_time_ratio},
                      {"worst_time_over_ideal", f.worst_time_ratio},
                      {"contacts", c},
                      {"pushing_contacts", f.pushing_contacts}});
    std::printf("%-10s %9.1f %9.3f %9.3f %9.2f %9.2f %6d %6d %6d %9.2f %9.2f %9d\n", f.robot.c_str(), f.first_localized_s,
                f.position_rms, f.position_worst, f.heading_rms * 180 / std::numbers::pi,
                f.heading_worst * 180 / std::numbers::pi, f.goals_started, f.goals_reached, f.goals_failed,
                f.median_time_ratio, f.worst_time_ratio, touching);
  }
  nav["robots"] = robots;
  std::printf("contacts per robot-hour (people, objects, robots): %.2f, of which the robot drove into: %.2f (%d); with walls: %d\n",
              r->contacts_per_robot_hour, r->pushing_contacts_per_robot_hour, r->pushing_contacts, r->contacts_with_walls);
  (*eval)["navigation"] = nav;
}

// Precision, recall, latency and localisation of the run's events against the ground truth's,
// per kind and in total: eval.json "events", and a table.
void evaluate_run_events(const fs::path& gt_path, const fs::path& events_path, nlohmann::ordered_json* eval) {
  auto truth = vision::load_truth_events(gt_path);
  if (!truth) throw Exit{report(truth.error())};
  auto reports = vision::read_events_jsonl(events_path.string());
  if (!reports) throw Exit{report(reports.error())};
  vision::EventEvalOptions eo;
  auto r = vision::evaluate_events(*truth, *reports, eo);
  if (!r) throw Exit{report(r.error())};
  const auto num = [](double v) { return std::isfinite(v) ? nlohmann::ordered_json(v) : nlohmann::ordered_json(nullptr); };
  const auto score_json = [&](const vision::EventScore& s) {
    nlohmann::ordered_json j;
    j["truth"] = s.truth;
    j["reported"] = s.reported;
    j["matched"] = s.matched;
    j["precision"] = s.precision;
    j["recall"] = s.recall;
    j["latency_s"] = num(s.latency_s);
    j["localisation_error_m"] = num(s.localisation_error_m);
    return j;
  };
  nlohmann::ordered_json ev = score_json(r->total);
  ev["events_file"] = events_path.filename().string();
  ev["match"] = {{"early_s", eo.early_s}, {"max_latency_s", eo.max_latency_s}, {"max_distance_m", eo.max_distance_m}};
  nlohmann::ordered_json kinds = nlohmann::ordered_json::object();
  for (const auto& [k, s] : r->per_kind) kinds[std::string(vision::to_string(k))] = score_json(s);
  ev["per_kind"] = kinds;
  nlohmann::ordered_json missed = nlohmann::ordered_json::array(), falses = nlohmann::ordered_json::array();
  for (size_t i : r->missed) {
    const auto& t = (*truth)[i];
    missed.push_back({{"kind", std::string(vision::to_string(t.kind))}, {"confirmed_ns", t.confirmed_ns}, {"object", t.object}});
  }
  for (size_t i : r->false_reports) {
    const auto& e = (*reports)[i];
    falses.push_back({{"kind", std::string(vision::to_string(e.kind))}, {"t_ns", e.stamp_ns}, {"camera", e.camera}, {"id", e.id}});
  }
  ev["missed"] = missed;
  ev["false_reports"] = falses;
  (*eval)["events"] = ev;

  const auto cell = [](double v) {
    char buf[32];
    if (std::isfinite(v)) std::snprintf(buf, sizeof buf, "%9.3f", v); else std::snprintf(buf, sizeof buf, "%9s", "-");
    return std::string(buf);
  };
  std::printf("events (%s against %s; a report matches within %.1f s before to %.1f s after the due time and %.2f m)\n",
              events_path.filename().string().c_str(), gt_path.filename().string().c_str(), eo.early_s, eo.max_latency_s,
              eo.max_distance_m);
  std::printf("%-20s%6s%9s%8s%10s%10s%10s%10s\n", "kind", "truth", "reported", "matched", "precision", "recall", "latency_s", "error_m");
  const auto row = [&](const std::string& name, const vision::EventScore& s) {
    std::printf("%-20s%6d%9d%8d %s %s %s %s\n", name.c_str(), s.truth, s.reported, s.matched, cell(s.precision).c_str(),
                cell(s.recall).c_str(), cell(s.latency_s).c_str(), cell(s.localisation_error_m).c_str());
  };
  for (const auto& [k, s] : r->per_kind) row(std::string(vision::to_string(k)), s);
  row("all", r->total);
}

void run_map_eval(const Opts& o) {
  if (o.run_dir.empty()) throw Exit{report(bad_input("", 0, "RUN_DIR", "give a run folder, or --mot-gt and --mot-test"))};
  const fs::path dir = o.run_dir;
  if (!fs::is_directory(dir)) throw Exit{report(bad_input(dir.string(), 0, "RUN_DIR", "not a folder"))};
  const fs::path gt_path = dir / "ground_truth.jsonl";
  const fs::path tracks_path = o.tracks.empty() ? dir / "tracks.jsonl" : fs::path(o.tracks);

  vision::MapTrackEvalOptions eo;
  eo.match_distance = o.match_distance;
  eo.camera = o.camera;
  eo.max_range = o.max_range;
  eo.exclude_carried = o.exclude_carried;
  for (const std::string& c : o.classes) {
    const auto cls = vision::parse_track_class(c);
    if (!cls) throw Exit{report(bad_input("", 0, "--classes", "unknown class '" + c + "' (known: person, bag, robot, unknown)"))};
    eo.classes.push_back(*cls);
  }
  if (!o.camera_xy.empty()) {
    if (o.camera_xy.size() != 2) throw Exit{report(bad_input("", 0, "--camera-xy", "expected X,Y"))};
    eo.camera_x = o.camera_xy[0];
    eo.camera_y = o.camera_xy[1];
  }
  if (o.camera_rate) {
    if (!(*o.camera_rate > 0)) throw Exit{report(bad_input("", 0, "--camera-rate", "must be positive"))};
    eo.camera_period_s = 1.0 / *o.camera_rate;
  }
  // The patrol graph: --graph, or the first team robot's in the scenario.
  fs::path patrol_graph = o.graph;
  if (patrol_graph.empty() && !o.scenario.empty()) {
    ScenarioContext ctx;
    auto sc = load_scenario(o.scenario, ctx);
    if (!sc) throw Exit{report(sc.error())};
    for (const RobotSpec& r : sc->robots) {
      auto it = r.params.find("graph");
      if (r.controller == "team" && it != r.params.end() && std::holds_alternative<std::string>(it->second.value)) {
        patrol_graph = std::get<std::string>(it->second.value);
        if (patrol_graph.is_relative()) patrol_graph = fs::path(o.scenario).parent_path() / patrol_graph;
        break;
      }
    }
  }
  // The camera's position (and rate) from the scenario.
  if (!o.scenario.empty() && (!o.camera.empty() || o.in_view || o.max_range)) {
    if (o.camera.empty()) throw Exit{report(bad_input("", 0, "--scenario", "needs --camera ID to pick the camera"))};
    ScenarioContext ctx;  // plugin names are not checked: only the camera's pose is needed
    auto sc = load_scenario(o.scenario, ctx);
    if (!sc) throw Exit{report(sc.error())};
    auto found = find_camera(*sc, o.camera, "--camera");
    if (!found) throw Exit{report(found.error())};
    const CameraSpec* cam = *found;
    if (o.camera_xy.empty()) {
      eo.camera_x = cam->position.x;
      eo.camera_y = cam->position.y;
    }
    if (!o.camera_rate) eo.camera_period_s = 1.0 / cam->rate_hz;
    if (o.in_view) {
      const double hfov = cam->fx ? 2 * std::atan(0.5 * cam->width / *cam->fx) : cam->hfov.value_or(60 * std::numbers::pi / 180);
      eo.half_fov = 0.5 * hfov;
      eo.camera_yaw = cam->yaw;
      // Not behind a wall: the map as the camera sees it (furniture lower than it seen over).
      WorldOptions wo;
      wo.plugins = builtin_plugin_registry();
      wo.controllers = false;
      auto world = World::create(*sc, wo);
      if (!world) throw Exit{report(world.error())};
      auto sight = std::make_shared<OccupancyGrid>(sight_map(**world, cam->position.z));
      auto walls = std::make_shared<WallRaycaster>(*sight);
      const Vec2 c{cam->position.x, cam->position.y};
      eo.truth_visible = [sight, walls, c](double x, double y) {
        const double range = std::hypot(x - c.x, y - c.y);
        if (range < 1e-6) return true;
        return walls->raycast_dir(c, {(x - c.x) / range, (y - c.y) / range}, range) >= range - 0.05;
      };
    }
  }
  if (o.in_view && o.scenario.empty())
    throw Exit{report(bad_input("", 0, "--in-view", "needs the camera from a scenario: --scenario FILE --camera ID"))};
  if (o.max_range && o.camera_xy.empty() && o.scenario.empty())
    throw Exit{report(bad_input("", 0, "--max-range", "needs the camera position: --camera-xy X,Y or --scenario FILE --camera ID"))};

  const bool have_tracks = !o.tracks.empty() || fs::exists(tracks_path);
  const fs::path events_path = dir / "events.jsonl";
  const bool have_events = fs::exists(events_path);
  const fs::path robots_path = dir / "robots.jsonl";
  const bool have_robots = fs::exists(robots_path);
  if (!have_tracks && !have_events && !have_robots)
    throw Exit{report(bad_input(tracks_path.string(), 0, "",
                                "missing, and no events.jsonl or robots.jsonl beside it: the run had no vision sensor "
                                "(a camera's plugin:) and no robot controller"))};
  const fs::path eval_path = dir / "eval.json";
  auto eval = read_eval_json(eval_path);
  if (!eval) throw Exit{report(eval.error())};
  if (have_tracks) {
    auto gt = vision::load_ground_truth_ticks(gt_path);
    if (!gt) throw Exit{report(gt.error())};
    if (gt->empty()) throw Exit{report(bad_input(gt_path.string(), 0, "", "no tick lines"))};
    auto tracks = vision::load_tracks_jsonl(tracks_path);
    if (!tracks) throw Exit{report(tracks.error())};
    auto r = vision::evaluate_map_tracks(*gt, *tracks, eo);
    if (!r) {
      Error e = r.error();
      if (e.key == "camera" || e.key == "tracks") {
        e.file = tracks_path.string();
      } else if (e.key == "match_distance") {
        e.key = "--match-distance";
      } else if (e.key == "max_range") {
        e.key = "--max-range";
      } else if (e.key == "camera_period") {
        e.key = "--camera-rate";
      }
      throw Exit{report(e)};
    }

    nlohmann::ordered_json t;
    t["ground_truth_file"] = gt_path.filename().string();
    t["tracks_file"] = o.tracks.empty() ? tracks_path.filename().string() : tracks_path.string();
    t["camera"] = o.camera.empty() ? nlohmann::ordered_json(nullptr) : nlohmann::ordered_json(o.camera);
    t["cameras"] = r->cameras;
    t["match_distance_m"] = eo.match_distance;
    t["max_range_m"] = eo.max_range ? nlohmann::ordered_json(*eo.max_range) : nlohmann::ordered_json(nullptr);
    t["in_view"] = eo.half_fov.has_value();
    t["camera_period_s"] = r->camera_period_s;
    t["frames"] = r->frames;
    t["frames_without_tracks"] = r->frames_without_tracks;
    t["skipped_track_stamps"] = r->skipped_track_stamps;
    const nlohmann::ordered_json overall = tracking_json(r->overall);
    for (const auto& item : overall.items()) t[item.key()] = item.value();
    nlohmann::ordered_json per_class = nlohmann::ordered_json::object();
    for (const auto& [cls, m] : r->per_class) per_class[std::string(vision::to_string(cls))] = tracking_json(m);
    t["per_class"] = per_class;
    (*eval)["tracking"] = t;
    char head[256];
    std::snprintf(head, sizeof head, "%lld frames (%.2f Hz), match within %.2f m", static_cast<long long>(r->frames),
                  r->camera_period_s > 0 ? 1.0 / r->camera_period_s : 0.0, eo.match_distance);
    std::string line = "vigil eval " + dir.string() + ": " + head + ", " + (o.camera.empty() ? "all cameras" : "camera " + o.camera);
    if (eo.max_range) {
      char range[96];
      std::snprintf(range, sizeof range, ", ground truth within %.2f m of (%.2f, %.2f)", *eo.max_range, eo.camera_x, eo.camera_y);
      line += range;
    }
    if (eo.half_fov) {
      char fov[96];
      std::snprintf(fov, sizeof fov, ", in a %.1f deg field of view", 2 * *eo.half_fov * 180 / std::numbers::pi);
      line += fov;
    }
    std::printf("%s\n", line.c_str());
    std::printf("%-8s%8s%8s%8s%8s%8s%8s%8s %6s %4s %4s %4s %6s %6s %5s %5s\n", "class", "MOTA", "MOTP(m)", "IDF1", "IDP", "IDR",
                "Rcll", "Prcn", "GT", "MT", "PT", "ML", "FP", "FN", "IDSW", "Frag");
    print_row("all", r->overall);
    for (const auto& [cls, m] : r->per_class) print_row(std::string(vision::to_string(cls)), m);
}
  if (have_events) evaluate_run_events(gt_path, events_path, &*eval);
  if (have_robots) evaluate_run_navigation(gt_path, robots_path, &*eval);
  if (!patrol_graph.empty()) evaluate_run_patrol(gt_path, robots_path, patrol_graph, o.visit_radius, &*eval);
  if (have_events && have_robots && !o.scenario.empty() &&
      test_file_contains(robots_path, "\"task_assigned\"")) {
    evaluate_run_response(dir, o.scenario, &*eval);
  }
  if (Status s = write_text_file(eval_path, eval->dump(2) + "\n"); !s) throw Exit{report(s.error())};
  std::printf("wrote %s\n", eval_path.string().c_str());
}

}  // namespace

void add_eval_command(CLI::App& app) {
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand("eval", "Tracking metrics (CLEAR MOT, IDF1) of a run's tracks, or of MOTChallenge files");
  cmd->add_option("run_dir", o->run_dir, "run folder with ground_truth.jsonl and tracks.jsonl (writes eval.json there)");
  cmd->add_option("--match-distance", o->match_distance, "a track matches a ground-truth entity within this many metres")
      ->capture_default_str();
  cmd->add_option("--camera", o->camera, "evaluate only this camera's tracks");
  cmd->add_option("--max-range", o->max_range, "only ground truth and tracks within this many metres of the camera");
  cmd->add_option("--camera-xy", o->camera_xy, "camera position X,Y in the map frame (for --max-range)")->delimiter(',');
  cmd->add_option("--scenario", o->scenario, "scenario file to read the --camera's position and rate from (and the team robots' patrol graph)");
  cmd->add_option("--graph", o->graph, "patrol graph to measure idleness on (default: the --scenario team robots' graph)");
  cmd->add_option("--visit-radius", o->visit_radius, "patrol: a vertex is visited within this distance (m)")->capture_default_str();
  cmd->add_option("--camera-rate", o->camera_rate, "camera frame rate in Hz (default: from --scenario, else from the track stamps)");
  cmd->add_option("--classes", o->classes, "only these classes (person, bag, robot, unknown)")->delimiter(',');
  cmd->add_flag("--in-view", o->in_view, "only ground truth and tracks inside the --scenario camera's horizontal field of view, and ground truth not behind a wall of its map");
  cmd->add_flag("--exclude-carried", o->exclude_carried, "leave out objects while a person carries them");
  cmd->add_option("--tracks", o->tracks, "tracks file (default RUN_DIR/tracks.jsonl)");
  cmd->add_option("--mot-gt", o->mot_gt, "MOTChallenge ground truth (frame,id,x,y,w,h,conf,...)");
  cmd->add_option("--mot-test", o->mot_test, "MOTChallenge tracker output to evaluate against --mot-gt");
  cmd->add_option("--iou-threshold", o->iou_threshold, "MOTChallenge: a pair matches when 1 - IoU <= this")->capture_default_str();
  cmd->add_option("--gt-min-confidence", o->gt_min_confidence, "MOTChallenge: ground-truth rows with a lower conf are ignored")
      ->capture_default_str();
  cmd->callback([o] {
    if (!o->mot_gt.empty() || !o->mot_test.empty()) {
      run_mot_challenge(*o);
    } else {
      run_map_eval(*o);
    }
  });
}

}  // namespace vigil::cli
