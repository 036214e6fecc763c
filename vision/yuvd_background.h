// Per-pixel YUV + depth Gaussian-mixture background model and foreground segmentation, after
// Harville, Gordon and Woodfill as described in section 10.4.1 of the chapter.
//
// Every pixel keeps K Gaussians (default 4) over X = [Y U V D] with a diagonal covariance: one
// variance for luminance, one shared by the two chroma channels, one for depth. Each Gaussian
// also keeps its mixing weight and the fraction of its observations that carried a valid depth.
// The Gaussians are kept sorted by decreasing weight / sigma_Y and an observation is matched to
// the first one that is close enough (on-line K-means):
//
//   * depth is compared only when the observation has a valid depth and the Gaussian's fraction
//     of valid depth observations is >= depth_valid_fraction (0.2);
//     - squared depth distance < match_threshold * sigma_D^2: the depth agrees, so the colour
//       tolerance is multiplied by depth_agree_factor (4): shadows and inter-reflections that
//       keep the background's depth but not its colour still match;
//     - otherwise the Gaussian does not match; if the observation is nearer than a background
//       Gaussian the pixel's foreground flag is set;
//   * luminance: (Y - mu_Y)^2 < tolerance * sigma_Y^2;
//   * chroma, only when both Y and mu_Y are >= min_chroma_luminance (dark chroma is noise):
//     (U - mu_U)^2 + (V - mu_V)^2 < tolerance * sigma_C^2.
//
// The matched Gaussian's mean and variances follow eq. 10.2 and every weight eq. 10.3
// (w <- (1 - a) w + a M). When nothing matches and the foreground flag is not set, the last
// (weakest) Gaussian is replaced by one centred on the observation with a low weight and the
// weights are renormalised; when nothing matches and the flag is set the pixel's Gaussians are
// left as they were. The
// learning rate a is divided by activity_divisor (5) where the per-pixel activity of eq. 10.4,
// Ac <- (1 - rho) Ac + rho |Y_t - Y_t-1|, exceeds activity_threshold (5). The background is the
// first Gaussians in sorted order whose cumulative weight reaches background_weight (Stauffer and
// Grimson); a pixel is foreground unless it matched one of them (and a "nearer" flag is only
// overruled by a background Gaussian whose depth agrees). Opening, closing and the removal of
// small components clean the mask, each optional.
//
// Input: a BGR CV_8UC3 frame and, optionally, a CV_32FC1 depth image in metres of the same size.
// Depth <= 0, NaN and +-inf mean "no depth" (as invalid disparity does in the chapter). A model
// that has never been given depth runs on colour alone and stores no depth statistics; when depth
// first comes later, every Gaussian starts with no depth statistics (valid fraction 0).
// Output: a CV_8UC1 mask, 255 = foreground, 0 = background.
//
// The per-pixel loop runs on 8 (AVX2, chosen at run time) or 4 (SSE2) pixels at a time with
// branch-free arithmetic on structure-of-arrays float planes, single-threaded, with no per-pixel
// allocation; the same input always gives the same bytes out, on either path.
#pragma once

#include <cstdint>
#include <memory>

#include <opencv2/core.hpp>

#include "common/status.h"

namespace vigil::vision {

// Every constant of the model. The chapter's values are the defaults; the others are choices of
// ours (noted). Colour values are on OpenCV's 8-bit YUV scale (0..255), depth in metres.
struct YuvdBackgroundParams {
  int num_gaussians = 4;                // K, 1..8
  float learning_rate = 0.005f;         // alpha of eqs. 10.2 and 10.3 (value ours)
  float match_threshold = 4.0f;         // squared distance in sigma units for a match
  float depth_valid_fraction = 0.2f;    // a Gaussian's depth is used only at or above this fraction
  float depth_agree_factor = 4.0f;      // colour tolerance multiplier when the depth agrees
  float min_chroma_luminance = 16.0f;   // chroma compared only when Y and mu_Y are >= this (ours)
  float activity_rate = 0.1f;           // rho of eq. 10.4 (ours)
  float activity_threshold = 5.0f;      // activity above this slows learning...
  float activity_divisor = 5.0f;        // ...by this factor
  float background_weight = 0.7f;       // cumulative weight of the background Gaussians (ours)
  float init_weight = 0.05f;            // weight of a replacing Gaussian (at least the rate)
  float init_sigma_y = 10.0f;           // sigma_Y of a new Gaussian
  float init_sigma_c = 10.0f;           // sigma_C of a new Gaussian (sqrt of E[dU^2 + dV^2])
  float init_sigma_depth = 0.15f;       // sigma_D of a new Gaussian (m)
  // Floors and ceilings of the learnt sigmas (ours). A floor of 4 gives the same smallest
  // tolerance (+-8 grey levels) as OpenCV's MOG2 defaults (sigma >= 2, 4 sigma).
  float min_sigma_y = 4.0f;
  float max_sigma_y = 40.0f;
  float min_sigma_c = 4.0f;
  float max_sigma_c = 40.0f;
  float min_sigma_depth = 0.02f;        // sigma_D floor: min_sigma_depth + rel * mu_D (m)
  float min_sigma_depth_rel = 0.01f;
  float max_sigma_depth = 2.0f;
  // Chapter: no replacement while the foreground ("nearer than the background") flag is set, so
  // an object in front of the background stays foreground however long it stays. False lets
  // such objects be learnt like any other change.
  bool nearer_blocks_replacement = true;
  // Ours: during the first bootstrap_frames frames the rate is max(alpha, 1 / (t + 1)), so the
  // first frames are averaged instead of the first frame alone being the background. 0 = off.
  int bootstrap_frames = 50;
  // Clean-up of the raw mask, in this order; 0 disables each.
  int open_radius = 1;        // opening with an elliptic (2r+1)^2 element: removes specks
  int close_radius = 1;       // closing: fills small holes
  int min_component_area = 0; // 8-connected foreground components below this area (px) removed

