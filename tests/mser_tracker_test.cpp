// The colour MSER system as a vision::Tracker in the map frame (vision/mser/mser_tracker.h):
// image boxes put on the floor with the camera's pose, a walker on synthetic frames tracked as
// a person where they are, the Tracker interface shared with the plan-view system, and bad
// input refused with the reason.
#include <cmath>
#include <memory>
#include <optional>
#include <set>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "vision/mser/mser_tracker.h"
#include "vision/planview_system.h"

namespace vigil::vision::mser {
namespace {

// A corridor camera as the scenarios mount it: 2.5 m up, looking along +x, 15 degrees down.
StereoCameraModel corridor_camera() {
  CameraPose pose;
  pose.position = Eigen::Vector3d(0, 0, 2.5);
  pose.yaw = 0;
  pose.pitch = 15 * M_PI / 180;
  return StereoCameraModel(Intrinsics::from_hfov(320, 240, 60 * M_PI / 180), 0.09, pose);
}

// The image box of an upright cylinder (radius r, height h) standing at (x, y).
cv::Rect cylinder_box(const StereoCameraModel& cam, double x, double y, double r, double h) {
  double u0 = 1e9, v0 = 1e9, u1 = -1e9, v1 = -1e9;
  for (int i = 0; i < 32; ++i) {
    const double a = i * M_PI / 16;
    for (double z : {0.0, h}) {
      Eigen::Vector2d px;
      EXPECT_TRUE(cam.project_map(Eigen::Vector3d(x + r * std::cos(a), y + r * std::sin(a), z), &px));
      u0 = std::min(u0, px.x()), v0 = std::min(v0, px.y()), u1 = std::max(u1, px.x()), v1 = std::max(v1, px.y());
    }
  }
  return cv::Rect(cv::Point(static_cast<int>(std::lround(u0)), static_cast<int>(std::lround(v0))),
                  cv::Point(static_cast<int>(std::lround(u1)), static_cast<int>(std::lround(v1))));
}

TEST(MserTracker, AnImageBoxStandingOnTheFloorGivesTheFootprintWidthAndHeight) {
  const StereoCameraModel cam = corridor_camera();
  auto t = MserTracker::create(cam);
  ASSERT_TRUE(t.ok()) << t.error().str();
  for (const auto& [x, y] : {std::pair{5.0, 0.0}, std::pair{7.0, 1.0}, std::pair{9.0, -1.2}}) {
    const cv::Rect box = cylinder_box(cam, x, y, 0.25, 1.75);
    double mx, my, w, h;
    ASSERT_TRUE(t->box_to_map(box, &mx, &my, &w, &h)) << x << " " << y;
    EXPECT_NEAR(mx, x, 0.12) << box;
    EXPECT_NEAR(my, y, 0.12) << box;
    EXPECT_NEAR(h, 1.75, 0.15) << box;
    EXPECT_NEAR(w, 0.5, 0.15) << box;
  }
  // A bag-sized box is low and narrow.
  double mx, my, w, h;
  ASSERT_TRUE(t->box_to_map(cylinder_box(cam, 6, 0.5, 0.15, 0.4), &mx, &my, &w, &h));
  EXPECT_NEAR(h, 0.4, 0.1);
  EXPECT_EQ(classify_track(h, w), TrackClass::kBag);
  // Too far, or above the horizon: no floor contact in view.
  EXPECT_FALSE(t->box_to_map(cylinder_box(cam, 20, 0, 0.25, 1.75), &mx, &my, &w, &h)) << "beyond max_range";
  EXPECT_FALSE(t->box_to_map(cv::Rect(100, 0, 20, 20), &mx, &my, &w, &h)) << "above the horizon";
  // Feet cut off by the bottom edge: a tall box is placed as a person by its top.
  cv::Rect near = cylinder_box(cam, 2.8, 0.0, 0.25, 1.7);
  ASSERT_GT(near.y + near.height, 240) << "the test needs the feet out of view";
  near.height = 240 - near.y;
  ASSERT_TRUE(t->box_to_map(near, &mx, &my, &w, &h));
  EXPECT_NEAR(mx, 2.8, 0.35);
  EXPECT_NEAR(my, 0.0, 0.1);
  EXPECT_DOUBLE_EQ(h, 1.7);
  cv::Rect squat = near;
  squat.height = squat.width / 2;
  squat.y = 240 - squat.height;
  EXPECT_FALSE(t->box_to_map(squat, &mx, &my, &w, &h)) << "a low box cut off at the bottom cannot be placed";
}

// A synthetic corridor: the same textured floor every frame and a walker drawn as a shirt over
// trousers where their cylinder projects.
cv::Mat frame_with_walker(const StereoCameraModel& cam, double x, double y, bool walker) {
  cv::Mat img(240, 320, CV_8UC3);
  cv::RNG rng(17);
  rng.fill(img, cv::RNG::UNIFORM, 150, 158);
  // Tile lines away from the walker's path (a line running under the feet can bleed into the
  // trousers' region where Canny leaves a gap at the junction: docs/MSER.md).
  for (int u = 230; u < 320; u += 60) cv::line(img, {u, 120}, {u - 40, 239}, cv::Scalar(90, 90, 90), 2);
  if (walker) {
    const cv::Rect b = cylinder_box(cam, x, y, 0.25, 1.75);
    const int waist = b.y + b.height / 2;
    cv::rectangle(img, cv::Rect(b.x, b.y, b.width, waist - b.y), cv::Scalar(40, 40, 200), cv::FILLED);
    cv::rectangle(img, cv::Rect(b.x, waist, b.width, b.y + b.height - waist), cv::Scalar(120, 40, 30), cv::FILLED);
  }
  return img;
}

TEST(MserTracker, TracksAWalkerAsOnePersonWhereTheyWalk) {
  const StereoCameraModel cam = corridor_camera();
  MserTrackerParams p;
  p.camera = "cam";
  auto made = MserTracker::create(cam, p);
  ASSERT_TRUE(made.ok());
  std::unique_ptr<Tracker> tracker = std::make_unique<MserTracker>(std::move(*made));
  EXPECT_EQ(tracker->name(), "mser");
  EXPECT_FALSE(tracker->needs_depth());
  std::set<int> ids;
  int reported = 0;
  for (int k = 0; k < 60; ++k) {
    StereoFrame f;
    f.index = k;
    f.stamp_ns = k * 66'666'667LL;
    const double x = 8.0 - 0.07 * (k - 25), y = -0.8 + 0.02 * (k - 25);  // 1.1 m/s towards the camera
    f.left = frame_with_walker(cam, x, y, k >= 25);
    auto tracks = tracker->process(f);
    ASSERT_TRUE(tracks.ok()) << tracks.error().str();
    if (k < 25) {
      EXPECT_TRUE(tracks->empty()) << "nothing moves before the walker comes, frame " << k;
      continue;
    }
    for (const Track& t : *tracks) {
      EXPECT_EQ(t.camera, "cam");
      ids.insert(t.id);
      ++reported;
      EXPECT_NEAR(t.x, x, 0.3) << "frame " << k;  // a pixel of the foot row is 8 cm at 7 m
      EXPECT_NEAR(t.y, y, 0.3) << "frame " << k;
      EXPECT_EQ(t.cls, TrackClass::kPerson) << "frame " << k << " height " << t.height;
      if (k > 35) {
        EXPECT_NEAR(t.vx, -1.05, 0.35) << "frame " << k;
      }
    }
    if (k == 59) {
      const cv::Mat a = tracker->annotate(f, *tracks);
      EXPECT_EQ(a.cols, 640) << "the view and the segmentation side by side";
    }
  }
  EXPECT_GE(reported, 30) << "the walker is reported on most frames once confirmed";
  EXPECT_EQ(ids.size(), 1u);
  // reset(): forgets the background; ids go on counting.
  tracker->reset();
  for (int k = 0; k < 40; ++k) {
    StereoFrame f;
    f.index = 60 + k;
    f.stamp_ns = (60 + k) * 66'666'667LL;
    f.left = frame_with_walker(cam, 7.0, 0.3 + 0.05 * k, k >= 25);
    auto tracks = tracker->process(f);
    ASSERT_TRUE(tracks.ok());
    for (const Track& t : *tracks) EXPECT_GT(t.id, *ids.rbegin()) << "an id is never reused after reset";
  }
}

// A table in front of the corridor camera (from the floor plan) with a laptop on it, drawn as
// their projected outlines.
cv::Mat table_scene(const StereoCameraModel& cam) {
  cv::Mat img(240, 320, CV_8UC3);
  cv::RNG rng(5);
  rng.fill(img, cv::RNG::UNIFORM, 150, 158);
  auto quad = [&](double x0, double y0, double x1, double y1, double z, cv::Scalar colour) {
    std::vector<cv::Point> pts;
    for (const auto& [x, y] : {std::pair{x0, y0}, std::pair{x1, y0}, std::pair{x1, y1}, std::pair{x0, y1}}) {
      Eigen::Vector2d px;
      EXPECT_TRUE(cam.project_map(Eigen::Vector3d(x, y, z), &px));
      pts.emplace_back(static_cast<int>(std::lround(px.x())), static_cast<int>(std::lround(px.y())));
    }
    cv::fillConvexPoly(img, pts, colour);
  };
  quad(5.1, -0.9, 6.0, 0.9, 0.75, cv::Scalar(60, 110, 170));  // the table top, brown
  quad(5.3, 0.2, 5.6, 0.55, 0.78, cv::Scalar(120, 120, 120));  // the laptop, grey
  return img;
}

// The tracker's parameters with the table of table_scene in the floor plan (x 5.1 to 6.0, y -0.9
// to 0.9, 0.75 m high), and the image point of the middle of its far edge.
MserTrackerParams with_table() {
  MserTrackerParams p;
  p.surfaces.push_back({5.55, 0.0, 0.0, 0.9, 1.8, 0.75});  // centre, yaw, size x, size y, height
  return p;
}
Eigen::Vector2d table_far_edge(const StereoCameraModel& cam) {
  Eigen::Vector2d edge;
  EXPECT_TRUE(cam.project_map(Eigen::Vector3d(6.0, 0.0, 0.75), &edge));
  return edge;
}

TEST(MserTracker, AnObjectLyingOnATableAtTheStartIsReportedThereAndNotTheTable) {
  const StereoCameraModel cam = corridor_camera();
  MserTrackerParams p;
  p.surfaces.push_back({5.55, 0.0, 0.0, 0.9, 1.8, 0.75});  // centre, yaw, size x, size y, height
  auto t = MserTracker::create(cam, p);
  ASSERT_TRUE(t.ok());
  // Something lying on the table top is placed on it, classed by its height above it.
  const cv::Mat img = table_scene(cam);
  // The same still picture for 25 frames (20 learn the background); the last frame's tracks.
  auto still_run = [&img](MserTracker* tracker) {
    std::vector<Track> last;
    for (int k = 0; k < 25; ++k) {
      StereoFrame f;
      f.index = k;
      f.stamp_ns = (k + 1) * 66'666'667LL;
      f.left = img;
      auto tracks = tracker->process(f);
      EXPECT_TRUE(tracks.ok()) << tracks.error().str();
      if (tracks.ok()) last = *tracks;
    }
    return last;
  };
  const std::vector<Track> last = still_run(&*t);
  ASSERT_EQ(last.size(), 1u) << "the laptop, and not a patch of the table";
  EXPECT_EQ(last[0].id, MserTracker::kStartIds + 1);
  EXPECT_EQ(last[0].cls, TrackClass::kBag);
  EXPECT_NEAR(last[0].x, 5.45, 0.2);
  EXPECT_NEAR(last[0].y, 0.375, 0.2);
  EXPECT_GT(last[0].height, 0.74) << "on the table";
  // Without the floor plan's table the same picture has nothing on a surface.
  auto bare = MserTracker::create(cam);
  ASSERT_TRUE(bare.ok());
  EXPECT_TRUE(still_run(&*bare).empty());
}

TEST(MserTracker, SomeoneBehindATableWithTheHeadOutOfViewStandsBeyondItsFarEdge) {
  const StereoCameraModel cam = corridor_camera();
  MserTrackerParams p;
  p.surfaces.push_back({5.55, 0.0, 0.0, 0.9, 1.8, 0.75});  // x 5.1 to 6.0, y -0.9 to 0.9
  auto t = MserTracker::create(cam, p);
  ASSERT_TRUE(t.ok());
  // A tall box from the image's top edge down to a point on the table top well inside its
  // outline (the body seen above the table, the legs hidden by it).
  Eigen::Vector2d on_table;
  ASSERT_TRUE(cam.project_map(Eigen::Vector3d(5.3, 0.0, 0.75), &on_table));
  const int bottom = static_cast<int>(std::lround(on_table.y()));
  const cv::Rect box(static_cast<int>(on_table.x()) - 20, 0, 40, bottom);
  MserTracker::Placement pl;
  ASSERT_TRUE(t->place(box, &pl));
  EXPECT_TRUE(pl.by_head);
  EXPECT_EQ(pl.surface, -1) << "standing on the floor";
  EXPECT_GT(pl.x, 6.0) << "beyond the table's far edge, not on the table";
  EXPECT_LT(pl.x, 6.0 + p.max_footprint);
  EXPECT_NEAR(pl.y, 0.0, 0.05);
}

// The body above a table whose legs the table hides: the box's bottom is the table's far edge,
// and the floor its bottom ray meets beyond the table (here 3 m further) is not where they stand.
TEST(MserTracker, ABoxCutOffByATablesFarEdgeStandsJustBehindItNotWhereItsBottomRayMeetsTheFloor) {
  const StereoCameraModel cam = corridor_camera();
  const MserTrackerParams p = with_table();
  auto t = MserTracker::create(cam, p);
  ASSERT_TRUE(t.ok());
  const Eigen::Vector2d edge = table_far_edge(cam);
  const int bottom = static_cast<int>(std::floor(edge.y())) - 1;  // just above the edge: the floor beyond
  const cv::Rect box(static_cast<int>(edge.x()) - 20, 0, 40, bottom);
  MserTracker::Placement pl;
  ASSERT_TRUE(t->place(box, &pl));
  EXPECT_TRUE(pl.by_head);
  EXPECT_GT(pl.x, 6.0);
  EXPECT_LT(pl.x, 6.0 + p.max_footprint);
  EXPECT_GE(pl.height, p.classes.person_min_height);
  // Where between the edge and that floor they stand the image does not say: the span along
  // the line of sight, from this place to where the bottom ray meets the floor (plus half a
  // footprint), is given for a tracker to place a track in by its motion.
  const Eigen::Vector3d c = cam.pose().position;
  const MserTracker::Placement at_edge = pl;
  EXPECT_NEAR(pl.range_min, std::hypot(pl.x - c.x(), pl.y - c.y()), 1e-6);
  // Without the table the same box stands where its bottom ray meets the floor, far beyond.
  auto bare = MserTracker::create(cam);
  ASSERT_TRUE(bare.ok());
  ASSERT_TRUE(bare->place(box, &pl));
  EXPECT_GT(pl.x, 8.0);
  EXPECT_EQ(pl.range_max, 0.0) << "seen standing: no span";
  EXPECT_NEAR(at_edge.range_max, std::hypot(pl.x - c.x(), pl.y - c.y()), 0.05) << "the span ends where the floor's place is";
}

// The image outline of a level rectangle (x0..x1, y0..y1 at height z).
std::vector<cv::Point> projected_quad(const StereoCameraModel& cam, double x0, double y0, double x1, double y1, double z) {
  std::vector<cv::Point> pts;
  for (const auto& [x, y] : {std::pair{x0, y0}, std::pair{x1, y0}, std::pair{x1, y1}, std::pair{x0, y1}}) {
    Eigen::Vector2d px;
    EXPECT_TRUE(cam.project_map(Eigen::Vector3d(x, y, z), &px));
    pts.emplace_back(static_cast<int>(std::lround(px.x())), static_cast<int>(std::lround(px.y())));
  }
  return pts;
}

// A thing lying on the table drawn over `empty`; with `figure`, a green-shirted figure behind
// it (from the image's top to just below the thing's far side, the thing in front), and with
// `hand` an arm reaching from the figure over the thing's middle.
cv::Mat thing_scene(const cv::Mat& empty, const std::vector<cv::Point>& thing, const cv::Scalar& colour, bool figure,
                    bool hand) {
  const cv::Rect b = cv::boundingRect(thing);
  const cv::Point centre(b.x + b.width / 2, b.y + b.height / 2);
  const cv::Rect body(centre.x - 22, 0, 44, b.y + 4);
  cv::Mat img = empty.clone();
  if (figure) cv::rectangle(img, body, cv::Scalar(60, 160, 50), cv::FILLED);
  cv::fillConvexPoly(img, thing, colour);
  if (hand) cv::line(img, cv::Point(body.x + 6, body.br().y - 8), centre, cv::Scalar(110, 150, 215), 6);
  return img;
}

// Feeds a tracker frame after frame (15 Hz stamps); each call gives that frame's tracks.
struct Feeder {
  MserTracker* tracker;
  int64_t k = 0;
  std::vector<Track> operator()(const cv::Mat& img) {
    StereoFrame f;
    f.index = k;
    f.stamp_ns = ++k * 66'666'667LL;
    f.left = img;
    auto tracks = tracker->process(f);
    EXPECT_TRUE(tracks.ok()) << tracks.error().str();
    return tracks.ok() ? *tracks : std::vector<Track>{};
  }
};

// Someone walks up behind the table and stands there, her head above the image and her legs
// hidden by the table: placed in the span along her line of sight by where she was last seen
// whole. Two frames in which her lower body is lost (trousers merged with what is behind) put
// her bottom above the table's edge, on the floor far beyond; they must not become where she
// was last seen, or every later span placement follows them there.
TEST(MserTracker, TwoWrongFramesBehindATableDoNotMoveWhereSheStands) {
  const StereoCameraModel cam = corridor_camera();
  const MserTrackerParams p = with_table();
  auto t = MserTracker::create(cam, p);
  ASSERT_TRUE(t.ok());
  const Eigen::Vector2d edge = table_far_edge(cam);
  // A figure from the image's top down to its feet at (x, y) (or to `cut_above` rows above the
  // table's far edge), the table drawn over it.
  auto frame = [&](double x, double y, int cut_above) {
    cv::Mat img(240, 320, CV_8UC3);
    cv::RNG rng(5);
    rng.fill(img, cv::RNG::UNIFORM, 150, 158);
    const cv::Rect feet = cylinder_box(cam, x, y, 0.25, 0.3);
    const int bottom = cut_above > 0 ? static_cast<int>(edge.y()) - cut_above : feet.br().y;
    cv::rectangle(img, cv::Rect(feet.x, 0, feet.width, bottom), cv::Scalar(60, 160, 50), cv::FILLED);
    cv::fillConvexPoly(img, projected_quad(cam, 5.1, -0.9, 6.0, 0.9, 0.75), cv::Scalar(60, 110, 170));
    return img;
  };
  const cv::Mat empty = table_scene(cam);
  Feeder step{&*t};
  for (int i = 0; i < 25; ++i) step(empty);
  // Walking up from 9 m at 1 m/s, feet in view until the table hides them; then standing.
  const double stand = 6.3;
  auto person_x = [&](const std::vector<Track>& tracks) {
    double best = -1;
    for (const Track& tr : tracks)
      if (tr.id < MserTracker::kStartIds && tr.cls == TrackClass::kPerson) best = tr.x;
    return best;
  };
  for (double x = 9.0; x > stand; x -= 1.0 / 15) step(frame(x, 0.0, 0));
  int placed = 0;
  for (int i = 0; i < 45; ++i) {
    const double x = person_x(step(frame(stand, 0.0, 0)));
    if (x < 0) continue;
    ++placed;
    EXPECT_NEAR(x, stand, 0.5) << "standing, frame " << i;
  }
  ASSERT_GE(placed, 30) << "she is tracked standing behind the table";
  for (int i = 0; i < 2; ++i) step(frame(stand, 0.0, 20));  // her lower body lost
  placed = 0;
  for (int i = 0; i < 20; ++i) {
    const double x = person_x(step(frame(stand, 0.0, 0)));
    if (x < 0) continue;
    ++placed;
    EXPECT_NEAR(x, stand, 0.5) << "standing again, frame " << i;
  }
  EXPECT_GE(placed, 15);
}

// Hands (Track::hand_on). After the laptop on the table has been learned as present at the
// start, a figure standing behind it (the laptop drawn over the figure: its pixels unchanged)
// has no hand on it; the same figure with an arm over the laptop has.
TEST(MserTracker, AHandOverAnObjectPresentAtTheStartIsSeenAndSomeoneBehindItIsNot) {
  const StereoCameraModel cam = corridor_camera();
  MserTrackerParams p;
  p.surfaces.push_back({5.55, 0.0, 0.0, 0.9, 1.8, 0.75});
  auto t = MserTracker::create(cam, p);
  ASSERT_TRUE(t.ok());
  EXPECT_TRUE(t->sees_hands());
  const cv::Mat empty = table_scene(cam);
  const auto laptop = projected_quad(cam, 5.3, 0.2, 5.6, 0.55, 0.78);
  const cv::Scalar grey(120, 120, 120);
  auto scene = [&](bool hand) { return thing_scene(empty, laptop, grey, true, hand); };
  Feeder step{&*t};
  for (int i = 0; i < 25; ++i) step(empty);
  bool start_object = false;
  for (const Track& tr : step(empty)) start_object = start_object || tr.id == MserTracker::kStartIds + 1;
  ASSERT_TRUE(start_object) << "the laptop, present at the start";
  bool figure = false;
  for (int i = 0; i < 10; ++i)
    for (const Track& tr : step(scene(false))) {
      EXPECT_EQ(tr.hand_on, 0) << "behind the laptop, frame " << i;
      figure = figure || (tr.id < MserTracker::kStartIds && tr.cls != TrackClass::kBag);
    }
  ASSERT_TRUE(figure) << "the figure is tracked";
  int hands = 0;
  for (int i = 0; i < 10; ++i)
    for (const Track& tr : step(scene(true)))
      if (tr.hand_on != 0) {
        EXPECT_EQ(tr.hand_on, MserTracker::kStartIds + 1);
        EXPECT_LT(tr.id, MserTracker::kStartIds);
        ++hands;
      }
  EXPECT_GE(hands, 8) << "the hand seen on the laptop";
}

// The same for a thing put on the table during the run: a dark book appears on the learned
// table and lies there (a still bag track); a figure behind it has no hand on it, an arm over it
// names the book's track.
TEST(MserTracker, AHandOverAThingPutDownDuringTheRunIsSeenAndSomeoneBehindItIsNot) {
  const StereoCameraModel cam = corridor_camera();
  // The book is about 90 pixels of this 320x240 view, under min_object_area (0.2 %, 154 px):
  // a thing lying still on a surface is an object from surface_min_area (0.05 %). A patch as
  // small lying on the floor (a mark, a scrap of paper) is not reported.
  MserTrackerParams p;
  p.surfaces.push_back({5.55, 0.0, 0.0, 0.9, 1.8, 0.75});
  auto t = MserTracker::create(cam, p);
  ASSERT_TRUE(t.ok());
  const cv::Mat empty = table_scene(cam);
  const auto book = projected_quad(cam, 5.15, -0.65, 5.65, -0.35, 0.8);
  const auto patch = projected_quad(cam, 4.4, 1.0, 4.65, 1.2, 0.0);
  ASSERT_LT(cv::contourArea(patch), 154) << "the floor patch is under the object size";
  ASSERT_GT(cv::contourArea(patch), 40) << "... and over surface_min_area";
  auto scene = [&](bool figure, bool hand) {
    cv::Mat img = thing_scene(empty, book, cv::Scalar(30, 30, 30), figure, hand);
    cv::fillConvexPoly(img, patch, cv::Scalar(30, 30, 30));
    return img;
  };
  Feeder step{&*t};
  for (int i = 0; i < 25; ++i) step(empty);
  int book_id = 0;
  for (int i = 0; i < 20; ++i)
    for (const Track& tr : step(scene(false, false))) {
      if (tr.id < MserTracker::kStartIds && tr.cls == TrackClass::kBag) book_id = tr.id;
      EXPECT_GT(std::hypot(tr.x - 4.5, tr.y - 1.1), 0.5) << "the small patch on the floor, frame " << i;
    }
  ASSERT_NE(book_id, 0) << "the book, a still bag on the table";
  for (int i = 0; i < 10; ++i)
    for (const Track& tr : step(scene(true, false))) EXPECT_EQ(tr.hand_on, 0) << "behind the book, frame " << i;
  int hands = 0;
  for (int i = 0; i < 10; ++i)
    for (const Track& tr : step(scene(true, true)))
      if (tr.hand_on != 0) {
        EXPECT_EQ(tr.hand_on, book_id);
        EXPECT_NE(tr.id, book_id);
        ++hands;
      }
  EXPECT_GE(hands, 8) << "the hand seen on the book";
}

// A tiled corridor floor (x 0.5 to 30 m, |y| under 1.5 m; tiles of two greys, with a dark accent
// tile in a sixth of them: a pattern whose third colour covers little of the floor but comes back
// all over it) below light walls, and its map: free inside the corridor, walls around.
cv::Mat tiled_corridor(const StereoCameraModel& cam) {
  cv::Mat img(240, 320, CV_8UC3, cv::Scalar(200, 200, 200));
  for (int i = 0; i < 59; ++i)
    for (int j = 0; j < 6; ++j) {
      const double x0 = 0.5 + 0.5 * i, y0 = -1.5 + 0.5 * j;
      const cv::Scalar c = (i % 3 == 0 && j % 2 == 0) ? cv::Scalar(100, 105, 110)
                           : (i + j) % 2          ? cv::Scalar(150, 150, 150)
                                                  : cv::Scalar(175, 172, 170);
      cv::fillConvexPoly(img, projected_quad(cam, x0, y0, x0 + 0.5, y0 + 0.5, 0.0), c);
    }
  return img;
}

OccupancyGrid corridor_map() {
  OccupancyGrid map(660, 80, 0.05, Pose2{-1.0, -2.0, 0.0}, Cell::kOccupied);
  for (int cy = 0; cy < 80; ++cy)
    for (int cx = 0; cx < 660; ++cx) {
      const Vec2 p = map.cell_center(cx, cy);
      if (p.x < 30.0 && std::abs(p.y) < 1.5) map.set(cx, cy, Cell::kFree);
    }
  return map;
}

// Shirt over trousers where a cylinder standing at (x, y) projects, as frame_with_walker draws.
void draw_figure(cv::Mat& img, const StereoCameraModel& cam, double x, double y, double r, double h, cv::Scalar top,
                 cv::Scalar bottom) {
  const cv::Rect b = cylinder_box(cam, x, y, r, h);
  const int waist = b.y + b.height / 2;
  cv::rectangle(img, cv::Rect(b.x, b.y, b.width, waist - b.y), top, cv::FILLED);
  cv::rectangle(img, cv::Rect(b.x, waist, b.width, b.y + b.height - waist), bottom, cv::FILLED);
}

// Someone standing beside the table holds an arm out to a bottle on it, the hand just above
// the bottle's top: the hand covers none of its pixels, yet the arm's end is at it, so her hand
// is on the bottle. With the arm down she handles nothing; with the arm held out as far to
// empty table beside the bottle, nothing either.
TEST(MserTracker, AnArmHeldOutToABottleIsAHandOnItThoughItCoversNoneOfIt) {
  const StereoCameraModel cam = corridor_camera();
  const cv::Mat empty = table_scene(cam);
  Eigen::Vector2d foot;
  ASSERT_TRUE(cam.project_map(Eigen::Vector3d(5.25, -0.55, 0.75), &foot));
  const cv::Rect bottle(static_cast<int>(foot.x()) - 3, static_cast<int>(foot.y()) - 16, 7, 16);
  const cv::Rect person = cylinder_box(cam, 4.6, -2.1, 0.15, 1.7);
  ASSERT_LT(bottle.br().x + 60, person.x) << "an arm's length of columns between the bottle and her";
  // Arm: from her shoulder to `end`, 2 pixels thick. `y`: where she stands (0.4 m further
  // right while she walks up).
  auto scene = [&](bool with_person, std::optional<cv::Point> end, double y = -2.1) {
    cv::Mat img = empty.clone();
    cv::rectangle(img, bottle, cv::Scalar(40, 150, 60), cv::FILLED);
    if (!with_person) return img;
    draw_figure(img, cam, 4.6, y, 0.15, 1.7, cv::Scalar(150, 60, 40), cv::Scalar(60, 40, 30));
    if (end) cv::line(img, cv::Point(person.x + 2, person.y + person.height / 5), *end, cv::Scalar(150, 60, 40), 2);
    return img;
  };
  // A fresh tracker each time: the background learned, the bottle put down (nobody there), she
  // walks up beside the table (5 frames, arm down), then stands 15 frames with her arm as given. Per frame: whether she was
  // seen, and her hand on the bottle.
  struct Seen {
    int frames = 0, hands = 0, other_hands = 0;
  };
  auto run = [&](std::optional<cv::Point> end) {
    auto tr = MserTracker::create(cam, with_table());
    EXPECT_TRUE(tr.ok());
    Feeder step{&*tr};
    for (int i = 0; i < 25; ++i) step(empty);
    int bottle_id = 0;
    for (int i = 0; i < 15; ++i)
      for (const Track& t : step(scene(false, std::nullopt)))
        if (t.id < MserTracker::kStartIds && t.cls == TrackClass::kBag) bottle_id = t.id;
    EXPECT_NE(bottle_id, 0) << "the bottle, a still bag on the table";
    for (int i = 0; i < 5; ++i) step(scene(true, std::nullopt, -2.5 + 0.08 * i));  // she walks up
    Seen seen;
    for (int i = 0; i < 15; ++i) {
      bool any = false;
      for (const Track& t : step(scene(true, end))) {
        if (t.id == bottle_id || t.id >= MserTracker::kStartIds) continue;
        any = true;
        if (t.hand_on == bottle_id) ++seen.hands;
        else if (t.hand_on != 0) ++seen.other_hands;
      }
      seen.frames += any;
    }
    return seen;
  };
  const Seen reaching = run(cv::Point(bottle.x + 3, bottle.y - 3));
  EXPECT_EQ(reaching.frames, 15) << "she stays an object with her arm held out";
  EXPECT_GE(reaching.hands, 12) << "the arm's end at the bottle";
  EXPECT_EQ(reaching.other_hands, 0);
  const Seen down = run(std::nullopt);
  EXPECT_EQ(down.frames, 15);
  EXPECT_EQ(down.hands + down.other_hands, 0) << "arm down: she handles nothing";
  // The arm held out as far, its end over the table a bottle's height and more from the bottle.
  const Seen beside = run(cv::Point(bottle.br().x + bottle.height + 6, bottle.y - 3));
  EXPECT_EQ(beside.hands + beside.other_hands, 0) << "an arm's end away from the bottle handles nothing";
}

// Things standing on the floor from the first frame are learned into the background with the
// rest; given the building's map, those standing in its free space (not marks on the floor, not
// the floor's own pattern) are released and tracked where they are; someone who then walks off
// leaves no ghost where she stood.
TEST(MserTracker, ThingsOnTheFloorFromTheFirstFrameAreTrackedGivenTheMapAndLeaveNoGhost) {
  const StereoCameraModel cam = corridor_camera();
  const cv::Mat floor = tiled_corridor(cam);
  auto scene = [&](double person_x) {
    cv::Mat img = floor.clone();
    cv::fillConvexPoly(img, projected_quad(cam, 8.5, 0.5, 8.9, 0.9, 0.0), cv::Scalar(40, 40, 200));  // a red mark
    draw_figure(img, cam, 5.0, 0.6, 0.15, 0.45, cv::Scalar(140, 50, 50), cv::Scalar(140, 50, 50));      // a blue bag
    draw_figure(img, cam, person_x, -0.5, 0.25, 1.75, cv::Scalar(40, 150, 60), cv::Scalar(90, 40, 40));  // someone
    return img;
  };
  for (bool with_map : {false, true}) {
    SCOPED_TRACE(with_map ? "with the map" : "without a map");
    auto made = MserTracker::create(cam);
    ASSERT_TRUE(made.ok());
    if (with_map) made->set_static_map(corridor_map());
    Feeder feed{&*made};
    int bag_seen = 0, person_seen = 0, ghost = 0, setting_off = 0;
    for (int k = 0; k < 100; ++k) {
      // Standing still for 60 frames, then walking off towards the camera at 1.2 m/s.
      const double px = 7.0 - (k < 60 ? 0.0 : 0.08 * (k - 60));
      for (const Track& t : feed(scene(px))) {
        EXPECT_FALSE(std::hypot(t.x - 8.7, t.y - 0.7) < 0.4) << "a mark on the floor is not a thing, frame " << k;
        if (!with_map) {
          // (Once she walks off, her regions move: foreground with or without the map.)
          if (k < 60) ADD_FAILURE() << "without the map what was there from the start is background, frame " << k;
          continue;
        }
        if (std::hypot(t.x - 5.0, t.y - 0.6) < 0.2) {
          EXPECT_EQ(t.cls, TrackClass::kBag) << "frame " << k << " height " << t.height;
          ++bag_seen;
        } else if (std::hypot(t.x - px, t.y + 0.5) < 0.35) {
          // Setting off, her still shirt and moving legs may be split for a moment (the system's
          // still-and-moving split, docs/MSER.md), whatever the map.
          if (k < 60 || k >= 70) {
            EXPECT_EQ(t.cls, TrackClass::kPerson) << "frame " << k << " height " << t.height;
          }
          ++person_seen;
        } else if (k >= 60 && k < 70) {
          ++setting_off;
        } else if (k >= 80 && std::hypot(t.x - 7.0, t.y + 0.5) < 0.5) {
          ++ghost;
        } else {
          ADD_FAILURE() << "nothing else is there: track at " << t.x << ", " << t.y << " frame " << k;
        }
      }
    }
    if (with_map) {
      EXPECT_GE(bag_seen, 70) << "the bag is tracked on most frames after learning";
      EXPECT_GE(person_seen, 60) << "she is tracked standing and walking off";
      EXPECT_LE(setting_off, 5);
      EXPECT_EQ(ghost, 0) << "where she stood is background again once she has left";
      EXPECT_GT(cv::countNonZero(made->system().released()), 0);
    }
  }
}

// Someone walks up behind a bag lying on the floor and stands there (the bag in front, their
// blobs one), then takes it and walks off. The bag is held where it lies while covered, and
// ends as soon as the floor shows where it lay; the person keeps one track throughout, placed
// behind the bag by the head at the height measured while the feet were in view, not where the
// merged blob's bottom (the bag's) would put them.
TEST(MserTracker, SomeoneStandingBehindABagIsPlacedByTheHeadAndTheBagHeldUntilTaken) {
  const StereoCameraModel cam = corridor_camera();
  auto made = MserTracker::create(cam);
  ASSERT_TRUE(made.ok());
  Feeder feed{&*made};
  const cv::Mat floor = frame_with_walker(cam, 0, 0, false);
  int64_t bag_id = -1;
  std::set<int64_t> person_ids;
  int bag_last = -1, merged_frames = 0, others = 0;
  for (int k = 0; k < 110; ++k) {
    // Her feet 0.4 m behind the bag are hidden by it: the merged blob's bottom is the bag's.
    const double px = k < 30 ? 9.0 : k < 75 ? 9.0 - 0.08 * (k - 30) : k < 95 ? 5.4 : 5.4 + 0.08 * (k - 95);
    cv::Mat img = floor.clone();
    if (k >= 30) draw_figure(img, cam, px, 0.6, 0.25, 1.75, cv::Scalar(40, 40, 200), cv::Scalar(120, 40, 30));
    if (k >= 25 && k < 95) draw_figure(img, cam, 5.0, 0.6, 0.15, 0.45, cv::Scalar(60, 160, 60), cv::Scalar(60, 160, 60));
    for (const Track& t : feed(img)) {
      if (t.cls == TrackClass::kBag && std::hypot(t.x - 5.0, t.y - 0.6) < 0.2) {
        if (bag_id < 0) bag_id = t.id;
        EXPECT_EQ(t.id, bag_id) << "frame " << k;
        bag_last = k;
      } else if (t.cls == TrackClass::kPerson && std::hypot(t.x - px, t.y - 0.6) < 0.4) {
        person_ids.insert(t.id);
        merged_frames += k >= 77 && k < 95;
      } else {
        // Setting off again, her still shirt and moving legs may be split for a moment (as in
        // ThingsOnTheFloorFromTheFirstFrame...).
        EXPECT_TRUE(k >= 95 && k < 105) << "frame " << k << ": track at " << t.x << ", " << t.y;
        ++others;
      }
    }
  }
  ASSERT_GE(bag_id, 0) << "the bag is tracked";
  EXPECT_GE(bag_last, 94) << "held while she stands over it";
  EXPECT_LE(bag_last, 99) << "gone once the floor shows where it lay";
  EXPECT_GE(merged_frames, 16) << "she is reported where she stands while her blob and the bag's are one";
  EXPECT_EQ(person_ids.size(), 1u) << "one person track, before, while and after she stands behind it";
  EXPECT_LE(others, 5);
}

// A tall walker (1.9 m) coming towards the camera until the feet leave the image: placed by the
// head at the height measured while the feet were in view, not at cut_person_height (1.7 m),
// which would put her a fifth further than she is.
TEST(MserTracker, APersonWhoseFeetLeaveTheImageIsPlacedByTheHeightMeasuredBefore) {
  const StereoCameraModel cam = corridor_camera();
  auto made = MserTracker::create(cam);
  ASSERT_TRUE(made.ok());
  Feeder feed{&*made};
  const cv::Mat floor = frame_with_walker(cam, 0, 0, false);
  int cut_frames = 0;
  for (int k = 0; k < 100; ++k) {
    const double px = 7.5 - 0.07 * std::max(0, k - 25);
    cv::Mat img = floor.clone();
    if (k >= 25) draw_figure(img, cam, px, -0.3, 0.25, 1.9, cv::Scalar(40, 40, 200), cv::Scalar(120, 40, 30));
    const bool cut = cylinder_box(cam, px, -0.3, 0.25, 1.9).br().y >= 240;
    for (const Track& t : feed(img)) {
      if (!cut || k < 30) continue;
      ++cut_frames;
      EXPECT_NEAR(t.x, px, 0.25) << "frame " << k << ", feet out of view";
    }
  }
  EXPECT_GE(cut_frames, 5) << "the test needs frames with the feet out of view";
}

// Feet cut off by the image's bottom edge, a box whose top was taken too high (a bit of wall
// above the head in it) would put the person far behind; she stands no farther than half a
// footprint beyond where the bottom row's ray meets the floor.
TEST(MserTracker, APersonCutOffAtTheBottomStandsNoFartherThanTheBottomEdgeAllows) {
  const StereoCameraModel cam = corridor_camera();
  auto t = MserTracker::create(cam);
  ASSERT_TRUE(t.ok());
  cv::Rect near = cylinder_box(cam, 3.0, 0.0, 0.25, 1.7);
  ASSERT_GT(near.y + near.height, 240) << "the test needs the feet out of view";
  near.height = 240 - near.y;
  double mx, my, w, h;
  ASSERT_TRUE(t->box_to_map(near, &mx, &my, &w, &h));
  EXPECT_NEAR(mx, 3.0, 0.35) << "the head in the box's top row";
  cv::Rect tall = near;
  tall.y -= 25;
  tall.height += 25;
  ASSERT_TRUE(t->box_to_map(tall, &mx, &my, &w, &h));
  // The bottom row's ray meets the floor 2.5 / tan(15 + 23.4 degrees) from the camera.
  const double bottom = 2.5 / std::tan((15 + 0.5 * 46.83) * M_PI / 180);
  EXPECT_LE(mx, bottom + 0.25 + 0.05) << "not placed by the too-high top alone";
  EXPECT_GT(mx, 2.5);
  // Cut off at a side as well: its width is part of its width, so a wide box is a person too.
  cv::Rect corner(0, 150, 120, 90);
  ASSERT_TRUE(t->box_to_map(corner, &mx, &my, &w, &h)) << "cut at the left and bottom";
  EXPECT_DOUBLE_EQ(h, 1.7);
  cv::Rect wide(100, 150, 120, 90);
  EXPECT_FALSE(t->box_to_map(wide, &mx, &my, &w, &h)) << "a wide low box cut at the bottom only is not placed";
}

// A walker far off under a steeply pitched camera (as cam_lab, 35 degrees down) whose head and
// shirt are above the image: her box's top is the image's top, so her height is only a lower
// bound, already taller than a bag. She is marked cut (Track::top_cut) and classed a robot by
// that height, for the vision sensor host to tell from where the robots say they are (a person
// elsewhere: CutTracksAreRobotsOnlyWhereARobotReportsItself); before, no vote was cast and she
// stayed unknown. The same walker nearer, whole in view, is a person and not cut; and one seen
// whole before she walks off stays a person.
TEST(MserTracker, AWalkerWhoseTopTheImageCutsIsMarkedCutAndNotLeftUnknown) {
  CameraPose pose;
  pose.position = Eigen::Vector3d(0, 0, 2.5);
  pose.pitch = 35 * M_PI / 180;
  const StereoCameraModel cam(Intrinsics::from_hfov(320, 240, 60 * M_PI / 180), 0.09, pose);
  for (const double range : {6.5, 2.6}) {
    auto made = MserTracker::create(cam);
    ASSERT_TRUE(made.ok());
    Feeder feed{&*made};
    const cv::Mat floor = frame_with_walker(cam, 0, 0, false);
    const bool cut = cylinder_box(cam, range, 0, 0.25, 1.75).y < 0;
    ASSERT_EQ(cut, range > 5) << "the far walker's head is out of view, the near one's in view";
    int seen = 0;
    for (int k = 0; k < 60; ++k) {
      const double y = -0.9 + 0.07 * std::max(0, k - 25);
      cv::Mat img = floor.clone();
      if (k >= 25) draw_figure(img, cam, range, y, 0.25, 1.75, cv::Scalar(40, 40, 200), cv::Scalar(120, 40, 30));
      for (const Track& t : feed(img)) {
        if (k < 32) continue;
        ++seen;
        EXPECT_NEAR(t.x, range, 0.5) << "frame " << k;
        EXPECT_EQ(t.top_cut, cut) << "frame " << k;
        EXPECT_EQ(t.cls, cut ? TrackClass::kRobot : TrackClass::kPerson) << "frame " << k << " height " << t.height;
        if (cut) {
          EXPECT_GT(t.height, 0.7);
          EXPECT_LT(t.height, 1.75);
        }
      }
    }
    EXPECT_GE(seen, 20) << "range " << range;
  }
  // Seen whole first, then walking off until the image's top cuts her: still a person (the cut
  // boxes say only that she is taller than a bag), and marked cut once she is.
  auto made = MserTracker::create(cam);
  ASSERT_TRUE(made.ok());
  Feeder feed{&*made};
  const cv::Mat floor = frame_with_walker(cam, 0, 0, false);
  int cut_seen = 0;
  for (int k = 0; k < 90; ++k) {
    const double x = 2.6 + 0.07 * std::max(0, k - 25);
    cv::Mat img = floor.clone();
    if (k >= 25) draw_figure(img, cam, x, -0.3, 0.25, 1.75, cv::Scalar(40, 40, 200), cv::Scalar(120, 40, 30));
    for (const Track& t : feed(img)) {
      if (k < 32) continue;
      EXPECT_EQ(t.cls, TrackClass::kPerson) << "frame " << k << " at " << x << " m";
      if (cylinder_box(cam, x, -0.3, 0.25, 1.75).y < -3) cut_seen += t.top_cut;
    }
  }
  EXPECT_GE(cut_seen, 10) << "the test needs frames with her top cut off";
}

TEST(MserTracker, BadFramesAreRefusedWithTheReason) {
  auto t = MserTracker::create(corridor_camera());
  ASSERT_TRUE(t.ok());
  StereoFrame f;
  f.index = 3;
  auto empty = t->process(f);
  ASSERT_FALSE(empty.ok());
  EXPECT_NE(empty.error().message.find("frame 3 has no image"), std::string::npos) << empty.error().str();
  f.left = cv::Mat(100, 100, CV_8UC3, cv::Scalar::all(0));
  auto size = t->process(f);
  ASSERT_FALSE(size.ok());
  EXPECT_NE(size.error().message.find("100x100 but the camera is 320x240"), std::string::npos) << size.error().str();
  f.left = cv::Mat(240, 320, CV_8UC1, cv::Scalar::all(0));
  EXPECT_FALSE(t->process(f).ok()) << "grey";
  f.left = cv::Mat(240, 320, CV_8UC3, cv::Scalar::all(90));
  f.stamp_ns = 1000;
  ASSERT_TRUE(t->process(f).ok());
  auto again = t->process(f);
  ASSERT_FALSE(again.ok());
  EXPECT_NE(again.error().message.find("not after the previous"), std::string::npos) << again.error().str();
  MserTrackerParams bad;
  bad.max_range = -1;
  auto b = MserTracker::create(corridor_camera(), bad);
  ASSERT_FALSE(b.ok());
  EXPECT_EQ(b.error().key, "max_range");
}

// Both camera systems behind the one interface.
TEST(Tracker, ThePlanViewSystemIsATrackerThatNeedsDepth) {
  auto pv = PlanViewSystem::create(corridor_camera());
  ASSERT_TRUE(pv.ok()) << pv.error().str();
  std::unique_ptr<Tracker> t = std::make_unique<PlanViewSystem>(std::move(*pv));
  EXPECT_EQ(t->name(), "planview");
  EXPECT_TRUE(t->needs_depth());
  StereoFrame f;
  f.left = cv::Mat(240, 320, CV_8UC3, cv::Scalar::all(90));
  auto r = t->process(f);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("no depth"), std::string::npos) << r.error().str();
  f.depth = cv::Mat(240, 320, CV_32F, cv::Scalar(5.0f));
  for (int k = 0; k < 3; ++k) {
    f.index = k;
    f.stamp_ns = (k + 1) * 66'666'667LL;
    ASSERT_TRUE(t->process(f).ok());
  }
  t->reset();
  f.stamp_ns += 66'666'667LL;
  EXPECT_TRUE(t->process(f).ok());
}

}  // namespace
}  // namespace vigil::vision::mser
