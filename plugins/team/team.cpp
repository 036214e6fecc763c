// team: a patrolling robot of a team (chapter 10.2, 10.6). It drives through the navigator
// (plugins/navigator/navigator.h: MCL, two-level planner, pure pursuit) and decides where to go
// with a patrol strategy over a patrol graph (planning/patrol/strategy.h), sharing with its
// team what it knows: team messages (world/plugin.h TeamMessage) that the transport carries,
// the run's team bus inside `vigil run`, DDS between processes. It never sees which.
//
// Messages it sends and understands:
//   hello  every `hello_period` s: position = its estimate, value = 1 while patrolling. A team
//          is the robots heard from in the last `member_timeout` s; it is formed after
//          `discovery_time` s and re-formed whenever a member joins, leaves or stops patrolling.
//   visit  when it passes a vertex (within `visit_radius` of its estimate): vertex, value = the
//          time, next_vertex = where it heads now, value2 = when it expects to get there.
// Tasks in its inbox (goto, cancel, stop) go to the navigator: a goto takes it off patrol
// ("respond") until the goal is reached or fails, then it rejoins.
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <tuple>

#include "planning/allocation/allocation.h"
#include "planning/allocation/token_passing.h"
#include "planning/patrol/strategy.h"
#include "plugins/navigator/navigator.h"
#include "plugins/plugin_export.h"

namespace vigil::plugins {
namespace {

namespace fs = std::filesystem;
using planning::patrol::PatrolGraph;
using planning::patrol::PatrolKnowledge;
using planning::patrol::PatrolSetup;

// One setup per graph file, map, planner and speed, shared by every robot of the process: the
// travel costs are the planner's path lengths between every pair of vertices.
Result<std::shared_ptr<const PatrolSetup>> shared_setup(const fs::path& file, const OccupancyGrid* map,
                                                        const planning::TwoLevelPlanner& planner, double speed,
                                                        const std::string& scenario, int line) {
  static std::mutex mu;
  // Keyed by the map's content, not its address (a freed map's address can come back for
  // another), and by the planner, which is itself shared per map (navigator.h).
  static std::map<std::tuple<std::string, uint64_t, const void*, long long>, std::shared_ptr<const PatrolSetup>> cache;
  const uint64_t which = map->fingerprint();
  std::lock_guard<std::mutex> lock(mu);
  auto key = std::make_tuple(fs::weakly_canonical(file).string(), which, static_cast<const void*>(&planner),
                             std::llround(speed * 1e6));
  if (auto it = cache.find(key); it != cache.end()) return it->second;
  auto g = PatrolGraph::read(file);
  if (!g) return g.error();
  planning::patrol::CostMatrix travel(g->size());
  for (size_t a = 0; a < g->size(); ++a) {
    const Vec2 p = g->vertex(a).position;
    if (!map->is_free(p)) {
      return bad_input(file.string(), 0, "vertex " + std::to_string(a),
                       "at (" + std::to_string(p.x) + ", " + std::to_string(p.y) + ") is not in the map's free space (" +
                           scenario + ":" + std::to_string(line) + ")");
    }
  }
  for (size_t a = 0; a < g->size(); ++a) {
    for (size_t b = a + 1; b < g->size(); ++b) {
      const auto r = planner.plan(g->vertex(a).position, g->vertex(b).position, nullptr);
      if (!planning::has_path(r.outcome)) {
        return bad_input(file.string(), 0, "vertex " + std::to_string(b),
                         "cannot be reached from vertex " + std::to_string(a) + " on the map: " +
                             planning::to_string(r.outcome) + ": " + r.detail);
      }
      travel.set(static_cast<int>(a), static_cast<int>(b), r.length);
    }
  }
  auto setup = PatrolSetup::make(std::move(*g), std::move(travel), speed);
  cache[key] = setup;
  return setup;
}

class Team : public Plugin {
 public:
  std::vector<ParamSpec> params() const override {
    // The navigator's own defaults hold: its localisation does not take a mate (or anyone) in
    // front of the laser for a sign of being lost (occlusion_range, beam_skip).
    std::vector<ParamSpec> p = nav_.params();
    const std::vector<ParamSpec> own = {
        {"graph", ParamType::kString, std::string(""), 0, 0, "patrol graph file (patrolling_sim format), relative to the scenario"},
        {"strategy", ParamType::kString, std::string("cyclic"), 0, 0, "cyclic | partition | greedy"},
        {"theta", ParamType::kNumber, 4.0, 0.0, 1000.0, "greedy: seconds of idleness one second of travel is worth"},
        {"visit_radius", ParamType::kNumber, 0.5, 0.1, 10.0, "a vertex is visited within this distance (m)"},
        {"reach_radius", ParamType::kNumber, 0.4, 0.05, 10.0,
         "a dead end's vertex (a leaf of the graph, where the robot turns round anyway) counts as reached within this distance of the estimate (m; at most visit_radius; other vertices: visit_radius): closer than the visit radius, so that the visit still counts with the estimate a little off"},
        {"discovery_time", ParamType::kNumber, 1.0, 0.0, 600.0, "listen this long for team mates before patrolling (s)"},
        {"hello_period", ParamType::kNumber, 0.2, 0.05, 60.0, "announce itself to the team this often (s)"},
        {"member_timeout", ParamType::kNumber, 5.0, 0.2, 3600.0, "a mate not heard from for this long leaves the team (s)"},
        {"standoff", ParamType::kNumber, 1.5, 0.3, 10.0, "respond: stop this far from the incident, facing it (m)"},
        {"guard_time", ParamType::kNumber, 60.0, 0.0, 36000.0, "respond: guard this long unless the incident is cancelled first (s)"},
        {"priorities", ParamType::kStringList, std::vector<std::string>{}, 0, 0,
         "incident priorities as KIND=N (larger first), e.g. [left_bag=3]; unset kinds keep the defaults (bag_taken 3, unauthorised_object 2, left_bag 1, exchange 0)"},
        {"picture_kinds", ParamType::kStringList, std::vector<std::string>{"bag_taken"}, 0, 0,
         "respond: incident kinds at which the robot takes a high-resolution picture once it faces the event"},
        {"accept_margin", ParamType::kNumber, 0.1, 0.0, 10.0, "token passing: keep a task within this share of the best estimated cost left"},
        {"spacing_hold", ParamType::kBool, false, 0, 0, "cyclic: wait at a vertex when the robot ahead is closer than the one behind"},
        {"spacing_pace", ParamType::kBool, true, 0, 0,
         "cyclic: slow down while nearer the mate ahead along the walk than the mate behind (the phases told in hello)"},
        {"pace_gain", ParamType::kNumber, 2.0, 0.0, 100.0, "cyclic: the pace's reaction to uneven spacing (share of speed per spacing of difference)"},
        {"min_pace", ParamType::kNumber, 0.3, 0.0, 1.0, "cyclic: the slowest share of cruise speed the pace asks for"},
        {"leaf_wait_distance", ParamType::kNumber, 0.0, 0.0, 20.0,
         "going into or out of a dead end (a leaf vertex), wait while a mate is this close in front (m; 0 = off)"},
        {"leaf_wait_time", ParamType::kNumber, 4.0, 0.0, 60.0, "the longest such wait for one mate (s)"},
        {"pace_band", ParamType::kNumber, 0.1, 0.0, 1.0, "cyclic: uneven spacing the pace tolerates (behind less ahead, share of the even spacing)"},
        {"pass_offset", ParamType::kNumber, 0.45, 0.0, 2.0, "keep this far right of the path when a mate comes the other way (m; 0 = off)"},
        {"pass_distance", ParamType::kNumber, 5.0, 0.5, 50.0, "a mate coming the other way this close starts the passing (m)"},
        {"min_region_walk", ParamType::kNumber, 3.0, 0.0, 1000.0,
         "partition: each robot's region walk at least this long where the graph allows (m): a robot shuttling between two vertices closer than about three visit radii never leaves one far enough for its next visit to count"},
        {"region_share_cost", ParamType::kNumber, 0.1, 0.0, 10.0,
         "partition: what robots sharing a region's walk lose to meeting each other, as a share of the walk per extra robot (large: a region each where the graph has room)"},
        {"region_detours", ParamType::kBool, true, 0, 0,
         "partition: a region shorter than min_region_walk is still a robot's own; on a leg too short to leave the last vertex behind the robot drives a loop off the graph (points 1.5 visit radii and more from both vertices) that passes straight through each vertex, so its visits count"},
    };
    p.insert(p.end(), own.begin(), own.end());
    return p;
  }

