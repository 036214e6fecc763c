// Tests of vision/stereo_matcher and vision/stereo_calibration on real data: SGBM and BM on the
// Middlebury "Aloe" pair read through the stereo frame source, scored against its ground truth;
// a stereo rig calibrated from OpenCV's 13 real chessboard pairs, saved, loaded back and used by
// the stereo frame source to rectify the same pairs; matcher parameter checks on a synthetic
// pair of known disparity; and the errors every malformed calibration file must give.
#include "vision/stereo_calibration.h"
#include "vision/stereo_matcher.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include <unistd.h>

#include <opencv2/core/utils/logger.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "tests/test_util.h"
#include "vision/image_sources.h"

namespace vigil::vision {
namespace {

namespace fs = std::filesystem;

std::string real(const std::string& name) { return (test::shared_data() / "real" / name).string(); }

class StereoTest : public ::testing::Test {
 protected:
  void SetUp() override {
    cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT);
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("vigil_stereo_" + std::to_string(getpid()) + "_" + info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  void write_text(const std::string& name, const std::string& text) const {
    std::ofstream(path(name)) << text;
  }
  fs::path dir_;
};

// ---- The matcher on a synthetic pair of known disparity ----

// A textured pair where every pixel has disparity `d`: right(x) = left(x + d).
void shifted_pair(cv::Size size, int d, int channels, cv::Mat* left, cv::Mat* right) {
  cv::Mat texture(size.height, size.width + d, channels == 3 ? CV_8UC3 : CV_8UC1);
  cv::RNG(5).fill(texture, cv::RNG::UNIFORM, 0, 255);
  cv::GaussianBlur(texture, texture, cv::Size(3, 3), 0);
  *left = texture(cv::Rect(0, 0, size.width, size.height)).clone();
  *right = texture(cv::Rect(d, 0, size.width, size.height)).clone();
}

// Matching only where it is wanted gives the whole image's disparities there (the crops reach
// the search range to the left and a margin round), nothing elsewhere, and says where it matched;
// an empty mask or one covering most of the image matches everything.
TEST_F(StereoTest, MatchingInBoxesGivesTheWholeImagesDisparityThere) {
  cv::Mat l, r;
  shifted_pair({320, 240}, 12, 3, &l, &r);
  StereoMatcherParams p;
  p.num_disparities = 32;
  p.half_pixel_pass = true;
  auto m = StereoMatcher::create(p);
  ASSERT_TRUE(m.ok());
  auto full = m->compute(l, r);
  ASSERT_TRUE(full.ok());
  cv::Mat wanted = cv::Mat::zeros(l.size(), CV_8UC1);
  wanted(cv::Rect(150, 60, 30, 50)).setTo(255);   // one part...
  wanted(cv::Rect(10, 150, 20, 20)).setTo(255);   // ...one against the left edge...
  wanted(cv::Rect(186, 70, 10, 10)).setTo(255);   // ...and one that merges with the first
  cv::Mat measured;
  auto part = m->compute_in(l, r, wanted, &measured, 4);
  ASSERT_TRUE(part.ok()) << part.error().str();
  ASSERT_EQ(measured.size(), l.size());
  ASSERT_EQ(measured.type(), CV_8UC1);
  // Every wanted pixel measured; the measured area is the grown boxes, a small part of the image.
  EXPECT_EQ(cv::countNonZero(wanted & ~measured), 0);
  EXPECT_LT(cv::countNonZero(measured), l.total() / 8);
  int agree = 0, total = 0, outside_valid = 0;
  for (int y = 0; y < l.rows; ++y)
    for (int x = 0; x < l.cols; ++x) {
      const float d = part->at<float>(y, x);
      if (!measured.at<uint8_t>(y, x)) {
        outside_valid += d > 0;
        continue;
      }
      // The band at the left edge too: a box there is matched padded, as the whole image is.
      if (!wanted.at<uint8_t>(y, x) || x < 13 + 4) continue;  // no match either way left of the shift
      ++total;
      agree += std::abs(d - full->at<float>(y, x)) < 0.05f;
    }
  EXPECT_EQ(outside_valid, 0);
  ASSERT_GT(total, 1000);
  EXPECT_GT(static_cast<double>(agree) / total, 0.97) << agree << " of " << total;
  // Same input, same bytes.
  cv::Mat measured2;
  auto again = m->compute_in(l, r, wanted, &measured2, 4);
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(cv::norm(*again, *part, cv::NORM_INF), 0.0);
  // An empty mask, or one wanting most of the image: the whole pair, measured everywhere.
  auto all = m->compute_in(l, r, cv::Mat(), &measured);
  ASSERT_TRUE(all.ok());
  EXPECT_TRUE(measured.empty());
  EXPECT_EQ(cv::norm(*all, *full, cv::NORM_INF), 0.0);
  cv::Mat most = cv::Mat::zeros(l.size(), CV_8UC1);
  most(cv::Rect(0, 0, 300, 200)).setTo(255);
  auto big = m->compute_in(l, r, most, &measured);
  ASSERT_TRUE(big.ok());
  EXPECT_TRUE(measured.empty());
  // Nothing wanted: nothing matched.
  auto none = m->compute_in(l, r, cv::Mat::zeros(l.size(), CV_8UC1), &measured);
  ASSERT_TRUE(none.ok());
  EXPECT_EQ(cv::countNonZero(measured), 0);
  EXPECT_EQ(cv::countNonZero(*none > 0), 0);
  // A mask of another size or type is an error naming it.
  auto bad = m->compute_in(l, r, cv::Mat::zeros(10, 10, CV_8UC1), &measured);
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().key, "wanted");
  bad = m->compute_in(l, r, cv::Mat::zeros(l.size(), CV_32F), &measured);
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().key, "wanted");
}

TEST_F(StereoTest, BothAlgorithmsRecoverAKnownShift) {
  for (const StereoMatcherParams& params : {StereoMatcherParams{}, StereoMatcherParams::bm()}) {
    for (int channels : {1, 3}) {
      cv::Mat left, right;
      shifted_pair({320, 240}, 13, channels, &left, &right);
      auto matcher = StereoMatcher::create(params);
      ASSERT_TRUE(matcher.ok()) << matcher.error().str();
      auto d = matcher->compute(left, right);
      ASSERT_TRUE(d.ok()) << d.error().str();
      ASSERT_EQ(d->type(), CV_32F);
      ASSERT_EQ(d->size(), left.size());
      const cv::Rect inner(80, 20, 220, 200);  // past the search range and block borders
      const cv::Mat valid = (*d)(inner) > 0;
      const std::string what = std::string(params.algorithm == StereoAlgorithm::kBM ? "BM" : "SGBM") +
                               " with " + std::to_string(channels) + " channels";
      EXPECT_GT(cv::countNonZero(valid), 0.95 * inner.area()) << what;
      cv::Mat err;
      cv::absdiff((*d)(inner), 13.0, err);
      EXPECT_EQ(cv::countNonZero((err > 0.5) & valid), 0) << what;
      // The band OpenCV leaves unmatched (the search range's width at the left edge) is matched
      // where its match lies inside the right image (full_width, the default)...
      const cv::Rect band(13 + 4, 20, 80 - 17, 200);
      const cv::Mat band_valid = (*d)(band) > 0;
      EXPECT_GT(cv::countNonZero(band_valid), 0.9 * band.area()) << what;
      cv::absdiff((*d)(band), 13.0, err);
      EXPECT_EQ(cv::countNonZero((err > 0.5) & band_valid), 0) << what;
      // ...and pixels whose match would lie left of the right image are (nearly all) unmatched.
      EXPECT_LT(cv::countNonZero((*d)(cv::Rect(0, 0, 13, 240)) > 0), 0.01 * 13 * 240) << what;
      EXPECT_EQ((*d).at<float>(120, 2), StereoMatcher::kInvalidDisparity) << what;
      // Without full_width, OpenCV's band is unmatched: nothing valid in its first columns.
      StereoMatcherParams narrow = params;
      narrow.full_width = false;
      auto nd = StereoMatcher::create(narrow)->compute(left, right);
      ASSERT_TRUE(nd.ok());
      EXPECT_EQ(cv::countNonZero((*nd)(cv::Rect(0, 0, 60, 240)) > 0), 0) << what;
      EXPECT_EQ(cv::countNonZero((*nd)(inner) != (*d)(inner)) , 0) << what << ": the rest is unchanged";
    }
  }
}

// Sub-pixel disparities: SGBM's parabola fit pulls them towards whole pixels (pixel locking);
// the half-pixel pass cancels most of that bias. A textured pair shifted by fractional amounts.
TEST_F(StereoTest, HalfPixelPassCancelsPixelLocking) {
  cv::Mat texture(240, 400, CV_32F);
  cv::RNG(7).fill(texture, cv::RNG::UNIFORM, 0, 255);
  cv::GaussianBlur(texture, texture, cv::Size(), 1.5);
  cv::Mat left;
  texture.convertTo(left, CV_8U);
  StereoMatcherParams fit_params;
  StereoMatcherParams cancel_params;
  cancel_params.half_pixel_pass = true;
  auto fit = StereoMatcher::create(fit_params);
  auto cancel = StereoMatcher::create(cancel_params);
  ASSERT_TRUE(fit.ok() && cancel.ok());
  const cv::Rect inner(80, 20, 300, 200);
  auto median_error = [&](const cv::Mat& d, double truth) {
    std::vector<float> e;
    for (int y = inner.y; y < inner.y + inner.height; ++y)
      for (int x = inner.x; x < inner.x + inner.width; ++x)
        if (d.at<float>(y, x) > 0) e.push_back(d.at<float>(y, x) - static_cast<float>(truth));
    EXPECT_GT(e.size(), 0.9 * inner.area());
    std::nth_element(e.begin(), e.begin() + e.size() / 2, e.end());
    return e.empty() ? 99.0 : static_cast<double>(e[e.size() / 2]);
  };
  double worst_fit = 0, worst_cancel = 0;
  for (double d : {7.2, 7.25, 7.4, 7.6, 7.75}) {
    cv::Mat shifted, right;  // right(x) = left(x + d)
    cv::warpAffine(texture, shifted, cv::Matx23d(1, 0, -d, 0, 1, 0), texture.size(), cv::INTER_LINEAR,
                   cv::BORDER_REPLICATE);
    shifted.convertTo(right, CV_8U);
    auto a = fit->compute(left, right);
    auto b = cancel->compute(left, right);
    ASSERT_TRUE(a.ok() && b.ok());
    const double ea = median_error(*a, d), eb = median_error(*b, d);
    std::printf("[subpixel] d %.2f: median error fit %+.3f px, cancel %+.3f px\n", d, ea, eb);
    worst_fit = std::max(worst_fit, std::abs(ea));
    worst_cancel = std::max(worst_cancel, std::abs(eb));
  }
  EXPECT_GT(worst_fit, 0.2);  // the locking is there to cancel
  EXPECT_LT(worst_cancel, 0.15);
  EXPECT_LT(worst_cancel, 0.6 * worst_fit);
  // Whole disparities stay right (within a quarter pixel everywhere, unbiased), and invalid
  // pixels stay invalid.
  cv::Mat l13, r13;
  shifted_pair({400, 240}, 13, 1, &l13, &r13);
  auto whole = cancel->compute(l13, r13);
  ASSERT_TRUE(whole.ok());
  cv::Mat err;
  cv::absdiff((*whole)(inner), 13.0, err);
  EXPECT_EQ(cv::countNonZero(err > 0.25), 0);
  EXPECT_LT(std::abs(median_error(*whole, 13.0)), 0.05);
  EXPECT_EQ(whole->at<float>(120, 2), StereoMatcher::kInvalidDisparity);
}

TEST_F(StereoTest, MinDisparityShiftsTheSearchRange) {
  cv::Mat left, right;
  shifted_pair({320, 240}, 40, 3, &left, &right);
  StereoMatcherParams p;
  p.num_disparities = 16;  // searches 0..15: the true 40 is out of range
  auto narrow = StereoMatcher::create(p);
  ASSERT_TRUE(narrow.ok());
  auto miss = narrow->compute(left, right);
  ASSERT_TRUE(miss.ok());
  cv::Mat near40;
  cv::absdiff((*miss)(cv::Rect(100, 20, 200, 200)), 40.0, near40);
  EXPECT_LT(cv::countNonZero(near40 < 0.5), 200);
  p.min_disparity = 32;  // searches 32..47
  auto shifted = StereoMatcher::create(p);
  ASSERT_TRUE(shifted.ok());
  auto hit = shifted->compute(left, right);
  ASSERT_TRUE(hit.ok());
  cv::absdiff((*hit)(cv::Rect(100, 20, 200, 200)), 40.0, near40);
  EXPECT_GT(cv::countNonZero(near40 < 0.5), 0.95 * 200 * 200);
}

TEST_F(StereoTest, BadParametersAndInputsAreErrors) {
  struct Case {
    StereoMatcherParams params;
    std::string key;
  };
  std::vector<Case> cases;
  StereoMatcherParams p;
  p.num_disparities = 50;
  cases.push_back({p, "num_disparities"});
  p = {};
  p.num_disparities = 0;
  cases.push_back({p, "num_disparities"});
  p = {};
  p.block_size = 4;
  cases.push_back({p, "block_size"});
  p = StereoMatcherParams::bm();
  p.block_size = 3;
  cases.push_back({p, "block_size"});
  p = StereoMatcherParams::bm();
  p.pre_filter_cap = 100;
  cases.push_back({p, "pre_filter_cap"});
  p = {};
  p.p1 = 100;
  p.p2 = 50;
  cases.push_back({p, "p2"});
  p = {};
  p.speckle_range = -1;
  cases.push_back({p, "speckle_range"});
  for (const Case& c : cases) {
    auto m = StereoMatcher::create(c.params);
    ASSERT_FALSE(m.ok()) << c.key;
    EXPECT_EQ(m.error().key, c.key) << m.error().str();
  }
  auto m = StereoMatcher::create({});
  ASSERT_TRUE(m.ok());
  const cv::Mat a(240, 320, CV_8UC3, cv::Scalar::all(0)), b(240, 300, CV_8UC3, cv::Scalar::all(0));
  EXPECT_FALSE(m->compute(a, b).ok());                                   // sizes differ
  EXPECT_FALSE(m->compute(a, cv::Mat()).ok());                           // empty
  EXPECT_FALSE(m->compute(cv::Mat(240, 320, CV_16UC1), cv::Mat(240, 320, CV_16UC1)).ok());  // 16-bit
  EXPECT_FALSE(m->compute(a(cv::Rect(0, 0, 60, 40)), a(cv::Rect(0, 0, 60, 40))).ok());  // too narrow
  auto gray = m->compute(cv::Mat(240, 320, CV_8UC1, cv::Scalar(0)), a);
  ASSERT_FALSE(gray.ok());  // types differ
  EXPECT_NE(gray.error().message.find("320x240"), std::string::npos) << gray.error().str();
}

// ---- Middlebury Aloe ----

// Percentage of pixels with both a ground-truth and an estimated disparity whose estimate is off
// by more than `threshold` px, and the fraction of ground-truth pixels that got an estimate.
struct Score {
  double bad_percent = 100, coverage = 0;
};
Score score_against_gt(const cv::Mat& disparity, const cv::Mat& gt, double threshold) {
  int64_t known = 0, estimated = 0, bad = 0;
  for (int y = 0; y < gt.rows; ++y) {
    for (int x = 0; x < gt.cols; ++x) {
      const int g = gt.at<uint8_t>(y, x);
      if (g == 0) continue;
      ++known;
      const float d = disparity.at<float>(y, x);
      if (!(d > 0)) continue;
      ++estimated;
      if (std::abs(d - g) > threshold) ++bad;
    }
  }
  Score s;
  if (estimated > 0) s.bad_percent = 100.0 * bad / estimated;
  if (known > 0) s.coverage = static_cast<double>(estimated) / known;
  return s;
}

// aloeGT.png (see ../shared/data/real/README.md) is the ground-truth disparity of the left view
// at the full 1282x1110 size, one grey level per pixel of disparity (disparity = value, not
// value / 4 or value / 3 as in Middlebury's reduced-size sets), 0 = unknown; its known values
// span 43..211 px. So the pair is matched at full size with a search range of 0..223 px and
// scored directly against the PNG's values.
TEST_F(StereoTest, AloeThroughTheStereoSourceScoresUnderTenPercentBad) {
  VIGIL_REQUIRE_SHARED_DATA();
  const cv::Mat gt = cv::imread(real("aloeGT.png"), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(gt.type(), CV_8UC1);
  ASSERT_EQ(gt.size(), cv::Size(1282, 1110));
  double lo, hi;
  cv::minMaxLoc(gt, &lo, &hi, nullptr, nullptr, gt > 0);
  EXPECT_EQ(lo, 43);
  EXPECT_EQ(hi, 211);

  auto source = open_frame_source("stereo:" + real("aloeL.jpg") + "," + real("aloeR.jpg") +
                                  ";disparity=sgbm;num_disparities=224");
  ASSERT_TRUE(source.ok()) << source.error().str();
  StereoFrame frame;
  const auto t0 = std::chrono::steady_clock::now();
  Result<bool> got = (*source)->next(&frame);
  const double sgbm_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_TRUE(got.ok()) << got.error().str();
  ASSERT_TRUE(*got);
  ASSERT_EQ(frame.disparity.size(), gt.size());
  const Score sgbm = score_against_gt(frame.disparity, gt, 2.0);
  EXPECT_LT(sgbm.bad_percent, 10.0);
  EXPECT_GT(sgbm.coverage, 0.6);  // a matcher that answers nothing must not pass
  // The pair is one frame.
  Result<bool> end = (*source)->next(&frame);
  ASSERT_TRUE(end.ok());
  EXPECT_FALSE(*end);

  // BM on the same pair, through the matcher directly.
  StereoMatcherParams bm_params = StereoMatcherParams::bm();
  bm_params.num_disparities = 224;
  auto bm = StereoMatcher::create(bm_params);
  ASSERT_TRUE(bm.ok());
  const cv::Mat left = cv::imread(real("aloeL.jpg")), right = cv::imread(real("aloeR.jpg"));
  const auto t1 = std::chrono::steady_clock::now();
  auto bm_disparity = bm->compute(left, right);
  const double bm_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t1).count();
  ASSERT_TRUE(bm_disparity.ok());
  const Score bm_score = score_against_gt(*bm_disparity, gt, 2.0);
  EXPECT_LT(bm_score.bad_percent, 10.0);
  EXPECT_GT(bm_score.coverage, 0.5);

  // The scale matters: scored as if the PNG held disparity x 2, most pixels would be bad.
  cv::Mat halved;
  frame.disparity.convertTo(halved, CV_32F, 0.5);
  EXPECT_GT(score_against_gt(halved, gt, 2.0).bad_percent, 80.0);

  std::cout << "aloe 1282x1110, 224 disparities: SGBM " << sgbm.bad_percent << "% bad>2px over "
            << 100 * sgbm.coverage << "% of known pixels (" << sgbm_ms << " ms incl. reading); BM "
            << bm_score.bad_percent << "% over " << 100 * bm_score.coverage << "% (" << bm_ms
            << " ms)\n";
}

// ---- Chessboard calibration ----

TEST_F(StereoTest, CalibrateRealChessboardPairsAndRectifyThroughTheSource) {
  VIGIL_REQUIRE_SHARED_DATA();
  auto left = list_image_files(real("left%02d.jpg"));
  auto right = list_image_files(real("right%02d.jpg"));
  ASSERT_TRUE(left.ok()) << left.error().str();
  ASSERT_TRUE(right.ok()) << right.error().str();
  ASSERT_EQ(left->size(), 13u);
  ChessboardParams board;  // 9x6 inner corners
  board.square_size = 0.025;
  StereoCalibrationReport report;
  auto calibration = calibrate_stereo_chessboard(*left, *right, board, &report);
  ASSERT_TRUE(calibration.ok()) << calibration.error().str();
  EXPECT_EQ(report.used_pairs.size(), 13u);
  EXPECT_TRUE(report.skipped_pairs.empty());
  EXPECT_LT(report.left_rms, 1.0);
  EXPECT_LT(report.right_rms, 1.0);
  EXPECT_LT(report.stereo_rms, 1.0);
  EXPECT_GT(report.stereo_rms, 0.05);  // real corners are never that exact
  const StereoCalibration& c = *calibration;
  EXPECT_EQ(c.image_size, cv::Size(640, 480));
  EXPECT_DOUBLE_EQ(c.rms, report.stereo_rms);
  // A side-by-side rig: right camera to the right (T.x < 0), nearly parallel.
  EXPECT_LT(c.T.at<double>(0), 0);
  EXPECT_LT(std::abs(c.T.at<double>(1)), 0.1 * std::abs(c.T.at<double>(0)));
  EXPECT_LT(cv::norm(c.R - cv::Mat::eye(3, 3, CV_64F), cv::NORM_INF), 0.05);
  ASSERT_TRUE(c.has_rectification());
  std::cout << "chessboard calibration: stereo RMS " << report.stereo_rms << " px (left "
            << report.left_rms << ", right " << report.right_rms << "), baseline "
            << cv::norm(c.T) / board.square_size << " squares\n";

  // Saved and loaded back unchanged.
  ASSERT_TRUE(save_stereo_calibration(path("rig.yaml"), c).ok());
  auto loaded = load_stereo_calibration(path("rig.yaml"));
  ASSERT_TRUE(loaded.ok()) << loaded.error().str();
  for (const auto& [a, b] : {std::pair{&c.K1, &loaded->K1}, {&c.D1, &loaded->D1}, {&c.K2, &loaded->K2},
                             {&c.D2, &loaded->D2}, {&c.R, &loaded->R}, {&c.T, &loaded->T},
                             {&c.P1, &loaded->P1}, {&c.P2, &loaded->P2}, {&c.Q, &loaded->Q}}) {
    ASSERT_EQ(a->size(), b->size());
    EXPECT_LE(cv::norm(*a, *b, cv::NORM_INF), 1e-12 * std::max(1.0, cv::norm(*a, cv::NORM_INF)));
  }
  EXPECT_DOUBLE_EQ(loaded->rms, c.rms);

  // Through the stereo source: rectified pairs and the model from P1/P2.
  auto source = StereoSequenceSource::open(real("left%02d.jpg"), real("right%02d.jpg"),
                                           path("rig.yaml"));
  ASSERT_TRUE(source.ok()) << source.error().str();
  EXPECT_TRUE((*source)->rectifies());
  ASSERT_TRUE((*source)->camera_model().has_value());
  const StereoCameraModel model = *(*source)->camera_model();
  EXPECT_DOUBLE_EQ(model.intrinsics().fx, c.P1.at<double>(0, 0));
  EXPECT_DOUBLE_EQ(model.intrinsics().cx, c.P1.at<double>(0, 2));
  EXPECT_DOUBLE_EQ(model.intrinsics().cy, c.P1.at<double>(1, 2));
  EXPECT_NEAR(model.baseline(), -c.P2.at<double>(0, 3) / c.P2.at<double>(0, 0), 1e-12);
  EXPECT_NEAR(model.baseline(), cv::norm(c.T), 1e-9);  // rectification keeps the baseline

  // In every rectified pair the board's corners lie on the same rows, and triangulated with the
  // model they are one square apart.
  int pairs = 0;
  double sum_abs_dy = 0, sum_square = 0;
  int n_dy = 0, n_square = 0;
  StereoFrame frame;
  for (;;) {
    Result<bool> r = (*source)->next(&frame);
    ASSERT_TRUE(r.ok()) << r.error().str();
    if (!*r) break;
    ++pairs;
    auto cl = find_chessboard_corners(frame.left, board);
    auto cr = find_chessboard_corners(frame.right, board);
    if (!cl || !cr) continue;
    std::vector<Eigen::Vector3d> points;
    for (size_t i = 0; i < cl->size(); ++i) {
      const cv::Point2f l = (*cl)[i], rr = (*cr)[i];
      sum_abs_dy += std::abs(l.y - rr.y);
      ++n_dy;
      points.push_back(model.back_project(l.x, l.y, model.depth_from_disparity(l.x - rr.x)));
    }
    for (int y = 0; y < board.inner_corners.height; ++y) {
      for (int x = 0; x + 1 < board.inner_corners.width; ++x) {
        const int i = y * board.inner_corners.width + x;
        sum_square += (points[i + 1] - points[i]).norm();
        ++n_square;
      }
    }
  }
  EXPECT_EQ(pairs, 13);
  ASSERT_GT(n_dy, 9 * 54);  // the board is still found in most rectified pairs
  EXPECT_LT(sum_abs_dy / n_dy, 0.5);
  EXPECT_NEAR(sum_square / n_square, board.square_size, 0.02 * board.square_size);
}

TEST_F(StereoTest, TooFewBoardsIsAnError) {
  VIGIL_REQUIRE_SHARED_DATA();
  // A blank pair (no board) and one real pair: 1 pair < min_pairs (3).
  ASSERT_TRUE(cv::imwrite(path("blank.png"), cv::Mat(480, 640, CV_8UC1, cv::Scalar(128))));
  auto c = calibrate_stereo_chessboard({path("blank.png"), real("left01.jpg")},
                                       {path("blank.png"), real("right01.jpg")}, {});
  ASSERT_FALSE(c.ok());
  EXPECT_NE(c.error().str().find("only 1 of 2"), std::string::npos) << c.error().str();
  // left.jpg (612x459, two books) then left01.jpg (640x480): the second image is named.
  auto sizes = calibrate_stereo_chessboard({real("left.jpg"), real("left01.jpg")},
                                           {real("right.jpg"), real("right01.jpg")}, {});
  ASSERT_FALSE(sizes.ok());
  EXPECT_EQ(sizes.error().file, real("left01.jpg"));
  EXPECT_NE(sizes.error().message.find("612x459"), std::string::npos) << sizes.error().str();
  auto missing = calibrate_stereo_chessboard({real("left01.jpg")}, {path("nope.jpg")}, {});
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.error().file, path("nope.jpg"));
  auto uneven = calibrate_stereo_chessboard({real("left01.jpg")}, {}, {});
  ASSERT_FALSE(uneven.ok());
}

