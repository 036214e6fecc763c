// Plan-view maps and the plan-view template tracker (chapter sections 10.4.2 and 10.4.3):
// known geometry first (boxes ray-cast into a depth image from a camera of known pose), then the
// tracker on synthetic sequences (walkers, crossings, a bag, a robot, a disappearance, bad input),
// then rendered frames (OSMesa: ground-truth depth and labels) of a hand-built crossing and of
// the shipped dis_left_bag and dis_bag_taken scenarios, checked against the world's true
// positions; timings last. Disabled reports (--gtest_also_run_disabled_tests): the crowd
// scenario, and the left-bag run on noisy depth.
//
// Debugging aids: PV_DEBUG=1 prints every frame's truth, tracks and match scores, and identity
// switches; PV_DRAW=<dir> writes the camera view and the drawn plan view every 15 frames of the
// rendered scenarios.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "plugins/builtin.h"
#include "plugins/stereo_camera/osmesa_renderer.h"
#include "plugins/stereo_camera/render_scene.h"
#include "tests/test_util.h"
#include "vision/plan_view.h"
#include "vision/planview_tracker.h"
#include "world/world.h"

namespace vigil::vision {
namespace {

using Eigen::Vector2d;
using Eigen::Vector3d;

constexpr double kDeg = M_PI / 180;

StereoCameraModel camera_at(const Vector3d& position, double yaw_deg, double pitch_deg, int w = 640, int h = 480) {
  CameraPose pose;
  pose.position = position;
  pose.yaw = yaw_deg * kDeg;
  pose.pitch = pitch_deg * kDeg;
  return StereoCameraModel(Intrinsics::from_hfov(w, h, 60 * kDeg), 0.09, pose);
}

// An axis-aligned box of the map frame standing on the floor (or at z0).
struct Box {
  Vector3d min, max;
  static Box on_floor(double cx, double cy, double sx, double sy, double sz, double z0 = 0) {
    return {Vector3d(cx - sx / 2, cy - sy / 2, z0), Vector3d(cx + sx / 2, cy + sy / 2, z0 + sz)};
  }
};

struct Synthetic {
  cv::Mat depth;  // CV_32F, metres along the optical axis (floor included)
  cv::Mat mask;   // 255 on the boxes
};

// Ray-casts the boxes and the floor z = 0: exact depth of every pixel.
Synthetic raycast(const StereoCameraModel& cam, const std::vector<Box>& boxes) {
  const Intrinsics& k = cam.intrinsics();
  const Eigen::Matrix3d R = cam.map_from_optical().linear();
  const Vector3d C = cam.map_from_optical().translation();
  Synthetic s;
  s.depth = cv::Mat::zeros(k.height, k.width, CV_32F);
  s.mask = cv::Mat::zeros(k.height, k.width, CV_8U);
  for (int v = 0; v < k.height; ++v) {
    for (int u = 0; u < k.width; ++u) {
      // The ray's parameter is the depth Z: its optical-frame direction has z = 1.
      const Vector3d d = R * Vector3d((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0);
      double best = std::numeric_limits<double>::infinity();
      bool on_box = false;
      for (const Box& b : boxes) {
        double t0 = 0, t1 = std::numeric_limits<double>::infinity();
        bool miss = false;
        for (int a = 0; a < 3 && !miss; ++a) {
          if (std::abs(d[a]) < 1e-12) {
            miss = C[a] < b.min[a] || C[a] > b.max[a];
            continue;
          }
          double ta = (b.min[a] - C[a]) / d[a], tb = (b.max[a] - C[a]) / d[a];
          if (ta > tb) std::swap(ta, tb);
          t0 = std::max(t0, ta);
          t1 = std::min(t1, tb);
          miss = t0 > t1;
        }
        if (!miss && t0 < best) {
          best = t0;
          on_box = true;
        }
      }
      if (d.z() < 0) {
        const double tf = -C.z() / d.z();
        if (tf < best) {
          best = tf;
          on_box = false;
        }
      }
      if (std::isfinite(best)) {
        s.depth.at<float>(v, u) = static_cast<float>(best);
        if (on_box) s.mask.at<uint8_t>(v, u) = 255;
      }
    }
  }
  return s;
}

// Bounding rectangle (map frame) of the non-zero cells of a map.
PlanViewRegion nonzero_extent(const PlanView& pv, const cv::Mat& map) {
  cv::Mat nz;
  cv::findNonZero(map > 0, nz);
  const cv::Rect r = cv::boundingRect(nz);
  const Vector2d a = pv.grid.to_map(r.x, r.y), b = pv.grid.to_map(r.x + r.width - 1, r.y + r.height - 1);
  return {a.x(), a.y(), b.x(), b.y()};
}

// ============================================================== plan-view maps, known geometry

TEST(PlanView, BoxOnTheFloorLandsWhereItIsWithItsHeight) {
  const auto cam = camera_at(Vector3d(0, 0, 2.5), 0, 20);
  const Box box = Box::on_floor(4.0, 0.5, 0.5, 0.4, 1.0);
  const Synthetic s = raycast(cam, {box});
  auto b = PlanViewBuilder::create(cam);
  ASSERT_TRUE(b.ok()) << b.error().str();
  PlanView pv;
  ASSERT_TRUE(b->build(s.mask, s.depth, &pv).ok());
  EXPECT_EQ(pv.invalid_depth, 0);
  EXPECT_EQ(pv.out_of_region, 0);
  EXPECT_GT(pv.points, 5000);
  // Every visible point of the box lies over its footprint: the occupied cells span it (1 cell).
  const double cell = pv.grid.cell;
  const PlanViewRegion e = nonzero_extent(pv, pv.occupancy);
  EXPECT_NEAR(e.x_min, box.min.x(), 1.0 * cell);
  EXPECT_NEAR(e.x_max, box.max.x(), 1.0 * cell);
  EXPECT_NEAR(e.y_min, box.min.y(), 1.0 * cell);
  EXPECT_NEAR(e.y_max, box.max.y(), 1.0 * cell);
  // After the refinement the blob is centred on the box within 2 cells, grown by the smoothing
  // kernel at most (3 sigma, plus a cell).
  const PlanViewRegion m = nonzero_extent(pv, pv.mask);
  EXPECT_NEAR((m.x_min + m.x_max) / 2, 4.0, 2 * cell);
  EXPECT_NEAR((m.y_min + m.y_max) / 2, 0.5, 2 * cell);
  const double grow = (3 * 1.5 + 1) * cell;
  EXPECT_LE(m.x_min, box.min.x() + cell);
  EXPECT_GE(m.x_min, box.min.x() - grow);
  EXPECT_GE(m.x_max, box.max.x() - cell);
  EXPECT_LE(m.x_max, box.max.x() + grow);
  EXPECT_LE(m.y_min, box.min.y() + cell);
  EXPECT_GE(m.y_min, box.min.y() - grow);
  EXPECT_GE(m.y_max, box.max.y() - cell);
  EXPECT_LE(m.y_max, box.max.y() + grow);
  // The height map reads the top (the camera at 2.5 m sees it), everywhere over the top.
  double hmax = 0;
  cv::minMaxLoc(pv.height, nullptr, &hmax);
  EXPECT_NEAR(hmax, 1.0, 0.01);
  const Vector2d c = pv.grid.to_cell(4.0, 0.5);
  EXPECT_NEAR(pv.height_masked.at<float>(static_cast<int>(std::lround(c.y())), static_cast<int>(std::lround(c.x()))),
              1.0, 0.01);
  // The front face (x = 3.75) is the densest column of cells.
  cv::Point peak;
  cv::minMaxLoc(pv.occupancy, nullptr, nullptr, nullptr, &peak);
  EXPECT_NEAR(pv.grid.to_map(peak.x, peak.y).x(), box.min.x(), 1.0 * cell);
  // Nothing outside the active rectangle.
  cv::Mat outside = pv.occupancy.clone();
  outside(pv.active).setTo(0);
  EXPECT_EQ(cv::countNonZero(outside), 0);
}

TEST(PlanView, RotatedCameraAndExplicitRegion) {
  // A camera in a corner looking back along -x and to the side: the blob must follow the map frame.
  const auto cam = camera_at(Vector3d(10, 5, 2.2), 150, 25);
  const Box box = Box::on_floor(7.0, 6.0, 0.4, 0.4, 0.8);
  const Synthetic s = raycast(cam, {box});
  PlanViewParams prm;
  prm.region = PlanViewRegion{4, 3, 10, 9};
  auto b = PlanViewBuilder::create(cam, prm);
  ASSERT_TRUE(b.ok()) << b.error().str();
  EXPECT_EQ(b->grid().cols, 300);
  EXPECT_EQ(b->grid().rows, 300);
  PlanView pv;
  ASSERT_TRUE(b->build(s.mask, s.depth, &pv).ok());
  const PlanViewRegion e = nonzero_extent(pv, pv.occupancy);
  EXPECT_NEAR(e.x_min, box.min.x(), 0.02);
  EXPECT_NEAR(e.x_max, box.max.x(), 0.02);
  EXPECT_NEAR(e.y_min, box.min.y(), 0.02);
  EXPECT_NEAR(e.y_max, box.max.y(), 0.02);
  double hmax = 0;
  cv::minMaxLoc(pv.height, nullptr, &hmax);
  EXPECT_NEAR(hmax, 0.8, 0.01);
  // The same frame again gives the same maps (buffers reused, old data cleared).
  PlanView again = pv;
  again.occupancy = pv.occupancy.clone();
  ASSERT_TRUE(b->build(raycast(cam, {}).mask, s.depth, &pv).ok());
  EXPECT_EQ(cv::countNonZero(pv.occupancy), 0);
  EXPECT_EQ(cv::countNonZero(pv.mask), 0);
  EXPECT_TRUE(pv.active.empty());
  ASSERT_TRUE(b->build(s.mask, s.depth, &pv).ok());
  EXPECT_EQ(cv::norm(pv.occupancy, again.occupancy, cv::NORM_INF), 0.0);
}

TEST(PlanView, OccupancyOfAnObjectDoesNotDependOnItsDistance) {
  // A board facing a level camera: its occupancy total (Z^2/f weighting) is its area, at 3 m and
  // at 6 m, and at any image resolution.
  std::map<std::string, double> area;
  for (const int w : {640, 320}) {
    const auto cam = camera_at(Vector3d(0, 0, 1.0), 0, 0, w, w * 3 / 4);
    for (const double x : {3.0, 6.0}) {
      const Box board{Vector3d(x, -0.3, 0.1), Vector3d(x + 0.02, 0.3, 1.7)};
      const Synthetic s = raycast(cam, {board});
      auto b = PlanViewBuilder::create(cam);
      ASSERT_TRUE(b.ok()) << b.error().str();
      PlanView pv;
      ASSERT_TRUE(b->build(s.mask, s.depth, &pv).ok());
      const double a = cv::sum(pv.occupancy)[0] * pv.grid.cell * pv.grid.cell;
      area[std::to_string(w) + "@" + std::to_string(static_cast<int>(x))] = a;
      EXPECT_NEAR(a, 0.6 * 1.6, 0.05) << "image width " << w << ", board at " << x << " m";
      // The smoothed map keeps the total.
      EXPECT_NEAR(cv::sum(pv.occupancy_smoothed)[0], cv::sum(pv.occupancy)[0], 1e-3 * cv::sum(pv.occupancy)[0]);
    }
  }
  EXPECT_NEAR(area["640@3"] / area["640@6"], 1.0, 0.03);
  EXPECT_NEAR(area["320@3"] / area["320@6"], 1.0, 0.03);
  EXPECT_NEAR(area["640@3"] / area["320@3"], 1.0, 0.03);
  RecordProperty("area_3m_m2", std::to_string(area["640@3"]));
  RecordProperty("area_6m_m2", std::to_string(area["640@6"]));
}

TEST(PlanView, InvalidDepthIsSkipped) {
  const auto cam = camera_at(Vector3d(0, 0, 2.5), 0, 20, 320, 240);
  const Synthetic s = raycast(cam, {Box::on_floor(4.0, 0.0, 0.5, 0.5, 1.2)});
  cv::Mat depth = s.depth.clone(), mask_without = s.mask.clone();
  // Spoil four runs of the box's pixels with each kind of invalid depth.
  const float bad[] = {0.0f, std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(), -2.0f};
  int spoiled = 0, k = 0;
  for (int v = 0; v < depth.rows; ++v)
    for (int u = 0; u < depth.cols; ++u)
      if (s.mask.at<uint8_t>(v, u) && (u + v) % 3 == 0) {
        depth.at<float>(v, u) = bad[k++ % 4];
        mask_without.at<uint8_t>(v, u) = 0;
        ++spoiled;
      }
  ASSERT_GT(spoiled, 100);
  auto b = PlanViewBuilder::create(cam);
  ASSERT_TRUE(b.ok());
  PlanView with_bad, without;
  ASSERT_TRUE(b->build(s.mask, depth, &with_bad).ok());
  ASSERT_TRUE(b->build(mask_without, s.depth, &without).ok());
  EXPECT_EQ(with_bad.invalid_depth, spoiled);
  EXPECT_EQ(with_bad.points, without.points);
  EXPECT_EQ(cv::norm(with_bad.occupancy, without.occupancy, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(with_bad.height, without.height, cv::NORM_INF), 0.0);
  // Background pixels are never looked at, whatever their depth.
  cv::Mat junk = s.depth.clone();
  junk.setTo(std::numeric_limits<float>::quiet_NaN(), s.mask == 0);
  PlanView pv;
  ASSERT_TRUE(b->build(s.mask, junk, &pv).ok());
  EXPECT_EQ(pv.invalid_depth, 0);
  // Floor and ceiling noise: points under min_height or over max_height are dropped.
  const Synthetic tall = raycast(cam, {Box::on_floor(4.0, 0.0, 0.5, 0.5, 2.6)});
  ASSERT_TRUE(b->build(tall.mask, tall.depth, &pv).ok());
  EXPECT_GT(pv.out_of_band, 0);
  double hmax = 0;
  cv::minMaxLoc(pv.height, nullptr, &hmax);
  EXPECT_LE(hmax, 2.2 + 1e-6);
}

TEST(PlanView, CameraLookingAboveTheHorizonIsAnError) {
  // Pitched up 40 deg (vertical field of view 47 deg): every ray rises, the floor is behind it.
  const auto up = camera_at(Vector3d(0, 0, 2.0), 0, -40);
  auto b = PlanViewBuilder::create(up);
  ASSERT_FALSE(b.ok());
  EXPECT_EQ(b.error().kind, ErrorKind::kBadInput);
  EXPECT_NE(b.error().message.find("horizon"), std::string::npos) << b.error().str();
  EXPECT_NE(b.error().message.find("behind"), std::string::npos) << b.error().str();
  // Also with an explicit region.
  PlanViewParams prm;
  prm.region = PlanViewRegion{0, -3, 6, 3};
  EXPECT_FALSE(PlanViewBuilder::create(up, prm).ok());
  EXPECT_FALSE(camera_footprint(up, 8.0).ok());
  // A camera under the floor.
  auto under = PlanViewBuilder::create(camera_at(Vector3d(0, 0, -0.5), 0, 20));
  ASSERT_FALSE(under.ok());
  EXPECT_NE(under.error().message.find("not above the floor"), std::string::npos) << under.error().str();
  // A level camera sees the floor in the lower half of its image: accepted, and its footprint
  // reaches max_range ahead.
  auto level = camera_footprint(camera_at(Vector3d(0, 0, 1.5), 0, 0), 8.0);
  ASSERT_TRUE(level.ok()) << level.error().str();
  EXPECT_NEAR(level->x_max, 8.0, 0.05);
  EXPECT_NEAR(level->x_min, 0.0, 0.05);
  // Slightly up (5 deg) still sees the floor: accepted.
  EXPECT_TRUE(PlanViewBuilder::create(camera_at(Vector3d(0, 0, 2.0), 0, -5)).ok());
}

TEST(PlanView, BadInputIsAnError) {
  const auto cam = camera_at(Vector3d(0, 0, 2.5), 0, 20, 320, 240);
  auto b = PlanViewBuilder::create(cam);
  ASSERT_TRUE(b.ok());
  PlanView pv;
  const cv::Mat mask = cv::Mat::zeros(240, 320, CV_8U), depth = cv::Mat::zeros(240, 320, CV_32F);
  Status s = b->build(cv::Mat::zeros(480, 640, CV_8U), cv::Mat::zeros(480, 640, CV_32F), &pv);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("640x480"), std::string::npos) << s.error().str();
  EXPECT_NE(s.error().message.find("320x240"), std::string::npos) << s.error().str();
  s = b->build(mask, cv::Mat::zeros(240, 320, CV_16U), &pv);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().key, "depth");
  s = b->build(cv::Mat::zeros(240, 320, CV_8UC3), depth, &pv);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().key, "foreground");
  PlanViewParams prm;
  prm.cell_size = 0;
  auto bad = PlanViewBuilder::create(cam, prm);
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().key, "cell_size");
  prm = {};
  prm.min_height = 2.5;
  EXPECT_FALSE(PlanViewBuilder::create(cam, prm).ok());
  prm = {};
  prm.region = PlanViewRegion{0, 0, 1000, 1000};
  auto huge = PlanViewBuilder::create(cam, prm);
  ASSERT_FALSE(huge.ok());
  EXPECT_EQ(huge.error().key, "region");
}

