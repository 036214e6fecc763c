// navigator: the robot's navigation stack as one controller plugin (chapter 10.6.2): Monte Carlo
// localisation on its laser and odometry (planning/localization), the two-level planner (PRM
// route + RRTConnect motion around what the laser sees, planning/two_level_planner.h) and a
// pure-pursuit follower within the robot's speed and turn limits. It never reads the ground
// truth: the pose it drives on, and reports, is its own estimate.
//
// Goals come from its parameters (waypoint_follower's `waypoints` / `points`, `loop`, `speed`,
// so a scenario switches controller by name) and from tasks in its inbox (`goto` preempts the
// patrol, `patrol` replaces it, `cancel` / `stop` end the current goal). It slows and stops for
// anything within `safety_distance` ahead, replans around obstacles that block its path (a
// bag, a standing person), recovers when stuck (back off, turn, replan) and after
// `max_recoveries` gives the goal up with a `goal_failed` report its owner sees. Every report
// carries the estimate, its uncertainty and the mode (idle, localizing, driving, avoiding,
// waiting, recovering, arrived, failed).
#pragma once

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <mutex>
#include <optional>

#include "planning/localization/mcl.h"
#include "planning/two_level_planner.h"
#include "world/plugin.h"

namespace vigil::plugins {
namespace nav_detail {

// Planners are shared by every robot on the same map with the same radius and seed (one
// roadmap per map, as a fleet would share it), built once per process or loaded from the
// cache folder.
inline std::shared_ptr<const planning::TwoLevelPlanner> shared_planner(const OccupancyGrid* map,
                                                                const planning::TwoLevelParams& params,
                                                                const std::filesystem::path& cache_dir,
                                                                Error* error) {
  static std::mutex mu;
  static std::map<std::tuple<uint64_t, long long, uint64_t, long long>,
                  std::shared_ptr<const planning::TwoLevelPlanner>>
      cache;
  // Keyed by the map's content: a freed map's address can come back for another map.
  const uint64_t which = map->fingerprint();
  std::lock_guard<std::mutex> lock(mu);
  const auto key = std::make_tuple(which, std::llround(params.robot_radius * 1e6), params.roadmap.seed,
                                   std::llround(params.roadmap.density * 1e6));
  auto& slot = cache[key];
  if (!slot) {
    std::filesystem::path file;
    if (!cache_dir.empty()) {
      std::error_code ec;
      std::filesystem::create_directories(cache_dir, ec);
      char name[96];
      std::snprintf(name, sizeof name, "roadmap_r%.3f_s%llu.txt", params.robot_radius,
                    static_cast<unsigned long long>(params.roadmap.seed));
      file = cache_dir / name;
    }
    // The planner refers to its grid, so the cache keeps its own copy of the map: the world's
    // map goes when its run ends, and a later run on the same map reuses the planner.
    struct Held {
      OccupancyGrid map;
      std::unique_ptr<planning::TwoLevelPlanner> planner;
    };
    auto held = std::make_shared<Held>();
    held->map = *map;
    auto created = planning::TwoLevelPlanner::create(held->map, params, file);
    if (!created) {
      *error = created.error();
      cache.erase(key);
      return nullptr;
    }
    held->planner = std::move(*created);
    slot = std::shared_ptr<const planning::TwoLevelPlanner>(held, held->planner.get());
  }
  return slot;
}

// The localisation's map data (likelihood field, free cells) is likewise shared by every robot
// on the same map with the same laser model: per robot only the particles are its own.
inline Result<std::shared_ptr<const planning::MclMap>> shared_mcl_map(const OccupancyGrid* map,
                                                               const planning::LikelihoodFieldParams& field) {
  static std::mutex mu;
  static std::map<std::pair<uint64_t, long long>, std::shared_ptr<const planning::MclMap>> cache;
  const uint64_t which = map->fingerprint();
  std::lock_guard<std::mutex> lock(mu);
  auto& slot = cache[{which, std::llround(field.max_range * 1e6)}];
  if (!slot) {
    auto built = planning::MclMap::build(*map, field);
    if (!built) return built.error();
    slot = *built;
  }
  return slot;
}

inline Pose2 compose(Pose2 a, Pose2 b) {
  const double c = std::cos(a.yaw), s = std::sin(a.yaw);
  return {a.x + c * b.x - s * b.y, a.y + s * b.x + c * b.y, wrap_angle(a.yaw + b.yaw)};
}
inline Pose2 between(Pose2 from, Pose2 to) {  // from^-1 * to
  const double c = std::cos(from.yaw), s = std::sin(from.yaw);
  const double dx = to.x - from.x, dy = to.y - from.y;
  return {c * dx + s * dy, -s * dx + c * dy, wrap_angle(to.yaw - from.yaw)};
}

}  // namespace nav_detail

class Navigator : public Plugin {
  using PlanOutcome = planning::PlanOutcome;
 public:
  std::vector<ParamSpec> params() const override {
    return {
        {"waypoints", ParamType::kStringList, std::vector<std::string>{}, 0, 0, "named places to patrol in order"},
        {"points", ParamType::kNumberList, std::vector<double>{}, -1e6, 1e6, "waypoints as x1 y1 x2 y2 ... (m)"},
        {"loop", ParamType::kBool, true, 0, 0, "start again after the last waypoint"},
        {"speed", ParamType::kNumber, 0.4, 0.01, 3.0, "cruise speed (m/s)"},
        {"tolerance", ParamType::kNumber, 0.3, 0.05, 5.0, "a goal counts as reached within this distance (m)"},
        {"lookahead", ParamType::kNumber, 0.6, 0.1, 5.0, "pure pursuit look-ahead distance (m)"},
        {"turn_gain", ParamType::kNumber, 2.0, 0.1, 20.0, "angular velocity per radian of heading error"},
        {"safety_distance", ParamType::kNumber, 0.45, 0.05, 5.0, "stop for returns closer than this ahead of the body (m)"},
        {"map_safety_distance", ParamType::kNumber, 0.1, 0.0, 5.0, "stop for returns on a mapped wall closer than this ahead of the body (m; the planned path keeps its clearance from walls)"},
        {"slow_distance", ParamType::kNumber, 1.2, 0.1, 10.0, "slow down for returns closer than this ahead (m)"},
        {"personal_space", ParamType::kNumber, 0.0, 0.0, 3.0, "stop for unmapped returns this close to the body in front of the axle (m; 0 = off)"},
        {"inflation_padding", ParamType::kNumber, 0.05, 0.0, 1.0, "added to the robot's radius for planning (m)"},
        {"obstacle_margin", ParamType::kNumber, 0.15, 0.0, 2.0, "kept from laser-seen obstacles when replanning (m)"},
        {"replan_period", ParamType::kNumber, 2.0, 0.1, 60.0, "replan against what the laser sees this often (s)"},
        {"blocked_wait", ParamType::kNumber, 1.0, 0.0, 60.0, "wait this long for a blocked way to clear before going round (s)"},
        {"stuck_time", ParamType::kNumber, 8.0, 1.0, 600.0, "no progress for this long starts a recovery (s)"},
        {"max_recoveries", ParamType::kInteger, 3.0, 0, 100, "recoveries before the goal is given up"},
        {"localization", ParamType::kString, std::string("mcl"), 0, 0, "mcl | odometry"},
        {"initial_pose", ParamType::kString, std::string("known"), 0, 0, "known (the scenario start) | unknown (global localisation)"},
        {"particles", ParamType::kInteger, 500.0, 10, 100000, "MCL particles (fixed count)"},
        {"global_particles", ParamType::kInteger, 5000.0, 10, 1000000, "MCL particles for global localisation"},
        {"laser_beams", ParamType::kInteger, 60.0, 1, 10000, "beams per scan MCL uses"},
        {"roadmap_density", ParamType::kNumber, 1.5, 0.05, 50.0, "PRM milestones per m^2 of free space"},
        {"roadmap_seed", ParamType::kInteger, 1.0, 0, 1e9, "seed of the shared roadmap"},
        {"report_rate", ParamType::kNumber, 2.0, 0.1, 100.0, "state reports per second (events are reported at once)"},
        {"occlusion_range", ParamType::kNumber, 3.0, 0.0, 50.0, "MCL: short beams within this range (a body in front) are not evidence of a wrong pose (m; 0 = off; on once localised)"},
        {"beam_skip", ParamType::kBool, true, 0, 0, "MCL: leave out beams most particles cannot explain (nav2 AMCL do_beamskip; on once localised)"},
    };
  }