// ---- Calibration files ----

// A valid calibration file (an ideal rig) with `drop` removed and `extra` appended.
std::string calibration_yaml(const std::string& drop = "", const std::string& extra = "") {
  const std::vector<std::pair<std::string, std::string>> entries = {
      {"image_width", "image_width: 640\n"},
      {"image_height", "image_height: 480\n"},
      {"K1", "K1: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
             "   data: [ 500., 0., 319.5, 0., 500., 239.5, 0., 0., 1. ]\n"},
      {"D1", "D1: [ 0., 0., 0., 0., 0. ]\n"},
      {"K2", "K2: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
             "   data: [ 500., 0., 319.5, 0., 500., 239.5, 0., 0., 1. ]\n"},
      {"D2", "D2: [ 0., 0., 0., 0., 0. ]\n"},
      {"R", "R: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
            "   data: [ 1., 0., 0., 0., 1., 0., 0., 0., 1. ]\n"},
      {"T", "T: [ -0.09, 0., 0. ]\n"},
  };
  std::string text = "%YAML:1.0\n---\n";
  for (const auto& [key, value] : entries)
    if (key != drop) text += value;
  return text + extra;
}

TEST_F(StereoTest, HandWrittenCalibrationLoads) {
  write_text("rig.yaml", calibration_yaml());
  auto c = load_stereo_calibration(path("rig.yaml"));
  ASSERT_TRUE(c.ok()) << c.error().str();
  EXPECT_EQ(c->image_size, cv::Size(640, 480));
  EXPECT_EQ(c->D1.size(), cv::Size(5, 1));
  EXPECT_EQ(c->T.size(), cv::Size(1, 3));
  EXPECT_TRUE(c->is_rectified_rig());
  EXPECT_FALSE(c->has_rectification());
  auto model = rectified_camera_model(*c);
  ASSERT_TRUE(model.ok()) << model.error().str();
  EXPECT_DOUBLE_EQ(model->baseline(), 0.09);
  EXPECT_DOUBLE_EQ(model->intrinsics().fx, 500);
  // Swapped cameras (T.x > 0) are refused by the model.
  write_text("swapped.yaml", calibration_yaml("T", "T: [ 0.09, 0., 0. ]\n"));
  auto swapped = load_stereo_calibration(path("swapped.yaml"));
  ASSERT_TRUE(swapped.ok()) << swapped.error().str();
  auto bad_model = rectified_camera_model(*swapped);
  ASSERT_FALSE(bad_model.ok());
  EXPECT_EQ(bad_model.error().key, "T");
}