// ============================================================== tracker on synthetic sequences

constexpr double kRate = 15.0;  // Hz, the cameras' rate

int64_t stamp_of(int frame) { return static_cast<int64_t>(std::llround(frame * 1e9 / kRate)); }

struct Truth {
  std::string name;
  Vector2d xy;
};

// Associates true objects with tracks frame by frame (keeping last frame's pairing while it is
// within the gate, as CLEAR-MOT does), and keeps the statistics.
class Scorer {
 public:
  explicit Scorer(double gate = 0.5) : gate_(gate) {}
  void add(const std::vector<Truth>& truth, const std::vector<Track>& tracks) {
    std::vector<bool> used(tracks.size(), false);
    std::vector<int> pick(truth.size(), -1);
    for (size_t g = 0; g < truth.size(); ++g) {
      auto it = last_.find(truth[g].name);
      if (it == last_.end()) continue;
      for (size_t k = 0; k < tracks.size(); ++k)
        if (!used[k] && tracks[k].id == it->second && dist(truth[g], tracks[k]) < gate_) {
          used[k] = true;
          pick[g] = static_cast<int>(k);
        }
    }
    struct Pair {
      double d;
      size_t g, k;
    };
    std::vector<Pair> pairs;
    for (size_t g = 0; g < truth.size(); ++g)
      for (size_t k = 0; k < tracks.size(); ++k)
        if (pick[g] < 0 && !used[k] && dist(truth[g], tracks[k]) < gate_)
          pairs.push_back({dist(truth[g], tracks[k]), g, k});
    std::sort(pairs.begin(), pairs.end(), [](const Pair& a, const Pair& b) { return a.d < b.d; });
    for (const Pair& p : pairs)
      if (pick[p.g] < 0 && !used[p.k]) {
        pick[p.g] = static_cast<int>(p.k);
        used[p.k] = true;
      }
    for (size_t g = 0; g < truth.size(); ++g) {
      Stats& s = stats_[truth[g].name];
      ++s.frames;
      if (pick[g] < 0) {
        ++s.missed;
        continue;
      }
      const Track& t = tracks[pick[g]];
      const double d = dist(truth[g], t);
      ++s.matched;
      s.err_sum += d;
      s.err_max = std::max(s.err_max, d);
      auto it = last_.find(truth[g].name);
      if (it != last_.end() && it->second != t.id) {
        ++s.switches;
        if (std::getenv("PV_DEBUG")) std::printf("SWITCH %s: %d -> %d\n", truth[g].name.c_str(), it->second, t.id);
      }
      last_[truth[g].name] = t.id;
      s.ids.insert(t.id);
      s.last_class = t.cls;
    }
    for (size_t k = 0; k < tracks.size(); ++k) extra_ += !used[k];
  }
  struct Stats {
    int frames = 0, matched = 0, missed = 0, switches = 0;
    double err_sum = 0, err_max = 0;
    std::set<int> ids;
    TrackClass last_class = TrackClass::kUnknown;
    double mean() const { return matched ? err_sum / matched : 0; }
  };
  const std::map<std::string, Stats>& stats() const { return stats_; }
  int total_switches() const {
    int n = 0;
    for (const auto& [k, s] : stats_) n += s.switches;
    return n;
  }
  double mean_error() const {
    double e = 0;
    int n = 0;
    for (const auto& [k, s] : stats_) {
      e += s.err_sum;
      n += s.matched;
    }
    return n ? e / n : 0;
  }
  int extra() const { return extra_; }
  std::string summary() const {
    std::string out;
    char buf[200];
    for (const auto& [k, s] : stats_) {
      std::snprintf(buf, sizeof buf,
                    "%s: %d frames, %d matched, mean error %.3f m, max %.3f m, %d switches, %zu ids, %s; ",
                    k.c_str(), s.frames, s.matched, s.mean(), s.err_max, s.switches, s.ids.size(),
                    std::string(to_string(s.last_class)).c_str());
      out += buf;
    }
    std::snprintf(buf, sizeof buf, "unmatched track-frames %d", extra_);
    return out + buf;
  }

