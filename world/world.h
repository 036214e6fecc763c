// The simulated world: a Box2D world with the map's walls as static bodies, differential-drive
// robots driven by controller plugins, people moved by their scripts (along grid paths, never
// through walls, keeping apart from each other), and objects that stand on the floor or on
// furniture or are carried. A fixed-step loop in integer nanoseconds; every random draw comes
// from the run's seed. The world also derives the ground-truth event timeline (left bag, bag
// taken, exchange, unauthorised object) from what the scripts make people do.
#pragma once

#include <deque>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "world/floorplan.h"
#include "common/geometry.h"
#include "world/map.h"
#include "planning/grid/grid_astar.h"
#include "world/plugin.h"
#include "world/ranger.h"
#include "common/rng.h"
#include "world/robot_model.h"
#include "world/scenario.h"
#include "world/status.h"

class b2World;
class b2Body;

namespace vigil {

enum class EntityKind { kRobot, kPerson, kObject };
const char* to_string(EntityKind k);

struct RobotEntity {
  RobotSpec spec;
  RobotModel model;
  b2Body* body = nullptr;
  Pose2 pose;            // true pose (ground truth, for scoring and rendering; never for controllers)
  RobotState state;      // what the controller reads
  LaserScan scan;
  SimTime next_scan = 0;
  double cmd_v = 0, cmd_w = 0;
  double odom_bias_x = 0, odom_bias_y = 0, odom_bias_yaw = 0;
  Rng rng;
  std::unique_ptr<Plugin> controller;
  std::deque<RobotTask> inbox;        // tasks for the controller, oldest first
  std::vector<RobotReport> outbox;    // reports not yet drained
  std::optional<RobotReport> last_report;  // the latest: the robot's published state
  std::vector<TeamMessage> sent;      // team messages not yet taken by the transport
  std::deque<TeamMessage> received;   // delivered, not yet taken by the controller
  Pose2 laser_pose() const;  // the laser's pose in the map frame
};

// A robot touching something, as the ground truth records it: from the first step the bodies
// touch to the last (`end` is the last step's time while still touching at the end of a run).
struct ContactRecord {
  std::string robot;
  std::string other;       // entity id, or "wall"
  std::string other_kind;  // person, object, robot, wall
  SimTime start = 0, end = 0;
  Vec2 where;              // robot's position when it began
  double robot_speed = 0;  // the forward speed its controller commanded when it began (m/s, signed)
  // The robot drove into it: commanded to move (> 0.05 m/s) towards it (the other's centre on
  // the side the robot moves to). Otherwise the other came to a standing or retreating robot.
  bool robot_pushing = false;
};

struct PersonEntity {
  PersonSpec spec;
  b2Body* body = nullptr;
  bool present = false;  // in the world now
  bool gone = false;     // has left
  Pose2 pose;
  Vec2 velocity;
  double walked = 0;     // metres walked (drives the renderer's gait)
  size_t step_index = 0; // current script step
  enum class Phase { kStart, kWalking, kActing, kDone } phase = Phase::kStart;
  bool approaching = false;  // walking to reach an object or drop point before acting
  // Held off the last point of a walk (by the repulsion of a thing beside it) without progress
  // for a stuck window while close to it: counts as arrived (otherwise the walk never ends).
  bool stalled_at_goal = false;
  std::vector<Vec2> path;
  size_t path_index = 0;
  SimTime phase_end = 0;
  double hand_seconds = 0;  // how long the pending hand action takes once within reach
  Vec2 reach_target;        // what the pending hand action reaches for
  double reach_z = 0;       // ...and the height the hand goes to (m above the floor)
  SimTime progress_check = 0;
  double progress_distance = 0;
  std::vector<int> carrying;  // object indices
  // True while a hand action (pick up, put down, touch) is being done: the person faces
  // reach_target and the renderer draws the arm reaching to it at reach_z.
  bool handling() const;
};

struct ObjectEntity {
  ObjectSpec spec;
  Pose2 pose;
  double z = 0;          // height of the object's base above the floor
  int carrier = -1;      // person index while carried
  b2Body* body = nullptr;  // on the floor only
  bool present = true;   // false once carried out of the world
  std::string last_carrier;  // id of the last person who carried it ("" = none yet)
};

// A primitive action performed by a person, as it happened.
struct ActionRecord {
  SimTime t = 0;
  std::string person;
  std::string action;  // appear, pick_up, put_down, touch, leave
  std::string object;
  Vec2 where;
};

// A ground-truth event: what the activity rules should report.
struct GroundTruthEvent {
  std::string kind;      // left_bag, bag_taken, exchange, unauthorised_object
  SimTime t = 0;         // the moment the situation arose
  SimTime confirmed = 0; // the moment the rule's own thresholds are met (left_bag: t + T)
  std::vector<std::string> people;  // left_bag: owner; bag_taken: taker; exchange: from, to
  std::string object;
  std::string owner;     // the object's owner or last carrier, if any
  Vec3 where;            // map frame
};

struct WorldOptions {
  // Where controllers come from: the caller hands the world its registry (the built-ins are in
  // plugins/builtin.h). Null: no registry, so a scenario robot with a controller is an error.
  std::shared_ptr<PluginRegistry> plugins;
  std::vector<std::filesystem::path> plugin_dirs;
  bool prefer_shared_plugins = false;  // load controllers from .so even when built in
  bool controllers = true;             // false: robots stand still (tests)
  std::filesystem::path cache_dir;     // handed to controllers for their caches (roadmaps); "" = none
};

class World : public WorldView {
 public:
  // Builds the world: loads the map and robot models, creates bodies, loads and configures
  // plugins. Errors name the scenario file, line and key.
  static Result<std::unique_ptr<World>> create(const Scenario& scenario, const WorldOptions& options = {});
  ~World() override;

