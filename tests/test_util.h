// Helpers shared by the tests: paths to the source tree, the shared data and the built tool.
#pragma once

#include <filesystem>
#include <string>

namespace vigil::test {

inline std::filesystem::path source_dir() { return VIGIL_SOURCE_DIR; }
inline std::filesystem::path plugin_dir() { return VIGIL_PLUGIN_DIR; }
inline std::filesystem::path vigil_binary() { return VIGIL_BINARY; }
// ../shared/data beside the checkout; tests that need it GTEST_SKIP() when it is absent.
inline std::filesystem::path shared_data() { return VIGIL_SHARED_DATA_DIR; }
inline bool have_shared_data() { return std::filesystem::exists(shared_data() / "maps"); }

}  // namespace vigil::test

#define VIGIL_REQUIRE_SHARED_DATA()                                                          \
  do {                                                                                       \
    if (!::vigil::test::have_shared_data())                                                  \
      GTEST_SKIP() << "../shared/data not found beside the checkout ("                       \
                   << ::vigil::test::shared_data() << "): skipping a test on real data";     \
  } while (0)
