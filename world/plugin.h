// Player/Stage-style plugins. A plugin is attached to one model of the scenario (a robot's
// controller, a camera's vision sensor model), configured from the scenario's parameters, reset
// at the start of a run, and updated every simulation step with read access to the world and a
// command channel to its own model. Plugins are shared libraries exporting one entry point,
// `vigil_plugin_entry`, loaded by name from a search path; built-in ones are also reachable from
// a static registry.
#pragma once

#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "common/geometry.h"
#include "common/laser_scan.h"
#include "world/map.h"
#include "world/params.h"
#include "world/status.h"

namespace vigil {

// Bumped whenever the Plugin interface changes; a library built for another version is refused.
constexpr int kPluginAbiVersion = 4;

// What a robot's controller may read of its own robot: its sensors, never the ground truth
// (the true pose is the world's, for scoring only).
struct RobotState {
  std::string id;
  Pose2 odometry;    // odometric pose estimate, starting at the start pose
  double v = 0, w = 0;  // current linear and angular velocity (wheel encoders)
  const LaserScan* scan = nullptr;  // latest scan, null when the robot has no ranger
};

// A task for a robot's controller, put in its inbox by whoever owns the transport (the DDS
// bridge, the team coordinator, a test). Controllers that do not understand a kind report it
// as rejected.
struct RobotTask {
  uint64_t id = 0;
  std::string kind;              // "goto" (drive to goal), "patrol" (waypoints), "cancel", "stop"
  Vec2 goal;                     // goto
  std::vector<Vec2> waypoints;   // patrol
  bool loop = false;             // patrol
  std::string label;             // free text carried back in reports (e.g. an incident id)
};

// What a robot's controller says about itself, taken from its outbox by the transport and the
// run log: its pose estimate (localised, not the truth), its mode and what happened to tasks.
struct RobotReport {
  SimTime stamp = 0;
  std::string robot;
  Pose2 pose;                    // the controller's estimate in the map frame
  double position_std = 0, yaw_std = 0;  // its uncertainty (m, rad)
  bool localized = false;        // the estimate has converged
  std::string mode;              // e.g. idle, driving, avoiding, waiting, recovering, arrived, failed
  std::string role;              // a team robot's role: patrol, respond, guard ("" for others)
  uint64_t task_id = 0;          // the task being worked on (0: none)
  std::string event;             // "" (state only), or goal_started, goal_reached, goal_failed, task_rejected
  std::string detail;            // why, for failures
  Vec2 goal;                     // the current goal
  double path_length = 0;        // planned length from where the goal was given (m)
  double cruise_speed = 0;       // the speed it drives at (m/s), for time-to-goal figures
  // What is left of the planned path, from the robot on (at most 64 points), for views such as
  // the top-down video and the report (robots.jsonl's "path", to the centimetre).
  std::vector<Vec2> path;
};

// A message between robots' controllers (patrol visits, task tokens, team state). The transport
// carries it: inside `vigil run` the run's team bus (world/team_bus.h), between processes DDS.
// Controllers never see which. Fields are generic so one type serves every protocol; each kind
// documents what it uses (plugins/team/).
struct TeamMessage {
  std::string kind;              // e.g. "visit", "hello", "token", "bid", "award"
  std::string from;              // the sender (filled in by the world)
  std::string to;                // one robot, or "" for every other robot
  SimTime sent = 0;              // when it was sent (filled in by the world)
  uint64_t task = 0;             // a task or incident id
  int64_t seq = 0;               // a sequence or round number
  int vertex = -1, next_vertex = -1;
  double value = 0, value2 = 0;  // e.g. a time, a cost, a utility
  Vec2 position;
  std::string text;
};

// Read-only access to the world, as plugins see it.
class WorldView {
 public:
  virtual ~WorldView() = default;
  virtual SimTime time() const = 0;
  virtual SimTime step_length() const = 0;  // fixed physics step
  virtual const OccupancyGrid& map() const = 0;
  virtual std::optional<Vec2> place(const std::string& name) const = 0;
  virtual const RobotState* robot(const std::string& id) const = 0;
};

// The command channel to the plugin's own model.
class ModelCommand {
 public:
  virtual ~ModelCommand() = default;
  // Velocity command for a differential-drive robot (clamped to its limits).
  virtual void set_velocity(double v, double w) = 0;
  // Takes the tasks waiting in the robot's inbox, oldest first.
  virtual std::vector<RobotTask> take_tasks() = 0;
  // Puts a report in the robot's outbox; the latest is also the robot's published state.
  virtual void report(const RobotReport& r) = 0;
  // Sends a message to other robots' controllers (delivered from the next step on).
  virtual void send(const TeamMessage& m) = 0;
  // Takes the messages delivered to this robot, oldest first.
  virtual std::vector<TeamMessage> take_messages() = 0;
};

// What a plugin learns about its model when configured.
struct PluginContext {
  std::string model_id;
  std::string scenario_file;
  int line = 0;                                 // where the model is declared
  const OccupancyGrid* map = nullptr;
  const std::map<std::string, Vec2>* places = nullptr;
  uint64_t seed = 0;                            // this plugin's own seed, derived from the run's
  // The robot's body, for controllers: where its laser sits, how big and fast it is.
  Pose2 laser_mount;                            // laser pose in the robot frame
  double robot_radius = 0;                      // disc covering the footprint (m)
  // Half the footprint's width across its direction of travel, from the base frame's x axis
  // (m): what a robot driving straight sweeps to either side. 0: use robot_radius.
  double body_half_width = 0;
  double max_speed = 0, max_turn_rate = 0;      // m/s, rad/s
  Pose2 start;                                  // where the robot is placed (the scenario's)
  bool start_known = true;                      // false: the controller must localise globally
  double laser_range_max = 0;
  std::filesystem::path cache_dir;              // where planners may cache (roadmaps); "" = none
};

class Plugin {
 public:
  virtual ~Plugin() = default;
  // The parameters this plugin accepts, with defaults and ranges.
  virtual std::vector<ParamSpec> params() const = 0;
  // Takes checked parameters; errors (e.g. a waypoint place that does not exist) name the key.
  virtual Status configure(const ParamSet& params, const PluginContext& ctx) = 0;
  // Back to the state just after configure.
  virtual void reset() = 0;
  // Called once per simulation step.
  virtual void update(const WorldView& world, ModelCommand& cmd) = 0;
};

using PluginFactory = std::unique_ptr<Plugin> (*)();

// What a plugin library's `vigil_plugin_entry` returns.
struct PluginEntry {
  int abi_version;
  const char* name;
  Plugin* (*create)();  // caller owns the result
};
extern "C" {
using PluginEntryFn = const PluginEntry* (*)();
}

// Finds plugins by name: the static registry first, then `lib<name>.so` or
// `libvigil_plugin_<name>.so` in each search directory.
class PluginRegistry {
 public:
  PluginRegistry() = default;  // empty: plugins/builtin.h adds the built-ins
  ~PluginRegistry();
  PluginRegistry(const PluginRegistry&) = delete;
  PluginRegistry& operator=(const PluginRegistry&) = delete;

  void add_builtin(const std::string& name, std::function<std::unique_ptr<Plugin>()> factory);
  void add_search_dir(const std::filesystem::path& dir);
  // Only the shared-library search, skipping the static registry (used by tests).
  void set_prefer_shared(bool prefer) { prefer_shared_ = prefer; }

  bool exists(const std::string& name) const;
  Result<std::unique_ptr<Plugin>> create(const std::string& name);
  // Where the last created plugin of that name came from: "builtin" or the .so path.
  std::string origin(const std::string& name) const;
  std::vector<std::string> builtin_names() const;

 private:
  std::optional<std::filesystem::path> find_library(const std::string& name) const;
  std::map<std::string, std::function<std::unique_ptr<Plugin>()>> builtins_;
  std::vector<std::filesystem::path> search_dirs_;
  std::map<std::string, void*> handles_;  // dlopen handles, closed at destruction
  std::map<std::string, std::string> origins_;
  bool prefer_shared_ = false;
};

}  // namespace vigil