 private:
  static double dist(const Truth& g, const Track& t) { return std::hypot(g.xy.x() - t.x, g.xy.y() - t.y); }
  double gate_;
  std::map<std::string, int> last_;
  std::map<std::string, Stats> stats_;
  int extra_ = 0;
};

// A synthetic object: a box whose centre follows `where(t)` (nullopt: absent).
struct Mover {
  std::string name;
  Vector3d size;
  std::function<std::optional<Vector2d>(double)> where;
  std::optional<Vector3d> mast;  // an extra thin box on top (robot): size, at the box's centre
};

Mover person(const std::string& name, std::function<std::optional<Vector2d>(double)> where) {
  return {name, Vector3d(0.3, 0.45, 1.75), std::move(where), std::nullopt};
}

struct SequenceResult {
  Scorer scorer;
  std::vector<std::vector<Track>> frames;
};

SequenceResult run_sequence(const StereoCameraModel& cam, const std::vector<Mover>& movers, int frames,
                            const PlanViewTrackerParams& tp = {}) {
  SequenceResult r;
  auto pipe = PlanViewPipeline::create(cam, {}, tp);
  EXPECT_TRUE(pipe.ok()) << pipe.error().str();
  if (!pipe.ok()) return r;
  for (int f = 0; f < frames; ++f) {
    const double t = f / kRate;
    std::vector<Box> boxes;
    std::vector<Truth> truth;
    for (const Mover& m : movers) {
      const auto p = m.where(t);
      if (!p) continue;
      boxes.push_back(Box::on_floor(p->x(), p->y(), m.size.x(), m.size.y(), m.size.z()));
      if (m.mast) boxes.push_back(Box::on_floor(p->x(), p->y(), m.mast->x(), m.mast->y(), m.mast->z()));
      truth.push_back({m.name, *p});
    }
    const Synthetic s = raycast(cam, boxes);
    auto tracks = pipe->process(s.mask, s.depth, stamp_of(f));
    EXPECT_TRUE(tracks.ok()) << tracks.error().str();
    if (!tracks.ok()) return r;
    if (std::getenv("PV_DEBUG")) {
      std::printf("f=%d truth:", f);
      for (const auto& g : truth) std::printf(" %s(%.2f,%.2f)", g.name.c_str(), g.xy.x(), g.xy.y());
      std::printf(" | tracks:");
      for (const auto& t : *tracks)
        std::printf(" %d:%s(%.2f,%.2f v%.2f,%.2f h%.2f w%.2f c%.2f)", t.id, std::string(to_string(t.cls)).c_str(),
                    t.x, t.y,
                    t.vx, t.vy, t.height, t.width, t.confidence);
      std::printf(" | scores");
      for (auto [id, sc] : pipe->tracker().last_scores()) std::printf(" %d:%.2f", id, sc);
      std::printf("\n");
    }
    r.scorer.add(truth, *tracks);
    r.frames.push_back(*tracks);
  }
  return r;
}

StereoCameraModel synthetic_camera() { return camera_at(Vector3d(0, 0, 2.5), 0, 20, 320, 240); }

TEST(PlanViewTracker, ConstantVelocityWalkerKeepsOneIdentity) {
  const Vector2d a(3.5, -1.2), v(0.6, 0.8);  // 1 m/s diagonally across the view
  const auto r = run_sequence(synthetic_camera(), {person("walker", [&](double t) {
                                return std::optional<Vector2d>(a + v * t);
                              })},
                              45);
  const auto& s = r.scorer.stats().at("walker");
  std::printf("[walker] %s\n", r.scorer.summary().c_str());
  EXPECT_EQ(s.ids.size(), 1u);
  EXPECT_EQ(s.switches, 0);
  EXPECT_GE(s.matched, 45 - 3);  // reported from its third frame
  EXPECT_LT(s.mean(), 0.15);
  EXPECT_LT(s.err_max, 0.25);
  EXPECT_EQ(r.scorer.extra(), 0);
  const Track& last = r.frames.back().at(0);
  EXPECT_NEAR(last.vx, v.x(), 0.15);
  EXPECT_NEAR(last.vy, v.y(), 0.15);
  EXPECT_EQ(last.cls, TrackClass::kPerson);
  EXPECT_NEAR(last.height, 1.75, 0.05);
  EXPECT_GT(last.confidence, 0.5);
  EXPECT_EQ(last.camera, "");
  RecordProperty("walker_mean_error_m", std::to_string(s.mean()));
}

TEST(PlanViewTracker, WalkerBehindAnotherKeepsItsIdentity) {
  // Figure 10.6: the far walker passes right behind the near one, hidden in the image; the plan
  // view keeps them 1.5 m apart in depth.
  const auto r = run_sequence(
      synthetic_camera(),
      {person("near", [](double t) { return std::optional<Vector2d>(Vector2d(3.5, 1.4 - 0.9 * t)); }),
       person("far", [](double t) { return std::optional<Vector2d>(Vector2d(5.0, -1.6 + 0.9 * t)); })},
      54);
  std::printf("[behind] %s\n", r.scorer.summary().c_str());
  EXPECT_EQ(r.scorer.total_switches(), 0);
  for (const auto& [name, s] : r.scorer.stats()) {
    EXPECT_EQ(s.ids.size(), 1u) << name;
    EXPECT_LT(s.mean(), 0.15) << name;
  }
  EXPECT_NE(*r.scorer.stats().at("near").ids.begin(), *r.scorer.stats().at("far").ids.begin());
}

TEST(PlanViewTracker, CrossingWalkersKeepTheirIdentities) {
  // Two walkers whose paths cross in an X, passing 0.6 m apart.
  const auto r = run_sequence(
      synthetic_camera(),
      {person("a", [](double t) { return std::optional<Vector2d>(Vector2d(3.2 + 0.7 * t, -1.4 + 0.7 * t)); }),
       person("b", [](double t) { return std::optional<Vector2d>(Vector2d(3.8 + 0.7 * t, 1.4 - 0.7 * t)); })},
      60);
  std::printf("[crossing] %s\n", r.scorer.summary().c_str());
  EXPECT_EQ(r.scorer.total_switches(), 0);
  for (const auto& [name, s] : r.scorer.stats()) {
    EXPECT_EQ(s.ids.size(), 1u) << name;
    EXPECT_LT(s.mean(), 0.15) << name;
  }
}

TEST(PlanViewTracker, StationaryBagIsBornAndClassified) {
  // A bag appears at frame 10; a robot (base and mast) and a standing person are there throughout.
  Mover bag{"bag", Vector3d(0.4, 0.2, 0.4),
            [](double t) { return t >= 10 / kRate ? std::optional<Vector2d>(Vector2d(4.0, 0.8)) : std::nullopt; },
            std::nullopt};
  Mover robot{"robot", Vector3d(0.4, 0.41, 0.23), [](double) { return std::optional<Vector2d>(Vector2d(5.0, -1.0)); },
              Vector3d(0.04, 0.04, 0.78)};
  const auto r = run_sequence(synthetic_camera(),
                              {bag, robot,
                               person("person", [](double) { return std::optional<Vector2d>(Vector2d(6, 0.9)); })},
                              30);
  std::printf("[classes] %s\n", r.scorer.summary().c_str());
  const auto& st = r.scorer.stats();
  EXPECT_EQ(st.at("bag").ids.size(), 1u);
  EXPECT_GE(st.at("bag").matched, 20 - 3);
  EXPECT_EQ(st.at("bag").last_class, TrackClass::kBag);
  EXPECT_LT(st.at("bag").mean(), 0.12);
  EXPECT_EQ(st.at("robot").last_class, TrackClass::kRobot);
  EXPECT_EQ(st.at("person").last_class, TrackClass::kPerson);
  EXPECT_EQ(r.scorer.total_switches(), 0);
  EXPECT_EQ(r.scorer.extra(), 0);
  // The bag is not reported before it has been seen min_hits times.
  for (int f = 0; f < 12; ++f) EXPECT_LE(r.frames[f].size(), 2u) << f;
  // Stationary: its velocity settles near zero.
  for (const Track& t : r.frames.back()) {
    if (t.cls == TrackClass::kBag) {
      EXPECT_LT(std::hypot(t.vx, t.vy), 0.05);
    }
  }
}

TEST(PlanViewTracker, TrackThatDisappearsIsDeletedAfterMaxMissed) {
  PlanViewTrackerParams tp;
  tp.max_missed = 5;
  const auto r = run_sequence(synthetic_camera(), {person("p", [](double t) {
                                return t < 10 / kRate ? std::optional<Vector2d>(Vector2d(4, 0)) : std::nullopt;
                              })},
                              20, tp);
  ASSERT_EQ(r.frames.size(), 20u);
  EXPECT_EQ(r.frames[9].size(), 1u);
  // Gone from frame 10: coasting (lower confidence) for max_missed - 1 frames, then deleted.
  for (int f = 10; f < 14; ++f) {
    ASSERT_EQ(r.frames[f].size(), 1u) << f;
    EXPECT_LT(r.frames[f][0].confidence, r.frames[9][0].confidence) << f;
  }
  for (int f = 14; f < 20; ++f) EXPECT_TRUE(r.frames[f].empty()) << f;
}

