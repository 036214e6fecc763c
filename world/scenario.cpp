// Scenario files: parsing and checking everything that can be checked without running (types,
// unknown keys, ranges, files, places, free space, cross-references between people, scripts
// and objects). Every error names the file, line and key. Format: docs/SCENARIO_FORMAT.md.
#include "world/scenario.h"

#include <algorithm>
#include <cmath>
#include <set>

#include "world/floorplan.h"
#include "world/map.h"
#include "world/yaml_util.h"

namespace vigil {

const char* to_string(ActionKind k) {
  switch (k) {
    case ActionKind::kWalkTo: return "walk_to";
    case ActionKind::kWait: return "wait";
    case ActionKind::kPickUp: return "pick_up";
    case ActionKind::kPutDown: return "put_down";
    case ActionKind::kTouch: return "touch";
    case ActionKind::kLeave: return "leave";
  }
  return "?";
}

const char* to_string(ObjectKind k) {
  switch (k) {
    case ObjectKind::kBag: return "bag";
    case ObjectKind::kLaptop: return "laptop";
    case ObjectKind::kBook: return "book";
    case ObjectKind::kBottle: return "bottle";
    case ObjectKind::kBox: return "box";
  }
  return "?";
}

namespace {

namespace fs = std::filesystem;
using yaml_input::InputError;
using yaml_input::Mapping;
using yaml_input::Value;

constexpr double kDegToRad = M_PI / 180.0;

// Default size (m) and colour of each object kind.
struct ObjectDefaults {
  ObjectKind kind;
  double sx, sy, sz;
  const char* colour;
};
constexpr ObjectDefaults kObjectDefaults[] = {
    {ObjectKind::kBag, 0.40, 0.20, 0.40, "#202020"},
    {ObjectKind::kLaptop, 0.34, 0.24, 0.03, "#404040"},
    {ObjectKind::kBook, 0.24, 0.17, 0.04, "#a03020"},
    {ObjectKind::kBottle, 0.07, 0.07, 0.25, "#2080c0"},
    {ObjectKind::kBox, 0.40, 0.30, 0.30, "#b08850"},
};

// Formats a number for messages.
std::string fmt(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", x);
  return buf;
}

// True when `path` names a vector floorplan (*.floorplan.yaml / *.floorplan.yml).
bool is_floorplan_path(const fs::path& path) {
  const std::string name = path.filename().string();
  for (const std::string suffix : {".floorplan.yaml", ".floorplan.yml"}) {
    if (name.size() > suffix.size() && name.compare(name.size() - suffix.size(), suffix.size(), suffix) == 0) {
      return true;
    }
  }
  return false;
}

// Reads one scenario document into a Scenario (throws InputError).
class ScenarioReader {
 public:
  ScenarioReader(const Value& root, const fs::path& file, const ScenarioContext& ctx)
      : root_(root), file_(file), dir_(file.parent_path()), ctx_(ctx) {}

  Scenario read() {
    const Mapping top = root_.mapping({"name", "map", "duration", "seed", "physics_rate_hz", "record_rate_hz",
                                       "rules", "places", "cameras", "robots", "people", "objects", "faults"});
    sc_.file = file_;
    sc_.name = file_.stem().string();
    if (auto v = top.get("name")) sc_.name = v->string();
    read_map(top.require("map"));
    sc_.duration = top.require("duration").positive(1e7);
    if (auto v = top.get("seed")) sc_.seed = v->unsigned_integer();
    if (auto v = top.get("physics_rate_hz")) sc_.physics_rate_hz = v->positive(1e5);
    if (auto v = top.get("record_rate_hz")) {
      sc_.record_rate_hz = v->positive(1e5);
      if (sc_.record_rate_hz > sc_.physics_rate_hz) {
        v->fail("must not exceed physics_rate_hz (" + fmt(sc_.physics_rate_hz) + ")");
      }
    }
    if (auto v = top.get("places")) read_places(*v);
    if (auto v = top.get("rules")) read_rules(*v);
    if (auto v = top.get("cameras")) {
      for (const Value& item : v->items()) sc_.cameras.push_back(read_camera(item));
    }
    if (auto v = top.get("robots")) {
      for (const Value& item : v->items()) sc_.robots.push_back(read_robot(item));
    }
    if (auto v = top.get("people")) {
      for (const Value& item : v->items()) sc_.people.push_back(read_person(item));
    }
    if (auto v = top.get("objects")) {
      for (const Value& item : v->items()) sc_.objects.push_back(read_object(item));
    }
    if (auto v = top.get("faults")) {
      for (const Value& item : v->items()) {
        const Mapping m = item.mapping({"robot", "at", "kind"});
        FaultSpec f;
        const Value& rv = m.require("robot");
        f.robot = rv.identifier();
        if (std::none_of(sc_.robots.begin(), sc_.robots.end(), [&](const RobotSpec& r) { return r.id == f.robot; })) {
          rv.fail("no robot '" + f.robot + "' in this scenario");
        }
        f.at = m.require("at").non_negative(1e7);
        const Value& kv = m.require("kind");
        f.kind = kv.string();
        if (f.kind != "stop" && f.kind != "silent") kv.fail("must be stop or silent, not '" + f.kind + "'");
        f.line = item.line();
        sc_.faults.push_back(f);
      }
    }
    check_scripts();
    return std::move(sc_);
  }

