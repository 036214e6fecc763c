#include "world/scenario_gen.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <map>
#include <optional>
#include <sstream>

#include "common/rng.h"
#include "world/scenario.h"

namespace vigil {

namespace {

constexpr double kPi = 3.14159265358979323846;
double deg(double d) { return d * kPi / 180.0; }

// The DIS wing's geometry the generator draws in (maps/dis_labs.floorplan.yaml): the horizontal
// corridor (walls at y 2.0 and 4.2, x 2.0 .. 41.0), the lab north of it (x 8 .. 16, y 4.2 .. 11,
// door at x 12), the lab table and its camera.
constexpr double kCorridorYMin = 2.0, kCorridorYMax = 4.2;
constexpr double kWalkYMin = 2.5, kWalkYMax = 3.7;   // a person's centre (radius 0.25, clear of the walls)
constexpr double kCorridorXMin = 4.4, kCorridorXMax = 40.2;
constexpr double kLabDoorX = 12.0;
constexpr double kTableX = 12.0, kTableY = 8.5, kTableSX = 1.8, kTableSY = 0.9;
constexpr double kLaptopX = 12.6, kLaptopY = 8.55;
constexpr double kLeftBagDistance = 3.0, kLeftBagTime = 5.0;
constexpr int kAttempts = 200;  // draws per scenario before giving up
constexpr double kHand = 1.0;  // s a pick-up, put-down or touch takes (the scenario default)

struct Vec {
  double x = 0, y = 0;
};
double dist(Vec a, Vec b) { return std::hypot(a.x - b.x, a.y - b.y); }

// A pinhole camera as the scenario states it (yaw about z, pitch down), for "in view" checks.
struct ViewCamera {
  std::string id;
  double x = 0, y = 0, z = 2.5, yaw = 0, pitch = 0;
  double hfov = deg(60);
  int width = 640, height = 480;
  double max_range = 7.5;  // m on the floor: inside the ground-truth sensor's 8 m, with margin
  double min_range = 2.0;

  bool project(double px, double py, double pz, double* u, double* v) const {
    const double fx = std::cos(yaw) * std::cos(pitch), fy = std::sin(yaw) * std::cos(pitch), fz = -std::sin(pitch);
    const double rx = std::sin(yaw), ry = -std::cos(yaw);
    const double ux = std::cos(yaw) * std::sin(pitch), uy = std::sin(yaw) * std::sin(pitch), uz = std::cos(pitch);
    const double dx = px - x, dy = py - y, dz = pz - z;
    const double depth = dx * fx + dy * fy + dz * fz;
    if (depth < 0.3) return false;
    const double f = 0.5 * width / std::tan(0.5 * hfov);
    *u = 0.5 * width + f * (dx * rx + dy * ry) / depth;
    *v = 0.5 * height - f * (dx * ux + dy * uy + dz * uz) / depth;
    return true;
  }
  // True when something standing at (px, py) up to `top` metres is wholly in the image (with a
  // margin) and within range on the floor.
  bool sees(Vec p, double top, double margin = 24) const {
    const double r = std::hypot(p.x - x, p.y - y);
    if (r > max_range || r < min_range) return false;
    for (double z_ : {0.0, top}) {
      double u, v;
      if (!project(p.x, p.y, z_, &u, &v)) return false;
      if (u < margin || u > width - margin || v < margin || v > height - margin) return false;
    }
    return true;
  }
  std::string yaml() const {
    char b[512];
    std::snprintf(b, sizeof b,
                  "  - id: %s\n    position: [%.2f, %.2f, %.2f]\n    yaw_deg: %.1f\n    pitch_deg: %.1f\n"
                  "    resolution: [%d, %d]\n    hfov_deg: 60\n    baseline: 0.09\n    rate_hz: 15\n",
                  id.c_str(), x, y, z, yaw * 180 / kPi, pitch * 180 / kPi, width, height);
    return b;
  }
};

std::string fmt(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.2f", v);
  std::string s = b;
  return s == "-0.00" ? "0.00" : s;
}
std::string pt(Vec p) { return "[" + fmt(p.x) + ", " + fmt(p.y) + "]"; }

// A scripted person as the generator builds them: the steps and an estimate of the time each
// ends (straight-line walking at the person's speed, a hand action's second), which the
// generator uses to time the others' steps.
struct Actor {
  std::string id;
  Vec start, pos;
  double speed = 1.2, height = 1.75;
  std::string shirt, trousers;
  std::optional<double> appear_at;
  std::vector<std::string> steps;
  double t = 0;  // estimated time the last step ends
  struct Leg {
    Vec from, to;
    double t0, t1;  // estimated start and end (s)
  };
  std::vector<Leg> segments;  // straight legs walked (planned paths bend around walls only)
  std::vector<Vec> waits;                     // where they stand a while (a wait, a step held back by `at`)