TEST(PlanViewTracker, FramesOutOfOrderOrOfAnotherGridAreErrors) {
  const auto cam = synthetic_camera();
  auto pipe = PlanViewPipeline::create(cam);
  ASSERT_TRUE(pipe.ok());
  const Synthetic s = raycast(cam, {Box::on_floor(4, 0, 0.3, 0.45, 1.75)});
  ASSERT_TRUE(pipe->process(s.mask, s.depth, 1000).ok());
  auto same = pipe->process(s.mask, s.depth, 1000);
  ASSERT_FALSE(same.ok());
  EXPECT_EQ(same.error().kind, ErrorKind::kBadInput);
  EXPECT_NE(same.error().message.find("increasing"), std::string::npos) << same.error().str();
  EXPECT_FALSE(pipe->process(s.mask, s.depth, 500).ok());
  EXPECT_TRUE(pipe->process(s.mask, s.depth, 2000).ok());
  // A frame of another size.
  auto big = pipe->process(cv::Mat::zeros(480, 640, CV_8U), cv::Mat::zeros(480, 640, CV_32F), 3000);
  ASSERT_FALSE(big.ok());
  EXPECT_NE(big.error().message.find("640x480"), std::string::npos) << big.error().str();
  // A plan view of another grid.
  auto t = PlanViewTracker::create(pipe->builder().grid());
  ASSERT_TRUE(t.ok());
  PlanViewParams other;
  other.cell_size = 0.05;
  auto b = PlanViewBuilder::create(cam, other);
  ASSERT_TRUE(b.ok());
  PlanView pv;
  ASSERT_TRUE(b->build(s.mask, s.depth, &pv).ok());
  auto wrong = t->update(pv, 1);
  ASSERT_FALSE(wrong.ok());
  EXPECT_NE(wrong.error().message.find("cells"), std::string::npos) << wrong.error().str();
  // Bad parameters.
  PlanViewTrackerParams bad;
  bad.template_size = 0;
  auto e = PlanViewTracker::create(pipe->builder().grid(), bad);
  ASSERT_FALSE(e.ok());
  EXPECT_EQ(e.error().key, "template_size");
}

TEST(PlanViewTracker, MissingTrackIsReportedBrieflyThenKeptForReacquisition) {
  // Seen on frames 0-9, gone on 10-19, back at the same place from 20.
  const auto r = run_sequence(synthetic_camera(), {person("p", [](double t) {
                                const int f = static_cast<int>(std::lround(t * kRate));
                                return f < 10 || f >= 20 ? std::optional<Vector2d>(Vector2d(4, 0)) : std::nullopt;
                              })},
                              30);
  ASSERT_EQ(r.frames.size(), 30u);
  ASSERT_EQ(r.frames[9].size(), 1u);
  const int id = r.frames[9][0].id;
  const int report = PlanViewTrackerParams{}.report_missed;
  for (int f = 10; f < 10 + report; ++f) EXPECT_EQ(r.frames[f].size(), 1u) << f;  // coasting, reported
  for (int f = 10 + report; f < 20; ++f) EXPECT_TRUE(r.frames[f].empty()) << f;   // stale: not reported
  // Kept all along (max_missed 15): the same identity takes the object back.
  for (int f = 20; f < 30; ++f) {
    ASSERT_EQ(r.frames[f].size(), 1u) << f;
    EXPECT_EQ(r.frames[f][0].id, id) << f;
  }
}

TEST(PlanViewTracker, TrackLostInTheOpenIsNotHeldAsOccluded) {
  // p vanishes in the open at frame 10; from frame 12 q stands between the camera and where p
  // was. p's track must not be held as occluded by q (it would be reported for seconds).
  const auto r = run_sequence(
      synthetic_camera(),
      {person("p", [](double t) { return t < 10 / kRate ? std::optional<Vector2d>(Vector2d(5.5, 0)) : std::nullopt; }),
       person("q", [](double t) { return t >= 12 / kRate ? std::optional<Vector2d>(Vector2d(3.5, 0)) : std::nullopt; })},
      45);
  ASSERT_EQ(r.frames.size(), 45u);
  for (int f = 20; f < 45; ++f) EXPECT_EQ(r.frames[f].size(), 1u) << f;  // q only
  EXPECT_EQ(r.scorer.stats().at("q").ids.size(), 1u);
  EXPECT_EQ(r.scorer.total_switches(), 0);
}

// A bag stands in view; at frame 20 someone is suddenly in front of it (a new track: their old
// one was lost behind something) and stays 60 frames. Their track is confirmed only min_hits
// frames after the bag is hidden, yet a bag does not walk: it is held as occluded once they are,
// and keeps its id. A person lost in the open is not held so (TrackLostInTheOpenIsNotHeldAsOccluded).
TEST(PlanViewTracker, ABagHiddenBySomeoneWhoseTrackIsNewKeepsItsId) {
  const Mover bag{"bag", Vector3d(0.4, 0.2, 0.4), [](double) { return std::optional<Vector2d>(Vector2d(5.5, 0.0)); },
                  std::nullopt};
  const Mover q = person("q", [](double t) {
    const double f = t * kRate;
    return f >= 20 && f < 80 ? std::optional<Vector2d>(Vector2d(3.5, 0.0)) : std::nullopt;
  });
  const auto r = run_sequence(synthetic_camera(), {bag, q}, 110);
  std::printf("[new occluder] %s\n", r.scorer.summary().c_str());
  EXPECT_EQ(r.scorer.stats().at("bag").ids.size(), 1u);
  EXPECT_EQ(r.scorer.stats().at("q").ids.size(), 1u);
}

TEST(PlanViewTracker, ATrackMeasuredForAFewFramesIsHeldStillWhileOccluded) {
  // o is seen for 7 frames moving sideways at 0.5 m/s (a thing being put down, a blob settling),
  // then is hidden behind p, who stands between it and the camera. Its velocity, from a few
  // frames, is not known to differ from zero: its track waits where it was last seen. With the
  // rule off it drifts off on that velocity.
  const Mover o = person("o", [](double t) {
    const int f = static_cast<int>(std::lround(t * kRate));
    return f >= 10 && f < 17 ? std::optional<Vector2d>(Vector2d(5.5, 0.5 * (t - 10 / kRate))) : std::nullopt;
  });
  const Mover p = person("p", [](double) { return std::optional<Vector2d>(Vector2d(3.5, 0.3)); });
  auto place = [&](const PlanViewTrackerParams& tp) {
    const auto r = run_sequence(synthetic_camera(), {o, p}, 45, tp);
    std::optional<Vector2d> at;
    for (const Track& t : r.frames.back())
      if (t.x > 4.5) at = Vector2d(t.x, t.y);
    return at;
  };
  const Vector2d last_seen(5.5, 0.5 * 6 / kRate);
  const auto held = place({});
  ASSERT_TRUE(held) << "o's track is no longer held as occluded";
  EXPECT_LT((*held - last_seen).norm(), 0.15) << held->transpose();
  PlanViewTrackerParams off;
  off.coast_min_sigmas = 0;
  const auto drifted = place(off);
  ASSERT_TRUE(drifted);
  EXPECT_GT((*drifted - last_seen).norm(), 0.4) << drifted->transpose();
}

// A bag stands in view; its owner walks up between it and the camera and stands there for 8 s
// (longer than max_occluded, 5 s), then walks off. A bag does not walk: its track is held as
// occluded for up to max_occluded_bag and keeps its id. With that limit at max_occluded the
// track is dropped while she stands there and the bag is found again under a new id.
TEST(PlanViewTracker, ABagHiddenBySomeoneStandingInFrontOfItKeepsItsId) {
  const Mover bag{"bag", Vector3d(0.4, 0.2, 0.4), [](double) { return std::optional<Vector2d>(Vector2d(5.0, 0.0)); },
                  std::nullopt};
  const Mover owner = person("owner", [](double t) {
    const double f = t * kRate;
    const double y = f < 20 ? -2.0 + 0.1 * f : f < 140 ? 0.0 : 0.1 * (f - 140);
    return y > 2.0 ? std::nullopt : std::optional<Vector2d>(Vector2d(3.5, y));
  });
  auto bag_ids = [&](const PlanViewTrackerParams& tp) {
    const auto r = run_sequence(synthetic_camera(), {bag, owner}, 175, tp);
    std::printf("[hidden bag] %s\n", r.scorer.summary().c_str());
    return r.scorer.stats().at("bag").ids.size();
  };
  EXPECT_EQ(bag_ids({}), 1u);
  PlanViewTrackerParams off;
  off.max_occluded_bag = off.max_occluded;
  EXPECT_GT(bag_ids(off), 1u);
}

// A bag put down right beside a person who stays (one blob with them in the plan view) gets a
// track of its own once it has stood there a while; a bag carried at the same place beside a
// walking person never does; with the rule off the bag put down is never born.
TEST(PlanViewTracker, ABagPutDownBesideSomeoneWhoStaysIsBornAndACarriedOneIsNot) {
  const Mover stander = person("stander", [](double) { return std::optional<Vector2d>(Vector2d(4.5, 0.0)); });
  const Mover put_down{"bag", Vector3d(0.2, 0.4, 0.4),
                       [](double t) { return t >= 10 / kRate ? std::optional<Vector2d>(Vector2d(4.5, 0.34)) : std::nullopt; },
                       std::nullopt};
  auto bag_frames = [](const SequenceResult& r, auto where) {
    int n = 0;
    for (size_t f = 0; f < r.frames.size(); ++f)
      for (const Track& t : r.frames[f])
        if (t.cls == TrackClass::kBag && (Vector2d(t.x, t.y) - where(f / kRate)).norm() < 0.2) {
          ++n;
          break;
        }
    return n;
  };
  const auto at_bag = [](double) { return Vector2d(4.5, 0.34); };
  const auto with_rule = run_sequence(synthetic_camera(), {stander, put_down}, 75);
  PlanViewTrackerParams off;
  off.split_still_frames = 0;
  const auto without = run_sequence(synthetic_camera(), {stander, put_down}, 75, off);
  const int born = bag_frames(with_rule, at_bag), never = bag_frames(without, at_bag);
  std::printf("[beside] bag tracked on %d of 75 frames (rule on), %d (off)\n", born, never);
  EXPECT_GE(born, 35);  // put down at frame 10, still for 15 frames, reported after 3 matches
  EXPECT_EQ(never, 0);
  EXPECT_EQ(with_rule.scorer.stats().at("stander").ids.size(), 1u);
  // Carried: the same bag, the same offset, moving with a walker.
  const Mover walker = person("walker", [](double t) { return std::optional<Vector2d>(Vector2d(6.5 - 1.2 * t, 0.0)); });
  const Mover carried{"bag", Vector3d(0.2, 0.4, 0.4),
                      [](double t) { return std::optional<Vector2d>(Vector2d(6.5 - 1.2 * t, 0.34)); }, std::nullopt};
  const auto carrying = run_sequence(synthetic_camera(), {walker, carried}, 45);
  int bag_tracks = 0;
  for (const auto& f : carrying.frames)
    for (const Track& t : f) bag_tracks += t.cls == TrackClass::kBag;
  EXPECT_EQ(bag_tracks, 0);
}

