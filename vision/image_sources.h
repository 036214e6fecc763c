// Recorded frame sources (vision/frame_source.h) read with OpenCV: a mono video file, a mono
// image sequence, and a stereo sequence (two image sequences or two videos) with an optional
// calibration that rectifies the pairs and gives the rig's camera model; plus a factory that
// opens any of them from a one-line spec. Every problem with the input (missing or corrupt file,
// an image that does not load, a frame of another size) comes back as an Error naming the file
// and frame; nothing here throws, prints or exits.
//
// Frame source specs, for open_frame_source():
//   video:PATH                      a video file (any container/codec FFmpeg reads)
//   images:DIR/PATTERN              an image sequence: the files of DIR whose names match PATTERN,
//                                   a printf pattern with one integer field (left%02d.jpg: the
//                                   files with that many digits there, in numeric order, gaps
//                                   allowed) or a glob with * and ? (sorted by name)
//   stereo:LEFT,RIGHT[,CALIB]       a stereo sequence: LEFT and RIGHT are each an image pattern as
//                                   above (when they contain %, * or ?), one image file (by its
//                                   extension: .png, .jpg, ...) or else a video path;
//                                   CALIB is a calibration file (vision/stereo_calibration.h).
//                                   Without CALIB the pairs are taken as already rectified and
//                                   the source has no camera model.
// followed by options, each ";key=value":
//   fps=F                           frame rate for time stamps (images: default 15, the
//                                   chapter's Videre rig; videos: default the file's own rate)
//   disparity=sgbm|bm|none          stereo only: compute the left disparity (and depth when
//                                   calibrated) with that matcher; default none
//   num_disparities, min_disparity, block_size, uniqueness_ratio, speckle_window_size,
//   speckle_range, disp12_max_diff, p1, p2 (integers), mode=sgbm|hh|3way|hh4
//                                   stereo matcher parameters (vision/stereo_matcher.h)
//   subpixel=fit|cancel             fit: the matcher's own sub-pixel disparities; cancel: plus a
//                                   half-pixel-shifted pass averaged in (half_pixel_pass)
//   alpha=A                         stereo only: rectification scaling, 0 (default) to 1
//   pose=X,Y,Z,YAW,PITCH,ROLL       stereo only: the rig's pose in the map frame (metres; angles in
//                                   degrees, vision/stereo_camera_model.h's CameraPose), overriding
//                                   the calibration file's (written by `vigil calibrate floor`)
// Example: stereo:/data/left%02d.jpg,/data/right%02d.jpg,/data/rig.yaml;disparity=sgbm;num_disparities=128
#pragma once

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/videoio.hpp>

#include "common/status.h"
#include "vision/frame_source.h"
#include "vision/stereo_calibration.h"
#include "vision/stereo_matcher.h"

namespace vigil::vision {

// The image files DIR/PATTERN names (see the spec above), in order; an error when DIR does not
// exist or nothing matches.
Result<std::vector<std::string>> list_image_files(const std::string& dir_and_pattern);
// True when the file name in `s` is an image pattern (holds %, * or ?).
bool is_image_pattern(const std::string& s);
// True when `s` names images: a pattern, or one file with an image extension (.png, .jpg, ...).
bool names_images(const std::string& s);

// A mono source: stereo sequences are built from two of these.
class MonoFrameSource : public FrameSource {
 public:
  bool is_stereo() const override { return false; }
  // The file (and frame) the last frame came from, for error messages.
  virtual std::string last_frame_name() const = 0;
};

struct VideoFileOptions {
  double fps = 0;                   // time stamp rate; 0 = the file's own (15 when it has none)
  int api_preference = cv::CAP_FFMPEG;  // OpenCV backend; FFmpeg avoids the image-pattern backend
  bool require_announced_length = false;  // error when the file ends before its header's count
};

// A video file through cv::VideoCapture. Opening decodes the first frame, so a missing,
// unreadable or corrupt file fails at open().
class VideoFileSource : public MonoFrameSource {
 public:
  static Result<std::unique_ptr<VideoFileSource>> open(const std::string& path,
                                                       const VideoFileOptions& options = {});
  Result<bool> next(StereoFrame* frame) override;
  std::string describe() const override;
  std::string last_frame_name() const override;
  cv::Size frame_size() const { return size_; }
  // The frame count the container announces (may be an estimate; 0 when unknown).
  int64_t announced_frame_count() const { return announced_; }
  double fps() const { return fps_; }

