// `vigil validate FILE...`: parses and checks scenario files without running them. Prints
// "OK FILE (N cameras, N robots, N people, N objects)" per good file, the error of each bad one,
// and exits 2 when any file failed (1 when the only failures were internal errors).
#include <algorithm>
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

namespace vigil::cli {

void add_validate_command(CLI::App& app) {
  auto files = std::make_shared<std::vector<std::string>>();
  CLI::App* cmd = app.add_subcommand("validate", "Check scenario files without running them");
  cmd->add_option("files", *files, "Scenario files (.yaml)")->required();
  cmd->callback([files] {
    // Plugin names are checked against the built-ins and the plugin search path.
    PluginRegistry registry;
    register_builtin_plugins(registry);
    for (const auto& dir : plugin_search_path()) registry.add_search_dir(dir);
    ScenarioContext ctx;
    ctx.plugin_exists = [&registry](const std::string& name) { return registry.exists(name) || sensors::vision_sensor_exists(name); };

    int worst = 0;
    for (const std::string& file : *files) {
      Result<Scenario> sc = load_scenario(file, ctx);
      if (!sc) {
        worst = std::max(worst, report(sc.error()));  // 2 (bad input) outranks 1 (internal)
        continue;
      }
      std::cout << "OK " << file << " (" << sc->cameras.size() << " cameras, " << sc->robots.size()
                << " robots, " << sc->people.size() << " people, " << sc->objects.size() << " objects)\n";
    }
    std::cout.flush();
    if (worst != 0) throw Exit{worst};
  });
}

}  // namespace vigil::cli
