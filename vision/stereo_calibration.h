// Stereo rig calibration: chessboard corners in left/right image pairs, OpenCV's
// calibrateCamera + stereoCalibrate, rectification (stereoRectify), and the calibration file in
// OpenCV FileStorage YAML (or XML) with keys image_width, image_height, K1, D1, K2, D2, R, T and
// the optional rectification R1, R2, P1, P2, Q and rms, and the optional rig pose over the floor
// (pose_position [x, y, z] in metres and pose_yaw_deg, pose_pitch_deg, pose_roll_deg: the
// rectified left camera in the map frame, vision/stereo_camera_model.h's CameraPose; written by
// `vigil calibrate floor`, see docs/RIG.md). Conventions are OpenCV's: K are 3x3
// camera matrices, D distortion rows (k1 k2 p1 p2 [k3 ...]), and a left-camera point X maps to
// the right camera as R * X + T, so a right camera `b` metres to the right has T = (-b, 0, 0).
// The rectified model (vision/stereo_camera_model.h) takes fx, fy, cx, cy from P1 and the
// baseline from P2's Tx (P2(0,3) = -fx * baseline).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "common/status.h"
#include "vision/stereo_camera_model.h"

namespace vigil::vision {

struct StereoCalibration {
  cv::Size image_size;    // size of the images the calibration was made for
  cv::Mat K1, D1, K2, D2; // intrinsics and distortion of the left and right cameras (CV_64F)
  cv::Mat R, T;           // right-from-left rotation (3x3) and translation (3x1)
  cv::Mat R1, R2;         // rectifying rotations (3x3); empty until computed or loaded
  cv::Mat P1, P2;         // rectified projections (3x4); empty until computed or loaded
  cv::Mat Q;              // disparity-to-depth matrix (4x4); empty until computed or loaded
  double rms = 0;         // stereo reprojection RMS (px) when known, 0 otherwise
  // The rectified left camera's pose in the map frame, when the rig file carries one.
  std::optional<CameraPose> pose;

  // True when R1, R2, P1, P2 and Q are all present.
  bool has_rectification() const;
  // True when the images are already rectified: R = I, no distortion, K1 = K2, T along x only.
  bool is_rectified_rig(double tolerance = 1e-6) const;
};

// A board's inner corners written COLSxROWS ("9x6", 2 to 100 each); the error names `key`.
Result<cv::Size> parse_board_size(const std::string& text, const std::string& key);

// The chessboard seen in the calibration images.
struct ChessboardParams {
  cv::Size inner_corners{9, 6};  // inner corners per row and per column
  double square_size = 0.025;    // side of a square (m); T and the baseline come out in this unit
  // Half-size of cornerSubPix's search window (px); 0 = per image, a third of the smallest
  // distance between neighbouring corners, 2 to 11 (a window reaching the next corner biases it).
  int subpixel_window = 0;
  int min_pairs = 3;             // fewest pairs with the board found in both views
  // Lens model estimated: kFull (k1 k2 p1 p2 k3), kRadial (k1 k2 only) or kPinhole (none).
  enum class LensModel { kFull, kRadial, kPinhole } lens = LensModel::kFull;
};

// What a chessboard calibration did.
struct StereoCalibrationReport {
  std::vector<std::string> used_pairs;     // left files whose pair was used
  std::vector<std::string> skipped_pairs;  // left files whose board was not found in both views
  std::vector<std::string> skip_reasons;   // for each skipped pair: which view lacks the board
  // Per used pair, stereoCalibrate's reprojection RMS in the left and the right view (px).
  std::vector<std::pair<double, double>> pair_rms;
  double left_rms = 0, right_rms = 0;      // per-camera reprojection RMS (px)
  double stereo_rms = 0;                   // stereoCalibrate's RMS over both views (px)
};

// The board's inner corners, refined to subpixel, in row-major order; nullopt when not found.
std::optional<std::vector<cv::Point2f>> find_chessboard_corners(const cv::Mat& image,
                                                                const ChessboardParams& board);

// Calibrates a rig from left/right image files given in matching order (pairs where the board is
// not found in both views are skipped and reported), then computes the rectification.
Result<StereoCalibration> calibrate_stereo_chessboard(const std::vector<std::string>& left_files,
                                                      const std::vector<std::string>& right_files,
                                                      const ChessboardParams& board,
                                                      StereoCalibrationReport* report = nullptr);

// Fills R1, R2, P1, P2, Q with cv::stereoRectify (zero disparity at infinity; alpha 0 keeps only
// valid pixels, 1 keeps every source pixel).
Status compute_rectification(StereoCalibration* calibration, double alpha = 0.0);

// Writes the calibration as FileStorage YAML (XML when the path ends in .xml).
Status save_stereo_calibration(const std::string& path, const StereoCalibration& calibration);

// Reads a calibration written by save_stereo_calibration (or by hand); errors name the file, the
// line of the key where it can be found, and the missing or malformed key.
Result<StereoCalibration> load_stereo_calibration(const std::string& path);

// The calibration of an ideal, already rectified rig with `model`'s intrinsics and baseline
// (K1 = K2, no distortion, R = I, T = (-baseline, 0, 0)) and its pose: what a rendered camera's
// frames are taken with.
StereoCalibration ideal_calibration(const StereoCameraModel& model);

// The rectified left camera and baseline at `pose`: fx, fy, cx, cy from P1 and the baseline from
// P2 (for an already-rectified rig, whose images are used as they are: K1 and -T.x). Errors when
// the rig is vertical or its right camera is not to the right.
Result<StereoCameraModel> rectified_camera_model(const StereoCalibration& calibration,
                                                 const CameraPose& pose = {});

}  // namespace vigil::vision