  Status configure(const ParamSet& p, const PluginContext& ctx) override {
    ctx_ = ctx;
    if (Status s = nav_.configure(p, ctx); !s) return s;
    const std::string graph = p.string("graph");
    if (graph.empty()) return bad_input(ctx.scenario_file, ctx.line, "params.graph", "a team robot needs a patrol graph");
    fs::path file = graph;
    if (file.is_relative()) file = fs::path(ctx.scenario_file).parent_path() / file;
    auto setup = shared_setup(file, ctx.map, nav_.planner(), nav_.cruise_speed(), ctx.scenario_file, ctx.line);
    if (!setup) {
      Error e = setup.error();
      if (e.file.empty()) e.file = ctx.scenario_file;
      e.message = "params.graph: " + e.message;
      return e;
    }
    setup_ = *setup;
    strategy_name_ = p.string("strategy");
    params_.theta = p.number("theta");
    params_.pace_gain = p.number("pace_gain");
    params_.min_pace = p.number("min_pace");
    params_.pace_band = p.number("pace_band");
    params_.min_region_walk = p.number("min_region_walk");
    params_.region_share_cost = p.number("region_share_cost");
    params_.region_detours = p.boolean("region_detours");
    spacing_pace_ = p.boolean("spacing_pace");
    leaf_wait_distance_ = p.number("leaf_wait_distance");
    leaf_wait_time_ = from_seconds(p.number("leaf_wait_time"));
    auto s = planning::patrol::make_strategy(strategy_name_, setup_, params_);
    if (!s) return bad_input(ctx.scenario_file, ctx.line, "params.strategy", s.error().message);
    visit_radius_ = p.number("visit_radius");
    reach_radius_ = std::min(visit_radius_, p.number("reach_radius"));
    discovery_ = from_seconds(p.number("discovery_time"));
    hello_every_ = from_seconds(p.number("hello_period"));
    member_timeout_ = from_seconds(p.number("member_timeout"));
    pass_offset_ = p.number("pass_offset");
    standoff_ = p.number("standoff");
    priorities_.clear();
    for (const std::string& kv : p.strings("priorities")) {
      const auto eq = kv.find('=');
      char* end = nullptr;
      const long v = eq == std::string::npos ? 0 : std::strtol(kv.c_str() + eq + 1, &end, 10);
      if (eq == std::string::npos || eq == 0 || end == kv.c_str() + eq + 1 || *end != '\0') {
        return bad_input(ctx.scenario_file, ctx.line, "params.priorities", "'" + kv + "' is not KIND=N");
      }
      priorities_[kv.substr(0, eq)] = static_cast<int>(v);
    }
    guard_time_ = from_seconds(p.number("guard_time"));
    picture_kinds_.clear();
    for (const std::string& k : p.strings("picture_kinds")) picture_kinds_.insert(k);
    token_params_.accept_margin = p.number("accept_margin");
    spacing_hold_ = p.boolean("spacing_hold");
    pass_distance_ = p.number("pass_distance");
    return Status::Ok();
  }

  void reset() override {
    nav_.reset();
    strategy_ = std::move(*planning::patrol::make_strategy(strategy_name_, setup_, params_));
    knowledge_ = PatrolKnowledge();
    knowledge_.last_visit.assign(setup_->graph.size(), 0.0);
    mates_.clear();
    team_.clear();
    formed_ = false;
    holding_ = false;
    yielding_ = false;
    on_leaf_edge_ = leaf_waiting_ = false;
    pace_ = 1.0;
    failed_at_ = -1;
    target_ = -1;
    last_at_ = -1;
    knowledge_.inside.assign(setup_->graph.size(), 0);
    next_hello_ = 0;
    role_ = "patrol";
    responding_ = false;
    pending_.clear();
    tokens_ = std::make_unique<planning::allocation::TokenAgent>(
        ctx_.model_id, token_params_, [this](const std::string& r, const planning::allocation::TokenTask& t) {
          return cost_for(r, t);
        });
    incidents_.clear();
    queue_.clear();
    handled_.clear();
    task_ = {};
    guard_until_ = -1;
    pictured_ = false;
  }