  Status configure(const ParamSet& p, const PluginContext& ctx) override {
    ctx_ = ctx;
    patrol_.clear();
    for (const auto& name : p.strings("waypoints")) {
      auto it = ctx.places->find(name);
      if (it == ctx.places->end()) {
        return bad_input(ctx.scenario_file, ctx.line, "params.waypoints", "no place named '" + name + "'");
      }
      patrol_.push_back(it->second);
    }
    const auto& pts = p.numbers("points");
    if (pts.size() % 2 != 0) return bad_input(ctx.scenario_file, ctx.line, "params.points", "needs x y pairs");
    for (size_t i = 0; i + 1 < pts.size(); i += 2) patrol_.push_back({pts[i], pts[i + 1]});
    loop_ = p.boolean("loop");
    speed_ = std::min(p.number("speed"), ctx.max_speed > 0 ? ctx.max_speed : 1e9);
    tolerance_ = p.number("tolerance");
    lookahead_ = p.number("lookahead");
    gain_ = p.number("turn_gain");
    safety_ = p.number("safety_distance");
    map_safety_ = std::min(p.number("map_safety_distance"), safety_);
    slow_ = std::max(p.number("slow_distance"), safety_ + 0.05);
    personal_space_ = p.number("personal_space");
    replan_period_ = from_seconds(p.number("replan_period"));
    blocked_wait_ = from_seconds(p.number("blocked_wait"));
    stuck_time_ = from_seconds(p.number("stuck_time"));
    max_recoveries_ = p.integer("max_recoveries");
    report_every_ = from_seconds(1.0 / p.number("report_rate"));
    const std::string loc = p.string("localization");
    if (loc != "mcl" && loc != "odometry") {
      return bad_input(ctx.scenario_file, ctx.line, "params.localization", "must be 'mcl' or 'odometry', not '" + loc + "'");
    }
    use_mcl_ = loc == "mcl";
    if (ctx.laser_range_max <= 0) {
      // Without a laser it can neither localise on the map nor see people in its way.
      return bad_input(ctx.scenario_file, ctx.line, "ranger",
                       "the navigator needs the robot's laser: give the robot a ranger");
    }
    const std::string init = p.string("initial_pose");
    if (init != "known" && init != "unknown") {
      return bad_input(ctx.scenario_file, ctx.line, "params.initial_pose", "must be 'known' or 'unknown', not '" + init + "'");
    }
    global_start_ = init == "unknown";
    if (global_start_ && !use_mcl_) {
      return bad_input(ctx.scenario_file, ctx.line, "params.initial_pose", "an unknown start needs localization: mcl");
    }

    planning::TwoLevelParams tp;
    tp.robot_radius = ctx.robot_radius + p.number("inflation_padding");
    tp.obstacle_margin = p.number("obstacle_margin");
    tp.roadmap.density = p.number("roadmap_density");
    tp.roadmap.seed = static_cast<uint64_t>(p.integer("roadmap_seed"));
    tp.motion.seed = ctx.seed;
    tp.motion.max_iterations = 1500;  // a 12 m window is solved in a few hundred when it can be
    tp.motion.window = 12.0;
    if (Status s = tp.check(ctx.scenario_file, ctx.line); !s) return s;
    Error err;
    planner_ = nav_detail::shared_planner(ctx.map, tp, ctx.cache_dir, &err);
    if (!planner_) {
      err.file = ctx.scenario_file;
      err.line = ctx.line;
      err.key = "params";
      err.message = "cannot build the planner: " + err.message;
      return err;
    }
    for (const Vec2& w : patrol_) {
      if (!ctx.map->is_free(w)) {
        return bad_input(ctx.scenario_file, ctx.line, "params",
                         "waypoint (" + std::to_string(w.x) + ", " + std::to_string(w.y) + ") is not in free space");
      }
    }
    if (use_mcl_) {
      planning::MclParams mp;
      mp.seed = ctx.seed ^ 0x5bd1e995ull;
      mp.particles = global_start_ ? p.integer("global_particles") : p.integer("particles");
      mp.max_beams = p.integer("laser_beams");
      // Among people and robots a body close in front of the laser must not throw the filter
      // off; but a filter localising globally may converge on a wrong but similar place, and
      // needs those beams to leave it: the options go on once it is localised.
      crowd_range_ = p.number("occlusion_range");
      crowd_skip_ = p.boolean("beam_skip");
      mp.occlusion_range = global_start_ ? 0.0 : crowd_range_;
      mp.beam_skip = global_start_ ? false : crowd_skip_;
      mp.laser_pose = ctx.laser_mount;
      if (ctx.laser_range_max > 0) mp.field.max_range = ctx.laser_range_max;
      auto shared = nav_detail::shared_mcl_map(ctx.map, mp.field);
      auto mcl = shared ? planning::MonteCarloLocalization::create(*shared, mp)
                        : Result<planning::MonteCarloLocalization>(shared.error());
      if (!mcl) {
        Error e = mcl.error();
        e.file = ctx.scenario_file;
        e.line = ctx.line;
        e.key = "params." + e.key;
        return e;
      }
      mcl_map_ = *shared;
      mcl_params_ = mp;
    }
    return Status::Ok();
  }