 private:
  // map: path of a .floorplan.yaml, map_server .yaml or Stage .world, relative to the file.
  void read_map(const Value& v) {
    const std::string rel = v.string();
    const fs::path path = (dir_ / rel).lexically_normal();
    std::error_code ec;
    if (!fs::exists(path, ec)) v.fail("map file '" + path.string() + "' does not exist");
    if (!fs::is_regular_file(path, ec)) v.fail("map '" + path.string() + "' is not a regular file");
    sc_.map = path;
    if (is_floorplan_path(path)) {
      Result<Floorplan> plan = load_floorplan(path);
      if (!plan) v.fail("cannot load map: " + plan.error().str());
      grid_ = plan->rasterize();
      sc_.places = plan->places;
      for (const auto& f : plan->furniture) {
        sc_.furniture[f.name] = f.pose;
        furniture_.push_back(f);
      }
    } else {
      Result<OccupancyGrid> grid = load_map(path);
      if (!grid) v.fail("cannot load map: " + grid.error().str());
      grid_ = std::move(*grid);
    }
    if (grid_.width() <= 0 || grid_.height() <= 0) v.fail("map '" + path.string() + "' has no cells");
  }

  // rules: {left_bag_distance, left_bag_time, exchange_distance, handling_zones: [furniture, ...],
  //         restricted_objects: [{name, at, z}, ...]}
  void read_rules(const Value& v) {
    const Mapping m = v.mapping({"left_bag_distance", "left_bag_time", "exchange_distance", "handling_zones",
                                 "restricted_objects"});
    if (auto x = m.get("restricted_objects")) {
      if (!x->is_sequence()) x->fail("expected a list of {name: NAME, at: PLACE or [x, y], z: M}");
      for (const Value& item : x->items()) {
        const Mapping r = item.mapping({"name", "at", "z"});
        RestrictedObjectSpec o;
        o.name = r.require("name").identifier();
        for (const auto& other : sc_.rules.restricted_objects)
          if (other.name == o.name) r.require("name").fail("restricted object '" + o.name + "' is marked twice");
        o.at = place_ref(r.require("at"));
        // On a piece of furniture: its top, unless given.
        for (const auto& f : furniture_) {
          const double c = std::cos(f.pose.yaw), s = std::sin(f.pose.yaw);
          const double dx = o.at.point.x - f.pose.x, dy = o.at.point.y - f.pose.y;
          if (std::abs(c * dx + s * dy) <= f.size_x / 2 && std::abs(-s * dx + c * dy) <= f.size_y / 2) o.z = f.height;
        }
        if (auto z = r.get("z")) o.z = z->non_negative(100);
        o.line = item.line();
        sc_.rules.restricted_objects.push_back(o);
      }
    }
    if (auto x = m.get("left_bag_distance")) sc_.rules.left_bag_distance = x->positive(1e4);
    if (auto x = m.get("left_bag_time")) sc_.rules.left_bag_time = x->non_negative(1e7);
    if (auto x = m.get("exchange_distance")) sc_.rules.exchange_distance = x->positive(1e4);
    if (auto x = m.get("handling_zones")) {
      if (!x->is_sequence()) x->fail("expected a list of furniture names, e.g. [lab_table]");
      for (const Value& item : x->items()) {
        const std::string name = item.identifier();
        bool known = false;
        for (const auto& f : furniture_) known = known || f.name == name;
        if (!known) item.fail("'" + name + "' is not a piece of furniture of the map");
        sc_.rules.handling_zones.push_back(name);
      }
    }
  }