  // Checks every field; the error's key is the field's name.
  Status validate() const;
};

// One Gaussian of one pixel, for inspection and tests.
struct YuvdGaussian {
  float weight = 0;
  float mean_y = 0, mean_u = 0, mean_v = 0, mean_depth = 0;
  float sigma_y = 0, sigma_c = 0, sigma_depth = 0;  // sigma_depth = 0 for a colour-only model
  float depth_valid_fraction = 0;
  bool background = false;  // part of the background set
};

class YuvdBackground {
 public:
  // A model for these parameters, or the error naming the bad parameter.
  static Result<YuvdBackground> create(const YuvdBackgroundParams& params = {});

  YuvdBackground(YuvdBackground&&) noexcept;
  YuvdBackground& operator=(YuvdBackground&&) noexcept;
  ~YuvdBackground();

  // Learns the frame and writes its foreground mask (CV_8UC1, 255 = foreground; the first frame
  // is all background). depth: empty, or CV_32FC1 metres of the frame's size. Errors (bad type,
  // empty frame, size other than the first frame's) leave the model unchanged.
  Status apply(const cv::Mat& bgr, const cv::Mat& depth, cv::Mat& fg_mask);
  // The same where depth was measured only inside `measured` (CV_8UC1 of the frame's size,
  // nonzero = measured; empty = everywhere). Outside it the pixel is matched on colour alone and
  // the Gaussians' depth statistics (mean, variance, valid fraction) are left as they were: depth
  // there is unknown, not invalid.
  Status apply(const cv::Mat& bgr, const cv::Mat& depth, const cv::Mat& measured, cv::Mat& fg_mask);
  // Colour only for this frame (same as an all-invalid depth image once depth has been seen).
  Status apply(const cv::Mat& bgr, cv::Mat& fg_mask) { return apply(bgr, cv::Mat(), fg_mask); }

  // Where this frame's colour differs from the background (CV_8UC1, 255 = differs), before it is
  // learnt, without changing the model: a pixel is 255 unless its colour matches one of the
  // background Gaussians with the plain tolerance (no depth, so no widening where depth agrees).
  // This is where foreground can be; a foreground pixel outside it would have to be one whose
  // colour is the background's and whose depth alone is nearer (camouflage). All 255 before the
  // first frame. Same errors as apply().
  Status colour_changes(const cv::Mat& bgr, cv::Mat& changed) const;

  // Gives the strongest Gaussian of each pixel set in `mask` (CV_8UC1 of the model's size) the
  // depth in `depth` (CV_32FC1 metres, > 0) as fully measured: what the scene behind is known to
  // be (the building, from its map) where the learnt frame showed something nearer. Those pixels
  // are then foreground while that thing stays (nearer than the background's depth). Needs a
  // model that has learnt a frame with depth; errors name the argument.
  Status set_background_depth(const cv::Mat& mask, const cv::Mat& depth);

  // Forgets everything: the next frame starts a new model (and may have another size).
  void reset();

  const YuvdBackgroundParams& params() const { return params_; }
  int64_t frames() const { return frames_; }  // frames learnt since creation or reset()
  cv::Size size() const { return {width_, height_}; }
  bool has_depth() const { return has_depth_; }  // depth statistics are kept
  // The mask of the last frame before the morphological clean-up.
  const cv::Mat& raw_mask() const { return raw_mask_; }
  // Gaussian k (0 = strongest, in the model's sorted order) of pixel (x, y); error when out of
  // range or before the first frame.
  Result<YuvdGaussian> gaussian(int x, int y, int k) const;
  // The activity level Ac of pixel (x, y) (eq. 10.4), 0 when out of range.
  float activity(int x, int y) const;
  // BGR image of the strongest Gaussian's colour mean: the model's idea of the background.
  cv::Mat background_image() const;

 private:
  explicit YuvdBackground(const YuvdBackgroundParams& params);
  void allocate(int width, int height);
  void add_depth_planes();
  void first_frame(const cv::Mat& depth);
  void learn(const cv::Mat& depth, const cv::Mat& measured);
  Status check_input(const cv::Mat& bgr, const cv::Mat& depth) const;
  void clean_up(cv::Mat& fg_mask);

  struct Buffers;
  YuvdBackgroundParams params_;
  int width_ = 0, height_ = 0, stride_ = 0;  // stride_: row length of the planes (padded)
  int64_t frames_ = 0;
  bool has_depth_ = false;
  std::unique_ptr<Buffers> buf_;
  cv::Mat yuv_, planes_[3], prev_y_, raw_mask_, morph_tmp_;  // planes_: Y, U, V of this frame
  cv::Mat open_kernel_, close_kernel_;
};

namespace detail {
// Tests only: run the portable (SSE2) kernel even where the AVX2 one is available. Both give
// identical bytes; this lets a test check it.
void yuvd_force_portable_kernel(bool force);
}  // namespace detail

}  // namespace vigil::vision
