#include "vision/planview_system.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include <opencv2/imgproc.hpp>

namespace vigil::vision {

Status DepthEdgeFilterParams::validate() const {
  if (edge_radius < 0 || edge_radius > 50) return bad_input("", 0, "edge_radius", "must be 0 to 50 px");
  if (!(edge_tolerance_px >= 0) || !std::isfinite(edge_tolerance_px))
    return bad_input("", 0, "edge_tolerance_px", "must be >= 0");
  if (!(edge_tolerance_m >= 0) || !std::isfinite(edge_tolerance_m)) return bad_input("", 0, "edge_tolerance_m", "must be >= 0");
  return Status::Ok();
}

Status DepthRegionParams::validate() const {
  if (full_every < 0) return bad_input("", 0, "full_every", "must be >= 0 frames");
  if (full_first < 1) return bad_input("", 0, "full_first", "must be >= 1 frame (the background needs depth)");
  return Status::Ok();
}

Status StartObjectParams::validate() const {
  if (!(wall_margin >= 0) || !std::isfinite(wall_margin)) return bad_input("", 0, "wall_margin", "must be >= 0 m");
  return Status::Ok();
}

Result<PlanViewSystem> PlanViewSystem::create(const StereoCameraModel& camera, const PlanViewSystemParams& params) {
  if (Status s = params.depth_filter.validate(); !s) return s.error();
  if (Status s = params.depth_region.validate(); !s) return s.error();
  if (Status s = params.start.validate(); !s) return s.error();
  if (Status s = params.reid.validate(); !s) return s.error();
  auto bg = YuvdBackground::create(params.background);
  if (!bg) return bg.error();
  auto pipeline = PlanViewPipeline::create(camera, params.plan, params.tracking);
  if (!pipeline) return pipeline.error();
  return PlanViewSystem(camera, std::move(*bg), std::move(*pipeline), params.depth_filter, params.depth_region,
                        params.start, params.reid);
}

Result<std::vector<Track>> PlanViewSystem::process(const StereoFrame& frame) {
  const auto& k = camera_.intrinsics();
  if (frame.left.empty()) return bad_input("", 0, "frame", "frame " + std::to_string(frame.index) + " has no image");
  if (frame.left.cols != k.width || frame.left.rows != k.height) {
    return bad_input("", 0, "frame",
                     "frame " + std::to_string(frame.index) + " is " + std::to_string(frame.left.cols) + "x" +
                         std::to_string(frame.left.rows) + " but the camera is " + std::to_string(k.width) + "x" +
                         std::to_string(k.height));
  }
  if (frame.depth.empty())
    return bad_input("", 0, "frame",
                     "frame " + std::to_string(frame.index) +
                         " has no depth: the plan-view system needs a stereo source with disparity (disparity=sgbm)");
  if (!frame.depth_measured.empty() && frame.depth_measured.size() != frame.depth.size())
    return bad_input("", 0, "frame", "frame " + std::to_string(frame.index) + ": depth_measured is not the depth's size");
  const bool first = background_.frames() == 0;
  cv::Mat floor_depth;
  if (first) {
    start_mask_.release();
    if (start_.enabled && !clearance_.empty() && frame.depth_measured.empty())
      if (Status s = find_start_objects(frame.depth, &floor_depth); !s) return s.error();
  }
  if (Status s = background_.apply(frame.left, frame.depth, frame.depth_measured, foreground_); !s) return s.error();
  if (first && !start_mask_.empty())
    if (Status s = background_.set_background_depth(start_mask_, floor_depth); !s) return s.error();
  const bool filter = filter_.edge_radius > 0 && frame.depth.type() == CV_32F && frame.depth.size() == foreground_.size();
  if (filter) filter_depth_edges(frame.depth);
  const cv::Mat& mask = filter ? plan_mask_ : foreground_;
  auto tracks = pipeline_.process(mask, frame.depth, frame.stamp_ns);
  if (!tracks) return tracks;
  reidentify(frame, mask, &*tracks);
  return tracks;
}

void PlanViewSystem::reidentify(const StereoFrame& frame, const cv::Mat& mask, std::vector<Track>* tracks) {
  if (!reid_params_.enabled) return;
  std::map<int, Appearance> seen;
  if (frame.left.type() == CV_8UC3 && frame.depth.type() == CV_32F) {
    std::vector<cv::Rect> boxes(tracks->size());
    for (size_t i = 0; i < tracks->size(); ++i)
      if ((*tracks)[i].cls == TrackClass::kPerson) boxes[i] = track_image_box(camera_, (*tracks)[i], frame.left.size());
    for (size_t i = 0; i < tracks->size(); ++i) {
      const Track& t = (*tracks)[i];
      if (t.cls != TrackClass::kPerson || !t.measured || boxes[i].empty()) continue;
      // Alone in the image: no other person's box covers a fifth of hers (her colours would mix).
      bool alone = true;
      for (size_t j = 0; j < tracks->size() && alone; ++j)
        alone = j == i || (boxes[i] & boxes[j]).area() * 5 < boxes[i].area();
      if (!alone) continue;
      Appearance a = measure_appearance(frame.left, mask, frame.depth, camera_, t, reid_params_);
      if (!a.empty()) seen.emplace(t.id, a);
    }
  }
  reid_.apply(frame.stamp_ns, tracks, seen);
}

cv::Mat PlanViewSystem::depth_wanted(const StereoFrame& frame) {
  if (!region_.foreground_only) return {};
  const int64_t learnt = background_.frames();
  if (learnt < region_.full_first) return {};
  if (region_.full_every > 0 && (learnt - region_.full_first) % region_.full_every == region_.full_every - 1) return {};
  if (!background_.colour_changes(frame.left, changed_)) return {};  // process() reports the bad frame
  // Objects present at the start keep the colour the model learnt: their depth is what tells them.
  if (!start_mask_.empty() && start_mask_.size() == changed_.size()) cv::bitwise_or(changed_, start_mask_, changed_);
  return changed_;
}

void PlanViewSystem::set_static_map(const OccupancyGrid& map) {
  static_map_ = map;
  clearance_ = map_clearance(map);
}

Status PlanViewSystem::find_start_objects(const cv::Mat& depth, cv::Mat* floor_depth) {
  if (depth.type() != CV_32F) return Status::Ok();  // process() reports the bad frame
  const PlanViewParams& pp = pipeline_.builder().params();
  const PlanViewGrid& grid = pipeline_.builder().grid();
  const PlanViewTrackerParams& tp = pipeline_.tracker().params();
  const Eigen::Vector3d centre = camera_.map_from_optical().translation();
  // 1. Points standing above the floor in free space, clear of the map's walls and furniture.
  cv::Mat candidates = cv::Mat::zeros(depth.size(), CV_8U);
  struct Pixel {
    int u, v, col, row;
  };
  std::vector<Pixel> pixels;
  for (int v = 0; v < depth.rows; ++v) {
    const float* d = depth.ptr<float>(v);
    for (int u = 0; u < depth.cols; ++u) {
      if (!(d[u] > 0 && d[u] < std::numeric_limits<float>::infinity())) continue;
      const Eigen::Vector3d p = camera_.back_project_map(u, v, d[u]);
      const double h = p.z() - pp.floor_z;
      if (h < pp.min_height || h > pp.max_height) continue;
      int cx = 0, cy = 0;
      if (!static_map_.world_to_cell(Vec2{p.x(), p.y()}, &cx, &cy)) continue;
      if (clearance_.at<float>(cy, cx) < start_.wall_margin) continue;
      const Eigen::Vector2d c = grid.to_cell(p.x(), p.y());
      const int col = static_cast<int>(std::lround(c.x())), row = static_cast<int>(std::lround(c.y()));
      if (col < 0 || row < 0 || col >= grid.cols || row >= grid.rows) continue;
      candidates.at<uint8_t>(v, u) = 255;
      pixels.push_back({u, v, col, row});
    }
  }
  if (pixels.empty()) return Status::Ok();
  // 2. Their plan view; the blobs a track could be born from.
  PlanView view;
  if (Status s = pipeline_.builder().build(candidates, depth, &view); !s) return s;
  cv::Mat labels;
  const int n = cv::connectedComponents(view.mask, labels, 8, CV_32S);
  std::vector<double> area(n, 0.0), top(n, 0.0);
  for (int r = 0; r < labels.rows; ++r) {
    const int* l = labels.ptr<int>(r);
    const float* o = view.occupancy.ptr<float>(r);
    const float* h = view.height_masked.ptr<float>(r);
    for (int c = 0; c < labels.cols; ++c) {
      if (!l[c]) continue;
      area[l[c]] += o[c] * grid.cell * grid.cell;
      top[l[c]] = std::max(top[l[c]], static_cast<double>(h[c]));
    }
  }
  std::vector<bool> keep(n, false);
  bool any = false;
  for (int k = 1; k < n; ++k) {
    keep[k] = area[k] >= tp.birth_min_area && top[k] >= tp.birth_min_height;
    any = any || keep[k];
  }
  if (!any) return Status::Ok();
  // 3. Their pixels, with the depth of what the map says is behind them as the background's:
  //    along each pixel's ray beyond the object, the first wall or piece of furniture the ray's
  //    foot crosses, else the floor. (Furniture is taken as reaching the ray: a nearer
  //    background than the true one is relearnt once the object leaves, a farther one would
  //    stay foreground.)
  start_mask_ = cv::Mat::zeros(depth.size(), CV_8U);
  *floor_depth = cv::Mat::zeros(depth.size(), CV_32F);
  const double step = 0.5 * static_map_.resolution();
  for (const Pixel& px : pixels) {
    if (!keep[labels.at<int>(px.row, px.col)]) continue;
    const Eigen::Vector3d q = camera_.back_project_map(px.u, px.v, 1.0);  // the ray's point at depth 1
    const double drop = centre.z() - q.z();
    if (drop <= 1e-6) continue;
    const double d0 = depth.at<float>(px.v, px.u);
    double behind = (centre.z() - pp.floor_z) / drop;  // the floor
    if (!(behind > d0)) continue;
    const double horizontal = std::hypot(q.x() - centre.x(), q.y() - centre.y());  // m per metre of depth
    if (horizontal > 1e-9) {
      const double dd = step / horizontal;
      for (double d = d0 + dd; d < behind; d += dd) {
        int cx = 0, cy = 0;
        const double x = centre.x() + (q.x() - centre.x()) * d, y = centre.y() + (q.y() - centre.y()) * d;
        if (!static_map_.world_to_cell(Vec2{x, y}, &cx, &cy) || static_map_.at(cx, cy) != Cell::kFree) {
          behind = d;
          break;
        }
      }
    }
    if (!(behind > d0)) continue;
    start_mask_.at<uint8_t>(px.v, px.u) = 255;
    floor_depth->at<float>(px.v, px.u) = static_cast<float>(behind);
  }
  return Status::Ok();
}

void PlanViewSystem::reset() {
  background_.reset();
  reid_.reset();
  start_mask_.release();
  pipeline_.reset();
  foreground_.release();
  plan_mask_.release();
}

void PlanViewSystem::filter_depth_edges(const cv::Mat& depth) {
  constexpr float kNone = 1e9f;
  // Nearest valid depth in the window: invalid depths (<= 0, NaN, inf) count as none.
  near_depth_.create(depth.size(), CV_32F);
  for (int r = 0; r < depth.rows; ++r) {
    const float* d = depth.ptr<float>(r);
    float* o = near_depth_.ptr<float>(r);
    for (int c = 0; c < depth.cols; ++c) o[c] = d[c] > 0 && d[c] < kNone ? d[c] : kNone;
  }
  const int k = 2 * filter_.edge_radius + 1;
  cv::erode(near_depth_, near_depth_, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(k, k)));
  const float inv_fb = static_cast<float>(filter_.edge_tolerance_px / (camera_.intrinsics().fx * camera_.baseline()));
  const float tol_m = static_cast<float>(filter_.edge_tolerance_m);
  foreground_.copyTo(plan_mask_);
  for (int r = 0; r < depth.rows; ++r) {
    const float* d = depth.ptr<float>(r);
    const float* n = near_depth_.ptr<float>(r);
    uint8_t* m = plan_mask_.ptr<uint8_t>(r);
    for (int c = 0; c < depth.cols; ++c) {
      if (!m[c] || !(d[c] > 0 && d[c] < kNone)) continue;
      if (d[c] - n[c] > tol_m + inv_fb * d[c] * d[c]) m[c] = 0;
    }
  }
}

