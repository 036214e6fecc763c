// vigil render SCENARIO.yaml --camera ID --out DIR [--frames N] [--at SECONDS]
// Steps the world and, at each tick of the camera's rate, renders its stereo pair with OSMesa:
// left_%06d.png, right_%06d.png (8-bit colour), depth_%06d.png (16-bit millimetres, 0 = none),
// disparity_%06d.png (16-bit, disparity * 256 as in KITTI, 0 = none), labels_%06d.png (16-bit
// entity labels; labels.txt maps them to entity ids).
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>

#include <opencv2/imgcodecs.hpp>

#include "plugins/builtin.h"
#include "plugins/stereo_camera/osmesa_renderer.h"
#include "plugins/stereo_camera/render_scene.h"
#include "plugins/vision_sensors/vision_sensor.h"
#include "tools/vigil/commands.h"
#include "tools/vigil/plugin_search.h"
#include "world/plugin.h"
#include "world/world.h"

namespace vigil::cli {
namespace {

// Writes one image; an Error naming the file when it cannot.
Status write_png(const std::filesystem::path& path, const cv::Mat& img) {
  bool ok = false;
  try {
    ok = cv::imwrite(path.string(), img);
  } catch (const cv::Exception&) {
    ok = false;
  }
  if (!ok) return bad_input(path.string(), 0, "", "cannot write the image");
  return Status::Ok();
}

// Metres (float) to 16-bit units of `scale` per metre, clamped; 0 stays 0.
cv::Mat to_u16(const cv::Mat& f, double scale) {
  cv::Mat out;
  f.convertTo(out, CV_16U, scale);  // saturating, rounds to nearest
  return out;
}

Status write_frame(const std::filesystem::path& dir, int n, const vision::StereoFrame& f) {
  char stem[32];
  auto name = [&](const char* kind) {
    std::snprintf(stem, sizeof stem, "%s_%06d.png", kind, n);
    return dir / stem;
  };
  cv::Mat labels;
  f.labels.convertTo(labels, CV_16U);
  for (const auto& [path, img] : {std::pair{name("left"), f.left}, std::pair{name("right"), f.right},
                                  std::pair{name("depth"), to_u16(f.depth, 1000.0)},
                                  std::pair{name("disparity"), to_u16(f.disparity, 256.0)},
                                  std::pair{name("labels"), labels}}) {
    if (Status s = write_png(path, img); !s) return s;
  }
  return Status::Ok();
}

}  // namespace

void add_render_command(CLI::App& app) {
  struct Opts {
    std::string scenario, camera, out;
    int frames = 30;
    std::optional<double> at;
    double noise = 0, exposure = 1, blur = 0;
    std::vector<std::string> plugin_paths;
  };
  auto opts = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand("render", "Render a scenario camera's stereo frames (OSMesa) to PNG files");
  cmd->add_option("scenario", opts->scenario, "scenario YAML file")->required();
  cmd->add_option("--camera", opts->camera, "camera id in the scenario")->required();
  cmd->add_option("--out", opts->out, "output folder")->required();
  cmd->add_option("--frames", opts->frames, "number of frames, one per camera tick from t = 0 (default 30)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--at", opts->at, "render only the instant at this simulated time (s)")->check(CLI::NonNegativeNumber);
  cmd->add_option("--noise", opts->noise, "Gaussian pixel noise, grey levels (default 0)")->check(CLI::NonNegativeNumber);
  cmd->add_option("--exposure", opts->exposure, "exposure gain (default 1)")->check(CLI::PositiveNumber);
  cmd->add_option("--blur", opts->blur, "Gaussian blur sigma, pixels (default 0)")->check(CLI::NonNegativeNumber);
  cmd->add_option("--plugin-path", opts->plugin_paths, "extra folder to search for plugin libraries");
  cmd->callback([opts] {
    PluginRegistry registry;
    register_builtin_plugins(registry);
    const auto dirs = plugin_search_path(opts->plugin_paths);
    for (const auto& d : dirs) registry.add_search_dir(d);
    ScenarioContext ctx;
    ctx.plugin_exists = [&](const std::string& n) { return registry.exists(n) || sensors::vision_sensor_exists(n); };
    auto scenario = load_scenario(opts->scenario, ctx);
    if (!scenario) throw Exit{report(scenario.error())};
    auto found = find_camera(*scenario, opts->camera, "--camera");
    if (!found) throw Exit{report(found.error())};
    const CameraSpec* spec = *found;
    if (opts->at && *opts->at > scenario->duration) {
      char end[64];
      std::snprintf(end, sizeof end, "%g s", scenario->duration);
      throw Exit{report(bad_input(opts->scenario, 0, "--at", std::string("time is after the scenario's end (") + end + ")"))};
    }
    const CameraSpec cam = *spec;
    std::error_code ec;
    std::filesystem::create_directories(opts->out, ec);
    if (ec) throw Exit{report(bad_input(opts->out, 0, "--out", "cannot create the folder: " + ec.message()))};

    WorldOptions wo;
    wo.plugins = builtin_plugin_registry();
    wo.plugin_dirs = dirs;
    auto world = World::create(*scenario, wo);
    if (!world) throw Exit{report(world.error())};
    render::RendererOptions ro;
    ro.effects.noise_std = opts->noise;
    ro.effects.exposure = opts->exposure;
    ro.effects.blur_sigma = opts->blur;
    ro.effects.seed = scenario->seed;
    auto renderer = render::OsmesaRenderer::create(cam.width, cam.height, ro);
    if (!renderer) throw Exit{report(renderer.error())};
    const vision::StereoCameraModel model = render::camera_model(cam);
    const render::SceneOptions scene_options = render::scene_options_for(**world, &cam);

    // The instants to render: camera ticks, or the one asked for.
    std::vector<SimTime> ticks;
    if (opts->at) {
      ticks.push_back(from_seconds(*opts->at));
    } else {
      for (int i = 0; i < opts->frames; ++i) {
        const SimTime t = from_seconds(i / cam.rate_hz);
        if (t > (*world)->end_time()) break;
        ticks.push_back(t);
      }
    }
    std::vector<std::string> label_ids;
    for (size_t i = 0; i < ticks.size(); ++i) {
      while ((*world)->time() < ticks[i]) {
        if (Status s = (*world)->advance(); !s) throw Exit{report(s.error())};
      }
      const render::RenderScene scene = render::build_render_scene(**world, scene_options);
      label_ids = scene.label_ids;
      vision::StereoFrame frame;
      frame.index = static_cast<int64_t>(i);
      frame.stamp_ns = (*world)->time();
      if (Status s = (*renderer)->render(scene, model, &frame); !s) throw Exit{report(s.error())};
      if (Status s = write_frame(opts->out, static_cast<int>(i), frame); !s) throw Exit{report(s.error())};
    }
    std::ofstream labels(std::filesystem::path(opts->out) / "labels.txt");
    labels << "# label entity_id (0 = background: floor, ceiling, walls, furniture)\n";
    for (size_t l = 1; l < label_ids.size(); ++l) labels << l << ' ' << label_ids[l] << '\n';
    if (!labels) throw Exit{report(bad_input(opts->out, 0, "--out", "cannot write labels.txt"))};
    std::printf("%zu stereo frames of %s (%dx%d) written to %s (%s)\n", ticks.size(), cam.id.c_str(), cam.width,
                cam.height, opts->out.c_str(), (*renderer)->gl_renderer().c_str());
  });
}

}  // namespace vigil::cli
