#include "world/plugin.h"

#include <dlfcn.h>

#include <algorithm>

namespace vigil {

PluginRegistry::~PluginRegistry() {
  for (auto& [name, handle] : handles_) dlclose(handle);
}

void PluginRegistry::add_builtin(const std::string& name,
                                 std::function<std::unique_ptr<Plugin>()> factory) {
  builtins_[name] = std::move(factory);
}

void PluginRegistry::add_search_dir(const std::filesystem::path& dir) {
  if (std::find(search_dirs_.begin(), search_dirs_.end(), dir) == search_dirs_.end()) search_dirs_.push_back(dir);
}

std::optional<std::filesystem::path> PluginRegistry::find_library(const std::string& name) const {
  for (const auto& dir : search_dirs_) {
    for (const std::string& file : {"libvigil_plugin_" + name + ".so", "lib" + name + ".so"}) {
      std::error_code ec;
      if (std::filesystem::is_regular_file(dir / file, ec)) return dir / file;
    }
  }
  return std::nullopt;
}

bool PluginRegistry::exists(const std::string& name) const {
  if (!prefer_shared_ && builtins_.count(name)) return true;
  return find_library(name).has_value() || builtins_.count(name) != 0;
}

Result<std::unique_ptr<Plugin>> PluginRegistry::create(const std::string& name) {
  if (!prefer_shared_) {
    if (auto it = builtins_.find(name); it != builtins_.end()) {
      origins_[name] = "builtin";
      return it->second();
    }
  }
  auto lib = find_library(name);
  if (!lib) {
    if (auto it = builtins_.find(name); it != builtins_.end()) {
      origins_[name] = "builtin";
      return it->second();
    }
    std::string dirs;
    for (const auto& d : search_dirs_) dirs += (dirs.empty() ? "" : ", ") + d.string();
    return bad_input("", 0, "", "plugin '" + name + "' not found (not built in; searched: " +
                                    (dirs.empty() ? "no directories" : dirs) + ")");
  }
  void* handle = nullptr;
  if (auto it = handles_.find(lib->string()); it != handles_.end()) {
    handle = it->second;
  } else {
    handle = dlopen(lib->c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!handle) return bad_input(lib->string(), 0, "", std::string("cannot load plugin: ") + dlerror());
    handles_[lib->string()] = handle;
  }
  auto entry_fn = reinterpret_cast<PluginEntryFn>(dlsym(handle, "vigil_plugin_entry"));
  if (!entry_fn) return bad_input(lib->string(), 0, "", "no entry point 'vigil_plugin_entry'");
  const PluginEntry* entry = entry_fn();
  if (!entry || entry->abi_version != kPluginAbiVersion) {
    return bad_input(lib->string(), 0, "",
                     "plugin ABI version " + std::to_string(entry ? entry->abi_version : -1) +
                         " does not match the host's " + std::to_string(kPluginAbiVersion));
  }
  if (name != entry->name) {
    return bad_input(lib->string(), 0, "", "library declares plugin '" + std::string(entry->name) +
                                               "', not '" + name + "'");
  }
  origins_[name] = lib->string();
  return std::unique_ptr<Plugin>(entry->create());
}

std::string PluginRegistry::origin(const std::string& name) const {
  auto it = origins_.find(name);
  return it == origins_.end() ? "" : it->second;
}

std::vector<std::string> PluginRegistry::builtin_names() const {
  std::vector<std::string> out;
  for (const auto& [n, f] : builtins_) out.push_back(n);
  return out;
}

}  // namespace vigil
