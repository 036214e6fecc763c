// The plugins shipped with Vigil, compiled into vigil_plugins_builtin. Callers build a registry
// with them and hand it to the world (WorldOptions::plugins); the world never reaches here.
#pragma once

#include <memory>

#include "world/plugin.h"

namespace vigil {

// Adds every built-in plugin to `registry`.
void register_builtin_plugins(PluginRegistry& registry);
// A new registry holding the built-in plugins.
std::shared_ptr<PluginRegistry> builtin_plugin_registry();

}  // namespace vigil