TEST_F(StereoTest, EveryMissingKeyIsNamed) {
  for (const char* key : {"image_width", "image_height", "K1", "D1", "K2", "D2", "R", "T"}) {
    write_text("rig.yaml", calibration_yaml(key));
    auto c = load_stereo_calibration(path("rig.yaml"));
    ASSERT_FALSE(c.ok()) << key;
    EXPECT_EQ(c.error().kind, ErrorKind::kBadInput);
    EXPECT_EQ(c.error().file, path("rig.yaml"));
    EXPECT_EQ(c.error().key, key);
    EXPECT_NE(c.error().message.find("missing"), std::string::npos) << c.error().str();
  }
}

TEST_F(StereoTest, MalformedValuesAreNamedWithTheirLine) {
  struct Case {
    std::string drop, extra, key, words;
    int line;  // of the key in the written file; 0 = not checked
  };
  // The full file has 22 lines (1 %YAML, 2 ---, 3 image_width, 4 image_height, 5-9 K1, 10 D1,
  // 11-15 K2, 16 D2, 17-21 R, 22 T); the replacement entry is appended after the others, so it
  // starts on line 22 when a one-line key was dropped and on line 18 for a five-line one.
  const std::vector<Case> cases = {
      {"image_width", "image_width: -640\n", "image_width", "positive", 22},
      {"image_height", "image_height: 479.5\n", "image_height", "integer", 22},
      {"image_width", "image_width: wide\n", "image_width", "integer", 22},
      {"D1", "D1: [ 0.1, 0.2, 0.3 ]\n", "D1", "coefficients", 22},
      {"T", "T: [ -0.09, 0. ]\n", "T", "3 numbers", 22},
      {"R", "R: [ 1., 0., 0., 0., 1., 0., 0., 0., 2. ]\n", "R", "rotation", 18},
      {"K2",
       "K2: !!opencv-matrix\n   rows: 2\n   cols: 2\n   dt: d\n   data: [ 1., 0., 0., 1. ]\n", "K2",
       "3x3", 18},
      {"K1", "K1: [ 0., 0., 319.5, 0., 500., 239.5, 0., 0., 1. ]\n", "K1", "focal", 18},
      {"T", "T: [ 0., 0., 0. ]\n", "T", "baseline", 22},
      {"", "P1: [ 500., 0., 319.5, 0., 0., 500., 239.5, 0., 0., 0., 1., 0. ]\n", "R1", "together", 0},
      {"D2", "D2: [ 0., .nan, 0., 0., 0. ]\n", "D2", "NaN", 22},
      {"D2", "D2: { a: 1 }\n", "D2", "matrix", 22},
  };
  for (const Case& c : cases) {
    write_text("rig.yaml", calibration_yaml(c.drop, c.extra));
    auto r = load_stereo_calibration(path("rig.yaml"));
    ASSERT_FALSE(r.ok()) << c.extra;
    EXPECT_EQ(r.error().file, path("rig.yaml"));
    EXPECT_EQ(r.error().key, c.key) << r.error().str();
    EXPECT_NE(r.error().message.find(c.words), std::string::npos) << r.error().str();
    if (c.line > 0) {
      EXPECT_EQ(r.error().line, c.line) << r.error().str();
    }
  }
}

