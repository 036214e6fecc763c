// Scenario files (scenarios/*.yaml): the map, duration, seed, cameras, robots, people with
// scripts and objects of one run. Parsing checks everything it can without running: types,
// unknown keys, ranges, that files exist, that places, objects and people named in scripts
// exist. Every error names the file, line and key. The format is documented in
// docs/SCENARIO_FORMAT.md.
#pragma once

#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "common/geometry.h"
#include "world/params.h"
#include "world/status.h"

namespace vigil {

// A position given either by a named place of the map or by explicit coordinates.
struct PlaceRef {
  std::string place;  // non-empty when named
  Vec2 point;         // resolved map-frame position (filled by the parser in both cases)
};

struct CameraSpec {
  std::string id;
  Vec3 position;                   // optical centre of the left camera, map frame
  double yaw = 0, pitch = 0, roll = 0;  // rad; yaw about z, pitch down positive, roll about view axis
  int width = 640, height = 480;
  std::optional<double> hfov;      // rad; used when fx is absent (default 60 deg)
  std::optional<double> fx, fy, cx, cy;
  double baseline = 0.09;          // m (Videre STH-MDCS: 9 cm)
  double rate_hz = 15;
  std::string plugin;              // vision plugin consuming the frames ("" = none)
  std::map<std::string, ParamEntry> params;
  int line = 0;
};

struct RangerSpec {
  bool enabled = false;
  double range_min = 0.02, range_max = 20.0;  // m
  double fov = 4.71238898;                    // rad (270 deg, Hokuyo)
  int samples = 180;
  double noise_std = 0.0;                     // m, Gaussian
  double rate_hz = 10;
};

struct OdometrySpec {
  // Stage's odom_error: per-robot bias drawn once, uniform in [-e, e], on x, y and yaw rates.
  double error_x = 0.0, error_y = 0.0, error_yaw = 0.0;
  double noise_std = 0.0;  // extra per-step Gaussian noise on the measured velocity (fraction)
};

struct RobotSpec {
  std::string id;
  std::filesystem::path urdf;   // resolved path
  Pose2 start;
  std::string start_place;      // when the start was given as a place
  std::string controller;       // plugin name ("" = none: the robot stands still)
  std::map<std::string, ParamEntry> params;
  RangerSpec ranger;
  OdometrySpec odometry;
  double max_speed = 0.5, max_turn_rate = 1.5;  // m/s, rad/s
  int line = 0;
};

enum class ActionKind { kWalkTo, kWait, kPickUp, kPutDown, kTouch, kLeave };
const char* to_string(ActionKind k);

// One step of a person's script. Steps run in order; `at` delays a step's start until that
// simulated time.
struct Action {
  ActionKind kind = ActionKind::kWait;
  std::optional<double> at;     // s, start no earlier than this
  PlaceRef target;              // walk_to, put_down (where; default: where the person stands), leave (exit)
  bool has_target = false;      // false for a put_down without `to` (and for wait, pick_up, touch)
  std::string object;           // pick_up, put_down, touch
  double duration = 0;          // wait: seconds; touch/pick_up/put_down: seconds the hand takes
  std::optional<double> speed;  // walk_to: m/s override
  int line = 0;
};

struct PersonSpec {
  std::string id;
  PlaceRef start;
  std::optional<double> appear_at;  // s; absent = present from the start
  double speed = 1.2;               // m/s walking
  double radius = 0.25;             // m
  double height = 1.75;             // m
  std::string shirt = "#3060c0", trousers = "#303030";  // clothing colours (#rrggbb)
  std::vector<Action> script;
  int line = 0;
};

enum class ObjectKind { kBag, kLaptop, kBook, kBottle, kBox };
const char* to_string(ObjectKind k);

struct ObjectSpec {
  std::string id;
  ObjectKind kind = ObjectKind::kBag;
  PlaceRef position;           // floor position, or position on the furniture
  std::string on;              // furniture name, "" = floor
  std::string carried_by;      // person id: starts carried by that person
  std::string owner;           // person id, "" = none (present in the building)
  bool authorised = true;      // false: nobody but its owner may handle it
  double size_x = 0.4, size_y = 0.2, size_z = 0.4;  // m (defaults per kind)
  std::string colour = "#202020";
  int line = 0;
};

// An object the operator marks as not to be handled, where it lies (the cameras' rules watch the
// place; nothing here is read from the scenario's objects).
struct RestrictedObjectSpec {
  std::string name;
  PlaceRef at;
  double z = 0;  // m: the object's height above the floor (default: the top of the furniture it is on)
  int line = 0;
};

// Thresholds of the ground-truth event rules.
struct EventRuleSpec {
  double left_bag_distance = 3.0;  // m the owner must be from the bag...
  double left_bag_time = 5.0;      // ...for this many seconds
  double exchange_distance = 1.5;  // m: both people this close at a hand-over
  // The operator's marking for the cameras' rules (not read by the ground truth): furniture whose
  // objects may be handled only by whoever put them there (chapter 10.6.1, scenario 2).
  std::vector<std::string> handling_zones;
  // The operator's marking of single objects (for camera systems that cannot see them, such as a
  // plan-view tracker and a laptop on a table).
  std::vector<RestrictedObjectSpec> restricted_objects;
};

// A scripted fault (issue 11): from `at` seconds a robot stops (its controller no longer runs,
// its wheels stop: a breakdown) or falls silent (its team messages are lost both ways: a radio
// failure; it keeps driving).
struct FaultSpec {
  std::string robot;
  double at = 0;
  std::string kind;  // stop | silent
  int line = 0;
};

struct Scenario {
  std::filesystem::path file;     // the scenario file
  std::string name;
  std::filesystem::path map;      // resolved map path (.floorplan.yaml, .yaml or .world)
  double duration = 60;           // s
  uint64_t seed = 1;
  double physics_rate_hz = 100;   // fixed step
  double record_rate_hz = 10;     // ground-truth and video frames
  EventRuleSpec rules;
  std::map<std::string, Vec2> places;  // the map's named places plus the scenario's own
  std::map<std::string, Pose2> furniture;  // the floorplan's furniture (tables), by name
  std::vector<CameraSpec> cameras;
  std::vector<RobotSpec> robots;
  std::vector<PersonSpec> people;
  std::vector<ObjectSpec> objects;
  std::vector<FaultSpec> faults;
};

// What the parser may look up outside the file.
struct ScenarioContext {
  // True when a plugin of that name can be loaded (static registry or search path). When
  // unset, plugin names are not checked.
  std::function<bool(const std::string&)> plugin_exists;
};

// Parses and checks a scenario file. Relative paths resolve against the file's folder.
Result<Scenario> load_scenario(const std::filesystem::path& path, const ScenarioContext& ctx = {});

// The camera with this id; otherwise an error naming the scenario file, the camera's line is
// unknown so `key` (e.g. "--camera") names what was asked, and the message lists the cameras.
Result<const CameraSpec*> find_camera(const Scenario& scenario, const std::string& id, const std::string& key = "camera");
// Parses a scenario from text (`file` is used in messages and to resolve relative paths).
Result<Scenario> parse_scenario(const std::string& text, const std::filesystem::path& file,
                                const ScenarioContext& ctx = {});

}  // namespace vigil