  void update(const WorldView& world, ModelCommand& cmd) override {
    now_ = world.time();
    knowledge_.now = to_seconds(now_);
    own_velocity_ = false;
    for (const TeamMessage& m : cmd.take_messages()) receive(m, cmd);
    for (RobotTask& t : cmd.take_tasks()) {
      if (t.kind == "incident" || t.kind == "cancel_incident") {
        on_incident(t, cmd);
        continue;
      }
      if (t.kind == "goto") {
        responding_ = true;
        role_ = "respond";
      } else if (t.kind == "cancel" || t.kind == "stop") {
        responding_ = false;
        role_ = "patrol";
        target_ = -1;
      }
      pending_.push_back(std::move(t));
    }
    tokens_->set_members(token_members());
    tokens_->tick(knowledge_.now);
    start_overdue_tokens();
    reopen_silent_keepers(cmd);
    release_lost_task(cmd);
    flush_tokens(cmd);
    take_kept(cmd);
    if (now_ >= next_hello_) {
      TeamMessage h;
      h.kind = "hello";
      h.position = nav_.pose().position();
      h.value = patrolling() ? 1 : 0;
      h.value2 = nav_.pose().yaw;
      // Cyclic: where I am along the shared walk (mm; -1: not on it), for the mates' pace.
      const double ph = my_phase();
      h.seq = ph >= 0 ? std::llround(ph * 1000.0) : -1;
      h.vertex = on_leaf_edge_ ? 1 : 0;  // going into or out of a dead end
      cmd.send(h);
      next_hello_ = now_ + hello_every_;
    }
    pace_ = 1.0;
    if (nav_.is_localized()) {
      pass_oncoming();
      note_visits();
      if (patrolling()) {
        update_team(cmd);
        if (formed_) patrol(cmd);
        if (yielding_ && back_off(cmd)) own_velocity_ = true;
        if (formed_ && spacing_pace_ && !yielding_ && !holding_) pace_ = team_pace();
        if (formed_ && !yielding_ && !holding_ && leaf_wait()) pace_ = 0.0;
      } else if (task_.id != 0) {
        own_velocity_ = respond(cmd);  // guarding: the velocity is ours this step
      }
    }
    struct Proxy : ModelCommand {
      ModelCommand* real;
      Team* self;
      void set_velocity(double v, double w) override {
        // The pace scales forward driving only (turning and backing off are left alone).
        if (!self->own_velocity_) real->set_velocity(v > 0 ? v * self->pace_ : v, w);
      }
      std::vector<RobotTask> take_tasks() override {
        std::vector<RobotTask> t;
        t.swap(self->pending_);
        return t;
      }
      void report(const RobotReport& r) override { self->forward(*real, r); }
      void send(const TeamMessage& m) override { real->send(m); }
      std::vector<TeamMessage> take_messages() override { return {}; }
    } proxy;
    proxy.real = &cmd;
    proxy.self = this;
    nav_.update(world, proxy);
  }

 private:
  bool patrolling() const { return !responding_; }

  void receive(const TeamMessage& m, ModelCommand& cmd) {
    if (m.kind == "token" || m.kind == "token_ack" || m.kind == "token_keep") {
      planning::allocation::TokenMessage t;
      t.kind = m.kind == "token" ? "token" : m.kind == "token_ack" ? "ack" : "keep";
      t.from = m.from;
      t.to = m.to;
      t.task.id = m.task;
      t.task.priority = m.vertex;
      t.task.where = m.position;
      const auto bar = m.text.find('|');
      t.task.kind = m.text.substr(0, bar);
      if (bar != std::string::npos) {
        std::string rest = m.text.substr(bar + 1);
        size_t a = 0;
        while (a < rest.size()) {
          const size_t b = rest.find(',', a);
          t.visited.push_back(rest.substr(a, b == std::string::npos ? std::string::npos : b - a));
          if (b == std::string::npos) break;
          a = b + 1;
        }
      }
      t.hop = m.seq;
      tokens_->receive(t, knowledge_.now);
      return;
    }
    if (m.kind == "task_done") {
      incidents_[m.task].done = true;
      tokens_->forget(m.task);
      return;
    }
    if (m.kind == "task_reopen") {
      // The keeper fell silent: a new token for the task follows from the sender. If that keeper
      // is me (the sender heard me too late), I let the task go and say why; the new token may
      // bring it back.
      if (task_.id == m.task) {
        cmd.report(base_report("task_released", task_.kind + " " + std::to_string(task_.id) + ": reopened by " + m.from +
                                                    " (it took " + m.text + " for silent)"));
        back_to_patrol();
      }
      tokens_->forget(m.task);
      handled_.erase(m.task);
      auto it = incidents_.find(m.task);
      if (it != incidents_.end()) it->second.started = true;  // the sender started it
      return;
    }
    if (m.kind == "hello") {
      Mate& mate = mates_[m.from];
      mate.where = m.position;
      mate.heard = now_;
      mate.patrolling = m.value > 0.5;
      mate.yaw = m.value2;
      mate.pose_time = m.sent;
      const double ph = m.seq >= 0 ? static_cast<double>(m.seq) / 1000.0 : -1;
      if (ph < 0 || mate.phase < 0 || std::abs(ph - mate.phase) > 0.3) {
        mate.phase = ph;
        mate.phase_moved = now_;
      }
      mate.on_leaf_edge = m.vertex == 1;
    } else if (m.kind == "visit") {
      knowledge_.visited(m.vertex, m.value);
      Mate& mate = mates_[m.from];
      mate.heard = now_;
      mate.where = m.position;
      knowledge_.others[m.from] = {m.next_vertex, m.value2, m.seq};
      // Two robots heading for one vertex (greedy): the later one chooses again.
      if (strategy_name_ == "greedy" && m.next_vertex == target_ && target_ >= 0) {
        const bool they_first = m.value2 < eta_ - 1e-6 || (std::abs(m.value2 - eta_) <= 1e-6 && m.from < ctx_.model_id);
        if (they_first) rechoose_ = true;
      }
    }
  }