  void reset() override {
    if (use_mcl_) {
      mcl_ = std::make_unique<planning::MonteCarloLocalization>(
          std::move(*planning::MonteCarloLocalization::create(mcl_map_, mcl_params_)));
      if (global_start_) mcl_->initialize_global();
      else (void)mcl_->initialize(ctx_.start, {0.1, 0.1, 0.05});
    }
    have_odom_ref_ = false;
    pose_ = ctx_.start;
    next_patrol_ = 0;
    goal_.reset();
    task_id_ = 0;
    path_.clear();
    mode_ = global_start_ ? "localizing" : "idle";
    recoveries_ = 0;
    next_report_ = 0;
    recovery_until_ = -1;
    blocked_since_ = -1;
    consecutive_failures_ = 0;
    retry_after_ = 0;
    last_scan_stamp_ = -1;
  }

  void update(const WorldView& world, ModelCommand& cmd) override {
    const RobotState* me = world.robot(ctx_.model_id);
    if (!me) return;
    now_ = world.time();
    localize(*me);
    handle_tasks(cmd);
    double v = 0, w = 0;
    if (mode_ == "localizing") {
      explore(*me, &v, &w);
      if (mcl_->converged()) {
        mode_ = "idle";
        (void)mcl_->set_crowd_options(crowd_range_, crowd_skip_);  // checked at configure
        push_event(cmd, "localized", "");
      }
    } else {
      if (!goal_) next_goal();
      if (goal_ && !goal_announced_) {
        goal_announced_ = true;
        push_event(cmd, "goal_started", label_);
      }
      if (goal_) drive(*me, cmd, &v, &w);
    }
    cmd.set_velocity(v, w);
    if (now_ >= next_report_) {
      send_report(cmd, "", "");
      next_report_ = now_ + report_every_;
    }
  }

