// Resident memory over a run (`vigil run --memory-log FILE`, tools/soak.sh): sampled every
// `period_s` of simulated time from /proc/self/statm, with the heap in use (glibc mallinfo2),
// written as CSV (sim_s, wall_s, rss_mb, heap_mb),
// with a picture of the curve and the figures a soak is judged by.
#pragma once

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "common/status.h"

namespace vigil::cli {

class MemoryLog {
 public:
  // Opens `csv` for writing; the picture goes beside it (same stem, .png).
  static Result<MemoryLog> open(const std::filesystem::path& csv, double period_s = 10.0);
  MemoryLog(MemoryLog&& o) noexcept;
  MemoryLog& operator=(MemoryLog&&) = delete;
  ~MemoryLog();

  // Samples when `sim_s` has reached the next sample time.
  void maybe_sample(double sim_s);
  // The last sample, the picture and the figures: warm-up ends at `warmup_share` of the run;
  // after it, the least-squares slope (MB per hour) and the largest rise over the warm-up's
  // level. Returns one line for the terminal.
  std::string finish(double sim_s, double warmup_share = 0.1);

  struct Sample {
    double sim_s, wall_s, rss_mb, heap_mb;
  };
  const std::vector<Sample>& samples() const { return samples_; }

 private:
  MemoryLog() = default;
  std::filesystem::path csv_;
  std::FILE* f_ = nullptr;
  double period_s_ = 10, next_ = 0;
  std::chrono::steady_clock::time_point t0_;
  std::vector<Sample> samples_;
};

// This process's resident set size in MB (0 when /proc is not there).
double resident_mb();

}  // namespace vigil::cli