  // The team: me and the mates heard from recently that are patrolling. Re-formed (shares
  // recomputed) when that set changes.
  void update_team(ModelCommand& cmd) {
    if (now_ < discovery_) return;
    std::vector<std::string> members{ctx_.model_id};
    for (const auto& [id, m] : mates_) {
      if (m.patrolling && now_ - m.heard <= member_timeout_) members.push_back(id);
    }
    for (auto it = knowledge_.others.begin(); it != knowledge_.others.end();) {
      if (std::find(members.begin(), members.end(), it->first) == members.end()) it = knowledge_.others.erase(it);
      else ++it;
    }
    std::sort(members.begin(), members.end());
    if (formed_ && members == team_) return;
    if (members != team_) {
      // Who patrols with me now (a mate joined, left or came back): a report, for the logs.
      std::string list;
      for (const auto& m : members) list += (list.empty() ? "" : ",") + m;
      cmd.report(base_report("team_formed", list));
    }
    team_ = members;
    std::vector<Vec2> where;
    int me = 0;
    for (size_t i = 0; i < members.size(); ++i) {
      if (members[i] == ctx_.model_id) {
        me = static_cast<int>(i);
        where.push_back(nav_.pose().position());
      } else {
        where.push_back(mates_[members[i]].where);
      }
    }
    strategy_->set_team(members, where, me);
    formed_ = true;
    holding_ = false;
    yielding_ = false;
    target_ = -1;
  }

  // ---- Response mode: incidents, token passing, respond, guard.
  // The team members tokens may go to: the patrolling team (me included while patrolling).
  std::vector<std::string> token_members() const {
    std::vector<std::string> m;
    if (patrolling()) m.push_back(ctx_.model_id);
    for (const auto& [id, mate] : mates_) {
      if (mate.patrolling && now_ - mate.heard <= member_timeout_) m.push_back(id);
    }
    std::sort(m.begin(), m.end());
    return m;
  }

  // Two keepers of one task resolve to one (token_passing.h): the other gives it up.
  void release_lost_task(ModelCommand& cmd) {
    if (task_.id == 0) return;
    const auto& kept = tokens_->kept();
    if (std::any_of(kept.begin(), kept.end(), [&](const auto& t) { return t.id == task_.id; })) return;
    cmd.report(base_report("task_released", task_.kind + " " + std::to_string(task_.id) + ": another robot keeps it"));
    back_to_patrol();
  }

  // Off the task, back on patrol (the team takes me in again at the next re-form).
  void back_to_patrol() {
    task_ = {};
    guard_until_ = -1;
    responding_ = false;
    role_ = "patrol";
    target_ = -1;
    formed_ = false;
    nav_.halt();
  }

  // Estimated time to serve a task: the planned path from where the robot is (mine exactly,
  // a mate's from its last hello) at cruise speed; infinite for a robot busy responding.
  double cost_for(const std::string& robot, const planning::allocation::TokenTask& t) const {
    Vec2 from;
    if (robot == ctx_.model_id) {
      if (!patrolling()) return std::numeric_limits<double>::infinity();
      from = nav_.pose().position();
    } else {
      auto it = mates_.find(robot);
      if (it == mates_.end() || !it->second.patrolling) return std::numeric_limits<double>::infinity();
      from = it->second.where;
    }
    const auto r = nav_.planner().plan(from, t.where, nullptr);
    return planning::has_path(r.outcome) ? r.length / std::max(0.05, nav_.cruise_speed())
                                         : std::numeric_limits<double>::infinity();
  }

  // An incident from the transport (every team robot gets it): the first patrolling member by
  // name starts its token; any other starts one if no keeper is known after 2 s (that member
  // may be silent; two tokens end with one keeper).
  void on_incident(const RobotTask& t, ModelCommand& cmd) {
    if (t.kind == "cancel_incident") {
      auto it = incidents_.find(t.id);
      if (it != incidents_.end()) it->second.cancelled = true;
      if (task_.id == t.id) end_response(cmd, "incident cancelled");
      return;
    }
    if (auto it = incidents_.find(t.id); it != incidents_.end()) {
      // The same incident again: the server's fused belief of where it is moved (another camera
      // saw it). The goal follows: a robot on its way re-aims its stand-off point when the
      // belief moved more than 0.25 m; a guarding one faces the new place.
      it->second.task.where = t.goal;
      if (task_.id == t.id) {
        const double moved = (t.goal - task_.where).norm();
        task_.where = t.goal;
        for (auto& q : queue_)
          if (q.id == t.id) q.where = t.goal;
        if (guard_until_ < 0 && moved > 0.25) {
          standoff_goal_ = standoff_point(t.goal);
          nav_.go_to(standoff_goal_, t.id, "incident " + std::to_string(t.id), false);
          cmd.report(base_report("incident_moved", task_.kind + " " + std::to_string(t.id)));
        }
      } else {
        for (auto& q : queue_)
          if (q.id == t.id) q.where = t.goal;
      }
      return;
    }
    Known k;
    auto pr = priorities_.find(t.label);
    k.task = {t.id, t.label, pr != priorities_.end() ? pr->second : planning::allocation::default_priority(t.label), t.goal};
    k.heard = now_;
    incidents_[t.id] = k;
    // The token's creator: the first by name of every robot heard (responding ones too).
    std::string first = ctx_.model_id;
    for (const auto& [id, mate] : mates_) {
      if (now_ - mate.heard <= member_timeout_ && id < first) first = id;
    }
    if (first == ctx_.model_id) {
      tokens_->create(k.task, knowledge_.now);
      incidents_[t.id].started = true;
    }
  }

  void start_overdue_tokens() {
    for (auto& [id, k] : incidents_) {
      if (k.started || k.cancelled || k.done || tokens_->keepers().count(id)) continue;
      if (now_ - k.heard >= from_seconds(2.0)) {
        tokens_->create(k.task, knowledge_.now);
        k.started = true;
      }
    }
  }

  // A mate that kept a task and has not been heard for `keeper_timeout`: the first patrolling
  // member by name reopens the task (everyone forgets the old token) and starts a new token.
  void reopen_silent_keepers(ModelCommand& cmd) {
    const auto members = token_members();
    if (members.empty() || members.front() != ctx_.model_id) return;
    for (auto& [id, k] : incidents_) {
      if (k.done || k.cancelled) continue;
      auto kp = tokens_->keepers().find(id);
      if (kp == tokens_->keepers().end() || kp->second == ctx_.model_id) continue;
      // A copy: forget() below erases the keeper's entry (reading it afterwards was a
      // use-after-free, found by AddressSanitizer).
      const std::string keeper = kp->second;
      auto mate = mates_.find(keeper);
      if (mate != mates_.end() && now_ - mate->second.heard <= keeper_timeout_) continue;
      TeamMessage m;
      m.kind = "task_reopen";
      m.task = id;
      m.text = keeper;
      cmd.send(m);
      tokens_->forget(id);
      handled_.erase(id);
      cmd.report(base_report("task_reopened", k.task.kind + " " + std::to_string(id) + ": " + keeper + " fell silent"));
      tokens_->create(k.task, knowledge_.now);
      k.started = true;
    }
  }

