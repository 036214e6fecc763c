// The colour MSER segmenter of chapter 10.3.1 (King and Nicolescu): line detection, MSER-tree
// construction over texture elements, and region expansion into a full segmentation.
//
// Tree construction. Texture elements (texture.h) are processed in increasing value; each merges
// its three-pixel unit (the pixel and its two neighbours in the element's direction), merging the
// regions the pixels belong to, except across line pixels (lines.h). After all elements of one
// value, every region that grew has its rate of growth measured: while its growth keeps
// accelerating or keeps declining it evolves on; when the growth turns from declining (or
// stable) to accelerating by more than MIN-SIZE pixels, the region as it was before the
// accelerated growth is stored as an MSER (if it has at least MIN-SIZE pixels). The stored
// regions nest into a tree; the last regions standing (the whole image, or each part lines cut
// off completely) are its roots. MIN-SIZE (24 pixels) is the only threshold.
//
// Region expansion (the second of the dual pass). The leaves of the tree (MSERs with no MSER
// inside) seed the segmentation; the elements are processed again in order and grow the leaves
// over the unassigned pixels, never merging two leaves and never crossing a line, until every
// pixel is in exactly one region. Parts no leaf reaches (closed off by lines) are regions of
// their own when they have MIN-SIZE pixels; line pixels and smaller parts join the adjacent
// region of the nearest mean colour.
//
// Pixel membership of every tree node is kept without copying: regions keep their pixels in a
// linked list that merges only concatenate (the larger region's list first), so a region as it
// was at any time is the run of `size` list entries from its head.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "vision/mser/lines.h"
#include "vision/mser/texture.h"

namespace vigil::vision::mser {

struct SegmenterParams {
  int min_size = 24;        // MIN-SIZE (pixels): the chapter's default
  bool use_lines = true;    // line constraint (off: plain colour MSER evolution)
  // Region feed-forward (10.3.1): pixels unchanged since the last frame (every channel within
  // `unchanged_within`) in a region whose majority is unchanged, and whose gradient is below the
  // region's average (or below `low_gradient`), and whose colour is within `seed_colour` of the
  // region's mean, seed this frame's evolution as one group per region. The colour gate keeps a
  // region that swallowed something unlike it (a distant person's shirt, merged into the wall
  // while it was a few pixels) from passing the merge on frame after frame: the swallowed part's
  // pixels evolve afresh and become their own region once they can. Off: every frame from scratch.
  bool feed_forward = false;
  int unchanged_within = 1;
  int low_gradient = 8;
  double seed_colour = 30;  // the tracking phases' colour limit (region_tracker.h)
  LineParams lines;
};

// A node of the MSER tree.
struct MserNode {
  int parent = -1;
  std::vector<int> children;
  int level = 0;     // the texture value after which it was stored (255 for roots)
  int size = 0;      // pixels
  int head = -1;     // first pixel of its run in MserSegmenter::pixel_list()
};

// A region of the segmentation.
struct Region {
  int size = 0;
  cv::Vec3f mean;            // mean colour, in the image's channel order
  cv::Point2f centroid;
  float cxx = 0, cyy = 0, cxy = 0;  // second moments of the pixel positions (covariance, px^2)
  cv::Rect bbox;
  int node = -1;             // the MSER-tree leaf it grew from (-1: a part no leaf reached)
  int donor = -1;            // feed-forward: the last frame's region most of its seeds came from (-1: none)
  int seeds = 0;             // feed-forward: pixels it was seeded with
  float width() const;       // 2 sqrt(cxx): the second-moment width (px)
  float height() const;      // 2 sqrt(cyy)
};

struct Segmentation {
  cv::Mat labels;                 // CV_32S: region index of every pixel
  std::vector<Region> regions;
  std::vector<MserNode> tree;     // every stored MSER; roots have parent -1
  std::vector<int> leaves;        // tree nodes without children, in the order stored
};

class MserSegmenter {
 public:
  explicit MserSegmenter(SegmenterParams params = {}) : p_(params) {}
  // Segments a CV_8UC3 image (any size >= 3 x 3; an empty or other-typed image is an error).
  // Buffers are kept between calls, so a run of frames allocates once. With feed_forward, the
  // last call's frame and segmentation seed this one (a frame of another size starts afresh).
  bool segment(const cv::Mat& bgr, Segmentation* out, std::string* error = nullptr);
  // Forgets the last frame (feed-forward starts afresh).
  void reset();
  // Feed-forward seeds of the last call: pixels seeded (and the groups they formed).
  int seeded_pixels() const { return seeded_; }
  int seed_groups() const { return seed_groups_; }

