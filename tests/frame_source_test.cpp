// Tests of vision/image_sources: the recorded frame sources (video file, image sequence, stereo
// sequence of image pairs or two videos, with and without a calibration), the spec factory, and
// the errors bad input must give instead of a crash: a missing, random or truncated video, an
// image that does not load, a frame of another size in the middle of a sequence, left and right
// streams that disagree, a calibration that is missing or does not fit the images.
#include "vision/image_sources.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include <unistd.h>

#include <opencv2/core/utils/logger.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "tests/test_util.h"

namespace vigil::vision {
namespace {

namespace fs = std::filesystem;

fs::path real(const std::string& name) { return test::shared_data() / "real" / name; }

// PREFIX + i + ".png", built by appending (GCC 12 warns falsely on "literal" + std::string).
std::string numbered(const char* prefix, int i) {
  std::string name(prefix);
  name += std::to_string(i);
  name += ".png";
  return name;
}

// A fresh scratch folder per test, removed afterwards; OpenCV's own logging silenced (FFmpeg's
// decoder still reports corrupt data on stderr).
class FrameSourceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT);
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("vigil_frame_source_" + std::to_string(getpid()) + "_" + info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string path(const std::string& name) const { return (dir_ / name).string(); }

  // A textured BGR image whose content depends on `seed`.
  static cv::Mat image(cv::Size size, int seed) {
    cv::Mat m(size, CV_8UC3);
    cv::RNG rng(seed);
    rng.fill(m, cv::RNG::UNIFORM, 0, 255);
    return m;
  }

  void write_image(const std::string& name, cv::Size size, int seed) const {
    ASSERT_TRUE(cv::imwrite(path(name), image(size, seed))) << path(name);
  }

  void write_bytes(const std::string& name, const std::string& bytes) const {
    std::ofstream out(path(name), std::ios::binary);
    out << bytes;
  }

  fs::path dir_;
};

// Reads every frame; returns the count, or fails the test on an error.
int64_t drain(FrameSource* source, std::vector<StereoFrame>* frames = nullptr) {
  int64_t n = 0;
  StereoFrame f;
  for (;;) {
    Result<bool> r = source->next(&f);
    EXPECT_TRUE(r.ok()) << r.error().str();
    if (!r.ok() || !*r) break;
    EXPECT_EQ(f.index, n);
    if (frames) frames->push_back(f);
    ++n;
  }
  return n;
}

// Reads until the first error and returns it (fails the test when there is none).
Error first_error(FrameSource* source, int64_t* frames_before = nullptr) {
  StereoFrame f;
  int64_t n = 0;
  for (int guard = 0; guard < 10000; ++guard) {
    Result<bool> r = source->next(&f);
    if (!r.ok()) {
      if (frames_before) *frames_before = n;
      return r.error();
    }
    if (!*r) break;
    ++n;
  }
  ADD_FAILURE() << "expected an error, the source ended cleanly after " << n << " frames";
  return Error{};
}

// ---- Video files ----

TEST_F(FrameSourceTest, VtestVideoHas795FramesOf768x576) {
  VIGIL_REQUIRE_SHARED_DATA();
  auto source = VideoFileSource::open(real("vtest.avi").string());
  ASSERT_TRUE(source.ok()) << source.error().str();
  VideoFileSource& v = **source;
  EXPECT_EQ(v.frame_size(), cv::Size(768, 576));
  EXPECT_EQ(v.announced_frame_count(), 795);
  EXPECT_DOUBLE_EQ(v.fps(), 10.0);
  EXPECT_FALSE(v.is_stereo());
  EXPECT_FALSE(v.camera_model().has_value());
  EXPECT_NE(v.describe().find("768x576"), std::string::npos) << v.describe();
  int64_t n = 0;
  StereoFrame f;
  for (;;) {
    Result<bool> r = v.next(&f);
    ASSERT_TRUE(r.ok()) << r.error().str();
    if (!*r) break;
    ASSERT_EQ(f.index, n);
    ASSERT_EQ(f.left.type(), CV_8UC3);
    ASSERT_EQ(f.left.size(), cv::Size(768, 576));
    ASSERT_EQ(f.stamp_ns, n * 100'000'000);  // 10 fps
    EXPECT_TRUE(f.right.empty() && f.disparity.empty() && f.depth.empty());
    ++n;
  }
  EXPECT_EQ(n, 795);
  // The end is sticky.
  Result<bool> again = v.next(&f);
  ASSERT_TRUE(again.ok());
  EXPECT_FALSE(*again);
}

TEST_F(FrameSourceTest, TreeVideoThroughTheFactory) {
  VIGIL_REQUIRE_SHARED_DATA();
  auto source = open_frame_source("video:" + real("tree.avi").string() + ";fps=30");
  ASSERT_TRUE(source.ok()) << source.error().str();
  std::vector<StereoFrame> frames;
  EXPECT_EQ(drain(source->get(), &frames), 68);
  ASSERT_EQ(frames.size(), 68u);
  EXPECT_EQ(frames[0].left.size(), cv::Size(320, 240));
  EXPECT_EQ(frames[3].stamp_ns, 100'000'000);  // the fps option overrides the file's 15
  // Frames differ (the foliage moves): the decoder is not returning one frame over and over.
  EXPECT_GT(cv::norm(frames[0].left, frames[40].left, cv::NORM_L1), 0.0);
}

TEST_F(FrameSourceTest, MissingVideoIsAnError) {
  auto source = VideoFileSource::open(path("nothing_here.avi"));
  ASSERT_FALSE(source.ok());
  EXPECT_EQ(source.error().kind, ErrorKind::kBadInput);
  EXPECT_EQ(source.error().file, path("nothing_here.avi"));
  EXPECT_NE(source.error().message.find("not found"), std::string::npos) << source.error().str();
  // A folder is not a video either.
  auto folder = VideoFileSource::open(dir_.string());
  ASSERT_FALSE(folder.ok());
  EXPECT_EQ(folder.error().file, dir_.string());
}

TEST_F(FrameSourceTest, RandomBytesVideoIsAnError) {
  std::mt19937 rng(1234);
  std::string bytes(20000, '\0');
  for (char& c : bytes) c = static_cast<char>(rng() & 0xff);
  write_bytes("x.avi", bytes);
  auto source = VideoFileSource::open(path("x.avi"));
  ASSERT_FALSE(source.ok());
  EXPECT_EQ(source.error().file, path("x.avi"));
  EXPECT_EQ(source.error().kind, ErrorKind::kBadInput);
  EXPECT_FALSE(source.error().message.empty());
  // The same through the factory.
  auto via_spec = open_frame_source("video:" + path("x.avi"));
  ASSERT_FALSE(via_spec.ok());
  EXPECT_NE(via_spec.error().str().find("x.avi"), std::string::npos) << via_spec.error().str();
  // An empty file too.
  write_bytes("empty.avi", "");
  auto empty = VideoFileSource::open(path("empty.avi"));
  ASSERT_FALSE(empty.ok());
  EXPECT_EQ(empty.error().file, path("empty.avi"));
}

TEST_F(FrameSourceTest, TruncatedVideoIsAnErrorOrEndsEarly) {
  VIGIL_REQUIRE_SHARED_DATA();
  std::ifstream in(real("vtest.avi"), std::ios::binary);
  std::string head(65536, '\0');
  in.read(head.data(), static_cast<std::streamsize>(head.size()));
  ASSERT_EQ(in.gcount(), 65536);
  // The first 4 KB hold only the AVI headers: no frame can be decoded.
  write_bytes("head4k.avi", head.substr(0, 4096));
  auto short_one = VideoFileSource::open(path("head4k.avi"));
  ASSERT_FALSE(short_one.ok());
  EXPECT_EQ(short_one.error().file, path("head4k.avi"));
  // The first 64 KB decode a few frames, then the file ends although its header announces 795.
  write_bytes("head64k.avi", head);
  auto lenient = VideoFileSource::open(path("head64k.avi"));
  ASSERT_TRUE(lenient.ok()) << lenient.error().str();
  EXPECT_EQ((*lenient)->announced_frame_count(), 795);
  const int64_t decoded = drain(lenient->get());
  EXPECT_GE(decoded, 1);
  EXPECT_LT(decoded, 795);
  VideoFileOptions strict;
  strict.require_announced_length = true;
  auto checked = VideoFileSource::open(path("head64k.avi"), strict);
  ASSERT_TRUE(checked.ok()) << checked.error().str();
  int64_t before = -1;
  const Error e = first_error(checked->get(), &before);
  EXPECT_EQ(before, decoded);
  EXPECT_EQ(e.file, path("head64k.avi"));
  EXPECT_NE(e.message.find("795"), std::string::npos) << e.str();
}

// ---- Image sequences ----

TEST_F(FrameSourceTest, PrintfPatternListsNumberedFilesInOrderWithGaps) {
  VIGIL_REQUIRE_SHARED_DATA();
  auto files = list_image_files((test::shared_data() / "real" / "left%02d.jpg").string());
  ASSERT_TRUE(files.ok()) << files.error().str();
  ASSERT_EQ(files->size(), 13u);  // left01..09, 11..14: there is no pair 10
  EXPECT_EQ(fs::path(files->front()).filename(), "left01.jpg");
  EXPECT_EQ(fs::path((*files)[8]).filename(), "left09.jpg");
  EXPECT_EQ(fs::path((*files)[9]).filename(), "left11.jpg");
  EXPECT_EQ(fs::path(files->back()).filename(), "left14.jpg");
  // The chessboard images are grey JPEGs; the source delivers 8-bit BGR at the chosen rate.
  ImageSequenceOptions options;
  options.fps = 4;
  auto source = ImageSequenceSource::open((test::shared_data() / "real" / "right%02d.jpg").string(),
                                          options);
  ASSERT_TRUE(source.ok()) << source.error().str();
  std::vector<StereoFrame> frames;
  EXPECT_EQ(drain(source->get(), &frames), 13);
  ASSERT_EQ(frames.size(), 13u);
  EXPECT_EQ(frames[5].left.type(), CV_8UC3);
  EXPECT_EQ(frames[5].left.size(), cv::Size(640, 480));
  EXPECT_EQ(frames[5].stamp_ns, 1'250'000'000);
  EXPECT_EQ(fs::path((*source)->last_frame_name()).filename(), "right14.jpg");
}

TEST_F(FrameSourceTest, PatternMatchingRules) {
  for (const char* name : {"f1.png", "f2.png", "f10.png", "f007.png", "g3.png", "f5.jpg"})
    write_image(name, {8, 8}, 1);
  auto plain = list_image_files(path("f%d.png"));
  ASSERT_TRUE(plain.ok()) << plain.error().str();
  ASSERT_EQ(plain->size(), 3u);  // f1, f2, f10 in numeric order; f007 is not how %d prints 7
  EXPECT_EQ(fs::path((*plain)[2]).filename(), "f10.png");
  auto padded = list_image_files(path("f%03d.png"));
  ASSERT_TRUE(padded.ok()) << padded.error().str();
  ASSERT_EQ(padded->size(), 1u);
  EXPECT_EQ(fs::path(padded->front()).filename(), "f007.png");
  auto glob = list_image_files(path("f*.png"));
  ASSERT_TRUE(glob.ok());
  ASSERT_EQ(glob->size(), 4u);  // sorted by name: f007, f1, f10, f2
  EXPECT_EQ(fs::path(glob->front()).filename(), "f007.png");
  auto one = list_image_files(path("?3.png"));
  ASSERT_TRUE(one.ok());
  EXPECT_EQ(one->size(), 1u);
  // Nothing matches / no folder / unsupported pattern: errors naming what failed.
  auto none = list_image_files(path("h%02d.png"));
  ASSERT_FALSE(none.ok());
  EXPECT_NE(none.error().str().find("h%02d.png"), std::string::npos) << none.error().str();
  auto no_dir = list_image_files(path("missing_dir/a%02d.png"));
  ASSERT_FALSE(no_dir.ok());
  EXPECT_NE(no_dir.error().file.find("missing_dir"), std::string::npos) << no_dir.error().str();
  auto bad = list_image_files(path("f%s.png"));
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("pattern"), std::string::npos) << bad.error().str();
}

TEST_F(FrameSourceTest, FrameOfAnotherSizeMidSequenceIsAnError) {
  for (int i = 0; i < 5; ++i)
    write_image(numbered("frame_", i), i == 3 ? cv::Size(64, 40) : cv::Size(64, 48), i);
  auto source = open_frame_source("images:" + path("frame_%d.png"));
  ASSERT_TRUE(source.ok()) << source.error().str();
  int64_t before = -1;
  const Error e = first_error(source->get(), &before);
  EXPECT_EQ(before, 3);
  EXPECT_EQ(e.kind, ErrorKind::kBadInput);
  EXPECT_EQ(e.file, path("frame_3.png"));
  EXPECT_NE(e.message.find("64x40"), std::string::npos) << e.str();
  EXPECT_NE(e.message.find("64x48"), std::string::npos) << e.str();
}

TEST_F(FrameSourceTest, RealSequenceWithAnOddSizedFirstImage) {
  VIGIL_REQUIRE_SHARED_DATA();
  // left*.jpg also matches left.jpg (612x459), which sorts first: left01.jpg (640x480) is then
  // the frame of another size.
  auto source = ImageSequenceSource::open((test::shared_data() / "real" / "left*.jpg").string());
  ASSERT_TRUE(source.ok()) << source.error().str();
  ASSERT_EQ((*source)->files().size(), 14u);
  const Error e = first_error(source->get());
  EXPECT_EQ(fs::path(e.file).filename(), "left01.jpg") << e.str();
  EXPECT_NE(e.message.find("612x459"), std::string::npos) << e.str();
}

TEST_F(FrameSourceTest, UnreadableImageMidSequenceIsAnError) {
  write_image("img_0.png", {32, 24}, 0);
  write_image("img_1.png", {32, 24}, 1);
  write_bytes("img_2.png", "this is not a PNG file");
  write_image("img_3.png", {32, 24}, 3);
  auto source = ImageSequenceSource::open(path("img_%d.png"));
  ASSERT_TRUE(source.ok()) << source.error().str();
  int64_t before = -1;
  const Error e = first_error(source->get(), &before);
  EXPECT_EQ(before, 2);
  EXPECT_EQ(e.file, path("img_2.png"));
  EXPECT_NE(e.message.find("cannot load"), std::string::npos) << e.str();
  // A file removed after listing fails the same way.
  auto again = ImageSequenceSource::open(path("img_%d.png"));
  ASSERT_TRUE(again.ok());
  fs::remove(path("img_0.png"));
  const Error gone = first_error(again->get());
  EXPECT_EQ(gone.file, path("img_0.png"));
}

// ---- Stereo sequences ----

TEST_F(FrameSourceTest, StereoImagePairsWithoutCalibration) {
  for (int i = 0; i < 3; ++i) {
    write_image(numbered("l", i), {96, 64}, i);
    write_image(numbered("r", i), {96, 64}, 10 + i);
  }
  auto source = open_frame_source("stereo:" + path("l%d.png") + "," + path("r%d.png"));
  ASSERT_TRUE(source.ok()) << source.error().str();
  EXPECT_TRUE((*source)->is_stereo());
  EXPECT_FALSE((*source)->camera_model().has_value());
  std::vector<StereoFrame> frames;
  EXPECT_EQ(drain(source->get(), &frames), 3);
  ASSERT_EQ(frames.size(), 3u);
  // Without calibration the pairs pass through unchanged.
  EXPECT_EQ(cv::norm(frames[1].left, image({96, 64}, 1), cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(frames[1].right, image({96, 64}, 11), cv::NORM_INF), 0);
  EXPECT_TRUE(frames[1].disparity.empty());
}

TEST_F(FrameSourceTest, StereoImageOfAnotherSizeIsAnError) {
  for (int i = 0; i < 3; ++i) {
    write_image(numbered("l", i), {96, 64}, i);
    write_image(numbered("r", i), i == 1 ? cv::Size(96, 60) : cv::Size(96, 64), i);
    write_image(numbered("s", i), {90, 64}, i);
  }
  // A right image that changes size mid-sequence.
  auto source = StereoSequenceSource::open(path("l%d.png"), path("r%d.png"), "");
  ASSERT_TRUE(source.ok()) << source.error().str();
  int64_t before = -1;
  const Error e = first_error(source->get(), &before);
  EXPECT_EQ(before, 1);
  EXPECT_EQ(e.file, path("r1.png"));
  EXPECT_NE(e.message.find("96x60"), std::string::npos) << e.str();
  // Right images all of another size than the left ones.
  auto mismatched = StereoSequenceSource::open(path("l%d.png"), path("s%d.png"), "");
  ASSERT_TRUE(mismatched.ok()) << mismatched.error().str();
  const Error m = first_error(mismatched->get(), &before);
  EXPECT_EQ(before, 0);
  EXPECT_EQ(m.file, path("s0.png"));
  EXPECT_NE(m.message.find(path("l0.png")), std::string::npos) << m.str();
  EXPECT_NE(m.message.find("90x64"), std::string::npos) << m.str();
}

TEST_F(FrameSourceTest, StereoListsOfDifferentLengthsAreAnError) {
  for (int i = 0; i < 3; ++i) write_image(numbered("l", i), {32, 32}, i);
  for (int i = 0; i < 2; ++i) write_image(numbered("r", i), {32, 32}, i);
  auto source = StereoSequenceSource::open(path("l%d.png"), path("r%d.png"), "");
  ASSERT_FALSE(source.ok());
  EXPECT_NE(source.error().message.find("2 images"), std::string::npos) << source.error().str();
  EXPECT_NE(source.error().message.find("r%d.png"), std::string::npos) << source.error().str();
}

TEST_F(FrameSourceTest, StereoVideosOfDifferentLengthsEndWithAnError) {
  // Two short MJPEG videos written here, the right one a frame shorter.
  for (const auto& [name, count] : {std::pair{"left.avi", 5}, std::pair{"right.avi", 4}}) {
    cv::VideoWriter writer(path(name), cv::CAP_FFMPEG, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'),
                           15, cv::Size(80, 60));
    if (!writer.isOpened()) GTEST_SKIP() << "no MJPEG writer in this OpenCV build";
    for (int i = 0; i < count; ++i) writer.write(image({80, 60}, i));
  }
  auto source = open_frame_source("stereo:" + path("left.avi") + "," + path("right.avi"));
  ASSERT_TRUE(source.ok()) << source.error().str();
  EXPECT_NE((*source)->describe().find("video"), std::string::npos) << (*source)->describe();
  int64_t before = -1;
  const Error e = first_error(source->get(), &before);
  EXPECT_EQ(before, 4);
  EXPECT_NE(e.file.find("left.avi"), std::string::npos) << e.str();
  EXPECT_NE(e.message.find("right.avi"), std::string::npos) << e.str();
}

// A calibration of an ideal, already rectified rig: f = 100 px, principal point at the centre,
// right camera 0.1 m to the right.
StereoCalibration ideal_rig(cv::Size size) {
  StereoCalibration c;
  c.image_size = size;
  c.K1 = (cv::Mat_<double>(3, 3) << 100, 0, (size.width - 1) / 2.0, 0, 100, (size.height - 1) / 2.0,
          0, 0, 1);
  c.K2 = c.K1.clone();
  c.D1 = cv::Mat::zeros(1, 5, CV_64F);
  c.D2 = cv::Mat::zeros(1, 5, CV_64F);
  c.R = cv::Mat::eye(3, 3, CV_64F);
  c.T = (cv::Mat_<double>(3, 1) << -0.1, 0, 0);
  return c;
}

TEST_F(FrameSourceTest, CalibrationOfARectifiedRigPassesImagesThrough) {
  for (int i = 0; i < 2; ++i) {
    write_image(numbered("l", i), {96, 64}, i);
    write_image(numbered("r", i), {96, 64}, 5 + i);
  }
  ASSERT_TRUE(save_stereo_calibration(path("rig.yaml"), ideal_rig({96, 64})).ok());
  StereoSequenceOptions options;
  options.pose = CameraPose{};
  options.pose->position = {1, 2, 3};
  auto source = StereoSequenceSource::open(path("l%d.png"), path("r%d.png"), path("rig.yaml"), options);
  ASSERT_TRUE(source.ok()) << source.error().str();
  EXPECT_FALSE((*source)->rectifies());
  ASSERT_TRUE((*source)->camera_model().has_value());
  const StereoCameraModel m = *(*source)->camera_model();
  EXPECT_DOUBLE_EQ(m.intrinsics().fx, 100);
  EXPECT_DOUBLE_EQ(m.intrinsics().cx, 47.5);
  EXPECT_DOUBLE_EQ(m.baseline(), 0.1);
  EXPECT_EQ(m.intrinsics().width, 96);
  EXPECT_TRUE(m.pose().position.isApprox(Eigen::Vector3d(1, 2, 3)));
  std::vector<StereoFrame> frames;
  EXPECT_EQ(drain(source->get(), &frames), 2);
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(cv::norm(frames[1].right, image({96, 64}, 6), cv::NORM_INF), 0);
}

TEST_F(FrameSourceTest, ImagesOfAnotherSizeThanTheCalibrationAreAnError) {
  write_image("l0.png", {96, 64}, 0);
  write_image("r0.png", {96, 64}, 1);
  ASSERT_TRUE(save_stereo_calibration(path("rig.yaml"), ideal_rig({640, 480})).ok());
  auto source = open_frame_source("stereo:" + path("l%d.png") + "," + path("r%d.png") + "," +
                                  path("rig.yaml"));
  ASSERT_TRUE(source.ok()) << source.error().str();
  const Error e = first_error(source->get());
  EXPECT_EQ(e.file, path("l0.png"));
  EXPECT_NE(e.message.find("640x480"), std::string::npos) << e.str();
  EXPECT_NE(e.message.find("96x64"), std::string::npos) << e.str();
  EXPECT_NE(e.message.find("rig.yaml"), std::string::npos) << e.str();
}

TEST_F(FrameSourceTest, CalibrationMissingAKeyIsAnErrorAtOpen) {
  write_image("l0.png", {96, 64}, 0);
  write_image("r0.png", {96, 64}, 1);
  {
    cv::FileStorage fs(path("rig.yaml"), cv::FileStorage::WRITE);
    const StereoCalibration c = ideal_rig({96, 64});
    fs << "image_width" << 96 << "image_height" << 64 << "K1" << c.K1 << "D1" << c.D1 << "K2"
       << c.K2 << "D2" << c.D2 << "R" << c.R;  // no T
  }
  auto source = open_frame_source("stereo:" + path("l%d.png") + "," + path("r%d.png") + "," +
                                  path("rig.yaml"));
  ASSERT_FALSE(source.ok());
  EXPECT_EQ(source.error().file, path("rig.yaml"));
  EXPECT_EQ(source.error().key, "T");
  EXPECT_NE(source.error().message.find("missing"), std::string::npos) << source.error().str();
  // A calibration that does not exist.
  auto none = StereoSequenceSource::open(path("l%d.png"), path("r%d.png"), path("none.yaml"));
  ASSERT_FALSE(none.ok());
  EXPECT_EQ(none.error().file, path("none.yaml"));
}

TEST_F(FrameSourceTest, StereoDisparityAndDepthFromACalibratedPair) {
  // A textured plane at constant disparity 8 px: right(x) = left(x + 8).
  const cv::Size size(160, 120);
  cv::Mat texture = image({size.width + 8, size.height}, 42);
  cv::GaussianBlur(texture, texture, cv::Size(3, 3), 0);
  ASSERT_TRUE(cv::imwrite(path("l0.png"), texture(cv::Rect(0, 0, size.width, size.height))));
  ASSERT_TRUE(cv::imwrite(path("r0.png"), texture(cv::Rect(8, 0, size.width, size.height))));
  ASSERT_TRUE(save_stereo_calibration(path("rig.yaml"), ideal_rig(size)).ok());
  auto source = open_frame_source("stereo:" + path("l0.png") + "," + path("r0.png") + "," +
                                  path("rig.yaml") + ";disparity=sgbm;num_disparities=32");
  ASSERT_TRUE(source.ok()) << source.error().str();
  StereoFrame f;
  Result<bool> r = (*source)->next(&f);
  ASSERT_TRUE(r.ok()) << r.error().str();
  ASSERT_TRUE(*r);
  ASSERT_EQ(f.disparity.type(), CV_32F);
  ASSERT_EQ(f.depth.type(), CV_32F);
  // Away from the left border (no match there), disparity 8 and depth f*b/d = 100*0.1/8 m.
  const cv::Rect inner(40, 10, 100, 100);
  const cv::Mat valid = f.disparity(inner) > 0;
  EXPECT_GT(cv::countNonZero(valid), 0.95 * inner.area());
  double lo, hi;
  cv::minMaxLoc(f.disparity(inner), &lo, &hi, nullptr, nullptr, valid);
  EXPECT_NEAR(lo, 8, 0.5);
  EXPECT_NEAR(hi, 8, 0.5);
  EXPECT_NEAR(cv::mean(f.depth(inner), valid)[0], 1.25, 0.05);
  // Invalid disparity has depth 0.
  EXPECT_EQ(cv::countNonZero((f.disparity <= 0) & (f.depth != 0)), 0);
}

// ---- The factory ----

TEST_F(FrameSourceTest, SpecErrorsNameTheirPart) {
  write_image("l0.png", {64, 48}, 0);
  const std::string pair = path("l%d.png") + "," + path("l%d.png");
  struct Case {
    std::string spec, expect;
  };
  const std::vector<Case> cases = {
      {"vtest.avi", "scheme"},
      {"camera:/dev/video0", "camera"},
      {"video:", "no path"},
      {"video:" + path("a.avi") + ";speed=2", "speed"},
      {"video:" + path("a.avi") + ";fps=abc", "fps"},
      {"images:" + path("l%d.png") + ";fps=-1", "fps"},
      {"stereo:" + path("l%d.png"), "LEFT,RIGHT"},
      {"stereo:" + pair + ";disparity=magic", "magic"},
      {"stereo:" + pair + ";num_disparities=64", "disparity=sgbm"},
      {"stereo:" + pair + ";disparity=sgbm;num_disparities=50", "num_disparities"},
      {"stereo:" + pair + ";disparity=bm;block_size=3", "block_size"},
      {"stereo:" + pair + ";disparity=sgbm;mode=fast", "mode"},
      {"stereo:" + pair + ";disparity=sgbm;subpixel=exact", "subpixel"},
      {"stereo:" + pair + ";subpixel=cancel", "disparity=sgbm"},
      {"stereo:" + pair + ";colour=1", "colour"},
      {"stereo:" + pair + ";disparity", "key=value"},
  };
  for (const Case& c : cases) {
    auto s = open_frame_source(c.spec);
    ASSERT_FALSE(s.ok()) << c.spec;
    EXPECT_NE(s.error().str().find(c.expect), std::string::npos)
        << c.spec << " gave: " << s.error().str();
  }
  // And a good one for contrast.
  auto ok = open_frame_source("stereo:" + pair + ";disparity=bm;num_disparities=16;block_size=5");
  EXPECT_TRUE(ok.ok()) << ok.error().str();
}

}  // namespace
}  // namespace vigil::vision
