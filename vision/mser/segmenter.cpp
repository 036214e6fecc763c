#include "vision/mser/segmenter.h"
#include "vision/mser/clones.h"

#include <algorithm>
#include <chrono>
#include <map>
#include <cmath>
#include <string>

namespace vigil::vision::mser {

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
  const auto t1 = Clock::now();
  compute_texture_values(bgr, &tex_);
  const auto t15 = Clock::now();
  seed_of_.assign(n, -1);
  seeded_ = seed_groups_ = 0;
  if (p_.feed_forward && !prev_frame_.empty() && prev_frame_.size() == bgr.size()) make_seeds(bgr);
  const auto t16 = Clock::now();
  // The order: elements centred on a line pixel merge nothing, and a unit wholly inside one
  // feed-forward group is one region already: both left out.
  order_texture_elements(&tex_, blocked_.data(), seeded_ > 0 ? seed_of_.data() : nullptr);
  const auto t2 = Clock::now();
  out->tree.clear();
  out->leaves.clear();
  build_tree(out);
  const auto t3 = Clock::now();
  expand(bgr, out);
  const auto t4 = Clock::now();
  times_ = {ms(t1, t15) + ms(t16, t2), ms(t0, t1), ms(t2, t3), ms(t3, t4), ms(t15, t16)};
  if (p_.feed_forward) {
    bgr.copyTo(prev_frame_);
    out->labels.copyTo(prev_labels_);
    prev_regions_ = static_cast<int>(out->regions.size());
  }
  return true;
}

void MserSegmenter::reset() {
  prev_frame_.release();
  prev_labels_.release();
}

// One run of a last-frame region through the seed test (make_seeds): unchanged, not on a line,
// gradient below the region's gate, colour within the limit of its mean; writes the region or
// -1 per pixel and returns how many seeded. An AVX2 clone where the processor has it (clones.h).
VIGIL_AVX2_CLONES int seed_run(const uint8_t* __restrict px, const uint8_t* __restrict same, const uint8_t* __restrict blocked,
                               const uint16_t* __restrict grad, int len, const float* mean, int below, float colour2,
                               int32_t region, int32_t* __restrict out) {
  const float m0 = mean[0], m1 = mean[1], m2 = mean[2];
  int seeded = 0;
  for (int k = 0; k < len; ++k) {
    const float d0 = px[3 * k] - m0, d1 = px[3 * k + 1] - m1, d2 = px[3 * k + 2] - m2;
    const int ok = same[k] & (blocked[k] ^ 1) & (grad[k] < below) & (d0 * d0 + d1 * d1 + d2 * d2 <= colour2);
    out[k] = (region + 1) * ok - 1;  // the region, or -1 (no branch)
    seeded += ok;
  }
  return seeded;
}

