// vigil bench camera-rate: a rendered run's real-time factor with the planview sensor on every
// camera (OSMesa, SGBM with the half-pixel pass, foreground, plan view, tracking, rules), our
// pipeline beside the one it replaced, in the same process on the same scenario and seed:
//   - stereo only where the colour differs from the background, cameras on their own threads
//     (the default);
//   - whole-image stereo, cameras on their own threads;
//   - stereo where the colour differs, one camera after the other;
//   - whole-image stereo, one camera after the other (the pipeline before, 2026-12-02).
// No DDS and no outputs (the videos are measured by `vigil run`, docs/PERFORMANCE.md).
#include <chrono>
#include <cstdio>
#include <fstream>
#include <thread>
#include <memory>
#include <nlohmann/json.hpp>

#include "plugins/builtin.h"
#include "plugins/stereo_camera/stereo_camera.h"
#include "plugins/vision_sensors/vision_sensor.h"
#include "tools/vigil/commands.h"
#include "world/runner.h"

namespace vigil::cli {

void add_bench_rate_command(CLI::App* bench) {
  struct Opts {
    std::string scenario = (std::filesystem::path(VIGIL_SOURCE_DIR) / "scenarios" / "dis_team_bag_taken.yaml").string();
    double duration = 20;
    std::string json;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = bench->add_subcommand(
      "camera-rate", "Rendered run's real-time factor, stereo where the colour changes and camera threads beside the whole-image, serial pipeline");
  cmd->add_option("--scenario", o->scenario, "scenario (default scenarios/dis_team_bag_taken.yaml)");
  cmd->add_option("--duration", o->duration, "simulated seconds per run (default 20)")->check(CLI::PositiveNumber);
  cmd->add_option("--json", o->json, "also write the results as JSON to this file");
  cmd->callback([o] {
    auto loaded = load_scenario(o->scenario);
    if (!loaded) throw Exit{report(loaded.error())};
    struct Config {
      const char* name;
      bool foreground;
      bool threads;
    };
    const Config configs[] = {{"stereo where the colour changes, camera threads (default)", true, true},
                              {"whole-image stereo, camera threads", false, true},
                              {"stereo where the colour changes, one thread for the cameras", true, false},
                              {"whole-image stereo, one thread for the cameras (before)", false, false}};
    int cameras = 0;
    for (const auto& c : loaded->cameras) cameras += c.plugin.empty() || c.plugin == "planview";
    std::printf("vigil bench camera-rate: %s, %.0f s simulated, planview on %d camera(s), %u hardware threads\n",
                loaded->name.c_str(), o->duration, cameras, std::thread::hardware_concurrency());
    std::printf("%-62s %10s %10s %14s %8s\n", "pipeline", "wall s", "RTF", "camera frames", "tracks");
    nlohmann::ordered_json results = nlohmann::ordered_json::array();
    double before_rtf = 0, ours_rtf = 0;
    for (const Config& cfg : configs) {
      Scenario sc = *loaded;
      for (auto& c : sc.cameras) {
        if (!c.plugin.empty() && c.plugin != "planview") continue;
        c.plugin = "planview";
        c.params["stereo_where"] = ParamEntry{std::string(cfg.foreground ? "foreground" : "everywhere"), 0};
      }
      render::CameraRigOptions rig_options;
      rig_options.video = false;
      rig_options.camera_threads = cfg.threads;
      render::CameraRig rig(rig_options);
      auto host = sensors::VisionSensorHost::create(sc, &rig);
      if (!host) throw Exit{report(host.error())};
      RunOptions ro;
      ro.world.plugins = builtin_plugin_registry();
      ro.duration = o->duration;
      ro.video = false;
      ro.observers = {host->get(), &rig};
      auto sum = run_scenario(sc, ro);
      if (!sum) throw Exit{report(sum.error())};
      int64_t frames = 0;
      for (const auto& [id, n] : rig.frames()) frames += n;
      std::printf("%-62s %10.1f %10.2f %14lld %8zu\n", cfg.name, sum->wall_seconds, sum->real_time_factor,
                  static_cast<long long>(frames), (*host)->track_count());
      std::fflush(stdout);
      if (cfg.foreground && cfg.threads) ours_rtf = sum->real_time_factor;
      if (!cfg.foreground && !cfg.threads) before_rtf = sum->real_time_factor;
      results.push_back({{"pipeline", cfg.name}, {"stereo_where", cfg.foreground ? "foreground" : "everywhere"},
                         {"camera_threads", cfg.threads}, {"wall_seconds", sum->wall_seconds},
                         {"real_time_factor", sum->real_time_factor}, {"camera_frames", frames},
                         {"tracks", (*host)->track_count()}});
    }
    if (before_rtf > 0) std::printf("speed-up over the pipeline before: %.2fx\n", ours_rtf / before_rtf);
    if (!o->json.empty()) {
      std::ofstream f(o->json);
      f << results.dump(2) << "\n";
      if (!f) throw Exit{report(bad_input(o->json, 0, "--json", "cannot write the file"))};
    }
  });
}

}  // namespace vigil::cli
