#include "planning/grid/clearance_field.h"

#include <cmath>
#include <limits>

namespace vigil::planning {
namespace {

// One-dimensional lower envelope of parabolas (Felzenszwalb-Huttenlocher), over n samples
// read and written with a stride.
void transform_1d(double* f, int n, size_t stride, std::vector<double>& d, std::vector<int>& v,
                  std::vector<double>& z) {
  if (n <= 0) return;
  d.resize(n);
  v.resize(n);
  z.resize(n + 1);
  const double inf = std::numeric_limits<double>::infinity();
  int k = 0;
  v[0] = 0;
  z[0] = -inf;
  z[1] = inf;
  for (int q = 1; q < n; ++q) {
    const double fq = f[q * stride] + static_cast<double>(q) * q;
    double s;
    while (true) {
      const int p = v[k];
      s = (fq - (f[p * stride] + static_cast<double>(p) * p)) / (2.0 * (q - p));
      if (s > z[k]) break;
      --k;
    }
    ++k;
    v[k] = q;
    z[k] = s;
    z[k + 1] = inf;
  }
  k = 0;
  for (int q = 0; q < n; ++q) {
    while (z[k + 1] < q) ++k;
    const double dq = q - v[k];
    d[q] = dq * dq + f[v[k] * stride];
  }
  for (int q = 0; q < n; ++q) f[q * stride] = d[q];
}

}  // namespace

void squared_distance_transform(std::vector<double>& f, int w, int h) {
  std::vector<double> d, z;
  std::vector<int> v;
  for (int x = 0; x < w; ++x) transform_1d(f.data() + x, h, static_cast<size_t>(w), d, v, z);
  for (int y = 0; y < h; ++y) transform_1d(f.data() + static_cast<size_t>(y) * w, w, 1, d, v, z);
}

ClearanceField::ClearanceField(const OccupancyGrid& grid) : width_(grid.width()), height_(grid.height()) {
  const int w = width_, h = height_;
  dist_.assign(static_cast<size_t>(w) * h, 0.0f);
  if (w == 0 || h == 0) return;
  // A border of sites one cell outside the grid makes its edge count as unknown space.
  const int pw = w + 2, ph = h + 2;
  const double big = static_cast<double>(pw + ph) * (pw + ph);
  std::vector<double> f(static_cast<size_t>(pw) * ph, 0.0);
  const auto& cells = grid.cells();
  const uint8_t kFree = static_cast<uint8_t>(Cell::kFree);
  for (int cy = 0; cy < h; ++cy) {
    const uint8_t* src = cells.data() + static_cast<size_t>(cy) * w;
    double* row = f.data() + static_cast<size_t>(cy + 1) * pw + 1;
    for (int cx = 0; cx < w; ++cx) row[cx] = src[cx] == kFree ? big : 0.0;
  }
  squared_distance_transform(f, pw, ph);
  const double res = grid.resolution();
  for (int cy = 0; cy < h; ++cy) {
    const double* row = f.data() + static_cast<size_t>(cy + 1) * pw + 1;
    float* out = dist_.data() + static_cast<size_t>(cy) * w;
    for (int cx = 0; cx < w; ++cx) {
      const float cells_away = static_cast<float>(std::sqrt(row[cx]));
      out[cx] = static_cast<float>(cells_away * res);
    }
  }
}

double ClearanceField::at_point(const OccupancyGrid& grid, Vec2 p) const {
  int cx, cy;
  if (!grid.world_to_cell(p, &cx, &cy)) return 0;
  return at(cx, cy);
}

}  // namespace vigil::planning