  void flush_tokens(ModelCommand& cmd) {
    for (const auto& t : tokens_->take_outbox()) {
      TeamMessage m;
      m.kind = t.kind == "token" ? "token" : t.kind == "ack" ? "token_ack" : "token_keep";
      m.to = t.to;
      m.task = t.task.id;
      m.vertex = t.task.priority;
      m.position = t.task.where;
      m.seq = t.hop;
      m.text = t.task.kind + "|";
      for (size_t i = 0; i < t.visited.size(); ++i) m.text += (i ? "," : "") + t.visited[i];
      cmd.send(m);
    }
  }

  // A task the token left with me: respond.
  void take_kept(ModelCommand& cmd) {
    // New tasks the token left with me, highest priority first; one of higher priority than
    // the task under way preempts it (that one goes back to the queue).
    std::vector<planning::allocation::TokenTask> fresh;
    for (const auto& t : tokens_->kept()) {
      if (!handled_.insert(t.id).second) continue;
      auto it = incidents_.find(t.id);
      if (it != incidents_.end() && it->second.cancelled) continue;
      fresh.push_back(t);
    }
    std::stable_sort(fresh.begin(), fresh.end(), [](const auto& a, const auto& b) { return a.priority > b.priority; });
    for (const auto& t : fresh) {
      if (task_.id != 0 && t.priority > task_.priority) {
        cmd.report(base_report("task_preempted", task_.kind + " " + std::to_string(task_.id) + " for " + t.kind + " " +
                                                     std::to_string(t.id)));
        queue_.push_back(task_);
        task_ = {};
      }
      if (task_.id != 0) {
        queue_.push_back(t);  // busy: served after the current one (highest priority first)
        continue;
      }
      start_task(t, cmd);
    }
  }

  void start_task(const planning::allocation::TokenTask& t, ModelCommand& cmd) {
    {
      task_ = t;
      responding_ = true;
      role_ = "respond";
      holding_ = yielding_ = false;
      guard_until_ = -1;
      pictured_ = false;
      standoff_goal_ = standoff_point(t.where);
      nav_.go_to(standoff_goal_, t.id, "incident " + std::to_string(t.id), false);
      RobotReport r = base_report("task_assigned", t.kind + " " + std::to_string(t.id));
      cmd.report(r);
    }
  }

  // Where to stop: `standoff` from the incident on the free side nearest to me.
  Vec2 standoff_point(Vec2 where) const {
    const Vec2 me = nav_.pose().position();
    const double base = std::atan2(me.y - where.y, me.x - where.x);
    const auto& g = nav_.planner().inflated();
    for (int k = 0; k < 16; ++k) {
      const double a = base + (k % 2 ? 1 : -1) * ((k + 1) / 2) * M_PI / 8;
      const Vec2 p = where + Vec2{std::cos(a), std::sin(a)} * standoff_;
      if (g.is_free(p)) return p;
    }
    return where;  // the planner moves a goal in an obstacle to the nearest free place
  }

  // Driving there, then guarding: true when this step's velocity is set here (facing).
  bool respond(ModelCommand& cmd) {
    if (guard_until_ < 0) {
      if (nav_.has_goal()) return false;
      if (nav_.mode() == "failed") {
        end_response(cmd, "could not reach the incident");
        return false;
      }
      // Arrived: guard.
      guard_until_ = now_ + guard_time_;
      role_ = "guard";
      nav_.halt();
      cmd.report(base_report("arrived_at_incident", task_.kind + " " + std::to_string(task_.id)));
    }
    if (now_ >= guard_until_) {
      end_response(cmd, "guard time over");
      return false;
    }
    // Face the incident (the disc turns in place).
    const Pose2 me = nav_.pose();
    const double err = wrap_angle(std::atan2(task_.where.y - me.y, task_.where.x - me.x) - me.yaw);
    const bool facing = std::abs(err) <= 0.05;
    cmd.set_velocity(0, facing ? 0.0 : std::clamp(2.0 * err, -ctx_.max_turn_rate, ctx_.max_turn_rate));
    // Facing it: the picture, once per response, for the kinds that want one. Whoever owns the
    // robot's camera takes it (world/runner.h RunObserver::on_report; plugins/stereo_camera/
    // robot_camera.h): the report carries the target (goal) and the incident (detail).
    if (facing && !pictured_ && picture_kinds_.count(task_.kind)) {
      pictured_ = true;
      RobotReport r = base_report("take_picture", task_.kind + " " + std::to_string(task_.id));
      r.goal = task_.where;
      cmd.report(r);
    }
    return true;
  }

  void end_response(ModelCommand& cmd, const std::string& why) {
    cmd.report(base_report("response_done", task_.kind + " " + std::to_string(task_.id) + ": " + why));
    TeamMessage done;
    done.kind = "task_done";
    done.task = task_.id;
    cmd.send(done);
    incidents_[task_.id].done = true;
    tokens_->forget(task_.id);
    back_to_patrol();
    // Next queued task, highest priority first (cancelled or done ones dropped).
    queue_.erase(std::remove_if(queue_.begin(), queue_.end(),
                                [&](const auto& q) { return incidents_[q.id].done || incidents_[q.id].cancelled; }),
                 queue_.end());
    if (!queue_.empty()) {
      auto best = std::max_element(queue_.begin(), queue_.end(),
                                   [](const auto& a, const auto& b) { return a.priority < b.priority; });
      const auto next = *best;
      queue_.erase(best);
      start_task(next, cmd);
    }
  }

  RobotReport base_report(const std::string& event, const std::string& detail) const {
    RobotReport r;
    r.pose = nav_.pose();
    r.localized = nav_.is_localized();
    std::tie(r.position_std, r.yaw_std) = nav_.uncertainty();
    r.mode = nav_.mode();
    r.role = role_;
    r.task_id = task_.id;
    r.event = event;
    r.detail = detail;
    r.goal = task_.id ? standoff_goal_ : Vec2{};
    r.cruise_speed = nav_.cruise_speed();
    r.path = nav_.planned_path();
    return r;
  }

