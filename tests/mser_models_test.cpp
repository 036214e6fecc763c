// Object models of the colour MSER system (vision/mser/object_model.h, chapter 10.3.4): the
// chapter's feature values by hand; pair and individual features unchanged when the object
// moves, grows or turns, and changed when it is stretched; hash-table votes that recognise a
// segmented object drawn elsewhere and larger, with the size and place they agree on, and refuse
// an object of other colours; the system giving a re-entering object its old id back (and not
// without `recognise`); determinism (the same answers whatever order the models were added in,
// the same objects on a second run); bad input refused with the reason.
#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <tuple>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "vision/mser/mser_system.h"
#include "vision/mser/object_model.h"
#include "vision/mser/segmenter.h"

namespace vigil::vision::mser {
namespace {

ModelRegion region(cv::Point2f c, float cxx, float cyy, float cxy, float area, cv::Vec3f colour) {
  ModelRegion r;
  r.centroid = c;
  r.cxx = cxx;
  r.cyy = cyy;
  r.cxy = cxy;
  r.area = area;
  r.colour = colour;
  return r;
}

// The region moved by `t`, scaled by `k` and turned by `a` radians about the origin.
ModelRegion transformed(const ModelRegion& r, cv::Point2f t, float k, float a) {
  const float c = std::cos(a), s = std::sin(a);
  ModelRegion o = r;
  o.centroid = cv::Point2f(k * (c * r.centroid.x - s * r.centroid.y), k * (s * r.centroid.x + c * r.centroid.y)) + t;
  // R C R', times k^2.
  const float xx = c * c * r.cxx - 2 * c * s * r.cxy + s * s * r.cyy;
  const float yy = s * s * r.cxx + 2 * c * s * r.cxy + c * c * r.cyy;
  const float xy = c * s * (r.cxx - r.cyy) + (c * c - s * s) * r.cxy;
  o.cxx = k * k * xx;
  o.cyy = k * k * yy;
  o.cxy = k * k * xy;
  o.area = k * k * r.area;
  return o;
}

TEST(MserModels, FeatureValuesFollowTheChapterByHand) {
  EXPECT_FLOAT_EQ(compare_value(1, 2), 0.5f);    // 1 - 1/2
  EXPECT_FLOAT_EQ(compare_value(2, 1), -0.5f);   // -(1 - 1/2)
  EXPECT_FLOAT_EQ(compare_value(3, 3), 0.0f);
  EXPECT_FLOAT_EQ(compare_value(1, 4), 0.75f);
  // A 60 x 20 box: variances 300 and 33.3; its ellipse's diameters along x and y are its
  // second-moment width and height, 2 sqrt(variance).
  const ModelRegion box = region({0, 0}, 300, 100.0f / 3, 0, 1200, {10, 20, 30});
  EXPECT_NEAR(diameter_along(box, {1, 0}), 2 * std::sqrt(300.0), 1e-4);
  EXPECT_NEAR(diameter_along(box, {0, 1}), 2 * std::sqrt(100.0 / 3), 1e-4);
  // Two regions side by side: colours (B, G, R) = (10, 20, 30) and (41, 20, 9);
  // red/grn: (31/21) vs (10/21) -> -(1 - 10/31); blu/grn: (11/21) vs (42/21) -> 1 - 11/42;
  // sqrt areas 34.64 vs 20 -> -(1 - 20/34.64); distance 60 vs diameters 34.64 + 2 sqrt(100) = 54.64
  // -> -(1 - 54.64/60).
  const ModelRegion other = region({60, 0}, 100, 100, 0, 400, {41, 20, 9});
  const auto f = pair_feature(box, other);
  EXPECT_NEAR(f[0], -(1 - 10.0 / 31), 1e-5);
  EXPECT_NEAR(f[1], 1 - 11.0 / 42, 1e-5);
  EXPECT_NEAR(f[2], -(1 - 20 / std::sqrt(1200.0)), 1e-5);
  EXPECT_NEAR(f[3], -(1 - (std::sqrt(1200.0) + 20) / 60), 1e-5);
  // The other order: the same values negated, the distance's unchanged.
  const auto g = pair_feature(other, box);
  for (int d = 0; d < 3; ++d) EXPECT_NEAR(g[d], -f[d], 1e-5);
  EXPECT_NEAR(g[3], f[3], 1e-5);
  const auto i = individual_feature(other);  // red/grn 10/21, blu/grn 42/21, no lines
  EXPECT_NEAR(i[0], 1 - 10.0 / 21, 1e-5);
  EXPECT_NEAR(i[1], -(1 - 21.0 / 42), 1e-5);
  EXPECT_FLOAT_EQ(i[2], -1.0f);
}

TEST(MserModels, PairFeaturesAreInvariantToTranslationScaleAndRotation) {
  const ModelRegion a = region({12, 30}, 80, 20, 15, 260, {40, 60, 200});
  const ModelRegion b = region({40, 18}, 30, 90, -10, 340, {180, 90, 30});
  const auto f = pair_feature(a, b);
  for (const auto& [t, k, ang] : std::vector<std::tuple<cv::Point2f, float, float>>{
           {{100, -40}, 1.0f, 0.0f}, {{0, 0}, 2.5f, 0.0f}, {{-7, 33}, 0.6f, 0.0f}, {{5, 5}, 1.7f, 0.8f}}) {
    const auto g = pair_feature(transformed(a, t, k, ang), transformed(b, t, k, ang));
    for (int d = 0; d < 4; ++d) EXPECT_NEAR(g[d], f[d], 1e-4) << "dimension " << d << " scale " << k << " turn " << ang;
    const auto ia = individual_feature(transformed(a, t, k, ang));
    for (int d = 0; d < 3; ++d) EXPECT_FLOAT_EQ(ia[d], individual_feature(a)[d]);
  }
  // v3 and v4 are even affine invariant (an ellipse's chord and the centroids' distance stretch
  // alike): stretching the object sideways changes nothing.
  ModelRegion a2 = a, b2 = b;
  for (ModelRegion* r : {&a2, &b2}) {
    r->centroid.x *= 3;
    r->cxx *= 9;
    r->cxy *= 3;
    r->area *= 3;
  }
  for (int d = 0; d < 4; ++d) EXPECT_NEAR(pair_feature(a2, b2)[d], f[d], 1e-4);
  // Not constants: the regions farther apart, one larger, or recoloured, change their dimension.
  ModelRegion far = b, big = b, red = b;
  far.centroid += cv::Point2f(40, 0);
  big.area *= 2;
  red.colour[2] *= 2;
  EXPECT_GT(std::abs(pair_feature(a, far)[3] - f[3]), 0.1);
  EXPECT_GT(std::abs(pair_feature(a, big)[2] - f[2]), 0.1);
  EXPECT_GT(std::abs(pair_feature(a, red)[0] - f[0]), 0.1);
  EXPECT_NEAR(pair_feature(a, red)[1], f[1], 1e-6);
}

// A figure of five coloured patches (hat, head, torso, bag, legs), `k` times its size, its
// top-left at `at`, on a flat noisy floor.
struct Palette {
  cv::Scalar hat, head, torso, bag, legs;
};
const Palette kFigureA{{60, 160, 60}, {150, 170, 220}, {40, 40, 200}, {40, 200, 220}, {160, 60, 30}};
const Palette kFigureB{{200, 200, 40}, {90, 90, 90}, {200, 60, 200}, {30, 120, 30}, {30, 30, 30}};

cv::Rect draw_figure(cv::Mat* img, cv::Point at, double k, const Palette& c) {
  auto box = [&](double x, double y, double w, double h, const cv::Scalar& col) {
    const cv::Rect r(at.x + static_cast<int>(std::lround(k * x)), at.y + static_cast<int>(std::lround(k * y)),
                     static_cast<int>(std::lround(k * w)), static_cast<int>(std::lround(k * h)));
    cv::rectangle(*img, r, col, cv::FILLED);
  };
  box(3, 0, 12, 5, c.hat);
  box(4, 5, 10, 10, c.head);
  box(0, 15, 18, 20, c.torso);
  box(18, 17, 6, 16, c.bag);
  box(2, 35, 14, 18, c.legs);
  return cv::Rect(at.x, at.y, static_cast<int>(std::lround(24 * k)), static_cast<int>(std::lround(53 * k)));
}

cv::Mat floor_image(int seed) {
  cv::Mat img(140, 200, CV_8UC3);
  cv::RNG rng(seed);
  rng.fill(img, cv::RNG::UNIFORM, 110, 116);
  return img;
}

// The segmented regions lying inside `box` (the figure's), as the object model sees them.
std::vector<ModelRegion> figure_regions(const cv::Mat& img, const cv::Rect& box) {
  MserSegmenter seg;
  Segmentation s;
  EXPECT_TRUE(seg.segment(img, &s));
  std::vector<ModelRegion> out;
  const cv::Rect grown(box.x - 2, box.y - 2, box.width + 4, box.height + 4);
  for (const Region& r : s.regions)
    if (r.size >= 24 && (r.bbox & grown) == r.bbox) out.push_back(ModelRegion::from(r));
  return out;
}

TEST(MserModels, HashVotesRecogniseAnObjectSeenElsewhereAndLargerButNotAStranger) {
  cv::Mat first = floor_image(1), later = floor_image(2), stranger = floor_image(3);
  const cv::Rect a0 = draw_figure(&first, {20, 30}, 1.0, kFigureA);
  const cv::Rect a1 = draw_figure(&later, {110, 20}, 1.5, kFigureA);
  const cv::Rect b1 = draw_figure(&stranger, {110, 20}, 1.5, kFigureB);
  const auto ra0 = figure_regions(first, a0), ra1 = figure_regions(later, a1), rb1 = figure_regions(stranger, b1);
  ASSERT_EQ(ra0.size(), 5u);
  ASSERT_EQ(ra1.size(), 5u);
  ASSERT_EQ(rb1.size(), 5u);

  ObjectModels models;
  ASSERT_TRUE(models.add(7, ra0));
  EXPECT_EQ(models.entries(), 5u * 4 + 5) << "both orders of the 10 pairs and the 5 regions";
  const Recognition r = models.recognise(ra1);
  ASSERT_TRUE(r.recognised);
  EXPECT_EQ(r.id, 7);
  EXPECT_GE(r.votes, 10) << "most of its 15 features agree";
  // The size and place the votes agree on: 1.5 times the first scale, at the figure's centre.
  ObjectDescription d0, d1;
  ASSERT_TRUE(describe_object(ra0, {}, &d0));
  ASSERT_TRUE(describe_object(ra1, {}, &d1));
  EXPECT_NEAR(r.scale / d0.scale, 1.5, 0.1);
  EXPECT_LT(cv::norm(r.centre - d1.centre), 0.1 * r.scale);

  const Recognition s = models.recognise(rb1);
  EXPECT_FALSE(s.recognised) << "other colours: votes " << s.votes;
  // With both known, each is told apart.
  ASSERT_TRUE(models.add(9, rb1));
  EXPECT_EQ(models.recognise(ra1).id, 7);
  EXPECT_EQ(models.recognise(figure_regions(first, a0)).id, 7);
  cv::Mat b_small = floor_image(4);
  const cv::Rect b0 = draw_figure(&b_small, {60, 40}, 1.0, kFigureB);
  const Recognition sb = models.recognise(figure_regions(b_small, b0));
  EXPECT_TRUE(sb.recognised);
  EXPECT_EQ(sb.id, 9);
  // Removed: not recognised any more.
  EXPECT_TRUE(models.remove(7));
  EXPECT_FALSE(models.recognise(ra1).recognised);
  EXPECT_EQ(models.entries(), 25u);
  EXPECT_FALSE(models.remove(7));
}

// A size-position vote that disagrees is not counted: the same five patches rearranged (legs on
// top) match every individual feature but imply places that do not agree.
TEST(MserModels, VotesMustAgreeOnTheObjectSPlace) {
  cv::Mat first = floor_image(1);
  const cv::Rect a0 = draw_figure(&first, {20, 30}, 1.0, kFigureA);
  const auto ra0 = figure_regions(first, a0);
  ASSERT_EQ(ra0.size(), 5u);
  ObjectModels models;
  ASSERT_TRUE(models.add(1, ra0));
  // Each region moved far from the others: same colours and sizes, no common centre.
  std::vector<ModelRegion> scattered = ra0;
  for (size_t i = 0; i < scattered.size(); ++i) scattered[i].centroid += cv::Point2f(100.0f * i, -70.0f * (i % 2));
  const Recognition r = models.recognise(scattered);
  EXPECT_FALSE(r.recognised) << "votes " << r.votes;
  EXPECT_GE(r.candidates, 1) << "its features did find the model";
  EXPECT_TRUE(models.recognise(ra0).recognised);
}

TEST(MserModels, RecognitionDoesNotDependOnTheOrderModelsWereAdded) {
  cv::Mat a = floor_image(1), b = floor_image(2), q = floor_image(5);
  const auto ra = figure_regions(a, draw_figure(&a, {20, 30}, 1.0, kFigureA));
  const auto rb = figure_regions(b, draw_figure(&b, {30, 20}, 1.2, kFigureB));
  const auto rq = figure_regions(q, draw_figure(&q, {120, 40}, 1.3, kFigureA));
  ObjectModels one, two;
  ASSERT_TRUE(one.add(3, ra));
  ASSERT_TRUE(one.add(4, rb));
  ASSERT_TRUE(one.add(5, ra));  // the same object twice: the lower id wins the tie
  ASSERT_TRUE(two.add(5, ra));
  ASSERT_TRUE(two.add(4, rb));
  ASSERT_TRUE(two.add(3, ra));
  const Recognition x = one.recognise(rq), y = two.recognise(rq), z = one.recognise(rq);
  ASSERT_TRUE(x.recognised);
  EXPECT_EQ(x.id, 3);
  for (const Recognition& o : {y, z}) {
    EXPECT_EQ(o.id, x.id);
    EXPECT_EQ(o.votes, x.votes);
    EXPECT_EQ(o.scale, x.scale);
    EXPECT_EQ(o.centre, x.centre);
    EXPECT_EQ(o.candidates, x.candidates);
  }
}

TEST(MserModels, BadInputIsRefusedWithTheReason) {
  ObjectModels models;
  std::string why;
  EXPECT_FALSE(models.add(1, {}, &why));
  EXPECT_NE(why.find("at least one region"), std::string::npos) << why;
  ModelRegion bad = region({1, 1}, 4, 4, 0, 0, {1, 2, 3});
  EXPECT_FALSE(models.add(1, {bad}, &why));
  EXPECT_NE(why.find("no area"), std::string::npos) << why;
  bad.area = 30;
  bad.cxx = std::nanf("");
  EXPECT_FALSE(models.add(1, {bad}, &why));
  EXPECT_NE(why.find("non-finite"), std::string::npos) << why;
  EXPECT_EQ(models.size(), 0u);
  EXPECT_FALSE(models.recognise({}).recognised);
  EXPECT_FALSE(models.recognise({bad}, &why).recognised);
  EXPECT_FALSE(describe_object({bad}, {}, nullptr, &why));
  // A one-region object is modelled, and a lone region never wins the vote (min_votes).
  const ModelRegion one = region({5, 5}, 9, 9, 0, 40, {10, 90, 200});
  EXPECT_TRUE(models.add(2, {one}));
  EXPECT_FALSE(models.recognise({one}).recognised);
  // Degenerate shapes (a one-pixel line, coinciding centroids) give finite features.
  const ModelRegion line = region({5, 5}, 25, 0, 0, 30, {0, 0, 0});
  for (float v : pair_feature(line, line)) EXPECT_TRUE(std::isfinite(v));
}

// The system: a learned floor; figure A walks in, out of the image at the right, and steps out
// somewhere else later, larger: it is recognised and gets its id back. Figure B, of other colours,
// is a new object. Without `recognise`, A's return is a new object too. Two runs report the same.
TEST(MserModels, TheSystemGivesARecognisedReenteringObjectItsIdBack) {
  auto frame = [](int f) {
    cv::Mat img(120, 160, CV_8UC3);
    cv::RNG rng(f * 7 + 1);
    rng.fill(img, cv::RNG::UNIFORM, 110, 116);
    cv::rectangle(img, cv::Rect(0, 0, 160, 20), cv::Scalar(170, 170, 175), cv::FILLED);  // a wall band
    if (f >= 22 && f < 38) draw_figure(&img, {70 + 6 * (f - 22), 30}, 1.0, kFigureA);  // walks out at the right
    if (f >= 48 && f < 56) draw_figure(&img, {20 + 2 * (f - 48), 25}, 1.3, kFigureA);  // back, larger
    if (f >= 66 && f < 74) draw_figure(&img, {80 - 2 * (f - 66), 30}, 1.0, kFigureB);  // a stranger
    return img;
  };
  std::vector<std::vector<int64_t>> traces;  // per run: frame, id and box of every reported object
  for (bool recognise : {true, true, false}) {
    traces.emplace_back();
    MserSystemParams p;
    p.recognise = recognise;
    MserSystem sys(p);
    std::set<int64_t> first, back, stranger;
    bool back_recognised = false, in_table_while_back = false;
    for (int f = 0; f < 76; ++f) {
      ASSERT_TRUE(sys.process(frame(f)));
      for (const ImageObject& o : sys.objects()) {
        traces.back().insert(traces.back().end(), {f, o.id, o.box.x, o.box.y, o.box.width, o.box.height});
        if (f >= 22 && f < 34) first.insert(o.id);  // while wholly in view
        if (f >= 50 && f < 56) {
          back.insert(o.id);
          back_recognised = back_recognised || o.recognised;
          in_table_while_back = in_table_while_back || sys.object_models().contains(o.id);
        }
        if (f >= 68 && f < 74) stranger.insert(o.id);
      }
    }
    ASSERT_EQ(first.size(), 1u) << "recognise " << recognise;
    ASSERT_EQ(back.size(), 1u) << "recognise " << recognise;
    ASSERT_EQ(stranger.size(), 1u) << "recognise " << recognise;
    if (recognise) {
      EXPECT_EQ(*back.begin(), *first.begin()) << "the same figure: its old id";
      EXPECT_TRUE(back_recognised);
      EXPECT_FALSE(in_table_while_back) << "in view again: out of the table";
      EXPECT_TRUE(sys.object_models().contains(*first.begin())) << "gone again: back in the table";
    } else {
      EXPECT_NE(*back.begin(), *first.begin());
      EXPECT_FALSE(back_recognised);
      EXPECT_EQ(sys.object_models().size(), 0u);
    }
    EXPECT_NE(*stranger.begin(), *first.begin()) << "recognise " << recognise;
    EXPECT_NE(*stranger.begin(), *back.begin()) << "recognise " << recognise;
  }
  EXPECT_EQ(traces[0], traces[1]) << "deterministic";
  EXPECT_NE(traces[0], traces[2]);
}

}  // namespace
}  // namespace vigil::vision::mser
