// waypoint_follower: drives a differential-drive robot through a list of waypoints (named
// places or points), in order, looping if asked. Between waypoints it follows a grid path
// around walls, turning in place when the heading error is large, and slows down and stops for
// anything its laser sees close ahead. Parameters:
//   waypoints (list of place names) or points (flat list x1 y1 x2 y2 ...), loop, speed,
//   tolerance, turn_gain, avoid_distance, clearance.
#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <mutex>

#include "planning/grid/grid_astar.h"
#include "plugins/plugin_export.h"

namespace vigil::plugins {
namespace {

// One path planner per (map, clearance), shared by every robot on that map. The planner refers
// to its grid, so the cache keeps its own copy of the map (the world's goes with its run).
const planning::GridPathPlanner& shared_planner(const OccupancyGrid* map, double clearance) {
  struct Held {
    OccupancyGrid map;
    std::unique_ptr<planning::GridPathPlanner> planner;
  };
  static std::mutex mu;
  // Keyed by the map's content: a freed map's address can come back for another map.
  static std::map<std::pair<uint64_t, double>, std::unique_ptr<Held>> cache;
  const uint64_t which = map->fingerprint();
  std::lock_guard<std::mutex> lock(mu);
  auto& slot = cache[{which, clearance}];
  if (!slot) {
    slot = std::make_unique<Held>();
    slot->map = *map;
    slot->planner = std::make_unique<planning::GridPathPlanner>(slot->map, clearance);
  }
  return *slot->planner;
}

class WaypointFollower : public Plugin {
 public:
  std::vector<ParamSpec> params() const override {
    return {
        {"waypoints", ParamType::kStringList, std::vector<std::string>{}, 0, 0, "named places to visit in order"},
        {"points", ParamType::kNumberList, std::vector<double>{}, -1e6, 1e6, "waypoints as x1 y1 x2 y2 ... (m)"},
        {"loop", ParamType::kBool, true, 0, 0, "start again after the last waypoint"},
        {"speed", ParamType::kNumber, 0.4, 0.01, 3.0, "cruise speed (m/s)"},
        {"tolerance", ParamType::kNumber, 0.3, 0.05, 5.0, "a waypoint counts as reached within this distance (m)"},
        {"turn_gain", ParamType::kNumber, 2.0, 0.1, 20.0, "angular velocity per radian of heading error"},
        {"avoid_distance", ParamType::kNumber, 0.6, 0.0, 5.0, "slow down for laser returns closer than this ahead (m)"},
        {"clearance", ParamType::kNumber, 0.35, 0.05, 2.0, "clearance from walls on planned paths (m)"},
    };
  }

  Status configure(const ParamSet& p, const PluginContext& ctx) override {
    ctx_ = ctx;
    waypoints_.clear();
    for (const auto& name : p.strings("waypoints")) {
      auto it = ctx.places->find(name);
      if (it == ctx.places->end()) {
        return bad_input(ctx.scenario_file, ctx.line, "params.waypoints", "no place named '" + name + "'");
      }
      waypoints_.push_back(it->second);
    }
    const auto& pts = p.numbers("points");
    if (pts.size() % 2 != 0) return bad_input(ctx.scenario_file, ctx.line, "params.points", "needs x y pairs");
    for (size_t i = 0; i + 1 < pts.size(); i += 2) waypoints_.push_back({pts[i], pts[i + 1]});
    for (const Vec2& w : waypoints_) {
      if (!ctx.map->is_free(w)) {
        return bad_input(ctx.scenario_file, ctx.line, "params",
                         "waypoint (" + std::to_string(w.x) + ", " + std::to_string(w.y) + ") is not in free space");
      }
    }
    loop_ = p.boolean("loop");
    speed_ = p.number("speed");
    tolerance_ = p.number("tolerance");
    gain_ = p.number("turn_gain");
    avoid_ = p.number("avoid_distance");
    planner_ = &shared_planner(ctx.map, p.number("clearance"));
    return Status::Ok();
  }

  void reset() override {
    next_ = 0;
    path_.clear();
    path_index_ = 0;
    done_ = waypoints_.empty();
  }

  void update(const WorldView& world, ModelCommand& cmd) override {
    const RobotState* me = world.robot(ctx_.model_id);
    if (!me || done_) {
      cmd.set_velocity(0, 0);
      return;
    }
    const Vec2 pos = me->odometry.position();
    if ((waypoints_[next_] - pos).norm() < tolerance_) {
      next_++;
      path_.clear();
      if (next_ >= waypoints_.size()) {
        if (!loop_) {
          done_ = true;
          cmd.set_velocity(0, 0);
          return;
        }
        next_ = 0;
      }
    }
    if (path_.empty()) {
      path_ = planner_->plan(pos, waypoints_[next_]);
      if (path_.empty()) path_ = {pos, waypoints_[next_]};  // no grid path: head straight
      path_index_ = 1;
    }
    while (path_index_ + 1 < path_.size() && (path_[path_index_] - pos).norm() < tolerance_) path_index_++;
    const Vec2 to = path_[std::min(path_index_, path_.size() - 1)] - pos;
    const double err = wrap_angle(std::atan2(to.y, to.x) - me->odometry.yaw);
    double v = std::abs(err) > 0.6 ? 0.0 : speed_ * std::cos(err);
    const double w = gain_ * err;
    if (me->scan && avoid_ > 0) {
      const double front = min_range_ahead(*me->scan, 0.35);
      v *= std::clamp((front - 0.3) / avoid_, 0.0, 1.0);
    }
    cmd.set_velocity(v, w);
  }

 private:
  static double min_range_ahead(const LaserScan& s, double half_angle) {
    double m = s.range_max;
    for (size_t i = 0; i < s.ranges.size(); ++i) {
      const double a = s.angle_min + i * s.angle_increment;
      if (std::abs(a) <= half_angle) m = std::min<double>(m, s.ranges[i]);
    }
    return m;
  }

  PluginContext ctx_;
  std::vector<Vec2> waypoints_;
  bool loop_ = true, done_ = false;
  double speed_ = 0.4, tolerance_ = 0.3, gain_ = 2.0, avoid_ = 0.6;
  const planning::GridPathPlanner* planner_ = nullptr;
  size_t next_ = 0;
  std::vector<Vec2> path_;
  size_t path_index_ = 0;
};

}  // namespace
}  // namespace vigil::plugins

VIGIL_PLUGIN(waypoint_follower, vigil::plugins::WaypointFollower)