  void walk(Vec to, std::optional<double> at = std::nullopt) {
    std::string s = "      - walk_to: " + pt(to);
    if (at && steps.empty() && (!appear_at || *appear_at <= *at)) {
      // Held back before the first step: appear then instead of standing there from the start.
      appear_at = *at;
      t = std::max(t, *at);
      at.reset();
    }
    if (at) waits.push_back(pos);
    if (at) {
      s += "\n        at: " + fmt(*at);
      t = std::max(t, *at);
    }
    steps.push_back(s);
    const double t0 = t;
    t += 1.15 * dist(pos, to) / speed + 0.3;  // planned paths bend a little; turning
    segments.push_back({pos, to, t0, t});
    pos = to;
  }
  void wait(double seconds) {
    waits.push_back(pos);
    steps.push_back("      - wait: " + fmt(seconds));
    t += seconds;
  }
  void hand(const std::string& verb, const std::string& object, Vec where, std::optional<Vec> to = std::nullopt,
            double duration = kHand, std::optional<double> at = std::nullopt) {
    std::string s = "      - " + verb + ": " + object;
    if (to) s += "\n        to: " + pt(*to);
    if (duration != kHand) s += "\n        duration: " + fmt(duration);
    if (at) {
      s += "\n        at: " + fmt(*at);
      t = std::max(t, *at);
    }
    steps.push_back(s);
    const double reach = std::max(0.0, dist(pos, where) - 0.55);
    const double t0 = t;
    t += 1.15 * reach / speed + duration;
    if (reach > 0) {  // walked up beside it
      const double f = reach / dist(pos, where);
      const Vec to{pos.x + f * (where.x - pos.x), pos.y + f * (where.y - pos.y)};
      segments.push_back({pos, to, t0, t - duration});
      pos = to;
    }
  }
  void leave(Vec to) {
    steps.push_back("      - leave: " + pt(to));
    const double t0 = t;
    t += 1.15 * dist(pos, to) / speed;
    segments.push_back({pos, to, t0, t});
    pos = to;
  }
  std::string yaml() const {
    std::string s = "  - id: " + id + "\n    start: " + pt(start) + "\n";
    if (appear_at) s += "    appear_at: " + fmt(*appear_at) + "\n";
    s += "    speed: " + fmt(speed) + "\n    height: " + fmt(height) + "\n    shirt: \"" + shirt + "\"\n    trousers: \"" +
         trousers + "\"\n    script:\n";
    for (const auto& st : steps) s += st + "\n";
    return s;
  }
};

struct Object {
  std::string id, kind, colour, owner, carried_by, on;
  std::optional<Vec> at;
  bool authorised = true;
  std::string yaml() const {
    std::string s = "  - id: " + id + "\n    kind: " + kind + "\n";
    if (!carried_by.empty()) s += "    carried_by: " + carried_by + "\n";
    if (!on.empty()) s += "    on: " + on + "\n";
    if (at) s += "    at: " + pt(*at) + "\n";
    if (!owner.empty()) s += "    owner: " + owner + "\n";
    if (!authorised) s += "    authorised: false\n";
    s += "    colour: \"" + colour + "\"\n";
    return s;
  }
};

struct Robot {
  std::string id;
  Vec start;
  double yaw_deg = 0;
  std::vector<Vec> points;
  double speed = 0.4;
  bool loop = false;
};

// The state of one draw.
class Draw {
 public:
  Draw(Rng rng, const ScenarioGenOptions& o) : rng_(rng), o_(o) {}

  double u(double lo, double hi) { return rng_.uniform(lo, hi); }
  bool chance(double p) { return rng_.uniform() < p; }
  int pick(int n) { return std::min(n - 1, static_cast<int>(rng_.uniform() * n)); }

  std::string colour(int lo = 20, int hi = 230) {
    // One draw after another (the order of a call's arguments is unspecified).
    const int r = static_cast<int>(u(lo, hi)), g = static_cast<int>(u(lo, hi)), bl = static_cast<int>(u(lo, hi));
    char b[16];
    std::snprintf(b, sizeof b, "#%02x%02x%02x", r, g, bl);
    return b;
  }

  Actor& person(Vec start, std::optional<double> appear_at = std::nullopt) {
    Actor a;
    a.id = std::string(1, static_cast<char>('A' + people_.size()));
    a.start = a.pos = start;
    a.speed = u(0.9, 1.5);
    a.height = u(1.6, 1.9);
    a.shirt = colour();
    a.trousers = colour(20, 120);
    a.appear_at = appear_at;
    if (appear_at) a.t = *appear_at;
    people_.push_back(a);
    return people_.back();
  }
  Object& bag(const std::string& carrier) {
    Object b;
    b.id = "bag" + std::to_string(objects_.size() + 1);
    b.kind = "bag";
    b.colour = colour(15, 200);
    b.carried_by = b.owner = carrier;
    objects_.push_back(b);
    return objects_.back();
  }

  // The corridor camera: on either wall, anywhere along the corridor, looking along it.
  void corridor_camera() {
    ViewCamera c;
    c.id = "cam_corridor";
    const bool west = chance(0.5);
    const bool north = chance(0.5);
    c.x = west ? u(14.0, 39.5) : u(4.5, 32.0);
    c.y = north ? 3.95 : 2.25;
    const double toward_centre = u(-1.0, 6.0);  // degrees, turned toward the corridor's axis
    c.yaw = deg(west ? 180.0 + (north ? toward_centre : -toward_centre) : (north ? -toward_centre : toward_centre));
    c.z = u(2.3, 2.7);
    c.pitch = deg(u(13.0, 18.0));
    cameras_.push_back(c);
    corridor_ = &cameras_.back();
    // The stretch of corridor in which a person at the axis is wholly in view.
    lo_ = 1e9, hi_ = -1e9;
    for (double x = kCorridorXMin; x <= kCorridorXMax; x += 0.05) {
      if (c.sees({x, 3.1}, 1.9)) lo_ = std::min(lo_, x), hi_ = std::max(hi_, x);
    }
  }
  void lab_camera() {
    ViewCamera c;
    c.id = "cam_lab";
    c.x = 14.6, c.y = 10.6, c.z = 2.3, c.yaw = deg(-140), c.pitch = deg(35);
    c.min_range = 0.5;
    cameras_.push_back(c);
    lab_ = &cameras_.back();
  }
  bool have_view() const { return hi_ - lo_ > 3.0; }
  double view_lo() const { return lo_; }
  double view_hi() const { return hi_; }

