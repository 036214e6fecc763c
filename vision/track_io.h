// tracks.jsonl: the tracks of a run (vision/track.h), one JSON object a line, in the map frame:
//   {"t_ns":1500000000,"camera":"cam_corridor","id":3,"class":"person","x":14.2000,"y":3.1500,
//    "vx":0.5000,"vy":0.0000,"height":1.7500,"width":0.5000,"confidence":0.9000}
// The writer prints every number with four decimals ("-0.0000" as "0.0000") and keys in that
// order, so the same tracks give the same bytes. The reader needs t_ns (integer), camera
// (non-empty string), id (integer), class ("unknown", "person", "bag", "robot"), x and y;
// vx, vy, height, width and confidence default to 0; other keys are ignored. Every error names
// the file, the line and the key. Documented in docs/EVALUATION.md.
#pragma once

#include <cstdio>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "common/status.h"
#include "vision/track.h"

namespace vigil::vision {

// One line of tracks.jsonl for `t`, without the newline. Non-finite numbers print as null
// (which the reader rejects); check_track() finds them first.
std::string format_track_json(const Track& t);
// An error naming the first non-finite number of `t` (or an empty camera id), Ok otherwise.
Status check_track(const Track& t);

// Parses one line; `file` and `line` are used in error messages.
Result<Track> parse_track_json(std::string_view text, const std::string& file, int line);
// Every track of a tracks.jsonl file, in file order (blank lines skipped, CRLF allowed).
Result<std::vector<Track>> load_tracks_jsonl(const std::filesystem::path& path);
// Writes `tracks` to `path` (replacing it).
Status save_tracks_jsonl(const std::filesystem::path& path, const std::vector<Track>& tracks);

// Streams tracks to a file as a tracker produces them.
class TrackJsonlWriter {
 public:
  TrackJsonlWriter() = default;
  TrackJsonlWriter(const TrackJsonlWriter&) = delete;
  TrackJsonlWriter& operator=(const TrackJsonlWriter&) = delete;
  ~TrackJsonlWriter();
  Status open(const std::filesystem::path& path);
  // Appends one line; an internal error when the track has a non-finite number.
  Status write(const Track& t);
  Status close();

 private:
  std::FILE* f_ = nullptr;
  std::string path_;
};

}  // namespace vigil::vision
