#include "vision/mser/lines.h"
#include "vision/mser/clones.h"

#include <algorithm>
#include <cmath>
#include <cstring>

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

// An AVX2 clone where the processor has it (clones.h).
VIGIL_AVX2_CLONES void canny_edges(const cv::Mat& grey, double low_thresh, double high_thresh, uint8_t* out, int stride,
                                    Lines* work) {
  CV_Assert(grey.type() == CV_8UC1 && !grey.empty());
  const int w = grey.cols, h = grey.rows;
  if (low_thresh > high_thresh) std::swap(low_thresh, high_thresh);
  const int low = cvFloor(low_thresh), high = cvFloor(high_thresh);
  // Gradients (w x h), the magnitude with a border of zeros ((h + 2) x (w + 2)), and two padded
  // rows of the vertical pass.
  const int ws = w + 2;
  const size_t n = static_cast<size_t>(w) * h;
  work->work16.resize(2 * n + static_cast<size_t>(ws) * (h + 2) + 2 * static_cast<size_t>(ws));
  int16_t* gx = work->work16.data();
  int16_t* gy = gx + n;
  int16_t* mag = gy + n;
  int16_t* vs = mag + static_cast<size_t>(ws) * (h + 2);
  int16_t* vd = vs + ws;
  std::fill(mag, mag + ws, int16_t{0});
  std::fill(mag + static_cast<size_t>(h + 1) * ws, mag + static_cast<size_t>(h + 2) * ws, int16_t{0});
  // The 3x3 Sobel with replicated borders, split: a vertical pass (smoothing 1 2 1 and the
  // difference below minus above) over the row's columns, padded by one replicated column each
  // side, then a horizontal one.
  for (int y = 0; y < h; ++y) {
    const uint8_t* __restrict r0 = grey.ptr<uint8_t>(std::max(y - 1, 0));
    const uint8_t* __restrict r1 = grey.ptr<uint8_t>(y);
    const uint8_t* __restrict r2 = grey.ptr<uint8_t>(std::min(y + 1, h - 1));
    int16_t* __restrict s = vs;
    int16_t* __restrict d = vd;
    for (int x = 0; x < w; ++x) {
      s[x + 1] = static_cast<int16_t>(r0[x] + 2 * r1[x] + r2[x]);
      d[x + 1] = static_cast<int16_t>(r2[x] - r0[x]);
    }
    s[0] = s[1], s[w + 1] = s[w];
    d[0] = d[1], d[w + 1] = d[w];
    int16_t* __restrict dx = gx + static_cast<size_t>(y) * w;
    int16_t* __restrict dy = gy + static_cast<size_t>(y) * w;
    int16_t* __restrict m = mag + static_cast<size_t>(y + 1) * ws;
    for (int x = 0; x < w; ++x) {
      const int16_t a = static_cast<int16_t>(s[x + 2] - s[x]);
      const int16_t b = static_cast<int16_t>(d[x] + 2 * d[x + 1] + d[x + 2]);
      dx[x] = a;
      dy[x] = b;
      m[x + 1] = static_cast<int16_t>(std::abs(a) + std::abs(b));
    }
    m[0] = m[w + 1] = 0;
  }
  // Non-maximum suppression along the gradient's direction, quantised to four by tan 22.5 and
  // tan 67.5 in fixed point (15 bits): a pixel above `low` is kept when its magnitude beats the
  // neighbour behind it and at least equals the one ahead (horizontal and vertical) or beats
  // both (diagonal). Kept pixels are 1, or 2 above `high`; the map has a border of zeros.
  constexpr int kShift = 15;
  const int tg22 = static_cast<int>(0.4142135623730950488 * (1 << kShift) + 0.5);
  work->edge_map.resize(static_cast<size_t>(ws) * (h + 2));
  uint8_t* cand = work->edge_map.data();
  std::fill(cand, cand + ws, uint8_t{0});
  std::fill(cand + static_cast<size_t>(h + 1) * ws, cand + static_cast<size_t>(h + 2) * ws, uint8_t{0});
  for (int y = 0; y < h; ++y) {
    const int16_t* __restrict mu = mag + static_cast<size_t>(y) * ws + 1;
    const int16_t* __restrict mc = mu + ws;
    const int16_t* __restrict md = mc + ws;
    const int16_t* __restrict dx = gx + static_cast<size_t>(y) * w;
    const int16_t* __restrict dy = gy + static_cast<size_t>(y) * w;
    uint8_t* __restrict c = cand + static_cast<size_t>(y + 1) * ws + 1;
    // Every neighbour loaded and the direction's pair chosen by masks: one vectorised loop.
    for (int x = 0; x < w; ++x) {
      const int m = mc[x], xs = dx[x], ys = dy[x];
      const int ax = xs < 0 ? -xs : xs, ay = (ys < 0 ? -ys : ys) << kShift;
      const int t22 = ax * tg22, t67 = t22 + (ax << (kShift + 1));
      const int horizontal = -(ay < t22), vertical = -(ay > t67) & ~horizontal, diagonal = ~(horizontal | vertical);
      const int same = -((xs ^ ys) >= 0);
      const int up_diag = (same & mu[x - 1]) | (~same & mu[x + 1]);
      const int down_diag = (same & md[x + 1]) | (~same & md[x - 1]);
      const int behind = (horizontal & mc[x - 1]) | (vertical & mu[x]) | (diagonal & up_diag);
      // At least equal to the one ahead (horizontal, vertical): more than it less one.
      const int ahead = ((horizontal & mc[x + 1]) | (vertical & md[x]) | (diagonal & down_diag)) + (diagonal & 1) - 1;
      const int keep = (m > low) & (m > behind) & (m > ahead);
      c[x] = static_cast<uint8_t>(keep * (1 + (m > high)));
    }
    c[-1] = c[w] = 0;
  }
  // Hysteresis: every kept pixel 8-connected to a strong one (through kept pixels) is an edge.
  const int off[8] = {-ws - 1, -ws, -ws + 1, -1, 1, ws - 1, ws, ws + 1};
  std::vector<int32_t>& stack = work->stack;
  stack.clear();
  const int32_t end = static_cast<int32_t>(h + 1) * ws;
  for (int32_t i = ws; i < end; ++i) {
    if (cand[i] != 2) continue;
    cand[i] = 255;
    stack.push_back(i);
    while (!stack.empty()) {
      const int32_t p = stack.back();
      stack.pop_back();
      for (int k = 0; k < 8; ++k) {
        const int32_t q = p + off[k];
        if (cand[q] == 1 || cand[q] == 2) {
          cand[q] = 255;
          stack.push_back(q);
        }
      }
    }
  }
  for (int y = 0; y < h; ++y) {
    const uint8_t* __restrict c = cand + static_cast<size_t>(y + 1) * ws + 1;
    uint8_t* __restrict o = out + static_cast<size_t>(y) * stride;
    for (int x = 0; x < w; ++x) o[x] = c[x] == 255 ? 255 : 0;
  }
}