  // A point of the corridor in view of its camera, for a person (top 1.9) or a bag (top 0.45).
  std::optional<Vec> corridor_spot(double top, double ymin, double ymax, double xmin = -1e9, double xmax = 1e9) {
    for (int i = 0; i < 200; ++i) {
      Vec p{u(std::max(lo_ - 1.0, xmin), std::min(hi_ + 1.0, xmax)), u(ymin, ymax)};
      if (corridor_->sees(p, top) && (top < 1.0 || clear(p))) return p;
    }
    return std::nullopt;
  }
  // A point out of view on one side of the corridor (west: lower x), at least `beyond` from the view.
  Vec off_view(bool west, double beyond = 2.5) {
    for (int i = 0; i < 100; ++i) {
      const double x = west ? u(lo_ - beyond - 4.0, lo_ - beyond) : u(hi_ + beyond, hi_ + beyond + 4.0);
      Vec p{std::clamp(x, kCorridorXMin, kCorridorXMax), u(kWalkYMin, kWalkYMax)};
      if (!corridor_->sees(p, 1.9, -40)) return p;
    }
    return {west ? kCorridorXMin : kCorridorXMax, 3.1};
  }
  // Which ways a person can leave a bag at `q` and stay in view until nearly out of the rules'
  // reach (left_bag_distance less 0.8 m: a camera cannot know how far someone out of view has
  // gone, and the rules count an owner lost for person_lost_time (1 s) as away; walking the
  // last 0.8 m takes about as long): 0 none, 1 west, 2 east, 3 both.
  int exit_sides(Vec q) const {
    int s = 0;
    if (q.x - lo_ >= kLeftBagDistance - 0.8) s |= 1;
    if (hi_ - q.x >= kLeftBagDistance - 0.8) s |= 2;
    return s;
  }
  bool side_west(int sides) {
    if (sides == 1) return true;
    if (sides == 2) return false;
    return chance(0.5);
  }
  // Where to put a bag down from a person standing at p: beside them, across the corridor's
  // axis, on the floor and clear of the walls.
  Vec beside(Vec p) {
    const double side = p.y > 3.1 ? -1 : 1;
    const double off = u(0.35, 0.55);
    Vec q{p.x + u(-0.15, 0.15), p.y + (chance(0.8) ? side : -side) * off};
    q.y = std::clamp(q.y, kCorridorYMin + 0.35, kCorridorYMax - 0.35);
    return q;
  }
  // A point in the corridor within [rmin, rmax] of q, in view.
  std::optional<Vec> near(Vec q, double rmin, double rmax, std::function<bool(Vec)> also = nullptr) {
    for (int i = 0; i < 400; ++i) {
      const double a = u(0, 2 * kPi), r = u(rmin, rmax);
      Vec p{q.x + r * std::cos(a), q.y + r * std::sin(a)};
      if (p.y < kWalkYMin || p.y > kWalkYMax || !clear(p) || (also && !also(p))) continue;
      if (corridor_->sees(p, 1.9)) return p;
    }
    return std::nullopt;
  }
  // A spot on the lab table in the lab camera's view.
  Vec table_spot(double min_from_laptop) {
    for (int i = 0; i < 200; ++i) {
      Vec p{u(kTableX - kTableSX / 2 + 0.15, kTableX + kTableSX / 2 - 0.15), u(kTableY - kTableSY / 2 + 0.12, kTableY + kTableSY / 2 - 0.12)};
      if (dist(p, {kLaptopX, kLaptopY}) < min_from_laptop) continue;
      if (lab_->sees(p, 0.95, 10)) return p;
    }
    return {kTableX - 0.5, kTableY};
  }
  Robot& robot(Vec start, double yaw_deg) {
    Robot r;
    r.id = "robot" + std::to_string(robots_.size() + 1);
    r.start = start;
    r.yaw_deg = yaw_deg;
    robots_.push_back(r);
    return robots_.back();
  }

  void on_floor(Vec p, double t = 0) { floor_objects_.push_back({p, t}); }
  // The bag at p is picked up at t.
  void off_floor(Vec p, double t) {
    for (FloorObject& f : floor_objects_)
      if (dist(f.at, p) < 1e-6) f.t1 = t;
  }
  // Clear of every bag on the floor by a person's radius, the bag's half-diagonal and a margin
  // (a walk target the person cannot reach for a bag in the way would stall the script).
  bool clear(Vec p) const {
    return std::all_of(floor_objects_.begin(), floor_objects_.end(), [&](const FloorObject& f) { return dist(p, f.at) >= 0.8; });
  }
  // People walk the paths planned on the map: a bag or a stopped robot on the floor is in their
  // way, and a leg that passes through one (nearer than a person's radius and the thing's half
  // size, somewhere between its ends) would stall the script. Legs that start or end beside
  // one (putting a bag down, walking off from it) are fine.
  bool paths_clear() const {
    auto seg_dist = [](Vec a, Vec b, Vec q, bool* interior) {
      const double vx = b.x - a.x, vy = b.y - a.y, l2 = vx * vx + vy * vy;
      const double s = l2 > 1e-12 ? std::clamp(((q.x - a.x) * vx + (q.y - a.y) * vy) / l2, 0.0, 1.0) : 0.0;
      *interior = s > 0.0 && s < 1.0;
      return std::hypot(a.x + s * vx - q.x, a.y + s * vy - q.y);
    };
    struct Thing {
      Vec at;
      double clearance, t0, t1;
    };
    std::vector<Thing> things;
    for (const FloorObject& f : floor_objects_) things.push_back({f.at, 0.5, f.t0, f.t1});
    for (const Robot& r : robots_)
      if (r.points.size() == 1) things.push_back({r.points.back(), 0.6, 0.0, 1e9});
    for (const Actor& a : people_)
      for (const auto& leg : a.segments)
        for (const Thing& th : things) {
          if (leg.t1 < th.t0 - 1.0 || leg.t0 > th.t1 + 1.0) continue;  // not there then (estimates: a margin)
          bool interior = false;
          const double d = seg_dist(leg.from, leg.to, th.at, &interior);
          if (interior && d < th.clearance && dist(leg.from, th.at) > d + 0.05 && dist(leg.to, th.at) > d + 0.05) return false;
        }
    // Where someone stands and waits, nobody else stands (two people walking to one spot wait
    // for each other for ever); walking past a standing person is fine, they step aside.
    for (size_t i = 0; i < people_.size(); ++i)
      for (size_t j = 0; j < people_.size(); ++j) {
        if (i == j) continue;
        for (Vec w : people_[i].waits) {
          for (Vec v : people_[j].waits)
            if (dist(w, v) < 0.8) return false;
        }
      }
    return true;
  }
  std::vector<Actor>& people() { return people_; }
  std::vector<Object>& objects() { return objects_; }
  const ViewCamera* corridor() const { return corridor_; }
  void handling_zone() { handling_zone_ = true; }
  void note(const std::string& s) { summary_ += (summary_.empty() ? "" : "; ") + s; }
  const std::string& summary() const { return summary_; }

