// Re-identification of people by their clothes (vision/reid.h): the colour measure on a synthetic
// view whose colours are known, the distance, and the identity bookkeeping over frames.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "vision/reid.h"

namespace vigil::vision {
namespace {

constexpr double kDeg = M_PI / 180.0;

StereoCameraModel camera() {
  CameraPose pose;
  pose.position = Eigen::Vector3d(0, 0, 2.5);
  pose.pitch = 20 * kDeg;
  return StereoCameraModel(Intrinsics::from_hfov(320, 240, 60 * kDeg), 0.09, pose);
}

// A person as a flat board facing the camera at x = `at`, 0.5 m wide, 1.75 m tall: shirt above
// 0.82 m, trousers below; the rest of the view an empty grey room with no depth.
struct View {
  cv::Mat bgr, mask, depth;
};
View person_view(const StereoCameraModel& cam, double at, cv::Vec3b shirt, cv::Vec3b trousers) {
  View v;
  v.bgr = cv::Mat(240, 320, CV_8UC3, cv::Scalar(128, 128, 128));
  v.mask = cv::Mat::zeros(240, 320, CV_8U);
  v.depth = cv::Mat::zeros(240, 320, CV_32F);
  const Eigen::Isometry3d T = cam.map_from_optical();
  const Intrinsics& k = cam.intrinsics();
  for (int r = 0; r < 240; ++r)
    for (int c = 0; c < 320; ++c) {
      const Eigen::Vector3d ray = T.linear() * Eigen::Vector3d((c - k.cx) / k.fx, (r - k.cy) / k.fy, 1.0);
      if (ray.x() <= 0) continue;
      const double s = (at - T.translation().x()) / ray.x();
      const Eigen::Vector3d p = T.translation() + s * ray;
      if (std::abs(p.y()) > 0.25 || p.z() < 0 || p.z() > 1.75) continue;
      v.bgr.at<cv::Vec3b>(r, c) = p.z() > 0.82 ? shirt : trousers;
      v.mask.at<uint8_t>(r, c) = 255;
      v.depth.at<float>(r, c) = static_cast<float>(s);  // the ray's optical z is 1 per unit s
    }
  return v;
}

cv::Vec3f yuv_of(cv::Vec3b bgr) {
  cv::Mat one(1, 1, CV_8UC3, cv::Scalar(bgr[0], bgr[1], bgr[2])), out;
  cv::cvtColor(one, out, cv::COLOR_BGR2YUV);
  const cv::Vec3b y = out.at<cv::Vec3b>(0, 0);
  return {static_cast<float>(y[0]), static_cast<float>(y[1]), static_cast<float>(y[2])};
}

Track person_track(int id, double x, double y = 0) {
  Track t;
  t.id = id;
  t.cls = TrackClass::kPerson;
  t.x = x;
  t.y = y;
  t.height = 1.75;
  t.width = 0.5;
  return t;
}

// Both bands measured on enough pixels, each the colour of those clothes.
void expect_clothes(const Appearance& a, cv::Vec3b shirt, cv::Vec3b trousers) {
  ASSERT_GT(a.weight[0], 40);
  ASSERT_GT(a.weight[1], 40);
  const cv::Vec3f s = yuv_of(shirt), tr = yuv_of(trousers);
  for (int ch = 0; ch < 3; ++ch) {
    EXPECT_NEAR(a.yuv[ch], s[ch], 1.0) << "shirt channel " << ch;
    EXPECT_NEAR(a.yuv[3 + ch], tr[ch], 1.0) << "trousers channel " << ch;
  }
}

TEST(Reid, MeasuresTheShirtAndTheTrousers) {
  const StereoCameraModel cam = camera();
  const cv::Vec3b shirt(40, 40, 200), trousers(120, 60, 20);  // BGR: a red shirt, dark blue trousers
  const View v = person_view(cam, 4.0, shirt, trousers);
  const Appearance a = measure_appearance(v.bgr, v.mask, v.depth, cam, person_track(1, 4.0), ReidParams{});
  expect_clothes(a, shirt, trousers);
  // Pixels at another depth (someone behind her in the box) are not hers.
  ReidParams tight;
  tight.depth_tolerance = 0.05;
  const Appearance off = measure_appearance(v.bgr, v.mask, v.depth, cam, person_track(1, 5.0), tight);
  EXPECT_TRUE(off.empty());
  // Bad input gives nothing, not a crash.
  EXPECT_TRUE(measure_appearance(cv::Mat(), v.mask, v.depth, cam, person_track(1, 4.0), ReidParams{}).empty());
  EXPECT_TRUE(measure_appearance(v.bgr, v.mask, cv::Mat(), cam, person_track(1, 4.0), ReidParams{}).empty());
}

// A mono camera (the colour MSER system) has no depth: each row of her box is put at her
// distance from the camera, so the bands still fall on the shirt and the trousers.
TEST(Reid, MonoMeasuresTheShirtAndTheTrousersAtHerDistance) {
  const StereoCameraModel cam = camera();
  const cv::Vec3b shirt(40, 40, 200), trousers(120, 60, 20);
  View v = person_view(cam, 4.0, shirt, trousers);
  const cv::Rect box = cv::boundingRect(v.mask);
  ASSERT_FALSE(box.empty());
  const Appearance a = measure_appearance_mono(v.bgr, v.mask, box, cam, 4.0, 0.0, 1.75, ReidParams{});
  expect_clothes(a, shirt, trousers);
  // Placed at half her distance, her rows would lie nearer the camera's height: the shirt band
  // reads rows that are her trousers (the placement matters).
  const Appearance near = measure_appearance_mono(v.bgr, v.mask, box, cam, 2.0, 0.0, 1.75, ReidParams{});
  ASSERT_GT(near.weight[0], 0);
  EXPECT_NEAR(near.yuv[2], yuv_of(trousers)[2], 1.0);
  // Foreground outside her box is not hers; background inside it is not either.
  cv::Mat more = v.mask.clone();
  more(cv::Rect(0, 0, 20, 240)).setTo(255);
  v.bgr(cv::Rect(0, 0, 20, 240)).setTo(cv::Scalar(0, 255, 0));
  const Appearance same = measure_appearance_mono(v.bgr, more, box, cam, 4.0, 0.0, 1.75, ReidParams{});
  for (int i = 0; i < 6; ++i) EXPECT_FLOAT_EQ(same.yuv[i], a.yuv[i]);
  // Bad input gives nothing, not a crash.
  EXPECT_TRUE(measure_appearance_mono(cv::Mat(), v.mask, box, cam, 4.0, 0.0, 1.75, ReidParams{}).empty());
  EXPECT_TRUE(measure_appearance_mono(v.bgr, v.mask, cv::Rect(400, 0, 10, 10), cam, 4.0, 0.0, 1.75, ReidParams{}).empty());
  EXPECT_TRUE(measure_appearance_mono(v.bgr, v.mask, box, cam, NAN, 0.0, 1.75, ReidParams{}).empty());
  EXPECT_TRUE(measure_appearance_mono(v.bgr, v.mask, box, cam, 4.0, 0.0, 0.0, ReidParams{}).empty());
}

TEST(Reid, DistanceOverTheBandsBothKnow) {
  Appearance a, b;
  a.yuv = {100, 120, 130, 50, 128, 128};
  a.weight = {10, 10};
  b = a;
  EXPECT_DOUBLE_EQ(appearance_distance(a, b), 0.0);
  b.yuv[0] += 20;  // brightness counts half
  EXPECT_DOUBLE_EQ(appearance_distance(a, b), 10.0);
  b.yuv[4] += 30;  // the worse band decides
  EXPECT_DOUBLE_EQ(appearance_distance(a, b), 30.0);
  b.weight[1] = 0;  // legs unknown on one side: the shirt alone
  EXPECT_DOUBLE_EQ(appearance_distance(a, b), 10.0);
  b.weight[0] = 0;
  EXPECT_TRUE(std::isinf(appearance_distance(a, b)));
}

Appearance colours(float u, float v) {
  Appearance a;
  a.yuv = {100, u, v, 60, 128, 100};
  a.weight = {100, 100};
  return a;
}

// Runs frames: `who(frame)` lists the tracker's (id, colours) on each frame; the ids reported.
std::vector<std::vector<int>> run(Reidentifier& r, int frames, const std::function<std::vector<std::pair<int, Appearance>>(int)>& who) {
  std::vector<std::vector<int>> out;
  for (int f = 0; f < frames; ++f) {
    std::vector<Track> tracks;
    std::map<int, Appearance> seen;
    for (const auto& [id, a] : who(f)) {
      tracks.push_back(person_track(id, 1.0 * id));
      seen[id] = a;
    }
    r.apply(static_cast<int64_t>(f) * 66'666'667, &tracks, seen);
    std::vector<int> ids;
    for (const Track& t : tracks) ids.push_back(t.id);
    out.push_back(ids);
  }
  return out;
}

TEST(Reid, APersonWhoComesBackTakesHerIdAndSomebodyElseDoesNot) {
  // A (red shirt) is tracker id 1 for frames 0-29, gone 30-99, back as tracker id 7 from frame
  // 100; B (green shirt) is tracker id 8 from frame 100 too.
  Reidentifier r;
  const Appearance red = colours(90, 200), green = colours(60, 60);
  const auto ids = run(r, 130, [&](int f) {
    std::vector<std::pair<int, Appearance>> v;
    if (f < 30) v.emplace_back(1, red);
    if (f >= 100) {
      Appearance again = red;
      again.yuv[0] += 8;  // a little brighter where she comes back
      again.yuv[1] += 3;
      v.emplace_back(7, again);
      v.emplace_back(8, green);
    }
    return v;
  });
  EXPECT_EQ(ids[10], (std::vector<int>{1}));
  // Her own id until her colours are known (min_frames), then A's again; B keeps his.
  EXPECT_EQ(ids[100], (std::vector<int>{7, 8}));
  EXPECT_EQ(ids[129], (std::vector<int>{1, 8}));
  EXPECT_EQ(r.reidentified(), 1);
}

TEST(Reid, NoTakeoverWhenItIsAmbiguousTooLateOrTheLostOneIsHere) {
  const Appearance red = colours(90, 200), red2 = colours(92, 196), blue = colours(200, 90);
  {
    // Two lost people dressed alike: nobody's id is taken.
    Reidentifier r;
    const auto ids = run(r, 80, [&](int f) {
      std::vector<std::pair<int, Appearance>> v;
      if (f < 20) v.emplace_back(1, red), v.emplace_back(2, red2);
      if (f >= 50) v.emplace_back(9, colours(91, 198));  // as near to one as to the other
      return v;
    });
    EXPECT_EQ(ids[79], (std::vector<int>{9}));
    EXPECT_EQ(r.reidentified(), 0);
  }
  // Tracker id 1 dressed in red on frames 0-19, tracker id 9 in red from frame 50: the ids on
  // the last frame.
  auto lost_and_new = [&](const ReidParams& p) {
    Reidentifier r(p);
    return run(r, 80, [&](int f) {
      std::vector<std::pair<int, Appearance>> v;
      if (f < 20) v.emplace_back(1, red);
      if (f >= 50) v.emplace_back(9, red);
      return v;
    })[79];
  };
  EXPECT_EQ(lost_and_new({}), (std::vector<int>{1}));
  // Lost longer ago than the window.
  ReidParams short_window;
  short_window.window = 1.0;
  EXPECT_EQ(lost_and_new(short_window), (std::vector<int>{9}));
  {
    // Still here (tracked on the same frame): a new track dressed like her is somebody else.
    Reidentifier r;
    const auto ids = run(r, 60, [&](int f) {
      std::vector<std::pair<int, Appearance>> v;
      v.emplace_back(1, red);
      if (f >= 20) v.emplace_back(9, red2);
      return v;
    });
    EXPECT_EQ(ids[59], (std::vector<int>{1, 9}));
  }
  {
    // Another colour: no takeover; and once settled (45 reports) a track never changes id.
    Reidentifier r;
    const auto ids = run(r, 200, [&](int f) {
      std::vector<std::pair<int, Appearance>> v;
      if (f < 20) v.emplace_back(1, red);
      if (f >= 30) v.emplace_back(9, blue);
      return v;
    });
    for (int f = 30; f < 200; ++f) EXPECT_EQ(ids[f], (std::vector<int>{9})) << f;
  }
  // Off: ids pass through.
  ReidParams off;
  off.enabled = false;
  EXPECT_EQ(lost_and_new(off), (std::vector<int>{9}));
}

TEST(Reid, ATrackWhoseIdentityWasTakenGetsAnotherIfItComesBack) {
  // Tracker id 1 is lost, id 9 takes its identity, then the tracker re-acquires id 1 as well:
  // the two are never both 1 on a frame.
  Reidentifier r;
  const Appearance red = colours(90, 200);
  const auto ids = run(r, 90, [&](int f) {
    std::vector<std::pair<int, Appearance>> v;
    if (f < 20 || f >= 70) v.emplace_back(1, red);
    if (f >= 30) v.emplace_back(9, red);
    return v;
  });
  EXPECT_EQ(ids[60], (std::vector<int>{1}));
  ASSERT_EQ(ids[80].size(), 2u);
  EXPECT_NE(ids[80][0], ids[80][1]);
  EXPECT_EQ(ids[80][1], 1);
}

TEST(Reid, BadParametersAreNamed) {
  ReidParams p;
  p.max_distance = -1;
  EXPECT_EQ(p.validate().error().key, "max_distance");
  p = {};
  p.ambiguity_ratio = 0;
  EXPECT_EQ(p.validate().error().key, "ambiguity_ratio");
  p = {};
  p.min_frames = 0;
  EXPECT_EQ(p.validate().error().key, "min_frames");
  p = {};
  p.depth_tolerance = std::nan("");
  EXPECT_EQ(p.validate().error().key, "depth_tolerance");
  EXPECT_TRUE(ReidParams{}.validate().ok());
}

}  // namespace
}  // namespace vigil::vision