void MserSegmenter::make_seeds(const cv::Mat& bgr) {
  const int w = bgr.cols, h = bgr.rows;
  const size_t n = static_cast<size_t>(w) * h;
  const uint8_t* cur = bgr.ptr<uint8_t>(0);
  const uint8_t* old = prev_frame_.ptr<uint8_t>(0);
  const int32_t* lab = prev_labels_.ptr<int32_t>(0);
  const size_t regions = static_cast<size_t>(prev_regions_);
  // Per last-frame region: its unchanged pixels and their gradient sum, counted here; its size
  // and colour sum are the last segmentation's (sums_, kept from its expansion).
  acc_.assign(regions, SeedAcc{});
  std::vector<SeedAcc>& acc = acc_;
  same_.resize(n);
  grad_.resize(n);
  unchanged_bytes_.resize(3 * n);
  const int tol = p_.unchanged_within;
  {
    // Per byte (a vectorised loop), then per pixel: every channel within `tol`.
    uint8_t* __restrict u = unchanged_bytes_.data();
    for (size_t j = 0; j < 3 * n; ++j) u[j] = static_cast<uint8_t>(std::abs(static_cast<int>(cur[j]) - static_cast<int>(old[j])) <= tol);
    const uint16_t* __restrict tv = tex_.value.data();
    uint8_t* __restrict same = same_.data();
    uint16_t* __restrict grad = grad_.data();
    for (size_t i = 0; i < n; ++i) {
      same[i] = u[3 * i] & u[3 * i + 1] & u[3 * i + 2];
      // A pixel's gradient: the larger of its two texture elements (this frame's; 256: none).
      const uint16_t th = tv[2 * i], tt = tv[2 * i + 1];
      grad[i] = std::max<uint16_t>(th < 256 ? th : 0, tt < 256 ? tt : 0);
    }
  }
  // Runs of one label along a row are summed first (most pixels lie inside large regions); the
  // runs are kept for the seed test below.
  runs_.clear();
  for (size_t i = 0; i < n;) {
    const int32_t r = lab[i];
    int32_t unchanged = 0;
    int64_t grad = 0;
    const size_t start = i, row_end = (i / w + 1) * static_cast<size_t>(w);
    for (; i < row_end && lab[i] == r; ++i) {
      unchanged += same_[i];
      grad += grad_[i];
    }
    acc[r].unchanged += unchanged;
    acc[r].grad += grad;
    runs_.push_back({static_cast<int32_t>(start), static_cast<int32_t>(i)});
  }
  // Per region: its mean colour, and the gradient a seed must stay under: its mean gradient
  // (grad < sum / size is grad < ceil(sum / size) for whole numbers) or `low_gradient`,
  // whichever is higher; 0 where its majority changed (nothing seeds).
  struct Gate {
    float colour[3] = {0, 0, 0};
    int32_t below = 0;
  };
  std::vector<Gate> gate(regions);
  for (size_t r = 0; r < regions; ++r) {
    const SeedAcc& a = acc[r];
    const int64_t size = sums_[r].n;
    if (size == 0 || 2 * a.unchanged <= size) continue;
    gate[r].below = std::max<int32_t>(static_cast<int32_t>((a.grad + size - 1) / size), p_.low_gradient);
    for (int k = 0; k < 3; ++k) gate[r].colour[k] = static_cast<float>(static_cast<double>(sums_[r].c[k]) / size);
  }
  const float colour2 = static_cast<float>(p_.seed_colour * p_.seed_colour);
  // Every pixel tested, run by run (one region's gate for the run): unchanged, not on a line,
  // gradient low, colour close; a run of a region that changed seeds nothing.
  const uint8_t* __restrict same = same_.data();
  const uint8_t* __restrict blocked = blocked_.data();
  const uint16_t* __restrict grad = grad_.data();
  int32_t* __restrict seed = seed_of_.data();
  int seeded = 0;
  for (const auto& [a, b] : runs_) {
    const int32_t r = lab[a];
    const Gate g = gate[r];
    if (g.below == 0) continue;  // seed_of_ is -1 already
    const int run_seeded = seed_run(cur + 3 * static_cast<size_t>(a), same + a, blocked + a, grad + a, b - a, g.colour,
                                    g.below, colour2, r, seed + a);
    seeded += run_seeded;
  }
  seeded_ = seeded;  // seed_groups_ is counted where the groups are formed (build_tree)
}