  // places: {name: [x, y], ...}, added to the map's places.
  void read_places(const Value& v) {
    const Mapping m = v.open_mapping();
    for (const auto& [name, value] : m.entries()) {
      if (sc_.places.count(name)) value.fail("place '" + name + "' is already defined by the map");
      sc_.places[name] = value.point();
    }
  }

  // A place name or [x, y], resolved to a point.
  PlaceRef place_ref(const Value& v) const {
    PlaceRef ref;
    if (v.is_sequence()) {
      ref.point = v.point();
      return ref;
    }
    if (!v.is_scalar()) v.fail("expected a place name or [x, y]");
    ref.place = v.string();
    auto it = sc_.places.find(ref.place);
    if (it == sc_.places.end()) v.fail("unknown place '" + ref.place + "' (known: " + known_places() + ")");
    ref.point = it->second;
    return ref;
  }

  // The first places by name, for "unknown place" messages.
  std::string known_places() const {
    std::string out;
    int n = 0;
    for (const auto& [name, p] : sc_.places) {
      if (++n > 30) return out + ", ...";
      out += (out.empty() ? "" : ", ") + name;
    }
    return out.empty() ? "none" : out;
  }

  // Fails unless p is inside the map and on a free cell.
  void check_free(const Value& v, Vec2 p, const std::string& what) const {
    int cx = 0, cy = 0;
    const Pose2 o = grid_.origin();
    if (!grid_.world_to_cell(p, &cx, &cy)) {
      v.fail(what + " (" + fmt(p.x) + ", " + fmt(p.y) + ") is outside the map (x " + fmt(o.x) + " to " +
             fmt(o.x + grid_.size_x()) + ", y " + fmt(o.y) + " to " + fmt(o.y + grid_.size_y()) + ")");
    }
    const Cell c = grid_.at(cx, cy);
    if (c == Cell::kOccupied) {
      v.fail(what + " (" + fmt(p.x) + ", " + fmt(p.y) + ") is inside a wall or obstacle");
    }
    if (c == Cell::kUnknown) v.fail(what + " (" + fmt(p.x) + ", " + fmt(p.y) + ") is in unknown space");
  }

  // Registers an entity id, unique across cameras, robots, people and objects.
  void register_id(const Value& v, const std::string& id, const std::string& kind) {
    auto [it, fresh] = ids_.emplace(id, std::make_pair(kind, v.line()));
    if (!fresh) {
      v.fail("duplicate id '" + id + "' (already used by the " + it->second.first + " at line " +
             std::to_string(it->second.second) + ")");
    }
  }

  // Fails when a plugin name is unknown to the context.
  void check_plugin(const Value& v, const std::string& name) const {
    if (ctx_.plugin_exists && !ctx_.plugin_exists(name)) {
      v.fail("unknown plugin '" + name + "' (not built in and not found on the plugin search path)");
    }
  }

  // params: {name: number | bool | string | list of numbers | list of strings}
  std::map<std::string, ParamEntry> read_params(const Value& v) const {
    std::map<std::string, ParamEntry> out;
    const Mapping m = v.open_mapping();
    for (const auto& [name, value] : m.entries()) {
      ParamEntry e;
      e.line = value.line();
      if (value.is_sequence()) {
        const auto items = value.items();
        bool all_numbers = !items.empty();
        for (const Value& item : items) {
          if (!item.is_scalar()) item.fail("list parameters hold numbers or strings only");
          all_numbers = all_numbers && item.looks_numeric();
        }
        if (all_numbers) {
          std::vector<double> xs;
          for (const Value& item : items) xs.push_back(item.number());
          e.value = std::move(xs);
        } else {
          std::vector<std::string> ss;
          for (const Value& item : items) ss.push_back(item.node().Scalar());
          e.value = std::move(ss);
        }
      } else if (value.is_scalar()) {
        const std::string& s = value.node().Scalar();
        if (!value.is_quoted() && (s == "true" || s == "false" || s == "True" || s == "False" ||
                                   s == "TRUE" || s == "FALSE")) {
          e.value = value.boolean();
        } else if (value.looks_numeric()) {
          e.value = value.number();
        } else {
          e.value = s;
        }
      } else if (value.is_null()) {
        value.fail("missing value");
      } else {
        value.fail("parameter values are numbers, true/false, strings or lists of them");
      }
      out[name] = std::move(e);
    }
    return out;
  }

