#include "vision/mser/mser_tracker.h"

#include <limits>
#include <set>

#include <algorithm>
#include <climits>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "vision/planview_system.h"

namespace vigil::vision::mser {

Status MserTrackerParams::validate() const {
  if (!(max_range > 0) || !std::isfinite(max_range)) return bad_input("", 0, "max_range", "must be a positive distance (m)");
  if (!(velocity_window > 0) || !std::isfinite(velocity_window))
    return bad_input("", 0, "velocity_window", "must be a positive time (s)");
  if (!(class_vote_decay > 0 && class_vote_decay <= 1)) return bad_input("", 0, "class_vote_decay", "must be in (0, 1]");
  if (Status s = reid.validate(); !s.ok()) return s;
  if (system.warmup_frames < 0 || system.learn_frames < 1)
    return bad_input("", 0, "learn_frames", "needs at least one learning frame and no negative warm-up");
  if (system.confirm_frames < 1) return bad_input("", 0, "confirm_frames", "must be at least 1");
  if (!(surface_min_area > 0 && surface_min_area <= 1))
    return bad_input("", 0, "surface_min_area", "must be a share of the image in (0, 1]");
  if (!std::isfinite(hand_reach_margin)) return bad_input("", 0, "hand_reach_margin", "must be a number (negative: off)");
  if (split_gap_px < 0) return bad_input("", 0, "split_gap_px", "must be a number of pixels, at least 0");
  return Status::Ok();
}

Result<MserTracker> MserTracker::create(const StereoCameraModel& camera, const MserTrackerParams& params) {
  if (Status s = params.validate(); !s) return s.error();
  const auto& k = camera.intrinsics();
  if (k.width < 3 || k.height < 3 || !(k.fx > 0)) return bad_input("", 0, "camera", "the camera's intrinsics are not usable");
  MserTrackerParams p = params;
  p.system.min_still_area = p.surface_min_area;
  MserTracker t(camera, p);
  // Where the camera sees a surface's top: small still things may lie there.
  if (!p.surfaces.empty()) {
    cv::Mat mask(k.height, k.width, CV_8U, cv::Scalar(0));
    for (int v = 0; v < k.height; ++v)
      for (int u = 0; u < k.width; ++u) mask.at<uint8_t>(v, u) = t.surface_under(u, v) >= 0 ? 255 : 0;
    t.system_.set_small_things_mask(mask);
  }
  return t;
}

void MserTracker::reset() {
  system_.reset();
  start_objects_.clear();
  start_found_ = false;
  floor_start_.release();
  history_.clear();
  alias_.clear();
  reid_.reset();
  id_offset_ = max_id_;
}

void MserTracker::set_static_map(const OccupancyGrid& map) {
  map_ = map;
  clearance_ = map_clearance(map);
}

cv::Mat MserTracker::find_floor_start_objects() {
  const Segmentation& seg = system_.segmentation();
  const cv::Mat& lab = seg.labels;
  if (!p_.floor_start_objects || clearance_.empty() || lab.empty()) return {};
  const Eigen::Vector3d c = camera_.pose().position;
  auto clear_at = [&](double x, double y) {
    int cx = 0, cy = 0;
    return map_.world_to_cell({x, y}, &cx, &cy) && clearance_.at<float>(cy, cx) >= p_.floor_margin;
  };
  // 1. The floor's view, from rays through every other pixel (each stands for its 2x2 block), at
  // any range: the upper body of someone 4 m away is seen against floor 10 m and more away.
  constexpr double kFloorViewRange = 100.0;
  cv::Mat floor_view = cv::Mat::zeros(lab.size(), CV_8U);
  for (int v = 0; v < lab.rows; v += 2)
    for (int u = 0; u < lab.cols; u += 2) {
      const Eigen::Vector3d dir = camera_.back_project_map(u + 0.5, v + 0.5, 1.0) - c;
      if (!(dir.z() < -1e-9)) continue;
      const double t = -c.z() / dir.z();
      const double dist = t * std::hypot(dir.x(), dir.y());
      if (dist > kFloorViewRange || !clear_at(c.x() + t * dir.x(), c.y() + t * dir.y())) continue;
      double ts = 0;
      if (first_surface(c, dir, p_.surface_margin, &ts) >= 0) continue;
      if (map_.raycast({c.x(), c.y()}, std::atan2(dir.y(), dir.x()), dist + 1e-3) < dist) continue;  // a wall first
      floor_view(cv::Rect(u, v, std::min(2, lab.cols - u), std::min(2, lab.rows - v))).setTo(255);
    }
  // 2. Each region's pixels on it.
  const size_t nr = seg.regions.size();
  std::vector<int> on_floor(nr, 0);
  for (int y = 0; y < lab.rows; ++y) {
    const int32_t* l = lab.ptr<int32_t>(y);
    const uint8_t* f = floor_view.ptr<uint8_t>(y);
    for (int x = 0; x < lab.cols; ++x) on_floor[l[x]] += f[x] != 0;
  }
  double floor_total = 0;
  for (int n : on_floor) floor_total += n;
  if (floor_total <= 0) return {};
  // 3. The floor's colours: those that regions covering a share of its view have. The parts of
  // things on it: regions mostly on the floor's view, of none of them.
  std::vector<int> parts;
  for (size_t r = 0; r < nr; ++r) {
    const Region& reg = seg.regions[r];
    if (reg.size < p_.system.segmenter.min_size || 2 * on_floor[r] < reg.size) continue;
    double same = 0;
    int repeats = 0;
    for (size_t s = 0; s < nr; ++s)
      if (on_floor[s] > 0 && cv::norm(seg.regions[s].mean - reg.mean) <= p_.system.bg_colour) {
        same += on_floor[s];
        repeats += on_floor[s] >= p_.system.segmenter.min_size;
      }
    // The floor's colour: one that covers a share of its view (a plain floor), or that comes
    // back in many places over it (a pattern: tiles).
    if (repeats >= p_.floor_colour_repeats && same >= 0.1 * p_.floor_colour_share * floor_total) continue;
    if (same < p_.floor_colour_share * floor_total) parts.push_back(static_cast<int>(r));
  }
  if (parts.empty()) return {};
  // 4. Parts that touch are one thing: components of their pixels, joined across start_touch_px.
  cv::Mat part_mask = cv::Mat::zeros(lab.size(), CV_8U);
  {
    std::vector<char> is_part(nr, 0);
    for (int r : parts) is_part[r] = 1;
    for (int y = 0; y < lab.rows; ++y) {
      const int32_t* l = lab.ptr<int32_t>(y);
      uint8_t* m = part_mask.ptr<uint8_t>(y);
      for (int x = 0; x < lab.cols; ++x) m[x] = is_part[l[x]] ? 255 : 0;
    }
  }
  cv::Mat joined, cc, stats, centroids;
  const int g = std::max(1, p_.start_touch_px);
  cv::morphologyEx(part_mask, joined, cv::MORPH_CLOSE, cv::getStructuringElement(cv::MORPH_RECT, {2 * g + 1, 2 * g + 1}));
  const int n = cv::connectedComponentsWithStats(joined, cc, stats, centroids, 8, CV_32S);
  // 5. Each thing: standing on the floor clear of the map, tall and wide enough, of an object's size.
  cv::Mat released = cv::Mat::zeros(lab.size(), CV_8U);
  const double min_area = p_.system.min_object_area * static_cast<double>(lab.total());
  for (int i = 1; i < n; ++i) {
    if (stats.at<int>(i, cv::CC_STAT_AREA) < min_area) continue;
    const cv::Rect box(stats.at<int>(i, cv::CC_STAT_LEFT), stats.at<int>(i, cv::CC_STAT_TOP), stats.at<int>(i, cv::CC_STAT_WIDTH),
                       stats.at<int>(i, cv::CC_STAT_HEIGHT));
    Placement pl;
    if (!place(box, &pl) || pl.surface >= 0 || !clear_at(pl.x, pl.y)) continue;
    if (pl.own_height < p_.floor_min_height || pl.width < p_.start_min_width) continue;
    released.setTo(255, (cc == i) & part_mask);
  }
  if (cv::countNonZero(released) == 0) return {};
  system_.release_from_background(released);
  return released;
}

bool MserTracker::place_by_head(const cv::Rect& box, Placement* out, double stature) const {
  const auto& k = camera_.intrinsics();
  const Eigen::Vector3d c = camera_.pose().position;
  const double u = box.x + 0.5 * (box.width - 1);
  // Cut off by a side of the image as well, the box's width is only part of the object's, so
  // its shape says nothing: the aspect is not asked.
  const bool side_cut = box.x <= 0 || box.x + box.width >= k.width;
  const double tall = stature > 0 ? stature : p_.cut_person_height;
  if (!(tall > 0) || box.y <= 0 || (!side_cut && box.height < p_.cut_min_aspect * box.width)) return false;
  const Eigen::Vector3d top_dir = camera_.back_project_map(u, box.y - 0.5, 1.0) - c;
  const double dz = tall - c.z();
  if (std::abs(top_dir.z()) < 1e-9 || dz / top_dir.z() <= 0) return false;
  const Eigen::Vector3d head = c + (dz / top_dir.z()) * top_dir;
  const double dist = std::hypot(head.x() - c.x(), head.y() - c.y());
  if (!(dist > 1e-6) || dist > p_.max_range) return false;
  const double depth = (camera_.optical_from_map() * head).z();
  if (!(depth > 0)) return false;
  out->x = head.x();
  out->y = head.y();
  out->width = box.width * depth / k.fx;
  out->height = tall;
  out->own_height = tall;
  out->support = 0;
  out->surface = -1;
  out->by_head = true;
  return std::isfinite(out->x) && std::isfinite(out->y);
}

namespace {

// How far along the horizontal ray from `from` in direction `along` (unit) it leaves the
// surface's outline (0 if it never crosses it).
double far_edge(const Surface& s, const Eigen::Vector2d& from, const Eigen::Vector2d& along) {
  const double cs = std::cos(s.yaw), sn = std::sin(s.yaw);
  // The ray in the surface's frame.
  const double px = cs * (from.x() - s.x) + sn * (from.y() - s.y), py = -sn * (from.x() - s.x) + cs * (from.y() - s.y);
  const double dx = cs * along.x() + sn * along.y(), dy = -sn * along.x() + cs * along.y();
  double t0 = 0, t1 = std::numeric_limits<double>::infinity();
  auto slab = [&](double p, double d, double half) {
    if (std::abs(d) < 1e-12) return std::abs(p) <= half;
    double a = (-half - p) / d, b = (half - p) / d;
    if (a > b) std::swap(a, b);
    t0 = std::max(t0, a);
    t1 = std::min(t1, b);
    return t0 <= t1;
  };
  if (!slab(px, dx, 0.5 * s.size_x) || !slab(py, dy, 0.5 * s.size_y) || !std::isfinite(t1)) return 0;
  return t1;
}

}  // namespace

bool MserTracker::place(const cv::Rect& box, Placement* out, double stature) const {
  out->range_min = out->range_max = 0;
  const auto& k = camera_.intrinsics();
  const Eigen::Vector3d c = camera_.pose().position;
  const double u = box.x + 0.5 * (box.width - 1);
  // The feet cut off by the image's edge: a tall box with its top in view is taken for a
  // person of `cut_person_height`, the ray through the top meeting that height above the
  // footprint's centre.
  if (box.y + box.height >= k.height) {
    if (!place_by_head(box, out, stature)) return false;
    // The feet below the image: the footprint's near side is nearer than where the bottom row's
    // ray meets the floor (unless a table top is in the way), so its centre is at most half a
    // footprint beyond. A box whose top is too high (a bit of wall above the head taken in)
    // would otherwise put the person metres behind where the bottom edge allows.
    const Eigen::Vector3d bottom_dir = camera_.back_project_map(u, k.height - 0.5, 1.0) - c;
    double tb = 0;
    if (bottom_dir.z() < -1e-9 && first_surface(c, bottom_dir, 0.0, &tb) < 0) {
      const double limit = tb * std::hypot(bottom_dir.x(), bottom_dir.y()) + 0.5 * p_.max_footprint;
      const double dist = std::hypot(out->x - c.x(), out->y - c.y());
      if (dist > limit) {
        const double s = limit / dist;
        out->x = c.x() + s * (out->x - c.x());
        out->y = c.y() + s * (out->y - c.y());
        out->width *= s;
      }
    }
    return true;
  }
  const double v_bottom = box.y + box.height - 0.5;
  const Eigen::Vector3d foot_dir = camera_.back_project_map(u, v_bottom, 1.0) - c;
  if (!(foot_dir.z() < -1e-9)) return false;  // at or above the horizon
  // What the bottom stands on: the first surface (a table top) the ray meets inside its
  // outline, else the floor.
  double t = 0;
  out->surface = first_surface(c, foot_dir, p_.surface_margin, &t);
  // The bottom on a surface's far edge: the rows just below it look onto the table top, so the
  // table hides what is below (someone standing behind it, their legs out of view), and the
  // floor the bottom ray meets beyond the table is not where they stand.
  int hidden_by = -1;
  if (out->surface < 0) {
    const Eigen::Vector3d below = camera_.back_project_map(u, std::min(v_bottom + p_.edge_rows, k.height - 0.5), 1.0) - c;
    double tb = 0;
    if (below.z() < -1e-9) hidden_by = first_surface(c, below, 0.0, &tb);
  }
  const double support = out->surface >= 0 ? p_.surfaces[out->surface].height : 0.0;
  const Eigen::Vector3d foot = c + t * foot_dir;
  const Eigen::Vector2d horiz(foot.x() - c.x(), foot.y() - c.y());
  const double dist = horiz.norm();
  if (!(dist > 1e-6) || dist > p_.max_range) return false;
  // Depth along the optical axis of the foot point: scales pixels to metres.
  const double depth = (camera_.optical_from_map() * foot).z();
  if (!(depth > 0)) return false;
  const double w = box.width * depth / k.fx;
  // The visible bottom is the footprint's near side: its centre is half a footprint further.
  // The footprint is no deeper than `max_footprint` (arms or a carried bag widen the box, not
  // what stands on the floor).
  const Eigen::Vector2d along = horiz / dist;
  const Eigen::Vector2d centre = Eigen::Vector2d(foot.x(), foot.y()) + 0.5 * std::min(w, p_.max_footprint) * along;
  // The top: the ray through the box's top at the footprint's horizontal distance.
  const Eigen::Vector3d top_dir = camera_.back_project_map(u, box.y - 0.5, 1.0) - c;
  const double top_h = std::hypot(top_dir.x(), top_dir.y());
  if (!(top_h > 1e-9)) return false;
  const double far = (centre - Eigen::Vector2d(c.x(), c.y())).norm();
  const double h = c.z() + top_dir.z() * far / top_h;
  // Taller above a table top than anything lying on it, or cut off below by the table's far
  // edge with the top out of view or as high as a person's at that edge: someone standing
  // behind the table, their legs hidden by it. Placed by the head, as a person whose feet are
  // out of view.
  bool behind_surface = support > 0 && h - support > p_.classes.bag_max_height;
  if (hidden_by >= 0) {
    const double edge = far_edge(p_.surfaces[hidden_by], Eigen::Vector2d(c.x(), c.y()), along);
    const double h_edge = c.z() + top_dir.z() * edge / top_h;  // the top's height were it at the edge
    behind_surface = box.y <= 0 || h_edge >= p_.classes.person_min_height;
    if (behind_surface) out->surface = hidden_by;
  }
  if (behind_surface) {
    Placement head;
    if (place_by_head(box, &head, stature) &&
        (hidden_by < 0 || std::hypot(head.x - c.x(), head.y - c.y()) >=
                              far_edge(p_.surfaces[hidden_by], Eigen::Vector2d(c.x(), c.y()), along))) {
      *out = head;
      return true;
    }
    // The head out of view as well: they stand behind the table, not on it. The line of sight
    // through the bottom leaves the table's outline at its far edge; the footprint's near side
    // is there at the closest, so its centre is half a footprint beyond.
    const Surface& table = p_.surfaces[out->surface];
    const double exit = far_edge(table, Eigen::Vector2d(c.x(), c.y()), along);
    // Cut off by the edge, the width is measured there (the floor beyond is farther).
    const double w_at = hidden_by >= 0 && exit > 1e-6 ? w * exit / dist : w;
    const Eigen::Vector2d at = exit > dist || (hidden_by >= 0 && exit > 1e-6)
                                   ? Eigen::Vector2d(c.x(), c.y()) + (exit + 0.5 * std::min(w_at, p_.max_footprint)) * along
                                   : centre;
    out->x = at.x();
    out->y = at.y();
    out->width = w_at;
    if (exit > 1e-6) {
      // Farther than where the bottom row's ray meets the floor, the feet would show above the
      // table's edge.
      const double floor_dist = -c.z() / foot_dir.z() * std::hypot(foot_dir.x(), foot_dir.y());
      const double near = (at - Eigen::Vector2d(c.x(), c.y())).norm();
      const double far = floor_dist + 0.5 * std::min(w * floor_dist / dist, p_.max_footprint);
      if (far > near) out->range_min = near, out->range_max = far;
    }
    out->height = out->own_height = stature > 0 ? stature : p_.cut_person_height;
    out->support = 0;
    out->surface = -1;
    out->by_head = true;
    return std::isfinite(out->x) && std::isfinite(out->y);
  }
  out->x = centre.x();
  out->y = centre.y();
  out->width = w;
  out->height = std::max(support, h);
  out->own_height = std::max(0.0, h - support);
  out->support = support;
  out->by_head = false;
  return std::isfinite(out->x) && std::isfinite(out->y) && std::isfinite(out->height);
}

int MserTracker::first_surface(const Eigen::Vector3d& c, const Eigen::Vector3d& dir, double margin, double* t) const {
  int best = -1;
  *t = -c.z() / dir.z();  // the floor
  for (size_t i = 0; i < p_.surfaces.size(); ++i) {
    const Surface& s = p_.surfaces[i];
    if (!(s.height > 0) || s.height >= c.z()) continue;
    const double ts = (s.height - c.z()) / dir.z();
    if (!(ts > 0) || ts >= *t) continue;
    const Eigen::Vector3d q = c + ts * dir;
    const double cs = std::cos(s.yaw), sn = std::sin(s.yaw);
    const double lx = cs * (q.x() - s.x) + sn * (q.y() - s.y), ly = -sn * (q.x() - s.x) + cs * (q.y() - s.y);
    if (std::abs(lx) <= 0.5 * s.size_x + margin && std::abs(ly) <= 0.5 * s.size_y + margin) best = static_cast<int>(i), *t = ts;
  }
  return best;
}

int MserTracker::surface_under(double u, double v) const {
  const Eigen::Vector3d c = camera_.pose().position;
  const Eigen::Vector3d dir = camera_.back_project_map(u, v, 1.0) - c;
  if (!(dir.z() < -1e-9)) return -1;
  double t = 0;
  return first_surface(c, dir, 0.0, &t);
}

bool MserTracker::box_to_map(const cv::Rect& box, double* x, double* y, double* width, double* height) const {
  Placement pl;
  if (!place(box, &pl)) return false;
  *x = pl.x;
  *y = pl.y;
  *width = pl.width;
  *height = pl.height;
  return true;
}

void MserTracker::find_start_objects(const cv::Mat& bgr) {
  // Background regions lying on a surface, the size of something one could pick up: the
  // objects present when the model was learned (the chapter's "present at the start").
  start_objects_.clear();
  const double r3 = std::sqrt(3.0);  // a uniform patch's side is sqrt(3) times its second-moment width
  const auto model = system_.background_model();
  const cv::Rect image(0, 0, bgr.cols, bgr.rows);
  std::vector<Placement> placed(model.size());
  std::vector<cv::Rect> boxes(model.size());
  std::vector<char> ok(model.size(), 0);
  // Each surface's own colour: that of the largest learned region lying on it (the table top).
  std::vector<double> surface_area(p_.surfaces.size(), 0);
  std::vector<cv::Vec3f> surface_colour(p_.surfaces.size());
  for (size_t i = 0; i < model.size(); ++i) {
    const auto& [centroid, w2, h2, colour] = model[i];
    boxes[i] = cv::Rect(cv::Point(static_cast<int>(std::lround(centroid.x - 0.5 * r3 * w2)),
                                  static_cast<int>(std::lround(centroid.y - 0.5 * r3 * h2))),
                        cv::Point(static_cast<int>(std::lround(centroid.x + 0.5 * r3 * w2)),
                                  static_cast<int>(std::lround(centroid.y + 0.5 * r3 * h2))));
    if (!place(boxes[i], &placed[i]) || placed[i].by_head || placed[i].surface < 0) continue;
    // The region's centroid must look onto that surface's top too (a floor patch seen just past
    // the table's far edge has its bottom there, not its middle).
    if (surface_under(centroid.x, centroid.y) != placed[i].surface) continue;
    ok[i] = 1;
    if (w2 * h2 > surface_area[placed[i].surface]) {
      surface_area[placed[i].surface] = w2 * h2;
      surface_colour[placed[i].surface] = colour;
    }
  }
  // The parts: each kept region's pixels, those of its colour inside its box.
  struct Part {
    cv::Rect box;
    cv::Mat mask;  // CV_8U over box
    Placement place;
  };
  std::vector<Part> parts;
  for (size_t i = 0; i < model.size(); ++i) {
    if (!ok[i]) continue;
    const Placement& pl = placed[i];
    if (pl.width < p_.start_min_width || pl.width >= p_.classes.robot_min_width || pl.own_height > p_.classes.bag_max_height)
      continue;
    // A patch of the surface's own colour is the surface, not something lying on it.
    if (cv::norm(std::get<3>(model[i]) - surface_colour[pl.surface]) <= p_.system.bg_colour) continue;
    // Its pixels: those of this frame's region that it matches (the nearest centroid, of its
    // colour), not a colour test over its box (a grey laptop before a grey floor would take in
    // floor pixels, which someone walking behind it changes).
    const auto& [centroid, w2, h2, colour] = model[i];
    const Segmentation& seg = system_.segmentation();
    int region = -1;
    double best = 3.0 + 0.1 * (w2 + h2);
    for (size_t r = 0; r < seg.regions.size(); ++r) {
      const Region& reg = seg.regions[r];
      if (reg.size < p_.system.segmenter.min_size || cv::norm(reg.mean - colour) > p_.system.bg_colour) continue;
      const double d = cv::norm(reg.centroid - centroid);
      if (d < best) best = d, region = static_cast<int>(r);
    }
    if (region < 0) continue;
    Part part{seg.regions[region].bbox & image, {}, pl};
    if (part.box.empty()) continue;
    part.mask = seg.labels(part.box) == region;
    if (cv::countNonZero(part.mask) > 0) parts.push_back(std::move(part));
  }
  // One object's parts (a laptop's screen and keys) touch in the image, or lie close on the
  // table: joined (union-find over the parts).
  std::vector<int> root(parts.size());
  for (size_t i = 0; i < parts.size(); ++i) root[i] = static_cast<int>(i);
  auto find = [&](int a) {
    while (root[a] != a) a = root[a] = root[root[a]];
    return a;
  };
  const int g = p_.start_touch_px;
  const cv::Mat grow = cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * g + 1, 2 * g + 1));
  for (size_t i = 0; i < parts.size(); ++i)
    for (size_t j = i + 1; j < parts.size(); ++j) {
      bool join = std::hypot(parts[i].place.x - parts[j].place.x, parts[i].place.y - parts[j].place.y) < p_.start_merge;
      const cv::Rect a = cv::Rect(parts[i].box.x - g, parts[i].box.y - g, parts[i].box.width + 2 * g, parts[i].box.height + 2 * g);
      if (!join && (a & parts[j].box).area() > 0) {
        const cv::Rect u = (a | parts[j].box) & image;
        cv::Mat mi = cv::Mat::zeros(u.size(), CV_8U), mj = cv::Mat::zeros(u.size(), CV_8U);
        parts[i].mask.copyTo(mi(parts[i].box - u.tl()));
        parts[j].mask.copyTo(mj(parts[j].box - u.tl()));
        cv::dilate(mi, mi, grow);
        join = cv::countNonZero(mi & mj) > 0;
      }
      if (join) root[find(static_cast<int>(i))] = find(static_cast<int>(j));
    }
  std::map<int, std::vector<int>> groups;  // by root, in the order of their first part
  std::vector<int> order;
  for (size_t i = 0; i < parts.size(); ++i) {
    const int r = find(static_cast<int>(i));
    if (!groups.count(r)) order.push_back(r);
    groups[r].push_back(static_cast<int>(i));
  }
  for (int r : order) {
    StartObject o;
    for (int i : groups[r]) o.box = o.box.area() > 0 ? (o.box | parts[i].box) : parts[i].box;
    o.picture.box = o.box;
    o.picture.mask = cv::Mat::zeros(o.box.size(), CV_8U);
    for (int i : groups[r]) o.picture.mask(parts[i].box - o.box.tl()) |= parts[i].mask;
    o.picture.colours = bgr(o.box).clone();
    o.picture.pixels = cv::countNonZero(o.picture.mask);
    // Placed by the whole object's box (its nearest part's bottom), else by its first part.
    if (!place(o.box, &o.place) || o.place.by_head || o.place.surface < 0) o.place = parts[groups[r].front()].place;
    o.index = static_cast<int>(start_objects_.size()) + 1;
    start_objects_.push_back(std::move(o));
  }
}

