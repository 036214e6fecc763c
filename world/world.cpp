#include "world/world.h"

#include <box2d/box2d.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "world/floorplan.h"

namespace vigil {
namespace {

constexpr double kReach = 0.9;             // m from a person's centre to an object they handle
constexpr double kArrive = 0.12;           // m: a path point counts as reached
constexpr double kPersonClearance = 0.30;  // m kept from walls on planned paths
constexpr SimTime kStuckWindow = 2 * kNsPerSecond;
constexpr double kStalledArrive = 0.4;     // m: held this near the last point for a stuck window: arrived
constexpr double kDefaultHandSeconds = 1.0;

bool is_bag(const ObjectEntity& o) { return o.spec.kind == ObjectKind::kBag; }

// Body tags in Box2D's user data, so contacts name what a robot touched (0: the walls).
enum : uintptr_t { kTagRobot = 1, kTagPerson = 2, kTagObject = 3 };
uintptr_t body_tag(uintptr_t kind, size_t index) { return (kind << 32) | (index + 1); }

Vec2 rotate(Vec2 v, double yaw) {
  const double c = std::cos(yaw), s = std::sin(yaw);
  return {c * v.x - s * v.y, s * v.x + c * v.y};
}

}  // namespace

const char* to_string(EntityKind k) {
  switch (k) {
    case EntityKind::kRobot: return "robot";
    case EntityKind::kPerson: return "person";
    case EntityKind::kObject: return "object";
  }
  return "?";
}

Pose2 RobotEntity::laser_pose() const {
  const Vec2 off = rotate({model.laser_offset.x, model.laser_offset.y}, pose.yaw);
  return {pose.x + off.x, pose.y + off.y, pose.yaw};
}

World::~World() {
  // Plugins must go before the registry that may hold their shared library open.
  for (auto& r : robots_) r.controller.reset();
}

size_t World::plugin_count() const {
  size_t n = 0;
  for (const auto& r : robots_) n += r.controller != nullptr;
  return n;
}

std::optional<Vec2> World::place(const std::string& name) const {
  auto it = scenario_.places.find(name);
  if (it == scenario_.places.end()) return std::nullopt;
  return it->second;
}

const RobotState* World::robot(const std::string& id) const {
  for (const auto& r : robots_)
    if (r.spec.id == id) return &r.state;
  return nullptr;
}

int World::find_object(const std::string& id) const {
  for (size_t i = 0; i < objects_.size(); ++i)
    if (objects_[i].spec.id == id) return static_cast<int>(i);
  return -1;
}

int World::find_person(const std::string& id) const {
  for (size_t i = 0; i < people_.size(); ++i)
    if (people_[i].spec.id == id) return static_cast<int>(i);
  return -1;
}

Result<std::unique_ptr<World>> World::create(const Scenario& scenario, const WorldOptions& options) {
  std::unique_ptr<World> w(new World());
  w->scenario_ = scenario;
  if (Status s = w->build(options); !s) return s.error();
  return w;
}

Status World::build(const WorldOptions& options) {
  const std::string file = scenario_.file.string();
  if (!(scenario_.physics_rate_hz > 0)) return bad_input(file, 0, "physics_rate_hz", "must be positive");
  dt_ = std::max<SimTime>(1, static_cast<SimTime>(std::llround(1e9 / scenario_.physics_rate_hz)));
  end_time_ = from_seconds(scenario_.duration);

  // Map and walls.
  const std::string map_name = scenario_.map.filename().string();
  if (map_name.size() > 15 && map_name.ends_with(".floorplan.yaml")) {
    auto fp = load_floorplan(scenario_.map);
    if (!fp) return fp.error();
    map_ = fp->rasterize();
    furniture_ = fp->furniture;
  } else {
    auto grid = load_map(scenario_.map);
    if (!grid) return grid.error();
    map_ = std::move(*grid);
  }
  prepare_simulation_map(&map_);
  walls_ = extract_wall_boxes(map_);
  double max_person_radius = 0.25;
  for (const auto& p : scenario_.people) max_person_radius = std::max(max_person_radius, p.radius);
  person_paths_ = std::make_unique<planning::GridPathPlanner>(map_, std::max(kPersonClearance, max_person_radius + 0.05));

  b2_ = std::make_unique<b2World>(b2Vec2(0.0f, 0.0f));
  {
    b2BodyDef def;  // one static body holds every wall rectangle
    b2Body* walls = b2_->CreateBody(&def);
    for (const auto& box : walls_) {
      b2PolygonShape shape;
      const b2Vec2 c(static_cast<float>((box.min.x + box.max.x) / 2), static_cast<float>((box.min.y + box.max.y) / 2));
      shape.SetAsBox(static_cast<float>((box.max.x - box.min.x) / 2), static_cast<float>((box.max.y - box.min.y) / 2), c, 0.0f);
      walls->CreateFixture(&shape, 0.0f);
    }
  }
  bodies_index_ = std::make_unique<ObstacleIndex>(
      Vec2{map_.origin().x, map_.origin().y},
      Vec2{map_.origin().x + map_.size_x(), map_.origin().y + map_.size_y()}, 1.0);

  wall_rays_ = std::make_unique<WallRaycaster>(map_);

  // Robots.
  registry_ = options.plugins;
  if (registry_) {
    for (const auto& d : options.plugin_dirs) registry_->add_search_dir(d);
    if (options.prefer_shared_plugins) registry_->set_prefer_shared(true);
  }
  robots_.resize(scenario_.robots.size());
  for (size_t i = 0; i < scenario_.robots.size(); ++i) {
    RobotEntity& r = robots_[i];
    r.spec = scenario_.robots[i];
    const std::string key = "robots[" + std::to_string(i) + "]";
    auto model = load_robot_model(r.spec.urdf);
    if (!model) {
      Error e = model.error();
      e.message = "robot '" + r.spec.id + "' (" + file + ":" + std::to_string(r.spec.line) + "): " + e.message;
      return e;
    }
    r.model = *model;
    r.rng = Rng::stream(scenario_.seed, "robot:" + r.spec.id);
    const auto& od = r.spec.odometry;
    r.odom_bias_x = od.error_x > 0 ? r.rng.uniform(-od.error_x, od.error_x) : 0;
    r.odom_bias_y = od.error_y > 0 ? r.rng.uniform(-od.error_y, od.error_y) : 0;
    r.odom_bias_yaw = od.error_yaw > 0 ? r.rng.uniform(-od.error_yaw, od.error_yaw) : 0;
    r.state.id = r.spec.id;
    r.pose = r.spec.start;
    r.state.odometry = r.spec.start;
    r.state.scan = r.spec.ranger.enabled ? &r.scan : nullptr;

    b2BodyDef def;
    def.type = b2_dynamicBody;
    def.position.Set(static_cast<float>(r.spec.start.x), static_cast<float>(r.spec.start.y));
    def.angle = static_cast<float>(r.spec.start.yaw);
    def.userData.pointer = body_tag(kTagRobot, i);
    r.body = b2_->CreateBody(&def);
    b2FixtureDef fix;
    fix.density = 20.0f;
    fix.friction = 0.3f;
    b2PolygonShape poly;
    b2CircleShape circle;
    const b2Vec2 off(static_cast<float>(r.model.footprint_offset.x), static_cast<float>(r.model.footprint_offset.y));
    if (r.model.footprint == FootprintShape::kBox) {
      poly.SetAsBox(static_cast<float>(r.model.half_x), static_cast<float>(r.model.half_y), off, 0.0f);
      fix.shape = &poly;
    } else {
      circle.m_radius = static_cast<float>(r.model.radius);
      circle.m_p = off;
      fix.shape = &circle;
    }
    r.body->CreateFixture(&fix);

    if (!r.spec.controller.empty() && options.controllers) {
      if (!registry_) {
        return bad_input(file, r.spec.line, key + ".controller",
                         "no plugin registry was given to the world to create '" + r.spec.controller + "'");
      }
      auto plugin = registry_->create(r.spec.controller);
      if (!plugin) {
        return bad_input(file, r.spec.line, key + ".controller", plugin.error().message);
      }
      r.controller = std::move(*plugin);
      auto params = resolve_params(r.controller->params(), r.spec.params, file, key + ".params");
      if (!params) return params.error();
      PluginContext ctx;
      ctx.model_id = r.spec.id;
      ctx.scenario_file = file;
      ctx.line = r.spec.line;
      ctx.map = &map_;
      ctx.places = &scenario_.places;
      ctx.seed = Rng::stream(scenario_.seed, "plugin:" + r.spec.id).next();
      ctx.laser_mount = {r.model.laser_offset.x, r.model.laser_offset.y, 0.0};
      ctx.robot_radius = r.model.radius + r.model.footprint_offset.norm();
      ctx.body_half_width = (r.model.footprint == FootprintShape::kBox ? r.model.half_y : r.model.radius) +
                            std::abs(r.model.footprint_offset.y);
      ctx.max_speed = r.spec.max_speed;
      ctx.max_turn_rate = r.spec.max_turn_rate;
      ctx.start = r.spec.start;
      ctx.laser_range_max = r.spec.ranger.enabled ? r.spec.ranger.range_max : 0.0;
      ctx.cache_dir = options.cache_dir;
      if (Status s = r.controller->configure(*params, ctx); !s) return s;
      r.controller->reset();
    }
  }

  // People (bodies are made when they appear).
  people_.resize(scenario_.people.size());
  for (size_t i = 0; i < people_.size(); ++i) {
    people_[i].spec = scenario_.people[i];
    people_[i].pose = {people_[i].spec.start.point.x, people_[i].spec.start.point.y, 0};
  }

  // Objects.
  objects_.resize(scenario_.objects.size());
  for (size_t i = 0; i < objects_.size(); ++i) {
    ObjectEntity& o = objects_[i];
    o.spec = scenario_.objects[i];
    if (!o.spec.carried_by.empty()) {
      o.carrier = find_person(o.spec.carried_by);
      if (o.carrier < 0) {
        return bad_input(file, o.spec.line, "objects[" + std::to_string(i) + "].carried_by",
                         "no person '" + o.spec.carried_by + "'");
      }
      people_[o.carrier].carrying.push_back(static_cast<int>(i));
      o.last_carrier = o.spec.carried_by;
      o.present = false;  // until the carrier appears
    } else {
      o.pose = {o.spec.position.point.x, o.spec.position.point.y, 0};
      std::string furniture;
      o.z = object_height_at(o.pose.position(), &furniture);
      if (furniture.empty()) place_object_on_floor(static_cast<int>(i), o.pose.position());
    }
  }
  return Status::Ok();
}

double World::object_height_at(Vec2 where, std::string* furniture) const {
  // Objects standing inside a table's footprint stand on it.
  for (const auto& f : furniture_) {
    const Vec2 rel = rotate(where - f.pose.position(), -f.pose.yaw);
    if (std::abs(rel.x) <= f.size_x / 2 && std::abs(rel.y) <= f.size_y / 2) {
      if (furniture) *furniture = f.name;
      return f.height;
    }
  }
  if (furniture) furniture->clear();
  return 0.0;
}

void World::place_object_on_floor(int oi, Vec2 where) {
  ObjectEntity& o = objects_[oi];
  remove_object_body(oi);
  o.pose = {where.x, where.y, o.pose.yaw};
  std::string furniture;
  o.z = object_height_at(where, &furniture);
  if (!furniture.empty()) return;  // on a table: the table is already an obstacle
  b2BodyDef def;
  def.type = b2_staticBody;
  def.position.Set(static_cast<float>(where.x), static_cast<float>(where.y));
  def.angle = static_cast<float>(o.pose.yaw);
  def.userData.pointer = body_tag(kTagObject, static_cast<size_t>(oi));
  o.body = b2_->CreateBody(&def);
  b2PolygonShape shape;
  shape.SetAsBox(static_cast<float>(o.spec.size_x / 2), static_cast<float>(o.spec.size_y / 2));
  o.body->CreateFixture(&shape, 0.0f);
}

void World::remove_object_body(int oi) {
  ObjectEntity& o = objects_[oi];
  if (o.body) {
    b2_->DestroyBody(o.body);
    o.body = nullptr;
  }
}

Status World::plan_walk(int i, Vec2 goal, int line, const std::string& what) {
  PersonEntity& p = people_[i];
  p.path = person_paths_->plan(p.pose.position(), goal);
  if (p.path.empty()) {
    return bad_input(scenario_.file.string(), line, "people[" + std::to_string(i) + "].script",
                     "person '" + p.spec.id + "' cannot reach " + what + " from (" +
                         std::to_string(p.pose.x) + ", " + std::to_string(p.pose.y) + ")");
  }
  p.path_index = p.path.size() > 1 ? 1 : 0;
  p.phase = PersonEntity::Phase::kWalking;
  p.stalled_at_goal = false;
  p.progress_check = time_ + kStuckWindow;
  p.progress_distance = (p.path.back() - p.pose.position()).norm();
  return Status::Ok();
}

std::optional<Vec2> World::approach_point(int i, Vec2 target) const {
  // A free spot within reach of the target, on the person's side first.
  const PersonEntity& p = people_[i];
  const double need = std::max(kPersonClearance, p.spec.radius + 0.05);
  const double base = std::atan2(p.pose.y - target.y, p.pose.x - target.x);
  for (double r : {0.6, 0.75, 0.88}) {
    for (int k = 0; k < 24; ++k) {
      const int step = (k + 1) / 2 * (k % 2 ? 1 : -1);
      const double a = base + step * (2 * M_PI / 24);
      const Vec2 c{target.x + r * std::cos(a), target.y + r * std::sin(a)};
      if (person_paths_->clearance_at(c) >= need) return c;
    }
  }
  return std::nullopt;
}

bool PersonEntity::handling() const {
  if (phase != Phase::kActing || approaching || step_index >= spec.script.size()) return false;
  const ActionKind k = spec.script[step_index].kind;
  return k == ActionKind::kPickUp || k == ActionKind::kPutDown || k == ActionKind::kTouch;
}

namespace {
// Where a put-down without a place sets the thing down: where it hangs (bags, at the side) or
// just in front (things held in front), out of the person's own way.
Vec2 put_down_spot(const PersonEntity& p, const ObjectEntity& o) {
  const Vec2 off = is_bag(o) ? Vec2{0.0, -(p.spec.radius + 0.2)} : Vec2{p.spec.radius + 0.2, 0.0};
  return p.pose.position() + rotate(off, p.pose.yaw);
}

// A person about to use their hands turns to what they reach for.
void face(PersonEntity& p, Vec2 target) {
  const Vec2 d = target - p.pose.position();
  if (d.norm() > 0.05) p.pose.yaw = std::atan2(d.y, d.x);
}
}  // namespace

Status World::start_action(int i) {
  PersonEntity& p = people_[i];
  const Action& a = p.spec.script[p.step_index];
  p.approaching = false;
  auto act_for = [&](double seconds) {
    p.phase = PersonEntity::Phase::kActing;
    p.phase_end = time_ + from_seconds(seconds);
  };
  switch (a.kind) {
    case ActionKind::kWalkTo:
    case ActionKind::kLeave:
      return plan_walk(i, a.target.point, a.line,
                       a.target.place.empty() ? "the target point" : "place '" + a.target.place + "'");
    case ActionKind::kWait:
      act_for(a.duration);
      return Status::Ok();
    case ActionKind::kPickUp:
    case ActionKind::kTouch:
    case ActionKind::kPutDown: {
      const int oi = find_object(a.object);
      if (oi < 0) return bad_input(scenario_.file.string(), a.line, "object", "no object '" + a.object + "'");
      const ObjectEntity& o = objects_[oi];
      if (a.kind == ActionKind::kPutDown && o.carrier != i) {
        return bad_input(scenario_.file.string(), a.line, "put_down",
                         "person '" + p.spec.id + "' is not carrying '" + a.object + "' at this point");
      }
      if (a.kind != ActionKind::kPutDown && (o.carrier >= 0 || !o.present)) {
        return bad_input(scenario_.file.string(), a.line, to_string(a.kind),
                         "object '" + a.object + "' is not lying anywhere at this point (carried or gone)");
      }
      // A put-down without a place sets the thing down where it hangs (finish_action): the hand
      // goes there, and the person does not turn (which would move the spot).
      const bool in_place = a.kind == ActionKind::kPutDown && !a.has_target;
      const Vec2 target = a.kind != ActionKind::kPutDown ? o.pose.position()
                          : a.has_target               ? a.target.point
                                                       : put_down_spot(p, o);
      const double hand = a.duration > 0 ? a.duration : kDefaultHandSeconds;
      // The hand goes to the object's top, or to where it will stand once put down.
      p.reach_target = target;
      p.reach_z = (a.kind == ActionKind::kPutDown ? object_height_at(target, nullptr) : o.z) + o.spec.size_z;
      if ((target - p.pose.position()).norm() > kReach) {
        auto spot = approach_point(i, target);
        if (!spot) {
          return bad_input(scenario_.file.string(), a.line, to_string(a.kind),
                           "no free spot within reach of '" + a.object + "'");
        }
        if (Status s = plan_walk(i, *spot, a.line, "a spot beside '" + a.object + "'"); !s) return s;
        p.approaching = true;
        p.hand_seconds = hand;  // acted once within reach
        return Status::Ok();
      }
      act_for(hand);
      if (!in_place) face(p, target);
      return Status::Ok();
    }
  }
  return Status::Ok();
}

Status World::finish_action(int i) {
  PersonEntity& p = people_[i];
  const Action& a = p.spec.script[p.step_index];
  const auto record = [&](const std::string& what, const std::string& obj, Vec2 where) {
    actions_.push_back({time_, p.spec.id, what, obj, where});
  };
  const double D = scenario_.rules.exchange_distance;
  switch (a.kind) {
    case ActionKind::kPickUp: {
      const int oi = find_object(a.object);
      ObjectEntity& o = objects_[oi];
      if (o.carrier >= 0 || !o.present) {
        return bad_input(scenario_.file.string(), a.line, "pick_up",
                         "person '" + p.spec.id + "' reached for '" + o.spec.id + "' but someone else took it first");
      }
      const Vec2 where = o.pose.position();
      const std::string prev = !o.last_carrier.empty() ? o.last_carrier : o.spec.owner;
      remove_object_body(oi);
      o.carrier = i;
      p.carrying.push_back(oi);
      record("pick_up", o.spec.id, where);
      std::erase_if(left_bag_watches_, [&](const LeftBagWatch& w) { return w.object == oi; });
      if (is_bag(o)) {
        if (!prev.empty() && prev != p.spec.id) {
          const int pi = find_person(prev);
          const bool handover = pi >= 0 && people_[pi].present &&
                                (people_[pi].pose.position() - p.pose.position()).norm() <= D;
          GroundTruthEvent e;
          e.kind = handover ? "exchange" : "bag_taken";
          e.t = e.confirmed = time_;
          e.people = handover ? std::vector<std::string>{prev, p.spec.id} : std::vector<std::string>{p.spec.id};
          e.object = o.spec.id;
          e.owner = prev;
          e.where = {where.x, where.y, o.z};
          events_.push_back(e);
        }
      } else if (!(o.spec.authorised || o.spec.owner == p.spec.id)) {
        events_.push_back({"unauthorised_object", time_, time_, {p.spec.id}, o.spec.id, o.spec.owner,
                           {where.x, where.y, o.z}});
      }
      o.last_carrier = p.spec.id;
      break;
    }
    case ActionKind::kPutDown: {
      const int oi = find_object(a.object);
      ObjectEntity& o = objects_[oi];
      Vec2 where;
      if (a.has_target) {
        where = a.target.point;
      } else {
        const Vec2 spot = put_down_spot(p, o);
        where = map_.is_free_disc(spot, 0.15) ? spot : p.pose.position();
      }
      std::erase(p.carrying, oi);
      o.carrier = -1;
      o.pose.yaw = p.pose.yaw;
      place_object_on_floor(oi, where);
      record("put_down", o.spec.id, where);
      if (is_bag(o)) left_bag_watches_.push_back({oi, i, -1});
      break;
    }
    case ActionKind::kTouch: {
      const int oi = find_object(a.object);
      const ObjectEntity& o = objects_[oi];
      record("touch", o.spec.id, o.pose.position());
      if (!(o.spec.authorised || o.spec.owner == p.spec.id)) {
        // The incident starts when the hand reaches the object, not when it lets go.
        const SimTime start = time_ - from_seconds(a.duration > 0 ? a.duration : kDefaultHandSeconds);
        events_.push_back({"unauthorised_object", start, start, {p.spec.id}, o.spec.id, o.spec.owner,
                           {o.pose.x, o.pose.y, o.z}});
      }
      break;
    }
    case ActionKind::kLeave: {
      record("leave", "", p.pose.position());
      p.present = false;
      p.gone = true;
      for (int oi : p.carrying) objects_[oi].present = false;
      if (p.body) {
        b2_->DestroyBody(p.body);
        p.body = nullptr;
      }
      break;
    }
    case ActionKind::kWalkTo:
    case ActionKind::kWait:
      break;
  }
  p.step_index++;
  p.phase = p.gone ? PersonEntity::Phase::kDone : PersonEntity::Phase::kStart;
  return Status::Ok();
}

Status World::step_person(int i) {
  PersonEntity& p = people_[i];
  if (p.gone) return Status::Ok();
  if (!p.present) {
    const SimTime appear = p.spec.appear_at ? from_seconds(*p.spec.appear_at) : 0;
    if (time_ < appear) return Status::Ok();
    p.present = true;
    b2BodyDef def;
    def.type = b2_dynamicBody;
    def.fixedRotation = true;
    def.position.Set(static_cast<float>(p.pose.x), static_cast<float>(p.pose.y));
    def.userData.pointer = body_tag(kTagPerson, static_cast<size_t>(i));
    p.body = b2_->CreateBody(&def);
    b2CircleShape circle;
    circle.m_radius = static_cast<float>(p.spec.radius);
    b2FixtureDef fix;
    fix.shape = &circle;
    fix.density = 1000.0f / static_cast<float>(M_PI * 0.25 * 0.25) * 0.07f;  // about 70 kg
    p.body->CreateFixture(&fix);
    for (int oi : p.carrying) objects_[oi].present = true;
    actions_.push_back({time_, p.spec.id, "appear", "", p.pose.position()});
  }

  Vec2 desired{0, 0};
  if (p.phase == PersonEntity::Phase::kStart && p.step_index < p.spec.script.size()) {
    const Action& a = p.spec.script[p.step_index];
    if (!a.at || time_ >= from_seconds(*a.at)) {
      if (Status s = start_action(i); !s) return s;
    }
  }
  if (p.phase == PersonEntity::Phase::kWalking) {
    const Action& a = p.spec.script[p.step_index];
    const double speed = a.speed.value_or(p.spec.speed);
    const Vec2 pos = p.pose.position();
    while (p.path_index + 1 < p.path.size() && (p.path[p.path_index] - pos).norm() < kArrive * 2) p.path_index++;
    const Vec2 to = p.path[p.path_index] - pos;
    const double dist_goal = (p.path.back() - pos).norm();
    const bool in_reach = p.approaching && (p.reach_target - pos).norm() <= kReach;
    if (in_reach || (p.path_index + 1 == p.path.size() && to.norm() < kArrive) || p.stalled_at_goal) {
      p.stalled_at_goal = false;
      if (p.approaching) {
        p.phase = PersonEntity::Phase::kActing;
        p.phase_end = time_ + from_seconds(p.hand_seconds);
        p.approaching = false;
        face(p, p.reach_target);
      } else if (Status st = finish_action(i); !st) {
        return st;
      }
    } else {
      const double slow = std::min(1.0, to.norm() / 0.3 + 0.2);  // ease into the last point
      desired = to * (speed * (p.path_index + 1 == p.path.size() ? slow : 1.0) / std::max(1e-9, to.norm()));
      // Keep apart from other people and robots ahead (social repulsion).
      Vec2 push{0, 0};
      auto repel = [&](Vec2 other, double other_radius) {
        const Vec2 d = pos - other;
        const double n = d.norm();
        const double range = p.spec.radius + other_radius + 0.6;
        if (n > 1e-6 && n < range && d.dot(desired) < 0) push = push + d * ((range - n) / (range * n));
      };
      for (size_t j = 0; j < people_.size(); ++j)
        if (static_cast<int>(j) != i && people_[j].present) repel(people_[j].pose.position(), people_[j].spec.radius);
      for (const auto& r : robots_) repel(r.pose.position(), r.model.radius);
      for (const auto& ob : objects_)
        if (ob.body) repel(ob.pose.position(), 0.5 * std::hypot(ob.spec.size_x, ob.spec.size_y));
      if (push.norm() > 0) {
        desired = desired + push * (speed * 1.5);
        const double n = desired.norm();
        if (n > speed) desired = desired * (speed / n);
      }
      // Replan when pushed off course and making no progress.
      if (time_ >= p.progress_check) {
        if (p.path_index + 1 == p.path.size() && dist_goal < kStalledArrive && dist_goal > p.progress_distance - 0.05) {
          p.stalled_at_goal = true;  // arrives on the next step
        } else if (dist_goal > p.progress_distance - 0.2) {
          auto path = person_paths_->plan(pos, p.path.back());
          if (!path.empty()) {
            p.path = std::move(path);
            p.path_index = p.path.size() > 1 ? 1 : 0;
          }
        }
        p.progress_distance = dist_goal;
        p.progress_check = time_ + kStuckWindow;
      }
    }
  } else if (p.phase == PersonEntity::Phase::kActing && time_ >= p.phase_end) {
    if (Status st = finish_action(i); !st) return st;
  }
  if (p.body) p.body->SetLinearVelocity(b2Vec2(static_cast<float>(desired.x), static_cast<float>(desired.y)));
  return Status::Ok();
}

void World::step_robots_control() {
  for (auto& r : robots_) {
    // A scripted breakdown: from its time the controller no longer runs and the wheels stop.
    bool stopped = false;
    for (const FaultSpec& f : scenario_.faults) {
      if (f.kind == "stop" && f.robot == r.spec.id && time_ >= from_seconds(f.at)) stopped = true;
    }
    if (stopped) {
      r.cmd_v = r.cmd_w = 0;
    } else if (r.controller) {
      struct Cmd : ModelCommand {
        RobotEntity* r;
        SimTime now;
        void set_velocity(double v, double w) override {
          r->cmd_v = std::isfinite(v) ? std::clamp(v, -r->spec.max_speed, r->spec.max_speed) : 0.0;
          r->cmd_w = std::isfinite(w) ? std::clamp(w, -r->spec.max_turn_rate, r->spec.max_turn_rate) : 0.0;
        }
        std::vector<RobotTask> take_tasks() override {
          std::vector<RobotTask> out(r->inbox.begin(), r->inbox.end());
          r->inbox.clear();
          return out;
        }
        void report(const RobotReport& rep) override {
          RobotReport copy = rep;
          copy.robot = r->spec.id;
          copy.stamp = now;
          // Nobody drains the outbox in some uses (benchmarks): keep the newest 4096.
          if (r->outbox.size() >= 4096) r->outbox.erase(r->outbox.begin(), r->outbox.begin() + 2048);
          r->outbox.push_back(copy);
          r->last_report = copy;
        }
        void send(const TeamMessage& m) override {
          TeamMessage copy = m;
          copy.from = r->spec.id;
          copy.sent = now;
          if (r->sent.size() >= 65536) r->sent.erase(r->sent.begin(), r->sent.begin() + 32768);
          r->sent.push_back(std::move(copy));
        }
        std::vector<TeamMessage> take_messages() override {
          std::vector<TeamMessage> out(r->received.begin(), r->received.end());
          r->received.clear();
          return out;
        }
      } cmd;
      cmd.r = &r;
      cmd.now = time_;
      r.controller->update(*this, cmd);
    }
    const double yaw = r.body->GetAngle();
    r.body->SetLinearVelocity(b2Vec2(static_cast<float>(r.cmd_v * std::cos(yaw)), static_cast<float>(r.cmd_v * std::sin(yaw))));
    r.body->SetAngularVelocity(static_cast<float>(r.cmd_w));
  }
}

void World::step_robots_sense() {
  const double dt = to_seconds(dt_);
  bool any_scan = false;
  for (auto& r : robots_) {
    const b2Vec2 pos = r.body->GetPosition();
    const Pose2 prev = r.pose;
    r.pose = {pos.x, pos.y, wrap_angle(r.body->GetAngle())};
    // Measured motion in the robot frame, then Stage-style odometry with per-robot bias.
    const Vec2 delta = rotate(r.pose.position() - prev.position(), -prev.yaw);
    const double dyaw = wrap_angle(r.pose.yaw - prev.yaw);
    r.state.v = delta.x / dt;
    r.state.w = dyaw / dt;
    double mx = delta.x * (1 + r.odom_bias_x), my = delta.y * (1 + r.odom_bias_y), myaw = dyaw * (1 + r.odom_bias_yaw);
    if (r.spec.odometry.noise_std > 0) {
      mx *= 1 + r.rng.normal(0, r.spec.odometry.noise_std);
      myaw *= 1 + r.rng.normal(0, r.spec.odometry.noise_std);
    }
    Pose2& od = r.state.odometry;
    const Vec2 d = rotate({mx, my}, od.yaw);
    od = {od.x + d.x, od.y + d.y, wrap_angle(od.yaw + myaw)};
    if (r.spec.ranger.enabled && time_ >= r.next_scan) any_scan = true;
  }
  if (!any_scan) return;
  std::vector<RangeObstacle> obs;
  obs.reserve(robots_.size() + people_.size() + objects_.size());
  for (size_t i = 0; i < robots_.size(); ++i) {
    const auto& r = robots_[i];
    RangeObstacle o;
    const Vec2 c = r.pose.position() + rotate(r.model.footprint_offset, r.pose.yaw);
    o.center = c;
    o.yaw = r.pose.yaw;
    o.owner = static_cast<int>(i);
    if (r.model.footprint == FootprintShape::kBox) {
      o.shape = RangeObstacle::Shape::kBox;
      o.half_x = r.model.half_x;
      o.half_y = r.model.half_y;
    } else {
      o.radius = r.model.radius;
    }
    obs.push_back(o);
  }
  for (const auto& p : people_) {
    if (!p.present) continue;
    RangeObstacle o;
    o.center = p.pose.position();
    o.radius = p.spec.radius;
    obs.push_back(o);
  }
  for (const auto& ob : objects_) {
    if (!ob.body) continue;  // carried or on furniture: above or part of known obstacles
    RangeObstacle o;
    o.shape = RangeObstacle::Shape::kBox;
    o.center = ob.pose.position();
    o.yaw = ob.pose.yaw;
    o.half_x = ob.spec.size_x / 2;
    o.half_y = ob.spec.size_y / 2;
    obs.push_back(o);
  }
  bodies_index_->rebuild(obs);
  for (size_t i = 0; i < robots_.size(); ++i) {
    auto& r = robots_[i];
    if (!r.spec.ranger.enabled || time_ < r.next_scan) continue;
    simulate_scan(*wall_rays_, *bodies_index_, r.laser_pose(), r.spec.ranger, static_cast<int>(i), &r.rng, time_, &r.scan);
    r.next_scan = time_ + std::max<SimTime>(dt_, from_seconds(1.0 / r.spec.ranger.rate_hz));
  }
}

void World::update_carried() {
  for (auto& p : people_) {
    if (p.body) {
      const b2Vec2 pos = p.body->GetPosition();
      const b2Vec2 vel = p.body->GetLinearVelocity();
      const Vec2 np{pos.x, pos.y};
      p.walked += (np - p.pose.position()).norm();
      p.velocity = {vel.x, vel.y};
      double yaw = p.pose.yaw;
      if (p.velocity.norm() > 0.15) yaw = std::atan2(p.velocity.y, p.velocity.x);
      p.pose = {np.x, np.y, yaw};
    }
    for (int oi : p.carrying) {
      ObjectEntity& o = objects_[oi];
      // Bags hang at the side; small objects are held in front.
      const bool bag = is_bag(o);
      const Vec2 off = bag ? Vec2{0.0, -(p.spec.radius + 0.08)} : Vec2{p.spec.radius + 0.1, 0.0};
      const Vec2 c = p.pose.position() + rotate(off, p.pose.yaw);
      o.pose = {c.x, c.y, p.pose.yaw};
      o.z = bag ? 0.25 : 0.95;
    }
  }
}

void World::monitor_events() {
  const double D = scenario_.rules.left_bag_distance;
  const SimTime T = from_seconds(scenario_.rules.left_bag_time);
  for (auto it = left_bag_watches_.begin(); it != left_bag_watches_.end();) {
    const ObjectEntity& o = objects_[it->object];
    const PersonEntity& p = people_[it->person];
    const bool away = !p.present || (p.pose.position() - o.pose.position()).norm() > D;
    if (!away) {
      it->away_since = -1;
    } else if (it->away_since < 0) {
      it->away_since = time_;
    }
    if (it->away_since >= 0 && time_ - it->away_since >= T) {
      GroundTruthEvent e;
      e.kind = "left_bag";
      e.t = it->away_since;
      e.confirmed = time_;
      e.people = {p.spec.id};
      e.object = o.spec.id;
      e.owner = !o.spec.owner.empty() ? o.spec.owner : p.spec.id;
      e.where = {o.pose.x, o.pose.y, o.z};
      events_.push_back(e);
      it = left_bag_watches_.erase(it);
    } else {
      ++it;
    }
  }
}

Status World::post_task(const std::string& robot, RobotTask task) {
  for (auto& r : robots_) {
    if (r.spec.id == robot) {
      r.inbox.push_back(std::move(task));
      return Status::Ok();
    }
  }
  return bad_input("", 0, "robot", "no robot '" + robot + "' in this world");
}

std::vector<RobotReport> World::drain_reports() {
  std::vector<RobotReport> out;
  for (auto& r : robots_) {
    out.insert(out.end(), r.outbox.begin(), r.outbox.end());
    r.outbox.clear();
  }
  return out;
}

std::vector<TeamMessage> World::drain_sent() {
  std::vector<TeamMessage> out;
  for (auto& r : robots_) {
    out.insert(out.end(), std::make_move_iterator(r.sent.begin()), std::make_move_iterator(r.sent.end()));
    r.sent.clear();
  }
  return out;
}

Status World::deliver(const std::string& robot, TeamMessage m) {
  for (auto& r : robots_) {
    if (r.spec.id == robot) {
      if (r.received.size() >= 65536) r.received.pop_front();
      r.received.push_back(std::move(m));
      return Status::Ok();
    }
  }
  return bad_input("", 0, "robot", "no robot '" + robot + "' in this world");
}

const RobotReport* World::last_report(const std::string& robot) const {
  for (const auto& r : robots_)
    if (r.spec.id == robot) return r.last_report ? &*r.last_report : nullptr;
  return nullptr;
}

void World::monitor_contacts() {
  // Touching pairs this step, per robot, by the other body's tag (0: walls).
  std::map<std::pair<int, uintptr_t>, size_t> still;
  for (size_t i = 0; i < robots_.size(); ++i) {
    const RobotEntity& r = robots_[i];
    for (b2ContactEdge* ce = r.body->GetContactList(); ce; ce = ce->next) {
      if (!ce->contact->IsTouching()) continue;
      const uintptr_t tag = ce->other->GetUserData().pointer;
      const auto key = std::make_pair(static_cast<int>(i), tag);
      if (still.count(key)) continue;
      auto open = open_contacts_.find(key);
      if (open != open_contacts_.end()) {
        contacts_[open->second].end = time_;
        still[key] = open->second;
        continue;
      }
      ContactRecord c;
      c.robot = r.spec.id;
      const uintptr_t kind = tag >> 32;
      const size_t index = static_cast<size_t>(tag & 0xffffffffu) - 1;
      Vec2 other_at = r.pose.position();
      if (tag == 0) {
        c.other = "wall";
        c.other_kind = "wall";
        b2WorldManifold m;
        ce->contact->GetWorldManifold(&m);
        other_at = {m.points[0].x, m.points[0].y};
      } else if (kind == kTagRobot) {
        c.other = robots_[index].spec.id;
        c.other_kind = "robot";
        other_at = robots_[index].pose.position();
      } else if (kind == kTagPerson) {
        c.other = people_[index].spec.id;
        c.other_kind = "person";
        other_at = people_[index].pose.position();
      } else {
        c.other = objects_[index].spec.id;
        c.other_kind = "object";
        other_at = objects_[index].pose.position();
      }
      // The speed the controller commanded (a body pushed by a person moves too, but does not push).
      c.robot_speed = r.cmd_v;
      const Vec2 heading{std::cos(r.pose.yaw), std::sin(r.pose.yaw)};
      const double side = (other_at - r.pose.position()).dot(heading);
      c.robot_pushing = std::abs(r.cmd_v) > 0.05 && side * r.cmd_v > 0;
      c.start = c.end = time_;
      c.where = r.pose.position();
      still[key] = contacts_.size();
      contacts_.push_back(c);
    }
  }
  open_contacts_ = std::move(still);
}

Status World::advance() {
  for (size_t i = 0; i < people_.size(); ++i) {
    if (Status s = step_person(static_cast<int>(i)); !s) return s;
  }
  step_robots_control();
  b2_->Step(static_cast<float>(to_seconds(dt_)), 8, 3);
  time_ += dt_;
  steps_++;
  update_carried();
  step_robots_sense();
  monitor_contacts();
  monitor_events();
  if (finished()) {
    std::stable_sort(events_.begin(), events_.end(),
                     [](const GroundTruthEvent& a, const GroundTruthEvent& b) { return a.t < b.t; });
  }
  return Status::Ok();
}

OccupancyGrid sight_map(const World& world, double eye_height) {
  OccupancyGrid g = world.map();
  const double r = g.resolution();
  for (const auto& f : world.furniture()) {
    if (f.height >= eye_height) continue;
    const double c = std::cos(f.pose.yaw), sn = std::sin(f.pose.yaw);
    const double hx = f.size_x / 2 + r, hy = f.size_y / 2 + r, reach = std::hypot(hx, hy);
    int x0, y0, x1, y1;
    if (!g.world_to_cell({f.pose.x - reach, f.pose.y - reach}, &x0, &y0)) x0 = y0 = 0;
    if (!g.world_to_cell({f.pose.x + reach, f.pose.y + reach}, &x1, &y1)) x1 = g.width() - 1, y1 = g.height() - 1;
    for (int cy = std::max(0, std::min(y0, y1)); cy <= std::min(g.height() - 1, std::max(y0, y1)); ++cy) {
      for (int cx = std::max(0, std::min(x0, x1)); cx <= std::min(g.width() - 1, std::max(x0, x1)); ++cx) {
        const Vec2 p = g.cell_center(cx, cy);
        const double lx = c * (p.x - f.pose.x) + sn * (p.y - f.pose.y);
        const double ly = -sn * (p.x - f.pose.x) + c * (p.y - f.pose.y);
        if (std::abs(lx) <= hx && std::abs(ly) <= hy) g.set(cx, cy, Cell::kFree);
      }
    }
  }
  return g;
}

}  // namespace vigil