  // One camera.
  CameraSpec read_camera(const Value& v) {
    const Mapping m = v.mapping({"id", "position", "yaw_deg", "pitch_deg", "roll_deg", "resolution", "hfov_deg",
                                 "fx", "fy", "cx", "cy", "baseline", "rate_hz", "plugin", "params"});
    CameraSpec c;
    c.line = v.line();
    const Value id = m.require("id");
    c.id = id.identifier();
    register_id(id, c.id, "camera");
    const Value pos = m.require("position");
    const auto p = pos.numbers(3);
    c.position = {p[0], p[1], p[2]};
    int cx = 0, cy = 0;
    if (!grid_.world_to_cell({p[0], p[1]}, &cx, &cy)) {
      pos.fail("camera (" + fmt(p[0]) + ", " + fmt(p[1]) + ") is outside the map");
    }
    if (p[2] < 0 || p[2] > 100) pos.fail("height z must be between 0 and 100 m");
    if (auto x = m.get("yaw_deg")) c.yaw = wrap_angle(x->number_in(-360, 360) * kDegToRad);
    if (auto x = m.get("pitch_deg")) c.pitch = x->number_in(-90, 90) * kDegToRad;
    if (auto x = m.get("roll_deg")) c.roll = x->number_in(-180, 180) * kDegToRad;
    if (auto x = m.get("resolution")) {
      if (!x->is_sequence() || x->node().size() != 2) x->fail("expected [width, height] in pixels");
      const auto items = x->items();
      c.width = static_cast<int>(items[0].integer(1, 16384));
      c.height = static_cast<int>(items[1].integer(1, 16384));
    }
    const auto hfov = m.get("hfov_deg");
    const auto fx = m.get("fx");
    if (hfov && fx) hfov->fail("give either hfov_deg or fx/fy/cx/cy, not both");
    if (hfov) c.hfov = hfov->number_in(1e-3, 179.0) * kDegToRad;
    if (fx) {
      c.fx = fx->positive(1e6);
      c.fy = c.fx;
      if (auto y = m.get("fy")) c.fy = y->positive(1e6);
      if (auto x = m.get("cx")) c.cx = x->number_in(0, c.width);
      if (auto y = m.get("cy")) c.cy = y->number_in(0, c.height);
    } else {
      for (const char* k : {"fy", "cx", "cy"}) {
        if (auto x = m.get(k)) x->fail(std::string(k) + " needs fx");
      }
      if (!hfov) c.hfov = 60.0 * kDegToRad;
    }
    if (auto x = m.get("baseline")) c.baseline = x->positive(10.0);
    if (auto x = m.get("rate_hz")) {
      c.rate_hz = x->positive(1000.0);
      if (c.rate_hz > sc_.physics_rate_hz) x->fail("must not exceed physics_rate_hz (" + fmt(sc_.physics_rate_hz) + ")");
    }
    if (auto x = m.get("plugin")) {
      c.plugin = x->identifier();
      check_plugin(*x, c.plugin);
    }
    if (auto x = m.get("params")) c.params = read_params(*x);
    return c;
  }

  // A robot start: a place name, [x, y(, yaw_deg)] or {place: NAME, yaw_deg: A}.
  Pose2 read_pose(const Value& v, std::string* place) const {
    Pose2 pose;
    Value where = v;
    if (v.is_sequence()) {
      const auto p = v.numbers(0, 2, 3);
      pose = {p[0], p[1], p.size() > 2 ? p[2] : 0.0};
      if (std::abs(pose.yaw) > 360) v.fail("yaw must be between -360 and 360 degrees");
      pose.yaw = wrap_angle(pose.yaw * kDegToRad);
    } else if (v.is_mapping()) {
      const Mapping m = v.mapping({"place", "yaw_deg"});
      where = m.require("place");
      const PlaceRef ref = place_ref(where);
      *place = ref.place;
      pose = {ref.point.x, ref.point.y, 0.0};
      if (auto y = m.get("yaw_deg")) pose.yaw = wrap_angle(y->number_in(-360, 360) * kDegToRad);
    } else {
      const PlaceRef ref = place_ref(v);
      *place = ref.place;
      pose = {ref.point.x, ref.point.y, 0.0};
    }
    check_free(where, pose.position(), "start");
    return pose;
  }