  // ---- For a controller that drives through this one (plugins/team): goals given directly,
  // the localised pose and what it is doing. Events of such goals are reported as for tasks.
  // Drives to `goal`, replacing any goal. `pass_through`: a waypoint on the way, driven through
  // at speed (the caller gives the next goal before this one is reached).
  void go_to(Vec2 goal, uint64_t task, const std::string& label, bool pass_through) {
    set_goal(goal, task, label);
    pass_through_ = pass_through;
    patrol_.clear();
  }
  // Drops the goal and any patrol; the robot stops.
  void halt() {
    goal_.reset();
    task_id_ = 0;
    path_.clear();
    patrol_.clear();
    if (mode_ != "localizing") mode_ = "idle";
  }
  // For `seconds` from now, pass on the right: the pursuit point is shifted `offset` to the
  // right of the path where the inflated map allows, and what stands on the path ahead (the
  // robot being passed) no longer triggers a replan round it. The safety stop still holds.
  void keep_right(double offset, double seconds) {
    keep_right_ = offset;
    keep_right_until_ = now_ + from_seconds(seconds);
  }
  Pose2 pose() const { return pose_; }
  const std::string& mode() const { return mode_; }
  bool has_goal() const { return goal_.has_value(); }
  bool is_localized() const { return localized(); }
  std::optional<Vec2> goal() const { return goal_; }
  const std::vector<Vec2>& path() const { return path_; }
  const planning::TwoLevelPlanner& planner() const { return *planner_; }
  double cruise_speed() const { return speed_; }
  double tolerance() const { return tolerance_; }
  // The localisation's uncertainty (m, rad).
  std::pair<double, double> uncertainty() const {
    if (!mcl_) return {0.0, 0.0};
    const auto& e = mcl_->estimate();
    return {std::max(e.stddev.x, e.stddev.y), e.stddev.z};
  }

 private:
  // ---- Localisation: MCL estimate at its last update, carried forward by the odometry since.
  void localize(const RobotState& me) {
    if (!use_mcl_) {
      pose_ = me.odometry;
      return;
    }
    const LaserScan* scan = nullptr;
    if (me.scan && me.scan->stamp != last_scan_stamp_ && !me.scan->ranges.empty()) {
      scan = me.scan;
      last_scan_stamp_ = me.scan->stamp;
    }
    if (mcl_->update(me.odometry, scan) || !have_odom_ref_) {
      odom_at_estimate_ = me.odometry;
      have_odom_ref_ = true;
    }
    pose_ = nav_detail::compose(mcl_->estimate().pose, nav_detail::between(odom_at_estimate_, me.odometry));
  }

  bool localized() const { return !use_mcl_ || mode_ != "localizing"; }

  // ---- Tasks and goals.
  void handle_tasks(ModelCommand& cmd) {
    for (RobotTask& t : cmd.take_tasks()) {
      consecutive_failures_ = 0;
      retry_after_ = 0;
      if (t.kind == "goto") {
        if (goal_ && task_id_ != 0) push_event(cmd, "goal_failed", "preempted by task " + std::to_string(t.id));
        set_goal(t.goal, t.id, t.label);
      } else if (t.kind == "patrol") {
        patrol_ = t.waypoints;
        loop_ = t.loop;
        next_patrol_ = 0;
        if (task_id_ == 0) goal_.reset();
      } else if (t.kind == "cancel" || t.kind == "stop") {
        if (goal_) push_event(cmd, "goal_failed", "cancelled");
        goal_.reset();
        task_id_ = 0;
        if (t.kind == "stop") patrol_.clear();
        mode_ = "idle";
      } else {
        const uint64_t keep = task_id_;
        task_id_ = t.id;
        push_event(cmd, "task_rejected", "unknown task kind '" + t.kind + "'");
        task_id_ = keep;
      }
    }
  }