void draw_tracks_on_view(cv::Mat* bgr, const StereoCameraModel& camera, const std::vector<Track>& tracks) {
  for (const Track& t : tracks) {
    // The cylinder's bounding box in the image: project points around its base and top.
    double u0 = 1e9, v0 = 1e9, u1 = -1e9, v1 = -1e9;
    int seen = 0;
    const double r = std::max(0.1, 0.5 * t.width);
    for (int i = 0; i < 8; ++i) {
      const double a = i * M_PI / 4;
      for (double z : {0.0, std::max(0.1, t.height)}) {
        Eigen::Vector2d px;
        if (!camera.project_map(Eigen::Vector3d(t.x + r * std::cos(a), t.y + r * std::sin(a), z), &px)) continue;
        u0 = std::min(u0, px.x());
        v0 = std::min(v0, px.y());
        u1 = std::max(u1, px.x());
        v1 = std::max(v1, px.y());
        ++seen;
      }
    }
    if (seen == 0) continue;
    const cv::Scalar colour = t.cls == TrackClass::kPerson ? cv::Scalar(0, 220, 0)
                              : t.cls == TrackClass::kBag  ? cv::Scalar(0, 160, 255)
                              : t.cls == TrackClass::kRobot ? cv::Scalar(255, 160, 0)
                                                            : cv::Scalar(200, 200, 200);
    const cv::Rect box(cv::Point(static_cast<int>(std::lround(std::max(-1e4, u0))), static_cast<int>(std::lround(std::max(-1e4, v0)))),
                       cv::Point(static_cast<int>(std::lround(std::min(1e4, u1))), static_cast<int>(std::lround(std::min(1e4, v1)))));
    cv::rectangle(*bgr, box, colour, 2, cv::LINE_AA);
    char label[48];
    std::snprintf(label, sizeof label, "%d %s", t.id, std::string(to_string(t.cls)).c_str());
    cv::putText(*bgr, label, cv::Point(box.x, std::max(12, box.y - 4)), cv::FONT_HERSHEY_SIMPLEX, 0.45, colour, 1, cv::LINE_AA);
  }
}