  std::string yaml(const std::string& name, const std::string& family) const {
    namespace fs = std::filesystem;
    auto rel = [&](const fs::path& p) {
      std::error_code ec;
      const fs::path r = fs::relative(fs::absolute(p), fs::absolute(o_.out_dir), ec);
      return (ec || r.empty() ? fs::absolute(p) : r).generic_string();
    };
    double end = 0;
    for (const Actor& a : people_) end = std::max(end, a.t);
    const double duration = std::ceil(end + kLeftBagTime + 6.0);
    std::ostringstream s;
    s << "# Generated by `vigil gen " << family << " --seed " << o_.seed << "` (scenario " << o_.index << "): "
      << scenario_family_description(family) << "\n# " << summary_ << "\n";
    s << "name: " << name << "\nmap: " << rel(o_.map) << "\nduration: " << duration << "\nseed: "
      << (o_.seed * 1000 + static_cast<uint64_t>(o_.index) + 1) << "\nphysics_rate_hz: 100\nrecord_rate_hz: 10\n";
    s << "rules:\n  left_bag_distance: " << kLeftBagDistance << "\n  left_bag_time: " << kLeftBagTime
      << "\n  exchange_distance: 1.5\n";
    if (handling_zone_)
      s << "  handling_zones: [lab_table]\n  restricted_objects:\n    - {name: laptop, at: [" << fmt(kLaptopX) << ", "
        << fmt(kLaptopY) << "]}\n";
    s << "\ncameras:\n";
    for (const ViewCamera& c : cameras_) {
      s << c.yaml();
      if (o_.sensor == "truth")
        s << "    plugin: truth\n    params: {position_noise: 0.05, miss_rate: 0.05, false_alarm_rate: 0.05}\n";
      else if (o_.sensor == "truth-clean")
        s << "    plugin: truth\n    params: {position_noise: 0.05}\n";
      else if (o_.sensor == "sgbm" || (o_.sensor == "platform" && c.id != "cam_lab"))
        s << "    plugin: planview\n    params: {disparity: sgbm}\n";
      else if (o_.sensor == "platform")
        s << "    plugin: mser\n";  // the chapter's platform: the colour MSER system in the lab (10.6.1)
    }
    if (!robots_.empty()) {
      s << "\nrobots:\n";
      for (const Robot& r : robots_) {
        s << "  - id: " << r.id << "\n    urdf: " << rel(o_.urdf) << "\n    start: [" << fmt(r.start.x) << ", "
          << fmt(r.start.y) << ", " << fmt(r.yaw_deg) << "]\n    controller: navigator\n    params:\n      points: [";
        for (size_t i = 0; i < r.points.size(); ++i)
          s << (i ? ", " : "") << fmt(r.points[i].x) << ", " << fmt(r.points[i].y);
        s << "]\n      loop: " << (r.loop ? "true" : "false") << "\n      speed: " << fmt(r.speed)
          << "\n    ranger: {range_max: 20, fov_deg: 270, samples: 271, noise_std: 0.01, rate_hz: 10}\n"
             "    odometry: {error: [0.01, 0.01, 0.1]}\n";
      }
    }
    s << "\npeople:\n";
    for (const Actor& a : people_) s << a.yaml();
    if (!objects_.empty()) {
      s << "\nobjects:\n";
      for (const Object& ob : objects_) s << ob.yaml();
    }
    return s.str();
  }

 private:
  Rng rng_;
  ScenarioGenOptions o_;
  std::vector<ViewCamera> cameras_;  // reserved below so that the pointers hold
  const ViewCamera* corridor_ = nullptr;
  const ViewCamera* lab_ = nullptr;
  double lo_ = 0, hi_ = 0;
  std::vector<Actor> people_;
  std::vector<Object> objects_;
  std::vector<Robot> robots_;
  bool handling_zone_ = false;
  std::string summary_;
  struct FloorObject {
    Vec at;
    double t0 = 0, t1 = 1e9;  // estimated time it lies there
  };
  std::vector<FloorObject> floor_objects_;  // bags on the floor: standing points keep clear of them

