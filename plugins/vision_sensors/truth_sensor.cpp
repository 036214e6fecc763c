// `truth`: the fast vision sensor model. Each camera tick it reports the people, objects and
// robots the camera can see (inside the image, within max_range on the floor, not behind a
// wall of the map) as map-frame tracks, with Gaussian position noise, a miss probability per
// detection and Poisson false alarms on the visible floor. Identities are stable per entity per
// camera; every false alarm has a fresh id. Seeded, so a run repeats byte for byte.
#include <cmath>
#include <map>
#include <memory>
#include <optional>

#include "plugins/vision_sensors/vision_sensor.h"
#include "world/ranger.h"
#include "common/rng.h"

namespace vigil::sensors {

namespace {

class TruthSensor : public VisionSensor {
 public:
  std::vector<ParamSpec> params() const override {
    return {
        {"max_range", ParamType::kNumber, 8.0, 0.1, 1000, "m on the floor from the camera; farther is not seen"},
        {"position_noise", ParamType::kNumber, 0.05, 0, 10, "m, standard deviation of x and y"},
        {"miss_rate", ParamType::kNumber, 0.0, 0, 1, "probability that a visible entity is not reported in a tick"},
        {"false_alarm_rate", ParamType::kNumber, 0.0, 0, 100, "mean false tracks per tick (Poisson)"},
        {"walls_occlude", ParamType::kBool, true, 0, 0, "entities behind a wall of the map are not seen"},
        {"confidence", ParamType::kNumber, 0.9, 0, 1, "confidence written on every track"},
    };
  }

  Status configure(const ParamSet& p, const SensorContext& ctx) override {
    ctx_ = ctx;
    max_range_ = p.number("max_range");
    noise_ = p.number("position_noise");
    miss_ = p.number("miss_rate");
    false_alarms_ = p.number("false_alarm_rate");
    walls_occlude_ = p.boolean("walls_occlude");
    confidence_ = p.number("confidence");
    rng_ = Rng(ctx.seed);
    return Status::Ok();
  }

  bool wants_frames() const override { return false; }

  Status tick(const vision::StereoFrame*, const World& world, std::vector<vision::Track>* out) override {
    if (!walls_) {
      sight_map_ = sight_map(world, ctx_.model.map_from_optical().translation().z());
      walls_ = std::make_unique<WallRaycaster>(sight_map_);
    }
    const SimTime now = world.time();
    for (const auto& r : world.robots()) {
      see(world, now, "robot:" + r.spec.id, vision::TrackClass::kRobot, {r.pose.x, r.pose.y},
          r.model.height, 2 * r.model.radius, out);
    }
    for (const auto& p : world.people()) {
      if (!p.present) continue;
      see(world, now, "person:" + p.spec.id, vision::TrackClass::kPerson, {p.pose.x, p.pose.y}, p.spec.height,
          2 * p.spec.radius, out);
    }
    for (const auto& o : world.objects()) {
      if (!o.present) continue;
      see(world, now, "object:" + o.spec.id, o.spec.kind == ObjectKind::kBag ? vision::TrackClass::kBag : vision::TrackClass::kUnknown,
          {o.pose.x, o.pose.y}, o.z + o.spec.size_z, std::max(o.spec.size_x, o.spec.size_y), out);
    }
    const int n_false = poisson(false_alarms_);
    for (int i = 0; i < n_false; ++i) {
      if (auto p = random_visible_floor_point(world)) {
        vision::Track t = base_track(now);
        t.id = next_id_++;
        t.cls = rng_.uniform() < 0.5 ? vision::TrackClass::kPerson : vision::TrackClass::kBag;
        t.x = p->x;
        t.y = p->y;
        t.height = t.cls == vision::TrackClass::kPerson ? 1.7 : 0.4;
        t.width = t.cls == vision::TrackClass::kPerson ? 0.5 : 0.4;
        out->push_back(t);
      }
    }
    return Status::Ok();
  }

 private:
  struct Memory {
    int id = 0;
    SimTime t = 0;
    Vec2 p;
  };

