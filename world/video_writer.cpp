#include "world/video_writer.h"

namespace vigil {

bool open_view_video(cv::VideoWriter& video, const std::string& path, double fps, cv::Size size) {
  try {
    if (video.open(path, cv::CAP_FFMPEG, cv::VideoWriter::fourcc('X', 'V', 'I', 'D'), fps, size)) return true;
  } catch (const cv::Exception&) {
    // no FFmpeg backend: the fallback below
  }
  return video.open(path, cv::CAP_OPENCV_MJPEG, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), fps, size);
}

}  // namespace vigil