  // One robot.
  RobotSpec read_robot(const Value& v) {
    const Mapping m = v.mapping({"id", "urdf", "start", "controller", "params", "ranger", "odometry", "max_speed",
                                 "max_turn_rate_deg"});
    RobotSpec r;
    r.line = v.line();
    const Value id = m.require("id");
    r.id = id.identifier();
    register_id(id, r.id, "robot");
    const Value urdf = m.require("urdf");
    r.urdf = (dir_ / urdf.string()).lexically_normal();
    std::error_code ec;
    if (!fs::is_regular_file(r.urdf, ec)) urdf.fail("URDF file '" + r.urdf.string() + "' does not exist");
    r.start = read_pose(m.require("start"), &r.start_place);
    if (auto x = m.get("controller")) {
      r.controller = x->identifier();
      check_plugin(*x, r.controller);
    }
    if (auto x = m.get("params")) r.params = read_params(*x);
    if (auto x = m.get("ranger")) r.ranger = read_ranger(*x);
    if (auto x = m.get("odometry")) r.odometry = read_odometry(*x);
    if (auto x = m.get("max_speed")) r.max_speed = x->positive(20.0);
    if (auto x = m.get("max_turn_rate_deg")) r.max_turn_rate = x->positive(3600.0) * kDegToRad;
    return r;
  }

  // ranger: {range_min, range_max, fov_deg, samples, noise_std, rate_hz}; present = enabled.
  RangerSpec read_ranger(const Value& v) const {
    const Mapping m = v.mapping({"range_min", "range_max", "fov_deg", "samples", "noise_std", "rate_hz"});
    RangerSpec g;
    g.enabled = true;
    if (auto x = m.get("range_min")) g.range_min = x->non_negative(1e3);
    if (auto x = m.get("range_max")) {
      g.range_max = x->positive(1e3);
      if (g.range_max <= g.range_min) x->fail("must be greater than range_min (" + fmt(g.range_min) + ")");
    } else if (g.range_max <= g.range_min) {
      m.get("range_min")->fail("must be less than range_max (" + fmt(g.range_max) + ")");
    }
    if (auto x = m.get("fov_deg")) g.fov = x->number_in(1e-3, 360) * kDegToRad;
    if (auto x = m.get("samples")) g.samples = static_cast<int>(x->integer(1, 100000));
    if (auto x = m.get("noise_std")) g.noise_std = x->non_negative(100.0);
    if (auto x = m.get("rate_hz")) g.rate_hz = x->positive(1000.0);
    return g;
  }

  // odometry: {error: [ex, ey, eyaw], noise_std}
  OdometrySpec read_odometry(const Value& v) const {
    const Mapping m = v.mapping({"error", "noise_std"});
    OdometrySpec o;
    if (auto x = m.get("error")) {
      const auto e = x->numbers(3);
      for (double f : e) {
        if (f < 0 || f > 1) x->fail("each error must be a fraction between 0 and 1");
      }
      o.error_x = e[0];
      o.error_y = e[1];
      o.error_yaw = e[2];
    }
    if (auto x = m.get("noise_std")) o.noise_std = x->non_negative(1.0);
    return o;
  }

  // One person with a script.
  PersonSpec read_person(const Value& v) {
    const Mapping m = v.mapping({"id", "start", "appear_at", "speed", "radius", "height", "shirt", "trousers",
                                 "script"});
    PersonSpec p;
    p.line = v.line();
    const Value id = m.require("id");
    p.id = id.identifier();
    register_id(id, p.id, "person");
    const Value start = m.require("start");
    p.start = place_ref(start);
    check_free(start, p.start.point, "start");
    if (auto x = m.get("appear_at")) p.appear_at = x->non_negative(1e7);
    if (auto x = m.get("speed")) p.speed = x->positive(10.0);
    if (auto x = m.get("radius")) p.radius = x->positive(2.0);
    if (auto x = m.get("height")) p.height = x->positive(3.0);
    if (auto x = m.get("shirt")) p.shirt = x->colour();
    if (auto x = m.get("trousers")) p.trousers = x->colour();
    std::vector<Value> sources;
    bool left = false;
    if (auto x = m.get("script")) {
      for (const Value& item : x->items()) {
        if (left) item.fail("no step can follow 'leave' (the person has left)");
        Value source = item;
        p.script.push_back(read_action(item, &source));
        sources.push_back(source);
        left = p.script.back().kind == ActionKind::kLeave;
      }
    }
    script_sources_.push_back(std::move(sources));
    return p;
  }

