#include "vision/mser/segmenter.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace vigil::vision::mser {
namespace {

inline int32_t find(std::vector<int32_t>& parent, int32_t x) {
  while (parent[x] != x) {
    parent[x] = parent[parent[x]];
    x = parent[x];
  }
  return x;
}

}  // namespace

float Region::width() const { return 2.0f * std::sqrt(std::max(0.0f, cxx)); }
float Region::height() const { return 2.0f * std::sqrt(std::max(0.0f, cyy)); }

bool MserSegmenter::segment(const cv::Mat& bgr, Segmentation* out, std::string* error) {
  if (bgr.empty() || bgr.type() != CV_8UC3 || bgr.cols < 3 || bgr.rows < 3) {
    if (error) *error = "the MSER segmenter needs a colour (CV_8UC3) image of at least 3 x 3 pixels";
    return false;
  }
  compute_texture_elements(bgr, &tex_);
  const size_t n = static_cast<size_t>(bgr.cols) * bgr.rows;
  blocked_.assign(n, 0);
  if (p_.use_lines) {
    detect_lines(bgr, p_.lines, &lines_);
    const uint8_t* m = lines_.mask.ptr<uint8_t>(0);
    for (size_t i = 0; i < n; ++i) blocked_[i] = m[i] != 0;
  } else {
    lines_.segments.clear();
    lines_.mask = cv::Mat::zeros(bgr.size(), CV_8U);
  }
  out->tree.clear();
  out->leaves.clear();
  build_tree(out);
  expand(bgr, out);
  return true;
}

void MserSegmenter::build_tree(Segmentation* out) {
  const int w = tex_.width, h = tex_.height;
  const size_t n = static_cast<size_t>(w) * h;
  parent_.resize(n);
  size_.assign(n, 1);
  head_.resize(n);
  tail_.resize(n);
  next_.assign(n, -1);
  prev_size_.assign(n, 1);
  growth_.assign(n, 0);
  growth_before_.assign(n, 0);
  hlevel_.assign(n, -2);
  top_head_.assign(n, -1);
  top_tail_.assign(n, -1);
  pend_head_.assign(n, -1);
  pend_tail_.assign(n, -1);
  touched_at_.assign(n, -1);
  node_next_.clear();
  for (size_t i = 0; i < n; ++i) {
    parent_[i] = static_cast<int32_t>(i);
    head_[i] = tail_[i] = static_cast<int32_t>(i);
  }
  auto append = [&](std::vector<int32_t>& lh, std::vector<int32_t>& lt, int32_t r, int32_t h2, int32_t t2) {
    if (h2 < 0) return;
    if (lh[r] < 0) {
      lh[r] = h2;
    } else {
      node_next_[lt[r]] = h2;
    }
    lt[r] = t2;
  };
  int16_t level = 0;
  auto touch = [&](int32_t r) {
    if (touched_at_[r] != level) {
      touched_at_[r] = level;
      touched_.push_back(r);
    }
  };
  const int min_size = p_.min_size;
  // Growth that "declines or is stable" before the acceleration: a level without growth, or a
  // declining growth that adds under an eighth of the region (a speck that doubles every level
  // while it shrinks its growth is still forming, not stable).
  auto steady = [&](int32_t r, bool last_level) {
    if (!last_level) return true;
    return growth_[r] <= growth_before_[r] && 8 * growth_[r] < prev_size_[r];
  };
  auto store = [&](int32_t r, int size, int node_level) {
    const int id = static_cast<int>(out->tree.size());
    MserNode node;
    node.level = node_level;
    node.size = size;
    node.head = head_[r];
    for (int32_t c = top_head_[r]; c >= 0; c = node_next_[c]) {
      node.children.push_back(c);
      out->tree[c].parent = id;
    }
    out->tree.push_back(std::move(node));
    node_next_.push_back(-1);
    top_head_[r] = top_tail_[r] = id;
  };
  auto unite = [&](int32_t a, int32_t b) {
    a = find(parent_, a);
    b = find(parent_, b);
    if (a == b) return;
    if (size_[a] < size_[b]) std::swap(a, b);
    // b ends here, swallowed by a larger region: for b that is accelerated growth, so b as it
    // was before this level is an MSER if it had been growing steadily (or not at all).
    if (prev_size_[b] >= min_size) {
      const bool last_level = hlevel_[b] == level - 1;
      const int g_prev = last_level ? growth_[b] : 0;
      const bool was_steady = steady(b, last_level);
      const int g = size_[a] + size_[b] - prev_size_[b];
      if (was_steady && g - g_prev > min_size) store(b, prev_size_[b], last_level ? level - 1 : hlevel_[b]);
    }
    parent_[b] = a;
    size_[a] += size_[b];
    next_[tail_[a]] = head_[b];
    tail_[a] = tail_[b];
    // b's maximal MSERs now lie inside a, reached this level.
    append(pend_head_, pend_tail_, a, top_head_[b], top_tail_[b]);
    append(pend_head_, pend_tail_, a, pend_head_[b], pend_tail_[b]);
    top_head_[b] = pend_head_[b] = -1;
    touch(a);
  };
  for (int v = 0; v < 256; ++v) {
    level = static_cast<int16_t>(v);
    touched_.clear();
    for (uint32_t k = tex_.level_start[v]; k < tex_.level_start[v + 1]; ++k) {
      const uint32_t e = tex_.order[k];
      const int32_t c = static_cast<int32_t>(e >> 1);
      if (blocked_[c]) continue;
      const int32_t step = (e & 1) ? w : 1;
      const int32_t a = c - step, b = c + step;
      if (!blocked_[a]) unite(c, a);
      if (!blocked_[b]) unite(c, b);
    }
    // Rates of growth of the regions that grew.
    for (int32_t r : touched_) {
      if (parent_[r] != r) continue;
      const int g = size_[r] - prev_size_[r];
      const bool last_level = hlevel_[r] == v - 1;
      const int g_prev = last_level ? growth_[r] : 0;
      const bool was_steady = steady(r, last_level);
      if (g - g_prev > min_size && was_steady && prev_size_[r] >= min_size) {
        store(r, prev_size_[r], last_level ? v - 1 : hlevel_[r]);
      }
      append(top_head_, top_tail_, r, pend_head_[r], pend_tail_[r]);
      pend_head_[r] = pend_tail_[r] = -1;
      growth_before_[r] = g_prev;
      growth_[r] = g;
      prev_size_[r] = size_[r];
      hlevel_[r] = static_cast<int16_t>(v);
    }
  }
  // The regions left standing are the roots (line pixels stay out: they are not grown).
  for (size_t i = 0; i < n; ++i) {
    const int32_t r = static_cast<int32_t>(i);
    if (parent_[r] != r || blocked_[r]) continue;
    append(top_head_, top_tail_, r, pend_head_[r], pend_tail_[r]);
    pend_head_[r] = -1;
    if (size_[r] < min_size && top_head_[r] < 0) continue;  // a speck: expansion assigns it
    store(r, size_[r], 255);
  }
  for (size_t i = 0; i < out->tree.size(); ++i)
    if (out->tree[i].children.empty()) out->leaves.push_back(static_cast<int>(i));
}

