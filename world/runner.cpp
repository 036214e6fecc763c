#include "world/runner.h"

#include "world/video_writer.h"

#include <chrono>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "world/ground_truth.h"
#include "world/topdown.h"

namespace vigil {

std::string robot_report_json(const RobotReport& r) {
  auto r4 = [](double v) { return std::isfinite(v) ? std::round(v * 1e4) / 1e4 + 0.0 : 0.0; };
  nlohmann::ordered_json j;
  j["t_ns"] = r.stamp;
  j["robot"] = r.robot;
  j["x"] = r4(r.pose.x);
  j["y"] = r4(r.pose.y);
  j["yaw"] = r4(r.pose.yaw);
  j["position_std"] = r4(r.position_std);
  j["yaw_std"] = r4(r.yaw_std);
  j["localized"] = r.localized;
  j["mode"] = r.mode;
  if (!r.role.empty()) j["role"] = r.role;
  j["task_id"] = r.task_id;
  if (!r.event.empty()) j["event"] = r.event;
  if (!r.detail.empty()) j["detail"] = r.detail;
  j["goal_x"] = r4(r.goal.x);
  j["goal_y"] = r4(r.goal.y);
  j["path_length"] = r4(r.path_length);
  j["cruise_speed"] = r4(r.cruise_speed);
  // What is left of the planned path, to the centimetre.
  if (!r.path.empty()) {
    auto r2 = [](double v) { return std::isfinite(v) ? std::round(v * 1e2) / 1e2 + 0.0 : 0.0; };
    nlohmann::ordered_json path = nlohmann::ordered_json::array();
    for (const Vec2& p : r.path) path.push_back({r2(p.x), r2(p.y)});
    j["path"] = path;
  }
  return j.dump();
}

namespace {

// After every step, one line per robot whose scan was taken in it: the laser's pose in the map
// frame then (the true one, where the rays were cast from), the scan's angles and its ranges (mm).
void write_scans(const World& world, std::vector<SimTime>* written, std::ostream& out) {
  std::string line;
  char buf[96];
  for (size_t i = 0; i < world.robots().size(); ++i) {
    const auto& r = world.robots()[i];
    if (!r.spec.ranger.enabled || r.scan.ranges.empty() || r.scan.stamp == (*written)[i]) continue;
    (*written)[i] = r.scan.stamp;
    const Pose2 lp = r.laser_pose();
    line.clear();
    std::snprintf(buf, sizeof buf, "{\"t_ns\":%lld,\"robot\":\"", static_cast<long long>(r.scan.stamp));
    line += buf;
    line += r.spec.id;
    std::snprintf(buf, sizeof buf, "\",\"laser\":[%.4f,%.4f,%.4f],\"angle_min\":%.6f,\"angle_increment\":%.6f,", lp.x, lp.y,
                  lp.yaw, r.scan.angle_min, r.scan.angle_increment);
    line += buf;
    std::snprintf(buf, sizeof buf, "\"range_min\":%.3f,\"range_max\":%.3f,\"ranges\":[", r.scan.range_min, r.scan.range_max);
    line += buf;
    for (size_t k = 0; k < r.scan.ranges.size(); ++k) {
      std::snprintf(buf, sizeof buf, k ? ",%.3f" : "%.3f", std::isfinite(r.scan.ranges[k]) ? r.scan.ranges[k] : r.scan.range_max);
      line += buf;
    }
    line += "]}\n";
    out << line;
  }
}

}  // namespace

std::string RunSummary::to_json() const {
  nlohmann::ordered_json j;
  j["scenario"] = scenario;
  if (!scenario_file.empty()) j["scenario_file"] = scenario_file;
  j["sim_seconds"] = sim_seconds;
  j["wall_seconds"] = wall_seconds;
  j["real_time_factor"] = real_time_factor;
  j["steps"] = steps;
  j["seed"] = seed;
  j["ground_truth_sha256"] = ground_truth_sha256;
  j["ground_truth_lines"] = ground_truth_lines;
  j["robots"] = robots;
  j["people"] = people;
  j["objects"] = objects;
  j["cameras"] = cameras;
  j["events"] = events;
  return j.dump(2) + "\n";
}

Result<RunSummary> run_scenario(Scenario scenario, const RunOptions& options) {
  if (options.seed) scenario.seed = *options.seed;
  if (options.duration) {
    if (!(*options.duration > 0)) return bad_input("", 0, "--duration", "must be positive");
    scenario.duration = *options.duration;
  }
  auto created = World::create(scenario, options.world);
  if (!created) return created.error();
  World& world = **created;

  const auto& out = options.out_dir;
  if (!out.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(out, ec);
    if (ec) return bad_input(out.string(), 0, "--out", "cannot create folder: " + ec.message());
  }
  GroundTruthLog log;
  if (Status s = log.open(out.empty() ? std::filesystem::path() : out / "ground_truth.jsonl"); !s) return s.error();

  std::ofstream robots_log;
  bool any_controller = false;
  for (const auto& r : world.robots()) any_controller = any_controller || r.controller;
  if (!out.empty() && any_controller) {
    robots_log.open(out / "robots.jsonl", std::ios::trunc);
    if (!robots_log) return internal_error("cannot write " + (out / "robots.jsonl").string());
  }
  // scans.jsonl: every laser scan of every robot, as it is taken.
  std::ofstream scans_log;
  std::vector<SimTime> scan_written(world.robots().size(), -1);
  // Not for more than kMaxScanRobots robots with a laser: 100 of them would write 1.5 MB/s.
  constexpr int kMaxScanRobots = 20;
  int rangers = 0;
  for (const auto& r : world.robots()) rangers += r.spec.ranger.enabled ? 1 : 0;
  if (!out.empty() && options.scans && rangers > 0 && rangers <= kMaxScanRobots) {
    scans_log.open(out / "scans.jsonl", std::ios::trunc);
    if (!scans_log) return internal_error("cannot write " + (out / "scans.jsonl").string());
  }
  std::unique_ptr<TopdownRenderer> topdown;
  VideoFile video;
  if (options.video && !out.empty()) {
    topdown = std::make_unique<TopdownRenderer>(world);
    const auto path = out / (std::string("topdown") + video_extension(options.video_format));
    if (!video.open(path, scenario.record_rate_hz, topdown->size(), options.video_format)) {
      return internal_error("cannot write " + path.string() + ": " + video.why());
    }
  }

  for (RunObserver* obs : options.observers) {
    if (Status s = obs->start(world, out); !s) return s.error();
  }
  const SimTime record_every = std::max<SimTime>(world.step_length(), from_seconds(1.0 / scenario.record_rate_hz));
  SimTime next_record = 0;
  // Scripted radio failures: the robot's team messages lost both ways from their time.
  TeamBusOptions bus_options = options.team_bus;
  for (const FaultSpec& f : scenario.faults) {
    if (f.kind == "silent") bus_options.silences.push_back({f.robot, f.at, 1e300});
  }
  LocalTeamBus bus(bus_options);
  const auto t0 = std::chrono::steady_clock::now();
  auto wall = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); };
  double next_progress = options.progress_interval_s;
  const double total = to_seconds(world.end_time());
  cv::Mat last_frame;
  while (true) {
    if (world.time() >= next_record) {
      log.write_tick(world);
      if (topdown) {
        last_frame = topdown->draw(world);
        video.write(last_frame);
      }
      next_record += record_every;
    }
    if (world.finished()) break;
    if (options.before_step) options.before_step(world);
    if (Status s = world.advance(); !s) return s.error();
    if (scans_log) write_scans(world, &scan_written, scans_log);
    if (options.exchange_messages) {
      if (Status s = options.exchange_messages(world); !s) return s.error();
    } else {
      bus.exchange(world);
    }
    for (const RobotReport& rep : world.drain_reports()) {
      if (robots_log) robots_log << robot_report_json(rep) << "\n";
      if (options.on_report) options.on_report(rep);
      for (RunObserver* obs : options.observers) {
        if (Status st = obs->on_report(world, rep); !st) return st.error();
      }
    }
    for (RunObserver* obs : options.observers) {
      if (Status s = obs->after_step(world); !s) return s.error();
    }
    if (options.progress && wall() >= next_progress) {
      options.progress(to_seconds(world.time()), total, wall());
      next_progress = wall() + options.progress_interval_s;
    }
  }
  for (RunObserver* obs : options.observers) {
    if (Status s = obs->finish(world); !s) return s.error();
  }
  log.write_timeline(world);
  if (Status s = log.close(); !s) return s.error();
  if (topdown) {
    video.release();
    cv::imwrite((out / "topdown.png").string(), topdown->draw(world));
  }

  RunSummary sum;
  sum.scenario = scenario.name;
  if (!scenario.file.empty()) {
    std::error_code ec;
    const auto abs = std::filesystem::absolute(scenario.file, ec);
    sum.scenario_file = (ec ? scenario.file : abs.lexically_normal()).string();
  }
  sum.sim_seconds = to_seconds(world.time());
  sum.wall_seconds = wall();
  sum.real_time_factor = sum.wall_seconds > 0 ? sum.sim_seconds / sum.wall_seconds : 0;
  sum.steps = world.steps();
  sum.seed = scenario.seed;
  sum.ground_truth_sha256 = log.sha256();
  sum.ground_truth_lines = log.lines();
  sum.robots = world.robots().size();
  sum.people = world.people().size();
  sum.objects = world.objects().size();
  sum.cameras = scenario.cameras.size();
  sum.events = world.events().size();
  if (options.progress) options.progress(sum.sim_seconds, total, sum.wall_seconds);
  if (!out.empty()) {
    std::ofstream f(out / "summary.json");
    f << sum.to_json();
    if (!f) return internal_error("cannot write " + (out / "summary.json").string());
  }
  return sum;
}

}  // namespace vigil