TEST_F(StereoTest, FilesThatAreNotCalibrationsAreErrors) {
  // Not there.
  auto none = load_stereo_calibration(path("none.yaml"));
  ASSERT_FALSE(none.ok());
  EXPECT_EQ(none.error().file, path("none.yaml"));
  // Broken YAML: OpenCV's parser throws; the error still names the file.
  write_text("broken.yaml", "%YAML:1.0\n---\nimage_width: 640\nK1: [ 1, 2\n  nonsense: {{{\n");
  auto broken = load_stereo_calibration(path("broken.yaml"));
  ASSERT_FALSE(broken.ok());
  EXPECT_EQ(broken.error().file, path("broken.yaml"));
  EXPECT_GE(broken.error().line, 4) << broken.error().str();  // the parser's line
  EXPECT_NE(broken.error().message.find("malformed"), std::string::npos) << broken.error().str();
  // Random bytes.
  write_text("noise.yaml", std::string("\x01\x02\xff\xfe garbage \x7f", 14));
  auto noise = load_stereo_calibration(path("noise.yaml"));
  ASSERT_FALSE(noise.ok());
  EXPECT_EQ(noise.error().file, path("noise.yaml"));
  // OpenCV's stereo_calib.xml is an image list, not a calibration.
  if (test::have_shared_data()) {
    auto list = load_stereo_calibration(real("stereo_calib.xml"));
    ASSERT_FALSE(list.ok());
    EXPECT_EQ(list.error().file, real("stereo_calib.xml"));
    EXPECT_EQ(list.error().key, "image_width");
  }
}