cv::Mat PlanViewSystem::annotate(const StereoFrame& frame, const std::vector<Track>& tracks) const {
  cv::Mat view = frame.left.clone();
  draw_tracks_on_view(&view, camera_, tracks);
  cv::Mat mask;
  if (foreground_.empty()) {
    mask = cv::Mat::zeros(view.size(), CV_8UC3);
  } else {
    cv::cvtColor(foreground_, mask, cv::COLOR_GRAY2BGR);
  }
  cv::Mat top;
  cv::hconcat(view, mask, top);
  cv::Mat plan = draw_plan_view(plan_view(), tracks);
  if (plan.empty()) return top;
  // Fit the plan view under the two images, keeping its aspect.
  const double s = std::min(static_cast<double>(top.cols) / plan.cols, static_cast<double>(top.rows) / plan.rows);
  cv::Mat scaled;
  cv::resize(plan, scaled, cv::Size(std::max(1, static_cast<int>(plan.cols * s)), std::max(1, static_cast<int>(plan.rows * s))),
             0, 0, cv::INTER_NEAREST);
  cv::Mat bottom = cv::Mat::zeros(scaled.rows, top.cols, CV_8UC3);
  scaled.copyTo(bottom(cv::Rect((top.cols - scaled.cols) / 2, 0, scaled.cols, scaled.rows)));
  cv::Mat out;
  cv::vconcat(top, bottom, out);
  return out;
}

}  // namespace vigil::vision