  // One script step: exactly one of walk_to, wait, pick_up, put_down, touch, leave, with the
  // options that step takes (at, speed, duration, to).
  Action read_action(const Value& v, Value* object_source) {
    static const std::vector<std::pair<std::string, ActionKind>> kKinds = {
        {"walk_to", ActionKind::kWalkTo}, {"wait", ActionKind::kWait},   {"pick_up", ActionKind::kPickUp},
        {"put_down", ActionKind::kPutDown}, {"touch", ActionKind::kTouch}, {"leave", ActionKind::kLeave}};
    if (!v.is_mapping()) {
      v.fail("expected a step such as '- walk_to: PLACE', '- wait: SECONDS', '- pick_up: OBJECT', "
             "'- put_down: OBJECT', '- touch: OBJECT' or '- leave: PLACE'");
    }
    const Mapping m = v.mapping({"walk_to", "wait", "pick_up", "put_down", "touch", "leave", "at", "speed",
                                 "duration", "to"});
    Action a;
    a.line = v.line();
    std::optional<Value> verb;
    std::string verb_name;
    for (const auto& [name, value] : m.entries()) {
      for (const auto& [verb_key, kind] : kKinds) {
        if (name != verb_key) continue;
        if (verb) value.fail("a step does only one thing: '" + verb_name + "' and '" + name + "' given together");
        verb = value;
        verb_name = name;
        a.kind = kind;
      }
    }
    if (!verb) v.fail("a step needs one of walk_to, wait, pick_up, put_down, touch, leave");
    // Options each kind accepts.
    std::vector<std::string> options = {"at"};
    switch (a.kind) {
      case ActionKind::kWalkTo:
      case ActionKind::kLeave: options.push_back("speed"); break;
      case ActionKind::kPickUp:
      case ActionKind::kTouch: options.push_back("duration"); break;
      case ActionKind::kPutDown: options.insert(options.end(), {"duration", "to"}); break;
      case ActionKind::kWait: break;
    }
    for (const auto& [entry_name, value] : m.entries()) {
      const std::string& name = entry_name;  // a plain reference: lambdas cannot capture a binding in C++17 (clang 14)
      const bool is_verb = std::any_of(kKinds.begin(), kKinds.end(), [&](const auto& k) { return k.first == name; });
      if (is_verb || std::find(options.begin(), options.end(), name) != options.end()) continue;
      std::string allowed;
      for (const auto& o : options) allowed += (allowed.empty() ? "" : ", ") + o;
      value.fail("'" + name + "' does not apply to " + verb_name + " (options: " + allowed + ")");
    }
    if (auto x = m.get("at")) {
      if (!x->is_scalar() || !x->looks_numeric()) {
        x->fail("'at' is the step's start time in seconds" +
                std::string(a.kind == ActionKind::kPutDown ? "; to put the object down somewhere use 'to:'" : ""));
      }
      a.at = x->non_negative(1e7);
    }
    switch (a.kind) {
      case ActionKind::kWalkTo:
      case ActionKind::kLeave:
        a.target = place_ref(*verb);
        a.has_target = true;
        check_free(*verb, a.target.point, a.kind == ActionKind::kWalkTo ? "walk_to target" : "leave target");
        if (auto x = m.get("speed")) a.speed = x->positive(10.0);
        break;
      case ActionKind::kWait:
        a.duration = verb->non_negative(1e7);
        break;
      case ActionKind::kPickUp:
      case ActionKind::kPutDown:
      case ActionKind::kTouch:
        a.object = verb->identifier();
        *object_source = *verb;
        a.duration = 1.0;
        if (auto x = m.get("duration")) a.duration = x->non_negative(1e4);
        if (auto x = m.get("to")) {
          a.target = place_ref(*x);
          a.has_target = true;
          // Down on the floor, or onto a piece of furniture (a table top).
          const bool on_furniture = std::any_of(furniture_.begin(), furniture_.end(),
                                                [&](const auto& f) { return on_footprint(f, a.target.point); });
          if (!on_furniture) check_free(*x, a.target.point, "put_down position");
        }
        break;
    }
    return a;
  }

