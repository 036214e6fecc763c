// Scenario generator (issue 13): families of random but valid DIS scenarios from a seed, so that
// the activity rules and trackers are judged on scripts nobody tuned them on. Each family is one
// kind of situation (a bag left, taken, exchanged, an owner who comes back or stays, people
// walking past or crossing, robots passing or stopping by a bag, objects put on the lab table and
// handled by their owner or by another), drawn with random places in a camera's view, directions,
// speeds, timings, clothes and bag colours; the corridor camera's own place along the corridor is
// drawn too. The ground truth follows from the script as for any scenario (the simulator derives
// it); every generated file parses with load_scenario (the generator checks it and redraws).
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "world/status.h"
#include "world/world.h"

namespace vigil {

struct ScenarioGenOptions {
  std::string family;            // one of scenario_families()
  uint64_t seed = 1;             // the family's seed; scenario `index` draws from its own stream
  int index = 0;
  std::filesystem::path map;     // the DIS floorplan (maps/dis_labs.floorplan.yaml)
  std::filesystem::path urdf;    // the robot model (maps/robots/erratic.urdf)
  std::filesystem::path out_dir; // where the file will be written (paths in it are relative to it)
  // The vision sensor written on every camera: "" (none), "truth" (the ground-truth sensor with
  // 0.05 m noise, 5 % misses, 0.05 false tracks per tick), "truth-clean" (no misses, no false
  // tracks), "sgbm" (the rendered plan-view pipeline with SGBM disparity) or "platform" (the
  // chapter's platform: SGBM and the plan view on the corridor camera, the colour MSER system on
  // the lab camera, section 10.6.1).
  std::string sensor;
  // Dry run: each draw is also simulated (no cameras) and kept only if every person finishes
  // their script (people walk the paths planned on the map and do not step around each other or
  // a stopped robot, so two walking head-on in one lane would wait for ever). `world` gives the
  // controllers (plugins/builtin.h); without a registry the robots stand still in the dry run.
  bool dry_run = true;
  WorldOptions world;
};

struct GeneratedScenario {
  std::string name;     // file stem: FAMILY_SEED_INDEX
  std::string family;
  std::string text;     // the YAML
  std::string summary;  // one line: what happens
};

// The dry run's checks on a drawn script, run to its end (no sensors; robots stand still unless
// `options` gives a registry): every person finishes their script, nobody walking is held in
// place for more than kMaxHeldWhileWalking seconds (wedged between people or things: a real
// person would step round; the stuck window that ends a walk held off its last point by a thing
// beside it is 2 s), and every event's object is
// seen by a camera (in its image within 8 m, lying still, and hidden by nobody standing between:
// people as upright cylinders) for at least kMinSeenBeforeEvent seconds before the event is due.
// A bag no camera could see is no test of a camera system (before this check the generator made
// an exchange with the owner standing between the camera and her bag throughout). Bad input,
// naming the key (people, objects), when a check fails: the generator draws again.
constexpr double kMinSeenBeforeEvent = 2.0;
constexpr double kMaxHeldWhileWalking = 3.0;
Status check_generated_script(const Scenario& scenario, const WorldOptions& options = {});

// The families, in a fixed order.
const std::vector<std::string>& scenario_families();
// One-line description of a family ("" for an unknown name).
std::string scenario_family_description(const std::string& family);

// Draws one scenario. The same options give the same bytes. Fails (bad input) for an unknown
// family or sensor, or when the map or robot model cannot be read.
Result<GeneratedScenario> generate_scenario(const ScenarioGenOptions& options);

}  // namespace vigil
