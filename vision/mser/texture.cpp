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
  float sum = 0;
  for (int k = 0; k < 3; ++k) sum += chi[c[k] * 256 + a[k]] + chi[c[k] * 256 + b[k]];
  return value_from_sum(sum);
}

void compute_texture_elements(const cv::Mat& bgr, TextureElements* out) {
  if (bgr.type() != CV_8UC3) throw std::invalid_argument("compute_texture_elements: expected a CV_8UC3 image");
  const int w = bgr.cols, h = bgr.rows;
  out->width = w;
  out->height = h;
  const size_t n = static_cast<size_t>(w) * h;
  out->value.assign(2 * n, 256);
  const auto& chi = chi_table();
  std::array<uint32_t, 257> count{};
  for (int y = 0; y < h; ++y) {
    const cv::Vec3b* row = bgr.ptr<cv::Vec3b>(y);
    const cv::Vec3b* up = y > 0 ? bgr.ptr<cv::Vec3b>(y - 1) : nullptr;
    const cv::Vec3b* down = y + 1 < h ? bgr.ptr<cv::Vec3b>(y + 1) : nullptr;
    uint16_t* v = out->value.data() + 2 * static_cast<size_t>(y) * w;
    for (int x = 0; x < w; ++x) {
      const cv::Vec3b c = row[x];
      if (x > 0 && x + 1 < w) {
        const cv::Vec3b a = row[x - 1], b = row[x + 1];
        float sum = 0;
        for (int k = 0; k < 3; ++k) sum += chi[c[k] * 256 + a[k]] + chi[c[k] * 256 + b[k]];
        v[2 * x] = static_cast<uint16_t>(value_from_sum(sum));
      }
      if (up && down) {
        const cv::Vec3b a = up[x], b = down[x];
        float sum = 0;
        for (int k = 0; k < 3; ++k) sum += chi[c[k] * 256 + a[k]] + chi[c[k] * 256 + b[k]];
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
