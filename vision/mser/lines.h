// Line detection for the colour MSER segmenter (chapter 10.3.1, "Line Detection"): Canny edges
// turned into straight line segments (edge chains traced and split where they bend), whose
// pixels region growth may not cross. A low-gradient gap in a strong border is bridged by
// Canny's hysteresis, so two same-coloured regions with a faint border stay apart.
#pragma once

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
  double min_length = 6;                    // px: shorter segments are dropped
};

struct Lines {
  std::vector<LineSegment> segments;
  cv::Mat mask;  // CV_8U, 255 on the segments' pixels (what growth may not cross)
};

void detect_lines(const cv::Mat& bgr, const LineParams& params, Lines* out);

}  // namespace vigil::vision::mser
