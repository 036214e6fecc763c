#include "vision/mser/lines.h"

#include <cmath>

#include <opencv2/imgproc.hpp>

namespace vigil::vision::mser {

float LineSegment::angle() const { return std::atan2(b.y - a.y, b.x - a.x); }

void detect_lines(const cv::Mat& bgr, const LineParams& p, Lines* out) {
  cv::Mat grey, edges;
  cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
  cv::Canny(grey, edges, p.canny_low, p.canny_high, 3, false);
  // Edge chains (each traced once), simplified to polylines whose pieces are the segments.
  std::vector<std::vector<cv::Point>> chains;
  cv::findContours(edges, chains, cv::RETR_LIST, cv::CHAIN_APPROX_NONE);
  out->segments.clear();
  out->mask = cv::Mat::zeros(bgr.size(), CV_8U);
  std::vector<cv::Point> poly;
  for (const auto& chain : chains) {
    if (chain.size() < 2) continue;
    // findContours walks an open chain there and back: keep the first half's worth of length.
    cv::approxPolyDP(chain, poly, p.max_deviation, false);
    for (size_t i = 0; i + 1 < poly.size(); ++i) {
      LineSegment s{cv::Point2f(poly[i]), cv::Point2f(poly[i + 1])};
      if (s.length() < p.min_length) continue;
      // The same piece walked back: skip the reverse duplicate.
      bool dup = false;
      for (size_t k = out->segments.size(); k-- > 0 && out->segments.size() - k <= poly.size();) {
        const LineSegment& o = out->segments[k];
        if (cv::norm(o.a - s.b) < 1.5 && cv::norm(o.b - s.a) < 1.5) {
          dup = true;
          break;
        }
      }
      if (dup) continue;
      out->segments.push_back(s);
      cv::line(out->mask, poly[i], poly[i + 1], cv::Scalar(255), 1, cv::LINE_8);
    }
  }
}

}  // namespace vigil::vision::mser
