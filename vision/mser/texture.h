// Texture elements of the colour MSER segmenter (chapter 10.3.1, "MSER-Tree Construction"): for
// every pixel c, the colour gradient across its three-pixel unit (c-1, c, c+1), horizontally
// (t_h) and vertically (t_v):
//
//   t = sqrt(512 * sum over r, g, b of (p_c - p_{c-1})^2 / (p_c + p_{c-1}) + (p_c - p_{c+1})^2 / (p_c + p_{c+1}))
//
// (a chi-squared distance; a term whose denominator is 0 is 0), clamped to 0..255. Pixels on the
// image border in a direction have no unit there and no element. The elements are then put in
// increasing order with a counting sort (256 values: linear time).
#pragma once

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

namespace vigil::vision::mser {

constexpr uint32_t kElement = 0x3fffffffu, kSideBefore = 1u << 30, kSideAfter = 1u << 31;

// One texture element's value by the formula, for the colours (BGR or RGB order alike) of the
// pixel `c` and its two neighbours `a` and `b` in one direction.
int texture_value(const cv::Vec3b& a, const cv::Vec3b& c, const cv::Vec3b& b);

// The elements of a CV_8UC3 image. Element e = 2 * pixel + direction (0: horizontal, 1:
// vertical); `value[e]` is 0..255, or 255 + 1 (= 256) where the pixel has no unit in that
// direction (left out of the order).
struct TextureElements {
  int width = 0, height = 0;
  std::vector<uint16_t> value;
  // Elements with a unit, in increasing value (stable: by element index within a value). The
  // element is `order[k] & kElement`; with a skip mask, the top bits say which of its unit's two
  // outer pixels is skipped (kSideBefore: left or above; kSideAfter: right or below).
  std::vector<uint32_t> order;
  // order[level_start[v] .. level_start[v + 1]) hold the elements of value v (v = 0..255).
  std::vector<uint32_t> level_start;
  std::vector<uint16_t> key;  // scratch of the sort
};

// The values alone (no order).
void compute_texture_values(const cv::Mat& bgr, TextureElements* out);

// The counting sort of the elements with a unit, leaving out those whose pixel is skipped
// (`skip`, one byte per pixel, non-zero: skip) and those whose unit lies wholly in one group
// (`group`, per pixel, -1: none; the segmenter's feed-forward seeds, one region already).

void order_texture_elements(TextureElements* t, const uint8_t* skip = nullptr, const int32_t* group = nullptr);

// Values and order. `skip` (optional, one byte per pixel, non-zero: skip): those pixels'
// elements get their values but stay out of the order (the segmenter's line pixels, which no
// element may merge).
void compute_texture_elements(const cv::Mat& bgr, TextureElements* out, const uint8_t* skip = nullptr);

}  // namespace vigil::vision::mser
