// The processes of a multi-process run (chapter 10.6.3: camera PCs, the video server, robots),
// talking over Cyclone DDS:
//   vigil camera-node SCENARIO --camera ID   runs the world and that camera's vision sensor and
//                                            activity rules; publishes its events (camera frame)
//   vigil server SCENARIO                    the video server: checks, map frame, merging; publishes
//                                            incidents and writes them to --out/events.jsonl
//   vigil events                             subscribes to incidents and prints them (a robot's view)
//   vigil robot-node SCENARIO --robot ID     runs the world with that team robot alone: its
//                                            controller takes the incidents and talks to its
//                                            mates over the team topic; pictures, robots.jsonl
// All take --session NAME (the DDS partition; processes of one system share it), --dds-domain and
// --dds-config. Documented in docs/DDS.md.
#include <signal.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <set>
#include <thread>

#include <nlohmann/json.hpp>

#include "plugins/builtin.h"
#include "plugins/dds_bridge/dds.h"
#include "plugins/dds_bridge/event_relay.h"
#include "plugins/dds_bridge/event_server.h"
#include "plugins/dds_bridge/team_transport.h"
#include "plugins/stereo_camera/robot_camera.h"
#include "plugins/stereo_camera/stereo_camera.h"
#include "plugins/vision_sensors/vision_sensor.h"
#include "tools/vigil/commands.h"
#include "tools/vigil/plugin_search.h"
#include "world/plugin.h"
#include "world/runner.h"
#include "world/world.h"

namespace vigil::cli {
namespace {

namespace fs = std::filesystem;

std::atomic<bool> g_stop{false};
void on_signal(int) { g_stop = true; }
void catch_signals() {
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
}

struct DdsOpts {
  std::string session = "vigil";
  uint32_t domain = 0;
  std::string config;
};

void add_dds_options(CLI::App* cmd, DdsOpts* o) {
  cmd->add_option("--session", o->session, "DDS session (partition vigil.NAME) shared by the processes of one system")
      ->capture_default_str();
  cmd->add_option("--dds-domain", o->domain, "DDS domain id (0 to 232)")->capture_default_str();
  cmd->add_option("--dds-config", o->config, "Cyclone DDS XML configuration (default: loopback only; see docs/DDS.md)");
}

dds::DomainOptions domain_options(const DdsOpts& o) {
  dds::DomainOptions d;
  d.domain_id = o.domain;
  d.session = o.session;
  if (!o.config.empty()) {
    auto cfg = dds::read_config(o.config);
    if (!cfg) throw Exit{report(cfg.error())};
    d.config = *cfg;
  }
  return d;
}

std::unique_ptr<dds::Participant> participant(const DdsOpts& o) {
  auto p = dds::Participant::create(domain_options(o));
  if (!p) throw Exit{report(p.error())};
  return std::move(*p);
}

Scenario load_checked(const std::string& file, PluginRegistry* registry) {
  register_builtin_plugins(*registry);
  for (const auto& d : plugin_search_path({})) registry->add_search_dir(d);
  ScenarioContext ctx;
  ctx.plugin_exists = [registry](const std::string& n) { return registry->exists(n) || sensors::vision_sensor_exists(n); };
  auto sc = load_scenario(file, ctx);
  if (!sc) throw Exit{report(sc.error())};
  return *sc;
}

// Holds simulated time to at most `speed` times wall time. With an epoch (Unix time, s) the
// world's time 0 is that instant, so processes given one epoch share a clock; a process started
// after it runs as fast as it can until it has caught up.
class Pacer : public RunObserver {
 public:
  explicit Pacer(double speed, double epoch = 0) : speed_(speed), epoch_(epoch) {}
  Status start(const World&, const fs::path&) override {
    t0_ = std::chrono::steady_clock::now();
    if (epoch_ > 0) {
      const double now = std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
      t0_ -= std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(now - epoch_));
    }
    return Status::Ok();
  }
  // True while the world is more than `slack_s` of wall time behind the shared clock (a
  // process started after the epoch, catching up).
  bool behind(const World& w, double slack_s = 0.25) const {
    if (speed_ <= 0) return false;
    const auto due = t0_ + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                               std::chrono::duration<double>(to_seconds(w.time()) / speed_ + slack_s));
    return std::chrono::steady_clock::now() > due;
  }
  Status after_step(const World& w) override {
    if (speed_ <= 0) return Status::Ok();
    const auto due = t0_ + std::chrono::duration<double>(to_seconds(w.time()) / speed_);
    std::this_thread::sleep_until(due);
    return g_stop ? Status(internal_error("stopped by a signal")) : Status::Ok();
  }

