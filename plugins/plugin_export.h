// VIGIL_PLUGIN(name, Class): makes a plugin class loadable. In the shared-library build it
// defines the one exported entry point `vigil_plugin_entry`; in the built-in build it defines a
// factory `vigil::plugins::create_<name>()` used by the static registry.
#pragma once

#include <memory>

#include "world/plugin.h"

#define VIGIL_PLUGIN_FACTORY_DECL(name) \
  namespace vigil::plugins { std::unique_ptr<Plugin> create_##name(); }

#if defined(VIGIL_PLUGIN_SHARED)
#define VIGIL_PLUGIN(name, Class)                                                        \
  extern "C" __attribute__((visibility("default"))) const vigil::PluginEntry*            \
  vigil_plugin_entry() {                                                                 \
    static const vigil::PluginEntry entry{vigil::kPluginAbiVersion, #name,               \
                                          []() -> vigil::Plugin* { return new Class(); }}; \
    return &entry;                                                                       \
  }
#else
#define VIGIL_PLUGIN(name, Class)                                                        \
  namespace vigil::plugins {                                                             \
  std::unique_ptr<Plugin> create_##name() { return std::make_unique<Class>(); }          \
  }
#endif