// A bag stands alone; its owner walks up, stands against it for 25 frames (one blob with it, the
// bag's cells under the owner's height) and walks off the way they came. Meanwhile the bag's
// templates do not match, but its place is still on a blob, so it is held there as hidden and
// keeps one id throughout. With the rule off it is lost in the open (nobody stands between it and
// the camera) and found again under a new id.
TEST(PlanViewTracker, ABagInOneBlobWithSomeoneBesideItKeepsItsId) {
  const Mover bag{"bag", Vector3d(0.2, 0.4, 0.45),
                  [](double t) { return t >= 3 / kRate ? std::optional<Vector2d>(Vector2d(5.0, 0.35)) : std::nullopt; },
                  std::nullopt};
  const Mover owner = person("owner", [](double t) {
    const double f = t * kRate;
    const double y = f < 20 ? -1.8 + 0.1 * f : f < 45 ? 0.2 : 0.2 - 0.1 * (f - 45);
    return std::optional<Vector2d>(Vector2d(5.0, std::max(y, -1.8)));
  });
  auto ids = [&](const PlanViewTrackerParams& tp) {
    const auto r = run_sequence(synthetic_camera(), {bag, owner}, 80, tp);
    const auto& s = r.scorer.stats().at("bag");
    std::printf("[bag beside] %s\n", r.scorer.summary().c_str());
    return std::make_pair(s.ids.size(), s.matched);
  };
  const auto [with_ids, with_matched] = ids({});
  EXPECT_EQ(with_ids, 1u);
  EXPECT_GE(with_matched, 80 - 3 - 3);
  PlanViewTrackerParams off;
  off.hold_bag_on_blob = false;
  const auto [without_ids, without_matched] = ids(off);
  EXPECT_GT(without_ids, 1u);
  EXPECT_LT(without_matched, with_matched);
}

// A plan view of one round blob (radius 0.24 m, 1.7 m tall) centred on cell (col, row) of a
// 4 x 4 m grid, the camera 3 m off its left side.
PlanView blob_view(int col, int row) {
  PlanView v;
  v.grid.x_min = 0.01;
  v.grid.y_min = 0.01;
  v.grid.cell = 0.02;
  v.grid.cols = v.grid.rows = 200;
  v.occupancy = cv::Mat::zeros(200, 200, CV_32F);
  cv::circle(v.occupancy, {col, row}, 12, cv::Scalar(2.0), cv::FILLED);
  v.occupancy_smoothed = v.occupancy.clone();
  v.height = cv::Mat::zeros(200, 200, CV_32F);
  v.height.setTo(1.7f, v.occupancy > 0);
  v.height_masked = v.height.clone();
  v.mask = v.occupancy > 0;
  v.active = cv::Rect(0, 0, 200, 200);
  v.camera_xy = Vector2d(-3, 2);
  v.camera_height = 2.5;
  v.smoothing = 1.5;
  return v;
}

TEST(PlanViewTracker, ATrackWhoseObjectWasFoundAgainByANewTrackInFrontIsNotHeldAsOccluded) {
  // One object, first seen at col 120 (5.4 m from the camera); from frame 20 its blob is also at
  // col 80 (0.8 m nearer, beyond the track's search reach: smear at the far range resolving), a
  // second track confirms there, and from frame 25 only that blob is left. The first track
  // stands behind the second, but the second was born beside it moments ago: the same object,
  // not an occluder, so the first is a missing track (reported report_missed frames), not a
  // ghost held as occluded for seconds. With the rule off it is held.
  auto view_at = [](int f) {
    PlanView v = blob_view(f < 25 ? 120 : 80, 100);
    if (f >= 20 && f < 25) {
      cv::circle(v.occupancy, {80, 100}, 12, cv::Scalar(2.0), cv::FILLED);
      v.occupancy_smoothed = v.occupancy.clone();
      v.height.setTo(1.7f, v.occupancy > 0);
      v.height_masked = v.height.clone();
      v.mask = v.occupancy > 0;
    }
    return v;
  };
  auto reported = [&](const PlanViewTrackerParams& tp) {
    auto t = PlanViewTracker::create(view_at(0).grid, tp);
    EXPECT_TRUE(t.ok());
    std::vector<size_t> n;
    for (int f = 0; f < 60; ++f) {
      auto r = t->update(view_at(f), stamp_of(f));
      EXPECT_TRUE(r.ok());
      n.push_back(r.ok() ? r->size() : 0);
    }
    return n;
  };
  const std::vector<size_t> with_rule = reported({});
  EXPECT_EQ(with_rule[23], 2u);  // both confirmed while both blobs are there
  const int report = PlanViewTrackerParams{}.report_missed;
  for (int f = 25 + report; f < 60; ++f) EXPECT_EQ(with_rule[f], 1u) << f;
  PlanViewTrackerParams off;
  off.split_window = 0;
  const std::vector<size_t> without = reported(off);
  for (int f = 25 + report; f < 60; ++f) EXPECT_EQ(without[f], 2u) << f;
}

TEST(PlanViewTracker, ABagBesideSomeoneIsBornThoughHerSmearedBodyTouchesIt) {
  // dis_bag_stay with SGBM: a bag put down 0.45 m beside a standing person, across the camera's
  // line of sight (+x here). Her upper body, smeared by stereo, reaches over the gap between
  // them: tall cells past split_radius that join the bag's cells to hers. The still residual is
  // the bag's low cells only; when the tall smear counted, the residual was as tall as a person
  // and was never born (the bag was tracked only once she had walked off, 15 s later).
  auto view_at = [](int f) {
    PlanView v = blob_view(100, 100);  // the person: map (2.01, 2.01), 1.7 m tall
    if (f >= 10) {
      // The bag, 0.4 m along the line of sight, 0.2 m across, 0.45 m tall, centred 0.44 m aside.
      cv::rectangle(v.occupancy, cv::Rect(90, 117, 20, 10), cv::Scalar(2.0), cv::FILLED);
      v.height.setTo(0.45f, (v.occupancy > 0) & (v.height == 0));
      // The smear of her body, 1.2 m tall, over the gap.
      const cv::Rect smear(95, 108, 10, 10);
      v.occupancy(smear).setTo(1.0);
      v.height(smear).setTo(1.2f);
      v.occupancy_smoothed = v.occupancy.clone();
      v.height_masked = v.height.clone();
      v.mask = v.occupancy > 0;
    }
    return v;
  };
  auto t = PlanViewTracker::create(view_at(0).grid, {});
  ASSERT_TRUE(t.ok());
  const Vector2d bag_at(0.01 + 100 * 0.02, 0.01 + 122 * 0.02);
  int bag_frames = 0, first = -1;
  std::set<int> person_ids;
  for (int f = 0; f < 60; ++f) {
    auto r = t->update(view_at(f), stamp_of(f));
    ASSERT_TRUE(r.ok());
    for (const Track& k : *r) {
      if (k.cls == TrackClass::kBag && (Vector2d(k.x, k.y) - bag_at).norm() < 0.2) {
        ++bag_frames;
        if (first < 0) first = f;
      }
      if (k.cls == TrackClass::kPerson) person_ids.insert(k.id);
    }
  }
  std::printf("[smeared beside] bag tracked on %d of 50 frames, from frame %d\n", bag_frames, first);
  EXPECT_GE(bag_frames, 25);  // put down at frame 10, still for 15 frames, then confirmed
  EXPECT_EQ(person_ids.size(), 1u);
}

// The view ceiling: a camera 2.5 m up pitched 35 degrees down sees a vertical line on its axis
// up to 2.5 - r tan(35 deg - the top edge's angle above the axis); an object reaching it there
// is cut by the image's top edge. A person 5.5 m away (ceiling 1.4 m) is reported top_cut, one
// 2.6 m away (ceiling 1.9 m, all of her seen) is not.
TEST(PlanViewTracker, ObjectsCutByTheTopOfTheImageAreMarked) {
  const StereoCameraModel cam = camera_at(Vector3d(0, 0, 2.5), 0, 35, 320, 240);
  auto builder = PlanViewBuilder::create(cam);
  ASSERT_TRUE(builder.ok());
  PlanView v;
  ASSERT_TRUE(builder->build(cv::Mat::zeros(240, 320, CV_8U), cv::Mat::zeros(240, 320, CV_32F), &v).ok());
  ASSERT_EQ(v.ceiling.size(), v.occupancy.size());
  const Intrinsics& k = cam.intrinsics();
  const double above = std::atan((k.cy + 0.5) / k.fy);
  for (double r : {3.0, 5.0, 7.0}) {
    const Vector2d c = v.grid.to_cell(r, 0.0);
    const float got = v.ceiling.at<float>(static_cast<int>(std::lround(c.y())), static_cast<int>(std::lround(c.x())));
    const double want = 2.5 - r * std::tan(35 * kDeg - above);
    EXPECT_NEAR(got, want, 0.02) << "at " << r << " m";
  }
  auto cut_frames = [&](double x) {
    const auto r = run_sequence(cam, {person("p", [x](double) { return std::optional<Vector2d>(Vector2d(x, 0.0)); })}, 12);
    int cut = 0, seen = 0;
    for (const auto& f : r.frames)
      for (const Track& t : f) {
        ++seen;
        cut += t.top_cut;
      }
    return std::make_pair(cut, seen);
  };
  const auto [far_cut, far_seen] = cut_frames(5.5);
  const auto [near_cut, near_seen] = cut_frames(2.6);
  EXPECT_GT(far_seen, 5);
  EXPECT_EQ(far_cut, far_seen);
  EXPECT_GT(near_seen, 5);
  EXPECT_EQ(near_cut, 0);
}

