#include "vision/mser/texture.h"
#include "vision/mser/clones.h"

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

// An AVX2 clone where the processor has it (clones.h).
VIGIL_AVX2_CLONES void compute_texture_values(const cv::Mat& bgr, TextureElements* out) {
  if (bgr.type() != CV_8UC3) throw std::invalid_argument("compute_texture_values: expected a CV_8UC3 image");
  const int w = bgr.cols, h = bgr.rows;
  out->width = w;
  out->height = h;
  const size_t n = static_cast<size_t>(w) * h;
  out->value.resize(2 * n);
  // Per channel byte: (x - y)^2 / (x + y) (0 when both are 0), in float
  // arrays the compiler vectorises; a term between two pixels serves both (the horizontal one
  // between x - 1 and x is x's left term and x - 1's right one; the vertical one between rows y
  // and y + 1 is row y's lower term and row y + 1's upper one). Sums, square roots and the
  // 16-bit values are vectorised loops too; the counts for the sort come last.
  const int m = 3 * w;
  std::vector<float> left(m, 0.0f), upper(m, 0.0f), lower(m, 0.0f), sum(w, 0.0f);
  std::vector<uint16_t> hv(w), vv(w);
  // (c + a + 1e-30 is c + a exactly when c + a >= 1, and makes 0 / 0 a 0 without a branch.)
  auto term = [](float c, float a) {
    const float d = c - a;
    return d * d / (c + a + 1e-30f);
  };
  auto to_values = [w](const float* __restrict s, uint16_t* __restrict v) {
    for (int x = 0; x < w; ++x) {
      // round(sqrt(512 s)) clamped to 255, as value_from_sum.
      const float t = std::min(std::sqrt(512.0f * s[x]), 255.0f);
      v[x] = static_cast<uint16_t>(static_cast<int>(t + 0.5f));
    }
  };
  for (int y = 0; y < h; ++y) {
    const uint8_t* __restrict row = bgr.ptr<uint8_t>(y);
    float* __restrict lf = left.data();
    float* __restrict uf = upper.data();
    float* __restrict df = lower.data();
    // left[i]: the term between byte i and byte i - 3 (the pixel to the left).
    for (int i = 3; i < m; ++i) lf[i] = term(row[i], row[i - 3]);
    // The last row's lower terms are this row's upper ones.
    std::swap(upper, lower);
    uf = upper.data();
    df = lower.data();
    if (y + 1 < h) {
      const uint8_t* __restrict down = bgr.ptr<uint8_t>(y + 1);
      for (int i = 0; i < m; ++i) df[i] = term(row[i], down[i]);
    }
    const bool vert = y > 0 && y + 1 < h;
    float* __restrict sm = sum.data();
    // Horizontal: the a side (left[3x..3x+2]) then the b side (left[3x+3..3x+5]), summed in the
    // order texture_value uses, so both round alike.
    for (int x = 1; x + 1 < w; ++x) {
      const int i = 3 * x;
      sm[x] = (lf[i] + lf[i + 1] + lf[i + 2]) + (lf[i + 3] + lf[i + 4] + lf[i + 5]);
    }
    to_values(sm, hv.data());
    hv[0] = hv[w - 1] = 256;
    if (vert) {
      for (int x = 0; x < w; ++x) {
        const int i = 3 * x;
        sm[x] = (uf[i] + uf[i + 1] + uf[i + 2]) + (df[i] + df[i + 1] + df[i + 2]);
      }
      to_values(sm, vv.data());
    } else {
      std::fill(vv.begin(), vv.end(), uint16_t{256});
    }
    uint16_t* __restrict v = out->value.data() + 2 * static_cast<size_t>(y) * w;
    for (int x = 0; x < w; ++x) {
      v[2 * x] = hv[x];
      v[2 * x + 1] = vv[x];
    }
  }
}

