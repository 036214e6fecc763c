#include "vision/mser/lines.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

namespace vigil::vision::mser {

float LineSegment::angle() const { return std::atan2(b.y - a.y, b.x - a.x); }

namespace {

// The 8 neighbours, the four sides first: a chain steps diagonally only where no side
// neighbour continues it, so it does not cut a corner and leave the corner pixel for later.
constexpr int kDx[8] = {1, 0, -1, 0, 1, -1, -1, 1};
constexpr int kDy[8] = {0, 1, 0, -1, 1, 1, -1, -1};

// Douglas-Peucker on an open polyline: keeps the points of `chain` that split it into pieces
// no point leaves by more than `eps` (indices into chain, first and last always kept).
void simplify(const std::vector<cv::Point>& chain, double eps, std::vector<int>* keep, std::vector<std::pair<int, int>>* stack) {
  keep->clear();
  stack->clear();
  const int last = static_cast<int>(chain.size()) - 1;
  keep->push_back(0);
  stack->push_back({0, last});
  const double eps2 = eps * eps;
  // Depth first, the first half first: the kept points come out in chain order.
  while (!stack->empty()) {
    const auto [i, j] = stack->back();
    stack->pop_back();
    const double ax = chain[i].x, ay = chain[i].y;
    const double dx = chain[j].x - ax, dy = chain[j].y - ay;
    const double len2 = dx * dx + dy * dy;
    int far = -1;
    double far_d = 0;  // squared distance times len2 (or squared distance to a when i, j meet)
    for (int k = i + 1; k < j; ++k) {
      const double px = chain[k].x - ax, py = chain[k].y - ay;
      const double cross = px * dy - py * dx;
      const double d = len2 > 0 ? cross * cross : (px * px + py * py);
      if (d > far_d) {
        far_d = d;
        far = k;
      }
    }
    const double limit = len2 > 0 ? eps2 * len2 : eps2;
    if (far >= 0 && far_d > limit) {
      stack->push_back({far, j});
      stack->push_back({i, far});
    } else {
      keep->push_back(j);
    }
  }
}

}  // namespace

void detect_lines(const cv::Mat& bgr, const LineParams& p, Lines* out) {
  const int w = bgr.cols, h = bgr.rows;
  // The edge map with a border of one empty pixel, so neighbours need no bounds checks: 255 on
  // an edge pixel, 1 once traced.
  cv::Mat grey, padded = cv::Mat::zeros(h + 2, w + 2, CV_8U);
  cv::Mat edges = padded(cv::Rect(1, 1, w, h));
  cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
  cv::Canny(grey, edges, p.canny_low, p.canny_high, 3, false);  // writes into the padded map
  out->segments.clear();
  out->mask.create(bgr.size(), CV_8U);
  out->mask.setTo(cv::Scalar(0));
  uint8_t* e = padded.ptr<uint8_t>(0);
  const int stride = static_cast<int>(padded.step1());
  int off[8];
  for (int k = 0; k < 8; ++k) off[k] = kDy[k] * stride + kDx[k];
  auto point = [stride](int i) { return cv::Point(i % stride - 1, i / stride - 1); };
  // Edge chains traced over the edge map, each edge pixel once: from the chain ends (pixels with
  // one edge neighbour) first, then what is left (closed loops). A chain that stops beside a
  // pixel of another chain (a junction) takes that pixel as its last point, so the two meet.
  std::vector<int> idx;  // the chain's pixels (indices into the padded map)
  std::vector<cv::Point> chain;
  std::vector<int> keep;
  std::vector<std::pair<int, int>> stack;
  auto trace = [&](int i) {
    idx.clear();
    idx.push_back(i);
    e[i] = 1;
    for (;;) {
      int next = -1;
      for (int k = 0; k < 8; ++k)
        if (e[i + off[k]] == 255) {
          next = i + off[k];
          break;
        }
      if (next < 0) break;
      i = next;
      e[i] = 1;
      idx.push_back(i);
    }
    // The end: a traced neighbour other than the two pixels before (a junction, or the start
    // of a loop).
    const size_t len = idx.size();
    if (len >= 2) {
      for (int k = 0; k < 8; ++k) {
        const int q = i + off[k];
        if (e[q] == 1 && q != idx[len - 2] && (len < 3 || q != idx[len - 3])) {
          idx.push_back(q);
          break;
        }
      }
    }
    if (idx.size() < 2) return;
    chain.resize(idx.size());
    for (size_t k = 0; k < idx.size(); ++k) chain[k] = point(idx[k]);
    simplify(chain, p.max_deviation, &keep, &stack);
    for (size_t k = 0; k + 1 < keep.size(); ++k) {
      const cv::Point a = chain[keep[k]], b = chain[keep[k + 1]];
      LineSegment s{cv::Point2f(a), cv::Point2f(b)};
      if (s.length() < p.min_length) continue;
      out->segments.push_back(s);
    }
  };
  for (int pass = 0; pass < 2; ++pass) {
    for (int y = 1; y <= h; ++y) {
      for (int x = 1; x <= w; ++x) {
        const int i = y * stride + x;
        if (e[i] != 255) continue;
        if (pass == 0) {
          int c = 0;
          for (int k = 0; k < 8; ++k) c += e[i + off[k]] != 0;
          if (c > 1) continue;
        }
        trace(i);
      }
    }
  }
  // The barrier: every pixel of an edge component (8-connected) with at least `min_length`
  // pixels, the chains' pixels, not only the segments fitted to them (a doubled edge, or a spur
  // at a junction shorter than a segment, would otherwise leave a gap growth leaks through).
  // Smaller components (specks of texture) do not block.
  std::vector<int> comp;
  const size_t min_pixels = static_cast<size_t>(std::max(1.0, std::ceil(p.min_length)));
  for (int y = 1; y <= h; ++y) {
    for (int x = 1; x <= w; ++x) {
      const int i0 = y * stride + x;
      if (e[i0] != 1) continue;
      comp.clear();
      comp.push_back(i0);
      e[i0] = 2;
      for (size_t k = 0; k < comp.size(); ++k)
        for (int d = 0; d < 8; ++d) {
          const int q = comp[k] + off[d];
          if (e[q] == 1) {
            e[q] = 2;
            comp.push_back(q);
          }
        }
      if (comp.size() < min_pixels) continue;
      for (int q : comp) {
        const cv::Point pt = point(q);
        out->mask.ptr<uint8_t>(pt.y)[pt.x] = 255;
      }
    }
  }
}

}  // namespace vigil::vision::mser