  void next_goal() {
    if (patrol_.empty() || now_ < retry_after_) return;
    if (consecutive_failures_ >= static_cast<int>(patrol_.size())) {
      mode_ = "failed";  // every patrol goal failed in a row: nothing to do until a task comes
      return;
    }
    if (next_patrol_ >= patrol_.size()) {
      if (!loop_) return;
      next_patrol_ = 0;
    }
    // A patrol of one place, reached: stay there rather than re-reach it every step.
    if (patrol_.size() == 1 && (patrol_[0] - pose_.position()).norm() < tolerance_) return;
    set_goal(patrol_[next_patrol_++], 0, "");
  }

  void set_goal(Vec2 g, uint64_t id, const std::string& label) {
    goal_ = g;
    task_id_ = id;
    label_ = label;
    path_.clear();
    recoveries_ = 0;
    planned_length_ = -1;
    progress_best_ = 1e18;
    progress_time_ = now_;
    mode_ = "driving";
    pass_through_ = false;
    goal_announced_ = false;
    statically_checked_ = false;
  }

  void finish_goal(ModelCommand& cmd, bool reached, const std::string& why) {
    mode_ = reached ? "arrived" : "failed";
    consecutive_failures_ = reached ? 0 : consecutive_failures_ + 1;
    if (!reached) retry_after_ = now_ + from_seconds(1.0);
    push_event(cmd, reached ? "goal_reached" : "goal_failed", why);
    goal_.reset();
    task_id_ = 0;
    path_.clear();
  }

  // ---- Planning.
  planning::LocalObstacles seen(const RobotState& me) const {
    if (!me.scan) return {};
    const Pose2 laser = nav_detail::compose(pose_, ctx_.laser_mount);
    return planning::LocalObstacles::from_scan(*me.scan, laser, planner_->inflated(), planner_->obstacle_clearance(),
                                               0.2, 6.0);
  }

  bool replan(const RobotState& me, bool with_obstacles) {
    const planning::LocalObstacles obs = with_obstacles ? seen(me) : planning::LocalObstacles();
    planning::PlanResult r = planner_->plan(pose_.position(), *goal_, with_obstacles ? &obs : nullptr);
    last_plan_ = now_;
    if (!planning::has_path(r.outcome)) {
      last_outcome_ = r.outcome;
      last_detail_ = r.detail;
      return false;
    }
    path_ = std::move(r.path);
    path_index_ = 0;
    // The new route is the reference progress is measured from (the stuck timer runs on).
    progress_best_ = remaining_length(pose_.position());
    avoiding_ = r.used_motion_level;
    if (planned_length_ < 0) planned_length_ = r.length;
    return true;
  }

  // The path ahead, from the robot's estimate on, thinned to at most 64 points.
  std::vector<Vec2> remaining_path() const {
    std::vector<Vec2> out;
    if (!goal_ || path_.empty()) return out;
    out.push_back(pose_.position());
    const size_t k = std::min(path_index_ + 1, path_.size() - 1);
    const size_t n = path_.size() - k;
    const size_t stride = std::max<size_t>(1, (n + 62) / 63);
    for (size_t i = k; i < path_.size(); i += stride) out.push_back(path_[i]);
    if ((out.back() - path_.back()).norm() > 1e-9) out.push_back(path_.back());
    return out;
  }

 public:
  const std::vector<Vec2> planned_path() const { return remaining_path(); }

 private:
  // What is left of the route from `pos`: to the path's next point, then along it; the
  // straight line to the goal when there is no path.
  double remaining_length(Vec2 pos) const {
    if (path_.empty()) return goal_ ? (*goal_ - pos).norm() : 0.0;
    size_t k = std::min(path_index_ + 1, path_.size() - 1);
    double len = (path_[k] - pos).norm();
    for (size_t i = k; i + 1 < path_.size(); ++i) len += (path_[i + 1] - path_[i]).norm();
    return len;
  }

  // True when the next few metres of the path pass within clearance of what the laser sees.
  bool path_blocked(const planning::LocalObstacles& obs, double horizon) const {
    double along = 0;
    Vec2 prev = pose_.position();
    for (size_t i = path_index_ + 1; i < path_.size() && along < horizon; ++i) {
      if (!obs.segment_free(prev, path_[i], planner_->params().robot_radius + 0.05)) return true;
      along += (path_[i] - prev).norm();
      prev = path_[i];
    }
    return false;
  }