  // Advances one fixed step. Fails only on a run-time impossibility in the scripts (a place a
  // person cannot reach from where they are), naming the scenario line.
  Status advance();
  bool finished() const { return time_ >= end_time_; }
  SimTime end_time() const { return end_time_; }
  uint64_t steps() const { return steps_; }

  // WorldView
  SimTime time() const override { return time_; }
  SimTime step_length() const override { return dt_; }
  const OccupancyGrid& map() const override { return map_; }
  std::optional<Vec2> place(const std::string& name) const override;
  const RobotState* robot(const std::string& id) const override;

  const Scenario& scenario() const { return scenario_; }
  const std::vector<RobotEntity>& robots() const { return robots_; }
  const std::vector<PersonEntity>& people() const { return people_; }
  const std::vector<ObjectEntity>& objects() const { return objects_; }
  const std::vector<ActionRecord>& actions() const { return actions_; }
  // Events so far, in the order they arose (sorted by t at the end of the run).
  const std::vector<GroundTruthEvent>& events() const { return events_; }
  const std::vector<WallBox>& walls() const { return walls_; }
  // Robot contacts so far (ongoing ones included), in the order they began.
  const std::vector<ContactRecord>& contacts() const { return contacts_; }

  // The transport's side of the controllers' inbox and outbox.
  // Queues a task for a robot's controller; an unknown robot is an error naming it.
  Status post_task(const std::string& robot, RobotTask task);
  // Takes every report the controllers made since the last call, in robot then time order.
  std::vector<RobotReport> drain_reports();
  // Takes every team message the controllers sent since the last call, in robot then send order.
  std::vector<TeamMessage> drain_sent();
  // Puts a message in a robot's message inbox; an unknown robot is an error naming it.
  Status deliver(const std::string& robot, TeamMessage m);
  // A robot's latest report (its published state), or null.
  const RobotReport* last_report(const std::string& robot) const;
  // The floorplan's furniture (tables), empty for maps that are not floorplans.
  const std::vector<FloorplanFurniture>& furniture() const { return furniture_; }
  size_t plugin_count() const;

 private:
  World() = default;
  Status build(const WorldOptions& options);
  Status step_person(int i);
  void step_robots_control();
  void step_robots_sense();
  void update_carried();
  void monitor_events();
  void monitor_contacts();
  Status start_action(int i);
  Status plan_walk(int i, Vec2 goal, int line, const std::string& what);
  std::optional<Vec2> approach_point(int i, Vec2 target) const;
  Status finish_action(int i);
  void place_object_on_floor(int o, Vec2 where);
  void remove_object_body(int o);
  int find_object(const std::string& id) const;
  int find_person(const std::string& id) const;
  double object_height_at(Vec2 where, std::string* furniture) const;

  Scenario scenario_;
  OccupancyGrid map_;
  std::vector<WallBox> walls_;
  std::vector<FloorplanFurniture> furniture_;  // from a floorplan map; empty otherwise
  std::unique_ptr<planning::GridPathPlanner> person_paths_;
  std::unique_ptr<b2World> b2_;
  std::shared_ptr<PluginRegistry> registry_;
  std::unique_ptr<ObstacleIndex> bodies_index_;
  std::unique_ptr<WallRaycaster> wall_rays_;
  std::vector<RobotEntity> robots_;
  std::vector<PersonEntity> people_;
  std::vector<ObjectEntity> objects_;
  std::vector<ActionRecord> actions_;
  std::vector<GroundTruthEvent> events_;
  std::vector<ContactRecord> contacts_;
  std::map<std::pair<int, uintptr_t>, size_t> open_contacts_;  // (robot, body tag) -> contacts_ index
  struct LeftBagWatch {
    int object;
    int person;
    SimTime away_since = -1;
  };
  std::vector<LeftBagWatch> left_bag_watches_;
  SimTime time_ = 0, dt_ = 10'000'000, end_time_ = 0;
  uint64_t steps_ = 0;
};

// The map as a camera's lines of sight see it: furniture lower than `eye_height` (m; tables,
// under a camera on the wall) is seen over, so its cells are cleared; walls stay.
OccupancyGrid sight_map(const World& world, double eye_height);

}  // namespace vigil
