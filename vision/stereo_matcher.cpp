#include "vision/stereo_matcher.h"

#include <cmath>
#include <string>

#include <opencv2/imgproc.hpp>

namespace vigil::vision {

namespace {

Error bad_param(const std::string& key, const std::string& message) {
  return bad_input("", 0, key, message);
}

int opencv_mode(SgbmMode mode) {
  switch (mode) {
    case SgbmMode::kSGBM: return cv::StereoSGBM::MODE_SGBM;
    case SgbmMode::kHH: return cv::StereoSGBM::MODE_HH;
    case SgbmMode::kSGBM3Way: return cv::StereoSGBM::MODE_SGBM_3WAY;
    case SgbmMode::kHH4: return cv::StereoSGBM::MODE_HH4;
  }
  return cv::StereoSGBM::MODE_SGBM;
}

// The image as 8-bit grey or BGR (BGRA loses alpha; grey stays grey).
cv::Mat as_grey_or_bgr(const cv::Mat& image) {
  if (image.channels() != 4) return image;
  cv::Mat bgr;
  cv::cvtColor(image, bgr, cv::COLOR_BGRA2BGR);
  return bgr;
}

cv::Mat as_grey(const cv::Mat& image) {
  if (image.channels() == 1) return image;
  cv::Mat grey;
  cv::cvtColor(image, grey, image.channels() == 4 ? cv::COLOR_BGRA2GRAY : cv::COLOR_BGR2GRAY);
  return grey;
}

std::string size_str(const cv::Mat& m) {
  return std::to_string(m.cols) + "x" + std::to_string(m.rows) + "x" + std::to_string(m.channels());
}

}  // namespace

StereoMatcherParams StereoMatcherParams::bm() {
  StereoMatcherParams p;
  p.algorithm = StereoAlgorithm::kBM;
  p.block_size = 15;
  p.pre_filter_cap = 31;
  return p;
}

Status StereoMatcherParams::validate() const {
  if (num_disparities <= 0 || num_disparities % 16 != 0)
    return bad_param("num_disparities",
                     "must be a positive multiple of 16, got " + std::to_string(num_disparities));
  if (block_size < 1 || block_size % 2 == 0)
    return bad_param("block_size", "must be odd and positive, got " + std::to_string(block_size));
  if (uniqueness_ratio < 0)
    return bad_param("uniqueness_ratio", "must be >= 0, got " + std::to_string(uniqueness_ratio));
  if (speckle_window_size < 0)
    return bad_param("speckle_window_size",
                     "must be >= 0, got " + std::to_string(speckle_window_size));
  if (speckle_range < 0)
    return bad_param("speckle_range", "must be >= 0, got " + std::to_string(speckle_range));
  if (algorithm == StereoAlgorithm::kBM) {
    if (block_size < 5 || block_size > 255)
      return bad_param("block_size",
                       "StereoBM needs an odd size in 5..255, got " + std::to_string(block_size));
    if (pre_filter_cap < 1 || pre_filter_cap > 63)
      return bad_param("pre_filter_cap",
                       "StereoBM needs 1..63, got " + std::to_string(pre_filter_cap));
    if (pre_filter_size < 5 || pre_filter_size > 255 || pre_filter_size % 2 == 0)
      return bad_param("pre_filter_size",
                       "must be odd in 5..255, got " + std::to_string(pre_filter_size));
    if (texture_threshold < 0)
      return bad_param("texture_threshold",
                       "must be >= 0, got " + std::to_string(texture_threshold));
  } else {
    if (pre_filter_cap < 1)
      return bad_param("pre_filter_cap", "must be > 0, got " + std::to_string(pre_filter_cap));
    if (p1 < 0) return bad_param("p1", "must be >= 0 (0 = default), got " + std::to_string(p1));
    if (p2 < 0) return bad_param("p2", "must be >= 0 (0 = default), got " + std::to_string(p2));
    if (p1 > 0 && p2 > 0 && p2 <= p1)
      return bad_param("p2", "must be greater than p1 (" + std::to_string(p1) + "), got " +
                                 std::to_string(p2));
  }
  return Status::Ok();
}

Result<StereoAlgorithm> parse_stereo_algorithm(const std::string& name) {
  if (name == "sgbm") return StereoAlgorithm::kSGBM;
  if (name == "bm") return StereoAlgorithm::kBM;
  return bad_param("algorithm", "unknown stereo algorithm '" + name + "' (expected sgbm or bm)");
}

Result<SgbmMode> parse_sgbm_mode(const std::string& name) {
  if (name == "sgbm") return SgbmMode::kSGBM;
  if (name == "hh") return SgbmMode::kHH;
  if (name == "3way") return SgbmMode::kSGBM3Way;
  if (name == "hh4") return SgbmMode::kHH4;
  return bad_param("mode", "unknown SGBM mode '" + name + "' (expected sgbm, hh, 3way or hh4)");
}

Result<StereoMatcher> StereoMatcher::create(const StereoMatcherParams& params) {
  if (Status s = params.validate(); !s) return s;
  StereoMatcher m(params);
  try {
    if (params.algorithm == StereoAlgorithm::kBM) {
      m.bm_ = cv::StereoBM::create(params.num_disparities, params.block_size);
      m.bm_->setMinDisparity(params.min_disparity);
      m.bm_->setPreFilterType(cv::StereoBM::PREFILTER_XSOBEL);
      m.bm_->setPreFilterSize(params.pre_filter_size);
      m.bm_->setPreFilterCap(params.pre_filter_cap);
      m.bm_->setTextureThreshold(params.texture_threshold);
      m.bm_->setUniquenessRatio(params.uniqueness_ratio);
      m.bm_->setSpeckleWindowSize(params.speckle_window_size);
      m.bm_->setSpeckleRange(params.speckle_range * 16);  // BM takes it in 1/16 px, SGBM in px
      m.bm_->setDisp12MaxDiff(params.disp12_max_diff);
    } else {
      m.sgbm_ = cv::StereoSGBM::create(params.min_disparity, params.num_disparities,
                                       params.block_size, 0, 0, params.disp12_max_diff,
                                       params.pre_filter_cap, params.uniqueness_ratio,
                                       params.speckle_window_size, params.speckle_range,
                                       opencv_mode(params.mode));
    }
  } catch (const cv::Exception& e) {
    return internal_error("cannot create the stereo matcher: " + std::string(e.what()));
  }
  return m;
}

Result<cv::Mat> StereoMatcher::compute(const cv::Mat& left, const cv::Mat& right) const {
  return match_pair(left, right, params_.full_width);
}

Result<cv::Mat> StereoMatcher::match_pair(const cv::Mat& left, const cv::Mat& right, bool pad) const {
  if (left.empty() || right.empty())
    return bad_input("", 0, left.empty() ? "left" : "right", "empty image given to the matcher");
  if (left.size() != right.size() || left.type() != right.type())
    return bad_input("", 0, "right",
                     "image is " + size_str(right) + " but the left one is " + size_str(left));
  if (left.depth() != CV_8U || (left.channels() != 1 && left.channels() != 3 && left.channels() != 4))
    return bad_input("", 0, "left", "stereo matching needs 8-bit images with 1, 3 or 4 channels");
  const int reach = params_.min_disparity + params_.num_disparities;
  if (left.cols <= reach || left.rows < params_.block_size)
    return bad_input("", 0, "left",
                     "image " + size_str(left) + " is too small for disparities up to " +
                         std::to_string(reach) + " and blocks of " +
                         std::to_string(params_.block_size));
  // OpenCV returns 16 * disparity in CV_16S and marks failures with (min_disparity - 1) * 16.
  // With `pad`, the pair gets `reach` black columns on the left and the result is cut back.
  const int band = pad ? reach : 0;
  auto match = [&](const cv::Mat& l_in, const cv::Mat& r_in, cv::Mat* disparity) -> Status {
    cv::Mat raw;
    try {
      cv::Mat lp = l_in, rp = r_in;
      if (band > 0) {
        cv::copyMakeBorder(l_in, lp, 0, 0, band, 0, cv::BORDER_CONSTANT, cv::Scalar::all(0));
        cv::copyMakeBorder(r_in, rp, 0, 0, band, 0, cv::BORDER_CONSTANT, cv::Scalar::all(0));
      }
      if (bm_) {
        bm_->compute(as_grey(lp), as_grey(rp), raw);
      } else {
        const cv::Mat l = as_grey_or_bgr(lp), r = as_grey_or_bgr(rp);
        const int area = params_.block_size * params_.block_size;
        sgbm_->setP1(params_.p1 > 0 ? params_.p1 : 8 * l.channels() * area);
        sgbm_->setP2(params_.p2 > 0 ? params_.p2 : 32 * l.channels() * area);
        sgbm_->compute(l, r, raw);
      }
      if (band > 0) raw = raw.colRange(band, raw.cols);
    } catch (const cv::Exception& e) {
      return internal_error("stereo matching failed: " + std::string(e.what()));
    }
    raw.convertTo(*disparity, CV_32F, 1.0 / 16.0);
    disparity->setTo(kInvalidDisparity, raw < params_.min_disparity * 16);
    // In the padded band (and a block beyond it), a match whose block reaches into the black is none.
    const int half = params_.block_size / 2;
    for (int y = 0; band > 0 && y < disparity->rows; ++y) {
      float* d = disparity->ptr<float>(y);
      for (int x = 0; x < std::min(band + half, disparity->cols); ++x)
        if (x < band ? !(d[x] > 0) || x - d[x] < half : d[x] > 0 && x - d[x] < half) d[x] = kInvalidDisparity;
    }
    return Status::Ok();
  };
  cv::Mat disparity;
  if (Status s = match(left, right, &disparity); !s) return s.error();
  if (!params_.half_pixel_pass) return disparity;
  // right'(x) = right(x + 0.5): a point at disparity d in the first pass is at d + 0.5 here.
  cv::Mat shifted, second;
  const cv::Matx23d shift(1, 0, -0.5, 0, 1, 0);
  cv::warpAffine(right, shifted, shift, right.size(), cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  if (Status s = match(left, shifted, &second); !s) return s.error();
  for (int y = 0; y < disparity.rows; ++y) {
    float* d = disparity.ptr<float>(y);
    const float* e = second.ptr<float>(y);
    for (int x = 0; x < disparity.cols; ++x) {
      const float d2 = e[x] - 0.5f;
      if (d[x] > 0 && e[x] > 0 && std::abs(d[x] - d2) < 1.0f) d[x] = 0.5f * (d[x] + d2);
    }
  }
  return disparity;
}

Result<cv::Mat> StereoMatcher::compute_in(const cv::Mat& left, const cv::Mat& right, const cv::Mat& wanted,
                                          cv::Mat* measured, int grow, double full_fraction) const {
  measured->release();
  if (wanted.empty()) return compute(left, right);
  if (wanted.type() != CV_8UC1 || wanted.size() != left.size())
    return bad_input("", 0, "wanted", "expected a CV_8UC1 mask of the left image's size");
  if (grow < 0) return bad_input("", 0, "grow", "must be >= 0");
  // Boxes of the grown mask's parts, merged while any two come within `grow` of each other.
  cv::Mat grown;
  if (grow > 0)
    cv::dilate(wanted, grown, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * grow + 1, 2 * grow + 1)));
  else
    grown = wanted;
  cv::Mat labels, stats, centroids;
  const int n = cv::connectedComponentsWithStats(grown, labels, stats, centroids, 8, CV_32S);
  std::vector<cv::Rect> boxes;
  for (int i = 1; i < n; ++i)
    boxes.emplace_back(stats.at<int>(i, cv::CC_STAT_LEFT), stats.at<int>(i, cv::CC_STAT_TOP),
                       stats.at<int>(i, cv::CC_STAT_WIDTH), stats.at<int>(i, cv::CC_STAT_HEIGHT));
  const cv::Rect image(0, 0, left.cols, left.rows);
  for (bool merged = true; merged;) {
    merged = false;
    for (size_t i = 0; i < boxes.size() && !merged; ++i) {
      const cv::Rect near(boxes[i].x - grow, boxes[i].y - grow, boxes[i].width + 2 * grow, boxes[i].height + 2 * grow);
      for (size_t j = i + 1; j < boxes.size(); ++j) {
        if ((near & boxes[j]).area() == 0) continue;
        boxes[i] |= boxes[j];
        boxes.erase(boxes.begin() + static_cast<std::ptrdiff_t>(j));
        merged = true;
        break;
      }
    }
  }
  cv::Mat disparity(left.size(), CV_32F, cv::Scalar(kInvalidDisparity));
  measured->create(left.size(), CV_8UC1);
  measured->setTo(0);
  if (boxes.empty()) return disparity;
  const int reach = params_.min_disparity + params_.num_disparities;
  const int margin = params_.block_size + 4;
  std::vector<cv::Rect> crops;
  double area = 0;
  for (const cv::Rect& b : boxes) {
    cv::Rect c(b.x - reach - margin, b.y - margin, b.width + reach + 2 * margin, b.height + 2 * margin);
    c &= image;
    // The matcher needs the crop wider than the search range and taller than a block.
    if (c.width <= reach + 1) {
      const int x1 = std::min(image.width, c.x + reach + 2);
      c.x = std::max(0, x1 - (reach + 2));
      c.width = x1 - c.x;
    }
    if (c.height < params_.block_size) {
      c.y = std::max(0, std::min(c.y, image.height - params_.block_size));
      c.height = std::min(image.height - c.y, params_.block_size);
    }
    crops.push_back(c);
    area += c.area();
  }
  if (area > full_fraction * image.area()) {
    measured->release();
    return compute(left, right);
  }
  for (size_t i = 0; i < boxes.size(); ++i) {
    const cv::Rect& c = crops[i];
    // A crop away from the image's left edge already reaches the search range further left.
    auto d = match_pair(left(c), right(c), params_.full_width && c.x == 0);
    if (!d) return d.error();
    const cv::Rect keep = boxes[i] & c;
    (*d)(keep - c.tl()).copyTo(disparity(keep));
    (*measured)(keep).setTo(255);
  }
  return disparity;
}

cv::Mat depth_from_disparity(const cv::Mat& disparity, const StereoCameraModel& camera) {
  const float fb = static_cast<float>(camera.intrinsics().fx * camera.baseline());
  cv::Mat depth = cv::Mat::zeros(disparity.size(), CV_32F);
  cv::Mat z;
  cv::divide(fb, disparity, z);
  z.copyTo(depth, disparity > 0);
  return depth;
}

}  // namespace vigil::vision