  // ---- Driving.
  void drive(const RobotState& me, ModelCommand& cmd, double* v, double* w) {
    const Vec2 pos = pose_.position();
    const double to_goal = (*goal_ - pos).norm();
    if (to_goal < tolerance_) {
      finish_goal(cmd, true, "");
      return;
    }
    // Progress is measured along the route (what is left of the planned path), not as the
    // straight line to the goal: a route that first leads away (out of a room by its door)
    // is progress too.
    const double remaining = remaining_length(pos);
    if (remaining < progress_best_ - 0.25) {
      progress_best_ = remaining;
      progress_time_ = now_;
    }
    // Recovery under way: back off, then turn towards the goal; then replan.
    if (recovery_until_ >= 0) {
      mode_ = "recovering";
      if (now_ < recovery_backoff_end_) {
        *v = rear_clear(me) ? -0.15 : 0.0;
        *w = 0;
        return;
      }
      if (now_ < recovery_until_) {
        const double err = wrap_angle(std::atan2(goal_->y - pos.y, goal_->x - pos.x) - pose_.yaw);
        *w = turn_clear(me) ? std::clamp(gain_ * err, -0.8, 0.8) : 0.0;
        return;
      }
      recovery_until_ = -1;
      path_.clear();
    }
    if (now_ - progress_time_ > stuck_time_) {
      if (recoveries_ >= max_recoveries_) {
        finish_goal(cmd, false,
                    path_.empty() ? std::string("no path: ") + planning::to_string(last_outcome_) + ": " + last_detail_
                                  : "stuck: no progress after " + std::to_string(recoveries_) + " recoveries");
        return;
      }
      ++recoveries_;
      recovery_backoff_end_ = now_ + from_seconds(2.0);
      recovery_until_ = now_ + from_seconds(4.0);
      progress_time_ = now_;
      return;
    }
    const planning::LocalObstacles obs = seen(me);
    if (!statically_checked_) {
      // A goal the static map says cannot be reached is an answer now; what the laser sees
      // later is worth waiting for (the stuck timer decides).
      statically_checked_ = true;
      const planning::PlanResult st = planner_->plan(pose_.position(), *goal_, nullptr);
      if (!planning::has_path(st.outcome)) {
        last_plan_ = now_;
        finish_goal(cmd, false, std::string(planning::to_string(st.outcome)) + ": " + st.detail);
        return;
      }
      planned_length_ = st.length;
    }
    // The periodic replan refreshes the route from where the robot is; it runs the motion level
    // (RRTConnect) only when what the laser sees blocks the next metres.
    const bool passing = keep_right_ > 0 && now_ < keep_right_until_;
    if (path_.empty()) replan(me, !passing);
    else if (now_ - last_plan_ >= replan_period_) replan(me, !passing && path_blocked(obs, 6.0));
    if (path_.empty()) {
      mode_ = "waiting";
      return;
    }
    if (!passing && path_blocked(obs, 3.0)) {
      if (blocked_since_ < 0) blocked_since_ = now_;
      // Something stands on the path: wait a moment (people pass), then go round it.
      if (now_ - blocked_since_ >= blocked_wait_ && now_ - last_plan_ >= from_seconds(1.0)) replan(me, true);
    } else {
      blocked_since_ = -1;
    }
    mode_ = passing ? "passing" : avoiding_ ? "avoiding" : "driving";
    // Pure pursuit: the carrot is the first path point at least the look-ahead away, past the
    // closest segment. Close to something (a door jamb, a corner) the look-ahead shrinks, down
    // to 40 %, so the robot cuts the path's corners less where there is no room for it (after
    // nav2's regulated pure pursuit).
    const double lookahead = lookahead_ * std::clamp((nearest_return(me) - ctx_.robot_radius) / 0.5, 0.4, 1.0);
    while (path_index_ + 1 < path_.size() && (path_[path_index_ + 1] - pos).norm() < lookahead) ++path_index_;
    Vec2 carrot = path_.back();
    Vec2 carrot_dir{0, 0};
    for (size_t i = path_index_ + 1; i < path_.size(); ++i) {
      if ((path_[i] - pos).norm() >= lookahead) {
        // Point on segment (i-1, i) at the lookahead distance.
        const Vec2 a = path_[i - 1], b = path_[i];
        const Vec2 d = b - a;
        const Vec2 f = a - pos;
        const double A = d.dot(d), B = 2 * f.dot(d), C = f.dot(f) - lookahead * lookahead;
        const double disc = B * B - 4 * A * C;
        double t = 1.0;
        if (A > 0 && disc >= 0) t = std::clamp((-B + std::sqrt(disc)) / (2 * A), 0.0, 1.0);
        carrot = a + d * t;
        carrot_dir = d;
        break;
      }
    }
    if (passing) {
      // To the right of the path's own direction there (a line parallel to the path), so the
      // shift does not turn with the robot.
      const Vec2 d = carrot_dir.norm() > 1e-9 ? carrot_dir : carrot - pos;
      const double n = d.norm();
      if (n > 1e-6) {
        const Vec2 right{d.y / n, -d.x / n};
        for (double off : {keep_right_, 0.5 * keep_right_}) {
          const Vec2 c = carrot + right * off;
          // 10 cm more than the inflation on the wall's side, so driving along the shifted
          // line leaves the swept corridor clear of the wall.
          if (planner_->inflated().is_free(c + right * 0.1) && planner_->inflated().segment_free(pos, c)) {
            carrot = c;
            break;
          }
        }
      }
    }
    const Vec2 to = carrot - pos;
    const double err = wrap_angle(std::atan2(to.y, to.x) - pose_.yaw);
    double speed = speed_;
    if (to_goal < 1.0 && !pass_through_) speed *= std::max(0.3, to_goal);
    *v = std::abs(err) > 0.7 ? 0.0 : speed * std::cos(err);
    *w = std::clamp(gain_ * err, -ctx_.max_turn_rate, ctx_.max_turn_rate);
    // Safety: slow for, and stop short of, anything in the swept corridor ahead: `safety_distance`
    // short of what the map does not hold (a person, a robot, a bag), `map_safety_distance`
    // short of a mapped wall. The path keeps its clearance from walls, but pure pursuit heads
    // for a carrot at a corner, and near a wall the wall can be the return straight ahead while
    // the path turns before it (a corner 0.3 m from a door jamb): a full safety distance there
    // stopped the robot for ever.
    double ahead_unmapped = 1e9, ahead_mapped = 1e9;
    clear_ahead(me, &ahead_mapped, &ahead_unmapped);
    const double band = slow_ - safety_;
    double factor = std::min(std::clamp((ahead_unmapped - safety_) / band, 0.0, 1.0),
                             std::clamp((ahead_mapped - map_safety_) / band, 0.0, 1.0));
    // Personal space: something the map does not hold (a person stepping in from the side)
    // within `personal_space` of the body, anywhere in front of its axle, stops the robot too.
    if (personal_space_ > 0) {
      for (const Vec2& q : obs.points()) {
        const Vec2 d = q - pos;
        const double fx = std::cos(pose_.yaw) * d.x + std::sin(pose_.yaw) * d.y;
        if (fx > 0 && d.norm() < ctx_.robot_radius + personal_space_) {
          factor = 0;
          break;
        }
      }
    }
    *v *= factor;
    if (factor == 0.0) {
      mode_ = "waiting";
      // Turning in place towards the path is still allowed (it lines the robot up with a path
      // that runs beside a wall) while nothing is within the disc the body sweeps turning (a
      // box's corners reach out to the disc: a door jamb beside an Erratic stops the turn).
      if (std::abs(err) <= 0.05 || !turn_clear(me)) *w = 0;
    }
  }