  const Lines& lines() const { return lines_; }
  const TextureElements& texture() const { return tex_; }
  // next[i]: the pixel after pixel i in its region's list (-1 at the end); with a node's head
  // and size it gives the node's pixels.
  const std::vector<int32_t>& pixel_list() const { return next_; }
  // The pixels of tree node `node` of the last segmentation.
  std::vector<int> node_pixels(const Segmentation& s, int node) const;
  const SegmenterParams& params() const { return p_; }
  // Wall time of each phase of the last segment() call (ms).
  struct PhaseTimes {
    double texture = 0, lines = 0, tree = 0, expansion = 0, seeds = 0;  // seeds: feed-forward
  };
  const PhaseTimes& phase_times() const { return times_; }

 private:
  void build_tree(Segmentation* out);
  void expand(const cv::Mat& bgr, Segmentation* out);

  SegmenterParams p_;
  PhaseTimes times_;
  TextureElements tex_;
  Lines lines_;
  std::vector<uint8_t> blocked_;  // line pixels
  // Union-find, pass 1: the parent links (hot: read for every element; a root's entry names its
  // region's record), and the regions' records.
  std::vector<int32_t> parent_;
  struct Rec {
    int32_t root = -1;                                   // its root pixel (-1: swallowed)
    int32_t size = 1, head = -1, tail = -1;              // its size; its pixel list
    int32_t prev_size = 1, growth = 0, growth_before = 0;  // sizes and growths at the last levels it grew
    int16_t hlevel = -2, touched_at = -1;                // the last level it grew; touched this level
    int32_t top_head = -1, top_tail = -1;                // its maximal MSERs (a list through node_next_)
    int32_t pend_head = -1, pend_tail = -1;              // ... those it swallowed this level
  };
  std::vector<Rec> recs_;
  std::vector<int32_t> next_, node_next_, touched_;
  std::vector<std::pair<int32_t, int32_t>> merges_;  // pass 1's unions (roots), in order
  // Pass 2.
  struct RegionSums {
    int64_t n = 0, sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0, c[3] = {0, 0, 0};
    int minx = 1 << 30, miny = 1 << 30, maxx = -1, maxy = -1;
  };
  std::vector<RegionSums> sums_;
  std::vector<int32_t> leaf_of_, root_, region_of_root_, comp_size_;
  std::vector<uint8_t> accepted_;
  // Feed-forward: the last frame and its labels; this frame's seeds (donor region per pixel).
  cv::Mat prev_frame_, prev_labels_;
  int prev_regions_ = 0;
  std::vector<int32_t> seed_of_;
  std::vector<uint8_t> same_, unchanged_bytes_;
  std::vector<uint16_t> grad_;
  struct SeedAcc {
    int32_t unchanged = 0;
    int64_t grad = 0;
  };
  std::vector<SeedAcc> acc_;
  std::vector<std::pair<int32_t, int32_t>> runs_;  // make_seeds: runs of one last-frame label
  // Feed-forward groups (one per last-frame region with seeds): first pixel, size, and the
  // region their component became (-1: a speck, its pixels assigned one by one); those pixels.
  std::vector<int32_t> group_first_, group_size_, group_label_, unassigned_;
  std::vector<int32_t> pending_;  // expansion: pixels not yet in a region
  int seeded_ = 0, seed_groups_ = 0;
  void make_seeds(const cv::Mat& bgr);
};

}  // namespace vigil::vision::mser