std::map<int64_t, int64_t> MserTracker::hands_on_objects(const cv::Mat& bgr, std::set<int64_t>* handled) const {
  // A hand on a thing lying there: its pixels change colour (something in front of them) and
  // are foreground of an object that is not itself lying there. Someone standing behind it
  // leaves its pixels as they were.
  std::map<int64_t, int64_t> hands;  // person -> thing, by changed pixels
  std::map<int64_t, std::pair<int64_t, double>> tips;  // person -> (thing, distance), by an arm's end
  const cv::Mat& fg = system_.foreground();
  const auto objects = system_.objects();
  std::vector<std::pair<const ImageObject*, int>> arm_ends;  // someone, their arm's end's column
  auto judge = [&](const Picture& pic, int64_t self) {
    if (pic.pixels <= 0) return;
    std::vector<cv::Point> changed;
    for (int y = 0; y < pic.box.height; ++y)
      for (int x = 0; x < pic.box.width; ++x) {
        if (!pic.mask.at<uint8_t>(y, x) || !fg.at<uint8_t>(pic.box.y + y, pic.box.x + x)) continue;
        const cv::Vec3b a = bgr.at<cv::Vec3b>(pic.box.y + y, pic.box.x + x), b = pic.colours.at<cv::Vec3b>(y, x);
        const int d = std::abs(a[0] - b[0]) + std::abs(a[1] - b[1]) + std::abs(a[2] - b[2]);
        if (d > p_.hand_change) changed.emplace_back(pic.box.x + x, pic.box.y + y);
      }
    // The track id of a system object, unless it is `self` or a bag (what lies there).
    auto hand_owner = [&](const ImageObject& o) -> int64_t {
      const int64_t sys_id = o.id + id_offset_;
      const auto al = alias_.find(sys_id);
      const int64_t id = al != alias_.end() ? al->second : sys_id;
      if (id == self) return -1;
      if (const auto h = history_.find(id); h != history_.end() && h->second.cls == TrackClass::kBag) return -1;
      return id;
    };
    if (static_cast<int>(changed.size()) >= std::max<double>(p_.hand_min_pixels, p_.hand_min_share * pic.pixels)) {
      handled->insert(self);
      // Whose: the object whose box holds most of the changed pixels.
      int64_t best = -1;
      size_t best_n = 0;
      for (const ImageObject& o : objects) {
        const int64_t id = hand_owner(o);
        if (id < 0) continue;
        size_t n = 0;
        for (const cv::Point& pt : changed) n += o.box.contains(pt);
        if (n > best_n) best_n = n, best = id;
      }
      if (best >= 0 && !hands.count(best)) hands[best] = self;
    }
    // An arm held out to it (the hand beside or above a thing too small to cover much of): the
    // end of someone's reach, beyond their upright body, with their foreground there within the
    // thing's box grown by hand_reach_margin of its height. What the arm's end is nearest is what they handle, not
    // what the arm passes in front of on its way.
    const int m = std::max(2, static_cast<int>(std::lround(p_.hand_reach_margin * pic.box.height)));
    for (const auto& [o, tip_x] : arm_ends) {
      const int dx = std::max({pic.box.x - tip_x, 0, tip_x - (pic.box.br().x - 1)});
      if (dx > m) continue;
      int dy = m + 1;  // the arm's end's foreground nearest the thing
      for (int y = o->box.y; y < o->box.br().y; ++y)
        if (fg.at<uint8_t>(y, tip_x)) dy = std::min(dy, std::max({pic.box.y - y, 0, y - (pic.box.br().y - 1)}));
      if (dy > m) continue;
      const int64_t id = hand_owner(*o);
      if (id < 0) continue;
      handled->insert(self);
      const double d = std::hypot(dx, dy);
      if (const auto t = tips.find(id); t == tips.end() || d < t->second.second) tips[id] = {self, d};
    }
  };
  // Each arm's end: the column where someone's box (their whole component) goes furthest
  // sideways beyond their upright body (thin columns, ImageObject::body).
  if (p_.hand_reach_margin >= 0)
    for (const ImageObject& o : objects) {
      if (o.box == o.body || (o.box & o.body) != o.body) continue;
      const int left = o.body.x - o.box.x, right = o.box.br().x - o.body.br().x;
      if (left > 0 || right > 0) arm_ends.push_back({&o, left >= right ? o.box.x : o.box.br().x - 1});
    }
  for (const StartObject& so : start_objects_) judge(so.picture, kStartIds + so.index);
  // Things put down during the run: still bags (on a table or the floor) seen as they lay.
  for (const auto& [id, h] : history_)
    if (h.cls == TrackClass::kBag) judge(h.picture, id);
  for (const auto& [who, what] : tips) hands[who] = what.first;
  return hands;
}