std::vector<int> MserSegmenter::node_pixels(const Segmentation& s, int node) const {
  std::vector<int> px;
  if (node < 0 || node >= static_cast<int>(s.tree.size())) return px;
  int32_t p = s.tree[node].head;
  for (int k = 0; k < s.tree[node].size && p >= 0; ++k, p = next_[p]) px.push_back(p);
  return px;
}

void MserSegmenter::expand(const cv::Mat& bgr, Segmentation* out) {
  const int w = tex_.width, h = tex_.height;
  const size_t n = static_cast<size_t>(w) * h;
  parent2_.resize(n);
  leaf_of_.assign(n, -1);
  for (size_t i = 0; i < n; ++i) parent2_[i] = static_cast<int32_t>(i);
  // Each leaf's pixels, one component.
  for (size_t li = 0; li < out->leaves.size(); ++li) {
    const MserNode& node = out->tree[out->leaves[li]];
    const int32_t first = node.head;
    leaf_of_[first] = static_cast<int32_t>(li);
    int32_t p = next_[first];
    for (int k = 1; k < node.size && p >= 0; ++k, p = next_[p]) parent2_[p] = first;
  }
  auto unite = [&](int32_t a, int32_t b) {
    a = find(parent2_, a);
    b = find(parent2_, b);
    if (a == b) return;
    const int32_t la = leaf_of_[a], lb = leaf_of_[b];
    if (la >= 0 && lb >= 0) return;  // leaves never merge
    if (la < 0) {
      parent2_[a] = b;
    } else {
      parent2_[b] = a;
    }
  };
  for (uint32_t k = 0; k < tex_.order.size(); ++k) {
    const uint32_t e = tex_.order[k];
    const int32_t c = static_cast<int32_t>(e >> 1);
    if (blocked_[c]) continue;
    const int32_t step = (e & 1) ? w : 1;
    const int32_t a = c - step, b = c + step;
    if (!blocked_[a]) unite(c, a);
    if (!blocked_[b]) unite(c, b);
  }
  // Components to regions: leaves first (in leaf order), then parts no leaf reached.
  out->labels.create(h, w, CV_32S);
  int32_t* lab = out->labels.ptr<int32_t>(0);
  std::vector<int32_t> region_of_root(n, -1);
  std::vector<int> comp_size(n, 0);
  for (size_t i = 0; i < n; ++i)
    if (!blocked_[i]) ++comp_size[find(parent2_, static_cast<int32_t>(i))];
  out->regions.clear();
  for (size_t li = 0; li < out->leaves.size(); ++li) {
    const int32_t r = find(parent2_, out->tree[out->leaves[li]].head);
    region_of_root[r] = static_cast<int32_t>(out->regions.size());
    Region reg;
    reg.node = out->leaves[li];
    out->regions.push_back(reg);
  }
  for (size_t i = 0; i < n; ++i) {
    if (blocked_[i]) {
      lab[i] = -1;
      continue;
    }
    const int32_t r = find(parent2_, static_cast<int32_t>(i));
    if (region_of_root[r] < 0 && comp_size[r] >= p_.min_size) {
      region_of_root[r] = static_cast<int32_t>(out->regions.size());
      out->regions.push_back(Region{});
    }
    lab[i] = region_of_root[r];
  }
  // Colour sums so far, for the pixels left (line pixels, specks).
  const cv::Vec3b* px = bgr.ptr<cv::Vec3b>(0);
  std::vector<cv::Vec3d> sum(out->regions.size(), cv::Vec3d(0, 0, 0));
  std::vector<int> cnt(out->regions.size(), 0);
  for (size_t i = 0; i < n; ++i) {
    if (lab[i] < 0) continue;
    sum[lab[i]] += cv::Vec3d(px[i][0], px[i][1], px[i][2]);
    ++cnt[lab[i]];
  }
  if (out->regions.empty()) {
    // Nothing but lines and specks: one region.
    out->regions.push_back(Region{});
    sum.push_back(cv::Vec3d(0, 0, 0));
    cnt.push_back(0);
    for (size_t i = 0; i < n; ++i) lab[i] = 0;
  }
  // Unassigned pixels join the 4-neighbour region of the nearest mean colour, sweep by sweep.
  std::vector<int32_t> pending;
  for (size_t i = 0; i < n; ++i)
    if (lab[i] < 0) pending.push_back(static_cast<int32_t>(i));
  std::vector<int32_t> still;
  std::vector<std::pair<int32_t, int32_t>> assign;
  while (!pending.empty()) {
    still.clear();
    assign.clear();
    for (int32_t i : pending) {
      const int x = i % w, y = i / w;
      int best = -1;
      double best_d = 1e300;
      const int32_t nb[4] = {x > 0 ? i - 1 : -1, x + 1 < w ? i + 1 : -1, y > 0 ? i - w : -1, y + 1 < h ? i + w : -1};
      for (int32_t q : nb) {
        if (q < 0 || lab[q] < 0) continue;
        const int r = lab[q];
        const cv::Vec3d m = cnt[r] ? sum[r] / cnt[r] : cv::Vec3d(px[q][0], px[q][1], px[q][2]);
        const cv::Vec3d d = m - cv::Vec3d(px[i][0], px[i][1], px[i][2]);
        const double dd = d.dot(d);
        if (dd < best_d) {
          best_d = dd;
          best = r;
        }
      }
      if (best >= 0) {
        assign.push_back({i, best});
      } else {
        still.push_back(i);
      }
    }
    if (assign.empty()) {  // cannot happen with at least one region; guard anyway
      for (int32_t i : still) lab[i] = 0;
      break;
    }
    for (const auto& [i, r] : assign) lab[i] = r;
    pending.swap(still);
  }
  // Region statistics.
  const size_t m = out->regions.size();
  std::vector<double> sx(m, 0), sy(m, 0), sxx(m, 0), syy(m, 0), sxy(m, 0);
  std::vector<cv::Vec3d> col(m, cv::Vec3d(0, 0, 0));
  std::vector<int> minx(m, w), miny(m, h), maxx(m, -1), maxy(m, -1), size(m, 0);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x;
      const int r = lab[i];
      ++size[r];
      sx[r] += x;
      sy[r] += y;
      sxx[r] += static_cast<double>(x) * x;
      syy[r] += static_cast<double>(y) * y;
      sxy[r] += static_cast<double>(x) * y;
      col[r] += cv::Vec3d(px[i][0], px[i][1], px[i][2]);
      minx[r] = std::min(minx[r], x);
      maxx[r] = std::max(maxx[r], x);
      miny[r] = std::min(miny[r], y);
      maxy[r] = std::max(maxy[r], y);
    }
  }
  for (size_t r = 0; r < m; ++r) {
    Region& reg = out->regions[r];
    reg.size = size[r];
    if (size[r] == 0) continue;
    const double k = 1.0 / size[r];
    const double mx = sx[r] * k, my = sy[r] * k;
    reg.centroid = cv::Point2f(static_cast<float>(mx), static_cast<float>(my));
    reg.cxx = static_cast<float>(sxx[r] * k - mx * mx);
    reg.cyy = static_cast<float>(syy[r] * k - my * my);
    reg.cxy = static_cast<float>(sxy[r] * k - mx * my);
    reg.mean = cv::Vec3f(static_cast<float>(col[r][0] * k), static_cast<float>(col[r][1] * k), static_cast<float>(col[r][2] * k));
    reg.bbox = cv::Rect(minx[r], miny[r], maxx[r] - minx[r] + 1, maxy[r] - miny[r] + 1);
  }
}

}  // namespace vigil::vision::mser