void detect_lines(const cv::Mat& bgr, const LineParams& p, Lines* out) {
  const int w = bgr.cols, h = bgr.rows;
  // The edge map with a border of one empty pixel, so neighbours need no bounds checks: 255 on
  // an edge pixel, 1 once traced.
  cv::Mat& padded = out->padded;
  padded.create(h + 2, w + 2, CV_8U);
  padded.setTo(cv::Scalar(0));
  cv::cvtColor(bgr, out->grey, cv::COLOR_BGR2GRAY);
  // Canny's edges (canny_edges: cv::Canny's, found faster) into the padded map.
  canny_edges(out->grey, p.canny_low, p.canny_high, padded.ptr<uint8_t>(1) + 1, static_cast<int>(padded.step1()), out);
  out->segments.clear();
  out->mask.create(bgr.size(), CV_8U);
  out->mask.setTo(cv::Scalar(0));
  uint8_t* e = padded.ptr<uint8_t>(0);
  const int stride = static_cast<int>(padded.step1());
  int off[8];
  for (int k = 0; k < 8; ++k) off[k] = kDy[k] * stride + kDx[k];
  // A padded index's pixel: its row by a multiplication (exact: the index plus a half is at least
  // half a row's reciprocal away from a whole number of rows, far beyond a double's error).
  const double per_row = 1.0 / stride;
  auto point = [stride, per_row](int i) {
    const int y = static_cast<int>((i + 0.5) * per_row);
    return cv::Point(i - y * stride - 1, y - 1);
  };
  // The edge pixels in raster order, found 8 bytes at a time (most of the map is empty): every
  // pass below visits them in the order a scan of the map would.
  std::vector<int32_t>& edge_px = out->edge_pixels;
  edge_px.clear();
  for (int y = 1; y <= h; ++y) {
    const int row = y * stride;
    int x = 1;
    for (; x + 8 <= w + 1; x += 8) {
      uint64_t word;
      std::memcpy(&word, e + row + x, 8);
      if (word == 0) continue;
      for (int k = 0; k < 8; ++k)
        if (e[row + x + k]) edge_px.push_back(row + x + k);
    }
    for (; x <= w; ++x)
      if (e[row + x]) edge_px.push_back(row + x);
  }
  // Edge chains traced over the edge map, each edge pixel once: from the chain ends (pixels with
  // one edge neighbour) first, then what is left (closed loops). A chain that stops beside a
  // pixel of another chain (a junction) takes that pixel as its last point, so the two meet.
  std::vector<int> idx;  // the chain's pixels (indices into the padded map)
  std::vector<cv::Point> chain;
  std::vector<int> keep;
  std::vector<std::pair<int, int>> stack;
  // Chains of fewer than `min_pixels` pixels (their first pixel): only their edge components can
  // be smaller than that; a longer chain's component is at least as long.
  const size_t min_pixels = static_cast<size_t>(std::max(1.0, std::ceil(p.min_length)));
  std::vector<int32_t>& short_chains = out->short_chains;
  short_chains.clear();
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
    // (Counted without the end's neighbour: on a closed loop that is the chain's own start.)
    if (len < min_pixels) short_chains.push_back(idx[0]);
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
    for (const int32_t i : edge_px) {
      if (e[i] != 255) continue;
      if (pass == 0) {
        int c = 0;
        for (int k = 0; k < 8; ++k) c += e[i + off[k]] != 0;
        if (c > 1) continue;
      }
      trace(i);
    }
  }
  // The barrier: every pixel of an edge component (8-connected) with at least `min_length`
  // pixels, the chains' pixels, not only the segments fitted to them (a doubled edge, or a spur
  // at a junction shorter than a segment, would otherwise leave a gap growth leaks through).
  // Smaller components (specks of texture) do not block.
  // Only the components a short chain lies in are searched, each until it is known to reach
  // `min_pixels` (then its pixels seen are marked 4, and a later search that meets them stops
  // there) or is found whole and smaller (its pixels marked 3: not a barrier). Every other edge
  // pixel blocks.
  std::vector<int> comp;
  for (const int32_t i0 : short_chains) {
    if (e[i0] != 1) continue;  // searched from another short chain already
    comp.clear();
    comp.push_back(i0);
    e[i0] = 2;
    bool large = false;
    for (size_t k = 0; k < comp.size() && !large; ++k)
      for (int d = 0; d < 8; ++d) {
        const uint8_t v = e[comp[k] + off[d]];
        if (v == 4) {
          large = true;
          break;
        }
        if (v == 1) {
          e[comp[k] + off[d]] = 2;
          comp.push_back(comp[k] + off[d]);
          if (comp.size() >= min_pixels) {
            large = true;
            break;
          }
        }
      }
    for (int q : comp) e[q] = large ? 4 : 3;
  }
  uint8_t* mask = out->mask.ptr<uint8_t>(0);
  for (const int32_t q : edge_px) {
    if (e[q] == 3) continue;
    const cv::Point pt = point(q);
    mask[static_cast<size_t>(pt.y) * w + pt.x] = 255;
  }
}

}  // namespace vigil::vision::mser
