#include "world/topdown.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

namespace vigil {

cv::Scalar parse_colour(const std::string& hex) {
  if (hex.size() != 7 || hex[0] != '#') return {128, 128, 128};
  try {
    const int v = std::stoi(hex.substr(1), nullptr, 16);
    return {double(v & 0xFF), double((v >> 8) & 0xFF), double((v >> 16) & 0xFF)};
  } catch (...) {
    return {128, 128, 128};
  }
}

TopdownRenderer::TopdownRenderer(const World& world, int max_width, int max_height) {
  init(world.map(), max_width, max_height);
  trails_.resize(world.people().size());
}

TopdownRenderer::TopdownRenderer(const OccupancyGrid& map, int max_width, int max_height) { init(map, max_width, max_height); }

void TopdownRenderer::init(const OccupancyGrid& m, int max_width, int max_height) {
  scale_ = std::min(max_width / m.size_x(), max_height / m.size_y());
  origin_ = {m.origin().x, m.origin().y};
  height_m_ = m.size_y();
  const int w = std::max(16, static_cast<int>(std::lround(m.size_x() * scale_))) & ~1;
  const int h = std::max(16, static_cast<int>(std::lround(m.size_y() * scale_))) & ~1;
  // Grid as an image (row 0 at the top), then resized with nearest neighbour or area.
  cv::Mat grid(m.height(), m.width(), CV_8UC3);
  for (int cy = 0; cy < m.height(); ++cy) {
    auto* row = grid.ptr<cv::Vec3b>(m.height() - 1 - cy);
    for (int cx = 0; cx < m.width(); ++cx) {
      const Cell c = m.at(cx, cy);
      row[cx] = c == Cell::kFree ? cv::Vec3b(250, 250, 250) : c == Cell::kOccupied ? cv::Vec3b(40, 40, 40) : cv::Vec3b(200, 200, 200);
    }
  }
  cv::resize(grid, background_, cv::Size(w, h), 0, 0, scale_ < 1.0 / m.resolution() ? cv::INTER_AREA : cv::INTER_NEAREST);
}

cv::Point TopdownRenderer::to_px(Vec2 p) const {
  return {static_cast<int>(std::lround((p.x - origin_.x) * scale_)),
          static_cast<int>(std::lround((height_m_ - (p.y - origin_.y)) * scale_))};
}

cv::Mat TopdownRenderer::map_view(const std::vector<CameraSpec>& cameras, const OccupancyGrid& map) const {
  cv::Mat img = background_.clone();
  const int lw = std::max(1, static_cast<int>(scale_ / 20));
  // Camera fields of view, clipped by walls, as translucent fans.
  cv::Mat overlay = img.clone();
  for (const auto& cam : cameras) {
    double hfov = cam.hfov.value_or(60.0 * M_PI / 180.0);
    if (cam.fx) hfov = 2 * std::atan(cam.width / (2 * *cam.fx));
    const Vec2 c{cam.position.x, cam.position.y};
    std::vector<cv::Point> fan{to_px(c)};
    for (int k = 0; k <= 24; ++k) {
      const double a = cam.yaw - hfov / 2 + hfov * k / 24;
      const double r = map.raycast(c, a, 12.0);
      fan.push_back(to_px(c + Vec2{std::cos(a), std::sin(a)} * r));
    }
    cv::fillPoly(overlay, std::vector<std::vector<cv::Point>>{fan}, cv::Scalar(255, 200, 120));
  }
  cv::addWeighted(overlay, 0.35, img, 0.65, 0, img);
  for (const auto& cam : cameras) {
    const Vec2 c{cam.position.x, cam.position.y};
    cv::rectangle(img, to_px(c) - cv::Point(3 * lw, 3 * lw), to_px(c) + cv::Point(3 * lw, 3 * lw), cv::Scalar(160, 80, 0), cv::FILLED);
    cv::putText(img, cam.id, to_px(c) + cv::Point(4 * lw, -4 * lw), cv::FONT_HERSHEY_SIMPLEX, 0.35 * lw, cv::Scalar(160, 80, 0), 1, cv::LINE_AA);
  }
  return img;
}

cv::Mat TopdownRenderer::draw(const World& world) {
  const int lw = std::max(1, static_cast<int>(scale_ / 20));
  cv::Mat img = map_view(world.scenario().cameras, world.map());

  // Laser scans: lines for a few robots, end points for many.
  const bool many = world.robots().size() > 20;
  for (const auto& r : world.robots()) {
    if (!r.spec.ranger.enabled || r.scan.ranges.empty()) continue;
    const Pose2 lp = r.laser_pose();
    const cv::Point o = to_px(lp.position());
    for (size_t k = 0; k < r.scan.ranges.size(); ++k) {
      const double a = lp.yaw + r.scan.angle_min + k * r.scan.angle_increment;
      const double d = r.scan.ranges[k];
      const cv::Point e = to_px(lp.position() + Vec2{std::cos(a), std::sin(a)} * d);
      if (!many && k % 2 == 0) cv::line(img, o, e, cv::Scalar(200, 200, 255), 1);
      if (d < r.scan.range_max) cv::circle(img, e, lw, cv::Scalar(40, 40, 230), cv::FILLED);
    }
  }

  // Objects.
  for (const auto& ob : world.objects()) {
    if (!ob.present) continue;
    const cv::Point p = to_px(ob.pose.position());
    const int s = std::max(2, static_cast<int>(std::max(ob.spec.size_x, ob.spec.size_y) * scale_ / 2));
    cv::rectangle(img, p - cv::Point(s, s), p + cv::Point(s, s), parse_colour(ob.spec.colour), cv::FILLED);
    cv::rectangle(img, p - cv::Point(s, s), p + cv::Point(s, s),
                  ob.spec.authorised ? cv::Scalar(0, 140, 0) : cv::Scalar(0, 0, 220), lw);
    cv::putText(img, ob.spec.id, p + cv::Point(s + 2, s + 8), cv::FONT_HERSHEY_SIMPLEX, 0.3 * lw, cv::Scalar(60, 60, 60), 1, cv::LINE_AA);
  }

  // Robots: trail by mode, the believed pose and the goal, then the body.
  if (robot_trails_.size() != world.robots().size()) robot_trails_.resize(world.robots().size());
  auto mode_colour = [](const std::string& m) {
    if (m == "avoiding") return cv::Scalar(0, 140, 255);
    if (m == "waiting" || m == "recovering" || m == "failed") return cv::Scalar(0, 0, 220);
    if (m == "localizing") return cv::Scalar(180, 60, 160);
    return cv::Scalar(60, 170, 60);
  };
  for (size_t i = 0; i < world.robots().size(); ++i) {
    const auto& r = world.robots()[i];
    auto& trail = robot_trails_[i];
    const cv::Point c = to_px(r.pose.position());
    const cv::Scalar col = mode_colour(r.last_report ? r.last_report->mode : "");
    if (trail.empty() || trail.back().p != c) trail.push_back({c, col});
    if (trail.size() > 3000) trail.pop_front();
    for (size_t k = 1; k < trail.size(); ++k) cv::line(img, trail[k - 1].p, trail[k].p, trail[k].colour, lw);
    if (!r.last_report) continue;
    const RobotReport& rep = *r.last_report;
    if (rep.goal.x != 0 || rep.goal.y != 0) {
      const cv::Point g = to_px(rep.goal);
      const int s = std::max(3, static_cast<int>(0.25 * scale_));
      cv::line(img, g - cv::Point(s, s), g + cv::Point(s, s), cv::Scalar(200, 0, 200), lw + 1);
      cv::line(img, g - cv::Point(s, -s), g + cv::Point(s, -s), cv::Scalar(200, 0, 200), lw + 1);
    }
    const int rad = std::max(3, static_cast<int>((r.model.radius + 0.1) * scale_));
    cv::circle(img, to_px(rep.pose.position()), rad, cv::Scalar(220, 80, 0), lw, cv::LINE_AA);
    // The planned path ahead (thin, teal).
    if (rep.path.size() >= 2) {
      std::vector<cv::Point> pts;
      for (const Vec2& p : rep.path) pts.push_back(to_px(p));
      cv::polylines(img, pts, false, cv::Scalar(200, 160, 0), std::max(1, lw - 1), cv::LINE_AA);
    }
    // A team robot's role; responding or guarding, its assignment: a line to where it goes.
    if (rep.role == "respond" || rep.role == "guard") {
      const cv::Scalar task_col = rep.role == "guard" ? cv::Scalar(0, 0, 200) : cv::Scalar(0, 120, 255);
      if (rep.goal.x != 0 || rep.goal.y != 0) {
        cv::line(img, c, to_px(rep.goal), task_col, lw, cv::LINE_AA);
        cv::circle(img, to_px(rep.goal), std::max(4, static_cast<int>(0.4 * scale_)), task_col, lw + 1, cv::LINE_AA);
      }
    }
    if (!many) {
      const std::string label = rep.role.empty() ? rep.mode : rep.role + " / " + rep.mode;
      cv::putText(img, label, c + cv::Point(rad + 2, rad + 10), cv::FONT_HERSHEY_SIMPLEX, 0.32 * lw, col, 1,
                  cv::LINE_AA);
    }
  }
  for (const auto& r : world.robots()) {
    const Pose2& p = r.pose;
    const cv::Point c = to_px(p.position());
    const int rad = std::max(2, static_cast<int>(r.model.radius * scale_));
    cv::circle(img, c, rad, cv::Scalar(40, 160, 40), cv::FILLED);
    cv::line(img, c, to_px(p.position() + Vec2{std::cos(p.yaw), std::sin(p.yaw)} * (r.model.radius * 1.4)), cv::Scalar(0, 60, 0), lw + 1);
    if (!many) cv::putText(img, r.spec.id, c + cv::Point(rad + 2, -rad), cv::FONT_HERSHEY_SIMPLEX, 0.35 * lw, cv::Scalar(0, 90, 0), 1, cv::LINE_AA);
  }

  // People with trails.
  for (size_t i = 0; i < world.people().size(); ++i) {
    const auto& p = world.people()[i];
    if (!p.present) continue;
    const cv::Point c = to_px(p.pose.position());
    auto& trail = trails_[i];
    if (trail.empty() || trail.back() != c) trail.push_back(c);
    if (trail.size() > 400) trail.pop_front();
    for (size_t k = 1; k < trail.size(); ++k) cv::line(img, trail[k - 1], trail[k], parse_colour(p.spec.shirt) * 0.6 + cv::Scalar(100, 100, 100), lw);
    const int rad = std::max(2, static_cast<int>(p.spec.radius * scale_));
    cv::circle(img, c, rad, parse_colour(p.spec.shirt), cv::FILLED);
    cv::circle(img, c, rad, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
    cv::line(img, c, to_px(p.pose.position() + Vec2{std::cos(p.pose.yaw), std::sin(p.pose.yaw)} * (p.spec.radius * 1.6)), cv::Scalar(0, 0, 0), lw);
    cv::putText(img, p.spec.id, c + cv::Point(rad + 2, -rad), cv::FONT_HERSHEY_SIMPLEX, 0.4 * lw, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  }

  // Events that have happened, and the clock.
  int y = 18;
  char buf[96];
  std::snprintf(buf, sizeof buf, "t = %7.2f s", to_seconds(world.time()));
  cv::putText(img, buf, {8, y}, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  for (const auto& e : world.events()) {
    y += 16;
    std::snprintf(buf, sizeof buf, "%6.1f s  %s  %s", to_seconds(e.t), e.kind.c_str(), e.object.c_str());
    cv::putText(img, buf, {8, y}, cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(0, 0, 200), 1, cv::LINE_AA);
    const cv::Point p = to_px({e.where.x, e.where.y});
    cv::circle(img, p, static_cast<int>(0.6 * scale_), cv::Scalar(0, 0, 230), lw + 1, cv::LINE_AA);
  }
  return img;
}

}  // namespace vigil