  vision::Track base_track(SimTime now) const {
    vision::Track t;
    t.stamp_ns = now;
    t.camera = ctx_.camera.id;
    t.confidence = confidence_;
    return t;
  }

  // Inside the image (the centre at half height, or the top, projects into it), within range
  // on the floor, and with a clear line of sight across the map.
  bool visible(Vec2 p, double height) const {
    const Eigen::Vector3d& c = ctx_.model.map_from_optical().translation();
    const Vec2 cam{c.x(), c.y()};
    const double range = (p - cam).norm();
    if (range > max_range_) return false;
    const auto& k = ctx_.model.intrinsics();
    bool in_image = false;
    for (double z : {0.5 * height, height}) {
      Eigen::Vector2d px;
      if (ctx_.model.project_map(Eigen::Vector3d(p.x, p.y, z), &px) && px.x() >= 0 && px.y() >= 0 &&
          px.x() <= k.width - 1 && px.y() <= k.height - 1)
        in_image = true;
    }
    if (!in_image) return false;
    if (walls_occlude_ && range > 1e-6) {
      const Vec2 dir{(p.x - cam.x) / range, (p.y - cam.y) / range};
      if (walls_->raycast_dir(cam, dir, range) < range - 0.05) return false;
    }
    return true;
  }

  void see(const World& world, SimTime now, const std::string& key, vision::TrackClass cls, Vec2 p, double height,
           double width, std::vector<vision::Track>* out) {
    if (!visible(p, height)) return;
    if (miss_ > 0 && rng_.uniform() < miss_) return;
    auto [it, fresh] = memory_.try_emplace(key);
    Memory& m = it->second;
    if (fresh) m.id = next_id_++;
    vision::Track t = base_track(now);
    t.id = m.id;
    t.cls = cls;
    t.x = p.x + (noise_ > 0 ? rng_.normal(0, noise_) : 0.0);
    t.y = p.y + (noise_ > 0 ? rng_.normal(0, noise_) : 0.0);
    if (!fresh && now > m.t) {
      const double dt = to_seconds(now - m.t);
      t.vx = (p.x - m.p.x) / dt;
      t.vy = (p.y - m.p.y) / dt;
    }
    t.height = height;
    t.width = width;
    m.t = now;
    m.p = p;
    out->push_back(t);
  }

  int poisson(double lambda) {
    if (lambda <= 0) return 0;
    const double limit = std::exp(-lambda);
    int k = 0;
    double prod = rng_.uniform();
    while (prod > limit && k < 1000) {
      ++k;
      prod *= rng_.uniform();
    }
    return k;
  }

  // A free floor point the camera sees within range, from a random pixel's ray (up to 20 tries).
  std::optional<Vec2> random_visible_floor_point(const World& world) {
    const auto& k = ctx_.model.intrinsics();
    const Eigen::Vector3d c = ctx_.model.map_from_optical().translation();
    for (int i = 0; i < 20; ++i) {
      const Eigen::Vector3d q = ctx_.model.back_project_map(rng_.uniform(0, k.width - 1), rng_.uniform(0, k.height - 1), 1.0);
      const Eigen::Vector3d d = q - c;
      if (d.z() >= -1e-9) continue;
      const double s = -c.z() / d.z();
      const Vec2 p{c.x() + s * d.x(), c.y() + s * d.y()};
      if (world.map().is_free(p) && visible(p, 0.0)) return p;
    }
    return std::nullopt;
  }

  SensorContext ctx_;
  double max_range_ = 8, noise_ = 0.05, miss_ = 0, false_alarms_ = 0, confidence_ = 0.9;
  bool walls_occlude_ = true;
  Rng rng_;
  OccupancyGrid sight_map_;  // what walls_ casts against
  std::unique_ptr<WallRaycaster> walls_;
  std::map<std::string, Memory> memory_;
  int next_id_ = 1;
};

}  // namespace

std::unique_ptr<VisionSensor> make_truth_sensor() { return std::make_unique<TruthSensor>(); }

}  // namespace vigil::sensors
