#include "vision/planview_system.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

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

Result<PlanViewSystem> PlanViewSystem::create(const StereoCameraModel& camera, const PlanViewSystemParams& params) {
  if (Status s = params.depth_filter.validate(); !s) return s.error();
  if (Status s = params.depth_region.validate(); !s) return s.error();
  auto bg = YuvdBackground::create(params.background);
  if (!bg) return bg.error();
  auto pipeline = PlanViewPipeline::create(camera, params.plan, params.tracking);
  if (!pipeline) return pipeline.error();
  return PlanViewSystem(camera, std::move(*bg), std::move(*pipeline), params.depth_filter, params.depth_region);
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
  if (Status s = background_.apply(frame.left, frame.depth, frame.depth_measured, foreground_); !s) return s.error();
  if (filter_.edge_radius <= 0 || frame.depth.type() != CV_32F || frame.depth.size() != foreground_.size())
    return pipeline_.process(foreground_, frame.depth, frame.stamp_ns);
  filter_depth_edges(frame.depth);
  return pipeline_.process(plan_mask_, frame.depth, frame.stamp_ns);
}

cv::Mat PlanViewSystem::depth_wanted(const StereoFrame& frame) {
  if (!region_.foreground_only) return {};
  const int64_t learnt = background_.frames();
  if (learnt < region_.full_first) return {};
  if (region_.full_every > 0 && (learnt - region_.full_first) % region_.full_every == region_.full_every - 1) return {};
  if (!background_.colour_changes(frame.left, changed_)) return {};  // process() reports the bad frame
  return changed_;
}

void PlanViewSystem::reset() {
  background_.reset();
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