void MserSegmenter::build_tree(Segmentation* out) {
  const int w = tex_.width, h = tex_.height;
  const size_t n = static_cast<size_t>(w) * h;
  // parent_[x] >= 0: x is not a root, its parent; -1: x is a root of one pixel (its state is
  // implicit); -(k + 2): x is the root of a region whose state is record k. Records are made when
  // a pixel first swallows another, one after another in memory, so the regions growing at a
  // level lie close together and a frame writes state only for regions that exist.
  parent_.assign(n, -1);
  next_.assign(n, -1);
  recs_.clear();
  recs_.reserve(n);  // never reallocated below: references into it stay valid
  node_next_.clear();
  merges_.clear();
  int32_t* parent = parent_.data();
  auto root = [parent](int32_t x) {
    for (;;) {
      const int32_t p = parent[x];
      if (p < 0) return x;
      const int32_t pp = parent[p];
      if (pp < 0) return p;
      parent[x] = pp;  // path halving
      x = pp;
    }
  };
  auto record_of = [&](int32_t x) -> Rec& {
    if (parent[x] == -1) {
      Rec r;
      r.root = r.head = r.tail = x;
      recs_.push_back(r);
      parent[x] = -static_cast<int32_t>(recs_.size()) - 1;
    }
    return recs_[static_cast<size_t>(-parent[x] - 2)];
  };
  auto size_of = [&](int32_t x) { return parent[x] == -1 ? 1 : recs_[static_cast<size_t>(-parent[x] - 2)].size; };
  auto append_top = [&](Rec& r, int32_t h2, int32_t t2) {
    if (h2 < 0) return;
    if (r.top_head < 0) r.top_head = h2;
    else node_next_[r.top_tail] = h2;
    r.top_tail = t2;
  };
  auto append_pend = [&](Rec& r, int32_t h2, int32_t t2) {
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
  auto steady = [&](const Rec& r, bool last_level) {
    if (!last_level) return true;
    return r.growth <= r.growth_before && 8 * r.growth < r.prev_size;
  };
  auto store = [&](Rec& r, int size, int node_level) {
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
  // Unites two roots: the smaller region goes into the larger (on a tie, b into a).
  auto unite = [&](int32_t a, int32_t b) __attribute__((always_inline)) {
    if (size_of(a) < size_of(b)) std::swap(a, b);
    Rec& A = record_of(a);
    if (parent[b] == -1) {
      // A single pixel (never an MSER: MIN-SIZE is above 1) joins.
      A.size += 1;
      next_[A.tail] = b;
      A.tail = b;
    } else {
      Rec& B = recs_[static_cast<size_t>(-parent[b] - 2)];
      // b ends here, swallowed by a larger region: for b that is accelerated growth, so b as it
      // was before this level is an MSER if it had been growing steadily (or not at all).
      if (B.prev_size >= min_size) {
        const bool last_level = B.hlevel == level - 1;
        const int g_prev = last_level ? B.growth : 0;
        const int g = A.size + B.size - B.prev_size;
        if (steady(B, last_level) && g - g_prev > min_size) store(B, B.prev_size, last_level ? level - 1 : B.hlevel);
      }
      A.size += B.size;
      next_[A.tail] = B.head;
      A.tail = B.tail;
      // b's maximal MSERs now lie inside a, reached this level.
      append_pend(A, B.top_head, B.top_tail);
      append_pend(A, B.pend_head, B.pend_tail);
      B.top_head = B.pend_head = -1;
      B.root = -1;
    }
    parent[b] = a;
    merges_.push_back({a, b});
    if (A.touched_at != level) {
      A.touched_at = level;
      touched_.push_back(static_cast<int32_t>(&A - recs_.data()));
    }
    return a;
  };
  // Feed-forward seeds: each last-frame region's seeds one group from the start (no growth
  // history: they evolve from there), however scattered.
  if (seeded_ > 0) {
    // Each group's first pixel (kept for the expansion's donor count).
    std::vector<int32_t>& first = group_first_;
    first.assign(static_cast<size_t>(*std::max_element(seed_of_.begin(), seed_of_.end())) + 1, -1);
    for (size_t i = 0; i < n; ++i) {
      const int32_t g = seed_of_[i];
      if (g < 0) continue;
      if (first[g] < 0) {
        first[g] = static_cast<int32_t>(i);
        continue;
      }
      const int32_t a = first[g], b = static_cast<int32_t>(i);
      Rec& A = record_of(a);
      parent[b] = a;
      merges_.push_back({a, b});
      A.size += 1;
      next_[A.tail] = b;
      A.tail = b;
    }
    for (int32_t a : first) seed_groups_ += a >= 0;
    group_size_.assign(first.size(), 0);
    for (size_t g = 0; g < first.size(); ++g) {
      const int32_t a = first[g];
      if (a < 0) continue;
      group_size_[g] = size_of(a);
      if (parent[a] != -1) {
        Rec& A = record_of(a);
        A.prev_size = A.size;
      }
    }
  }
  const uint32_t* order = tex_.order.data();
  for (int v = 0; v < 256; ++v) {
    level = static_cast<int16_t>(v);
    touched_.clear();
    const uint32_t k_end = tex_.level_start[v + 1];
    for (uint32_t k = tex_.level_start[v]; k < k_end; ++k) {
      // Never a line pixel's element, nor a unit inside one feed-forward group (left out of the
      // order); its top bits say which outer pixel of the unit is on a line.
      const uint32_t entry = order[k];
      const uint32_t e = entry & kElement;
      const int32_t c = static_cast<int32_t>(e >> 1);
      const int32_t step = (e & 1) ? w : 1;
      // Most units lie inside one region already: compare roots before uniting.
      int32_t rc = root(c);
      if (!(entry & kSideBefore)) {
        const int32_t ra = root(c - step);
        if (ra != rc) rc = unite(rc, ra);
      }
      if (!(entry & kSideAfter)) {
        const int32_t rb = root(c + step);
        if (rb != rc) unite(rc, rb);
      }
    }
    // Rates of growth of the regions that grew.
    for (int32_t ri : touched_) {
      Rec& r = recs_[static_cast<size_t>(ri)];
      if (r.root < 0) continue;  // swallowed later this level
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
  // The regions left standing are the roots, in pixel order (line pixels and pixels nothing
  // reached stay single: expansion assigns them).
  for (size_t i = 0; i < n; ++i) {
    if (parent[i] >= -1) continue;
    Rec& r = recs_[static_cast<size_t>(-parent[i] - 2)];
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
  // leaf_of_: the leaf each pixel lies in (-1: none); at a component's root, its leaf.
  leaf_of_.assign(n, -1);
  for (size_t li = 0; li < out->leaves.size(); ++li) {
    const MserNode& node = out->tree[out->leaves[li]];
    int32_t p = node.head;
    for (int k = 0; k < node.size && p >= 0; ++k, p = next_[p]) leaf_of_[p] = static_cast<int32_t>(li);
  }
  // The first pass's merges, replayed in their order: the same growth in the same order of
  // texture values, refused where two leaves would meet (so a part swallowed there by a region
  // holding two leaves joins the leaf whose merges reach it first). Elements that merged
  // nothing there are left out: a third of the work of a second pass over the elements.
  // Each merge (a, b) joined two roots of the first pass, b under a. The replay keeps that
  // direction, so a and b are roots here too when their merge comes (a refused merge only leaves
  // b a root for good): no root is searched for. A leaf is a first-pass region as it was at
  // some level, so every merge that formed it comes before any that reaches outside it.
  const size_t nm = merges_.size();
  accepted_.resize(nm);
  // Component sizes at their roots, added up as merges are accepted (line pixels are never
  // merged: they stay components of one).
  std::vector<int32_t>& comp_size = comp_size_;
  comp_size.assign(n, 1);
  for (size_t k = 0; k < nm; ++k) {
    const auto [a, b] = merges_[k];
    const int32_t la = leaf_of_[a], lb = leaf_of_[b];
    const bool ok = la < 0 || lb < 0 || la == lb;  // leaves never merge
    accepted_[k] = ok;
    if (!ok) continue;
    if (la < 0) leaf_of_[a] = lb;
    comp_size[a] += comp_size[b];
  }
  // Every pixel's component: a merge's b takes a's final root, latest merges first.
  root_.resize(n);
  for (size_t i = 0; i < n; ++i) root_[i] = static_cast<int32_t>(i);
  for (size_t k = nm; k-- > 0;)
    if (accepted_[k]) root_[merges_[k].second] = root_[merges_[k].first];
  // Components to regions: leaves first (in leaf order), then parts no leaf reached.
  out->labels.create(h, w, CV_32S);
  int32_t* lab = out->labels.ptr<int32_t>(0);
  std::vector<int32_t>& region_of_root = region_of_root_;
  region_of_root.assign(n, -1);
  out->regions.clear();
  for (size_t li = 0; li < out->leaves.size(); ++li) {
    const int32_t r = root_[out->tree[out->leaves[li]].head];
    region_of_root[r] = static_cast<int32_t>(out->regions.size());
    Region reg;
    reg.node = out->leaves[li];
    out->regions.push_back(reg);
  }
  // Pixels left unassigned (line pixels, specks) are listed for the sweeps below.
  std::vector<int32_t>& pending = pending_;
  pending.clear();
  for (size_t i = 0; i < n; ++i) {
    if (blocked_[i]) {
      lab[i] = -1;
      pending.push_back(static_cast<int32_t>(i));
      continue;
    }
    const int32_t r = root_[i];
    if (region_of_root[r] < 0 && comp_size[r] >= p_.min_size) {
      region_of_root[r] = static_cast<int32_t>(out->regions.size());
      out->regions.push_back(Region{});
    }
    lab[i] = region_of_root[r];
    if (lab[i] < 0) pending.push_back(static_cast<int32_t>(i));
  }
  if (out->regions.empty()) {
    // Nothing but lines and specks: one region.
    out->regions.push_back(Region{});
    for (size_t i = 0; i < n; ++i) lab[i] = 0;
    pending.clear();
  }
  // Region statistics (size, position moments, colour sums, box), summed exactly in integers
  // over runs of one label along a row; the pixels assigned below are added one by one.
  const uint8_t* px = bgr.ptr<uint8_t>(0);
  const size_t m = out->regions.size();
  sums_.assign(m, RegionSums{});
  auto tri = [](int64_t k) { return k * (k + 1) / 2; };               // 0 + 1 + .. + k
  auto sq = [](int64_t k) { return k * (k + 1) * (2 * k + 1) / 6; };  // 0^2 + .. + k^2
  for (int y = 0; y < h; ++y) {
    const int32_t* row = lab + static_cast<size_t>(y) * w;
    const uint8_t* col = px + 3 * static_cast<size_t>(y) * w;
    for (int x0 = 0; x0 < w;) {
      const int32_t r = row[x0];
      int x1 = x0;
      int64_t c0 = 0, c1 = 0, c2 = 0;
      for (; x1 < w && row[x1] == r; ++x1) {
        c0 += col[3 * x1];
        c1 += col[3 * x1 + 1];
        c2 += col[3 * x1 + 2];
      }
      if (r >= 0) {
        RegionSums& a = sums_[r];
        const int64_t k = x1 - x0, sx = tri(x1 - 1) - tri(x0 - 1);
        a.n += k;
        a.sx += sx;
        a.sy += k * y;
        a.sxx += sq(x1 - 1) - (x0 > 0 ? sq(x0 - 1) : 0);
        a.syy += k * y * y;
        a.sxy += sx * y;
        a.c[0] += c0;
        a.c[1] += c1;
        a.c[2] += c2;
        a.minx = std::min(a.minx, x0);
        a.maxx = std::max(a.maxx, x1 - 1);
        a.miny = std::min(a.miny, y);
        a.maxy = std::max(a.maxy, y);
      }
      x0 = x1;
    }
  }
  // Unassigned pixels (line pixels, specks) join the 4-neighbour region of the nearest mean
  // colour (the regions' means before any of them joined), sweep by sweep.
  std::vector<cv::Vec3d> mean(m);
  for (size_t r = 0; r < m; ++r) {
    const RegionSums& a = sums_[r];
    if (a.n > 0) mean[r] = cv::Vec3d(static_cast<double>(a.c[0]), static_cast<double>(a.c[1]), static_cast<double>(a.c[2])) * (1.0 / static_cast<double>(a.n));
  }
  // A feed-forward group is one region from the start, so all its pixels lie in one component:
  // its region, or (a speck) pixels assigned one by one below. Which, before they are.
  if (seeded_ > 0) {
    group_label_.resize(group_first_.size());
    for (size_t g = 0; g < group_first_.size(); ++g) group_label_[g] = group_first_[g] >= 0 ? lab[group_first_[g]] : -1;
    unassigned_ = pending;
  }
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
        const double m0 = sums_[r].n ? mean[r][0] : px[3 * q], m1 = sums_[r].n ? mean[r][1] : px[3 * q + 1],
                     m2 = sums_[r].n ? mean[r][2] : px[3 * q + 2];
        const double d0 = m0 - px[3 * i], d1 = m1 - px[3 * i + 1], d2 = m2 - px[3 * i + 2];
        const double dd = d0 * d0 + d1 * d1 + d2 * d2;
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
      for (int32_t i : still) assign.push_back({i, 0});
      still.clear();
    }
    for (const auto& [i, r] : assign) {
      lab[i] = r;
      RegionSums& a = sums_[r];
      const int x = i % w, y = i / w;
      ++a.n;
      a.sx += x;
      a.sy += y;
      a.sxx += static_cast<int64_t>(x) * x;
      a.syy += static_cast<int64_t>(y) * y;
      a.sxy += static_cast<int64_t>(x) * y;
      for (int k = 0; k < 3; ++k) a.c[k] += px[3 * i + k];
      a.minx = std::min(a.minx, x);
      a.maxx = std::max(a.maxx, x);
      a.miny = std::min(a.miny, y);
      a.maxy = std::max(a.maxy, y);
    }
    pending.swap(still);
  }
  // Feed-forward links: the last frame's region most of a region's seeds came from (on a tie,
  // the lowest). A region has few donors, kept in a short list, more in a map.
  if (seeded_ > 0) {
    struct Donors {
      int32_t donor[4], count[4];
      int used = 0;
      std::map<int, int> more;
    };
    std::vector<Donors> by(out->regions.size());
    auto add = [&by](int32_t r, int32_t d, int32_t c) {
      Donors& x = by[r];
      for (int k = 0; k < x.used; ++k)
        if (x.donor[k] == d) {
          x.count[k] += c;
          return;
        }
      if (x.used < 4) {
        x.donor[x.used] = d;
        x.count[x.used++] = c;
      } else {
        x.more[d] += c;
      }
    };
    // Each group whole where its component is a region; pixel by pixel where it was a speck.
    for (size_t g = 0; g < group_first_.size(); ++g)
      if (group_label_[g] >= 0) add(group_label_[g], static_cast<int32_t>(g), group_size_[g]);
    for (const int32_t i : unassigned_)
      if (seed_of_[i] >= 0) add(lab[i], seed_of_[i], 1);
    for (size_t r = 0; r < out->regions.size(); ++r) {
      const Donors& x = by[r];
      int best = -1, most = 0, total = 0;
      auto consider = [&](int d, int c) {
        total += c;
        if (c > most || (c == most && c > 0 && d < best)) {
          most = c;
          best = d;
        }
      };
      for (int k = 0; k < x.used; ++k) consider(x.donor[k], x.count[k]);
      for (const auto& [d, c] : x.more) consider(d, c);
      out->regions[r].donor = best;
      out->regions[r].seeds = total;
    }
  }

  for (size_t r = 0; r < m; ++r) {
    Region& reg = out->regions[r];
    const RegionSums& a = sums_[r];
    reg.size = static_cast<int>(a.n);
    if (a.n == 0) continue;
    const double k = 1.0 / static_cast<double>(a.n);
    const double mx = static_cast<double>(a.sx) * k, my = static_cast<double>(a.sy) * k;
    reg.centroid = cv::Point2f(static_cast<float>(mx), static_cast<float>(my));
    reg.cxx = static_cast<float>(static_cast<double>(a.sxx) * k - mx * mx);
    reg.cyy = static_cast<float>(static_cast<double>(a.syy) * k - my * my);
    reg.cxy = static_cast<float>(static_cast<double>(a.sxy) * k - mx * my);
    reg.mean = cv::Vec3f(static_cast<float>(static_cast<double>(a.c[0]) * k), static_cast<float>(static_cast<double>(a.c[1]) * k),
                         static_cast<float>(static_cast<double>(a.c[2]) * k));
    reg.bbox = cv::Rect(a.minx, a.miny, a.maxx - a.minx + 1, a.maxy - a.miny + 1);
  }
}

}  // namespace vigil::vision::mser
