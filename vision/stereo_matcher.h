// Dense disparity from a rectified stereo pair with OpenCV's semi-global (StereoSGBM) or block
// (StereoBM) matcher, every parameter exposed, so the same downstream code runs on rendered and
// on real pairs. The output is always a CV_32F disparity map of the left view in pixels, with
// unmatched pixels set to kInvalidDisparity (any value <= 0 means "no usable disparity").
#pragma once

#include <string>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "common/status.h"
#include "vision/stereo_camera_model.h"

namespace vigil::vision {

enum class StereoAlgorithm { kSGBM, kBM };

// OpenCV's StereoSGBM modes: 5 directions (kSGBM), 8 directions with a full-size cost buffer
// (kHH), the faster 3-way variant (kSGBM3Way) and 4 directions (kHH4).
enum class SgbmMode { kSGBM, kHH, kSGBM3Way, kHH4 };

// Matcher parameters with working defaults (SGBM). Disparities are searched in
// [min_disparity, min_disparity + num_disparities).
struct StereoMatcherParams {
  StereoAlgorithm algorithm = StereoAlgorithm::kSGBM;
  int min_disparity = 0;          // smallest disparity searched (px)
  int num_disparities = 64;       // width of the search range (px), a positive multiple of 16
  int block_size = 5;             // matched block side (odd): SGBM >= 1 (3..11 usual), BM 5..255
  int p1 = 0;                     // SGBM penalty for a disparity change of 1 between neighbours;
                                  // 0 = OpenCV's advice 8 * channels * block_size^2
  int p2 = 0;                     // SGBM penalty for larger changes (> p1);
                                  // 0 = OpenCV's advice 32 * channels * block_size^2
  int disp12_max_diff = 1;        // left-right consistency tolerance (px); negative disables it
  int pre_filter_cap = 63;        // clip of the prefiltered image (SGBM any > 0, BM 1..63)
  int uniqueness_ratio = 10;      // percent by which the best cost must beat the second best
  int speckle_window_size = 100;  // largest speckle (px area) removed as noise; 0 disables
  int speckle_range = 2;          // disparity variation (px) allowed inside one connected region
  SgbmMode mode = SgbmMode::kSGBM;
  int texture_threshold = 10;     // BM only: minimum texture for a block to be matched
  int pre_filter_size = 9;        // BM only: normalisation window (odd, 5..255)
  // Sub-pixel error cancellation after Shimizu and Okutomi: the matcher's sub-pixel fit (a
  // parabola through the costs at d-1, d, d+1) pulls disparities towards whole pixels ("pixel
  // locking", up to 0.2 px here: 0.25 m of depth at 7 m with a 9 cm baseline). With this set, a
  // second pass matches the left image against the right one shifted by half a pixel, whose
  // locking error has the opposite sign, and the two disparities are averaged where both are
  // valid and within 1 px of each other (elsewhere the first pass is kept). Twice the time.
  bool half_pixel_pass = false;
  // Disparities in the left image's first min_disparity + num_disparities columns too. OpenCV
  // leaves that band without any (its search would run off the right image), yet a point there
  // whose match lies inside the right image has one: a person 7 m away at the view's left edge is
  // 7 px of disparity, not 64. With this set, both images are padded on the left by the band's
  // width in black before matching and the result is cut back, so the band gets the disparities
  // its matches in the right image allow (points whose match is outside it stay unmatched: the
  // left-right check refuses the black). 10 % more matching at 640 px wide.
  bool full_width = true;

  // Defaults for StereoBM (block 15, pre-filter cap 31); the other fields as above.
  static StereoMatcherParams bm();
  // Checks every field; the error's key is the field's name.
  Status validate() const;
};

// Depth along the optical axis (CV_32F metres, a new image) from a disparity image (CV_32F
// pixels), Z = fx * baseline / d where d > 0, 0 elsewhere.
cv::Mat depth_from_disparity(const cv::Mat& disparity, const StereoCameraModel& camera);

// Parses "sgbm" or "bm".
Result<StereoAlgorithm> parse_stereo_algorithm(const std::string& name);
// Parses "sgbm", "hh", "3way" or "hh4".
Result<SgbmMode> parse_sgbm_mode(const std::string& name);

class StereoMatcher {
 public:
  // Value written for pixels without a match.
  static constexpr float kInvalidDisparity = -1.0f;

  // A matcher for these parameters, or the error naming the bad parameter.
  static Result<StereoMatcher> create(const StereoMatcherParams& params);

  const StereoMatcherParams& params() const { return params_; }
  // Disparity of the left view in pixels (CV_32F, invalid <= 0) from a rectified pair of the same
  // size and type (8-bit, 1 or 3 channels; BM matches their grey levels).
  Result<cv::Mat> compute(const cv::Mat& left, const cv::Mat& right) const;

  // Matching only where it is wanted: `wanted` (CV_8UC1 of the pair's size, nonzero = wanted) is
  // grown by `grow` pixels and cut into boxes (the bounding boxes of its connected parts, merged
  // where they come within `grow` of each other). Each box is matched as a pair of crops that
  // reach num_disparities + block_size further left (the search range) and block_size beyond the
  // other sides (the blocks and the smoothness paths), and its disparities are kept. Returns the
  // disparity (kInvalidDisparity outside the boxes) and sets *measured (CV_8UC1, 255 inside the
  // boxes). When the boxes would cover more than `full_fraction` of the image, or `wanted` is
  // empty, the whole pair is matched and *measured is left empty (measured everywhere).
  // The same pair and mask always give the same bytes.
  Result<cv::Mat> compute_in(const cv::Mat& left, const cv::Mat& right, const cv::Mat& wanted, cv::Mat* measured,
                             int grow = 8, double full_fraction = 0.6) const;

 private:
  explicit StereoMatcher(const StereoMatcherParams& params) : params_(params) {}
  // compute(), padding the pair on the left first when `pad` (see full_width).
  Result<cv::Mat> match_pair(const cv::Mat& left, const cv::Mat& right, bool pad) const;
  StereoMatcherParams params_;
  cv::Ptr<cv::StereoBM> bm_;      // set for kBM
  cv::Ptr<cv::StereoSGBM> sgbm_;  // set for kSGBM; its default penalties follow the input's channels
};

}  // namespace vigil::vision