void order_texture_elements(TextureElements* t, const uint8_t* skip, const int32_t* group) {
  const int32_t w = t->width;
  const size_t n = static_cast<size_t>(t->width) * t->height;
  if (2 * n > kElement + 1) throw std::invalid_argument("order_texture_elements: image too large");
  // Each element's key: its value, or 256 where it stays out. Per pixel, both of its elements
  // (a value below 256 means the unit exists, so its outer pixels are inside the image).
  t->key.resize(2 * n);
  uint16_t* __restrict key = t->key.data();
  const uint16_t* __restrict value = t->value.data();
  // Four partial counts, so runs of equal keys do not wait on one counter.
  std::array<std::array<uint32_t, 257>, 4> part{};
  // One pixel's two keys (the branches: image borders only).
  auto keys_of = [&](size_t c) {
    uint16_t kh = value[2 * c], kv = value[2 * c + 1];
    if (skip && skip[c]) kh = kv = 256;
    if (group) {
      const int32_t g = group[c];
      if (g >= 0) {
        if (kh < 256 && group[c - 1] == g && group[c + 1] == g) kh = 256;
        if (kv < 256 && group[c - w] == g && group[c + w] == g) kv = 256;
      }
    }
    key[2 * c] = kh;
    key[2 * c + 1] = kv;
  };
  const size_t inner_begin = static_cast<size_t>(w), inner_end = n > static_cast<size_t>(w) ? n - w : 0;
  for (size_t c = 0; c < std::min(inner_begin, n); ++c) keys_of(c);
  if (group && inner_end > inner_begin) {
    // Rows with a row above and below: every neighbour exists, so the tests need no branches.
    for (size_t c = inner_begin; c < inner_end; ++c) {
      const int32_t g = group[c];
      const bool seeded = g >= 0;
      const uint16_t off = static_cast<uint16_t>(skip ? skip[c] != 0 : 0);
      const bool in_h = off | (seeded & (group[c - 1] == g) & (group[c + 1] == g));
      const bool in_v = off | (seeded & (group[c - w] == g) & (group[c + w] == g));
      const uint16_t kh = value[2 * c], kv = value[2 * c + 1];
      key[2 * c] = in_h ? uint16_t{256} : kh;
      key[2 * c + 1] = in_v ? uint16_t{256} : kv;
    }
  } else {
    for (size_t c = inner_begin; c < inner_end; ++c) keys_of(c);
  }
  for (size_t c = std::max(inner_begin, inner_end); c < n; ++c) keys_of(c);
  for (size_t c = 0; c < n; ++c) {
    ++part[(c & 1) * 2][key[2 * c]];
    ++part[(c & 1) * 2 + 1][key[2 * c + 1]];
  }
  // Counting sort of the elements left in (key <= 255), stable: by element within a value.
  t->level_start.assign(257, 0);
  uint32_t acc = 0;
  for (int k = 0; k < 256; ++k) {
    t->level_start[k] = acc;
    acc += part[0][k] + part[1][k] + part[2][k] + part[3][k];
  }
  t->level_start[256] = acc;
  t->order.resize(acc);
  uint32_t* __restrict order = t->order.data();
  std::array<uint32_t, 256> next{};
  for (int k = 0; k < 256; ++k) next[k] = t->level_start[k];
  for (size_t c = 0; c < n; ++c) {
    const uint16_t kh = key[2 * c], kv = key[2 * c + 1];
    // Line sides in the top bits (one array written, not two: the sort's writes scatter).
    if (kh < 256) {
      const uint32_t sides = skip ? (skip[c - 1] ? kSideBefore : 0u) | (skip[c + 1] ? kSideAfter : 0u) : 0u;
      order[next[kh]++] = static_cast<uint32_t>(2 * c) | sides;
    }
    if (kv < 256) {
      const uint32_t sides = skip ? (skip[c - w] ? kSideBefore : 0u) | (skip[c + w] ? kSideAfter : 0u) : 0u;
      order[next[kv]++] = static_cast<uint32_t>(2 * c + 1) | sides;
    }
  }
}

void compute_texture_elements(const cv::Mat& bgr, TextureElements* out, const uint8_t* skip) {
  compute_texture_values(bgr, out);
  order_texture_elements(out, skip, nullptr);
}

}  // namespace vigil::vision::mser