TEST(PlanViewTracker, NoBirthFromABlobCutByTheGridBorder) {
  // An object entering across the edge of the plan view: its blob is cut by the border and its
  // centre lies near it. No track is born from it; with the margin off, one is; a blob inside is.
  auto frames_with_tracks = [](const PlanView& v, const PlanViewTrackerParams& tp) {
    auto t = PlanViewTracker::create(v.grid, tp);
    EXPECT_TRUE(t.ok());
    int n = 0;
    for (int f = 0; f < 10; ++f) {
      auto r = t->update(v, stamp_of(f));
      EXPECT_TRUE(r.ok());
      n += r.ok() && !r->empty();
    }
    return n;
  };
  const PlanView cut = blob_view(196, 100), inside = blob_view(150, 100);
  EXPECT_EQ(frames_with_tracks(cut, {}), 0);
  PlanViewTrackerParams off;
  off.birth_border_margin = 0;
  EXPECT_EQ(frames_with_tracks(cut, off), 8);  // reported from the third frame
  EXPECT_EQ(frames_with_tracks(inside, {}), 8);
}

TEST(PlanViewTracker, TrackMeasuresTheCentreOfASmearedBlobNotTheEndItWasOn) {
  // Stereo at long range smears a person along the line of sight into a plateau of occupancy. A
  // person's blob (camera to the left, looking along +x) starts round at col 56, then grows away
  // from the camera, 2 cells a frame, into a uniform strip from col 46 to col 84 (its centre at
  // col 65, 0.18 m on), then stays. With measure_blob_centre the track measures the blob's centre,
  // not the end it was born on (a local mean shift stops anywhere on a plateau).
  PlanView v = blob_view(56, 100);
  PlanViewTrackerParams tp;
  tp.measure_blob_centre = true;
  auto t = PlanViewTracker::create(v.grid, tp);
  ASSERT_TRUE(t.ok());
  std::vector<Track> last;
  for (int f = 0; f < 40; ++f) {
    if (f >= 5) {
      v.occupancy.setTo(0);
      const int end = std::min(84, 68 + 2 * (f - 4));
      cv::rectangle(v.occupancy, cv::Point(46, 88), cv::Point(end, 112), cv::Scalar(2.0), cv::FILLED);
      v.occupancy_smoothed = v.occupancy.clone();
      v.height.setTo(0);
      v.height.setTo(1.7f, v.occupancy > 0);
      v.height_masked = v.height.clone();
      v.mask = v.occupancy > 0;
    }
    auto r = t->update(v, stamp_of(f));
    ASSERT_TRUE(r.ok());
    last = *r;
  }
  ASSERT_EQ(last.size(), 1u);
  // The strip's centre, col 65 (x = 1.31), pushed 0.1 m away from the camera.
  EXPECT_NEAR(last[0].x, 1.41, 0.03);
  EXPECT_NEAR(last[0].y, 2.01, 0.05);
}

// A bag standing still and a robot (base and mast) driving across the view right behind it, so
// close that their plan-view blobs merge for a while.
std::vector<Mover> robot_passing_bag() {
  Mover bag{"bag", Vector3d(0.4, 0.2, 0.4), [](double) { return std::optional<Vector2d>(Vector2d(4.0, 0.8)); },
            std::nullopt};
  Mover robot{"robot", Vector3d(0.4, 0.41, 0.23),
              [](double t) { return std::optional<Vector2d>(Vector2d(4.45, -0.4 + 0.4 * t)); },
              Vector3d(0.04, 0.04, 0.78)};
  return {bag, robot};
}

// A bag put down half a metre behind a person standing (as seen from the camera) and beside
// them in the image: stereo would smear the two together along the line of sight, so no track is
// born from the bag while the person stands there; it is born once they have walked off.
TEST(PlanViewTracker, NoBirthInTheStereoShadowOfATrack) {
  const Mover bag{"bag", Vector3d(0.4, 0.2, 0.4),
                  [](double t) { return t >= 10 / kRate ? std::optional<Vector2d>(Vector2d(4.6, 0.35)) : std::nullopt; },
                  std::nullopt};
  const Mover stander = person("person", [](double t) {
    const double leave = 40 / kRate;
    return std::optional<Vector2d>(t < leave ? Vector2d(4.0, 0.0) : Vector2d(4.0, -1.0 * (t - leave)));
  });
  auto first_bag_frame = [](const SequenceResult& r) {
    for (size_t f = 0; f < r.frames.size(); ++f)
      for (const Track& t : r.frames[f])
        if (std::hypot(t.x - 4.6, t.y - 0.35) < 0.3) return static_cast<int>(f);
    return -1;
  };
  const auto with_rule = run_sequence(synthetic_camera(), {bag, stander}, 70);
  PlanViewTrackerParams off;
  off.birth_shadow_depth = 0;
  const auto without = run_sequence(synthetic_camera(), {bag, stander}, 70, off);
  const int born_with = first_bag_frame(with_rule), born_without = first_bag_frame(without);
  std::printf("[shadow] bag first reported at frame %d (rule on), %d (off); the person leaves at 40\n", born_with,
              born_without);
  ASSERT_GE(born_without, 0);
  EXPECT_LT(born_without, 20);  // visible beside the person: born at once without the rule
  ASSERT_GE(born_with, 0);
  EXPECT_GE(born_with, 40);  // not while the person stands in front...
  EXPECT_LT(born_with, 60);  // ...but soon after they have gone
  EXPECT_EQ(with_rule.frames.back().size(), 2u);
  for (const Track& t : with_rule.frames.back()) {
    if (std::hypot(t.x - 4.6, t.y - 0.35) < 0.3) {
      EXPECT_EQ(t.cls, TrackClass::kBag);
    }
  }
}

TEST(PlanViewTracker, BagKeepsItsShapeWhileARobotPassesBesideIt) {
  const auto r = run_sequence(synthetic_camera(), robot_passing_bag(), 105);
  std::printf("[robot past bag] %s\n", r.scorer.summary().c_str());
  const auto& bag = r.scorer.stats().at("bag");
  EXPECT_EQ(bag.ids.size(), 1u);
  EXPECT_GE(bag.matched, 105 - 3);
  const int id = *bag.ids.begin();
  for (size_t f = 0; f < r.frames.size(); ++f)
    for (const Track& t : r.frames[f])
      if (t.id == id) {
        // The merged blob's extent and the robot's mast are not the bag's.
        EXPECT_LT(t.width, 0.5) << f;
        EXPECT_LT(t.height, 0.6) << f;
        EXPECT_EQ(t.cls, TrackClass::kBag) << f;
      }
}

// The template search stops scoring a window once its partial sum cannot beat the best so far,
// and uses AVX2 where the CPU has it: the tracks are the same, bit for bit, as scoring every
// window in full with the portable kernel (walkers crossing, a walker behind another, a robot
// passing a bag: misses, occlusion and claims all take part).
TEST(PlanViewTracker, FastSearchGivesTheSameTracksAsTheExhaustiveOne) {
  auto run = [](bool exhaustive) {
    detail::planview_tracker_exhaustive_search(exhaustive);
    std::vector<std::vector<Track>> all;
    auto add = [&](const SequenceResult& r) { all.insert(all.end(), r.frames.begin(), r.frames.end()); };
    add(run_sequence(
        synthetic_camera(),
        {person("a", [](double t) { return std::optional<Vector2d>(Vector2d(3.2 + 0.7 * t, -1.4 + 0.7 * t)); }),
         person("b", [](double t) { return std::optional<Vector2d>(Vector2d(3.8 + 0.7 * t, 1.4 - 0.7 * t)); })},
        60));
    add(run_sequence(
        synthetic_camera(),
        {person("near", [](double t) { return std::optional<Vector2d>(Vector2d(3.5, 1.4 - 0.9 * t)); }),
         person("far", [](double t) { return std::optional<Vector2d>(Vector2d(5.0, -1.6 + 0.9 * t)); })},
        54));
    add(run_sequence(synthetic_camera(), robot_passing_bag(), 105));
    detail::planview_tracker_exhaustive_search(false);
    return all;
  };
  const auto fast = run(false), full = run(true);
  ASSERT_EQ(fast.size(), full.size());
  size_t tracks = 0;
  for (size_t f = 0; f < fast.size(); ++f) {
    ASSERT_EQ(fast[f].size(), full[f].size()) << "frame " << f;
    for (size_t i = 0; i < fast[f].size(); ++i) {
      const Track &a = fast[f][i], &b = full[f][i];
      EXPECT_EQ(a.id, b.id) << f;
      EXPECT_EQ(a.cls, b.cls) << f;
      // Bitwise: not a tolerance.
      EXPECT_EQ(std::memcmp(&a.x, &b.x, sizeof a.x), 0) << f;
      EXPECT_EQ(std::memcmp(&a.y, &b.y, sizeof a.y), 0) << f;
      EXPECT_EQ(std::memcmp(&a.vx, &b.vx, sizeof a.vx), 0) << f;
      EXPECT_EQ(std::memcmp(&a.width, &b.width, sizeof a.width), 0) << f;
      EXPECT_EQ(std::memcmp(&a.height, &b.height, sizeof a.height), 0) << f;
      EXPECT_EQ(std::memcmp(&a.confidence, &b.confidence, sizeof a.confidence), 0) << f;
      ++tracks;
    }
  }
  EXPECT_GT(tracks, 300u);
}

