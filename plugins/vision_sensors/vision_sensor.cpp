#include "plugins/vision_sensors/vision_sensor.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <mutex>

#include "common/rng.h"
#include "world/video_writer.h"

namespace vigil::sensors {

std::unique_ptr<VisionSensor> make_truth_sensor();     // truth_sensor.cpp
std::unique_ptr<VisionSensor> make_planview_sensor();  // tracker_sensor.cpp
std::unique_ptr<VisionSensor> make_mser_sensor();      // tracker_sensor.cpp

namespace {

using Factory = std::function<std::unique_ptr<VisionSensor>()>;

std::map<std::string, Factory>& registry() {
  static std::map<std::string, Factory> r = [] {
    std::map<std::string, Factory> m;
    m["truth"] = make_truth_sensor;
    m["planview"] = make_planview_sensor;
    m["mser"] = make_mser_sensor;
    return m;
  }();
  return r;
}

std::mutex& registry_mutex() {
  static std::mutex m;
  return m;
}

}  // namespace

bool vision_sensor_exists(const std::string& name) {
  std::lock_guard<std::mutex> lock(registry_mutex());
  return registry().count(name) != 0;
}

std::vector<std::string> vision_sensor_names() {
  std::lock_guard<std::mutex> lock(registry_mutex());
  std::vector<std::string> names;
  for (const auto& [n, f] : registry()) names.push_back(n);
  return names;
}

Result<std::unique_ptr<VisionSensor>> create_vision_sensor(const std::string& name) {
  Factory f;
  {
    std::lock_guard<std::mutex> lock(registry_mutex());
    auto it = registry().find(name);
    if (it != registry().end()) f = it->second;
  }
  if (!f) {
    std::string known;
    for (const auto& n : vision_sensor_names()) known += (known.empty() ? "" : ", ") + n;
    return bad_input("", 0, "plugin", "no vision sensor '" + name + "' (known: " + known + ")");
  }
  return f();
}

void register_vision_sensor(const std::string& name, Factory factory) {
  std::lock_guard<std::mutex> lock(registry_mutex());
  registry()[name] = std::move(factory);
}

// ---- VisionSensorHost ----

Result<std::unique_ptr<VisionSensorHost>> VisionSensorHost::create(const Scenario& scenario, render::CameraRig* rig) {
  std::unique_ptr<VisionSensorHost> host(new VisionSensorHost());
  // The building's furniture (what a camera system may know of the floor plan: table tops).
  std::vector<FloorplanFurniture> furniture;
  if (!scenario.furniture.empty()) {
    auto plan = load_floorplan(scenario.map);
    if (!plan) return plan.error();
    furniture = plan->furniture;
  }
  for (size_t i = 0; i < scenario.cameras.size(); ++i) {
    const CameraSpec& cam = scenario.cameras[i];
    if (cam.plugin.empty()) continue;
    const std::string key = "cameras[" + std::to_string(i) + "]";
    if (!vision_sensor_exists(cam.plugin)) {
      std::string known;
      for (const auto& n : vision_sensor_names()) known += (known.empty() ? "" : ", ") + n;
      return bad_input(scenario.file.string(), cam.line, key + ".plugin",
                       "'" + cam.plugin + "' is not a vision sensor (vision sensors: " + known + ")");
    }
    auto sensor = create_vision_sensor(cam.plugin);
    if (!sensor) return sensor.error();
    auto params = resolve_params((*sensor)->params(), cam.params, scenario.file.string(), key + ".params");
    if (!params) return params.error();
    SensorContext ctx;
    ctx.camera = cam;
    ctx.model = render::camera_model(cam);
    ctx.scenario_file = scenario.file.string();
    ctx.furniture = furniture;
    ctx.seed = Rng::stream(scenario.seed, "vision_sensor:" + cam.id).next();
    if (Status s = (*sensor)->configure(*params, ctx); !s) {
      Error e = s.error();
      if (e.file.empty()) e.file = scenario.file.string();
      if (e.line == 0) e.line = cam.line;
      if (e.key.empty() || e.key.rfind(key, 0) != 0) e.key = key + ".params" + (e.key.empty() ? "" : "." + e.key);
      return e;
    }
    auto a = std::make_unique<Attached>();
    a->camera = cam;
    a->file = scenario.file.string();
    a->key = key;
    a->sensor = std::move(*sensor);
    a->model = ctx.model;
    if (a->sensor->wants_frames()) {
      if (!rig) return internal_error("camera " + cam.id + ": a frame-consuming vision sensor needs the camera rig");
      VisionSensorHost* self = host.get();
      Attached* att = a.get();
      // The tick (and the annotated video) on the camera's own thread; the rules, the tracks'
      // output and the events in camera order on the simulation's.
      rig->add_worker(cam.id, [self, att](const CameraSpec&, const vision::StereoFrame& frame, const World& world) {
        att->fresh.clear();
        if (Status s = att->sensor->tick(&frame, world, &att->fresh); !s) return Status(in_context(*att, world, s.error()));
        if (self->videos_ && self->writing_) {
          const cv::Mat img = att->sensor->annotate(frame, att->fresh);
          if (!img.empty()) {
            if (!att->video.is_open()) {
              const std::filesystem::path dir = self->out_dir_ / "cameras";
              std::error_code ec;
              std::filesystem::create_directories(dir, ec);
              const auto path = dir / (att->camera.id + "_" + att->camera.plugin + video_extension(self->video_format_));
              if (!att->video.open(path, att->camera.rate_hz, img.size(), self->video_format_))
                return Status(bad_input(path.string(), 0, "", "cannot open the video for writing: " + att->video.why()));
            }
            att->video.write(img);
          }
        }
        return Status::Ok();
      });
      rig->add_consumer(cam.id, [self, att](const CameraSpec&, const vision::StereoFrame& frame, const World& world) {
        ++att->index;
        return self->emit(att, world, frame.stamp_ns, &att->fresh);
      });
    }
    host->sensors_.push_back(std::move(a));
  }
  return host;
}

vision::ActivityRuleParams activity_rule_params(const World& world) {
  const Scenario& sc = world.scenario();
  vision::ActivityRuleParams p;
  p.left_bag_distance = sc.rules.left_bag_distance;
  p.left_bag_time = sc.rules.left_bag_time;
  p.exchange_distance = sc.rules.exchange_distance;
  for (const std::string& name : sc.rules.handling_zones)
    for (const auto& f : world.furniture())
      if (f.name == name) p.handling_zones.push_back({f.name, f.pose.x, f.pose.y, f.pose.yaw, f.size_x, f.size_y});
  // The operator's marking of single objects, where they lie (for camera systems that cannot see
  // them on a table); handling zones judge the objects the cameras do see there. Nothing is read
  // from the scenario's objects (which are the ground truth).
  for (const auto& r : sc.rules.restricted_objects) p.watched.push_back({r.name, {r.at.point.x, r.at.point.y, r.z}, false});
  return p;
}

Status VisionSensorHost::start(const World& world, const std::filesystem::path& out_dir) {
  tracks_.clear();
  events_.clear();
  const vision::ActivityRuleParams rp = activity_rule_params(world);
  robot_radius_ = rp.robot_radius;
  for (auto& a : sensors_) {
    vision::ActivityRuleParams own = rp;
    own.hands_seen = a->sensor->sees_hands();
    auto rules = vision::ActivityRules::create(own, a->camera.id, a->model);
    if (!rules) return in_context(*a, world, rules.error());
    a->rules.emplace(std::move(*rules));
  }
  out_dir_ = out_dir;
  if (!out_dir.empty() && !sensors_.empty()) {
    if (Status s = out_.open(out_dir / "tracks.jsonl"); !s) return s;
    events_path_ = (out_dir / "camera_events.jsonl").string();
    events_out_ = std::fopen(events_path_.c_str(), "wb");
    if (!events_out_) return bad_input(events_path_, 0, "", "cannot create file");
    writing_ = true;
  }
  return after_step(world);
}

Status VisionSensorHost::after_step(const World& world) {
  for (auto& a : sensors_) {
    if (a->sensor->wants_frames() || world.time() < a->next_tick) continue;
    std::vector<vision::Track> fresh;
    if (Status s = a->sensor->tick(nullptr, world, &fresh); !s) return Status(in_context(*a, world, s.error()));
    ++a->index;
    a->next_tick = from_seconds(static_cast<double>(a->index) / a->camera.rate_hz);
    if (Status s = emit(a.get(), world, world.time(), &fresh); !s) return s;
  }
  return Status::Ok();
}

Status VisionSensorHost::emit(Attached* a, const World& world, int64_t stamp_ns, std::vector<vision::Track>* fresh) {
  // The robots' own pose estimates, as they publish them: not the truth.
  std::vector<vision::ActivityRules::RobotPosition> robots;
  for (const RobotEntity& r : world.robots()) {
    // A controller's localised estimate when it reports one, else the wheel odometry.
    const RobotReport* rep = world.last_report(r.spec.id);
    if (rep && rep->localized) robots.push_back({rep->pose.x, rep->pose.y});
    else robots.push_back({r.state.odometry.x, r.state.odometry.y});
  }
  // A bag-sized track where a robot says it is, is that robot (a robot seen through a doorway,
  // or far off with its mast unresolved, is as low as a bag): reported as a robot, as the rules
  // take it (ActivityRuleParams::robot_radius).
  // And one whose top the image cuts (its height only a lower bound: legs below the top edge at
  // the far end of the view) is classed robot by its height only when a robot says it is there;
  // elsewhere it is a person cut off at the waist.
  for (vision::Track& t : *fresh) {
    const bool robot_there = std::any_of(robots.begin(), robots.end(), [&](const auto& r) {
      return std::hypot(t.x - r.x, t.y - r.y) < robot_radius_;
    });
    if (t.cls == vision::TrackClass::kBag && robot_there) t.cls = vision::TrackClass::kRobot;
    if (t.cls == vision::TrackClass::kRobot && t.top_cut && !robot_there) t.cls = vision::TrackClass::kPerson;
  }
  if (a->rules) {
    auto events = a->rules->update(stamp_ns, *fresh, robots);
    if (!events) {
      Error e = events.error();
      e.message = "camera " + a->camera.id + ", activity rules: " + e.message;
      return internal_error(e.str());  // the sensor produced tracks the rules cannot take: our bug
    }
    for (const vision::Event& ev : *events) {
      if (events_out_) {
        const std::string line = vision::format_event_json(ev) + "\n";
        if (std::fwrite(line.data(), 1, line.size(), events_out_) != line.size())
          return internal_error("cannot write " + events_path_);
      }
      events_.push_back(ev);
      if (sink_) {
        if (Status s = sink_(ev); !s) return s;
      }
    }
  }
  for (auto& t : *fresh) {
    if (writing_) {
      if (Status s = out_.write(t); !s) return s;
    }
    ++track_count_;
    if (keep_tracks_) tracks_.push_back(std::move(t));
  }
  return Status::Ok();
}

Error VisionSensorHost::in_context(const Attached& a, const World& world, Error e) {
  char when[48];
  std::snprintf(when, sizeof when, " (at t = %.3f s)", to_seconds(world.time()));
  e.message = "camera " + a.camera.id + ", vision sensor " + a.camera.plugin + ": " + e.message + when;
  if (e.file.empty()) {
    e.file = a.file;
    e.line = a.camera.line;
  }
  if (e.key.empty() || e.key == "frame") e.key = a.key + ".plugin";
  return e;
}

Status VisionSensorHost::finish(const World&) {
  for (auto& a : sensors_)
    if (a->video.is_open()) a->video.release();
  if (!writing_) return Status::Ok();
  writing_ = false;
  const bool events_ok = std::fclose(events_out_) == 0;
  events_out_ = nullptr;
  if (Status s = out_.close(); !s) return s;
  if (!events_ok) return internal_error("cannot write " + events_path_);
  return Status::Ok();
}

VisionSensorHost::~VisionSensorHost() {
  if (events_out_) std::fclose(events_out_);
}

}  // namespace vigil::sensors
