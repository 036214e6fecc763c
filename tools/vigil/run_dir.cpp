#include "tools/vigil/run_dir.h"

#include <fstream>
#include <sstream>

#include "tools/vigil/commands.h"
#include "world/floorplan.h"
#include "world/map.h"
#include "world/robot_model.h"

namespace vigil::cli {

nlohmann::json read_json_object(const std::filesystem::path& p) {
  std::ifstream in(p);
  if (!in) throw Exit{report(bad_input(p.string(), 0, "", "cannot read the file"))};
  std::stringstream ss;
  ss << in.rdbuf();
  nlohmann::json j = nlohmann::json::parse(ss.str(), nullptr, false);
  if (j.is_discarded() || !j.is_object()) throw Exit{report(bad_input(p.string(), 0, "", "not a JSON object"))};
  return j;
}

nlohmann::ordered_json scene_entities(const Scenario& sc) {
  nlohmann::ordered_json ents = nlohmann::ordered_json::object();
  for (const auto& r : sc.robots) {
    double radius = 0.25;
    if (auto m = load_robot_model(r.urdf)) radius = m->radius;
    ents[r.id] = {{"kind", "robot"}, {"radius", radius}, {"height", 0.5}, {"colour", "#28a028"}};
  }
  for (const auto& p : sc.people)
    ents[p.id] = {{"kind", "person"}, {"radius", p.radius}, {"height", p.height}, {"colour", p.shirt}};
  for (const auto& ob : sc.objects)
    ents[ob.id] = {{"kind", to_string(ob.kind)}, {"size", {ob.size_x, ob.size_y, ob.size_z}}, {"size_x", ob.size_x},
                   {"size_y", ob.size_y}, {"colour", ob.colour}, {"authorised", ob.authorised}};
  return ents;
}

RunScene load_run_scene(const std::filesystem::path& run, const std::string& scenario_override) {
  if (!std::filesystem::is_directory(run)) throw Exit{report(bad_input(run.string(), 0, "run", "not a folder"))};
  const std::filesystem::path summary_path = run / "summary.json";
  if (!std::filesystem::exists(summary_path))
    throw Exit{report(bad_input(summary_path.string(), 0, "", "missing: not a folder `vigil run` wrote"))};
  RunScene scene;
  scene.summary = read_json_object(summary_path);
  std::filesystem::path scenario_path = scenario_override;
  if (scenario_path.empty()) {
    if (!scene.summary.contains("scenario_file") || !scene.summary["scenario_file"].is_string())
      throw Exit{report(bad_input(summary_path.string(), 0, "scenario_file",
                                  "missing (a run written before 2026-12-06): pass --scenario FILE"))};
    scenario_path = scene.summary["scenario_file"].get<std::string>();
  }
  auto scenario = load_scenario(scenario_path);
  if (!scenario) throw Exit{report(scenario.error())};
  scene.scenario = std::move(*scenario);
  // The map as the world loads it: a floor plan rasterised, else a map file.
  if (scene.scenario.map.filename().string().ends_with(".floorplan.yaml")) {
    auto fp = load_floorplan(scene.scenario.map);
    if (!fp) throw Exit{report(fp.error())};
    scene.grid = fp->rasterize();
  } else {
    auto grid = load_map(scene.scenario.map);
    if (!grid) throw Exit{report(grid.error())};
    scene.grid = std::move(*grid);
  }
  prepare_simulation_map(&scene.grid);  // as the world does: the map the run simulated
  return scene;
}

}  // namespace vigil::cli
