// Frame sources: one interface for every place frames come from, so the vision code runs the
// same on rendered frames (the simulator's stereo cameras) and on recorded ones (a mono video or
// image sequence; a stereo sequence of image pairs or two videos with an OpenCV calibration).
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include <opencv2/core.hpp>

#include "common/status.h"
#include "vision/stereo_camera_model.h"

namespace vigil::vision {

// One (stereo) frame. Images are 8-bit BGR; what a source cannot provide stays empty.
struct StereoFrame {
  int64_t index = 0;      // 0, 1, 2, ... in the order delivered
  int64_t stamp_ns = 0;   // capture time (simulated time for rendered frames)
  cv::Mat left;           // CV_8UC3, always present
  cv::Mat right;          // CV_8UC3, stereo sources only
  cv::Mat depth;          // CV_32F metres along the optical axis of the left view; 0 = no depth
  cv::Mat disparity;      // CV_32F pixels (left view); 0 or negative = invalid
  cv::Mat labels;         // CV_32S entity label per left pixel (rendered frames; 0 = background)
  // CV_8U, where depth and disparity were measured at all (nonzero) when stereo was matched only
  // in parts of the image (StereoMatcher::compute_in); empty = measured everywhere. Outside it
  // depth is unknown, which is not the same as "no match": a background model neither compares
  // nor learns depth there.
  cv::Mat depth_measured;
};

class FrameSource {
 public:
  virtual ~FrameSource() = default;
  // Fills `frame` with the next frame and returns true, returns false at the end of the stream,
  // or an Error naming the file and frame at fault (missing, corrupt, wrong size).
  virtual Result<bool> next(StereoFrame* frame) = 0;
  // The rig's model when the source knows it (rendered frames, calibrated stereo sequences).
  virtual std::optional<StereoCameraModel> camera_model() const { return std::nullopt; }
  // True when the model's pose places the rig in the map frame (rendered frames; a recorded rig
  // whose calibration carries a pose, or given one); false when the pose is only the origin.
  virtual bool has_pose() const { return camera_model().has_value(); }
  virtual bool is_stereo() const = 0;
  // Short description for logs, e.g. "video vtest.avi (768x576)".
  virtual std::string describe() const = 0;
};

}  // namespace vigil::vision
