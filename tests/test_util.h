// Helpers shared by the tests: paths to the source tree, the shared data and the built tool.
#pragma once

#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace vigil::test {

inline std::filesystem::path source_dir() { return VIGIL_SOURCE_DIR; }
inline std::filesystem::path plugin_dir() { return VIGIL_PLUGIN_DIR; }
inline std::filesystem::path vigil_binary() { return VIGIL_BINARY; }
// ../shared/data beside the checkout; tests that need it GTEST_SKIP() when it is absent.
inline std::filesystem::path shared_data() { return VIGIL_SHARED_DATA_DIR; }
inline bool have_shared_data() { return std::filesystem::exists(shared_data() / "maps"); }

// What a finished `vigil` command printed and its exit code.
struct Output {
  int code = -1;
  std::string out;  // stdout, and stderr too unless asked otherwise
};

// Runs a shell command line and waits for it: its exit code and what it printed (stdout, and
// stderr too unless asked otherwise).
inline Output shell(const std::string& command, bool merge_stderr = true) {
  const std::string cmd = command + (merge_stderr ? " 2>&1" : " 2>/dev/null");
  Output o;
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return o;
  std::array<char, 4096> buf;
  size_t n;
  while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) o.out.append(buf.data(), n);
  const int status = pclose(p);
  o.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return o;
}

// Runs `vigil ARGS` (a shell command line) and waits for it.
inline Output vigil_cmd(const std::string& args, bool merge_stderr = true) {
  return shell(vigil_binary().string() + " " + args, merge_stderr);
}

// A whole file as bytes ("" when it cannot be read).
// A fresh, empty folder under the system's temp folder, unique to this process:
// vigil_<prefix>_<name>_<pid>.
inline std::filesystem::path fresh_temp_dir(const std::string& prefix, const std::string& name) {
  const std::filesystem::path d =
      std::filesystem::temp_directory_path() / ("vigil_" + prefix + "_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(d);
  std::filesystem::create_directories(d);
  return d;
}

inline std::string slurp(const std::filesystem::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

}  // namespace vigil::test

#define VIGIL_REQUIRE_SHARED_DATA()                                                          \
  do {                                                                                       \
    if (!::vigil::test::have_shared_data())                                                  \
      GTEST_SKIP() << "../shared/data not found beside the checkout ("                       \
                   << ::vigil::test::shared_data() << "): skipping a test on real data";     \
  } while (0)
