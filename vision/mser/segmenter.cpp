#include "vision/mser/segmenter.h"

#include <algorithm>
#include <chrono>
#include <map>
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
  using Clock = std::chrono::steady_clock;
  auto ms = [](Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double, std::milli>(b - a).count(); };
  const auto t0 = Clock::now();
  compute_texture_elements(bgr, &tex_);
  const auto t1 = Clock::now();
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
  seed_of_.assign(n, -1);
  seeded_ = seed_groups_ = 0;
  if (p_.feed_forward && !prev_frame_.empty() && prev_frame_.size() == bgr.size()) make_seeds(bgr);
  const auto t2 = Clock::now();
  out->tree.clear();
  out->leaves.clear();
  build_tree(out);
  const auto t3 = Clock::now();
  expand(bgr, out);
  const auto t4 = Clock::now();
  times_ = {ms(t0, t1), ms(t1, t2), ms(t2, t3), ms(t3, t4)};
  if (p_.feed_forward) {
    bgr.copyTo(prev_frame_);
    out->labels.copyTo(prev_labels_);
  }
  return true;
}

void MserSegmenter::reset() {
  prev_frame_.release();
  prev_labels_.release();
}

void MserSegmenter::make_seeds(const cv::Mat& bgr) {
  const int w = bgr.cols, h = bgr.rows;
  const size_t n = static_cast<size_t>(w) * h;
  const cv::Vec3b* cur = bgr.ptr<cv::Vec3b>(0);
  const cv::Vec3b* old = prev_frame_.ptr<cv::Vec3b>(0);
  const int32_t* lab = prev_labels_.ptr<int32_t>(0);
  double mx = 0;
  cv::minMaxLoc(prev_labels_, nullptr, &mx);
  const size_t regions = static_cast<size_t>(mx) + 1;
  // Per last-frame region: its size, its unchanged pixels, their gradient sum.
  std::vector<int> size(regions, 0), unchanged(regions, 0);
  std::vector<double> grad_sum(regions, 0);
  std::vector<uint8_t> same(n, 0);
  std::vector<uint16_t> grad(n, 0);
  const int tol = p_.unchanged_within;
  for (size_t i = 0; i < n; ++i) {
    const int r = lab[i];
    ++size[r];
    // A pixel's gradient: the larger of its two texture elements (this frame's).
    const uint16_t th = tex_.value[2 * i], tv = tex_.value[2 * i + 1];
    grad[i] = static_cast<uint16_t>(std::max(th < 256 ? th : 0, tv < 256 ? tv : 0));
    grad_sum[r] += grad[i];
    if (std::abs(cur[i][0] - old[i][0]) <= tol && std::abs(cur[i][1] - old[i][1]) <= tol &&
        std::abs(cur[i][2] - old[i][2]) <= tol) {
      same[i] = 1;
      ++unchanged[r];
    }
  }
  // The last frame's region colours.
  std::vector<cv::Vec3d> colour(regions, cv::Vec3d(0, 0, 0));
  for (size_t i = 0; i < n; ++i) colour[lab[i]] += cv::Vec3d(old[i][0], old[i][1], old[i][2]);
  for (size_t r = 0; r < regions; ++r) colour[r] /= std::max(1, size[r]);
  const double colour2 = p_.seed_colour * p_.seed_colour;
  std::vector<int> groups(regions, 0);
  for (size_t i = 0; i < n; ++i) {
    const int r = lab[i];
    if (!same[i] || blocked_[i] || 2 * unchanged[r] <= size[r]) continue;
    const double mean = grad_sum[r] / std::max(1, size[r]);
    const double d0 = cur[i][0] - colour[r][0], d1 = cur[i][1] - colour[r][1], d2 = cur[i][2] - colour[r][2];
    if (d0 * d0 + d1 * d1 + d2 * d2 > colour2) continue;
    if (grad[i] < mean || grad[i] < p_.low_gradient) {
      seed_of_[i] = r;
      ++seeded_;
      if (groups[r]++ == 0) ++seed_groups_;
    }
  }
}

