#include "world/video_writer.h"

namespace vigil {

std::optional<VideoFormat> parse_video_format(std::string_view s) {
  if (s == "mp4") return VideoFormat::kMp4;
  if (s == "avi") return VideoFormat::kAvi;
  return std::nullopt;
}

const char* video_extension(VideoFormat f) { return f == VideoFormat::kMp4 ? ".mp4" : ".avi"; }

namespace {

bool try_open(cv::VideoWriter& w, const std::string& path, int api, int fourcc, double fps, cv::Size size) {
  try {
    return w.open(path, api, fourcc, fps, size);
  } catch (const cv::Exception&) {
    return false;  // the backend is missing or refused: the caller says what
  }
}

}  // namespace

bool VideoFile::open(const std::filesystem::path& path, double fps, cv::Size size, VideoFormat format,
                     VideoContent content) {
  path_ = path;
  frame_size_ = size;
  video_size_ = size;
  why_.clear();
  const std::string p = path.string();
  if (format == VideoFormat::kMp4) {
    video_size_ = cv::Size(size.width + (size.width & 1), size.height + (size.height & 1));
    if (try_open(writer_, p, cv::CAP_FFMPEG, cv::VideoWriter::fourcc('a', 'v', 'c', '1'), fps, video_size_)) return true;
    why_ = "OpenCV's FFmpeg backend cannot write H.264 (libx264) here; --video-format avi writes AVI without it";
    return false;
  }
  if (content == VideoContent::kDrawnView &&
      try_open(writer_, p, cv::CAP_FFMPEG, cv::VideoWriter::fourcc('X', 'V', 'I', 'D'), fps, size))
    return true;
  if (try_open(writer_, p, cv::CAP_OPENCV_MJPEG, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), fps, size)) return true;
  why_ = "OpenCV's MJPEG writer cannot open the file";
  return false;
}

void VideoFile::write(const cv::Mat& frame) {
  if (!writer_.isOpened() || frame.empty()) return;
  if (frame.size() == video_size_) {
    writer_.write(frame);
    return;
  }
  // Padding (H.264 needs even sizes) or a frame of another size: place it top-left on black.
  padded_.create(video_size_, frame.type());
  padded_.setTo(cv::Scalar::all(0));
  const cv::Rect r(0, 0, std::min(frame.cols, video_size_.width), std::min(frame.rows, video_size_.height));
  frame(r).copyTo(padded_(r));
  writer_.write(padded_);
}

}  // namespace vigil