 public:
  void reserve() {
    cameras_.reserve(4);
    people_.reserve(16);
    objects_.reserve(16);
    robots_.reserve(4);
  }
};

// A person carries a bag into view from one side, puts it down beside them and, optionally,
// waits. Returns the bag's place, or nothing when no place fits.
struct Drop {
  Vec bag;
  int sides = 0;
};
std::optional<Drop> carry_in(Draw& d, Actor& a, Object& bag, std::optional<double> at = std::nullopt) {
  for (int i = 0; i < 50; ++i) {
    auto stand = d.corridor_spot(1.9, kWalkYMin, kWalkYMax);
    if (!stand) return std::nullopt;
    const Vec q = d.beside(*stand);
    if (!d.corridor()->sees(q, 0.45)) continue;
    Drop r{q, d.exit_sides(q)};
    if (!r.sides) continue;
    a.walk(*stand, at);
    a.hand("put_down", bag.id, q, q);
    d.on_floor(q, a.t);
    return r;
  }
  return std::nullopt;
}

// Leaves out of view on one side: walks there and leaves.
void walk_off(Draw& d, Actor& a, bool west, std::optional<double> at = std::nullopt) {
  const Vec out = d.off_view(west);
  if (at) a.walk({std::clamp(a.pos.x + (west ? -0.5 : 0.5), kCorridorXMin, kCorridorXMax), a.pos.y}, at);
  a.leave(out);
}

// Someone who walks in from out of view on a random side (appearing at `appear` when given).
Actor& walker(Draw& d, std::optional<double> appear = std::nullopt) {
  const Vec start = d.off_view(d.chance(0.5));
  return d.person(start, appear);
}

// The corridor families' opening: the camera, and a person who carries a bag into view and puts
// it down. Nothing when the draw leaves no room for it.
struct Carrier {
  Actor* person;
  Object* bag;
  Drop drop;
};
std::optional<Carrier> bag_carried_in(Draw& d, std::optional<double> appear = std::nullopt) {
  d.corridor_camera();
  if (!d.have_view()) return std::nullopt;
  Actor& a = walker(d, appear);
  Object& bag = d.bag(a.id);
  auto drop = carry_in(d, a, bag);
  if (!drop) return std::nullopt;
  return Carrier{&a, &bag, *drop};
}

// Walks to `to` so as to be there at about `t` (held back with `at` when early).
void arrive_at(Actor& a, Vec to, double t) {
  const double lead = dist(a.pos, to) / a.speed * 1.15;
  a.walk(to, std::max(0.0, t - lead));
}

// Picks a bag up from the floor: it is no longer in anyone's way.
void pick_up_bag(Draw& d, Actor& a, const Object& bag, Vec where) {
  a.hand("pick_up", bag.id, where);
  d.off_floor(where, a.t);
}

using Family = std::function<bool(Draw&)>;

bool fam_left_bag(Draw& d) {
  const std::optional<double> appear = d.chance(0.5) ? std::optional<double>(d.u(0, 4)) : std::nullopt;
  auto c = bag_carried_in(d, appear);
  if (!c) return false;
  Actor& a = *c->person;
  const Object& bag = *c->bag;
  const Drop* drop = &c->drop;
  if (d.chance(0.4)) a.wait(d.u(0.5, 4.0));
  const bool west = d.side_west(drop->sides);
  walk_off(d, a, west);
  d.note(a.id + " leaves " + bag.id + " at " + pt(drop->bag) + " and walks " + (west ? "west" : "east"));
  return true;
}

bool fam_bag_taken(Draw& d) {
  auto c = bag_carried_in(d);
  if (!c) return false;
  Actor& a = *c->person;
  const Object& bag = *c->bag;
  const Drop* drop = &c->drop;
  const double t_down = a.t;
  walk_off(d, a, d.side_west(drop->sides));
  // The taker arrives once the owner is well away: sometimes before the bag counts as left.
  const bool early = d.chance(0.3);
  const double t_b = t_down + (early ? d.u(2.5, 4.0) : d.u(kLeftBagTime + 2, kLeftBagTime + 15));
  const bool b_west = d.chance(0.5);
  Actor& b = d.person(d.off_view(b_west));
  const Vec by = d.near(drop->bag, 0.8, 1.1).value_or(Vec{drop->bag.x + (b_west ? -1.0 : 1.0), 3.1});
  arrive_at(b, by, t_b);
  pick_up_bag(d, b, bag, drop->bag);
  const bool b_exit_west = d.side_west(d.exit_sides(drop->bag) ? d.exit_sides(drop->bag) : 3);
  walk_off(d, b, b_exit_west);
  d.note(a.id + " leaves " + bag.id + " at " + pt(drop->bag) + "; " + b.id + " takes it " +
         (early ? "soon after" : "later") + " and walks " + (b_exit_west ? "west" : "east"));
  return true;
}

bool fam_exchange(Draw& d) {
  auto c = bag_carried_in(d);
  if (!c) return false;
  Actor& a = *c->person;
  const Object& bag = *c->bag;
  const Drop* drop = &c->drop;
  // The owner stays right by the bag; the taker comes up beside both.
  const auto w = d.near(drop->bag, 0.8, 0.95);
  if (!w) return false;
  a.walk(*w);
  const double t_b = a.t + d.u(1.0, 6.0);
  Actor& b = walker(d);
  const auto by = d.near(drop->bag, 0.8, 0.9, [&](Vec p) { return dist(p, *w) >= 0.7 && dist(p, *w) <= 1.25; });
  if (!by) return false;
  arrive_at(b, *by, t_b);
  pick_up_bag(d, b, bag, drop->bag);
  const double t_pick = b.t;
  const bool b_west = d.chance(0.5);
  walk_off(d, b, b_west);
  // The owner walks off after the hand-over, with the taker or the other way.
  const bool a_west = d.chance(0.5) ? b_west : !b_west;
  walk_off(d, a, a_west, t_pick + d.u(1.5, 3.5));
  d.note(a.id + " puts " + bag.id + " down at " + pt(drop->bag) + " and stays; " + b.id + " picks it up; both walk off " +
         (a_west == b_west ? "together" : "apart"));
  return true;
}

bool fam_owner_returns(Draw& d) {
  auto c = bag_carried_in(d);
  if (!c) return false;
  Actor& a = *c->person;
  const Object& bag = *c->bag;
  const Drop* drop = &c->drop;
  const bool west = d.side_west(drop->sides);
  const bool long_away = d.chance(0.7);
  // Away to a point in view beyond the rules' distance, or out of view.
  Vec away;
  bool in_view = false;
  for (int i = 0; i < 100 && !in_view; ++i) {
    const double x = drop->bag.x + (west ? -1 : 1) * d.u(kLeftBagDistance + 0.6, kLeftBagDistance + 1.5);
    away = {x, d.u(kWalkYMin, kWalkYMax)};
    in_view = d.corridor()->sees(away, 1.9) && dist(away, drop->bag) > kLeftBagDistance + 0.5;
  }
  if (!in_view) {
    if (!long_away) return false;  // a short absence needs a place in view
    away = d.off_view(west);
  }
  a.walk(away);
  a.wait(long_away ? d.u(kLeftBagTime + 1.5, kLeftBagTime + 10) : d.u(0.0, 0.8));
  pick_up_bag(d, a, bag, drop->bag);
  walk_off(d, a, d.chance(0.5));
  d.note(a.id + " leaves " + bag.id + " at " + pt(drop->bag) + ", walks to " + pt(away) + (in_view ? " (in view)" : " (out of view)") +
         (long_away ? ", stays away" : ", turns back at once") + " and takes it back");
  return true;
}

bool fam_owner_stays(Draw& d) {
  auto c = bag_carried_in(d);
  if (!c) return false;
  Actor& a = *c->person;
  const Object& bag = *c->bag;
  const Drop* drop = &c->drop;
  const int moves = 1 + d.pick(3);
  for (int i = 0; i < moves; ++i) {
    if (auto p = d.near(drop->bag, 0.8, kLeftBagDistance - 0.7)) a.walk(*p);
    a.wait(d.u(2.0, 7.0));
  }
  pick_up_bag(d, a, bag, drop->bag);
  walk_off(d, a, d.chance(0.5));
  d.note(a.id + " puts " + bag.id + " down at " + pt(drop->bag) + ", stays within " + fmt(kLeftBagDistance - 0.7) +
         " m for " + std::to_string(moves) + " moves and takes it");
  return true;
}

bool fam_walk_past(Draw& d) {
  d.corridor_camera();
  if (!d.have_view()) return false;
  auto q = d.corridor_spot(0.45, kCorridorYMin + 0.35, kCorridorYMax - 0.35);
  if (!q) return false;
  Object b;
  b.id = "bag1";
  b.kind = "bag";
  b.colour = d.colour(15, 200);
  b.at = *q;
  d.objects().push_back(b);
  d.on_floor(*q);
  const int n = 1 + d.pick(3);
  const ViewCamera& cam = *d.corridor();
  double t0 = d.u(0.5, 4.0);
  for (int i = 0; i < n; ++i) {
    const bool from_west = d.chance(0.5);
    Actor& p = d.person(d.off_view(from_west), t0);
    // Past the bag, keeping the width of a shoulder from it.
    const double lane = q->y > 3.1 ? d.u(kWalkYMin, q->y - 0.65) : d.u(q->y + 0.65, kWalkYMax);
    if (d.chance(0.5)) {
      // Stop for a while between the camera and the bag (an occlusion), then go on.
      const double s = d.u(0.3, 0.7);
      Vec stop{cam.x + s * (q->x - cam.x), std::clamp(cam.y + s * (q->y - cam.y), kWalkYMin, kWalkYMax)};
      if (dist(stop, *q) < 0.9) stop.x += (cam.x > q->x ? 0.9 : -0.9);
      p.walk(stop);
      p.wait(d.u(1.5, 5.0));
    }
    const double dir = from_west ? 1 : -1;
    p.walk({q->x - dir * 1.5, std::clamp(lane, kWalkYMin, kWalkYMax)});
    p.walk({q->x + dir * 1.5, std::clamp(lane, kWalkYMin, kWalkYMax)});
    p.leave(d.off_view(!from_west));
    t0 += d.u(0.0, 6.0);
  }
  d.note(std::to_string(n) + " people walk past " + b.id + " at " + pt(*q) + " (present from the start, nobody's)");
  return true;
}

bool fam_two_carriers(Draw& d) {
  auto c = bag_carried_in(d);
  if (!c) return false;
  Actor& a = *c->person;
  const Object& bag_a = *c->bag;
  const Drop* da = &c->drop;
  const double b_appears = d.u(0.0, 4.0);
  Actor& b = walker(d, b_appears);
  Object& bag_b = d.bag(b.id);
  const std::optional<Drop> db = carry_in(d, b, bag_b);
  if (!db || dist(db->bag, da->bag) < 1.5) return false;
  walk_off(d, a, d.side_west(da->sides));
  const bool both = d.chance(0.4);
  if (both) {
    walk_off(d, b, d.side_west(db->sides));
  } else {
    if (auto p = d.near(db->bag, 0.8, 1.4)) b.walk(*p);
    b.wait(d.u(kLeftBagTime + 1, kLeftBagTime + 6));
    pick_up_bag(d, b, bag_b, db->bag);
    walk_off(d, b, d.chance(0.5));
  }
  d.note(a.id + " leaves " + bag_a.id + " at " + pt(da->bag) + "; " + b.id + " puts " + bag_b.id + " at " + pt(db->bag) +
         (both ? " and leaves it too" : ", stays and takes it back"));
  return true;
}

bool fam_crossing(Draw& d) {
  d.corridor_camera();
  if (!d.have_view()) return false;
  const int n = 3 + d.pick(3);
  double t0 = d.u(0.0, 2.0);
  int carriers = 0;
  for (int i = 0; i < n; ++i) {
    const bool from_west = d.chance(0.5);
    Actor& p = d.person(d.off_view(from_west), t0);
    if (d.chance(0.35)) {
      d.bag(p.id);
      ++carriers;
    }
    if (d.chance(0.4)) {
      if (auto s = d.corridor_spot(1.9, kWalkYMin, kWalkYMax)) {
        p.walk(*s);
        p.wait(d.u(1.0, 4.0));
      }
    }
    p.leave(d.off_view(!from_west));
    t0 += d.u(0.5, 5.0);
  }
  d.note(std::to_string(n) + " people cross the view, " + std::to_string(carriers) + " carrying bags they keep");
  return true;
}

bool fam_robot_near_bag(Draw& d) {
  auto c = bag_carried_in(d, d.u(0.0, 12.0));
  if (!c) return false;
  Actor& a = *c->person;
  const Object& bag = *c->bag;
  const Drop* drop = &c->drop;
  walk_off(d, a, d.side_west(drop->sides));
  // A robot drives in from a side and either stops by the bag or passes it and goes on.
  const bool from_west = d.chance(0.5);
  Robot& r = d.robot(d.off_view(from_west, 3.0), from_west ? 0 : 180);
  r.speed = d.u(0.3, 0.5);
  const bool stops = d.chance(0.6);
  if (stops) {
    // Beside it along the corridor, not in its way... nor the bag in the robot's.
    const double side = from_west ? -1 : 1;
    Vec s{drop->bag.x + side * d.u(0.9, 1.5), std::clamp(drop->bag.y + d.u(-0.4, 0.4), 2.55, 3.65)};
    r.points = {s};
  } else {
    const double lane = drop->bag.y > 3.1 ? 2.55 : 3.65;
    r.points = {{drop->bag.x, lane}, d.off_view(!from_west, 3.0)};
  }
  d.note(a.id + " leaves " + bag.id + " at " + pt(drop->bag) + "; " + r.id + (stops ? " stops beside it" : " drives past it"));
  return true;
}

// The lab families: a person comes in from the corridor with things, puts them on the marked table.
Vec lab_entry_from(Draw& d) { return {d.chance(0.5) ? d.u(5.0, 9.0) : d.u(15.0, 19.0), d.u(kWalkYMin, kWalkYMax)}; }

void into_lab(Actor& a) {
  a.walk({kLabDoorX, 3.1});
  a.walk({kLabDoorX, 5.0});
}
void out_of_lab(Draw& d, Actor& a) {
  a.walk({kLabDoorX, 5.0});
  a.walk({kLabDoorX, 3.1});
  a.leave({d.chance(0.5) ? 5.0 : 19.0, 3.1});
}

// Walks up to the table's long side next to a spot on it (the side away from the lab camera
// mostly), as a person does before handling something there.
void step_up_to(Draw& d, Actor& a, Vec spot) {
  const bool north = d.chance(0.2);
  const Vec side{std::clamp(spot.x + d.u(-0.15, 0.15), kTableX - kTableSX / 2 + 0.1, kTableX + kTableSX / 2 - 0.1),
                 north ? kTableY + kTableSY / 2 + 0.4 : kTableY - kTableSY / 2 - 0.4};
  if (dist(a.pos, side) > 0.2) a.walk(side);
}

std::vector<std::string> bring_objects(Draw& d, Actor& a, int n, std::vector<Vec>* where) {
  static const char* kinds[] = {"book", "bottle", "box"};
  std::vector<std::string> ids;
  for (int i = 0; i < n; ++i) {
    Object o;
    o.kind = kinds[d.pick(3)];
    o.id = o.kind + std::to_string(d.objects().size() + 1);
    o.carried_by = o.owner = a.id;
    o.authorised = false;  // only its owner may handle it
    o.colour = d.colour();
    d.objects().push_back(o);
    ids.push_back(o.id);
  }
  for (const auto& id : ids) {
    Vec p;
    bool ok = false;
    for (int k = 0; k < 50 && !ok; ++k) {
      p = d.table_spot(0.85);
      ok = std::all_of(where->begin(), where->end(), [&](Vec q) { return dist(p, q) > 0.35; });
    }
    step_up_to(d, a, p);
    a.hand("put_down", id, p, p);
    where->push_back(p);
  }
  return ids;
}

Object& laptop(Draw& d) {
  Object l;
  l.id = "laptop";
  l.kind = "laptop";
  l.on = "lab_table";
  l.at = Vec{kLaptopX, kLaptopY};
  l.authorised = false;
  l.colour = "#808080";
  d.objects().push_back(l);
  return d.objects().back();
}

bool fam_lab_own(Draw& d) {
  d.lab_camera();
  d.handling_zone();
  laptop(d);
  const Vec b_from = lab_entry_from(d);
  Actor& b = d.person(b_from, d.u(0.0, 3.0));
  into_lab(b);
  std::vector<Vec> where;
  const auto ids = bring_objects(d, b, 1 + d.pick(2), &where);
  for (size_t i = 0; i < ids.size(); ++i) {
    if (d.chance(0.6)) {
      step_up_to(d, b, where[i]);
      b.hand("touch", ids[i], where[i], std::nullopt, d.u(1.5, 3.5));
    }
  }
  if (d.chance(0.5)) {
    const int i = d.pick(static_cast<int>(ids.size()));
    step_up_to(d, b, where[i]);
    b.hand("pick_up", ids[i], where[i], std::nullopt, 1.5);
    const Vec p = d.table_spot(0.85);
    step_up_to(d, b, p);
    b.hand("put_down", ids[i], p, p);
    where[i] = p;
  }
  if (d.chance(0.3)) b.wait(d.u(1.0, 4.0));
  out_of_lab(d, b);
  d.note(b.id + " brings " + std::to_string(ids.size()) + " object(s) to the table, handles them and leaves");
  return true;
}

bool fam_lab_other(Draw& d) {
  d.lab_camera();
  d.handling_zone();
  laptop(d);
  const Vec b_from = lab_entry_from(d);
  Actor& b = d.person(b_from, d.u(0.0, 3.0));
  into_lab(b);
  std::vector<Vec> where;
  const auto ids = bring_objects(d, b, 1 + d.pick(2), &where);
  if (d.chance(0.4)) {
    step_up_to(d, b, where[0]);
    b.hand("touch", ids[0], where[0], std::nullopt, d.u(1.5, 3.0));
  }
  out_of_lab(d, b);
  // Someone else comes in later and handles one of B's things, or the laptop.
  const Vec c_from = lab_entry_from(d);
  const double c_appear = std::max(0.0, b.t + d.u(-2.0, 8.0) - 1.15 * dist(c_from, {kLabDoorX, 5.0}) / 1.2);
  Actor& c = d.person(c_from, c_appear);
  const bool the_laptop = d.chance(0.3);
  into_lab(c);
  const int i = d.pick(static_cast<int>(ids.size()));
  if (the_laptop) {
    step_up_to(d, c, {kLaptopX, kLaptopY});
    c.hand("touch", "laptop", {kLaptopX, kLaptopY}, std::nullopt, d.u(1.5, 3.0));
  } else {
    step_up_to(d, c, where[i]);
    c.hand("touch", ids[i], where[i], std::nullopt, d.u(1.5, 3.0));
  }
  out_of_lab(d, c);
  d.note(b.id + " brings " + std::to_string(ids.size()) + " object(s) and leaves; " + c.id + " touches " +
         (the_laptop ? std::string("the laptop") : ids[i]));
  return true;
}

struct FamilyEntry {
  const char* name;
  const char* description;
  Family draw;
};

const std::vector<FamilyEntry>& families() {
  static const std::vector<FamilyEntry> f = {
      {"left_bag", "a person carries a bag into view, puts it down and walks away (left bag)", fam_left_bag},
      {"bag_taken", "a bag is left; another person picks it up, soon or later, and walks off (bag taken, left bag when later)", fam_bag_taken},
      {"exchange", "the owner stays by her bag while another person picks it up; both walk off (exchange)", fam_exchange},
      {"owner_returns", "the owner leaves her bag, walks away and comes back for it (left bag then its cancellation, or nothing when she turns back at once)", fam_owner_returns},
      {"owner_stays", "the owner puts her bag down and moves about near it, then takes it (nothing)", fam_owner_stays},
      {"walk_past", "a bag present from the start; people walk past it, some stopping in front of it (nothing)", fam_walk_past},
      {"two_carriers", "two people each put a bag down; one leaves, the other stays or leaves too (one or two left bags)", fam_two_carriers},
      {"crossing", "several people cross the view, some carrying bags they keep, some pausing (nothing)", fam_crossing},
      {"robot_near_bag", "a bag is left; a patrol robot stops beside it or drives past (left bag)", fam_robot_near_bag},
      {"lab_own", "a person brings things to the marked lab table and handles them (nothing)", fam_lab_own},
      {"lab_other", "a person brings things to the lab table and leaves; another person touches one, or the laptop (unauthorised object)", fam_lab_other},
  };
  return f;
}

// True when the segment from the camera's centre to `p` (height pz) passes through a standing
// person (an upright cylinder) before it reaches p: the point is hidden from that camera.
bool hidden_by_people(const ViewCamera& c, double px, double py, double pz, const World& w) {
  const double dx = px - c.x, dy = py - c.y, dd = dx * dx + dy * dy;
  if (dd < 1e-9) return false;
  for (const PersonEntity& q : w.people()) {
    if (!q.present || q.gone) continue;
    // The stretch of the segment (parameter t in [0, 1]) within the person's radius on the floor.
    const double ox = c.x - q.pose.x, oy = c.y - q.pose.y, r = q.spec.radius;
    const double b = 2 * (dx * ox + dy * oy), cc = ox * ox + oy * oy - r * r;
    const double disc = b * b - 4 * dd * cc;
    if (disc <= 0) continue;
    const double t0 = (-b - std::sqrt(disc)) / (2 * dd), t1 = (-b + std::sqrt(disc)) / (2 * dd);
    // Only what stands between the camera and the point (the point's own surroundings, within a
    // few centimetres of it, do not hide it).
    const double end = std::min(t1, 1.0 - 0.05 / std::sqrt(dd));
    if (end <= std::max(t0, 0.0)) continue;
    // The ray descends from the camera: it is lowest at the stretch's far end.
    const double z_end = c.z + end * (pz - c.z);
    if (z_end < q.spec.height) return true;
  }
  return false;
}

}  // namespace

Status check_generated_script(const Scenario& scenario, const WorldOptions& options) {
  WorldOptions wo = options;
  if (!wo.plugins) wo.controllers = false;
  auto world = World::create(scenario, wo);
  if (!world) return world.error();
  World& w = **world;
  std::vector<ViewCamera> cams;
  for (const CameraSpec& cs : scenario.cameras) {
    ViewCamera c;
    c.id = cs.id;
    c.x = cs.position.x;
    c.y = cs.position.y;
    c.z = cs.position.z;
    c.yaw = cs.yaw;
    c.pitch = cs.pitch;
    c.width = cs.width;
    c.height = cs.height;
    c.hfov = cs.fx ? 2 * std::atan(0.5 * cs.width / *cs.fx) : cs.hfov.value_or(deg(60));
    c.min_range = 0;
    c.max_range = 8.0;  // the ground-truth sensor's and the scoring's range
    cams.push_back(c);
  }
  // Per object: (time, seconds seen so far) at each step.
  std::vector<std::vector<std::pair<SimTime, double>>> seen(w.objects().size());
  std::vector<double> seen_total(w.objects().size(), 0.0);
  auto look = [&] {
    const double dt = to_seconds(w.step_length());
    for (size_t i = 0; i < w.objects().size(); ++i) {
      const ObjectEntity& o = w.objects()[i];
      if (o.present && o.carrier < 0) {
        const double top = o.z + o.spec.size_z, mid = o.z + 0.5 * o.spec.size_z;
        for (const ViewCamera& c : cams) {
          if (!c.sees({o.pose.x, o.pose.y}, top, 4)) continue;
          if (!hidden_by_people(c, o.pose.x, o.pose.y, top, w) && !hidden_by_people(c, o.pose.x, o.pose.y, mid, w)) {
            seen_total[i] += dt;
            break;
          }
        }
      }
      seen[i].push_back({w.time(), seen_total[i]});
    }
  };
  auto all_gone = [&] {
    for (const auto& p : w.people())
      if (!p.gone) return false;
    return true;
  };
  // How long each walker has been held in place (under a fifth of a metre a second).
  std::vector<double> held(w.people().size(), 0.0);
  while (!w.finished() && !all_gone()) {
    if (Status s = w.advance(); !s) return s;
    look();
    for (size_t i = 0; i < w.people().size(); ++i) {
      const PersonEntity& p = w.people()[i];
      const bool walking = p.present && !p.gone && p.phase == PersonEntity::Phase::kWalking;
      held[i] = walking && std::hypot(p.velocity.x, p.velocity.y) < 0.2 ? held[i] + to_seconds(w.step_length()) : 0.0;
      if (held[i] > kMaxHeldWhileWalking) {
        char b[200];
        std::snprintf(b, sizeof b, " is held in place for %.1f s while walking, at (%.2f, %.2f) at %.1f s (wedged: the simulator's people do not step round)",
                      held[i], p.pose.x, p.pose.y, to_seconds(w.time()));
        return bad_input(scenario.file.string(), 0, "people", p.spec.id + b);
      }
    }
  }
  std::string stuck;
  for (const auto& p : w.people())
    if (!p.gone) stuck += (stuck.empty() ? "" : ", ") + p.spec.id;
  if (!stuck.empty()) return bad_input(scenario.file.string(), 0, "people", "did not finish their scripts: " + stuck);
  for (const GroundTruthEvent& e : w.events()) {
    size_t i = 0;
    while (i < w.objects().size() && w.objects()[i].spec.id != e.object) ++i;
    if (i == w.objects().size()) continue;
    const SimTime due = std::max(e.t, e.confirmed);
    double before = 0;
    for (const auto& [t, s] : seen[i]) {
      if (t > due) break;
      before = s;
    }
    if (before < kMinSeenBeforeEvent) {
      char b[160];
      std::snprintf(b, sizeof b, " is seen lying still, unhidden, for %.1f s before its %s is due (at least %.1f)", before,
                    e.kind.c_str(), kMinSeenBeforeEvent);
      return bad_input(scenario.file.string(), 0, "objects", e.object + b);
    }
  }
  return Status::Ok();
}

const std::vector<std::string>& scenario_families() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n;
    for (const auto& f : families()) n.push_back(f.name);
    return n;
  }();
  return names;
}

