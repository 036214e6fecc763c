// A small static 2-D kd-tree (median splits) for radius queries over region centroids: the
// candidate search of the MSER tracking phases and the region background model.
#pragma once

#include <algorithm>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

namespace vigil::vision::mser {

// A 2-D kd-tree over points (built once per frame), for radius queries.
class KdTree2 {
 public:
  explicit KdTree2(std::vector<std::pair<cv::Point2f, int>> pts) : pts_(std::move(pts)) { build(0, pts_.size(), 0); }
  // Ids of the points within `r` of `q`, in increasing id order.
  std::vector<int> within(cv::Point2f q, float r) const {
    std::vector<int> out;
    search(0, pts_.size(), 0, q, r * r, &out);
    std::sort(out.begin(), out.end());
    return out;
  }

 private:
  void build(size_t lo, size_t hi, int depth) {
    if (hi - lo <= 1) return;
    const size_t mid = (lo + hi) / 2;
    auto key = [depth](const auto& a, const auto& b) {
      const float ka = depth % 2 ? a.first.y : a.first.x, kb = depth % 2 ? b.first.y : b.first.x;
      return ka < kb || (ka == kb && a.second < b.second);
    };
    std::nth_element(pts_.begin() + lo, pts_.begin() + mid, pts_.begin() + hi, key);
    build(lo, mid, depth + 1);
    build(mid + 1, hi, depth + 1);
  }
  void search(size_t lo, size_t hi, int depth, cv::Point2f q, float r2, std::vector<int>* out) const {
    if (lo >= hi) return;
    const size_t mid = (lo + hi) / 2;
    const auto& p = pts_[mid];
    const float dx = p.first.x - q.x, dy = p.first.y - q.y;
    if (dx * dx + dy * dy <= r2) out->push_back(p.second);
    const float d = depth % 2 ? q.y - p.first.y : q.x - p.first.x;
    if (d <= 0 || d * d <= r2) search(lo, mid, depth + 1, q, r2, out);
    if (d >= 0 || d * d <= r2) search(mid + 1, hi, depth + 1, q, r2, out);
  }
  std::vector<std::pair<cv::Point2f, int>> pts_;
};


}  // namespace vigil::vision::mser
