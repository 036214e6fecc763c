// vigil export-mcap RUN_DIR [--scenario FILE] [--out FILE] [--image-rate HZ]
// Writes RUN_DIR/run.mcap for Foxglove: what this binary knows of the run's scene (the map grid as
// the world loads it, the cameras, the entities' kinds, colours and sizes) goes to a scene file,
// then tools/export_mcap.sh (Python in a virtual environment it makes, PyPI's mcap, foxglove-sdk
// and opencv-python-headless) writes the MCAP from it and the run's files with Foxglove's
// well-known schemas. docs/FOXGLOVE.md.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <unistd.h>

#include "tools/vigil/commands.h"
#include "tools/vigil/run_dir.h"

namespace vigil::cli {
namespace {

namespace fs = std::filesystem;

std::string shell_quote(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

// Row-major from the grid's origin (the lowest row first), ROS occupancy values: 0 free, 100
// occupied, -1 unknown, as hexadecimal bytes (two characters a cell).
std::string occupancy_hex(const OccupancyGrid& g) {
  static const char* k = "0123456789abcdef";
  std::string out;
  out.reserve(static_cast<size_t>(g.width()) * g.height() * 2);
  for (int cy = 0; cy < g.height(); ++cy)
    for (int cx = 0; cx < g.width(); ++cx) {
      const Cell c = g.at(cx, cy);
      const uint8_t v = c == Cell::kFree ? 0 : c == Cell::kOccupied ? 100 : 0xFF;
      out += k[v >> 4];
      out += k[v & 15];
    }
  return out;
}

}  // namespace

void add_export_mcap_command(CLI::App& app) {
  struct Opts {
    std::string run, scenario, out;
    double image_rate = 5;
    int jpeg_quality = 80;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand("export-mcap", "Write RUN_DIR/run.mcap for Foxglove (tools/export_mcap.sh)");
  cmd->add_option("run", o->run, "a folder `vigil run` wrote")->required();
  cmd->add_option("--scenario", o->scenario, "the scenario run (default: summary.json's scenario_file)");
  cmd->add_option("--out", o->out, "the MCAP file (default RUN_DIR/run.mcap)");
  cmd->add_option("--image-rate", o->image_rate, "camera images per second in the file (default 5; 0: none)")
      ->check(CLI::Range(0.0, 1000.0));
  cmd->add_option("--jpeg-quality", o->jpeg_quality, "JPEG quality of the camera images (default 80)")->check(CLI::Range(1, 100));
  cmd->callback([o] {
    const fs::path run = o->run;
    const RunScene scene = load_run_scene(run, o->scenario);
    const Scenario& sc = scene.scenario;
    nlohmann::ordered_json j;
    j["scenario"] = sc.name;
    j["map"] = {{"file", sc.map.string()},
                {"width", scene.grid.width()},
                {"height", scene.grid.height()},
                {"resolution", scene.grid.resolution()},
                {"origin_x", scene.grid.origin().x},
                {"origin_y", scene.grid.origin().y},
                {"occupancy_hex", occupancy_hex(scene.grid)}};
    nlohmann::ordered_json cams = nlohmann::ordered_json::array();
    for (const auto& c : sc.cameras) {
      double hfov = c.hfov.value_or(60.0 * M_PI / 180.0);
      if (c.fx) hfov = 2 * std::atan(c.width / (2 * *c.fx));
      cams.push_back({{"id", c.id}, {"x", c.position.x}, {"y", c.position.y}, {"z", c.position.z}, {"yaw", c.yaw},
                      {"pitch", c.pitch}, {"roll", c.roll}, {"hfov", hfov}, {"width", c.width}, {"height", c.height}, {"rate_hz", c.rate_hz},
                      {"plugin", c.plugin}});
    }
    j["cameras"] = cams;
    j["entities"] = scene_entities(sc);

    const fs::path scene_file = fs::temp_directory_path() / ("vigil_mcap_scene_" + std::to_string(::getpid()) + ".json");
    {
      std::ofstream f(scene_file);
      f << j.dump();
      if (!f) throw Exit{report(internal_error("cannot write " + scene_file.string()))};
    }
    const fs::path out = o->out.empty() ? run / "run.mcap" : fs::path(o->out);
    const char* tools = std::getenv("VIGIL_TOOLS_DIR");
    const fs::path script = fs::path(tools ? tools : VIGIL_SOURCE_DIR "/tools") / "export_mcap.sh";
    if (!fs::exists(script)) throw Exit{report(internal_error("cannot find " + script.string() + " (set VIGIL_TOOLS_DIR)"))};
    char rate[32];
    std::snprintf(rate, sizeof rate, "%g", o->image_rate);
    const std::string command = "bash " + shell_quote(script.string()) + " --scene " + shell_quote(scene_file.string()) +
                                " --out " + shell_quote(out.string()) + " --image-rate " + rate + " --jpeg-quality " +
                                std::to_string(o->jpeg_quality) + " " + shell_quote(run.string());
    const int status = std::system(command.c_str());
    fs::remove(scene_file);
    const int code = WIFEXITED(status) ? WEXITSTATUS(status) : 1;
    if (code != 0) throw Exit{code == 2 ? 2 : 1};
  });
}

}  // namespace vigil::cli
