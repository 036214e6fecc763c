// wander: Stage's classic wander behaviour. The robot drives forward, drifting with a slowly
// changing random turn rate; when its laser sees something closer than avoid_distance in front
// it stops and turns towards the more open side until the way is clear. Parameters: speed,
// turn_rate, avoid_distance, front_half_angle_deg, drift.
#include <algorithm>
#include <cmath>

#include "plugins/plugin_export.h"
#include "common/rng.h"

namespace vigil::plugins {
namespace {

class Wander : public Plugin {
 public:
  std::vector<ParamSpec> params() const override {
    return {
        {"speed", ParamType::kNumber, 0.4, 0.01, 3.0, "forward speed when clear (m/s)"},
        {"turn_rate", ParamType::kNumber, 1.0, 0.05, 5.0, "turn rate when avoiding (rad/s)"},
        {"avoid_distance", ParamType::kNumber, 0.6, 0.05, 10.0, "turn away from returns closer than this (m)"},
        {"front_half_angle_deg", ParamType::kNumber, 30.0, 1.0, 90.0, "half width of the watched sector (deg)"},
        {"drift", ParamType::kNumber, 0.3, 0.0, 3.0, "largest random turn rate while cruising (rad/s)"},
    };
  }

  Status configure(const ParamSet& p, const PluginContext& ctx) override {
    id_ = ctx.model_id;
    seed_ = ctx.seed;
    speed_ = p.number("speed");
    turn_ = p.number("turn_rate");
    avoid_ = p.number("avoid_distance");
    half_ = p.number("front_half_angle_deg") * M_PI / 180.0;
    drift_ = p.number("drift");
    return Status::Ok();
  }

  void reset() override {
    rng_.reseed(seed_);
    drift_w_ = 0;
    next_drift_ = 0;
    turning_ = 0;
  }

  void update(const WorldView& world, ModelCommand& cmd) override {
    const RobotState* me = world.robot(id_);
    if (!me) return;
    if (world.time() >= next_drift_) {
      drift_w_ = rng_.uniform(-drift_, drift_);
      next_drift_ = world.time() + from_seconds(rng_.uniform(1.0, 3.0));
    }
    if (!me->scan || me->scan->ranges.empty()) {
      cmd.set_velocity(speed_, drift_w_);
      return;
    }
    const LaserScan& s = *me->scan;
    double front = s.range_max, left = 0, right = 0;
    int nl = 0, nr = 0;
    for (size_t i = 0; i < s.ranges.size(); ++i) {
      const double a = s.angle_min + i * s.angle_increment;
      if (std::abs(a) <= half_) front = std::min<double>(front, s.ranges[i]);
      if (a > 0 && a < M_PI / 2) left += s.ranges[i], nl++;
      if (a < 0 && a > -M_PI / 2) right += s.ranges[i], nr++;
    }
    if (front < avoid_) {
      // Keep turning the same way until clear, so the robot does not dither.
      if (turning_ == 0) turning_ = (nl ? left / nl : 0) >= (nr ? right / nr : 0) ? 1 : -1;
      cmd.set_velocity(0, turning_ * turn_);
    } else {
      turning_ = 0;
      cmd.set_velocity(speed_ * std::clamp((front - avoid_) / avoid_ + 0.3, 0.3, 1.0), drift_w_);
    }
  }

 private:
  std::string id_;
  uint64_t seed_ = 0;
  Rng rng_;
  double speed_ = 0.4, turn_ = 1.0, avoid_ = 0.6, half_ = 0.5, drift_ = 0.3;
  double drift_w_ = 0;
  SimTime next_drift_ = 0;
  int turning_ = 0;
};

}  // namespace
}  // namespace vigil::plugins

VIGIL_PLUGIN(wander, vigil::plugins::Wander)