 private:
  double speed_, epoch_;
  std::chrono::steady_clock::time_point t0_;
};

void add_camera_node(CLI::App& app) {
  struct Opts {
    std::string scenario, camera, sensor, out, source;
    double speed = 0, linger = 2, wait_for_server = 0, epoch = 0;
    std::optional<double> duration;
    DdsOpts dds;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand("camera-node", "Run one camera's vision pipeline and publish its events over DDS");
  cmd->add_option("scenario", o->scenario, "scenario YAML file")->required();
  cmd->add_option("--camera", o->camera, "the camera this node serves")->required();
  cmd->add_option("--sensor", o->sensor, "vision sensor overriding the camera's plugin (truth, planview, mser)");
  cmd->add_option("--out", o->out, "also write this node's tracks.jsonl and camera_events.jsonl here");
  cmd->add_option("--source", o->source,
                  "recorded frames instead of rendered ones: stereo:LEFT,RIGHT,RIG (a rig file with its pose, see "
                  "docs/RIG.md); one frame per camera tick");
  cmd->add_option("--duration", o->duration, "simulated seconds overriding the scenario's");
  cmd->add_option("--speed", o->speed, "run at most this many times real time (0: as fast as possible)")->capture_default_str();
  cmd->add_option("--wait-for-server", o->wait_for_server, "seconds to wait for a subscriber before starting")->capture_default_str();
  cmd->add_option("--linger", o->linger, "seconds to stay up after the run, serving durable events to late joiners")
      ->capture_default_str();
  cmd->add_option("--epoch", o->epoch, "Unix time (s) of the world's time 0, shared by the processes of one run (with --speed)");
  add_dds_options(cmd, &o->dds);
  cmd->callback([o] {
    catch_signals();
    PluginRegistry registry;
    Scenario sc = load_checked(o->scenario, &registry);
    if (auto found = find_camera(sc, o->camera, "--camera"); !found) throw Exit{report(found.error())};
    for (auto& c : sc.cameras) {
      if (c.id == o->camera) {
        if (!o->sensor.empty()) {
          if (!sensors::vision_sensor_exists(o->sensor))
            throw Exit{report(bad_input("", 0, "--sensor", "'" + o->sensor + "' is not a vision sensor"))};
          if (o->sensor != c.plugin) c.params.clear();
          c.plugin = o->sensor;
        }
        if (c.plugin.empty())
          throw Exit{report(bad_input(sc.file.string(), c.line, "plugin", "camera '" + c.id + "' has no vision sensor: give --sensor truth|planview"))};
      } else {
        c.plugin.clear();  // this node serves one camera
      }
    }
    // A recorded rig in the camera's place: the scenario's camera takes the rig's model and pose.
    std::unique_ptr<vision::FrameSource> recorded;
    if (!o->source.empty()) {
      WorldOptions wo;
      wo.plugins = builtin_plugin_registry();
      auto src = render::open_any_frame_source(o->source, wo);
      if (!src) throw Exit{report(src.error())};
      if (!(*src)->is_stereo() || !(*src)->camera_model() || !(*src)->has_pose())
        throw Exit{report(bad_input(o->source, 0, "--source",
                                    "a camera node needs a calibrated stereo source whose rig file carries the pose "
                                    "(vigil calibrate floor, or ;pose=X,Y,Z,YAW,PITCH,ROLL); got " + (*src)->describe()))};
      for (auto& c : sc.cameras)
        if (c.id == o->camera) c = render::camera_spec_from_model(c, *(*src)->camera_model());
      recorded = std::move(*src);
    }
    auto part = participant(o->dds);
    auto pub = dds::CameraEventPublisher::create(*part);
    if (!pub) throw Exit{report(pub.error())};
    if (o->wait_for_server > 0 && (*pub)->writer().wait_for_readers(1, o->wait_for_server) < 1)
      std::fprintf(stderr, "camera-node %s: no subscriber after %.1f s; publishing anyway (durable)\n", o->camera.c_str(),
                   o->wait_for_server);
    render::CameraRigOptions rig_options;
    rig_options.video = false;
    render::CameraRig rig(rig_options);
    if (recorded) rig.set_recorded_source(o->camera, std::move(recorded));
    auto host = sensors::VisionSensorHost::create(sc, &rig);
    if (!host) throw Exit{report(host.error())};
    (*host)->set_keep_tracks(false);  // a node runs for hours: nothing kept but what it publishes
    int published = 0;
    dds::CameraEventPublisher* pp = pub->get();
    (*host)->set_event_sink([pp, &published](const vision::Event& e) {
      if (Status s = pp->publish(e); !s) return s;
      ++published;
      std::printf("%s\n", vision::format_event_json(e).c_str());
      std::fflush(stdout);
      return Status::Ok();
    });
    Pacer pacer(o->speed, o->epoch);
    RunOptions ro;
    ro.world.plugins = builtin_plugin_registry();
    ro.out_dir = o->out;
    ro.duration = o->duration;
    ro.video = false;
    ro.observers = {&pacer, host->get()};
    if (rig.active()) ro.observers.push_back(&rig);
    auto sum = run_scenario(sc, ro);
    if (!sum) throw Exit{report(sum.error())};
    std::fprintf(stderr, "camera-node %s: %.1f s simulated, %d events published (session %s)\n", o->camera.c_str(),
                 sum->sim_seconds, published, o->dds.session.c_str());
    if (!o->source.empty()) {
      const auto it = rig.frames().find(o->camera);
      std::fprintf(stderr, "camera-node %s: %lld recorded frames from %s%s\n", o->camera.c_str(),
                   static_cast<long long>(it == rig.frames().end() ? 0 : it->second), o->source.c_str(),
                   rig.recorded_ended() ? " (the source ended before the run)" : "");
    }
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(o->linger);
    while (!g_stop && std::chrono::steady_clock::now() < end) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  });
}

void add_server(CLI::App& app) {
  struct Opts {
    std::string scenario, out;
    double idle_exit = 0, max_seconds = 0, merge_distance = 1.0, merge_time = 5.0;
    DdsOpts dds;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand("server", "The video server: camera events in, incidents in the map frame out, over DDS");
  cmd->add_option("scenario", o->scenario, "scenario YAML file (its map and camera poses)")->required();
  cmd->add_option("--out", o->out, "write incidents to DIR/events.jsonl (appended)");
  cmd->add_option("--idle-exit", o->idle_exit, "exit after this many seconds without camera events, once one came (0: never)")
      ->capture_default_str();
  cmd->add_option("--max-seconds", o->max_seconds, "exit after this many seconds (0: run until SIGINT/SIGTERM)")->capture_default_str();
  cmd->add_option("--merge-distance", o->merge_distance, "m: reports of one kind this close are one incident")->capture_default_str();
  cmd->add_option("--merge-time", o->merge_time, "s: ... and this close in time")->capture_default_str();
  add_dds_options(cmd, &o->dds);
  cmd->callback([o] {
    catch_signals();
    PluginRegistry registry;
    Scenario sc = load_checked(o->scenario, &registry);
    WorldOptions wo;
    wo.plugins = builtin_plugin_registry();
    wo.controllers = false;
    auto world = World::create(sc, wo);  // for the map
    if (!world) throw Exit{report(world.error())};
    std::FILE* out = nullptr;
    fs::path out_path;
    if (!o->out.empty()) {
      std::error_code ec;
      fs::create_directories(o->out, ec);
      out_path = fs::path(o->out) / "events.jsonl";
      out = std::fopen(out_path.c_str(), "ab");
      if (!out) throw Exit{report(bad_input(out_path.string(), 0, "", "cannot open for appending"))};
    }
    auto part = participant(o->dds);
    dds::MergeParams mp;
    mp.merge_distance = o->merge_distance;
    mp.merge_time_s = o->merge_time;
    auto server = dds::EventServer::create(*part, dds::IncidentMerger(dds::server_cameras(sc), mp, dds::inside_map((*world)->map())));
    if (!server) throw Exit{report(server.error())};
    std::fprintf(stderr, "server: up (session %s, %zu cameras)\n", o->dds.session.c_str(), sc.cameras.size());
    const auto t0 = std::chrono::steady_clock::now();
    auto last = t0;
    int received = 0;
    while (!g_stop) {
      dds::EventServer::Log log;
      if (Status s = (*server)->poll(0.1, &log); !s) throw Exit{report(s.error())};
      const auto now = std::chrono::steady_clock::now();
      if (log.received) {
        received += log.received;
        last = now;
      }
      for (const auto& r : log.rejected) std::fprintf(stderr, "server: rejected %s\n", r.c_str());
      for (const auto& in : log.updated)
        std::fprintf(stderr, "server: incident %llu fused from %zu cameras: now at (%.3f, %.3f)\n",
                     static_cast<unsigned long long>(in.id), in.cameras.size(), in.position.x, in.position.y);
      for (const auto& in : log.published) {
        const std::string line = vision::format_event_json(in.as_event());
        std::printf("%s\n", line.c_str());
        if (out) {
          std::fprintf(out, "%s\n", line.c_str());
          std::fflush(out);
        }
      }
      std::fflush(stdout);
      const double up = std::chrono::duration<double>(now - t0).count();
      if (o->max_seconds > 0 && up >= o->max_seconds) break;
      if (o->idle_exit > 0 && received > 0 && std::chrono::duration<double>(now - last).count() >= o->idle_exit) break;
    }
    if (out) std::fclose(out);
    std::fprintf(stderr, "server: %d camera events received, %zu incidents\n", received, (*server)->merger().incidents().size());
  });
}

int64_t monotonic_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1000000000LL + ts.tv_nsec;
}

// Reads one topic until `count` lines are printed (0: no limit), `timeout` seconds pass (0: no
// limit) or a signal comes; `line(sample)` gives the JSON line for a sample, or none to skip it.
// Exit 1 when fewer than `count` came.
template <class Line>
void print_topic(const dds::Participant& part, dds::Topic topic, int count, double timeout, Line line) {
  auto reader = dds::Reader::create(part, topic);
  if (!reader) throw Exit{report(reader.error())};
  const auto t0 = std::chrono::steady_clock::now();
  int n = 0;
  while (!g_stop && (count <= 0 || n < count)) {
    (*reader)->wait(0.1);
    Status st = (*reader)->take_each([&](const void* sample, const dds_sample_info_t&) {
      if (count > 0 && n >= count) return;
      std::optional<nlohmann::json> j = line(sample);
      if (!j) return;
      std::printf("%s\n", j->dump().c_str());
      ++n;
    });
    if (!st) throw Exit{report(st.error())};
    std::fflush(stdout);
    if (timeout > 0 && std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() >= timeout) break;
  }
  if (count > 0 && n < count) throw Exit{1};
}

// `vigil events --assignments`: the allocation's decisions as the robots announce them. Tokens
// and acknowledgements are the protocol's chatter and keepers repeat their announcement every
// keep period, so a line is printed when a robot first keeps an incident, and for every task done
// or reopened.
void print_assignments(const dds::Participant& part, int count, double timeout) {
  std::set<std::pair<uint64_t, std::string>> kept;
  print_topic(part, dds::Topic::kTaskAssignments, count, timeout, [&](const void* sample) -> std::optional<nlohmann::json> {
    uint64_t number = 0;
    const auto& x = *static_cast<const vigil_msgs_TaskAssignment*>(sample);
    auto m = dds::from_assignment(x, &number);
    if (!m) {
      std::fprintf(stderr, "events: rejected task assignment: %s\n", m.error().str().c_str());
      return std::nullopt;
    }
    if (m->kind == "token" || m->kind == "token_ack") return std::nullopt;
    if (m->kind == "token_keep" && !kept.insert({m->task, m->from}).second) return std::nullopt;
    nlohmann::json j;
    j["incident"] = m->task;
    j["state"] = m->kind == "token_keep" ? "keep" : m->kind == "task_done" ? "done" : "reopen";
    j["robot"] = std::string(x.robot);
    j["from"] = m->from;
    j["t_ns"] = m->sent;
    if (m->kind == "token_keep") {
      j["kind"] = std::string(x.task_kind);
      j["target"] = {m->position.x, m->position.y};
    }
    return j;
  });
}

// `vigil events --robots`: every robot state sample as it arrives.
void print_robot_states(const dds::Participant& part, int count, double timeout) {
  print_topic(part, dds::Topic::kRobotState, count, timeout, [](const void* sample) -> std::optional<nlohmann::json> {
    auto m = dds::from_message(*static_cast<const vigil_msgs_RobotState*>(sample));
    if (!m) {
      std::fprintf(stderr, "events: rejected robot state: %s\n", m.error().str().c_str());
      return std::nullopt;
    }
    nlohmann::json j;
    j["robot"] = m->robot;
    j["t_ns"] = m->stamp_ns;
    j["x"] = m->pose.x;
    j["y"] = m->pose.y;
    j["yaw"] = m->pose.yaw;
    j["v"] = m->linear_velocity;
    j["w"] = m->angular_velocity;
    j["mode"] = m->mode;
    j["task"] = m->task;
    return j;
  });
}

void add_events(CLI::App& app) {
  struct Opts {
    int count = 0;
    double timeout = 0;
    bool text = false, latency = false, assignments = false, robots = false;
    DdsOpts dds;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand("events", "Subscribe to the video server's incidents and print them as JSON lines");
  cmd->add_flag("--assignments", o->assignments,
                "print the robots' task assignments instead (topic vigil_task_assignments): who keeps which "
                "incident, tasks done and reopened, as JSON lines; --count counts them");
  cmd->add_flag("--robots", o->robots,
                "print the robots' published states instead (topic vigil_robot_state, every 0.5 s of simulated "
                "time: each robot's own pose estimate, velocities, mode, task), as JSON lines; --count counts them");
  cmd->add_option("--count", o->count, "exit after this many incidents (0: no limit)")->capture_default_str();
  cmd->add_option("--timeout", o->timeout, "exit after this many seconds (0: run until SIGINT/SIGTERM)")->capture_default_str();
  cmd->add_flag("--text", o->text, "print the chapter's string form (\"left bag X Y Z\") instead of JSON");
  cmd->add_flag("--latency", o->latency,
                "print receive time minus the event's stamp in ns (stamps taken from CLOCK_MONOTONIC; benchmarks)");
  add_dds_options(cmd, &o->dds);
  cmd->callback([o] {
    catch_signals();
    auto part = participant(o->dds);
    if (o->assignments) {
      print_assignments(*part, o->count, o->timeout);
      return;
    }
    if (o->robots) {
      print_robot_states(*part, o->count, o->timeout);
      return;
    }
    auto sub = dds::IncidentSubscriber::create(*part);
    if (!sub) throw Exit{report(sub.error())};
    const auto t0 = std::chrono::steady_clock::now();
    int n = 0;
    while (!g_stop && (o->count <= 0 || n < o->count)) {
      std::vector<dds::Incident> got;
      std::vector<std::string> rejected;
      if (Status s = (*sub)->poll(0.1, &got, &rejected); !s) throw Exit{report(s.error())};
      const int64_t now = monotonic_ns();
      for (const auto& r : rejected) std::fprintf(stderr, "events: rejected %s\n", r.c_str());
      for (const auto& in : got) {
        if (o->latency) {
          std::printf("%lld\n", static_cast<long long>(now - in.stamp_ns));
        } else if (o->text) {
          std::printf("%s\n", vision::format_event_string(in.as_event()).c_str());
        } else {
          std::printf("%s\n", vision::format_event_json(in.as_event()).c_str());
        }
        ++n;
      }
      std::fflush(stdout);
      if (o->timeout > 0 && std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() >= o->timeout) break;
    }
    if (o->count > 0 && n < o->count) throw Exit{1};
  });
}

void add_robot_node(CLI::App& app) {
  struct Opts {
    std::string scenario, robot, out;
    double speed = 1, epoch = 0, linger = 0, wait_for_mates = 0;
    int mates = 0;
    std::optional<double> duration;
    bool video = false;
    DdsOpts dds;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand("robot-node", "Run one team robot: its controller, incidents and team messages over DDS");
  cmd->add_option("scenario", o->scenario, "scenario YAML file")->required();
  cmd->add_option("--robot", o->robot, "the team robot this node runs")->required();
  cmd->add_option("--out", o->out, "write this node's robots.jsonl, ground_truth.jsonl, summary.json and pictures/ here");
  cmd->add_option("--duration", o->duration, "simulated seconds overriding the scenario's");
  cmd->add_option("--speed", o->speed, "run at most this many times real time (0: as fast as possible)")->capture_default_str();
  cmd->add_option("--epoch", o->epoch, "Unix time (s) of the world's time 0, shared by the processes of one run (0: now)")
      ->capture_default_str();
  cmd->add_option("--mates", o->mates, "wait for this many other robot nodes' readers before starting")->capture_default_str();
  cmd->add_option("--wait-for-mates", o->wait_for_mates, "... for at most this many seconds")->capture_default_str();
  cmd->add_option("--linger", o->linger, "seconds to stay up after the run")->capture_default_str();
  cmd->add_flag("--video", o->video, "also write this node's topdown.mp4 and topdown.png");
  add_dds_options(cmd, &o->dds);
  cmd->callback([o] {
    catch_signals();
    PluginRegistry registry;
    Scenario sc = load_checked(o->scenario, &registry);
    auto me = std::find_if(sc.robots.begin(), sc.robots.end(), [&](const RobotSpec& r) { return r.id == o->robot; });
    if (me == sc.robots.end()) {
      std::string ids;
      for (const auto& r : sc.robots) ids += (ids.empty() ? "" : ", ") + r.id;
      throw Exit{report(bad_input(sc.file.string(), 0, "--robot", "no robot '" + o->robot + "' in the scenario (" + ids + ")"))};
    }
    if (me->controller != "team") {
      throw Exit{report(bad_input(sc.file.string(), me->line, "controller",
                                  "robot '" + o->robot + "' is not a team robot (controller: " + me->controller + ")"))};
    }
    // The other team robots are other nodes' (their poses reach this one in their hellos);
    // robots under other controllers run here as everywhere. No vision here.
    sc.robots.erase(std::remove_if(sc.robots.begin(), sc.robots.end(),
                                   [&](const RobotSpec& r) { return r.controller == "team" && r.id != o->robot; }),
                    sc.robots.end());
    double silent_from = -1;
    std::vector<FaultSpec> faults;
    for (const FaultSpec& f : sc.faults) {
      if (f.robot != o->robot) continue;
      if (f.kind == "silent") silent_from = silent_from < 0 ? f.at : std::min(silent_from, f.at);
      faults.push_back(f);
    }
    sc.faults = faults;
    for (auto& c : sc.cameras) c.plugin.clear();
    auto part = participant(o->dds);
    auto sub = dds::IncidentSubscriber::create(*part);
    if (!sub) throw Exit{report(sub.error())};
    dds::DdsTeamLink::Options lo;
    lo.domain = domain_options(o->dds);
    lo.silent_from = silent_from;
    auto link = dds::DdsTeamLink::create(o->robot, lo);
    if (!link) throw Exit{report(link.error())};
    if (o->mates > 0) {
      const int got = (*link)->wait_for_mates(o->mates, o->wait_for_mates);
      if (got < o->mates)
        std::fprintf(stderr, "robot-node %s: %d of %d mates after %.1f s; starting anyway\n", o->robot.c_str(), got, o->mates,
                     o->wait_for_mates);
    }
    const std::string id = o->robot;
    dds::IncidentSubscriber* sp = sub->get();
    dds::DdsTeamLink* lp = link->get();
    size_t incidents = 0;
    Pacer pacer(o->speed, o->epoch);
    render::PictureTaker pictures;
    RunOptions ro;
    ro.world.plugins = builtin_plugin_registry();
    ro.out_dir = o->out;
    ro.duration = o->duration;
    ro.video = o->video && !o->out.empty();
    ro.observers = {&pacer, &pictures};
    // A node started after the epoch (a restarted robot) first catches up with the shared clock
    // offline, as a robot booting would: it takes no incidents and no team messages and sends
    // none until its world is on time; then it joins (its mates' protocol timers run on the
    // shared clock, which a world racing through the past would break).
    bool joined = false;
    Pacer* pp = &pacer;
    auto on_time = [pp, &joined, id](const World& w) {
      if (!joined && !pp->behind(w)) {
        joined = true;
        if (w.time() > from_seconds(1.0))
          std::fprintf(stderr, "robot-node %s: caught up with the shared clock at %.1f s; joining the team\n", id.c_str(),
                       to_seconds(w.time()));
      }
      return joined;
    };
    ro.before_step = [sp, id, &incidents, on_time](World& w) {
      if (!on_time(w)) return;
      std::vector<dds::Incident> got;
      std::vector<std::string> rejected;
      if (Status s = sp->poll(0, &got, &rejected); !s) throw Exit{report(s.error())};
      for (const auto& r : rejected) std::fprintf(stderr, "robot-node %s: rejected incident: %s\n", id.c_str(), r.c_str());
      for (const dds::Incident& in : got) {
        if (Status s = w.post_task(id, dds::incident_task(in)); !s) throw Exit{report(s.error())};
        ++incidents;
      }
    };
    ro.exchange_messages = [lp, on_time](World& w) {
      if (!on_time(w)) {
        (void)w.drain_sent();  // offline: nothing leaves
        return lp->discard_received();
      }
      return lp->exchange(w);
    };
    ro.on_report = [](const RobotReport& r) {
      if (r.event.empty()) return;
      std::printf("%s\n", robot_report_json(r).c_str());
      std::fflush(stdout);
    };
    auto sum = run_scenario(sc, ro);
    if (!sum) throw Exit{report(sum.error())};
    std::fprintf(stderr,
                 "robot-node %s: %.1f s simulated, %zu incidents in, team messages %llu written (%llu task assignments), "
                 "%llu delivered, %llu stale, %llu malformed; %zu pictures (session %s)\n",
                 id.c_str(), sum->sim_seconds, incidents, static_cast<unsigned long long>(lp->written()),
                 static_cast<unsigned long long>(lp->assignments_written()),
                 static_cast<unsigned long long>(lp->delivered()), static_cast<unsigned long long>(lp->stale()),
                 static_cast<unsigned long long>(lp->rejected()), pictures.pictures().size(), o->dds.session.c_str());
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(o->linger);
    while (!g_stop && std::chrono::steady_clock::now() < end) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  });
}

}  // namespace

void add_node_commands(CLI::App& app) {
  add_camera_node(app);
  add_robot_node(app);
  add_server(app);
  add_events(app);
}

}  // namespace vigil::cli
