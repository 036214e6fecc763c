// Plugin search path of the command-line tools: VIGIL_PLUGIN_PATH (colon-separated), then
// --plugin-path options, then the build tree's plugin folder.
#pragma once

#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

namespace vigil::cli {

inline std::vector<std::filesystem::path> plugin_search_path(const std::vector<std::string>& extra = {}) {
  std::vector<std::filesystem::path> dirs;
  if (const char* env = std::getenv("VIGIL_PLUGIN_PATH")) {
    std::stringstream ss(env);
    std::string d;
    while (std::getline(ss, d, ':'))
      if (!d.empty()) dirs.emplace_back(d);
  }
  for (const auto& d : extra) dirs.emplace_back(d);
#ifdef VIGIL_PLUGIN_DIR
  dirs.emplace_back(VIGIL_PLUGIN_DIR);
#endif
  return dirs;
}

}  // namespace vigil::cli
