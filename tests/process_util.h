// Helpers for tests that run the vigil binary as separate processes (tests/dds_process_test.cpp,
// tests/netns_test.cpp): start one in the background (optionally on a network namespace), wait
// for it, poll a file for lines with a deadline, read an events.jsonl.
#pragma once

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "tests/test_util.h"
#include "vision/event.h"

extern char** environ;

namespace vigil::test {

// 1, or 5 when this test is built with AddressSanitizer or ThreadSanitizer (tools/test.sh
// --sanitize): the factor on a wall-clock lead given to other processes (an epoch a few seconds
// ahead, by which they must all have started and found each other), as sanitized processes start
// several times slower; and the divisor of a multi-process run's pace (its speed over real time).
inline double slowdown() {
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
  return 5;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
  return 5;
#else
  return 1;
#endif
#else
  return 1;
#endif
}

// Starts `vigil ARGS` in the background, stdout and stderr to `log`; on network namespace `ns`
// (through `ip netns exec`) when given. The process id, or -1.
inline pid_t spawn_vigil(const std::vector<std::string>& args, const std::filesystem::path& log, const std::string& ns = "") {
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&fa, 1, 2);
  std::vector<std::string> all;
  if (!ns.empty()) all = {"ip", "netns", "exec", ns};
  all.push_back(vigil_binary().string());
  all.insert(all.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : all) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = -1;
  const int rc = posix_spawnp(&pid, argv[0], &fa, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&fa);
  return rc == 0 ? pid : -1;
}

// Waits for the process; its exit code, or -1 when it did not exit normally.
inline int wait_exit(pid_t pid) {
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// Waits until `file` holds at least `n` lines, or `timeout_s` passes.
inline bool wait_for_lines(const std::filesystem::path& file, size_t n, double timeout_s) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (std::chrono::steady_clock::now() < end) {
    if (std::filesystem::exists(file)) {
      size_t lines = 0;
      for (char c : slurp(file)) lines += c == '\n';
      if (lines >= n) return true;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return false;
}

inline std::vector<vision::Event> read_events(const std::filesystem::path& p) {
  auto r = vision::read_events_jsonl(p.string());
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().str());
  return r.ok() ? *r : std::vector<vision::Event>{};
}

}  // namespace vigil::test