TEST(PlanViewTracker, EstablishedClassSurvivesAFewSecondsOfAnotherShape) {
  // A bag seen for 8 s, then for 2.7 s something makes its blob 0.7 m wide (robot-like under a
  // classifier where low things from 0.5 m wide are robots), then it is a bag again: its class
  // stays bag. With a short vote memory it flips.
  Mover bag{"bag", Vector3d(0.4, 0.2, 0.4), [](double) { return std::optional<Vector2d>(Vector2d(4.0, 0.8)); },
            std::nullopt};
  Mover widen{"widen", Vector3d(0.2, 0.7, 0.35), [](double t) {
                const int f = static_cast<int>(std::lround(t * kRate));
                return f >= 120 && f < 160 ? std::optional<Vector2d>(Vector2d(4.0, 0.8)) : std::nullopt;
              },
              std::nullopt};
  auto classes = [&](const PlanViewTrackerParams& tp) {
    const auto r = run_sequence(synthetic_camera(), {bag, widen}, 175, tp);
    std::set<TrackClass> seen;
    for (size_t f = 0; f < r.frames.size(); ++f)
      for (const Track& t : r.frames[f]) seen.insert(t.cls);
    return seen;
  };
  PlanViewTrackerParams wide_robots;
  wide_robots.classes.robot_min_width = 0.5;
  EXPECT_EQ(classes(wide_robots), std::set<TrackClass>{TrackClass::kBag});
  PlanViewTrackerParams short_memory = wide_robots;
  short_memory.class_vote_decay = 0.9;
  EXPECT_TRUE(classes(short_memory).count(TrackClass::kRobot));
}

TEST(PlanViewTracker, ClassesFromHeightAndWidth) {
  EXPECT_EQ(classify_track(1.75, 0.45), TrackClass::kPerson);
  EXPECT_EQ(classify_track(1.3, 0.4), TrackClass::kPerson);
  EXPECT_EQ(classify_track(0.4, 0.4), TrackClass::kBag);
  EXPECT_EQ(classify_track(0.78, 0.45), TrackClass::kRobot);  // the Erratic with its mast
  EXPECT_EQ(classify_track(0.5, 0.6), TrackClass::kRobot);    // a low, wide robot
  EXPECT_EQ(classify_track(2.5, 0.5), TrackClass::kUnknown);
  EXPECT_EQ(classify_track(0.05, 0.1), TrackClass::kUnknown);
  // The plan view's classes: a bag seen long side on at 7 m (0.47 m tall, 0.51 m across) is a
  // bag, not a robot; a robot shows its mast.
  const ClassifierParams pv = PlanViewTrackerParams{}.classes;
  EXPECT_EQ(classify_track(0.47, 0.51, pv), TrackClass::kBag);
  EXPECT_EQ(classify_track(0.42, 0.50, pv), TrackClass::kBag);
  EXPECT_EQ(classify_track(0.78, 0.45, pv), TrackClass::kRobot);
  EXPECT_EQ(classify_track(0.5, 0.9, pv), TrackClass::kRobot);
}

TEST(PlanViewTracker, DrawingShowsMapsAndTracks) {
  const auto cam = synthetic_camera();
  auto pipe = PlanViewPipeline::create(cam);
  ASSERT_TRUE(pipe.ok());
  const Synthetic s = raycast(cam, {Box::on_floor(4, 0.5, 0.3, 0.45, 1.75)});
  std::vector<Track> tracks;
  for (int f = 0; f < 4; ++f) {
    auto r = pipe->process(s.mask, s.depth, stamp_of(f));
    ASSERT_TRUE(r.ok());
    tracks = *r;
  }
  ASSERT_EQ(tracks.size(), 1u);
  const PlanView& pv = pipe->plan_view();
  PlanViewDrawOptions o;
  o.scale = 2;
  const cv::Mat img = draw_plan_view(pv, tracks, o);
  ASSERT_EQ(img.type(), CV_8UC3);
  EXPECT_EQ(img.cols, 2 * 2 * pv.grid.cols + 4);
  const cv::Mat occ = draw_occupancy_map(pv, tracks, o), hgt = draw_height_map(pv, {}, o);
  EXPECT_EQ(occ.size(), cv::Size(2 * pv.grid.cols, 2 * pv.grid.rows));
  // The height map is coloured over the person (y up: row from the top), black far from it.
  const cv::Point2d px = plan_view_pixel(pv.grid, 4.05, 0.5, 2);  // just behind the front face
  const cv::Vec3b c = hgt.at<cv::Vec3b>(static_cast<int>(px.y), static_cast<int>(px.x));
  EXPECT_GT(c[0] + c[1] + c[2], 100);
  const cv::Point2d far = plan_view_pixel(pv.grid, 6.5, -1.0, 2);
  EXPECT_EQ(hgt.at<cv::Vec3b>(static_cast<int>(far.y), static_cast<int>(far.x)), cv::Vec3b(0, 0, 0));
  // The track's circle is drawn in the person colour.
  EXPECT_GT(cv::countNonZero(occ.reshape(1) == 220), 0);
}

// ============================================================== rendered frames

std::unique_ptr<render::OsmesaRenderer> renderer(int w, int h) {
  auto r = render::OsmesaRenderer::create(w, h);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().str());
  return r.ok() ? std::move(*r) : nullptr;
}

TEST(PlanViewRendered, PersonWalkingBehindAnotherKeepsItsIdentity) {
  // Two articulated walking figures (the renderer's people) crossing the view 1.5 m apart in
  // depth: the far one is hidden behind the near one mid-way. Foreground = labelled pixels.
  constexpr int W = 320, H = 240;
  auto r = renderer(W, H);
  ASSERT_TRUE(r);
  const auto cam = camera_at(Vector3d(0, 0, 2.5), 0, 15, W, H);
  auto pipe = PlanViewPipeline::create(cam);
  ASSERT_TRUE(pipe.ok()) << pipe.error().str();
  Scorer scorer;
  const double speed = 1.0;
  for (int f = 0; f < 60; ++f) {
    const double t = f / kRate;
    const Vector2d a(3.5, 1.7 - speed * t), b(5.0, -1.7 + speed * t);
    render::RenderScene scene;
    render::Light l;
    l.position = Vector3d(4, 0, 2.6);
    scene.lights.push_back(l);
    render::Primitive floor;
    floor.pose = Eigen::Isometry3d(Eigen::Translation3d(5, 0, -0.05));
    floor.size = Vector3d(20, 20, 0.1);
    floor.texture = render::Texture::kTiles;
    scene.primitives.push_back(floor);
    render::add_person_figure(&scene, a.x(), a.y(), -M_PI / 2, 1.75, 0.25, speed * t, speed, {0.8f, 0.2f, 0.2f},
                              {0.1f, 0.1f, 0.3f}, 1);
    render::add_person_figure(&scene, b.x(), b.y(), M_PI / 2, 1.7, 0.25, speed * t, speed, {0.2f, 0.6f, 0.2f},
                              {0.3f, 0.3f, 0.3f}, 2);
    StereoFrame fr;
    ASSERT_TRUE(r->render(scene, cam, &fr).ok());
    const cv::Mat mask = fr.labels != 0;
    auto tracks = pipe->process(mask, fr.depth, stamp_of(f));
    ASSERT_TRUE(tracks.ok()) << tracks.error().str();
    scorer.add({{"near", a}, {"far", b}}, *tracks);
  }
  std::printf("[rendered behind] %s\n", scorer.summary().c_str());
  EXPECT_EQ(scorer.total_switches(), 0);
  for (const auto& [name, s] : scorer.stats()) {
    EXPECT_EQ(s.ids.size(), 1u) << name;
    EXPECT_LE(s.mean(), 0.15) << name;
    EXPECT_GE(s.matched, 60 - 8) << name;
    EXPECT_EQ(s.last_class, TrackClass::kPerson) << name;
  }
  RecordProperty("near_mean_error_m", std::to_string(scorer.stats().at("near").mean()));
  RecordProperty("far_mean_error_m", std::to_string(scorer.stats().at("far").mean()));
}

std::unique_ptr<World> world_at(const std::string& scenario, double seconds) {
  auto sc = load_scenario(test::source_dir() / "scenarios" / scenario);
  EXPECT_TRUE(sc.ok()) << (sc.ok() ? "" : sc.error().str());
  if (!sc.ok()) return nullptr;
  WorldOptions wo;
  wo.plugins = builtin_plugin_registry();
  wo.plugin_dirs = {test::plugin_dir()};
  auto w = World::create(*sc, wo);
  EXPECT_TRUE(w.ok()) << (w.ok() ? "" : w.error().str());
  if (!w.ok()) return nullptr;
  while ((*w)->time() < from_seconds(seconds)) {
    if (!(*w)->advance().ok()) return nullptr;
  }
  return std::move(*w);
}

const CameraSpec* find_camera(const World& w, const std::string& id) {
  for (const auto& c : w.scenario().cameras)
    if (c.id == id) return &c;
  return nullptr;
}

// People, and bags lying on the floor away from people, fully in view within `range` of the camera.
std::vector<Truth> visible_truth(const World& w, const StereoCameraModel& cam, double range) {
  const Intrinsics& k = cam.intrinsics();
  const Vector2d c = cam.map_from_optical().translation().head<2>();
  auto in_view = [&](double x, double y, double top) {
    if ((Vector2d(x, y) - c).norm() > range) return false;
    for (const double z : {0.0, top}) {
      Eigen::Vector2d px;
      if (!cam.project_map(Vector3d(x, y, z), &px)) return false;
      if (px.x() < 0 || px.y() < 0 || px.x() > k.width - 1 || px.y() > k.height - 1) return false;
    }
    return true;
  };
  std::vector<Truth> out;
  for (const PersonEntity& p : w.people())
    if (p.present && in_view(p.pose.x, p.pose.y, p.spec.height)) out.push_back({p.spec.id, {p.pose.x, p.pose.y}});
  for (const ObjectEntity& o : w.objects()) {
    if (!o.present || o.carrier >= 0 || o.spec.kind != ObjectKind::kBag) continue;
    bool near_person = false;
    for (const PersonEntity& p : w.people())
      near_person |= p.present && std::hypot(p.pose.x - o.pose.x, p.pose.y - o.pose.y) < 0.8;
    if (!near_person && in_view(o.pose.x, o.pose.y, o.z + o.spec.size_z))
      out.push_back({o.spec.id, {o.pose.x, o.pose.y}});
  }
  return out;
}

