// The static plugin registry: every plugin shipped with Vigil, compiled in.
#include "plugins/plugin_export.h"

VIGIL_PLUGIN_FACTORY_DECL(waypoint_follower)
VIGIL_PLUGIN_FACTORY_DECL(wander)

namespace vigil {

void register_builtin_plugins(PluginRegistry& registry) {
  registry.add_builtin("waypoint_follower", plugins::create_waypoint_follower);
  registry.add_builtin("wander", plugins::create_wander);
}

}  // namespace vigil
