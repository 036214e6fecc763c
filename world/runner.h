// Runs a scenario headless from start to end: steps the world, records ground truth at the
// scenario's record rate, draws the top-down video, and writes ground_truth.jsonl, robots.jsonl
// (what the robots' controllers reported), topdown.mp4 (or .avi), topdown.png and summary.json into the
// output folder.
#pragma once

#include "world/video_writer.h"

#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "world/scenario.h"
#include "world/status.h"
#include "world/team_bus.h"
#include "world/world.h"

namespace vigil {

// Something that watches a run (a camera writing its video, a vision pipeline, a robot's
// camera): called once at the start, for every report a robot's controller made, after every
// step, and once at the end, with the world as it is then.
class RunObserver {
 public:
  virtual ~RunObserver() = default;
  virtual Status start(const World& world, const std::filesystem::path& out_dir) { return Status::Ok(); }
  virtual Status on_report(const World& world, const RobotReport& report) { return Status::Ok(); }
  virtual Status after_step(const World& world) = 0;
  virtual Status finish(const World& world) { return Status::Ok(); }
};

struct RunOptions {
  std::filesystem::path out_dir;       // empty: write nothing (hash only)
  std::optional<uint64_t> seed;        // overrides the scenario's
  std::optional<double> duration;      // s, overrides the scenario's
  bool video = true;                   // topdown.mp4 (or .avi) and topdown.png
  VideoFormat video_format = VideoFormat::kMp4;  // of topdown.* (world/video_writer.h)
  bool scans = true;                   // scans.jsonl: every laser scan (at most 20 robots with a laser)
  WorldOptions world;
  // Called about every `progress_interval_s` of wall time with (sim s, total sim s, wall s).
  std::function<void(double, double, double)> progress;
  double progress_interval_s = 0.5;
  std::vector<RunObserver*> observers;  // not owned
  // The transport's hooks: called before every step (to post tasks into robots' inboxes) and
  // for every report the controllers made (also written to robots.jsonl).
  std::function<void(World&)> before_step;
  std::function<void(const RobotReport&)> on_report;
  // Carries the controllers' team messages after every step. Empty: a LocalTeamBus with
  // `team_bus` options (world/team_bus.h).
  std::function<Status(World&)> exchange_messages;
  TeamBusOptions team_bus;
};

// One line of robots.jsonl: a controller's report (its estimate, mode and task events).
std::string robot_report_json(const RobotReport& r);

struct RunSummary {
  std::string scenario;
  std::string scenario_file;  // absolute (vigil report draws the run's map from it)
  double sim_seconds = 0, wall_seconds = 0, real_time_factor = 0;
  uint64_t steps = 0;
  uint64_t seed = 0;
  std::string ground_truth_sha256;
  uint64_t ground_truth_lines = 0;
  size_t robots = 0, people = 0, objects = 0, cameras = 0, events = 0;
  // summary.json's text (stable key order, two-space indent).
  std::string to_json() const;
};

Result<RunSummary> run_scenario(Scenario scenario, const RunOptions& options);

}  // namespace vigil
