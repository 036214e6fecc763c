#include "world/kinematic_robot.h"

#include <algorithm>
#include <cmath>

namespace vigil {
namespace {

Pose2 compose(Pose2 a, Pose2 b) {
  const double c = std::cos(a.yaw), s = std::sin(a.yaw);
  return {a.x + c * b.x - s * b.y, a.y + s * b.x + c * b.y, wrap_angle(a.yaw + b.yaw)};
}

}  // namespace

KinematicRobot::KinematicRobot(const OccupancyGrid& map, Pose2 start, std::vector<Vec2> route, RouteEnd end,
                               const Options& options)
    : grid_(&map),
      walls_(map),
      bodies_({map.origin().x, map.origin().y}, {map.origin().x + map.size_x(), map.origin().y + map.size_y()}),
      options_(options),
      truth_(start),
      route_(std::move(route)),
      end_(end),
      noise_(Rng::stream(options.noise_seed, "laser")) {
  bodies_.rebuild({});
  spec_.enabled = true;
  spec_.range_max = 20;
  spec_.fov = 270 * M_PI / 180;
  spec_.samples = options.samples;
  spec_.noise_std = 0.01;
  take_scan();
}

void KinematicRobot::teleport(Pose2 p, size_t next) {
  truth_ = p;
  next_ = next;
}

void KinematicRobot::set_route(std::vector<Vec2> route) {
  route_ = std::move(route);
  next_ = 0;
}

void KinematicRobot::step() {
  const double dt = options_.period, speed = options_.speed, turn = options_.turn;
  double v = 0, w = 0;
  if (next_ < route_.size()) {
    const Vec2 d = route_[next_] - truth_.position();
    if (d.norm() < 0.15) {
      ++next_;
      if (end_ == RouteEnd::kLoop && next_ >= route_.size()) next_ = 0;
    } else {
      const double err = wrap_angle(std::atan2(d.y, d.x) - truth_.yaw);
      w = std::clamp(2.0 * err, -turn, turn);
      v = std::abs(err) < 0.3 ? std::min(speed, d.norm() / dt) : 0.0;
    }
  } else if (end_ == RouteEnd::kWander) {
    // Steer toward the longest free ray within +-60 deg; turn on the spot when blocked.
    double best = -1, best_a = 0;
    for (int k = -4; k <= 4; ++k) {
      const double a = k * 15 * M_PI / 180;
      const double r = std::min(6.0, grid_->raycast(truth_.position(), truth_.yaw + a, 6.0, true)) - 0.05 * std::abs(k);
      if (r > best) best = r, best_a = a;
    }
    const double front = std::min({grid_->raycast(truth_.position(), truth_.yaw, 2.0, true),
                                   grid_->raycast(truth_.position(), truth_.yaw + 0.4, 2.0, true),
                                   grid_->raycast(truth_.position(), truth_.yaw - 0.4, 2.0, true)});
    if (front < 0.7) {
      w = turn_dir_ * turn;
    } else {
      turn_dir_ = best_a >= 0 ? 1 : -1;
      w = std::clamp(1.5 * best_a, -turn, turn);
      v = speed;
    }
  }
  const Pose2 prev = truth_;
  const double a = truth_.yaw + 0.5 * w * dt;
  truth_ = {truth_.x + v * dt * std::cos(a), truth_.y + v * dt * std::sin(a), wrap_angle(truth_.yaw + w * dt)};
  // Odometry as World::step_robots_sense: the robot-frame increment, biased.
  const double c = std::cos(prev.yaw), s = std::sin(prev.yaw);
  const double dx = c * (truth_.x - prev.x) + s * (truth_.y - prev.y);
  const double dy = -s * (truth_.x - prev.x) + c * (truth_.y - prev.y);
  const double dyaw = wrap_angle(truth_.yaw - prev.yaw);
  const Vec3& b = options_.bias;
  const double mx = dx * (1 + b.x), my = dy * (1 + b.y), myaw = dyaw * (1 + b.z);
  const double oc = std::cos(odom_.yaw), os = std::sin(odom_.yaw);
  odom_ = {odom_.x + oc * mx - os * my, odom_.y + os * mx + oc * my, wrap_angle(odom_.yaw + myaw)};
  t_ += dt;
  take_scan();
}

void KinematicRobot::take_scan() {
  const Pose2 lp = compose(truth_, options_.laser);
  simulate_scan(walls_, bodies_, lp, spec_, -1, &noise_, from_seconds(t_), &scan_);
  const double res = grid_->resolution(), x0 = grid_->origin().x + res, y0 = grid_->origin().y + res;
  const double x1 = grid_->origin().x + grid_->size_x() - res, y1 = grid_->origin().y + grid_->size_y() - res;
  for (size_t i = 0; i < scan_.ranges.size(); ++i) {
    const double r = scan_.ranges[i], a = lp.yaw + scan_.angle_min + i * scan_.angle_increment;
    const double x = lp.x + r * std::cos(a), y = lp.y + r * std::sin(a);
    if (x < x0 || y < y0 || x > x1 || y > y1) scan_.ranges[i] = static_cast<float>(scan_.range_max);
  }
}

}  // namespace vigil
