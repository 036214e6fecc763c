// The whole stereo plan-view system (foreground, plan view, tracking) on rendered frames with
// SGBM disparity, as `vigil track` and the `planview` camera sensor run it: tracks of the
// person and the bag come out near the truth; frames without depth, of another size or out of
// order are clear errors; the annotated view has a fixed size.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <limits>
#include <map>

#include <opencv2/imgproc.hpp>

#include "plugins/stereo_camera/stereo_camera.h"
#include "tests/test_util.h"
#include "vision/planview_system.h"

namespace vigil::vision {
namespace {

// Runs every frame of `src` through `sys`, calling `each` with the frame and its tracks; a
// failure of either ends the run (and the test).
void run_frames(vision::FrameSource& src, PlanViewSystem& sys,
                const std::function<void(const StereoFrame&, const std::vector<Track>&)>& each) {
  StereoFrame f;
  while (true) {
    auto more = src.next(&f);
    ASSERT_TRUE(more.ok()) << more.error().str();
    if (!*more) return;
    auto tracks = sys.process(f);
    ASSERT_TRUE(tracks.ok()) << tracks.error().str();
    each(f, *tracks);
  }
}

Scenario load(const std::string& name) {
  auto s = load_scenario(test::source_dir() / "scenarios" / (name + ".yaml"));
  EXPECT_TRUE(s.ok()) << (s.ok() ? "" : s.error().str());
  return *s;
}

// dis_left_bag with every camera at 320x240 for `duration` seconds.
Scenario small_left_bag(double duration) {
  Scenario sc = load("dis_left_bag");
  for (auto& c : sc.cameras) {
    c.width = 320;
    c.height = 240;
  }
  sc.duration = duration;
  return sc;
}

// dis_left_bag from cam_corridor at 320x240 with SGBM: A walks towards the camera carrying bag1
// and puts it down in view.
TEST(PlanViewSystem, TracksThePersonAndTheBagFromSgbmDepth) {
  Scenario sc = small_left_bag(24);
  render::RenderedSourceOptions ro;
  StereoMatcherParams mp;
  mp.num_disparities = 32;
  ro.matcher = mp;
  auto src = render::RenderedStereoSource::open(sc, "cam_corridor", ro);
  ASSERT_TRUE(src.ok()) << src.error().str();
  PlanViewSystemParams sp;
  sp.tracking.camera = "cam_corridor";
  auto sys = PlanViewSystem::create(*(*src)->camera_model(), sp);
  ASSERT_TRUE(sys.ok()) << sys.error().str();
  StereoFrame f;
  double err_sum = 0;
  int matched = 0, frames_with_truth_in_range = 0;
  std::map<int, int> ids_on_person;
  cv::Size annotated;
  while (true) {
    auto more = (*src)->next(&f);
    ASSERT_TRUE(more.ok()) << more.error().str();
    if (!*more) break;
    auto tracks = sys->process(f);
    ASSERT_TRUE(tracks.ok()) << tracks.error().str();
    const cv::Mat a = sys->annotate(f, *tracks);
    if (annotated.area() == 0) annotated = a.size();
    ASSERT_EQ(a.size(), annotated);
    // The person, when within 7 m of the camera.
    const World& w = (*src)->world();
    for (const auto& p : w.people()) {
      if (!p.present) continue;
      const double range = std::hypot(p.pose.x - 27.0, p.pose.y - 3.9);
      if (range > 7.0 || range < 1.5) continue;
      ++frames_with_truth_in_range;
      double best = 1e9;
      int best_id = -1;
      for (const auto& t : *tracks) {
        const double d = std::hypot(t.x - p.pose.x, t.y - p.pose.y);
        if (d < best) best = d, best_id = t.id;
      }
      if (best < 0.5) {
        ++matched;
        err_sum += best;
        ++ids_on_person[best_id];
      }
    }
  }
  ASSERT_GT(frames_with_truth_in_range, 30);
  const double recall = static_cast<double>(matched) / frames_with_truth_in_range;
  std::printf("person within 1.5-7 m: %d frames, matched %.1f%%, mean error %.3f m, %zu ids\n",
              frames_with_truth_in_range, 100 * recall, err_sum / std::max(matched, 1), ids_on_person.size());
  // Measured 56.5% at 320x240 with SGBM (the person is missed mostly while entering at the far
  // end and when closer than ~3 m with the head out of the image); the issue's target (MOTA 0.9)
  // needs tuning on SGBM depth: this guards against regressions below today's figure.
  EXPECT_GT(recall, 0.5);
  EXPECT_LT(err_sum / matched, 0.2);
  EXPECT_LE(ids_on_person.size(), 2u);
}

// Stereo matched only where the colour differs from the background (DepthRegionParams, the
// planview sensor's default) tracks as well as the whole image's stereo: dis_left_bag at
// 320x240, both systems on the same rendered frames. Scored against the truth (the person within
// 1.5 to 7 m found within 0.5 m; tracks near nobody and no object are false), not against each
// other: far from the camera the coarse 320x240 depth gives both systems ghosts, which drift
// differently.
TEST(PlanViewSystem, StereoWhereTheColourChangesTracksAsWellAsTheWholeImage) {
  Scenario sc = small_left_bag(16);
  auto src = render::RenderedStereoSource::open(sc, "cam_corridor");
  ASSERT_TRUE(src.ok()) << src.error().str();
  StereoMatcherParams mp;
  mp.num_disparities = 32;
  mp.half_pixel_pass = true;
  auto matcher = StereoMatcher::create(mp);
  ASSERT_TRUE(matcher.ok());
  PlanViewSystemParams sp;
  sp.tracking.camera = "cam_corridor";
  auto whole = PlanViewSystem::create(*(*src)->camera_model(), sp);
  sp.depth_region.foreground_only = true;
  auto part = PlanViewSystem::create(*(*src)->camera_model(), sp);
  ASSERT_TRUE(whole.ok() && part.ok());
  StereoFrame f;
  int frames = 0, full_frames = 0, person_frames = 0, same_frames = 0;
  double measured_sum = 0;
  int found[2] = {0, 0}, false_tracks[2] = {0, 0};
  while (true) {
    auto more = (*src)->next(&f);
    ASSERT_TRUE(more.ok()) << more.error().str();
    if (!*more) break;
    StereoFrame a = f, b = f;
    ASSERT_TRUE(render::match_disparity(*matcher, *(*src)->camera_model(), &a).ok());
    const cv::Mat wanted = part->depth_wanted(b);
    ASSERT_TRUE(render::match_disparity(*matcher, *(*src)->camera_model(), &b, wanted).ok());
    if (wanted.empty()) {
      EXPECT_TRUE(b.depth_measured.empty());
      ++full_frames;
    } else {
      measured_sum += static_cast<double>(cv::countNonZero(b.depth_measured)) / b.depth_measured.total();
    }
    auto ta = whole->process(a);
    auto tb = part->process(b);
    ASSERT_TRUE(ta.ok() && tb.ok());
    ++frames;
    const World& w = (*src)->world();
    std::vector<cv::Point2d> truth;
    for (const auto& p : w.people())
      if (p.present) truth.emplace_back(p.pose.x, p.pose.y);
    for (const auto& o : w.objects()) truth.emplace_back(o.pose.x, o.pose.y);
    const std::vector<Track>* tracks[2] = {&*ta, &*tb};
    bool in_range = false;
    for (int k = 0; k < 2; ++k) {
      for (const Track& t : *tracks[k]) {
        bool near = false;
        for (const auto& q : truth) near = near || std::hypot(t.x - q.x, t.y - q.y) < 0.7;
        false_tracks[k] += !near;
      }
      for (const auto& p : w.people()) {
        const double range = std::hypot(p.pose.x - 27.0, p.pose.y - 3.9);
        if (!p.present || range > 7.0 || range < 1.5) continue;
        if (k == 0) in_range = true, ++person_frames;
        for (const Track& t : *tracks[k])
          if (std::hypot(t.x - p.pose.x, t.y - p.pose.y) < 0.5) {
            ++found[k];
            break;
          }
      }
    }
    if (in_range && ta->size() == tb->size()) {
      bool alike = true;
      for (size_t i = 0; i < ta->size(); ++i)
        alike = alike && std::hypot((*ta)[i].x - (*tb)[i].x, (*ta)[i].y - (*tb)[i].y) < 0.05;
      same_frames += alike;
    }
  }
  const int partial = frames - full_frames;
  ASSERT_GT(partial, 150);
  ASSERT_GT(person_frames, 30);
  std::printf("%d frames (%d matched whole), matched area %.1f%% of the image on the others; person found on %d "
              "(whole image) and %d (where the colour changes) of %d frames, false tracks %d and %d; the same "
              "tracks on %d frames with the person in range\n",
              frames, full_frames, 100 * measured_sum / partial, found[0], found[1], person_frames, false_tracks[0],
              false_tracks[1], same_frames);
  // The first 10 frames and one in 60 after them are matched whole.
  EXPECT_EQ(full_frames, 10 + (frames - 10) / 60);
  EXPECT_LT(measured_sum / partial, 0.35);
  EXPECT_GE(found[1], found[0] - person_frames / 50);
  EXPECT_LE(false_tracks[1], false_tracks[0] + false_tracks[0] / 5 + 10);
}

// scenarios/dis_occlusion.yaml: B walks towards the camera behind A (who stands nearer), waits
// and walks back; with the renderer's depth both keep one identity each through the occlusion.
TEST(PlanViewSystem, IdentitiesSurviveAPersonWalkingBehindAnother) {
  Scenario sc = load("dis_occlusion");
  auto src = render::RenderedStereoSource::open(sc, "cam_corridor");
  ASSERT_TRUE(src.ok()) << src.error().str();
  PlanViewSystemParams sp;
  sp.tracking.camera = "cam_corridor";
  auto sys = PlanViewSystem::create(*(*src)->camera_model(), sp);
  ASSERT_TRUE(sys.ok()) << sys.error().str();
  StereoFrame f;
  std::map<std::string, std::map<int, int>> ids;  // person -> track id -> frames
  std::map<std::string, int> in_range, matched;
  while (true) {
    auto more = (*src)->next(&f);
    ASSERT_TRUE(more.ok()) << more.error().str();
    if (!*more) break;
    auto tracks = sys->process(f);
    ASSERT_TRUE(tracks.ok()) << tracks.error().str();
    if (f.stamp_ns < 2'000'000'000) continue;  // the background is still being learnt
    for (const auto& p : (*src)->world().people()) {
      if (std::hypot(p.pose.x - 27.0, p.pose.y - 3.9) > 8.0) continue;
      ++in_range[p.spec.id];
      for (const auto& t : *tracks) {
        if (std::hypot(t.x - p.pose.x, t.y - p.pose.y) < 0.4) {
          ++matched[p.spec.id];
          ++ids[p.spec.id][t.id];
          break;
        }
      }
    }
  }
  for (const char* who : {"A", "B"}) {
    ASSERT_GT(in_range[who], 60) << who;
    EXPECT_GT(static_cast<double>(matched[who]) / in_range[who], 0.9) << who << ": " << matched[who] << " of " << in_range[who];
    EXPECT_EQ(ids[who].size(), 1u) << who << " was given more than one identity";
  }
  ASSERT_FALSE(ids["A"].empty());
  ASSERT_FALSE(ids["B"].empty());
  EXPECT_NE(ids["A"].begin()->first, ids["B"].begin()->first);
}

// scenarios/dis_walk_past: bag1 stands in the corridor, 6 m from the camera, from the first frame.
// Given the building's map the system tells it from the building in its first frame and tracks it
// as a bag; without the map it is learnt as background and never tracked. The renderer's depth,
// the first 4 s (before C comes near).
TEST(PlanViewSystem, ABagStandingThereFromTheFirstFrameIsTrackedGivenTheBuildingsMap) {
  Scenario sc = load("dis_walk_past");
  sc.duration = 4;
  struct Counts {
    int frames = 0, on_bag = 0, elsewhere = 0, start_pixels = 0;
  };
  auto run = [&](bool with_map) {
    Counts c;
    auto src = render::RenderedStereoSource::open(sc, "cam_corridor");
    EXPECT_TRUE(src.ok()) << src.error().str();
    if (!src.ok()) return c;
    PlanViewSystemParams sp;
    sp.tracking.camera = "cam_corridor";
    auto sys = PlanViewSystem::create(*(*src)->camera_model(), sp);
    EXPECT_TRUE(sys.ok()) << sys.error().str();
    if (!sys.ok()) return c;
    if (with_map) sys->set_static_map((*src)->world().map());
    StereoFrame f;
    while (true) {
      auto more = (*src)->next(&f);
      EXPECT_TRUE(more.ok()) << more.error().str();
      if (!more.ok() || !*more) break;
      auto tracks = sys->process(f);
      EXPECT_TRUE(tracks.ok()) << tracks.error().str();
      if (!tracks.ok()) break;
      if (f.index == 0) c.start_pixels = cv::countNonZero(sys->start_objects().empty() ? cv::Mat(1, 1, CV_8U, cv::Scalar(0)) : sys->start_objects());
      if (f.stamp_ns < 1'000'000'000) continue;
      const ObjectEntity& bag = (*src)->world().objects().at(0);
      ++c.frames;
      bool on = false;
      for (const Track& t : *tracks) {
        if (std::hypot(t.x - bag.pose.x, t.y - bag.pose.y) < 0.3 && t.cls == TrackClass::kBag)
          on = true;
        else if (t.cls == TrackClass::kPerson || t.cls == TrackClass::kBag)
          ++c.elsewhere;
      }
      c.on_bag += on;
    }
    return c;
  };
  const Counts with = run(true), without = run(false);
  std::printf("[start objects] with the map: bag tracked on %d of %d frames (%d start pixels, %d other tracks); "
              "without: %d\n",
              with.on_bag, with.frames, with.start_pixels, with.elsewhere, without.on_bag);
  ASSERT_GT(with.frames, 40);
  EXPECT_GT(with.start_pixels, 0);
  EXPECT_GT(with.on_bag, 0.9 * with.frames);
  EXPECT_EQ(with.elsewhere, 0);  // nothing of the building taken for a person or a bag
  EXPECT_EQ(without.on_bag, 0);
}

// Someone standing 0.45 m from the corridor's south wall from the first frame, 5 m from the
// camera, walks off out of the plan view: nothing is left where she stood (no track, no
// foreground). The rays over her head meet that wall long before the floor, and the background
// depth given to her pixels is the wall's. (Here the model also relearns the uncovered wall with
// the floor's depth, 10 m and more away, so this does not single out the wall cut; it guards
// the start objects' clean exit.)
TEST(PlanViewSystem, AStartObjectThatLeavesLeavesNothingBehindOnTheWall) {
  const char* text = R"(
name: start_object_leaves
map: ../maps/dis_labs.floorplan.yaml
duration: 12
seed: 1
physics_rate_hz: 100
record_rate_hz: 10
cameras:
  - id: cam_corridor
    position: [27.0, 3.9, 2.5]
    yaw_deg: 180
    pitch_deg: 15
    resolution: [320, 240]
    hfov_deg: 60
    baseline: 0.09
    rate_hz: 15
people:
  - id: A
    start: [22.0, 2.5]
    speed: 1.2
    script:
      - wait: 1.5
      - walk_to: [12.0, 3.1]
)";
  auto sc = parse_scenario(text, test::source_dir() / "scenarios" / "inline_start_object.yaml");
  ASSERT_TRUE(sc.ok()) << sc.error().str();
  auto src = render::RenderedStereoSource::open(*sc, "cam_corridor");
  ASSERT_TRUE(src.ok()) << src.error().str();
  PlanViewSystemParams sp;
  sp.tracking.camera = "cam_corridor";
  auto sys = PlanViewSystem::create(*(*src)->camera_model(), sp);
  ASSERT_TRUE(sys.ok()) << sys.error().str();
  sys->set_static_map((*src)->world().map());
  int a_tracked = 0, left_over = 0, start_foreground = 0;
  run_frames(**src, *sys, [&](const StereoFrame& f, const std::vector<Track>& tracks) {
    const auto& a = (*src)->world().people().at(0).pose;
    for (const Track& t : tracks) {
      if (f.stamp_ns < 1'500'000'000 && std::hypot(t.x - a.x, t.y - a.y) < 0.4) ++a_tracked;
      if (f.stamp_ns > 10'000'000'000) ++left_over;  // A is 14 m off by then, out of the plan view
    }
    // Foreground left where she stood at the start (A's own pixels are far from there by then).
    if (f.stamp_ns > 10'000'000'000 && !sys->start_objects().empty())
      start_foreground = std::max(start_foreground, cv::countNonZero(sys->foreground() & sys->start_objects()));
  });
  std::printf("[start object leaves] A tracked on %d frames at the start; %d track reports and at most %d foreground "
              "pixels where she stood, after she left\n",
              a_tracked, left_over, start_foreground);
  EXPECT_GT(a_tracked, 10);
  EXPECT_EQ(left_over, 0);
  EXPECT_LT(start_foreground, 20);
}

// A near person-like block (3 m) in front of a far background (9 m), its outline pixels of
// mixed depth (6 m, as stereo gives at the discontinuity): with the depth-edge filter the outline
// leaves the plan view (nothing lands beyond 4.5 m), without it the outline is smeared behind.
TEST(PlanViewSystem, DepthEdgeFilterDropsMixedDepthOutlinePixels) {
  CameraPose pose;
  pose.position = Eigen::Vector3d(0, 0, 2.5);
  pose.pitch = 15 * M_PI / 180;
  const StereoCameraModel cam(Intrinsics::from_hfov(320, 240, 60 * M_PI / 180), 0.09, pose);
  auto far_occupancy = [&](int edge_radius) {
    PlanViewSystemParams sp;
    sp.depth_filter.edge_radius = edge_radius;
    auto sys = PlanViewSystem::create(cam, sp);
    EXPECT_TRUE(sys.ok());
    StereoFrame f;
    f.left = cv::Mat(240, 320, CV_8UC3, cv::Scalar(120, 120, 120));
    cv::randu(f.left, cv::Scalar::all(100), cv::Scalar::all(140));
    f.depth = cv::Mat(240, 320, CV_32F, cv::Scalar(9.0f));
    for (int i = 0; i < 20; ++i) {  // the empty scene: background
      f.index = i;
      f.stamp_ns = i * 66'666'667LL;
      EXPECT_TRUE(sys->process(f).ok());
    }
    const cv::Rect block(140, 60, 40, 150), outline(block.x - 2, block.y - 2, block.width + 4, block.height + 4);
    f.left(outline).setTo(cv::Scalar(30, 30, 200));
    f.depth(outline).setTo(6.0f);
    f.depth(block).setTo(3.0f);
    f.index = 20;
    f.stamp_ns = 20 * 66'666'667LL;
    EXPECT_TRUE(sys->process(f).ok());
    const PlanView& pv = sys->plan_view();
    EXPECT_GT(pv.points, 1000);  // the block is in the plan view
    double far = 0;
    for (int r = 0; r < pv.grid.rows; ++r)
      for (int c = 0; c < pv.grid.cols; ++c) {
        const Eigen::Vector2d m = pv.grid.to_map(c, r);
        if ((m - pv.camera_xy).norm() > 4.5) far += pv.occupancy.at<float>(r, c);
      }
    return far;
  };
  EXPECT_EQ(far_occupancy(3), 0.0);
  EXPECT_GT(far_occupancy(0), 0.0);
}

TEST(PlanViewSystem, FramesWithoutDepthOfAnotherSizeOrOutOfOrderAreErrors) {
  Scenario sc = load("dis_left_bag");
  render::RenderedSourceOptions ro;
  ro.max_frames = 2;
  auto src = render::RenderedStereoSource::open(sc, "cam_corridor", ro);
  ASSERT_TRUE(src.ok());
  auto sys = PlanViewSystem::create(*(*src)->camera_model());
  ASSERT_TRUE(sys.ok());
  StereoFrame f0, f1;
  ASSERT_TRUE((*src)->next(&f0).ok());
  ASSERT_TRUE((*src)->next(&f1).ok());
  StereoFrame no_depth = f0;
  no_depth.depth = cv::Mat();
  auto r = sys->process(no_depth);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().str().find("no depth"), std::string::npos) << r.error().str();
  StereoFrame small = f0;
  cv::resize(f0.left, small.left, {320, 240});
  r = sys->process(small);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().str().find("320x240"), std::string::npos) << r.error().str();
  StereoFrame empty;
  ASSERT_FALSE(sys->process(empty).ok());
  // NaN and inf depth are no depth, not a crash.
  StereoFrame nan = f0;
  nan.depth = f0.depth.clone();
  nan.depth(cv::Rect(0, 0, 320, 240)).setTo(std::numeric_limits<float>::quiet_NaN());
  nan.depth(cv::Rect(320, 240, 320, 240)).setTo(std::numeric_limits<float>::infinity());
  ASSERT_TRUE(sys->process(nan).ok());
  ASSERT_TRUE(sys->process(f1).ok());
  // f0 again: its stamp is before f1's.
  r = sys->process(f0);
  ASSERT_FALSE(r.ok());
}

}  // namespace
}  // namespace vigil::vision
