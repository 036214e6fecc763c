// vigil run SCENARIO.yaml [--out DIR] [--seed N] [--duration S] [--no-video] [--video-format mp4|avi] [--no-scans]
// Writes the ground truth, summary, top-down video and (rendered with OSMesa) each camera's video.
#include <algorithm>
#include <chrono>
#include <unistd.h>

#include <cstdio>
#include <memory>

#include "plugins/builtin.h"
#include "plugins/dds_bridge/event_relay.h"
#include "plugins/dds_bridge/team_transport.h"
#include "plugins/stereo_camera/robot_camera.h"
#include "plugins/stereo_camera/stereo_camera.h"
#include "plugins/vision_sensors/vision_sensor.h"
#include "tools/vigil/commands.h"
#include "tools/vigil/memory_log.h"
#include "tools/vigil/plugin_search.h"
#include "world/plugin.h"
#include "world/runner.h"

namespace vigil::cli {

void add_run_command(CLI::App& app) {
  struct Opts {
    std::string scenario, out;
    std::optional<uint64_t> seed;
    std::optional<double> duration;
    bool no_video = false, quiet = false, no_scans = false;
    std::vector<std::string> plugin_paths;
    uint32_t dds_domain = 0;
    std::string sensor;
    std::string dds_config;
    std::string team_transport = "dds";
    std::string memory_log;
    std::string video_format = "mp4";
  };
  auto opts = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand("run", "Run a scenario headless and write its outputs");
  cmd->add_option("scenario", opts->scenario, "scenario YAML file")->required();
  cmd->add_option("--out", opts->out, "output folder (default runs/<scenario name>)");
  cmd->add_option("--seed", opts->seed, "seed overriding the scenario's");
  cmd->add_option("--duration", opts->duration, "simulated seconds overriding the scenario's");
  cmd->add_flag("--no-video", opts->no_video, "do not write the top-down video, topdown.png or the camera videos");
  cmd->add_option("--video-format", opts->video_format,
                  "mp4 (H.264, opens in browsers and players) or avi (camera views MJPEG, drawn views MPEG-4 Part 2)")
      ->check(CLI::IsMember({"mp4", "avi"}))
      ->capture_default_str();
  cmd->add_flag("--no-scans", opts->no_scans, "do not write scans.jsonl (the robots' laser scans)");
  cmd->add_flag("--quiet,-q", opts->quiet, "no progress output");
  cmd->add_option("--plugin-path", opts->plugin_paths, "extra folder to search for plugin libraries");
  cmd->add_option("--sensor", opts->sensor,
                  "attach this vision sensor (truth, planview, mser) to every camera that has none in the scenario");
  cmd->add_option("--dds-domain", opts->dds_domain, "DDS domain id for the events (0 to 232)")->capture_default_str();
  cmd->add_option("--dds-config", opts->dds_config, "Cyclone DDS XML configuration (default: loopback only)");
  cmd->add_option("--team-transport", opts->team_transport,
                  "how team robots' messages travel: dds (a DDS participant per robot) or local (in-process bus)")
      ->capture_default_str();
  cmd->add_option("--memory-log", opts->memory_log,
                  "write this process's resident memory every 10 s of simulated time to this CSV, with a picture (.png) and "
                  "figures (.json) beside it (tools/soak.sh)");
  cmd->callback([opts] {
    PluginRegistry registry;
    register_builtin_plugins(registry);
    const auto dirs = plugin_search_path(opts->plugin_paths);
    for (const auto& d : dirs) registry.add_search_dir(d);
    ScenarioContext ctx;
    ctx.plugin_exists = [&](const std::string& n) { return registry.exists(n) || sensors::vision_sensor_exists(n); };
    auto scenario = load_scenario(opts->scenario, ctx);
    if (!scenario) throw Exit{report(scenario.error())};
    if (!opts->sensor.empty()) {
      if (!sensors::vision_sensor_exists(opts->sensor)) {
        std::string known;
        for (const auto& n : sensors::vision_sensor_names()) known += (known.empty() ? "" : ", ") + n;
        throw Exit{report(bad_input("", 0, "--sensor", "'" + opts->sensor + "' is not a vision sensor (" + known + ")"))};
      }
      for (auto& c : scenario->cameras)
        if (c.plugin.empty()) c.plugin = opts->sensor;
    }
    RunOptions ro;
    ro.world.plugins = builtin_plugin_registry();
    ro.out_dir = opts->out.empty() ? std::filesystem::path("runs") / scenario->name : std::filesystem::path(opts->out);
    ro.seed = opts->seed;
    ro.duration = opts->duration;
    ro.video = !opts->no_video;
    ro.scans = !opts->no_scans;
    ro.video_format = *parse_video_format(opts->video_format);  // checked by CLI11
    ro.world.plugin_dirs = dirs;
    // Every camera renders at its rate and writes cameras/<id>.mp4 (unless --no-video).
    render::CameraRigOptions rig_options;
    rig_options.video = ro.video;
    rig_options.video_format = ro.video_format;
    render::CameraRig rig(rig_options);
    // The cameras' vision sensors (plugin: under a camera) write tracks.jsonl.
    // (--seed reaches the sensors' own seeds; the host starts before the rig, whose first frames
    // it consumes at t = 0.)
    if (opts->seed) scenario->seed = *opts->seed;
    auto host = sensors::VisionSensorHost::create(*scenario, &rig);
    if (!host) throw Exit{report(host.error())};
    (*host)->set_videos(ro.video, ro.video_format);  // cameras/<camera>_<plugin>.mp4: what each tracker shows
    (*host)->set_keep_tracks(false);  // written to tracks.jsonl as they come
    // Their activity rules' events go through DDS to the video server (in this process, on the
    // loopback configuration unless --dds-config), which writes events.jsonl.
    std::unique_ptr<dds::DdsEventRelay> relay;
    if (!(*host)->empty()) {
      dds::RelayOptions rel;
      rel.domain.domain_id = opts->dds_domain;
      if (!opts->dds_config.empty()) {
        auto cfg = dds::read_config(opts->dds_config);
        if (!cfg) throw Exit{report(cfg.error())};
        rel.domain.config = *cfg;
      }
      auto r = dds::DdsEventRelay::create(rel);
      if (!r) throw Exit{report(r.error())};
      relay = std::move(*r);
      dds::DdsEventRelay* rp = relay.get();
      (*host)->set_event_sink([rp](const vision::Event& e) { return rp->publish(e); });
      ro.observers.push_back(relay.get());
      ro.observers.push_back(host->get());
    }
    if (rig.active() && !scenario->cameras.empty()) ro.observers.push_back(&rig);
    // Robots' inspection pictures (pictures/<incident>_<robot>.png), when a controller asks.
    render::PictureTaker pictures;
    ro.observers.push_back(&pictures);
    // The robots' side of the incidents: a participant subscribed to the server's vigil_events
    // that puts every incident (and cancellation) in each team robot's inbox, in lockstep with
    // the server (every incident published so far is in the inboxes before the next step).
    std::unique_ptr<dds::Participant> robot_side;
    std::unique_ptr<dds::IncidentSubscriber> incident_sub;
    size_t incidents_in = 0;
    std::vector<std::string> team_ids;
    for (const RobotSpec& r : scenario->robots)
      if (r.controller == "team") team_ids.push_back(r.id);
    if (relay && !team_ids.empty()) {
      auto p = dds::Participant::create(relay->domain());
      if (!p) throw Exit{report(p.error())};
      robot_side = std::move(*p);
      auto sub = dds::IncidentSubscriber::create(*robot_side);
      if (!sub) throw Exit{report(sub.error())};
      incident_sub = std::move(*sub);
      dds::DdsEventRelay* rp = relay.get();
      ro.before_step = [rp, &incident_sub, &incidents_in, team_ids](World& w) {
        const auto t0 = std::chrono::steady_clock::now();
        while (incidents_in < rp->incidents().size()) {
          std::vector<dds::Incident> got;
          if (Status s = incident_sub->poll(0.05, &got); !s) throw Exit{report(s.error())};
          for (const dds::Incident& in : got) {
            const RobotTask t = dds::incident_task(in);
            for (const std::string& id : team_ids) (void)w.post_task(id, t);
          }
          incidents_in += got.size();
          if (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() > 10) {
            throw Exit{report(internal_error("the robots did not receive an incident over DDS within 10 s"))};
          }
        }
      };
    }
    // Team messages between the robots' controllers: over DDS (a participant per robot, in
    // lockstep, so the run is the same as with the local bus), or the in-process bus.
    std::unique_ptr<dds::DdsTeamBus> team_bus;
    if (opts->team_transport != "dds" && opts->team_transport != "local") {
      throw Exit{report(bad_input("", 0, "--team-transport", "must be dds or local, not '" + opts->team_transport + "'"))};
    }
    const bool any_team = std::any_of(scenario->robots.begin(), scenario->robots.end(),
                                      [](const RobotSpec& r) { return r.controller == "team"; });
    if (opts->team_transport == "dds" && any_team) {
      dds::DdsTeamBus::Options to;
      to.domain.domain_id = opts->dds_domain;
      if (!opts->dds_config.empty()) {
        auto cfg = dds::read_config(opts->dds_config);
        if (!cfg) throw Exit{report(cfg.error())};
        to.domain.config = *cfg;
      }
      std::vector<std::string> ids;
      for (const RobotSpec& r : scenario->robots) ids.push_back(r.id);
      for (const FaultSpec& f : scenario->faults)
        if (f.kind == "silent") to.silent_from.push_back({f.robot, f.at});
      auto b = dds::DdsTeamBus::create(ids, to);
      if (!b) throw Exit{report(b.error())};
      team_bus = std::move(*b);
      dds::DdsTeamBus* bp = team_bus.get();
      ro.exchange_messages = [bp](World& w) { return bp->exchange(w); };
    }
    const bool tty = isatty(STDERR_FILENO);
    int last_decile = -1;
    if (!opts->quiet) {
      ro.progress = [tty, &last_decile](double sim, double total, double wall) {
        const double frac = total > 0 ? sim / total : 1.0;
        if (tty) {
          const int bar = static_cast<int>(frac * 30);
          std::fprintf(stderr, "\r[%.*s%*s] %6.1f / %.1f s sim  %6.1f s wall  %6.1fx real time", bar,
                       "==============================", 30 - bar, "", sim, total, wall, wall > 0 ? sim / wall : 0.0);
          std::fflush(stderr);
        } else if (static_cast<int>(frac * 10) > last_decile) {
          last_decile = static_cast<int>(frac * 10);
          std::fprintf(stderr, "[run] %3d%%  %.1f / %.1f s sim  %.1f s wall\n", last_decile * 10, sim, total, wall);
        }
      };
    }
    std::optional<MemoryLog> memory;
    if (!opts->memory_log.empty()) {
      auto m = MemoryLog::open(opts->memory_log);
      if (!m) throw Exit{report(m.error())};
      memory.emplace(std::move(*m));
      auto inner = ro.before_step;
      MemoryLog* mp = &*memory;
      ro.before_step = [inner, mp](World& w) {
        if (inner) inner(w);
        mp->maybe_sample(to_seconds(w.time()));
      };
    }
    auto summary = run_scenario(*scenario, ro);
    if (tty && !opts->quiet) std::fprintf(stderr, "\n");
    if (!summary) throw Exit{report(summary.error())};
    std::printf("%s: %.1f s simulated in %.2f s (%.1fx real time), %llu steps, %zu ground-truth events\n",
                summary->scenario.c_str(), summary->sim_seconds, summary->wall_seconds, summary->real_time_factor,
                static_cast<unsigned long long>(summary->steps), summary->events);
    if (team_bus) {
      std::printf("team messages over DDS: %llu written (%llu on vigil_task_assignments), %llu delivered, %llu malformed dropped\n",
                  static_cast<unsigned long long>(team_bus->written()),
                  static_cast<unsigned long long>(team_bus->assignments_written()),
                  static_cast<unsigned long long>(team_bus->delivered()),
                  static_cast<unsigned long long>(team_bus->rejected()));
    }
    if (memory) std::printf("%s\n", memory->finish(summary->sim_seconds).c_str());
    std::printf("ground_truth_sha256 %s\noutputs in %s\n", summary->ground_truth_sha256.c_str(), ro.out_dir.c_str());
  });
}

}  // namespace vigil::cli