std::string scenario_family_description(const std::string& family) {
  for (const auto& f : families())
    if (family == f.name) return f.description;
  return "";
}

Result<GeneratedScenario> generate_scenario(const ScenarioGenOptions& o) {
  const FamilyEntry* fam = nullptr;
  for (const auto& f : families())
    if (o.family == f.name) fam = &f;
  if (!fam) {
    std::string known;
    for (const auto& n : scenario_families()) known += (known.empty() ? "" : ", ") + n;
    return bad_input("", 0, "family", "unknown scenario family '" + o.family + "' (known: " + known + ")");
  }
  if (!(o.sensor.empty() || o.sensor == "truth" || o.sensor == "truth-clean" || o.sensor == "sgbm" || o.sensor == "platform"))
    return bad_input("", 0, "sensor", "must be none, truth, truth-clean, sgbm or platform, not '" + o.sensor + "'");
  if (o.index < 0) return bad_input("", 0, "index", "must be >= 0");
  GeneratedScenario g;
  g.family = o.family;
  g.name = o.family + "_" + std::to_string(o.seed) + "_" + std::to_string(o.index);
  // Each scenario draws from its own stream; a draw that does not fit (no place in view, a script
  // the parser refuses) is drawn again from the next attempt's stream.
  std::string last_error;
  for (int attempt = 0; attempt < kAttempts; ++attempt) {
    Draw d(Rng::stream(o.seed, o.family + "/" + std::to_string(o.index) + "/" + std::to_string(attempt)), o);
    d.reserve();
    if (!fam->draw(d) || !d.paths_clear()) continue;
    g.text = d.yaml(g.name, o.family);
    g.summary = d.summary();
    auto parsed = parse_scenario(g.text, o.out_dir / (g.name + ".yaml"));
    if (parsed) {
      if (!o.dry_run) return g;
      Status s = check_generated_script(*parsed, o.world);
      if (s) return g;
      if (s.error().kind != ErrorKind::kBadInput) return s.error();
      last_error = s.error().str();
      continue;
    }
    last_error = parsed.error().str();
    // An internal error, or the map or robot model itself failing, is not a matter of drawing again.
    const std::string& key = parsed.error().key;
    if (parsed.error().kind != ErrorKind::kBadInput || key == "map" || key.find("urdf") != std::string::npos)
      return parsed.error();
  }
  return bad_input("", 0, "family", "no valid '" + o.family + "' scenario in " + std::to_string(kAttempts) + " draws for seed " + std::to_string(o.seed) +
                                        " index " + std::to_string(o.index) + (last_error.empty() ? "" : "; last: " + last_error));
}

}  // namespace vigil
