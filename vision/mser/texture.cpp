#include "vision/mser/texture.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>

namespace vigil::vision::mser {
namespace {

// (x - y)^2 / (x + y) for every pair of 8-bit values (0 when both are 0).
const std::array<float, 65536>& chi_table() {
  static const std::array<float, 65536> table = [] {
    std::array<float, 65536> t{};
    for (int x = 0; x < 256; ++x) {
      for (int y = 0; y < 256; ++y) {
        const int s = x + y;
        t[x * 256 + y] = s == 0 ? 0.0f : static_cast<float>((x - y) * (x - y)) / static_cast<float>(s);
      }
    }
    return t;
  }();
  return table;
}

inline int value_from_sum(float sum) {
  const float t = std::sqrt(512.0f * sum);
  return t >= 255.0f ? 255 : static_cast<int>(t + 0.5f);
}

}  // namespace

int texture_value(const cv::Vec3b& a, const cv::Vec3b& c, const cv::Vec3b& b) {
  const auto& chi = chi_table();
  // Summed in the order compute_texture_elements uses (the a side, then the b side), so both
  // round alike.
  const float sa = chi[c[0] * 256 + a[0]] + chi[c[1] * 256 + a[1]] + chi[c[2] * 256 + a[2]];
  const float sb = chi[c[0] * 256 + b[0]] + chi[c[1] * 256 + b[1]] + chi[c[2] * 256 + b[2]];
  return value_from_sum(sa + sb);
}

void compute_texture_elements(const cv::Mat& bgr, TextureElements* out) {
  if (bgr.type() != CV_8UC3) throw std::invalid_argument("compute_texture_elements: expected a CV_8UC3 image");
  const int w = bgr.cols, h = bgr.rows;
  out->width = w;
  out->height = h;
  const size_t n = static_cast<size_t>(w) * h;
  out->value.assign(2 * n, 256);
  std::array<uint32_t, 257> count{};
  // Per channel byte: (x - y)^2 / (x + y) as d^2 / max(s, 1) (0 when both are 0), in float
  // arrays the compiler vectorises; then summed per pixel over its two neighbours.
  const int m = 3 * w;
  std::vector<float> left(m), upper(m), lower(m);
  for (int y = 0; y < h; ++y) {
    const uint8_t* __restrict row = bgr.ptr<uint8_t>(y);
    float* __restrict lf = left.data();
    float* __restrict uf = upper.data();
    float* __restrict df = lower.data();
    // left[i]: the term between byte i and byte i - 3 (the pixel to the left).
    for (int i = 3; i < m; ++i) {
      const float c = row[i], a = row[i - 3];
      const float d = c - a;
      lf[i] = d * d / std::max(c + a, 1.0f);
    }
    const bool vert = y > 0 && y + 1 < h;
    if (vert) {
      const uint8_t* __restrict up = bgr.ptr<uint8_t>(y - 1);
      const uint8_t* __restrict down = bgr.ptr<uint8_t>(y + 1);
      for (int i = 0; i < m; ++i) {
        const float c = row[i], a = up[i], b = down[i];
        const float d1 = c - a, d2 = c - b;
        uf[i] = d1 * d1 / std::max(c + a, 1.0f);
        df[i] = d2 * d2 / std::max(c + b, 1.0f);
      }
    }
    uint16_t* v = out->value.data() + 2 * static_cast<size_t>(y) * w;
    for (int x = 0; x < w; ++x) {
      const int i = 3 * x;
      if (x > 0 && x + 1 < w) {
        const float sum = (left[i] + left[i + 1] + left[i + 2]) + (left[i + 3] + left[i + 4] + left[i + 5]);
        v[2 * x] = static_cast<uint16_t>(value_from_sum(sum));
      }
      if (vert) {
        const float sum = (upper[i] + upper[i + 1] + upper[i + 2]) + (lower[i] + lower[i + 1] + lower[i + 2]);
        v[2 * x + 1] = static_cast<uint16_t>(value_from_sum(sum));
      }
      ++count[v[2 * x]];
      ++count[v[2 * x + 1]];
    }
  }
  // Counting sort of the elements that have a unit (value <= 255).
  out->level_start.assign(257, 0);
  uint32_t acc = 0;
  for (int k = 0; k < 256; ++k) {
    out->level_start[k] = acc;
    acc += count[k];
  }
  out->level_start[256] = acc;
  out->order.resize(acc);
  std::array<uint32_t, 256> next{};
  for (int k = 0; k < 256; ++k) next[k] = out->level_start[k];
  const uint32_t total = static_cast<uint32_t>(2 * n);
  for (uint32_t e = 0; e < total; ++e) {
    const uint16_t val = out->value[e];
    if (val < 256) out->order[next[val]++] = e;
  }
}

}  // namespace vigil::vision::mser
