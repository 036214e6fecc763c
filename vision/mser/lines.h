// Line detection for the colour MSER segmenter (chapter 10.3.1, "Line Detection"): Canny edges
// traced into chains (each edge pixel once, from the chain ends first) and split into straight
// line segments where they bend (Douglas-Peucker). Region growth may not cross the chains: the
// mask holds every pixel of an edge component with at least `min_length` pixels, so a doubled
// edge or a short spur at a junction leaves no gap. A low-gradient gap in a strong border is
// bridged by Canny's hysteresis, so two same-coloured regions with a faint border stay apart.
// The segments (end points, angles) serve line-corner tracking.
#pragma once

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

namespace vigil::vision::mser {

struct LineSegment {
  cv::Point2f a, b;  // end points (pixels)
  float length() const { return static_cast<float>(cv::norm(b - a)); }
  float angle() const;  // radians, of a -> b
};

struct LineParams {
  double canny_low = 40, canny_high = 120;  // on the grey image (OpenCV's Canny, L1 gradient, 3x3)
  double max_deviation = 1.5;               // px: a chain is split where it leaves its chord by more
  double min_length = 6;                    // px: shorter segments are dropped; so are edge components of fewer pixels
};

struct Lines {
  std::vector<LineSegment> segments;
  cv::Mat mask;  // CV_8U, 255 on the line pixels (what growth may not cross)
  // Work buffers, kept between calls (a run of frames allocates once).
  std::vector<int16_t> work16;
  std::vector<uint8_t> edge_map;
  std::vector<int32_t> stack, edge_pixels, short_chains;
  cv::Mat grey, padded;
};

// Canny's edges of a CV_8UC1 image with a 3x3 Sobel and the L1 gradient magnitude, exactly as
// cv::Canny(grey, edges, low, high, 3, false) finds them (the same thresholds, taken as their
// floors; the same non-maximum suppression with its ties; hysteresis over 8 neighbours): 255 on
// an edge pixel, 0 elsewhere, written into `out` (row y at out + y * stride; the caller's buffer,
// at least grey.rows rows of grey.cols). One pass of vectorised loops for gradients and
// suppression, then a flood from the strong pixels; cv::Canny takes 3 to 4 times as long on one
// thread (its hysteresis grows a deque).
void canny_edges(const cv::Mat& grey, double low, double high, uint8_t* out, int stride, Lines* work);

void detect_lines(const cv::Mat& bgr, const LineParams& params, Lines* out);

}  // namespace vigil::vision::mser