  // Cyclic: how far along the shared walk I am (m), -1 off it (not patrolling, no target yet,
  // another strategy).
  double my_phase() const {
    if (!patrolling() || !formed_ || target_ < 0) return -1;
    const double rest = (setup_->graph.vertex(target_).position - nav_.pose().position()).norm();
    return strategy_->phase(rest);
  }

  // The share of cruise speed that evens the spacing out, from the phases the team members
  // told in their latest hellos (1.5 s old at most).
  double team_pace() const {
    const double mine = my_phase();
    if (mine < 0) return 1.0;
    std::vector<std::pair<std::string, double>> phases;
    for (const std::string& id : team_) {
      if (id == ctx_.model_id) continue;
      auto it = mates_.find(id);
      if (it == mates_.end() || it->second.phase < 0 || now_ - it->second.pose_time > from_seconds(1.5)) continue;
      // A mate stuck for a while (in a jam, recovering) is left out: waiting for it would
      // only pile the team up behind it.
      if (now_ - it->second.phase_moved > from_seconds(10.0)) continue;
      phases.push_back({id, it->second.phase});
    }
    return strategy_->pace(mine, phases);
  }

  // Going into or out of a dead end (a leaf vertex of the graph: a door, a room) with a mate
  // within `leaf_wait_distance` in front: wait (turning is still allowed) and let it go by along
  // the corridor first, rather than cross its lane and meet it face to face in the opening. At
  // most `leaf_wait_time` per mate in the way; a mate also on a dead-end edge goes first when its
  // name sorts first (so two never wait for each other).
  bool leaf_wait() {
    if (leaf_wait_distance_ <= 0 || target_ < 0) {
      leaf_waiting_ = false;
      return false;
    }
    auto leaf = [&](int v) { return v >= 0 && setup_->graph.vertex(static_cast<size_t>(v)).edges.size() == 1; };
    const bool minor = leaf(target_) || leaf(last_at_);
    const Pose2 me = nav_.pose();
    const Vec2 h{std::cos(me.yaw), std::sin(me.yaw)};
    std::string in_way;
    if (minor) {
      for (const auto& [id, m] : mates_) {
        if (m.pose_time < 0 || now_ - m.pose_time > from_seconds(1.5) || !m.patrolling) continue;
        const Vec2 r = m.where - me.position();
        const double d = r.norm();
        if (d > leaf_wait_distance_ || d < 1e-6 || h.dot(r) < 0.2 * d) continue;
        if (m.on_leaf_edge && id > ctx_.model_id) continue;  // on a dead-end edge too, and I sort first
        in_way = id;
        break;
      }
    }
    on_leaf_edge_ = minor;
    if (in_way.empty()) {
      leaf_waiting_ = false;
      return false;
    }
    if (!leaf_waiting_ || in_way != leaf_wait_for_) {
      leaf_waiting_ = true;
      leaf_wait_for_ = in_way;
      leaf_wait_until_ = now_ + leaf_wait_time_;
    }
    return now_ < leaf_wait_until_;
  }

  // A mate within 3 m: a robot standing in a corridor would be in its way.
  bool mate_close() const { return mate_within(3.0); }
  bool mate_within(double d) const {
    const Vec2 me = nav_.pose().position();
    for (const auto& [id, m] : mates_) {
      if (m.pose_time >= 0 && now_ - m.pose_time <= from_seconds(1.5) && (m.where - me).norm() < d) return true;
    }
    return false;
  }
  // A mate with precedence (its name sorts first) within 1.6 m in front of me.
  bool should_yield() const {
    const Pose2 me = nav_.pose();
    const Vec2 h{std::cos(me.yaw), std::sin(me.yaw)};
    for (const auto& [id, m] : mates_) {
      if (m.pose_time < 0 || now_ - m.pose_time > from_seconds(1.5) || !(id < ctx_.model_id)) continue;
      const Vec2 r = m.where - me.position();
      const double d = r.norm();
      if (d < 1.6 && h.dot(r) > 0.2 * d) return true;
    }
    return false;
  }

  // A mate coming the other way within `pass_distance`, in front of me and I in front of it:
  // both keep right (traffic rule: every robot applies it, so no one has to decide who yields).
  void pass_oncoming() {
    oncoming_ = false;
    if (pass_offset_ <= 0) return;
    const Pose2 me = nav_.pose();
    const Vec2 h{std::cos(me.yaw), std::sin(me.yaw)};
    for (const auto& [id, m] : mates_) {
      if (m.pose_time < 0 || now_ - m.pose_time > from_seconds(1.5)) continue;
      const Vec2 r = m.where - me.position();
      const double d = r.norm();
      if (d > pass_distance_ || d < 1e-6) continue;
      const Vec2 mh{std::cos(m.yaw), std::sin(m.yaw)};
      const bool facing = h.dot(mh) < -0.5 && h.dot(r) > 0.3 * d && mh.dot(r * -1.0) > 0.3 * d;
      if (facing) {
        nav_.keep_right(pass_offset_, 1.5);
        oncoming_ = true;
        return;
      }
    }
  }

  // Giving way with the way to the side spot blocked (the mate too close to turn away from):
  // back straight off, slowly, while the map behind is free and the mate is within 1.2 m.
  // True when this step's velocity is set here.
  bool back_off(ModelCommand& cmd) {
    if (nav_.mode() != "waiting" || !mate_within(1.2)) return false;
    const Pose2 me = nav_.pose();
    const Vec2 back{-std::cos(me.yaw), -std::sin(me.yaw)};
    if (!nav_.planner().inflated().is_free(me.position() + back * 0.3)) return false;
    cmd.set_velocity(-0.2, 0.0);
    return true;
  }

  // A visited vertex counts again only once the robot has gone beyond this distance of it.
  double rearm_radius() const { return 1.5 * visit_radius_; }

  // On to the current target vertex, keeping speed through it.
  void drive_to_target() {
    nav_.go_to(setup_->graph.vertex(target_).position, 0, "vertex " + std::to_string(target_), true);
  }

  // Vertices passed (entered within the visit radius of the estimate), told to the team.
  void note_visits() {
    const Vec2 p = nav_.pose().position();
    for (size_t i = 0; i < setup_->graph.size(); ++i) {
      const double d = (setup_->graph.vertex(i).position - p).norm();
      if (!knowledge_.inside[i] && d <= visit_radius_) {
        knowledge_.inside[i] = 1;
        knowledge_.visited(static_cast<int>(i), knowledge_.now);
        visited_now_.push_back(static_cast<int>(i));
      } else if (knowledge_.inside[i] && d > rearm_radius()) {
        knowledge_.inside[i] = 0;
      }
    }
  }