  // One object.
  ObjectSpec read_object(const Value& v) {
    const Mapping m = v.mapping({"id", "kind", "at", "on", "carried_by", "owner", "authorised", "size", "colour"});
    ObjectSpec o;
    o.line = v.line();
    const Value id = m.require("id");
    o.id = id.identifier();
    register_id(id, o.id, "object");
    const Value kind = m.require("kind");
    const std::string kind_name = kind.string();
    const ObjectDefaults* defaults = nullptr;
    for (const auto& d : kObjectDefaults) {
      if (kind_name == to_string(d.kind)) defaults = &d;
    }
    if (!defaults) kind.fail("unknown object kind '" + kind_name + "' (known: bag, laptop, book, bottle, box)");
    o.kind = defaults->kind;
    o.size_x = defaults->sx;
    o.size_y = defaults->sy;
    o.size_z = defaults->sz;
    o.colour = defaults->colour;

    const auto at = m.get("at");
    const auto on = m.get("on");
    if (auto carrier = m.get("carried_by")) {
      if (at || on) carrier->fail("an object carried by someone has no 'at' or 'on'");
      o.carried_by = carrier->identifier();
      const PersonSpec* person = find_person(*carrier, o.carried_by);
      o.position = person->start;
    } else if (on) {
      o.on = on->identifier();
      const FloorplanFurniture* f = find_furniture(o.on);
      if (!f) on->fail("unknown furniture '" + o.on + "' (known: " + known_furniture() + ")");
      if (at) {
        o.position = place_ref(*at);
        if (!on_footprint(*f, o.position.point)) {
          at->fail("(" + fmt(o.position.point.x) + ", " + fmt(o.position.point.y) + ") is not on '" + o.on + "'");
        }
      } else {
        o.position.point = f->pose.position();
      }
    } else {
      if (!at) v.fail("an object needs 'at' (a place or [x, y]), 'on' (furniture) or 'carried_by' (a person)");
      o.position = place_ref(*at);
      check_free(*at, o.position.point, "object position");
    }
    if (auto x = m.get("owner")) {
      o.owner = x->identifier();
      find_person(*x, o.owner);
    }
    if (auto x = m.get("authorised")) o.authorised = x->boolean();
    if (auto x = m.get("size")) {
      const auto s = x->numbers(3);
      for (double d : s) {
        if (d <= 0 || d > 10) x->fail("sizes must be greater than 0 and at most 10 m");
      }
      o.size_x = s[0];
      o.size_y = s[1];
      o.size_z = s[2];
    }
    if (auto x = m.get("colour")) o.colour = x->colour();
    return o;
  }

  // The person with that id; fails naming what the id is otherwise.
  const PersonSpec* find_person(const Value& v, const std::string& id) const {
    for (const auto& p : sc_.people) {
      if (p.id == id) return &p;
    }
    if (auto it = ids_.find(id); it != ids_.end()) v.fail("'" + id + "' is a " + it->second.first + ", not a person");
    v.fail("unknown person '" + id + "'");
  }

  const FloorplanFurniture* find_furniture(const std::string& name) const {
    for (const auto& f : furniture_) {
      if (f.name == name) return &f;
    }
    return nullptr;
  }

  std::string known_furniture() const {
    std::string out;
    for (const auto& f : furniture_) out += (out.empty() ? "" : ", ") + f.name;
    return out.empty() ? "none in this map" : out;
  }

  // True when p lies on the furniture's footprint.
  static bool on_footprint(const FloorplanFurniture& f, Vec2 p) {
    const Vec2 d = p - f.pose.position();
    const Vec2 u{std::cos(f.pose.yaw), std::sin(f.pose.yaw)};
    const Vec2 w{-u.y, u.x};
    return std::abs(d.dot(u)) <= 0.5 * f.size_x + 1e-9 && std::abs(d.dot(w)) <= 0.5 * f.size_y + 1e-9;
  }