 private:
  VideoFileSource() = default;
  std::string path_;
  VideoFileOptions options_;
  cv::VideoCapture capture_;
  cv::Mat pending_;  // the first frame, decoded at open()
  cv::Size size_;
  double fps_ = 15;
  int64_t announced_ = 0;
  int64_t index_ = -1;  // index of the last frame delivered
  bool ended_ = false;
};

struct ImageSequenceOptions {
  double fps = 15;  // time stamp rate (the chapter's Videre rig runs at 15 fps)
};

// Numbered or globbed still images (see list_image_files), loaded one by one as 8-bit BGR.
class ImageSequenceSource : public MonoFrameSource {
 public:
  static Result<std::unique_ptr<ImageSequenceSource>> open(const std::string& dir_and_pattern,
                                                           const ImageSequenceOptions& options = {});
  // The same over an explicit list of files (must not be empty).
  static Result<std::unique_ptr<ImageSequenceSource>> open(std::vector<std::string> files,
                                                           const ImageSequenceOptions& options = {});
  Result<bool> next(StereoFrame* frame) override;
  std::string describe() const override;
  std::string last_frame_name() const override;
  const std::vector<std::string>& files() const { return files_; }

 private:
  ImageSequenceSource() = default;
  std::string pattern_;
  std::vector<std::string> files_;
  ImageSequenceOptions options_;
  cv::Size size_;  // the first image's size; every later one must match
  size_t next_ = 0;
};

struct StereoSequenceOptions {
  double fps = 0;                              // time stamp rate; 0 = the left stream's default
  std::optional<StereoMatcherParams> matcher;  // when set, every frame gets a disparity map
  std::optional<CameraPose> pose;              // the rig's pose in the map frame; nullopt: the
                                               // calibration's, if it has one
  double rectify_alpha = 0;                    // used when the calibration lacks P1/P2
};

// Left/right pairs from two mono sources, rectified with the calibration when it has one that
// is not already rectified (maps computed once), with optional disparity and depth. Checks that
// both streams have the same length and that each pair has one size, equal to the calibration's.
class StereoSequenceSource : public FrameSource {
 public:
  // LEFT and RIGHT are each an image pattern, one image file or a video path (see the spec at
  // the top); calibration_path may be empty (pairs already rectified, no camera model).
  static Result<std::unique_ptr<StereoSequenceSource>> open(const std::string& left,
                                                            const std::string& right,
                                                            const std::string& calibration_path,
                                                            const StereoSequenceOptions& options = {});
  // The same from two open mono sources and an optional calibration in memory.
  static Result<std::unique_ptr<StereoSequenceSource>> open(
      std::unique_ptr<MonoFrameSource> left, std::unique_ptr<MonoFrameSource> right,
      std::optional<StereoCalibration> calibration, const StereoSequenceOptions& options = {});

  Result<bool> next(StereoFrame* frame) override;
  std::optional<StereoCameraModel> camera_model() const override { return model_; }
  bool has_pose() const override { return model_ && has_pose_; }
  bool is_stereo() const override { return true; }
  std::string describe() const override;
  // The calibration in use (with its rectification), when there is one.
  const std::optional<StereoCalibration>& calibration() const { return calibration_; }
  // True when frames are remapped (the calibration is not of an already-rectified rig).
  bool rectifies() const { return !map_left_[0].empty(); }

 private:
  StereoSequenceSource() = default;
  std::unique_ptr<MonoFrameSource> left_, right_;
  std::optional<StereoCalibration> calibration_;
  std::string calibration_path_;
  StereoSequenceOptions options_;
  std::optional<StereoCameraModel> model_;
  bool has_pose_ = false;  // the model's pose came from the options or the calibration
  std::optional<StereoMatcher> matcher_;
  cv::Mat map_left_[2], map_right_[2];  // initUndistortRectifyMap output (CV_16SC2 + CV_16UC1)
  int64_t index_ = 0;
};

// A spec split into its scheme ("video"), body (the path part) and ";key=value" options.
struct SourceSpec {
  std::string scheme, body;
  std::map<std::string, std::string> options;
};
Result<SourceSpec> parse_source_spec(const std::string& spec);
// Takes "fps" out of the options: its value, or 0 when absent.
Result<double> take_fps_option(const std::string& spec, std::map<std::string, std::string>* options);
// Takes "disparity" and the matcher keys out of the options (leaving `other_keys` alone; any
// other key is an error): the matcher's parameters, or nullopt for disparity=none or no
// "disparity" key.
Result<std::optional<StereoMatcherParams>> take_matcher_options(const std::string& spec,
                                                                std::map<std::string, std::string>* options,
                                                                const std::vector<std::string>& other_keys = {});

// Opens the source a spec names (see the top of this file); errors name the spec and the part
// at fault.
Result<std::unique_ptr<FrameSource>> open_frame_source(const std::string& spec);

}  // namespace vigil::vision
