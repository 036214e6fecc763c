// `vigil gen FAMILY|all --seed S --count N --out DIR [--sensor truth|truth-clean|sgbm|platform|none]`:
// writes N random but valid scenarios per family (world/scenario_gen.h), FAMILY_SEED_INDEX.yaml,
// and prints one line per file with what happens in it. `vigil gen --list` lists the families.
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "plugins/builtin.h"
#include "plugins/vision_sensors/vision_sensor.h"
#include "tools/vigil/commands.h"
#include "tools/vigil/plugin_search.h"
#include "world/plugin.h"
#include "world/scenario.h"
#include "world/scenario_gen.h"

namespace vigil::cli {

namespace fs = std::filesystem;

void add_gen_command(CLI::App& app) {
  struct Opts {
    std::vector<std::string> families;
    uint64_t seed = 1;
    int count = 10;
    int first = 0;
    std::string out = "runs/generated";
    std::string sensor = "none";
    std::string map, urdf;
    bool list = false;
  };
  auto o = std::make_shared<Opts>();
  CLI::App* cmd = app.add_subcommand("gen", "Write random but valid scenarios of the given families (DIS map)");
  cmd->add_option("families", o->families, "Families (or 'all'); see --list");
  cmd->add_option("--seed", o->seed, "Seed of the draw (same seed, same files)");
  cmd->add_option("--count", o->count, "Scenarios per family")->check(CLI::Range(1, 100000));
  cmd->add_option("--first", o->first, "Index of the first scenario (to extend a set)")->check(CLI::Range(0, 100000000));
  cmd->add_option("--out", o->out, "Output folder");
  cmd->add_option("--sensor", o->sensor, "Vision sensor on every camera: none, truth (0.05 m noise, 5% misses, "
                                         "0.05 false tracks per tick), truth-clean (noise only), sgbm (rendered plan view) or platform "
                                         "(the chapter's: sgbm on the corridor camera, the colour MSER system on the lab camera)");
  cmd->add_option("--map", o->map, "The DIS floorplan (default: the project's maps/dis_labs.floorplan.yaml)");
  cmd->add_option("--urdf", o->urdf, "Robot model (default: maps/robots/erratic.urdf)");
  cmd->add_flag("--list", o->list, "List the families and exit");
  cmd->callback([o] {
    if (o->list) {
      for (const auto& f : scenario_families()) std::cout << f << ": " << scenario_family_description(f) << "\n";
      return;
    }
    if (o->families.empty()) {
      std::cerr << "vigil gen: name one or more families, or 'all' (vigil gen --list)\n";
      throw Exit{2};
    }
    std::vector<std::string> fams;
    for (const auto& f : o->families) {
      if (f == "all") {
        fams.insert(fams.end(), scenario_families().begin(), scenario_families().end());
      } else {
        fams.push_back(f);
      }
    }
    const fs::path src = VIGIL_SOURCE_DIR;
    ScenarioGenOptions g;
    g.seed = o->seed;
    g.map = o->map.empty() ? src / "maps" / "dis_labs.floorplan.yaml" : fs::path(o->map);
    g.urdf = o->urdf.empty() ? src / "maps" / "robots" / "erratic.urdf" : fs::path(o->urdf);
    g.out_dir = o->out;
    g.sensor = o->sensor == "none" ? "" : o->sensor;
    if (!fs::exists(g.map)) throw Exit{report(bad_input(g.map.string(), 0, "--map", "no such file"))};
    std::error_code ec;
    fs::create_directories(g.out_dir, ec);
    if (ec) throw Exit{report(bad_input(g.out_dir.string(), 0, "--out", "cannot create the folder: " + ec.message()))};
    // The written files are checked again as `vigil validate` checks them (plugins included).
    auto registry = std::make_shared<PluginRegistry>();
    register_builtin_plugins(*registry);
    for (const auto& dir : plugin_search_path()) registry->add_search_dir(dir);
    ScenarioContext ctx;
    ctx.plugin_exists = [registry](const std::string& name) { return registry->exists(name) || sensors::vision_sensor_exists(name); };
    g.world.plugins = registry;  // the dry run drives the robots with their controllers
    for (const auto& fam : fams) {
      g.family = fam;
      for (int i = o->first; i < o->first + o->count; ++i) {
        g.index = i;
        auto s = generate_scenario(g);
        if (!s) throw Exit{report(s.error())};
        const fs::path file = g.out_dir / (s->name + ".yaml");
        {
          std::ofstream f(file, std::ios::binary);
          f << s->text;
          if (!f) throw Exit{report(bad_input(file.string(), 0, "--out", "cannot write the file"))};
        }
        if (auto v = load_scenario(file, ctx); !v) throw Exit{report(v.error())};
        std::cout << file.string() << "  " << s->summary << "\n";
      }
    }
  });
}

}  // namespace vigil::cli