  // True when the person's script has a put_down of the object.
  bool puts_down(const std::string& person_id, const std::string& object) const {
    for (const auto& p : sc_.people) {
      if (p.id != person_id) continue;
      for (const auto& a : p.script) {
        if (a.kind == ActionKind::kPutDown && a.object == object) return true;
      }
    }
    return false;
  }

  // Scripts against objects: named objects exist, nobody picks up what another person starts
  // carrying and never puts down, or what they already hold; put_down only puts down what is held.
  void check_scripts() const {
    for (size_t pi = 0; pi < sc_.people.size(); ++pi) {
      const PersonSpec& person = sc_.people[pi];
      std::set<std::string> held;
      for (const auto& o : sc_.objects) {
        if (o.carried_by == person.id) held.insert(o.id);
      }
      for (size_t ai = 0; ai < person.script.size(); ++ai) {
        const Action& a = person.script[ai];
        if (a.object.empty()) continue;
        const Value& where = script_sources_[pi][ai];
        const ObjectSpec* obj = nullptr;
        for (const auto& o : sc_.objects) {
          if (o.id == a.object) obj = &o;
        }
        if (!obj) {
          if (auto it = ids_.find(a.object); it != ids_.end()) {
            where.fail("'" + a.object + "' is a " + it->second.first + ", not an object");
          }
          where.fail("unknown object '" + a.object + "'");
        }
        if (a.kind == ActionKind::kPickUp) {
          if (!obj->carried_by.empty() && obj->carried_by != person.id && !puts_down(obj->carried_by, a.object)) {
            where.fail("'" + a.object + "' starts carried by '" + obj->carried_by +
                       "', who never puts it down, so '" + person.id + "' cannot pick it up");
          }
          if (held.count(a.object)) where.fail("'" + person.id + "' is already carrying '" + a.object + "'");
          held.insert(a.object);
        } else if (a.kind == ActionKind::kPutDown) {
          if (!held.count(a.object)) {
            where.fail("'" + person.id + "' is not carrying '" + a.object + "' at this step (pick it up first)");
          }
          held.erase(a.object);
        }
      }
    }
  }

  const Value& root_;
  fs::path file_, dir_;
  const ScenarioContext& ctx_;
  Scenario sc_;
  OccupancyGrid grid_;
  std::vector<FloorplanFurniture> furniture_;
  std::map<std::string, std::pair<std::string, int>> ids_;  // id -> (entity kind, line)
  std::vector<std::vector<Value>> script_sources_;           // per person, per step: what names the object
};

}  // namespace

Result<Scenario> parse_scenario(const std::string& text, const std::filesystem::path& file,
                                const ScenarioContext& ctx) {
  const std::string name = file.string();
  try {
    const YAML::Node doc = yaml_input::parse_document(text, name);
    const Value root(doc, std::make_shared<const std::string>(name), "", yaml_input::line_of(doc, 1));
    return ScenarioReader(root, file, ctx).read();
  } catch (const InputError& e) {
    return e.error;
  } catch (const YAML::Exception& e) {
    return bad_input(name, e.mark.is_null() ? 0 : e.mark.line + 1, "", "YAML error: " + e.msg);
  } catch (const std::exception& e) {
    return internal_error(name + ": " + e.what());
  } catch (...) {
    return internal_error(name + ": unknown exception while parsing");
  }
}

Result<Scenario> load_scenario(const std::filesystem::path& path, const ScenarioContext& ctx) {
  std::string text;
  try {
    text = yaml_input::read_text_file(path);
  } catch (const InputError& e) {
    return e.error;
  } catch (const std::exception& e) {
    return internal_error(path.string() + ": " + e.what());
  }
  return parse_scenario(text, path, ctx);
}

Result<const CameraSpec*> find_camera(const Scenario& scenario, const std::string& id, const std::string& key) {
  std::string known;
  for (const CameraSpec& c : scenario.cameras) {
    if (c.id == id) return &c;
    known += (known.empty() ? "" : ", ") + c.id;
  }
  return bad_input(scenario.file.string(), 0, key,
                   "no camera '" + id + "' in the scenario (cameras: " + (known.empty() ? "none" : known) + ")");
}

}  // namespace vigil