  // Calls fn(x, y) for every valid laser return, in the robot frame.
  template <class Fn>
  void for_each_return(const RobotState& me, Fn&& fn) const {
    if (!me.scan) return;
    const LaserScan& s = *me.scan;
    for (size_t i = 0; i < s.ranges.size(); ++i) {
      const double r = s.ranges[i];
      if (!std::isfinite(r) || r >= s.range_max - 1e-3 || r < s.range_min) continue;
      const double a = s.angle_min + static_cast<double>(i) * s.angle_increment + ctx_.laser_mount.yaw;
      fn(ctx_.laser_mount.x + r * std::cos(a), ctx_.laser_mount.y + r * std::sin(a));
    }
  }

  // Distance from the robot's front to the nearest laser return in the corridor it sweeps.
  double clear_ahead(const RobotState& me) const {
    double mapped = 1e9, unmapped = 1e9;
    clear_ahead(me, &mapped, &unmapped);
    return std::min(mapped, unmapped);
  }

  // The same, split: returns on a mapped wall (within 0.2 m of one, seen from the estimate, as
  // LocalObstacles tells them apart) and the others.
  void clear_ahead(const RobotState& me, double* mapped, double* unmapped) const {
    // The body's own width and 2 cm: paths keep inflation_padding (5 cm) more from walls than
    // the disc covering the body, so a wall beside a path that hugs it is not taken for
    // something in the way. A box-shaped body driving forward sweeps only its own half width
    // (a doorway one metre wide leaves an Erratic 10 cm to spare each side, the disc 3 cm).
    const double body = ctx_.body_half_width > 0 ? std::min(ctx_.body_half_width, ctx_.robot_radius) : ctx_.robot_radius;
    const double half_width = body + 0.02;
    const auto& map = planner_->inflated();
    const double c = std::cos(pose_.yaw), s = std::sin(pose_.yaw);
    *mapped = *unmapped = 1e9;
    for_each_return(me, [&](double x, double y) {
      if (x <= 0 || std::abs(y) > half_width) return;
      const double d = x - ctx_.robot_radius;
      if (d >= *mapped && d >= *unmapped) return;
      const Vec2 q{pose_.x + c * x - s * y, pose_.y + s * x + c * y};
      double* slot = map.clearance().at_point(map.grid(), q) <= 0.2 ? mapped : unmapped;
      *slot = std::min(*slot, d);
    });
  }