  void tell_visit(ModelCommand& cmd, int vertex) {
    TeamMessage m;
    m.kind = "visit";
    m.vertex = vertex;
    m.value = knowledge_.now;
    m.next_vertex = target_;
    m.value2 = eta_;
    m.seq = strategy_->walk_index();
    m.position = nav_.pose().position();
    cmd.send(m);
  }

  void head_for(int v, ModelCommand& cmd, int visited) {
    target_ = v;
    const Vec2 goal = setup_->graph.vertex(v).position;
    const Vec2 p = nav_.pose().position();
    eta_ = knowledge_.now + (last_at_ >= 0 ? setup_->travel(last_at_, v) : (goal - p).norm()) / setup_->speed;
    detour_.clear();
    if (last_at_ >= 0 && v >= 0 && strategy_->short_walk()) detour_ = detour_points(setup_->graph.vertex(last_at_).position, goal);
    if (!detour_.empty()) {
      double len = (detour_.front() - p).norm() + (goal - detour_.back()).norm();
      for (size_t i = 1; i < detour_.size(); ++i) len += (detour_[i] - detour_[i - 1]).norm();
      eta_ = knowledge_.now + len / setup_->speed;
      nav_.go_to(detour_.front(), 0, "detour to vertex " + std::to_string(v), true);
    } else {
      nav_.go_to(goal, 0, "vertex " + std::to_string(v), true);
    }
    tell_visit(cmd, visited);
  }

  // A leg from `a` to `b` too short to leave `a` behind (a visit of `a` counts again only after
  // the robot has gone beyond 1.5 visit radii of it; reaching `b` within the visit radius may
  // not take it that far): a way round off the graph, at least that far from both vertices.
  // First choice, a loop beside the leg: out from `a` square to the leg on its left, along, and
  // in to `b`; the way back (left of the return leg) is the other side, so a robot going back
  // and forth drives round a rectangle and passes through each vertex in a straight line (its
  // visits count with the estimate a little off). Else the mirror image; else one point beside
  // the leg's middle, either side; else one beyond `b`. Each point free for the robot and in
  // sight of the one before, with room round it. Empty when the leg is long enough or nothing
  // is free.
  std::vector<Vec2> detour_points(Vec2 a, Vec2 b) const {
    const double rearm = rearm_radius() + 0.2;
    const double d = (b - a).norm();
    if (d - visit_radius_ >= rearm) return {};
    const Vec2 u = d > 1e-6 ? (b - a) * (1.0 / d) : Vec2{1.0, 0.0};
    const Vec2 left{-u.y, u.x};
    const auto& grid = nav_.planner().inflated();
    // Room round a point: the navigator's forward check stops short of walls the planner's
    // inflation allows, so a point hugging a wall may never be reached.
    auto roomy = [&](Vec2 q) {
      constexpr double kRoom = 0.35;
      return grid.is_free(q) && grid.is_free(q + Vec2{kRoom, 0}) && grid.is_free(q - Vec2{kRoom, 0}) &&
             grid.is_free(q + Vec2{0, kRoom}) && grid.is_free(q - Vec2{0, kRoom});
    };
    auto free_way = [&](const std::vector<Vec2>& pts) {
      Vec2 from = a;
      for (const Vec2& q : pts) {
        if (!roomy(q) || !grid.segment_free(from, q)) return false;
        from = q;
      }
      return grid.segment_free(from, b);
    };
    for (const double side : {1.0, -1.0}) {
      const Vec2 off = left * (side * rearm);
      std::vector<Vec2> pts{a + off};
      if (d > 1e-6) pts.push_back(b + off);
      if (free_way(pts)) return pts;
    }
    const Vec2 mid = (a + b) * 0.5;
    const double h = std::sqrt(std::max(0.0, rearm * rearm - 0.25 * d * d));
    for (const Vec2 c : {mid + left * h, mid - left * h, b + u * rearm}) {
      if (free_way({c})) return {c};
    }
    return {};
  }

