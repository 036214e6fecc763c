// The static plugin registry: every plugin shipped with Vigil, compiled in.
#include "plugins/builtin.h"
#include "plugins/plugin_export.h"

VIGIL_PLUGIN_FACTORY_DECL(waypoint_follower)
VIGIL_PLUGIN_FACTORY_DECL(wander)
VIGIL_PLUGIN_FACTORY_DECL(navigator)
VIGIL_PLUGIN_FACTORY_DECL(team)

namespace vigil {

void register_builtin_plugins(PluginRegistry& registry) {
  registry.add_builtin("waypoint_follower", plugins::create_waypoint_follower);
  registry.add_builtin("wander", plugins::create_wander);
  registry.add_builtin("navigator", plugins::create_navigator);
  registry.add_builtin("team", plugins::create_team);
}

std::shared_ptr<PluginRegistry> builtin_plugin_registry() {
  auto registry = std::make_shared<PluginRegistry>();
  register_builtin_plugins(*registry);
  return registry;
}

}  // namespace vigil
