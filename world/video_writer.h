// The videos a run writes: the top-down view, each camera's left view and each vision system's
// annotated view.
//
// VideoFormat::kMp4 (the default): H.264 in an MP4 container, written with FFmpeg's libavcodec
// and libavformat directly (libx264, constant quality CRF 23, preset veryfast, yuv420p; OpenCV's
// own FFmpeg writer passes x264 no options, so it ran at preset medium, a quarter of a run's CPU),
// which every browser and player opens; frames of odd width or height are padded by one black
// column or row (H.264's 4:2:0 needs even sizes). Deterministic: x264's threads do not change its
// output, and the container carries no time of writing.
//
// VideoFormat::kAvi: what runs wrote before, for tools that want it: camera views as MJPEG
// through OpenCV's own writer (no codec library, byte-identical, the best quality when the
// frames are read back as recorded ones), the top-down and annotated views as MPEG-4 Part 2
// through FFmpeg (OpenCV's MJPEG writer where FFmpeg is missing).
//
// Measured on the default scenario in docs/PERFORMANCE.md ("Videos").
#pragma once

#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include <opencv2/core.hpp>
#include <opencv2/videoio.hpp>

namespace vigil {

enum class VideoFormat { kMp4, kAvi };

// "mp4" or "avi"; nullopt otherwise.
std::optional<VideoFormat> parse_video_format(std::string_view s);
// ".mp4" or ".avi".
const char* video_extension(VideoFormat f);

// What the video shows: a camera's own view (MJPEG in AVI) or a drawn view (MPEG-4 Part 2 in AVI).
enum class VideoContent { kCameraView, kDrawnView };

class VideoFile {
 public:
  VideoFile();
  ~VideoFile();
  VideoFile(VideoFile&&) noexcept;
  VideoFile& operator=(VideoFile&&) noexcept;
  // Opens `path` (its extension is the caller's: see video_extension) for frames of `size` at
  // `fps`. False, with why() saying what failed, when no writer could.
  bool open(const std::filesystem::path& path, double fps, cv::Size size, VideoFormat format,
            VideoContent content = VideoContent::kDrawnView);
  // Writes one BGR frame of the size given to open() (padded when the video's size is larger).
  void write(const cv::Mat& frame);
  bool is_open() const { return writer_.isOpened() || h264_ != nullptr; }
  // Finishes the file (flushes the encoder, writes the index).
  void release();
  const std::filesystem::path& path() const { return path_; }
  const std::string& why() const { return why_; }

 private:
  struct H264;  // libavcodec's encoder and libavformat's MP4 muxer
  std::unique_ptr<H264> h264_;
  cv::VideoWriter writer_;
  std::filesystem::path path_;
  cv::Size frame_size_, video_size_;
  cv::Mat padded_;
  std::string why_;
};

}  // namespace vigil
