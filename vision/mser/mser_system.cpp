#include "vision/mser/mser_system.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <set>
#include <tuple>

#include <opencv2/imgproc.hpp>

#include "vision/mser/kd_tree.h"

namespace vigil::vision::mser {
namespace {

SegmenterParams with_feed_forward(SegmenterParams p) {
  p.feed_forward = true;
  return p;
}

// Grows `box` to hold pixel (x, y) (an empty box becomes that pixel).
void include(cv::Rect* box, int x, int y) {
  *box = box->area() ? (*box | cv::Rect(x, y, 1, 1)) : cv::Rect(x, y, 1, 1);
}

double iou(const cv::Rect& a, const cv::Rect& b) {
  const int inter = (a & b).area();
  const int uni = a.area() + b.area() - inter;
  return uni > 0 ? static_cast<double>(inter) / uni : 0.0;
}

// The typical count of `counts` (rows' or columns' pixels): the count of the one the median
// pixel lies in, sorted by count (a long thin tail has many rows but few pixels); 0 if empty.
int typical_count(const std::vector<int>& counts) {
  std::vector<int> nz;
  int total = 0;
  for (int v : counts)
    if (v > 0) nz.push_back(v), total += v;
  if (nz.empty()) return 0;
  std::sort(nz.begin(), nz.end());
  int acc = 0;
  for (int v : nz)
    if ((acc += v) * 2 >= total) return v;
  return nz.back();
}

// The foreground pixels of component `id` (label in `cc`) in each row of `box` (`rows`), else
// in each column.
std::vector<int> component_counts(const cv::Mat& cc, const cv::Mat& fg, int id, const cv::Rect& box, bool rows) {
  std::vector<int> n(rows ? box.height : box.width, 0);
  for (int y = box.y; y < box.y + box.height; ++y) {
    const int32_t* c = cc.ptr<int32_t>(y);
    const uint8_t* f = fg.ptr<uint8_t>(y);
    for (int x = box.x; x < box.x + box.width; ++x) n[rows ? y - box.y : x - box.x] += c[x] == id && f[x];
  }
  return n;
}

// The box of a component's foreground pixels (label `id` in `cc`) without thin tails at its
// top and bottom: rows with fewer than `thin` of the typical row's pixels (a grout line the
// feet stand on, bled into the trousers' region; a strip of something far behind the head).
cv::Rect trimmed_box(const cv::Mat& cc, const cv::Mat& fg, int id, const cv::Rect& box, double thin) {
  if (!(thin > 0)) return box;
  const std::vector<int> row = component_counts(cc, fg, id, box, true);
  const int typical = typical_count(row);
  if (typical == 0) return box;
  const double min_row = thin * typical;
  int top = 0, bottom = box.height - 1;
  while (top < bottom && row[top] < min_row) ++top;
  while (bottom > top && row[bottom] < min_row) --bottom;
  int x0 = box.x + box.width, x1 = box.x - 1;
  for (int y = box.y + top; y <= box.y + bottom; ++y) {
    const int32_t* c = cc.ptr<int32_t>(y);
    const uint8_t* f = fg.ptr<uint8_t>(y);
    for (int x = box.x; x < box.x + box.width; ++x)
      if (c[x] == id && f[x]) x0 = std::min(x0, x), x1 = std::max(x1, x);
  }
  if (x1 < x0) return box;
  return cv::Rect(x0, box.y + top, x1 - x0 + 1, bottom - top + 1);
}

// The body of component `id` in `box`: its heaviest run of columns each holding at least
// `thin` times the typical column's foreground pixels (the column the median pixel lies in,
// columns sorted by their count), cut to the rows its pixels there span.
// An arm held out to a thing on a table is thin columns; the thing it reaches is another run.
cv::Rect heaviest_column_run(const cv::Mat& cc, const cv::Mat& fg, int id, const cv::Rect& box, double thin) {
  const std::vector<int> col = component_counts(cc, fg, id, box, false);
  const int typical = typical_count(col);
  if (typical == 0) return box;
  const double min_col = thin * typical;
  int best_left = 0, best_right = -1, best_sum = 0;
  for (int x = 0; x < box.width;) {
    if (col[x] < min_col) {
      ++x;
      continue;
    }
    int sum = 0, end = x;
    while (end < box.width && col[end] >= min_col) sum += col[end++];
    if (sum > best_sum) best_sum = sum, best_left = x, best_right = end - 1;
    x = end;
  }
  if (best_right < best_left) return box;
  int y0 = box.y + box.height, y1 = box.y - 1;
  for (int y = box.y; y < box.y + box.height; ++y) {
    const int32_t* c = cc.ptr<int32_t>(y);
    const uint8_t* f = fg.ptr<uint8_t>(y);
    for (int x = box.x + best_left; x <= box.x + best_right; ++x)
      if (c[x] == id && f[x]) y0 = std::min(y0, y), y1 = std::max(y1, y);
  }
  return cv::Rect(box.x + best_left, y0, best_right - best_left + 1, y1 - y0 + 1);
}

}  // namespace

MserSystem::MserSystem(MserSystemParams params)
    : p_(params), seg_(with_feed_forward(params.segmenter)), tracker_(params.tracking), models_(params.models) {}

void MserSystem::reset() {
  seg_.reset();
  tracker_.reset();
  model_.clear();
  info_.clear();
  objects_.clear();
  region_owner_.clear();
  next_object_ = 1;
  frame_ = 0;
  moved_background_ = 0;
  reshaped_background_ = 0;
  model_image_.release();
  uncovered_.release();
  released_.clear();
  models_.clear();
  model_order_.clear();
  object_regions_.clear();
}

bool MserSystem::process(const cv::Mat& bgr, std::string* error) {
  using Clock = std::chrono::steady_clock;
  auto ms = [](Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double, std::milli>(b - a).count(); };
  const auto t0 = Clock::now();
  if (!seg_.segment(bgr, &seg_out_, error)) return false;
  frame_bgr_ = bgr;
  const auto t1 = Clock::now();
  region_ids_ = tracker_.update(seg_out_, &seg_.lines());
  const auto t2 = Clock::now();
  // Track statistics: frames seen, how far it moved.
  for (size_t r = 0; r < seg_out_.regions.size(); ++r) {
    const int64_t id = region_ids_[r];
    if (id <= 0) continue;
    TrackInfo& t = info_[id];
    if (t.seen > 0) t.moved += cv::norm(seg_out_.regions[r].centroid - t.last);
    t.last = seg_out_.regions[r].centroid;
    t.recent[t.seen % t.recent.size()] = t.last;
    ++t.seen;
  }
  ++frame_;
  if (frame_ > p_.warmup_frames && frame_ <= p_.warmup_frames + p_.learn_frames) learn();
  classify();
  const auto t3 = Clock::now();
  update_objects();
  const auto t4 = Clock::now();
  times_ = {ms(t0, t1), ms(t1, t2), ms(t2, t3), ms(t3, t4)};
  // Forget the statistics of tracks gone for good.
  if (frame_ % 50 == 0) {
    std::set<int64_t> live;
    for (const auto& t : tracker_.tracks()) live.insert(t.id);
    for (auto it = info_.begin(); it != info_.end();) it = live.count(it->first) ? std::next(it) : info_.erase(it);
  }
  return true;
}

int MserSystem::best_entry(const std::vector<Entry>& model, const KdTree2* tree, const Region& reg) const {
  const float w = reg.width(), h = reg.height();
  const double radius = p_.bg_shift + 0.25 * (w + h);
  int best = -1;
  double best_d = 1e300;
  auto consider = [&](int e) {
    const Entry& m = model[e];
    const double rw = std::max(w, 1.0f) / std::max(m.width, 1.0f), rh = std::max(h, 1.0f) / std::max(m.height, 1.0f);
    if (rw > p_.bg_size_ratio || rw < 1 / p_.bg_size_ratio || rh > p_.bg_size_ratio || rh < 1 / p_.bg_size_ratio) return;
    const double dp = cv::norm(reg.centroid - m.centroid);
    if (dp > radius) return;
    const double dc = cv::norm(reg.mean - m.colour);
    if (dc > p_.bg_colour) return;
    const double d = dp / radius + dc / p_.bg_colour;
    if (d < best_d) {
      best_d = d;
      best = e;
    }
  };
  if (tree) {
    for (int e : tree->within(reg.centroid, static_cast<float>(radius))) consider(e);
  } else {
    for (size_t e = 0; e < model.size(); ++e) consider(static_cast<int>(e));
  }
  return best;
}

// Learning: every region of every learning frame is matched against the candidates so far (the
// same features and limits as in operation); a match refines the candidate, no match adds one.
// At the end, the candidates seen in at least half the learning frames, moving little, are the
// model.
void MserSystem::learn() {
  std::vector<std::pair<cv::Point2f, int>> pts;
  for (size_t i = 0; i < candidates_.size(); ++i) pts.push_back({candidates_[i].centroid, static_cast<int>(i)});
  const KdTree2 tree(std::move(pts));
  const size_t before = candidates_.size();
  std::vector<int64_t> seen_this_frame(before, -1);
  // Per region of this frame: the candidate it refined or added (-1: none, a speck or a second
  // match of a candidate).
  learned_as_.assign(seg_out_.regions.size(), -1);
  if (frame_ == p_.warmup_frames + 1 && p_.unknown_moving) frame_bgr_.copyTo(learn_first_);
  for (size_t r = 0; r < seg_out_.regions.size(); ++r) {
    const Region& reg = seg_out_.regions[r];
    if (reg.size < p_.tracking.min_size) continue;
    const int e = before ? best_entry(candidates_, &tree, reg) : -1;
    if (e >= 0 && seen_this_frame[e] != frame_) {
      learned_as_[r] = e;
      seen_this_frame[e] = frame_;
      Entry& m = candidates_[e];
      const float k = 1.0f / static_cast<float>(++m.count);
      m.moved += cv::norm(reg.centroid - m.centroid);
      m.centroid += k * (reg.centroid - m.centroid);
      m.width += k * (reg.width() - m.width);
      m.height += k * (reg.height() - m.height);
      m.colour += k * (reg.mean - m.colour);
    } else if (e < 0) {
      learned_as_[r] = static_cast<int>(candidates_.size());
      candidates_.push_back({reg.centroid, reg.width(), reg.height(), reg.mean, 1, 0.0});
    }
  }
  if (frame_ == p_.warmup_frames + p_.learn_frames) {
    // Still: its matches stayed within `still_speed` px of it, plus 2 % of its size (a large
    // region's centroid shifts as people cross it).
    std::vector<char> kept(candidates_.size(), 0);
    for (size_t i = 0; i < candidates_.size(); ++i) {
      const Entry& m = candidates_[i];
      if (2 * m.count >= p_.learn_frames && m.moved / std::max(1, m.count - 1) <= p_.still_speed + 0.02 * (m.width + m.height)) {
        model_.push_back(m);
        kept[i] = 1;
      }
    }
    for (Entry& m : model_) m.origin = m.centroid;
    // The model's picture: every pixel in its region's mean colour, as last learned, where that
    // region is in the model (and on specks). A region left out (something moving while the
    // model was learned: a robot driving off, someone walking) is not the scene: its pixels get
    // no model colour and are handled as released ones (release_from_background), so what it
    // uncovers when it moves on is taken into the model, and its own regions are not.
    model_image_.create(seg_out_.labels.size(), CV_32FC3);
    const int32_t* l = seg_out_.labels.ptr<int32_t>(0);
    cv::Vec3f* mi = model_image_.ptr<cv::Vec3f>(0);
    std::vector<char> unknown(seg_out_.regions.size(), 0);
    for (size_t r = 0; r < seg_out_.regions.size(); ++r) {
      const int e = learned_as_[r];
      if (seg_out_.regions[r].size < p_.tracking.min_size || (e >= 0 && kept[static_cast<size_t>(e)])) continue;
      unknown[r] = 1;
      if (e >= 0) released_.push_back(candidates_[static_cast<size_t>(e)]);
    }
    if (p_.unknown_moving && learn_first_.size() == frame_bgr_.size()) {
      uncovered_ = cv::Mat::zeros(model_image_.size(), CV_8U);
      uint8_t* u = uncovered_.ptr<uint8_t>(0);
      // ...where the picture changed over the learning frames (something moved there; a thin
      // region whose centroid wobbled over a still scene did not change it).
      const uint8_t* a = learn_first_.ptr<uint8_t>(0);
      const uint8_t* b = frame_bgr_.ptr<uint8_t>(0);
      const int changed = static_cast<int>(p_.bg_colour);
      for (size_t i = 0; i < model_image_.total(); ++i) {
        const bool moved_here = std::abs(a[3 * i] - b[3 * i]) > changed || std::abs(a[3 * i + 1] - b[3 * i + 1]) > changed ||
                                std::abs(a[3 * i + 2] - b[3 * i + 2]) > changed;
        if (unknown[l[i]] && moved_here) {
          mi[i] = cv::Vec3f(0, 0, 0);
          u[i] = 255;
        } else {
          mi[i] = seg_out_.regions[l[i]].mean;
        }
      }
    } else {
      released_.clear();
      for (size_t i = 0; i < model_image_.total(); ++i) mi[i] = seg_out_.regions[l[i]].mean;
    }
    candidates_.clear();
    learn_first_.release();
  }
}

bool MserSystem::colour_touching(int r) const {
  // The region's outer boundary: pixels of other regions 4-next to it, not released, whose
  // model colour is the region's (the floor it continues).
  const Region& reg = seg_out_.regions[static_cast<size_t>(r)];
  const cv::Mat& lab = seg_out_.labels;
  const double limit = p_.bg_colour * p_.bg_colour;
  const cv::Rect b = cv::Rect(reg.bbox.x - 1, reg.bbox.y - 1, reg.bbox.width + 2, reg.bbox.height + 2) & cv::Rect(0, 0, lab.cols, lab.rows);
  for (int y = b.y; y < b.br().y; ++y) {
    const int32_t* l = lab.ptr<int32_t>(y);
    const cv::Vec3f* mi = model_image_.ptr<cv::Vec3f>(y);
    const uint8_t* u = uncovered_.ptr<uint8_t>(y);
    for (int x = b.x; x < b.br().x; ++x) {
      if (l[x] == r || u[x]) continue;
      const bool next = (x > 0 && l[x - 1] == r) || (x + 1 < lab.cols && l[x + 1] == r) ||
                        (y > 0 && lab.ptr<int32_t>(y - 1)[x] == r) || (y + 1 < lab.rows && lab.ptr<int32_t>(y + 1)[x] == r);
      if (!next) continue;
      const cv::Vec3f d = mi[x] - reg.mean;
      if (d.dot(d) <= limit) return true;
    }
  }
  return false;
}

bool MserSystem::colour_beside(const Region& reg) const {
  // The model's colours around the region's box (half its size further on each side, at least
  // 4 px), on pixels not released, every other pixel.
  const int mx = std::max(4, reg.bbox.width / 2), my = std::max(4, reg.bbox.height / 2);
  const cv::Rect around = cv::Rect(reg.bbox.x - mx, reg.bbox.y - my, reg.bbox.width + 2 * mx, reg.bbox.height + 2 * my) &
                          cv::Rect(0, 0, model_image_.cols, model_image_.rows);
  const double limit = p_.bg_colour * p_.bg_colour;
  for (int y = around.y; y < around.br().y; y += 2) {
    const cv::Vec3f* mi = model_image_.ptr<cv::Vec3f>(y);
    const uint8_t* u = uncovered_.ptr<uint8_t>(y);
    for (int x = around.x; x < around.br().x; x += 2) {
      if (u[x]) continue;
      const cv::Vec3f d = mi[x] - reg.mean;
      if (d.dot(d) <= limit) return true;
    }
  }
  return false;
}

bool MserSystem::set_small_things_mask(const cv::Mat& mask) {
  if (!mask.empty() && mask.type() != CV_8U) return false;
  small_things_ = mask.clone();
  return true;
}

int MserSystem::release_from_background(const cv::Mat& mask) {
  if (learning() || model_image_.empty() || mask.type() != CV_8UC1 || mask.size() != model_image_.size()) return -1;
  int n = 0;
  for (Entry& m : model_) {
    const int x = static_cast<int>(std::lround(m.centroid.x)), y = static_cast<int>(std::lround(m.centroid.y));
    if (x < 0 || y < 0 || x >= mask.cols || y >= mask.rows || !mask.at<uint8_t>(y, x)) continue;
    m.gone = true;
    released_.push_back(m);
    ++n;
  }
  model_.erase(std::remove_if(model_.begin(), model_.end(), [](const Entry& m) { return m.gone; }), model_.end());
  // No model colour there (zero: the sums of the model's colours under a region leave them out).
  model_image_.setTo(cv::Scalar::all(0), mask);
  if (uncovered_.empty()) uncovered_ = cv::Mat::zeros(mask.size(), CV_8U);
  uncovered_.setTo(255, mask);
  return n;
}

void MserSystem::classify() {
  const cv::Mat& lab = seg_out_.labels;
  fg_ = cv::Mat::zeros(lab.size(), CV_8U);
  if (learning()) return;
  std::vector<std::pair<cv::Point2f, int>> pts;
  for (size_t i = 0; i < model_.size(); ++i) pts.push_back({model_[i].centroid, static_cast<int>(i)});
  const KdTree2 tree(std::move(pts));
  std::vector<char> is_fg(seg_out_.regions.size(), 0);
  std::vector<Entry> absorb;
  // Per region: the model picture's mean colour under it (a background region whose shape
  // changed, cut by something passing in front, still has the model's colours under it).
  std::vector<cv::Vec3d> under(seg_out_.regions.size(), cv::Vec3d(0, 0, 0));
  // Per region: its pixels on released ones (what a released thing uncovers).
  std::vector<int> on_released;
  if (!uncovered_.empty() && cv::countNonZero(uncovered_) > 0) {
    on_released.assign(seg_out_.regions.size(), 0);
    const int32_t* l = lab.ptr<int32_t>(0);
    const uint8_t* u = uncovered_.ptr<uint8_t>(0);
    for (size_t i = 0; i < lab.total(); ++i)
      if (u[i]) ++on_released[l[i]];
  }
  std::vector<int> uncovered_regions;
  {
    const int32_t* l = lab.ptr<int32_t>(0);
    const cv::Vec3f* mi = model_image_.ptr<cv::Vec3f>(0);
    // Summed over runs of one label (sums of floats in doubles are exact here, so the order
    // does not matter).
    const size_t n = lab.total();
    for (size_t i = 0; i < n;) {
      const int32_t r = l[i];
      double s0 = 0, s1 = 0, s2 = 0;
      for (; i < n && l[i] == r; ++i) s0 += mi[i][0], s1 += mi[i][1], s2 += mi[i][2];
      under[r] += cv::Vec3d(s0, s1, s2);
    }
  }
  for (size_t r = 0; r < seg_out_.regions.size(); ++r) {
    const Region& reg = seg_out_.regions[r];
    const float w = reg.width(), h = reg.height();
    const int best = best_entry(model_, &tree, reg);
    const int64_t id = region_ids_[r];
    TrackInfo* t = id > 0 ? &info_[id] : nullptr;
    if (best >= 0) {
      Entry& m = model_[best];
      const float a = static_cast<float>(p_.adapt);
      m.centroid = (1 - a) * m.centroid + a * reg.centroid;
      m.width = (1 - a) * m.width + a * w;
      m.height = (1 - a) * m.height + a * h;
      m.colour = (1 - a) * m.colour + a * reg.mean;
      // A background region that wanders off from where it was learned (a distant person,
      // walking slowly enough in the image to look still while the model was learned) is
      // something moving: the entry goes, the region is foreground.
      if (cv::norm(m.centroid - m.origin) > p_.bg_shift + 0.25 * (m.width + m.height)) {
        m.gone = true;
        ++moved_background_;
        if (t) t->background = false;
        is_fg[r] = 1;
        continue;
      }
      if (t) {
        t->background = true;
        t->still_foreground = 0;
      }
      continue;
    }
    if (reg.size < p_.tracking.min_size) continue;  // specks: neither
    // The model's colours under it, where it has them (not on released pixels: those under at
    // least half of it).
    const int modelled = reg.size - (on_released.empty() ? 0 : on_released[r]);
    const cv::Vec3d u = under[r] / std::max(1, modelled);
    if (2 * modelled >= reg.size && cv::norm(cv::Vec3d(reg.mean[0], reg.mean[1], reg.mean[2]) - u) <= p_.bg_colour) {
      ++reshaped_background_;  // the model's colours under it: background, reshaped
      // Reaching over released pixels, it shows what they uncovered: the scene's again.
      if (modelled < reg.size) uncovered_regions.push_back(static_cast<int>(r));
      continue;
    }
    is_fg[r] = 1;
    if (t) {
      if (t->background) ++moved_background_;  // a background region that changed unexpectedly
      t->background = false;
      // Uncovered by a released thing: mostly on its pixels, none of its regions (their entries
      // as learned: place, size and colour), and of a colour the model has beside it (the floor
      // or the wall that was behind it).
      if (!on_released.empty() && 5 * on_released[r] >= 4 * reg.size && best_entry(released_, nullptr, reg) < 0 &&
          (p_.uncover_touching ? colour_touching(static_cast<int>(r)) : colour_beside(reg))) {
        absorb.push_back({reg.centroid, w, h, reg.mean, 1, 0.0});
        uncovered_regions.push_back(static_cast<int>(r));
        t->still_foreground = 0;
        is_fg[r] = 0;
        continue;
      }
      // Still for long: taken into the model.
      if (++t->still_foreground >= p_.absorb_frames) {
        absorb.push_back({reg.centroid, w, h, reg.mean, 1, 0.0});
        t->still_foreground = 0;
      }
    }
  }
  model_.erase(std::remove_if(model_.begin(), model_.end(), [](const Entry& m) { return m.gone; }), model_.end());
  for (Entry& m : absorb) m.origin = m.centroid;
  model_.insert(model_.end(), absorb.begin(), absorb.end());
  if (!uncovered_regions.empty()) {
    // Those pixels are the scene's again, in the colours they now show.
    std::vector<char> back(seg_out_.regions.size(), 0);
    cv::Rect box = seg_out_.regions[uncovered_regions.front()].bbox;  // theirs (all their pixels)
    for (int r : uncovered_regions) back[r] = 1, box |= seg_out_.regions[r].bbox;
    for (int y = box.y; y < box.br().y; ++y) {
      const int32_t* l = lab.ptr<int32_t>(y);
      uint8_t* u = uncovered_.ptr<uint8_t>(y);
      cv::Vec3f* mi = model_image_.ptr<cv::Vec3f>(y);
      for (int x = box.x; x < box.br().x; ++x)
        if (back[l[x]]) u[x] = 0, mi[x] = seg_out_.regions[l[x]].mean;
    }
  }
  const int32_t* l = lab.ptr<int32_t>(0);
  uint8_t* f = fg_.ptr<uint8_t>(0);
  const size_t n = lab.total();
  for (size_t i = 0; i < n; ++i) f[i] = is_fg[l[i]] ? 255 : 0;
  // A background region that spilled over places of another colour in the model's picture has
  // merged with something of its colour in front (dark trousers with a dark laptop screen
  // behind): those of its pixels are foreground, when there are at least a region's worth.
  spilled_.assign(seg_out_.regions.size(), 0);
  spill_.release();
  if (p_.spill_colour > 0) {
    const size_t nr = seg_out_.regions.size();
    // Only a background region of at least a region's size can spill.
    std::vector<char> can(nr, 0);
    for (size_t r = 0; r < nr; ++r) can[r] = !is_fg[r] && seg_out_.regions[r].size >= p_.tracking.min_size;
    std::vector<int> spill(nr, 0);
    const float limit = static_cast<float>(p_.spill_colour * p_.spill_colour);
    const cv::Vec3f* mi = model_image_.ptr<cv::Vec3f>(0);
    const uint8_t* u = uncovered_.empty() ? nullptr : uncovered_.ptr<uint8_t>(0);
    const uint8_t* px = frame_bgr_.ptr<uint8_t>(0);
    // Off the model: the region's mean and the pixel's own colour both far from the model's
    // picture there (two background regions of different colours merged in this frame's
    // segmentation have the model's colours pixel by pixel).
    cv::Mat spill_mask(lab.size(), CV_8U);
    uint8_t* sm = spill_mask.ptr<uint8_t>(0);
    for (size_t i = 0; i < n; ++i) {
      const int32_t r = l[i];
      sm[i] = 0;
      if (!can[r] || (u && u[i])) continue;
      const cv::Vec3f d = mi[i] - seg_out_.regions[r].mean;
      if (d.dot(d) <= limit) continue;
      const cv::Vec3f e = mi[i] - cv::Vec3f(px[3 * i], px[3 * i + 1], px[3 * i + 2]);
      if (e.dot(e) <= limit) continue;
      sm[i] = 255;
      ++spill[r];
    }
    // A merge leaves a good share of both: a region nearly all off the model is a background
    // region found a little off its place, a sliver off a large one is noise.
    cv::Rect roi;  // the spilled regions' box
    for (size_t r = 0; r < nr; ++r) {
      const double share = static_cast<double>(spill[r]) / std::max(1, seg_out_.regions[r].size);
      spilled_[r] = spill[r] >= p_.tracking.min_size && share >= p_.spill_share && share <= 1.0 - p_.spill_share;
      if (spilled_[r]) roi = roi.area() > 0 ? roi | seg_out_.regions[r].bbox : seg_out_.regions[r].bbox;
    }
    if (roi.area() > 0) {
      // Only where it touches the foreground: the thing in front shows elsewhere too (the shirt
      // above the trousers). A spill alone is a change of the scene, not someone in front. All
      // of the work is in the spilled regions' box but the foreground's sizes.
      for (int y = roi.y; y < roi.br().y; ++y) {
        uint8_t* m = spill_mask.ptr<uint8_t>(y);
        const int32_t* lr = lab.ptr<int32_t>(y);
        for (int x = roi.x; x < roi.br().x; ++x)
          if (!spilled_[lr[x]]) m[x] = 0;
      }
      cv::Mat cc;
      const int ncc = cv::connectedComponents(spill_mask(roi), cc, 8, CV_32S);
      // ...of an object's size without the spill (not a speck of reshaped wall texture).
      cv::Mat fcc;
      const int nf = cv::connectedComponents(fg_, fcc, 8, CV_32S);
      std::vector<int> area(static_cast<size_t>(nf), 0);
      const int32_t* fc = fcc.ptr<int32_t>(0);
      for (size_t i = 0; i < n; ++i) ++area[fc[i]];
      const double min_area = p_.min_object_area * static_cast<double>(n);
      std::vector<char> large(static_cast<size_t>(nf), 0);
      for (int k = 1; k < nf; ++k) large[k] = area[k] >= min_area;
      std::vector<char> touches(static_cast<size_t>(ncc), 0);
      for (int y = 0; y < roi.height; ++y) {
        const int32_t* c = cc.ptr<int32_t>(y);
        for (int x = 0; x < roi.width; ++x) {
          if (c[x] == 0 || touches[c[x]]) continue;
          const int gx = roi.x + x, gy = roi.y + y;
          for (int yy = std::max(0, gy - 1); yy <= std::min(lab.rows - 1, gy + 1) && !touches[c[x]]; ++yy) {
            const int32_t* fr = fcc.ptr<int32_t>(yy);
            for (int xx = std::max(0, gx - 1); xx <= std::min(lab.cols - 1, gx + 1); ++xx)
              if (large[fr[xx]]) {
                touches[c[x]] = 1;
                break;
              }
          }
        }
      }
      std::fill(spilled_.begin(), spilled_.end(), 0);
      spill_ = cv::Mat::zeros(lab.size(), CV_8U);
      for (int y = 0; y < roi.height; ++y) {
        const int32_t* c = cc.ptr<int32_t>(y);
        const int32_t* lr = lab.ptr<int32_t>(roi.y + y) + roi.x;
        uint8_t* fr = fg_.ptr<uint8_t>(roi.y + y) + roi.x;
        uint8_t* so = spill_.ptr<uint8_t>(roi.y + y) + roi.x;
        for (int x = 0; x < roi.width; ++x)
          if (c[x] > 0 && touches[c[x]]) fr[x] = so[x] = 255, spilled_[lr[x]] = 1;
      }
    }
  }
}

std::vector<std::vector<ModelRegion>> MserSystem::box_regions(const cv::Mat& cc, const std::vector<int>& box_of) const {
  const cv::Mat& lab = seg_out_.labels;
  const size_t nr = seg_out_.regions.size();
  std::vector<int> box_of_region(nr, -1), boundary(nr, 0), on_line(nr, 0);
  // Lines, widened by a pixel: a region's boundary pixel beside one is on a line.
  cv::Mat near_line;
  cv::dilate(seg_.lines().mask, near_line, cv::Mat::ones(3, 3, CV_8U));
  for (int y = 0; y < lab.rows; ++y) {
    const int32_t* l = lab.ptr<int32_t>(y);
    const uint8_t* f = fg_.ptr<uint8_t>(y);
    const int32_t* c = cc.ptr<int32_t>(y);
    const uint8_t* nl = near_line.ptr<uint8_t>(y);
    for (int x = 0; x < lab.cols; ++x) {
      if (!f[x]) continue;
      const int r = l[x];
      if (box_of_region[r] < 0 && c[x] > 0) box_of_region[r] = box_of[c[x]];
      const bool edge = (x > 0 && l[x - 1] != r) || (x + 1 < lab.cols && l[x + 1] != r) ||
                        (y > 0 && lab.ptr<int32_t>(y - 1)[x] != r) || (y + 1 < lab.rows && lab.ptr<int32_t>(y + 1)[x] != r);
      if (!edge) continue;
      ++boundary[r];
      on_line[r] += nl[x] != 0;
    }
  }
  std::vector<std::vector<ModelRegion>> out(*std::max_element(box_of.begin(), box_of.end()) + 1);
  for (size_t r = 0; r < nr; ++r) {
    if (box_of_region[r] < 0 || seg_out_.regions[r].size < p_.tracking.min_size) continue;
    const float straight = boundary[r] > 0 ? static_cast<float>(on_line[r]) / boundary[r] : 0.0f;
    out[box_of_region[r]].push_back(ModelRegion::from(seg_out_.regions[r], straight));
  }
  return out;
}

void MserSystem::update_objects() {
  std::vector<cv::Rect> boxes, bodies;  // per box: its box, its upright body (thin_column)
  std::vector<int> areas;
  std::vector<std::vector<ModelRegion>> regions_of_box;
  std::vector<char> still_part;  // per box: the still part of a split component
  std::vector<int64_t> box_owner;  // per box: the object whose regions it holds (-1: found by matching)
  cv::Mat cc;                      // components (and the parts split off them)
  std::vector<int> box_of;         // component or part -> box
  if (!learning()) {
    cv::Mat closed;
    const int k = std::max(1, p_.close_px);
    cv::morphologyEx(fg_, closed, cv::MORPH_CLOSE, cv::getStructuringElement(cv::MORPH_RECT, {k, k}));
    cv::Mat stats, centroids;
    const int n = cv::connectedComponentsWithStats(closed, cc, stats, centroids, 8, CV_32S);
    const double min_area = p_.min_object_area * static_cast<double>(fg_.total());
    const double min_still = small_things_.size() == fg_.size()
                                 ? std::min(min_area, p_.min_still_area * static_cast<double>(fg_.total()))
                                 : min_area;
    // A box whose bottom middle lies where small things may lie.
    auto on_small_mask = [&](const cv::Rect& b) {
      return small_things_.size() == fg_.size() && b.area() > 0 &&
             small_things_.at<uint8_t>(b.y + b.height - 1, b.x + b.width / 2) != 0;
    };
    // Which foreground regions are still: tracked for a while and not moving.
    std::vector<char> still(seg_out_.regions.size(), 0);
    if (p_.split_still) {
      const int age = std::clamp(p_.still_age, 1, 31);
      for (size_t r = 0; r < seg_out_.regions.size(); ++r) {
        const int64_t id = region_ids_[r];
        if (id <= 0) continue;
        const auto it = info_.find(id);
        if (it == info_.end() || it->second.seen <= age) continue;
        const TrackInfo& t = it->second;
        const cv::Point2f then = t.recent[(t.seen - 1 - age) % t.recent.size()];
        still[r] = cv::norm(t.last - then) < p_.split_still_speed * age;
      }
    }
    box_of.assign(n, -1);
    int labels = n;
    // Live objects that stood upright (see split_owners).
    std::set<int64_t> upright;
    std::map<int64_t, cv::Rect> last_box;
    if (p_.split_owners)
      for (const ImageObject& o : objects_)
        if (o.age + 1 >= p_.confirm_frames && o.box.height >= p_.split_aspect * o.box.width) upright.insert(o.id), last_box[o.id] = o.box;
    auto owner_at = [&](int r) -> int64_t {
      const int64_t rid = region_ids_[r];
      if (rid <= 0) return -1;
      const auto it = region_owner_.find(rid);
      return it != region_owner_.end() && upright.count(it->second) ? it->second : -1;
    };
    // Each upright object's foreground pixels in the whole frame: a component holding a small
    // share of someone (a piece of her cut off from the rest) is not where she is.
    std::map<int64_t, int> owned_px;
    if (upright.size() >= 2)
      for (int y = 0; y < cc.rows; ++y) {
        const uint8_t* f = fg_.ptr<uint8_t>(y);
        const int32_t* l = seg_out_.labels.ptr<int32_t>(y);
        for (int x = 0; x < cc.cols; ++x)
          if (f[x]) {
            const int64_t ow = owner_at(l[x]);
            if (ow >= 0) ++owned_px[ow];
          }
      }
    // A component's body (thin_column: its heaviest run of columns that are not thin), if upright
    // (else its whole box).
    auto body_of = [&](int label, const cv::Rect& t) {
      if (!(p_.thin_column > 0)) return t;
      const cv::Rect body = heaviest_column_run(cc, fg_, label, t, p_.thin_column);
      return body.height < p_.split_aspect * body.width ? t : body;
    };
    auto add_box = [&](int label, const cv::Rect& b, bool still, int64_t owner) {
      const cv::Rect t = trimmed_box(cc, fg_, label, b, p_.thin_row);
      const int px = cv::countNonZero(fg_(t) & (cc(t) == label));
      if (px < p_.min_fill * t.area()) return;
      box_of[label] = static_cast<int>(boxes.size());
      boxes.push_back(t);
      bodies.push_back(body_of(label, t));
      areas.push_back(px);
      still_part.resize(boxes.size(), 0);
      still_part.back() = still;
      box_owner.resize(boxes.size(), -1);
      box_owner.back() = owner;
    };
    for (int i = 1; i < n; ++i) {
      const int area = stats.at<int>(i, cv::CC_STAT_AREA);
      if (area < min_still) continue;
      const cv::Rect box(stats.at<int>(i, cv::CC_STAT_LEFT), stats.at<int>(i, cv::CC_STAT_TOP),
                         stats.at<int>(i, cv::CC_STAT_WIDTH), stats.at<int>(i, cv::CC_STAT_HEIGHT));
      // Whose regions the component holds: parted when two upright objects each have an
      // object's size of it.
      if (upright.size() >= 2 && area >= min_area) {
        std::map<int64_t, int> px_of;
        std::map<int64_t, cv::Rect> owned_box;  // the box of each owner's pixels here
        for (int y = box.y; y < box.y + box.height; ++y) {
          const int32_t* c = cc.ptr<int32_t>(y);
          const uint8_t* f = fg_.ptr<uint8_t>(y);
          const int32_t* l = seg_out_.labels.ptr<int32_t>(y);
          for (int x = box.x; x < box.x + box.width; ++x)
            if (c[x] == i && f[x]) {
              const int64_t ow = owner_at(l[x]);
              if (ow < 0) continue;
              ++px_of[ow];
              include(&owned_box[ow], x, y);
            }
        }
        std::vector<std::pair<int, int64_t>> owners;  // (-pixels, id): the largest first
        for (const auto& [id, px] : px_of)
          if (px >= min_area && 2 * px >= owned_px[id] && last_box[id].height >= p_.split_min_height * box.height)
            owners.push_back({-px, id});
        // Side by side or one behind the other, not one above the other (the shirt and the
        // legs of one person, once apart for a moment): each part's last box shares at least
        // half of its height's rows with the largest's.
        std::sort(owners.begin(), owners.end());
        if (owners.size() >= 2) {
          const cv::Rect& first = last_box[owners[0].second];
          owners.erase(std::remove_if(owners.begin() + 1, owners.end(),
                                      [&](const std::pair<int, int64_t>& o) {
                                        const cv::Rect& b = last_box[o.second];
                                        const int rows = std::min(b.br().y, first.br().y) - std::max(b.y, first.y);
                                        return 2 * rows < std::min(b.height, first.height);
                                      }),
                       owners.end());
        }
        if (owners.size() >= 2) {
          std::map<int64_t, size_t> part_of;  // owner -> part (0: the largest, keeping label i)
          std::vector<int> part_label(owners.size());
          std::vector<cv::Rect> part_box(owners.size());
          for (size_t q = 0; q < owners.size(); ++q) {
            part_label[q] = q == 0 ? i : labels++;
            if (q > 0) box_of.push_back(-1);
            part_of[owners[q].second] = q;
          }
          for (int y = box.y; y < box.y + box.height; ++y) {
            int32_t* c = cc.ptr<int32_t>(y);
            const uint8_t* f = fg_.ptr<uint8_t>(y);
            const int32_t* l = seg_out_.labels.ptr<int32_t>(y);
            for (int x = box.x; x < box.x + box.width; ++x) {
              if (c[x] != i) continue;
              // Another's pixels, or nobody's: to the part whose own pixels' box holds the
              // pixel (the smallest such), else the largest part.
              const int64_t ow = f[x] ? owner_at(l[x]) : -1;
              const auto it = ow >= 0 ? part_of.find(ow) : part_of.end();
              size_t q = 0;
              if (it != part_of.end()) {
                q = it->second;
              } else {
                int smallest = std::numeric_limits<int>::max();
                for (size_t o = 0; o < owners.size(); ++o) {
                  const cv::Rect& ob = owned_box[owners[o].second];
                  if (ob.contains({x, y}) && ob.area() < smallest) smallest = ob.area(), q = o;
                }
              }
              c[x] = part_label[q];
              if (!f[x]) continue;
              include(&part_box[q], x, y);
            }
          }
          for (size_t q = 0; q < owners.size(); ++q)
            if (part_box[q].area() > 0) add_box(part_label[q], part_box[q], false, owners[q].second);
          continue;
        }
      }
      // Foreground (before closing) within the component, still and moving.
      int fg_px = 0, still_px = 0, spill_px = 0;
      cv::Rect still_box, moving_box, spill_box;
      for (int y = box.y; y < box.y + box.height; ++y) {
        const int32_t* c = cc.ptr<int32_t>(y);
        const uint8_t* f = fg_.ptr<uint8_t>(y);
        const uint8_t* sp = spill_.empty() ? nullptr : spill_.ptr<uint8_t>(y);
        const int32_t* l = seg_out_.labels.ptr<int32_t>(y);
        for (int x = box.x; x < box.x + box.width; ++x) {
          if (c[x] != i || !f[x]) continue;
          ++fg_px;
          if (sp && sp[x]) {  // with whatever it touches: neither still nor moving
            ++spill_px;
            include(&spill_box, x, y);
            continue;
          }
          include(still[l[x]] ? &still_box : &moving_box, x, y);
          still_px += still[l[x]];
        }
      }
      // Spilled pixels only go with something: they make no object of their own.
      if (fg_px - spill_px < min_still) continue;
      // Smaller than an object: only a thing lying still where small things may lie.
      if (area < min_area && (10 * still_px < 9 * (fg_px - spill_px) || !on_small_mask(box))) continue;
      // Something still beside something moving, each an object's size (a bag just put down
      // beside the person walking off, a walker passing in front of a parked robot), or a small
      // still thing where small things may lie (a book put down on a table): two objects.
      if ((still_px >= min_area || (still_px >= min_still && on_small_mask(still_box))) && fg_px - spill_px - still_px >= min_area) {
        const int part = labels++;
        box_of.push_back(-1);
        // The spill goes with the part it lies under or over (the columns they share): the legs
        // below a walker's shirt, with the walker, not with a thing put down beside.
        auto shared = [&](const cv::Rect& b) { return std::min(b.br().x, spill_box.br().x) - std::max(b.x, spill_box.x); };
        const bool spill_still = spill_px > 0 && shared(still_box) > shared(moving_box);
        for (int y = still_box.y; y < still_box.y + still_box.height; ++y) {
          int32_t* c = cc.ptr<int32_t>(y);
          const uint8_t* f = fg_.ptr<uint8_t>(y);
          const int32_t* l = seg_out_.labels.ptr<int32_t>(y);
          for (int x = still_box.x; x < still_box.x + still_box.width; ++x)
            if (c[x] == i && f[x] && still[l[x]] && !(spill_.data && spill_.at<uint8_t>(y, x))) c[x] = part;
        }
        if (spill_still) {  // (else they kept the moving part's label)
          for (int y = spill_box.y; y < spill_box.br().y; ++y) {
            int32_t* c = cc.ptr<int32_t>(y);
            const uint8_t* sp = spill_.ptr<uint8_t>(y);
            for (int x = spill_box.x; x < spill_box.br().x; ++x)
              if (c[x] == i && sp[x]) c[x] = part;
          }
        }
        if (spill_px > 0) (spill_still ? still_box : moving_box) |= spill_box;
        for (const auto& [b, label] : {std::pair{moving_box, i}, std::pair{still_box, part}}) add_box(label, b, label == part, -1);
        continue;
      }
      const cv::Rect t = trimmed_box(cc, fg_, i, box, p_.thin_row);
      if (cv::countNonZero(fg_(t) & (cc(t) == i)) < p_.min_fill * t.area()) continue;
      box_of[i] = static_cast<int>(boxes.size());
      boxes.push_back(t);
      bodies.push_back(body_of(i, t));
      areas.push_back(area);
    }
    if (p_.recognise && !boxes.empty()) regions_of_box = box_regions(cc, box_of);
  }
  regions_of_box.resize(boxes.size());
  still_part.resize(boxes.size(), 0);
  box_owner.resize(boxes.size(), -1);
  // An object's view for its model: the regions of the frame it showed the most foreground in
  // (or nearly: the later one), so an object leaving the image is modelled before it was cut.
  auto keep_view = [&](int64_t id, int area, std::vector<ModelRegion>* regions) {
    if (regions->empty()) return;
    auto it = object_regions_.find(id);
    if (it != object_regions_.end() && area < 0.9 * it->second.area) return;
    object_regions_[id] = {std::move(*regions), std::max(area, it != object_regions_.end() ? it->second.area : 0)};
  };
  // Greedy by overlap with each object's predicted box.
  std::vector<std::tuple<double, size_t, size_t>> pairs;
  for (size_t o = 0; o < objects_.size(); ++o) {
    cv::Rect pred = objects_[o].box;
    const cv::Point2f shift = objects_[o].velocity * static_cast<float>(objects_[o].lost + 1);
    pred.x += static_cast<int>(std::lround(shift.x));
    pred.y += static_cast<int>(std::lround(shift.y));
    for (size_t b = 0; b < boxes.size(); ++b) {
      // A part holding an object's regions is that object's.
      if (box_owner[b] >= 0) {
        if (objects_[o].id == box_owner[b]) pairs.push_back({-2.0, o, b});
        continue;
      }
      // The still part split off an object much larger than it is a thing put down, new; the
      // object (the one who put it down) goes on in the moving part.
      if (still_part[b] && objects_[o].box.area() > 2 * boxes[b].area()) continue;
      const double v = iou(pred, boxes[b]);
      if (v >= p_.min_iou) pairs.push_back({-v, o, b});
    }
  }
  std::sort(pairs.begin(), pairs.end());
  std::vector<char> used_o(objects_.size(), 0), used_b(boxes.size(), 0);
  std::vector<ImageObject> next;
  for (const auto& [neg, o, b] : pairs) {
    if (used_o[o] || used_b[b]) continue;
    used_o[o] = used_b[b] = 1;
    ImageObject obj = objects_[o];
    const cv::Point2f c0(obj.box.x + 0.5f * obj.box.width, obj.box.y + 0.5f * obj.box.height);
    const cv::Point2f c1(boxes[b].x + 0.5f * boxes[b].width, boxes[b].y + 0.5f * boxes[b].height);
    obj.velocity = 0.5f * obj.velocity + 0.5f * (c1 - c0) / static_cast<float>(obj.lost + 1);
    obj.box = boxes[b];
    obj.body = bodies[b];
    obj.area = areas[b];
    obj.lost = 0;
    ++obj.age;
    keep_view(obj.id, areas[b], &regions_of_box[b]);
    next.push_back(obj);
  }
  for (size_t o = 0; o < objects_.size(); ++o) {
    if (used_o[o]) continue;
    ImageObject obj = objects_[o];
    if (++obj.lost <= p_.keep_lost) {
      next.push_back(obj);
      continue;
    }
    // Ended: a reported object's model is kept for when it comes back.
    auto it = object_regions_.find(obj.id);
    if (p_.recognise && (obj.age + 1 >= p_.confirm_frames || obj.recognised) && it != object_regions_.end() && models_.add(obj.id, it->second.regions)) {
      model_order_.push_back(obj.id);
      while (static_cast<int>(model_order_.size()) > std::max(0, p_.max_models)) {
        models_.remove(model_order_.front());
        model_order_.erase(model_order_.begin());
      }
    }
    if (it != object_regions_.end()) object_regions_.erase(it);
  }
  for (size_t b = 0; b < boxes.size(); ++b) {
    if (used_b[b]) continue;
    ImageObject obj;
    obj.id = next_object_++;
    obj.box = boxes[b];
    obj.body = bodies[b];
    obj.area = areas[b];
    keep_view(obj.id, areas[b], &regions_of_box[b]);
    next.push_back(obj);
  }
  // A tentative object seen this frame: is it an ended object come back? Then it takes its id.
  if (p_.recognise && models_.size() > 0)
    for (ImageObject& obj : next) {
      if (obj.lost != 0 || obj.recognised || obj.age + 1 > p_.confirm_frames) continue;
      auto it = object_regions_.find(obj.id);
      if (it == object_regions_.end()) continue;
      const Recognition rec = models_.recognise(it->second.regions);
      if (!rec.recognised) continue;
      models_.remove(rec.id);
      model_order_.erase(std::find(model_order_.begin(), model_order_.end(), rec.id));
      object_regions_[rec.id] = std::move(it->second);
      object_regions_.erase(it);
      obj.id = rec.id;
      obj.recognised = true;
    }
  std::sort(next.begin(), next.end(), [](const ImageObject& a, const ImageObject& b) { return a.id < b.id; });
  objects_.swap(next);
  // Whose each foreground region is now: the object its box went to (split_owners). Entries of
  // objects that ended are dropped.
  if (p_.split_owners && !cc.empty()) {
    std::vector<int64_t> id_of_box(boxes.size(), -1);
    for (const ImageObject& o : objects_)
      if (o.lost == 0)
        for (size_t b = 0; b < boxes.size(); ++b)
          if (boxes[b] == o.box) id_of_box[b] = o.id;
    for (int y = 0; y < cc.rows; ++y) {
      const int32_t* c = cc.ptr<int32_t>(y);
      const uint8_t* f = fg_.ptr<uint8_t>(y);
      const int32_t* l = seg_out_.labels.ptr<int32_t>(y);
      for (int x = 0; x < cc.cols; ++x) {
        if (!f[x] || c[x] <= 0 || c[x] >= static_cast<int>(box_of.size()) || box_of[c[x]] < 0) continue;
        const int64_t rid = region_ids_[l[x]];
        const int64_t who = id_of_box[box_of[c[x]]];
        if (rid > 0 && who >= 0) region_owner_[rid] = who;
      }
    }
    std::set<int64_t> live;
    for (const ImageObject& o : objects_) live.insert(o.id);
    for (auto it = region_owner_.begin(); it != region_owner_.end();)
      it = live.count(it->second) ? std::next(it) : region_owner_.erase(it);
  }
}

std::vector<ImageObject> MserSystem::objects() const {
  std::vector<ImageObject> out;
  for (const auto& o : objects_)
    if (o.lost == 0 && o.age + 1 >= p_.confirm_frames) out.push_back(o);
  return out;
}

cv::Mat MserSystem::annotate(const cv::Mat& bgr) const {
  cv::Mat img(bgr.size(), CV_8UC3);
  const int32_t* l = seg_out_.labels.ptr<int32_t>(0);
  cv::Vec3b* px = img.ptr<cv::Vec3b>(0);
  for (size_t i = 0; i < img.total(); ++i) {
    const cv::Vec3f& m = seg_out_.regions[l[i]].mean;
    px[i] = cv::Vec3b(cv::saturate_cast<uint8_t>(m[0]), cv::saturate_cast<uint8_t>(m[1]), cv::saturate_cast<uint8_t>(m[2]));
  }
  img.setTo(cv::Scalar(0, 220, 0), seg_.lines().mask);
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(fg_.clone(), contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_SIMPLE);
  cv::drawContours(img, contours, -1, cv::Scalar(255, 0, 255), 1);
  for (const auto& o : objects()) {
    cv::rectangle(img, o.box, cv::Scalar(0, 0, 255), 2);
    cv::putText(img, std::to_string(o.id), o.box.tl() + cv::Point(2, 14), cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(255, 255, 255), 1);
  }
  if (learning()) cv::putText(img, "learning the background", {8, 20}, cv::FONT_HERSHEY_SIMPLEX, 0.6, cv::Scalar(0, 255, 255), 2);
  return img;
}

}  // namespace vigil::vision::mser