  void patrol(ModelCommand& cmd) {
    const Vec2 p = nav_.pose().position();
    // Visits on the way (not the target) are told with the current target.
    for (int v : visited_now_) {
      if (v != target_) tell_visit(cmd, v);
    }
    // Reached: within the reach radius, or the navigator stopped there (a vertex it could not
    // get closer to) within the visit radius.
    const double to_target = target_ >= 0 ? (setup_->graph.vertex(target_).position - p).norm() : 1e9;
    const bool leaf = target_ >= 0 && setup_->graph.vertex(static_cast<size_t>(target_)).edges.size() == 1;
    // A mate standing on it (within the visit radius: it visits it now) while I am close:
    // reached too, rather than wait for it to move off the vertex.
    bool taken = false;
    if (target_ >= 0 && to_target <= 2.0) {
      const Vec2 tv = setup_->graph.vertex(static_cast<size_t>(target_)).position;
      for (const auto& [id, m] : mates_) {
        if (m.pose_time >= 0 && now_ - m.pose_time <= from_seconds(0.5) && (m.where - tv).norm() <= visit_radius_) taken = true;
      }
    }
    const bool reached = detour_.empty() && target_ >= 0 &&
                         (to_target <= (leaf ? reach_radius_ : visit_radius_) || taken ||
                          (!nav_.has_goal() && nav_.mode() != "failed" && to_target <= visit_radius_));
    visited_now_.clear();
    if (!detour_.empty() && target_ >= 0) {
      // Round each detour point (passed within 0.3 m, or the navigator stopped or gave it up),
      // then on to the vertex.
      if ((detour_.front() - p).norm() <= 0.3 || !nav_.has_goal()) {
        detour_.erase(detour_.begin());
        if (!detour_.empty()) {
          nav_.go_to(detour_.front(), 0, "detour to vertex " + std::to_string(target_), true);
        } else {
          drive_to_target();
        }
      }
      return;
    }
    if (target_ < 0) {
      last_at_ = -1;
      head_for(strategy_->next(-1, p, knowledge_), cmd, -1);
      return;
    }
    // Face to face with a mate and both stopped: the one whose name sorts later gives way,
    // backing off to the side, and resumes once the other has gone by.
    if (yielding_) {
      const bool there = (yield_spot_ - p).norm() < 0.35 || !nav_.has_goal();
      // Resumed once no mate is within 2 m: at the spot, or a second on (the mate may have gone
      // by before the spot is reached: waiting on for the spot would only lose time).
      const bool clear = !mate_within(2.0) && (there || now_ - yield_from_ >= from_seconds(1.0));
      if (now_ < yield_until_ && !clear) return;
      yielding_ = false;
      detour_.clear();
      drive_to_target();
      return;
    }
    if (nav_.mode() == "waiting" && should_yield()) {
      const Pose2 me = nav_.pose();
      const Vec2 h{std::cos(me.yaw), std::sin(me.yaw)}, right{h.y, -h.x};
      for (const Vec2 off : {h * -1.2 + right * 0.6, h * -1.2, h * -1.2 - right * 0.6, right * 0.8, right * -0.8}) {
        const Vec2 spot = p + off;
        if (nav_.planner().inflated().is_free(spot) && nav_.planner().inflated().segment_free(p, spot)) {
          yielding_ = true;
          yield_spot_ = spot;
          yield_from_ = now_;
          yield_until_ = now_ + from_seconds(8.0);
          nav_.go_to(spot, 0, "giving way", false);
          return;
        }
      }
    }
    if (holding_) {
      // Waiting at a vertex for the spacing to even out (the strategy says how long).
      // A mate coming the other way would have to squeeze past: go on instead.
      if (strategy_->hold(knowledge_) > 0.25 && now_ < hold_until_ && !mate_close()) return;
      holding_ = false;
      detour_.clear();
      drive_to_target();
      eta_ = knowledge_.now + setup_->travel(last_at_, target_) / setup_->speed;
      tell_visit(cmd, -1);
      return;
    }
    if (reached) {
      last_at_ = target_;
      head_for(strategy_->next(target_, p, knowledge_), cmd, last_at_);
      const double h = spacing_hold_ ? strategy_->hold(knowledge_) : 0.0;
      if (h > 0.25 && !mate_close()) {
        holding_ = true;
        hold_until_ = now_ + from_seconds(h);
        nav_.halt();
        eta_ += h;
        tell_visit(cmd, -1);
      }
      return;
    }
    // The navigator gave the vertex up: pass over it, after a pause (a robot that cannot plan
    // from where it is would otherwise retry every step).
    if (!nav_.has_goal() && nav_.mode() == "failed") {
      if (failed_at_ < 0) failed_at_ = now_;
      if (now_ - failed_at_ < from_seconds(2.0)) return;
      failed_at_ = -1;
      last_at_ = -1;
      head_for(strategy_->next(target_, p, knowledge_), cmd, -1);
      return;
    }
    if (rechoose_) {
      rechoose_ = false;
      const int before = target_;
      const int nv = strategy_->next(last_at_, p, knowledge_);
      if (nv != before) head_for(nv, cmd, -1);
    }
  }

  void forward(ModelCommand& cmd, const RobotReport& r) {
    RobotReport out = r;
    out.role = role_;
    if (responding_ && task_.id == 0 && (r.event == "goal_reached" || r.event == "goal_failed") && r.task_id != 0) {
      // Back to patrol; the team takes me in again.
      responding_ = false;
      role_ = "patrol";
      target_ = -1;
      formed_ = false;
    }
    cmd.report(out);
  }

  struct Mate {
    Vec2 where;
    SimTime heard = 0;
    bool patrolling = true;
    double yaw = 0;
    SimTime pose_time = -1;  // when `where` and `yaw` were measured (hello only)
    double phase = -1;       // cyclic: along the shared walk (m; -1: not on it)
    SimTime phase_moved = 0; // when its phase last moved on by more than 0.3 m
    bool on_leaf_edge = false;
  };

  Navigator nav_;
  PluginContext ctx_;
  std::shared_ptr<const PatrolSetup> setup_;
  std::string strategy_name_;
  planning::patrol::StrategyParams params_;
  std::unique_ptr<planning::patrol::PatrolStrategy> strategy_;
  std::vector<Vec2> detour_;  // a short region's leg: the points rounded before the vertex
  double visit_radius_ = 0.5, reach_radius_ = 0.4, pass_offset_ = 0.45, pass_distance_ = 5.0;
  SimTime discovery_ = 0, hello_every_ = 0, member_timeout_ = 0;

  SimTime now_ = 0, next_hello_ = 0;
  PatrolKnowledge knowledge_;
  std::map<std::string, Mate> mates_;
  std::vector<std::string> team_;
  bool formed_ = false, responding_ = false, rechoose_ = false, holding_ = false, oncoming_ = false;
  bool spacing_hold_ = true, yielding_ = false, spacing_pace_ = true;
  double pace_ = 1.0;
  bool on_leaf_edge_ = false, leaf_waiting_ = false;
  std::string leaf_wait_for_;
  SimTime leaf_wait_until_ = 0, leaf_wait_time_ = 0;
  double leaf_wait_distance_ = 0.0;
  Vec2 yield_spot_;
  SimTime yield_until_ = 0, yield_from_ = 0;
  SimTime hold_until_ = 0, failed_at_ = -1;
  int target_ = -1, last_at_ = -1;
  double eta_ = 0;
  std::vector<int> visited_now_;
  std::string role_ = "patrol";
  std::vector<RobotTask> pending_;
  // Response.
  struct Known {
    planning::allocation::TokenTask task;
    SimTime heard = 0;
    bool started = false, cancelled = false, done = false;
  };
  std::vector<planning::allocation::TokenTask> queue_;
  std::map<std::string, int> priorities_;
  SimTime keeper_timeout_ = from_seconds(2.0);
  planning::allocation::TokenParams token_params_;
  std::unique_ptr<planning::allocation::TokenAgent> tokens_;
  std::map<uint64_t, Known> incidents_;
  std::set<uint64_t> handled_;  // kept tasks already started or queued
  planning::allocation::TokenTask task_;
  Vec2 standoff_goal_;
  double standoff_ = 1.5;
  SimTime guard_time_ = 0, guard_until_ = -1;
  std::set<std::string> picture_kinds_;
  bool pictured_ = false;
  bool own_velocity_ = false;
};

}  // namespace
}  // namespace vigil::plugins

VIGIL_PLUGIN(team, vigil::plugins::Team)