struct ScenarioRun {
  Scorer scorer;
  int frames = 0;
  std::map<int, TrackClass> classes;  // last class of every track id reported
  std::map<int, std::string> robots;  // track id -> robot near it (within 0.5 m) at least once
  double disparity_noise = 0;         // px, Gaussian noise added to the disparity (0 = exact depth)
  cv::RNG rng{12345};
};

// Steps `scenario` to t0, then renders `camera` at its rate (at W x H) until t1, tracking the
// labelled pixels; scores against the people and floor bags within 8 m (visible_truth).
void run_scenario(const std::string& scenario, const std::string& camera, double t0, double t1, int W, int H,
                  ScenarioRun* out) {
  auto w = world_at(scenario, t0);
  ASSERT_TRUE(w);
  const CameraSpec* spec0 = find_camera(*w, camera);
  ASSERT_TRUE(spec0);
  CameraSpec spec = *spec0;
  spec.width = W;
  spec.height = H;
  const StereoCameraModel cam = render::camera_model(spec);
  auto r = renderer(W, H);
  ASSERT_TRUE(r);
  PlanViewTrackerParams tp;
  tp.camera = spec.id;
  auto pipe = PlanViewPipeline::create(cam, {}, tp);
  ASSERT_TRUE(pipe.ok()) << pipe.error().str();
  const int64_t period = from_seconds(1.0 / spec.rate_hz);
  int64_t next = w->time();
  while (w->time() < from_seconds(t1)) {
    while (w->time() < next) ASSERT_TRUE(w->advance().ok());
    next += period;
    StereoFrame f;
    ASSERT_TRUE(r->render(render::build_render_scene(*w, render::scene_options_for(*w, &spec)), cam, &f).ok());
    if (out->disparity_noise > 0) {
      // Stereo-like depth error: Gaussian disparity noise (px), so depth error grows as Z^2.
      cv::Mat noise(f.depth.size(), CV_32F);
      out->rng.fill(noise, cv::RNG::NORMAL, 0.0, out->disparity_noise);
      const float fb = static_cast<float>(cam.intrinsics().fx * cam.baseline());
      for (int v = 0; v < f.depth.rows; ++v) {
        float* z = f.depth.ptr<float>(v);
        const float* n = noise.ptr<float>(v);
        for (int u = 0; u < f.depth.cols; ++u)
          if (z[u] > 0) z[u] = fb / std::max(0.05f, fb / z[u] + n[u]);
      }
    }
    auto tracks = pipe->process(f.labels != 0, f.depth, w->time());
    ASSERT_TRUE(tracks.ok()) << tracks.error().str();
    for (const Track& t : *tracks) {
      EXPECT_EQ(t.camera, camera);
      EXPECT_EQ(t.stamp_ns, w->time());
      out->classes[t.id] = t.cls;
      for (const RobotEntity& rb : w->robots())
        if (std::hypot(rb.pose.x - t.x, rb.pose.y - t.y) < 0.5) out->robots[t.id] = rb.spec.id;
    }
    const auto truth = visible_truth(*w, cam, 8.0);
    if (std::getenv("PV_DEBUG")) {
      std::printf("t=%.2f truth:", w->time() * 1e-9);
      for (const auto& g : truth) std::printf(" %s(%.2f,%.2f)", g.name.c_str(), g.xy.x(), g.xy.y());
      for (const auto& p : w->people()) std::printf(" [%s %.2f,%.2f]", p.spec.id.c_str(), p.pose.x, p.pose.y);
      for (const auto& o : w->objects())
        std::printf(" [%s %.2f,%.2f c%d]", o.spec.id.c_str(), o.pose.x, o.pose.y, o.carrier);
      for (const auto& rb : w->robots())
        std::printf(" [%s %.2f,%.2f]", rb.spec.id.c_str(), rb.pose.x, rb.pose.y);
      std::printf(" | tracks:");
      for (const auto& t : *tracks)
        std::printf(" %d:%s(%.2f,%.2f h%.2f w%.2f c%.2f)", t.id, std::string(to_string(t.cls)).c_str(), t.x, t.y,
                    t.height, t.width, t.confidence);
      std::printf(" | live %d scores", pipe->tracker().live_tracks());
      for (auto [id, sc] : pipe->tracker().last_scores()) std::printf(" %d:%.2f", id, sc);
      std::printf("\n");
    }
    if (const char* dir = std::getenv("PV_DRAW"); dir && out->frames % 15 == 0) {
      // Debugging aid: the camera view with the mask, and the plan view with the tracks.
      PlanViewDrawOptions o;
      o.scale = 2;
      char name[64];
      std::snprintf(name, sizeof name, "/%s_%05d", camera.c_str(), out->frames);
      cv::imwrite(std::string(dir) + name + "_plan.png", draw_plan_view(pipe->plan_view(), *tracks, o));
      cv::Mat left = f.left.clone();
      left.setTo(cv::Scalar(0, 255, 255), f.labels != 0);
      cv::addWeighted(f.left, 0.6, left, 0.4, 0, left);
      cv::imwrite(std::string(dir) + name + "_left.png", left);
    }
    out->scorer.add(truth, *tracks);
    ++out->frames;
  }
}

TEST(PlanViewRendered, LeftBagScenarioMatchesTheWorld) {
  // dis_left_bag, cam_corridor at 320x240, 9 s to 22 s: A walks in, puts bag1 down at
  // corridor_mid, walks away towards (and under) the camera, hiding the bag for a while.
  ScenarioRun run;
  run_scenario("dis_left_bag.yaml", "cam_corridor", 9.0, 22.0, 320, 240, &run);
  if (HasFatalFailure()) return;
  const Scorer& scorer = run.scorer;
  std::printf("[dis_left_bag] %d frames: %s\n", run.frames, scorer.summary().c_str());
  const auto& st = scorer.stats();
  ASSERT_TRUE(st.count("A"));
  ASSERT_TRUE(st.count("bag1"));
  EXPECT_LE(scorer.mean_error(), 0.15);
  EXPECT_EQ(scorer.total_switches(), 0);
  EXPECT_EQ(st.at("A").ids.size(), 1u);
  EXPECT_EQ(st.at("bag1").ids.size(), 1u);
  EXPECT_GE(st.at("A").matched, 0.9 * st.at("A").frames);
  EXPECT_GE(st.at("bag1").matched, 0.9 * st.at("bag1").frames);
  EXPECT_EQ(run.classes.at(*st.at("A").ids.begin()), TrackClass::kPerson);
  EXPECT_EQ(run.classes.at(*st.at("bag1").ids.begin()), TrackClass::kBag);
  RecordProperty("mean_error_m", std::to_string(scorer.mean_error()));
}

TEST(PlanViewRendered, BagTakenScenarioMatchesTheWorld) {
  // dis_bag_taken, cam_corridor at 320x240, 28 s to 45 s: B comes up the corridor to bag1 (left
  // there by A), picks it up and walks off with it, while robot1 patrols past them.
  ScenarioRun run;
  run_scenario("dis_bag_taken.yaml", "cam_corridor", 28.0, 45.0, 320, 240, &run);
  if (HasFatalFailure()) return;
  const Scorer& scorer = run.scorer;
  std::printf("[dis_bag_taken] %d frames: %s\n", run.frames, scorer.summary().c_str());
  const auto& st = scorer.stats();
  ASSERT_TRUE(st.count("B"));
  ASSERT_TRUE(st.count("bag1"));
  EXPECT_LE(scorer.mean_error(), 0.15);
  EXPECT_EQ(scorer.total_switches(), 0);
  EXPECT_EQ(st.at("B").ids.size(), 1u);
  EXPECT_EQ(st.at("bag1").ids.size(), 1u);
  EXPECT_GE(st.at("B").matched, 0.9 * st.at("B").frames);
  EXPECT_GE(st.at("bag1").matched, 0.9 * st.at("bag1").frames);
  EXPECT_EQ(run.classes.at(*st.at("B").ids.begin()), TrackClass::kPerson);
  EXPECT_EQ(run.classes.at(*st.at("bag1").ids.begin()), TrackClass::kBag);
  // The robot passing by is tracked too, as a robot.
  ASSERT_FALSE(run.robots.empty());
  for (const auto& [id, robot] : run.robots) EXPECT_EQ(run.classes.at(id), TrackClass::kRobot) << id << " " << robot;
  RecordProperty("mean_error_m", std::to_string(scorer.mean_error()));
}

// The left-bag run on depth with stereo-like noise (0.25 px of disparity; 0.36 m of depth at 6 m
// at 320x240): reported, not checked (run with --gtest_also_run_disabled_tests).
TEST(PlanViewRendered, DISABLED_LeftBagWithDisparityNoiseReport) {
  for (const auto& [W, H] : {std::pair{640, 480}, std::pair{320, 240}}) {
    ScenarioRun run;
    run.disparity_noise = 0.25;
    run_scenario("dis_left_bag.yaml", "cam_corridor", 9.0, 22.0, W, H, &run);
    if (HasFatalFailure()) return;
    std::printf("[dis_left_bag, 0.25 px disparity noise, %dx%d] mean error %.3f m, %d switches; %s\n", W, H,
                run.scorer.mean_error(), run.scorer.total_switches(), run.scorer.summary().c_str());
  }
}

// Ten people in the corridor, often hiding one another: a stress run, reported but not checked
// (run with --gtest_also_run_disabled_tests).
TEST(PlanViewRendered, DISABLED_CrowdReport) {
  ScenarioRun run;
  run_scenario("dis_crowd.yaml", "cam_corridor", 5.0, 25.0, 320, 240, &run);
  if (HasFatalFailure()) return;
  std::printf("[dis_crowd] %d frames: mean error %.3f m, %d switches; %s\n", run.frames, run.scorer.mean_error(),
              run.scorer.total_switches(), run.scorer.summary().c_str());
}

// The plan view's and the tracker's times per frame are benchmark figures, not test assertions
// (a shared machine's speed varies): `vigil bench planview` (docs/PERFORMANCE.md), with
// `--scenario scenarios/dis_crowd.yaml --from 8` for a crowd.

}  // namespace
}  // namespace vigil::vision
