// The ground-truth log (ground_truth.jsonl): one `tick` line per recorded instant with every
// entity's id, kind and pose, then the people's `action` lines, the derived `event` lines and
// the robots' `contact` lines (who touched what, from when to when).
// Numbers are printed with fixed precision so the same run gives the same bytes; the SHA-256 of
// those bytes is kept as they are written.
#pragma once

#include <cstdio>
#include <filesystem>
#include <string>

#include "world/sha256.h"
#include "world/status.h"
#include "world/world.h"

namespace vigil {

class GroundTruthLog {
 public:
  ~GroundTruthLog();
  // Opens `path` for writing; an empty path keeps only the hash (no file).
  Status open(const std::filesystem::path& path);
  // One line with every entity's state at the world's current time.
  void write_tick(const World& world);
  // The action and event lines; call once at the end of the run.
  void write_timeline(const World& world);
  Status close();
  std::string sha256();  // digest of every byte written (call after close)
  uint64_t bytes() const { return bytes_; }
  uint64_t lines() const { return lines_; }

 private:
  void emit(const std::string& line);
  std::FILE* f_ = nullptr;
  Sha256 hash_;
  std::string digest_;
  uint64_t bytes_ = 0, lines_ = 0;
};

// "1.2345" with "-0.0000" printed as "0.0000".
std::string fixed4(double v);

}  // namespace vigil
