// A finished run's folder as `vigil report` and `vigil export-mcap` read it: summary.json, the
// scenario that was run (summary.json's scenario_file, or one given) and its map as the world
// loads it. Errors are bad input naming the file and key; they end the command (cli::Exit).
#pragma once

#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "common/occupancy_grid.h"
#include "world/scenario.h"

namespace vigil::cli {

struct RunScene {
  nlohmann::json summary;
  Scenario scenario;
  OccupancyGrid grid;
};

// `scenario_override` empty: summary.json's scenario_file.
RunScene load_run_scene(const std::filesystem::path& run, const std::string& scenario_override);

// The scenario's robots, people and objects by id, as the tools that draw a run want them: kind,
// colour, and size (robots and people: radius and height; objects: size [x, y, z], size_x,
// size_y, authorised).
nlohmann::ordered_json scene_entities(const Scenario& scenario);

// A JSON object file; bad input naming the file when it is missing or not one.
nlohmann::json read_json_object(const std::filesystem::path& p);

}  // namespace vigil::cli