TEST_F(StereoTest, XmlCalibrationRoundTrip) {
  write_text("rig.yaml", calibration_yaml());
  auto c = load_stereo_calibration(path("rig.yaml"));
  ASSERT_TRUE(c.ok());
  ASSERT_TRUE(compute_rectification(&*c).ok());
  ASSERT_TRUE(save_stereo_calibration(path("rig.xml"), *c).ok());
  auto x = load_stereo_calibration(path("rig.xml"));
  ASSERT_TRUE(x.ok()) << x.error().str();
  EXPECT_TRUE(x->has_rectification());
  EXPECT_EQ(cv::norm(x->P2, c->P2, cv::NORM_INF), 0);
  // A missing key in XML is named with its file too.
  std::ifstream in(path("rig.xml"));
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const size_t a = text.find("<K2"), b = text.find("</K2>");
  ASSERT_NE(a, std::string::npos);
  write_text("no_k2.xml", text.substr(0, a) + text.substr(b + 5));
  auto no_k2 = load_stereo_calibration(path("no_k2.xml"));
  ASSERT_FALSE(no_k2.ok());
  EXPECT_EQ(no_k2.error().key, "K2");
  EXPECT_EQ(no_k2.error().file, path("no_k2.xml"));
}

}  // namespace
}  // namespace vigil::vision

namespace vigil::vision {
namespace {

// One parser of COLSxROWS for `vigil calibrate stereo --board` and `vigil render --chessboard`.
TEST(StereoCalibration, BoardSizeParsesColsByRowsAndNamesTheKeyOnBadInput) {
  auto a = parse_board_size("9x6", "--board");
  ASSERT_TRUE(a) << a.error().str();
  EXPECT_EQ(*a, cv::Size(9, 6));
  auto b = parse_board_size("12X8", "--chessboard");
  ASSERT_TRUE(b);
  EXPECT_EQ(*b, cv::Size(12, 8));
  for (const char* bad : {"", "9", "9x", "x6", "9x6x2", "9*6", "1x6", "9x101", "9x6 extra"}) {
    auto r = parse_board_size(bad, "--board");
    ASSERT_FALSE(r) << "'" << bad << "' parsed";
    EXPECT_EQ(r.error().key, "--board");
    EXPECT_EQ(r.error().kind, ErrorKind::kBadInput);
  }
}

}  // namespace
}  // namespace vigil::vision