Result<std::vector<Track>> MserTracker::process(const StereoFrame& frame) {
  const auto& k = camera_.intrinsics();
  const std::string at = "frame " + std::to_string(frame.index);
  if (frame.left.empty()) return bad_input("", 0, "frame", at + " has no image");
  if (frame.left.type() != CV_8UC3) return bad_input("", 0, "frame", at + " is not an 8-bit colour image");
  if (frame.left.cols != k.width || frame.left.rows != k.height)
    return bad_input("", 0, "frame",
                     at + " is " + std::to_string(frame.left.cols) + "x" + std::to_string(frame.left.rows) +
                         " but the camera is " + std::to_string(k.width) + "x" + std::to_string(k.height));
  if (last_stamp_ != INT64_MIN && frame.stamp_ns <= last_stamp_)
    return bad_input("", 0, "frame", at + ": its stamp is not after the previous frame's");
  std::string error;
  if (!system_.process(frame.left, &error)) return bad_input("", 0, "frame", at + ": " + error);
  last_stamp_ = frame.stamp_ns;
  // The objects present at the start, found once the background is learned.
  if (!system_.learning() && !start_found_) {
    find_start_objects(frame.left);
    floor_start_ = find_floor_start_objects();
    start_found_ = true;
  }
  std::set<int64_t> handled;  // things a hand is seen on this frame
  const std::map<int64_t, int64_t> hands = hands_on_objects(frame.left, &handled);

  std::vector<Track> out;
  auto report = [&](int64_t id, TrackClass cls, double x, double y, double w, double h, double confidence, bool measured) {
    Track t;
    t.stamp_ns = frame.stamp_ns;
    t.camera = p_.camera;
    t.id = static_cast<int>(id);
    t.cls = cls;
    t.x = x;
    t.y = y;
    t.width = w;
    t.height = h;
    t.confidence = confidence;
    t.measured = measured;
    out.push_back(std::move(t));
    return &out.back();
  };
  std::map<int64_t, History> next;
  // Whether two boxes overlap once one is grown by split_gap_px.
  auto overlaps = [&](const cv::Rect& a, const cv::Rect& b) {
    const int g = p_.split_gap_px;
    return (cv::Rect(a.x - g, a.y - g, a.width + 2 * g, a.height + 2 * g) & b).area() > 0;
  };
  // The person track last seen nearest (x, y), within merge_reach plus max_speed times how long
  // ago, at most `max_unseen` s ago, and not one of `excluded`; -1 if none.
  auto nearest_person = [&](double x, double y, double max_unseen, const std::set<int64_t>& excluded) {
    int64_t who = -1;
    double best_d = p_.merge_reach;
    for (const auto& [pid, ph] : history_) {
      if (ph.cls != TrackClass::kPerson || excluded.count(pid)) continue;
      const double unseen = (frame.stamp_ns - ph.stamp_ns) * 1e-9;
      if (unseen > max_unseen) continue;
      const double d = std::hypot(ph.x - x, ph.y - y);
      if (d < best_d + p_.max_speed * unseen) best_d = d, who = pid;
    }
    return who;
  };
  // The tracks this frame's objects continue as things stand (before any new alias).
  std::set<int64_t> claimed;
  for (const ImageObject& o : system_.objects()) {
    const int64_t sid = o.id + id_offset_;
    const auto al = alias_.find(sid);
    claimed.insert(al != alias_.end() ? al->second : sid);
  }
  const double object_px = p_.system.min_object_area * static_cast<double>(frame.left.total());
  for (const ImageObject& o : system_.objects()) {
    Placement pl;
    if (!place(o.box, &pl)) continue;
    if (o.area < object_px && pl.support <= 0) continue;  // small, and not lying on a surface
    const int64_t sys_id = o.id + id_offset_;
    // Behind a table with neither head nor feet in view, the image gives the line of sight and
    // a span of distances along it: a person track is placed where it is predicted to be (the
    // last place it was seen at moved on by its velocity then, for at most velocity_window),
    // brought into that span (someone walking up to the table keeps walking a moment; someone
    // standing at it stays).
    if (pl.range_max > pl.range_min) {
      const auto al0 = alias_.find(sys_id);
      const auto prior = history_.find(al0 != alias_.end() ? al0->second : sys_id);
      if (prior != history_.end() && prior->second.cls == TrackClass::kPerson && prior->second.seen.stamp_ns > 0) {
        const History& ph = prior->second;
        const double dt = std::min((frame.stamp_ns - ph.seen.stamp_ns) * 1e-9, p_.velocity_window);
        const Eigen::Vector3d c = camera_.pose().position;
        const Eigen::Vector2d cam(c.x(), c.y()), along = (Eigen::Vector2d(pl.x, pl.y) - cam).normalized();
        const double r = std::clamp((Eigen::Vector2d(ph.seen.x + ph.seen_vx * dt, ph.seen.y + ph.seen_vy * dt) - cam).dot(along), pl.range_min, pl.range_max);
            pl.width *= r / pl.range_min;
        pl.x = cam.x() + r * along.x();
        pl.y = cam.y() + r * along.y();
      }
    }
    double x = pl.x, y = pl.y, w = pl.width, h = pl.height;
    max_id_ = std::max(max_id_, sys_id);
    // A new object where a bag lies (held, or still seen: the bag's image split in two) is that
    // bag: near its place and overlapping its last box in the image (a second thing put down
    // beside it, apart in the image, is a thing of its own).
    if (!history_.count(sys_id) && !alias_.count(sys_id)) {
      for (const auto& [hid, hh] : history_) {
        if (hh.cls != TrackClass::kBag || hh.frames < p_.hold_min_frames) continue;
        if ((frame.stamp_ns - hh.stamp_ns) * 1e-9 <= p_.hold_time && std::hypot(hh.x - x, hh.y - y) <= p_.hold_match &&
            overlaps(hh.box, o.box)) {
          alias_[sys_id] = hid;
          break;
        }
      }
    }
    // A new object where a person was lost a moment ago (their blob changed so much the system
    // began another: a bag taken from it, a merge undone) continues them.
    if (!history_.count(sys_id) && !alias_.count(sys_id)) {
      const int64_t who = nearest_person(x, y, p_.resume_time, claimed);
      if (who >= 0) {
        alias_[sys_id] = who;
        claimed.insert(who);
      }
    }
    auto al = alias_.find(sys_id);
    // The alias lasts while the object stays at the bag's place (not a walker who stood by it).
    if (al != alias_.end()) {
      const auto h = history_.find(al->second);
      if (h == history_.end() || std::hypot(h->second.x - x, h->second.y - y) > p_.hold_match) {
        alias_.erase(al);
        al = alias_.end();
      }
    }
    int64_t id = al != alias_.end() ? al->second : sys_id;
    // A still bag whose object grows person-sized: someone reached it and their blobs merged
    // (the system kept the bag's object). The bag is held where it lay (not measured: covered);
    // the merged object is that someone, the person track last seen nearby, else a new track.
    if (const auto b = history_.find(id); b != history_.end() && b->second.cls == TrackClass::kBag &&
                                          b->second.frames >= p_.hold_min_frames &&
                                          std::hypot(b->second.vx, b->second.vy) <= p_.hold_speed &&
                                          (pl.by_head || h >= p_.classes.person_min_height)) {
      std::set<int64_t> reported;
      for (const auto& [nid, nh] : next) reported.insert(nid);
      const int64_t who = nearest_person(x, y, p_.hold_time, reported);
      id = who >= 0 ? who : kMergedIds + ++merged_ids_;
      alias_[sys_id] = id;
    }
    // A person-sized box whose bottom is a still bag's (someone behind the bag, reaching over it,
    // their blobs merged): they stand where their head puts them, if that is beyond the bag.
    if (!pl.by_head && h >= p_.classes.person_min_height) {
      const Eigen::Vector3d c = camera_.pose().position;
      for (const auto& [bid, bh] : history_) {
        if (bh.cls != TrackClass::kBag || bh.frames < p_.hold_min_frames || std::hypot(bh.vx, bh.vy) > p_.hold_speed) continue;
        const cv::Rect& bb = bh.box;
        if (std::abs(o.box.br().y - bb.br().y) > std::max(2, bb.height / 8) || bb.x < o.box.x - 2 || bb.br().x > o.box.br().x + 2) continue;
        Placement head;
        const auto me = history_.find(id);
        if (place_by_head(o.box, &head, me != history_.end() ? me->second.stature : -1) && std::hypot(head.x - c.x(), head.y - c.y()) > std::hypot(bh.x - c.x(), bh.y - c.y())) {
          pl = head;
          x = pl.x, y = pl.y, w = pl.width, h = pl.height;
        }
        break;
      }
    }
    if (next.count(id)) continue;  // two objects claiming one held bag: the first keeps it
    History hist;
    if (auto it = history_.find(id); it != history_.end()) hist = it->second;
    // Placed by the head: by the person's own height once measured (at 7 m, 5 cm of height is
    // 0.4 m of distance).
    if (pl.by_head && hist.stature > 0 && std::abs(pl.height - hist.stature) > 1e-9) {
      Placement again;
      if (place(o.box, &again, hist.stature) && again.by_head) {
        pl = again;
        x = pl.x, y = pl.y, w = pl.width, h = pl.height;
      }
    }
    const bool top_cut = o.box.y <= 0 && !pl.by_head;  // its top out of view: its height a lower bound
    // Velocity: the footprint's displacement over the last `velocity_window` seconds (a pixel
    // of the foot row is several centimetres, so frame-to-frame differences are mostly noise).
    // A person's jump no one walks (the box's bottom now another part of the blob: a table's
    // edge, a thing merged in) restarts the velocity rather than reading the jump as motion. (A
    // bag's jump keeps it: its blob merged with someone's, and it is not lying still there.)
    // Whether (x, y) is a walk from a fix (at most max_speed, plus jump_slack).
    auto walkable_from = [&](const Fix& f) {
      return std::hypot(x - f.x, y - f.y) <= p_.max_speed * (frame.stamp_ns - f.stamp_ns) * 1e-9 + p_.jump_slack;
    };
    const bool jumped = !hist.trail.empty() && hist.cls != TrackClass::kBag && !walkable_from(hist.trail.back());
    if (jumped) hist.trail.clear();
    hist.trail.push_back({frame.stamp_ns, x, y});
    while (hist.trail.size() > 2 && (frame.stamp_ns - hist.trail[1].stamp_ns) * 1e-9 >= p_.velocity_window)
      hist.trail.pop_front();
    {
      const auto& first = hist.trail.front();
      const double span = (frame.stamp_ns - first.stamp_ns) * 1e-9;
      hist.vx = span > 0 ? (x - first.x) / span : 0.0;
      hist.vy = span > 0 ? (y - first.y) / span : 0.0;
    }
    for (auto& [c, v] : hist.votes) v *= p_.class_vote_decay;
    hist.cut_votes *= p_.class_vote_decay;
    // Classed by its own height: a book on a table is as low as a bag on the floor. A box cut
    // off by the image's top edge (not placed by a head) gives only a lower bound of the
    // height: a person's if it reaches one; taller than a bag, only that it is a robot or
    // someone cut off at the waist (History::cut_votes); else no vote (a walker whose head is
    // out of view is not short).
    if (o.box.y > 0 || pl.by_head)
      hist.votes[pl.support > 0 ? classify_track(std::max(p_.classes.bag_min_height, pl.own_height), w, p_.classes)
                                : classify_track(h, w, p_.classes)] += 1.0;
    else if (pl.own_height >= p_.classes.person_min_height)
      hist.votes[TrackClass::kPerson] += 1.0;
    else if (pl.own_height >= p_.classes.bag_max_height)
      hist.cut_votes += 1.0;
    // A still bag seen on its own, no hand on it, its box not grown (merged with someone):
    // how it looks now is what a hand on it will be judged against.
    const double speed = std::hypot(hist.vx, hist.vy);
    if (hist.cls == TrackClass::kBag && speed <= p_.hold_speed && hist.frames + 1 >= p_.hold_min_frames &&
        !handled.count(id) && (hist.picture.pixels == 0 || o.box.area() <= 1.5 * hist.picture.box.area())) {
      const cv::Rect b = o.box & cv::Rect(0, 0, frame.left.cols, frame.left.rows);
      hist.picture.box = b;
      hist.picture.mask = system_.foreground()(b).clone();
      hist.picture.colours = frame.left(b).clone();
      hist.picture.pixels = cv::countNonZero(hist.picture.mask);
    } else if (hist.cls != TrackClass::kBag || speed > p_.hold_speed) {
      hist.picture = Picture{};  // carried or moving: no longer lying where it was seen
    }
    // A person's height, from frames with the feet on the floor and the head in view.
    if (!pl.by_head && pl.support == 0 && o.box.y > 0 && hist.cls == TrackClass::kPerson &&
        h >= p_.classes.person_min_height && h <= p_.classes.person_max_height)
    {
      // The median of the last measurements (an arm raised or a carried bag lifts a few).
      hist.statures.push_back(h);
      if (hist.statures.size() > 31) hist.statures.pop_front();
      std::vector<double> v(hist.statures.begin(), hist.statures.end());
      std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
      hist.stature = v[v.size() / 2];
    }
    // (Not a jump no one walks from there: the box's bottom another part of the blob for a
    // frame or a few.)
    // Nor one no one walks from the place predicted in a span since (someone standing behind the
    // table for seconds: a wrong fix two frames running is walkable from where she was last seen
    // whole, long ago, but not from where she stands).
    const bool spanned = pl.range_max > pl.range_min;
    if (!spanned && !jumped && (hist.seen.stamp_ns == 0 || walkable_from(hist.seen)) &&
        (hist.spanned.stamp_ns <= hist.seen.stamp_ns || walkable_from(hist.spanned)))
      hist.seen = {frame.stamp_ns, x, y}, hist.seen_vx = hist.vx, hist.seen_vy = hist.vy;
    if (spanned) hist.spanned = {frame.stamp_ns, x, y};
    hist.stamp_ns = frame.stamp_ns;
    hist.x = x;
    hist.y = y;
    hist.width = w;
    hist.height = h;
    hist.box = o.box;
    hist.legs_in_view = !pl.by_head && pl.support == 0 && o.box.br().y < frame.left.rows;
    hist.upper_in_view = o.box.y > 0 || pl.by_head;
    ++hist.frames;
    TrackClass cls = TrackClass::kUnknown;
    double best = -1;
    for (const auto& [c, v] : hist.votes)  // std::map: ties go to the first class in order
      if (v > best) best = v, cls = c;
    // Nothing measured whole of late (less than a frame's vote left), but cut boxes taller than
    // a bag: a robot by its height, reported cut, for whoever knows where the robots say they
    // are to tell (the vision sensor host: a person unless a robot reports itself there).
    bool cut_class = false;
    if (best < 1.0 && hist.cut_votes > std::max(best, 0.0)) cls = TrackClass::kRobot, cut_class = true;
    hist.cls = cls;
    next[id] = hist;
    Track* t = report(id, cls, x, y, w, h, std::min(1.0, 0.5 + 0.05 * o.age), true);
    t->vx = hist.vx;
    t->vy = hist.vy;
    t->top_cut = top_cut || cut_class;
    if (const auto hand = hands.find(id); hand != hands.end() && cls != TrackClass::kBag) t->hand_on = static_cast<int>(hand->second);
  }
  // Objects unseen this frame keep their history for a while; a still bag is held where it
  // was (not measured: a walker in front hides it, or its blob merged with theirs).
  for (auto& [id, hist] : history_) {
    if (next.count(id)) continue;
    const double unseen = (frame.stamp_ns - hist.stamp_ns) * 1e-9;
    if (unseen >= std::max(2.0, p_.hold_time)) continue;
    next[id] = hist;
    if (hist.cls != TrackClass::kBag || hist.frames < p_.hold_min_frames || unseen > p_.hold_time ||
        std::hypot(hist.vx, hist.vy) > p_.hold_speed)
      continue;
    // Held only while something in the image covers where it was: a clear view of an empty
    // place means it has gone.
    bool covered = false;
    for (const ImageObject& o : system_.objects()) covered = covered || (o.box & hist.box).area() > 0;
    // With a picture of it lying there: its pixels still foreground (itself, or someone in
    // front); once they are background again the floor shows where it lay, and it has gone.
    if (covered && hist.picture.pixels > 0) {
      const cv::Mat fg = system_.foreground()(hist.picture.box);
      covered = 2 * cv::countNonZero(fg & hist.picture.mask) >= hist.picture.pixels;
    }
    if (!covered) continue;
    bool taken_over = false;  // a bag reported at its place now, over its box, is it, or hides it
    for (const Track& o : out)
      taken_over = taken_over || (o.cls == TrackClass::kBag && std::hypot(o.x - hist.x, o.y - hist.y) <= p_.hold_match &&
                                  next.count(o.id) && overlaps(next.at(o.id).box, hist.box));
    if (taken_over) continue;
    report(id, hist.cls, hist.x, hist.y, hist.width, hist.height, 0.3, false);
  }
  // The objects present at the start, reported as lying where they were (a still bag each:
  // the rules judge who handles them).
  for (const StartObject& o : start_objects_)
    report(kStartIds + o.index, TrackClass::kBag, o.place.x, o.place.y, o.place.width, o.place.height, 0.5, true);
  reidentify(frame.stamp_ns, frame.left, next, &out);
  std::sort(out.begin(), out.end(), [](const Track& a, const Track& b) { return a.id < b.id; });
  history_.swap(next);
  return out;
}