void MserSegmenter::build_tree(Segmentation* out) {
  const int w = tex_.width, h = tex_.height;
  const size_t n = static_cast<size_t>(w) * h;
  // One record per pixel, a region's state at its root: what a union touches shares a line.
  px_.resize(n);
  parent_.resize(n);
  next_.assign(n, -1);
  for (size_t i = 0; i < n; ++i) {
    PxState& q = px_[i];
    parent_[i] = q.head = q.tail = static_cast<int32_t>(i);
    q.size = q.prev_size = 1;
    q.growth = q.growth_before = 0;
    q.hlevel = -2;
    q.touched_at = -1;
    q.top_head = q.top_tail = q.pend_head = q.pend_tail = -1;
  }
  node_next_.clear();
  merges_.clear();
  int32_t* parent = parent_.data();
  auto root = [parent](int32_t x) {
    while (parent[x] != x) {
      parent[x] = parent[parent[x]];
      x = parent[x];
    }
    return x;
  };
  auto append_top = [&](PxState& r, int32_t h2, int32_t t2) {
    if (h2 < 0) return;
    if (r.top_head < 0) r.top_head = h2;
    else node_next_[r.top_tail] = h2;
    r.top_tail = t2;
  };
  auto append_pend = [&](PxState& r, int32_t h2, int32_t t2) {
    if (h2 < 0) return;
    if (r.pend_head < 0) r.pend_head = h2;
    else node_next_[r.pend_tail] = h2;
    r.pend_tail = t2;
  };
  int16_t level = 0;
  const int min_size = p_.min_size;
  // Growth that "declines or is stable" before the acceleration: a level without growth, or a
  // declining growth that adds under an eighth of the region (a speck that doubles every level
  // while it shrinks its growth is still forming, not stable).
  auto steady = [&](const PxState& r, bool last_level) {
    if (!last_level) return true;
    return r.growth <= r.growth_before && 8 * r.growth < r.prev_size;
  };
  auto store = [&](PxState& r, int size, int node_level) {
    const int id = static_cast<int>(out->tree.size());
    MserNode node;
    node.level = node_level;
    node.size = size;
    node.head = r.head;
    for (int32_t c = r.top_head; c >= 0; c = node_next_[c]) {
      node.children.push_back(c);
      out->tree[c].parent = id;
    }
    out->tree.push_back(std::move(node));
    node_next_.push_back(-1);
    r.top_head = r.top_tail = id;
  };
  // Unites two roots.
  auto unite = [&](int32_t a, int32_t b) {
    if (px_[a].size < px_[b].size) std::swap(a, b);
    PxState& A = px_[a];
    PxState& B = px_[b];
    // b ends here, swallowed by a larger region: for b that is accelerated growth, so b as it
    // was before this level is an MSER if it had been growing steadily (or not at all).
    if (B.prev_size >= min_size) {
      const bool last_level = B.hlevel == level - 1;
      const int g_prev = last_level ? B.growth : 0;
      const int g = A.size + B.size - B.prev_size;
      if (steady(B, last_level) && g - g_prev > min_size) store(B, B.prev_size, last_level ? level - 1 : B.hlevel);
    }
    parent[b] = a;
    merges_.push_back({a, b});
    A.size += B.size;
    next_[A.tail] = B.head;
    A.tail = B.tail;
    // b's maximal MSERs now lie inside a, reached this level.
    append_pend(A, B.top_head, B.top_tail);
    append_pend(A, B.pend_head, B.pend_tail);
    B.top_head = B.pend_head = -1;
    if (A.touched_at != level) {
      A.touched_at = level;
      touched_.push_back(a);
    }
    return a;
  };
  const uint8_t* blocked = blocked_.data();
  const int32_t* seed = seed_of_.data();
  // Feed-forward seeds: each last-frame region's seeds one group from the start (no growth
  // history: they evolve from there), however scattered.
  if (seeded_ > 0) {
    std::vector<int32_t> first(static_cast<size_t>(*std::max_element(seed_of_.begin(), seed_of_.end())) + 1, -1);
    for (size_t i = 0; i < n; ++i) {
      const int32_t g = seed_of_[i];
      if (g < 0) continue;
      if (first[g] < 0) {
        first[g] = static_cast<int32_t>(i);
        continue;
      }
      const int32_t a = first[g], b = static_cast<int32_t>(i);
      PxState& A = px_[a];
      PxState& B = px_[b];
      parent[b] = a;
      merges_.push_back({a, b});
      A.size += B.size;
      next_[A.tail] = B.head;
      A.tail = B.tail;
    }
    for (int32_t a : first)
      if (a >= 0) px_[a].prev_size = px_[a].size;
  }
  for (int v = 0; v < 256; ++v) {
    level = static_cast<int16_t>(v);
    touched_.clear();
    for (uint32_t k = tex_.level_start[v]; k < tex_.level_start[v + 1]; ++k) {
      const uint32_t e = tex_.order[k];
      const int32_t c = static_cast<int32_t>(e >> 1);
      if (blocked[c]) continue;
      const int32_t step = (e & 1) ? w : 1;
      const int32_t a = c - step, b = c + step;
      // A unit inside one feed-forward group is one region already.
      if (seeded_ > 0) {
        const int32_t g = seed[c];
        if (g >= 0 && seed[a] == g && seed[b] == g) continue;
      }
      // Most units lie inside one region already: compare roots before uniting.
      int32_t rc = root(c);
      if (!blocked[a]) {
        const int32_t ra = root(a);
        if (ra != rc) rc = unite(rc, ra);
      }
      if (!blocked[b]) {
        const int32_t rb = root(b);
        if (rb != rc) unite(rc, rb);
      }
    }
    // Rates of growth of the regions that grew.
    for (int32_t ri : touched_) {
      PxState& r = px_[ri];
      if (parent[ri] != ri) continue;
      const int g = r.size - r.prev_size;
      const bool last_level = r.hlevel == v - 1;
      const int g_prev = last_level ? r.growth : 0;
      if (g - g_prev > min_size && steady(r, last_level) && r.prev_size >= min_size) {
        store(r, r.prev_size, last_level ? v - 1 : r.hlevel);
      }
      append_top(r, r.pend_head, r.pend_tail);
      r.pend_head = r.pend_tail = -1;
      r.growth_before = g_prev;
      r.growth = g;
      r.prev_size = r.size;
      r.hlevel = static_cast<int16_t>(v);
    }
  }
  // The regions left standing are the roots (line pixels stay out: they are not grown).
  for (size_t i = 0; i < n; ++i) {
    PxState& r = px_[i];
    if (parent[i] != static_cast<int32_t>(i) || blocked[i]) continue;
    append_top(r, r.pend_head, r.pend_tail);
    r.pend_head = -1;
    if (r.size < min_size && r.top_head < 0) continue;  // a speck: expansion assigns it
    store(r, r.size, 255);
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
  // The first pass's merges, replayed in their order: the same growth in the same order of
  // texture values, refused where two leaves would meet (so a part swallowed there by a region
  // holding two leaves joins the leaf whose merges reach it first). Elements that merged
  // nothing there are left out: a third of the work of a second pass over the elements.
  for (const auto& [a, b] : merges_) unite(a, b);
  // Every pixel's component, once.
  root_.resize(n);
  for (size_t i = 0; i < n; ++i) root_[i] = find(parent2_, static_cast<int32_t>(i));
  // Components to regions: leaves first (in leaf order), then parts no leaf reached.
  out->labels.create(h, w, CV_32S);
  int32_t* lab = out->labels.ptr<int32_t>(0);
  std::vector<int32_t>& region_of_root = region_of_root_;
  std::vector<int32_t>& comp_size = comp_size_;
  region_of_root.assign(n, -1);
  comp_size.assign(n, 0);
  for (size_t i = 0; i < n; ++i)
    if (!blocked_[i]) ++comp_size[root_[i]];
  out->regions.clear();
  for (size_t li = 0; li < out->leaves.size(); ++li) {
    const int32_t r = root_[out->tree[out->leaves[li]].head];
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
    const int32_t r = root_[i];
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
  // Feed-forward links: the last frame's region most of a region's seeds came from.
  if (seeded_ > 0) {
    std::vector<std::map<int, int>> by_donor(out->regions.size());
    for (size_t i = 0; i < n; ++i)
      if (seed_of_[i] >= 0) ++by_donor[lab[i]][seed_of_[i]];
    for (size_t r = 0; r < out->regions.size(); ++r) {
      int best = -1, most = 0, total = 0;
      for (const auto& [d, c] : by_donor[r]) {
        total += c;
        if (c > most) {
          most = c;
          best = d;
        }
      }
      out->regions[r].donor = best;
      out->regions[r].seeds = total;
    }
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