  // Distance from the body's centre to the nearest laser return (infinite without a scan).
  double nearest_return(const RobotState& me) const {
    double best = 1e9;
    for_each_return(me, [&](double x, double y) { best = std::min(best, std::hypot(x, y)); });
    return best;
  }

  // Nothing the laser sees within the disc the body sweeps turning in place, and 3 cm (a disc
  // body sweeps nothing new turning: always clear).
  bool turn_clear(const RobotState& me) const {
    if (ctx_.body_half_width <= 0 || ctx_.body_half_width >= ctx_.robot_radius - 1e-3) return true;
    return nearest_return(me) >= ctx_.robot_radius + 0.03;
  }

  // The laser sees no rear; backing off is allowed only a short, slow way (the recovery's
  // 2 s at 0.15 m/s) and not when something is right beside the body.
  bool rear_clear(const RobotState& me) const {
    if (!me.scan) return true;
    const LaserScan& s = *me.scan;
    for (size_t i = 0; i < s.ranges.size(); ++i) {
      const double a = s.angle_min + static_cast<double>(i) * s.angle_increment;
      if (std::abs(a) < M_PI / 2 - 0.2) continue;
      if (s.ranges[i] < ctx_.robot_radius + 0.25) return false;
    }
    return true;
  }

  // Global localisation: drive along the free space, turning away from what is close.
  void explore(const RobotState& me, double* v, double* w) {
    const double ahead = clear_ahead(me);
    if (ahead < 0.8) {
      *v = 0;
      *w = 0.6;
    } else {
      *v = std::min(speed_, 0.4);
      *w = 0;
    }
  }

  // ---- Reports.
  void push_event(ModelCommand& cmd, const std::string& event, const std::string& detail) {
    send_report(cmd, event, detail);
  }

  void send_report(ModelCommand& cmd, const std::string& event, const std::string& detail) {
    RobotReport r;
    r.pose = pose_;
    if (mcl_) {
      const auto& e = mcl_->estimate();
      r.position_std = std::max(e.stddev.x, e.stddev.y);
      r.yaw_std = e.stddev.z;
      r.localized = localized() && e.converged;
    } else {
      r.localized = true;
    }
    r.mode = mode_;
    r.task_id = task_id_;
    r.event = event;
    r.detail = detail.empty() ? label_ : detail;
    if (goal_) r.goal = *goal_;
    else if (!event.empty() && last_goal_) r.goal = *last_goal_;
    r.path_length = std::max(0.0, planned_length_);
    r.cruise_speed = speed_;
    r.path = remaining_path();
    if (goal_) last_goal_ = goal_;
    cmd.report(r);
  }

  PluginContext ctx_;
  std::vector<Vec2> patrol_;
  bool loop_ = true;
  double speed_ = 0.4, tolerance_ = 0.3, lookahead_ = 0.6, gain_ = 2.0, safety_ = 0.45, map_safety_ = 0.1, slow_ = 1.2;
  double personal_space_ = 0.0;
  double keep_right_ = 0.0;
  SimTime keep_right_until_ = -1;
  SimTime replan_period_ = 0, blocked_wait_ = 0, stuck_time_ = 0, report_every_ = 0;
  int max_recoveries_ = 3;
  bool use_mcl_ = true, global_start_ = false;
  double crowd_range_ = 0;  // MCL's occlusion_range and beam_skip once localised
  bool crowd_skip_ = false;
  std::shared_ptr<const planning::TwoLevelPlanner> planner_;
  std::shared_ptr<const planning::MclMap> mcl_map_;
  planning::MclParams mcl_params_;
  std::unique_ptr<planning::MonteCarloLocalization> mcl_;

  // Run state.
  SimTime now_ = 0;
  Pose2 pose_, odom_at_estimate_;
  bool have_odom_ref_ = false;
  int64_t last_scan_stamp_ = -1;
  size_t next_patrol_ = 0;
  std::optional<Vec2> goal_, last_goal_;
  uint64_t task_id_ = 0;
  std::string label_;
  std::vector<Vec2> path_;
  size_t path_index_ = 0;
  bool avoiding_ = false, goal_announced_ = false, statically_checked_ = false, pass_through_ = false;
  SimTime last_plan_ = 0, progress_time_ = 0, blocked_since_ = -1;
  SimTime recovery_until_ = -1, recovery_backoff_end_ = -1;
  double progress_best_ = 1e18, planned_length_ = -1;
  int recoveries_ = 0, consecutive_failures_ = 0;
  SimTime retry_after_ = 0;
  PlanOutcome last_outcome_ = PlanOutcome::kNoPath;
  std::string last_detail_;
  std::string mode_ = "idle";
  SimTime next_report_ = 0;
};

}  // namespace vigil::plugins
