// Tests the map-frame evaluation of a run's tracks (vision/map_track_eval.h): ground truth
// interpolated at track stamps, entity sets from the nearest tick, ground-truth ticks without
// tracks counted as empty frames, class-agnostic overall figures beside per-class ones, the
// range, class, camera and carried-object filters, and the ground_truth.jsonl reader's errors.
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <numbers>

#include "vision/map_track_eval.h"

namespace vigil::vision {
namespace {

namespace fs = std::filesystem;

constexpr int64_t kMs = 1000000;

GroundTruthEntity ent(const std::string& id, const std::string& kind, double x, double y, bool carried = false) {
  return GroundTruthEntity{id, kind, x, y, carried};
}

Track trk(int64_t t_ns, int id, TrackClass cls, double x, double y, const std::string& camera = "cam") {
  Track t;
  t.stamp_ns = t_ns;
  t.camera = camera;
  t.id = id;
  t.cls = cls;
  t.x = x;
  t.y = y;
  t.confidence = 1;
  return t;
}

TEST(MapTrackEval, InterpolatesGroundTruthAtTrackStamps) {
  // A person walks 1 m per 100 ms tick along x; the tracker reports halfway between ticks.
  std::vector<GroundTruthTick> gt;
  for (int k = 0; k <= 3; ++k) gt.push_back({k * 100 * kMs, {ent("A", "person", k * 1.0, 2.0)}});
  std::vector<Track> tracks;
  for (int k = 0; k < 3; ++k) tracks.push_back(trk((k * 100 + 50) * kMs, 1, TrackClass::kPerson, k + 0.5, 2.1));
  auto r = evaluate_map_tracks(gt, tracks, {});
  ASSERT_TRUE(r) << r.error().str();
  EXPECT_EQ(r->frames, 3);
  EXPECT_EQ(r->frames_without_tracks, 0);
  EXPECT_DOUBLE_EQ(r->camera_period_s, 0.1);
  EXPECT_EQ(r->overall.num_matches, 3);
  EXPECT_NEAR(r->overall.motp, 0.1, 1e-9);  // 0.1 m off the interpolated path, not 0.5 m off a tick
  EXPECT_DOUBLE_EQ(r->overall.mota, 1.0);
  EXPECT_DOUBLE_EQ(r->overall.idf1, 1.0);
  ASSERT_EQ(r->per_class.size(), 1u);
  EXPECT_EQ(r->per_class[0].first, TrackClass::kPerson);
}

TEST(MapTrackEval, EntitiesComeFromTheNearestTick) {
  // B appears at tick 100 ms. At 40 ms the nearest tick (0) does not have it; at 60 ms it does.
  std::vector<GroundTruthTick> gt = {{0, {ent("A", "person", 0, 0)}},
                                     {100 * kMs, {ent("A", "person", 0, 0), ent("B", "person", 5, 0)}}};
  std::vector<Track> tracks = {trk(40 * kMs, 1, TrackClass::kPerson, 0, 0), trk(60 * kMs, 1, TrackClass::kPerson, 0, 0)};
  MapTrackEvalOptions o;
  o.camera_period_s = 0.02;
  auto r = evaluate_map_tracks(gt, tracks, o);
  ASSERT_TRUE(r) << r.error().str();
  // Frames: 40 and 60 ms, and the ticks 0 and 100 ms (no stamp within 15 ms of them).
  EXPECT_EQ(r->frames, 4);
  EXPECT_EQ(r->frames_without_tracks, 2);
  EXPECT_EQ(r->overall.num_objects, 1 + 1 + 2 + 2);
  EXPECT_EQ(r->overall.num_matches, 2);
  EXPECT_EQ(r->overall.num_misses, 4);  // A at 0 and 100 ms, B at 60 and 100 ms
}

TEST(MapTrackEval, TicksWithoutTracksAreMissedFrames) {
  std::vector<GroundTruthTick> gt;
  for (int k = 0; k < 10; ++k) gt.push_back({k * 100 * kMs, {ent("A", "person", 1, 1)}});
  std::vector<Track> tracks;
  for (int k = 0; k < 5; ++k) tracks.push_back(trk(k * 100 * kMs, 4, TrackClass::kPerson, 1, 1));
  auto r = evaluate_map_tracks(gt, tracks, {});
  ASSERT_TRUE(r) << r.error().str();
  EXPECT_EQ(r->frames, 10);
  EXPECT_EQ(r->frames_without_tracks, 5);
  EXPECT_EQ(r->overall.num_misses, 5);
  EXPECT_DOUBLE_EQ(r->overall.mota, 0.5);
  EXPECT_EQ(r->overall.partially_tracked, 1);
  // No tracks at all: every tick is a frame of misses.
  auto none = evaluate_map_tracks(gt, {}, {});
  ASSERT_TRUE(none) << none.error().str();
  EXPECT_EQ(none->frames, 10);
  EXPECT_DOUBLE_EQ(none->overall.mota, 0.0);
  EXPECT_EQ(none->overall.mostly_lost, 1);
}

TEST(MapTrackEval, OverallIgnoresClassesPerClassDoesNot) {
  std::vector<GroundTruthTick> gt = {{0, {ent("A", "person", 0, 0), ent("B", "bag", 3, 0), ent("L", "laptop", 6, 0)}}};
  // A tracked as a bag, the laptop as unknown, B missed.
  std::vector<Track> tracks = {trk(0, 1, TrackClass::kBag, 0.1, 0), trk(0, 2, TrackClass::kUnknown, 6, 0.2)};
  auto r = evaluate_map_tracks(gt, tracks, {});
  ASSERT_TRUE(r) << r.error().str();
  EXPECT_EQ(r->overall.num_matches, 2);
  EXPECT_EQ(r->overall.num_misses, 1);
  EXPECT_EQ(r->overall.num_false_positives, 0);
  ASSERT_EQ(r->per_class.size(), 3u);
  EXPECT_EQ(r->per_class[0].first, TrackClass::kPerson);
  EXPECT_EQ(r->per_class[0].second.num_misses, 1);
  EXPECT_EQ(r->per_class[1].first, TrackClass::kBag);
  EXPECT_EQ(r->per_class[1].second.num_false_positives, 1);
  EXPECT_EQ(r->per_class[1].second.num_misses, 1);
  EXPECT_EQ(r->per_class[2].first, TrackClass::kUnknown);
  EXPECT_EQ(r->per_class[2].second.num_matches, 1);
  EXPECT_EQ(track_class_of_kind("box"), TrackClass::kUnknown);
  EXPECT_EQ(track_class_of_kind("robot"), TrackClass::kRobot);
}

TEST(MapTrackEval, RangeClassCameraAndCarriedFilters) {
  std::vector<GroundTruthTick> gt = {
      {0, {ent("A", "person", 1, 0), ent("far", "person", 20, 0), ent("r1", "robot", 2, 0), ent("bag1", "bag", 1.3, 0, true)}}};
  std::vector<Track> tracks = {trk(0, 1, TrackClass::kPerson, 1, 0, "a"), trk(0, 2, TrackClass::kPerson, 20, 0, "a"),
                               trk(0, 3, TrackClass::kRobot, 2, 0, "a"), trk(0, 9, TrackClass::kPerson, 1, 0, "b")};
  MapTrackEvalOptions o;
  o.camera = "a";
  auto all = evaluate_map_tracks(gt, tracks, o);
  ASSERT_TRUE(all) << all.error().str();
  EXPECT_EQ(all->cameras, std::vector<std::string>{"a"});
  EXPECT_EQ(all->overall.num_objects, 4);
  EXPECT_EQ(all->overall.num_matches, 3);
  EXPECT_EQ(all->overall.num_misses, 1);  // the carried bag

  o.max_range = 5.0;  // camera at the origin: "far" and its track drop out
  o.exclude_carried = true;
  auto near = evaluate_map_tracks(gt, tracks, o);
  ASSERT_TRUE(near) << near.error().str();
  EXPECT_EQ(near->overall.num_objects, 2);
  EXPECT_EQ(near->overall.num_predictions, 2);
  EXPECT_DOUBLE_EQ(near->overall.mota, 1.0);

  MapTrackEvalOptions view;  // a camera at (0.5, -1) looking along +y with a 90 deg field of view
  view.half_fov = std::numbers::pi / 4;
  view.camera_yaw = std::numbers::pi / 2;
  view.camera_x = 0.5;
  view.camera_y = -1;
  auto fov = evaluate_map_tracks(gt, tracks, view);
  ASSERT_TRUE(fov) << fov.error().str();
  EXPECT_EQ(fov->overall.num_objects, 2);  // A 27 deg and bag1 39 deg off the axis; r1 (56 deg) and far outside
  EXPECT_EQ(fov->overall.num_predictions, 2);  // tracks 1 (cam a) and 9 (cam b) on A

  // Ground truth the camera cannot see (behind a wall, here x > 1.5) is not counted; a track
  // there still is (a track behind a wall is the tracker's error).
  MapTrackEvalOptions walls;
  walls.camera = "a";
  walls.truth_visible = [](double x, double) { return x <= 1.5; };
  auto seen = evaluate_map_tracks(gt, tracks, walls);
  ASSERT_TRUE(seen) << seen.error().str();
  EXPECT_EQ(seen->overall.num_objects, 2);      // A and bag1; r1 (x 2) and far (x 20) hidden
  EXPECT_EQ(seen->overall.num_predictions, 3);  // tracks 1, 2 and 3 all count
  EXPECT_EQ(seen->overall.num_false_positives, 2);

  o.classes = {TrackClass::kRobot};
  auto robots = evaluate_map_tracks(gt, tracks, o);
  ASSERT_TRUE(robots) << robots.error().str();
  EXPECT_EQ(robots->overall.num_objects, 1);
  EXPECT_EQ(robots->overall.num_matches, 1);
  ASSERT_EQ(robots->per_class.size(), 1u);

  o = {};
  o.camera = "nope";
  auto bad = evaluate_map_tracks(gt, tracks, o);
  ASSERT_FALSE(bad);
  EXPECT_EQ(bad.error().key, "camera");
  EXPECT_NE(bad.error().message.find("a, b"), std::string::npos) << bad.error().str();
}

TEST(MapTrackEval, RejectsRepeatedTracksAndBadOptions) {
  std::vector<GroundTruthTick> gt = {{0, {ent("A", "person", 0, 0)}}};
  auto twice = evaluate_map_tracks(gt, {trk(0, 1, TrackClass::kPerson, 0, 0), trk(0, 1, TrackClass::kPerson, 1, 0)}, {});
  ASSERT_FALSE(twice);
  EXPECT_NE(twice.error().message.find("track 1 appears twice"), std::string::npos) << twice.error().str();
  MapTrackEvalOptions o;
  o.match_distance = 0;
  EXPECT_FALSE(evaluate_map_tracks(gt, {}, o));
  EXPECT_FALSE(evaluate_map_tracks({}, {}, {}));
}

TEST(MapTrackEval, SkipsStampsOutsideTheGroundTruth) {
  std::vector<GroundTruthTick> gt = {{1000 * kMs, {ent("A", "person", 0, 0)}}, {1100 * kMs, {ent("A", "person", 0, 0)}}};
  std::vector<Track> tracks = {trk(0, 1, TrackClass::kPerson, 0, 0), trk(1000 * kMs, 1, TrackClass::kPerson, 0, 0),
                               trk(1100 * kMs, 1, TrackClass::kPerson, 0, 0), trk(1140 * kMs, 1, TrackClass::kPerson, 0, 0),
                               trk(5000 * kMs, 1, TrackClass::kPerson, 0, 0)};
  auto r = evaluate_map_tracks(gt, tracks, {});
  ASSERT_TRUE(r) << r.error().str();
  EXPECT_EQ(r->skipped_track_stamps, 2);  // 0 and 5 s; 1.14 s is within half a tick of the last tick
  EXPECT_EQ(r->frames, 3);
  EXPECT_DOUBLE_EQ(r->overall.mota, 1.0);
}

TEST(MapTrackEval, ReadsGroundTruthTicksAndNamesErrors) {
  const fs::path dir = fs::temp_directory_path() / ("vigil_map_eval_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const fs::path good = dir / "gt.jsonl";
  std::ofstream(good, std::ios::binary)
      << "{\"type\":\"tick\",\"t_ns\":0,\"entities\":[{\"id\":\"r1\",\"kind\":\"robot\",\"x\":6.0,\"y\":3.1,\"yaw\":0,"
         "\"odom\":[6,3.1,0]},{\"id\":\"bag1\",\"kind\":\"bag\",\"x\":1,\"y\":2,\"z\":0,\"yaw\":0,\"carried_by\":\"A\"}]}\r\n"
      << "{\"type\":\"tick\",\"t_ns\":100000000,\"entities\":[]}\r\n"
      << "{\"type\":\"action\",\"t_ns\":5,\"person\":\"A\",\"action\":\"appear\"}\n"
      << "{\"type\":\"event\",\"kind\":\"left_bag\",\"t_ns\":5}\n";
  auto r = load_ground_truth_ticks(good);
  ASSERT_TRUE(r) << r.error().str();
  ASSERT_EQ(r->size(), 2u);
  ASSERT_EQ((*r)[0].entities.size(), 2u);
  EXPECT_EQ((*r)[0].entities[0].kind, "robot");
  EXPECT_FALSE((*r)[0].entities[0].carried);
  EXPECT_TRUE((*r)[0].entities[1].carried);
  EXPECT_EQ((*r)[1].t_ns, 100000000);

  struct Case {
    std::string line, expect;
  };
  const std::vector<Case> cases = {
      {"{\"type\":\"tick\",\"t_ns\":200,\"entities\":[{\"id\":\"A\",\"kind\":\"person\",\"x\":1}]}", ":2: entities[0].y: missing"},
      {"{\"type\":\"tick\",\"t_ns\":200,\"entities\":[{\"id\":\"A\",\"kind\":\"person\",\"x\":\"1\",\"y\":1}]}",
       ":2: entities[0].x: expected a number"},
      {"{\"type\":\"tick\",\"t_ns\":0,\"entities\":[]}", ":2: t_ns: ticks must come in increasing time"},
      {"{\"type\":\"tick\",\"t_ns\":200}", ":2: entities: missing"},
      {"{\"t_ns\":200}", ":2: type: missing"},
      {"{\"type\":\"tick\",", ":2: not valid JSON"},
      {"{\"type\":\"tick\",\"t_ns\":200,\"entities\":[{\"id\":\"A\",\"kind\":\"person\",\"x\":1,\"y\":1},"
       "{\"id\":\"A\",\"kind\":\"person\",\"x\":1,\"y\":1}]}",
       ":2: entities[1].id: 'A' appears twice"},
  };
  int n = 0;
  for (const auto& c : cases) {
    const fs::path p = dir / ("bad" + std::to_string(n++) + ".jsonl");
    std::ofstream(p, std::ios::binary) << "{\"type\":\"tick\",\"t_ns\":100,\"entities\":[]}\n" << c.line << "\n";
    auto bad = load_ground_truth_ticks(p);
    ASSERT_FALSE(bad) << c.line;
    EXPECT_NE(bad.error().str().find(p.string() + c.expect), std::string::npos) << bad.error().str();
  }
  EXPECT_FALSE(load_ground_truth_ticks(dir / "missing.jsonl"));
}

}  // namespace
}  // namespace vigil::vision