void MserTracker::reidentify(int64_t stamp_ns, const cv::Mat& bgr, const std::map<int64_t, History>& next, std::vector<Track>* out) {
  if (!p_.reid.enabled) return;
  const cv::Mat& fg = system_.foreground();
  // Measured people and their boxes this frame.
  std::vector<std::pair<size_t, cv::Rect>> people;
  for (size_t i = 0; i < out->size(); ++i) {
    const Track& t = (*out)[i];
    if (t.cls != TrackClass::kPerson || !t.measured) continue;
    const auto h = next.find(t.id);
    if (h != next.end() && h->second.stamp_ns == stamp_ns && (h->second.legs_in_view || h->second.upper_in_view))
      people.emplace_back(i, h->second.box);
  }
  std::map<int, Appearance> seen;
  if (!fg.empty() && fg.type() == CV_8UC1 && bgr.size() == fg.size())
    for (const auto& [i, box] : people) {
      bool alone = true;
      for (const auto& [j, other] : people) alone = alone && (j == i || (box & other).area() * 5 < box.area());
      if (!alone) continue;
      const Track& t = (*out)[i];
      Appearance a = measure_appearance_mono(bgr, fg, box, camera_, t.x, t.y, t.height, p_.reid);
      // Legs behind a table, or a head out of view: that band is something else.
      const History& hh = next.at(t.id);
      if (!hh.legs_in_view) a.weight[1] = 0;
      if (!hh.upper_in_view) a.weight[0] = 0;
      if (!a.empty()) seen.emplace(t.id, a);
    }
  std::vector<int> before(out->size());
  for (size_t i = 0; i < out->size(); ++i) before[i] = (*out)[i].id;
  reid_.apply(stamp_ns, out, seen);
  // A hand on a thing names the thing's identity too.
  std::map<int, int> renamed;
  for (size_t i = 0; i < out->size(); ++i)
    if ((*out)[i].id != before[i]) renamed[before[i]] = (*out)[i].id;
  if (!renamed.empty())
    for (Track& t : *out)
      if (const auto r = renamed.find(t.hand_on); t.hand_on > 0 && r != renamed.end()) t.hand_on = r->second;
}

cv::Mat MserTracker::annotate(const StereoFrame& frame, const std::vector<Track>& tracks) const {
  cv::Mat view = frame.left.empty() ? cv::Mat(camera_.intrinsics().height, camera_.intrinsics().width, CV_8UC3, cv::Scalar::all(0))
                                    : frame.left.clone();
  draw_tracks_on_view(&view, camera_, tracks);
  cv::Mat seg = system_.frames() > 0 ? system_.annotate(frame.left) : cv::Mat::zeros(view.size(), CV_8UC3);
  if (seg.size() != view.size()) return view;
  cv::Mat both;
  cv::hconcat(view, seg, both);
  return both;
}

}  // namespace vigil::vision::mser
