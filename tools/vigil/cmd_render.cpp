// vigil render SCENARIO.yaml --camera ID --out DIR [--frames N] [--at SECONDS]
// Steps the world and, at each tick of the camera's rate, renders its stereo pair with OSMesa:
// left_%06d.png, right_%06d.png (8-bit colour), depth_%06d.png (16-bit millimetres, 0 = none),
// disparity_%06d.png (16-bit, disparity * 256 as in KITTI, 0 = none), labels_%06d.png (16-bit
// entity labels; labels.txt maps them to entity ids), and rig.yaml, the camera's ideal rig file
// (vision/stereo_calibration.h, with its true pose), so the frames read back as a recorded rig:
// stereo:DIR/left_%06d.png,DIR/right_%06d.png,DIR/rig.yaml.
// vigil render SCENARIO.yaml --camera ID --out DIR --chessboard 9x6 [--square 0.06] [--views 20]
// Renders a chessboard held in front of the camera at --views random poses (in the scene as it is
// at t = 0, seeded by the scenario's seed) instead: left_%06d.png, right_%06d.png and rig.yaml,
// the input of `vigil calibrate stereo` with a known answer.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/rng.h"
#include "plugins/builtin.h"
#include "plugins/stereo_camera/osmesa_renderer.h"
#include "plugins/stereo_camera/render_scene.h"
#include "plugins/vision_sensors/vision_sensor.h"
#include "tools/vigil/commands.h"
#include "tools/vigil/plugin_search.h"
#include "vision/stereo_calibration.h"
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

// A chessboard of inner x inner corners with squares of `square` m, seen from `model`: its
// board frame (x along a row of corners, y down the columns, z into the board) at `board_pose` in
// the left optical frame. A white board with a one-square margin and black squares on its face,
// both emissive (unlit), so the pattern is the same under any light.
void add_chessboard(render::RenderScene* scene, const vision::StereoCameraModel& model, const Eigen::Isometry3d& board_pose,
                    cv::Size inner, double square) {
  const Eigen::Isometry3d map_from_board = model.map_from_optical() * board_pose;
  const int cols = inner.width + 1, rows = inner.height + 1;  // squares
  // The first inner corner is the board frame's origin: squares span [-1, cols - 1] x [-1, rows - 1].
  const Eigen::Vector3d centre((cols - 2) * square / 2, (rows - 2) * square / 2, 0);
  render::Primitive back;
  back.shape = render::Shape::kBox;
  back.pose = map_from_board * Eigen::Translation3d(centre + Eigen::Vector3d(0, 0, 0.005));
  back.size = {(cols + 2) * square, (rows + 2) * square, 0.01};
  back.colour = {1, 1, 1};
  back.texture = render::Texture::kEmissive;
  scene->primitives.push_back(back);
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      if ((r + c) % 2 != 0) continue;
      render::Primitive sq = back;
      sq.pose = map_from_board * Eigen::Translation3d((c - 0.5) * square, (r - 0.5) * square, -0.0005);
      sq.size = {square, square, 0.001};
      sq.colour = {0, 0, 0};
      scene->primitives.push_back(sq);
    }
  }
}

// A random board pose in front of the camera (board frame in the left optical frame) with the
// whole board and its margin inside both views; nullopt when the draw does not fit.
std::optional<Eigen::Isometry3d> chessboard_pose(const vision::StereoCameraModel& model, cv::Size inner, double square,
                                                 Rng* rng) {
  const vision::Intrinsics& k = model.intrinsics();
  const double w = (inner.width + 1) * square, h = (inner.height + 1) * square;
  // Distance so the board spans a third to two thirds of the image width.
  const double fill = rng->uniform(0.35, 0.65);
  const double z = k.fx * w / (fill * k.width);
  const double x = rng->uniform(-0.5, 0.5) * z * k.width / k.fx * (1 - fill);
  const double y = rng->uniform(-0.5, 0.5) * z * k.height / k.fy * (1 - fill);
  const Eigen::Matrix3d rot = (Eigen::AngleAxisd(rng->uniform(-0.6, 0.6), Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(rng->uniform(-0.6, 0.6), Eigen::Vector3d::UnitX()) *
                               Eigen::AngleAxisd(rng->uniform(-0.3, 0.3), Eigen::Vector3d::UnitZ()))
                                  .toRotationMatrix();
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = rot;
  // Centre the inner corners on (x, y, z).
  pose.translation() =
      Eigen::Vector3d(x, y, z) - rot * Eigen::Vector3d((inner.width - 1) * square / 2, (inner.height - 1) * square / 2, 0);
  for (double bx : {-2 * square, w})
    for (double by : {-2 * square, h})
      for (double shift : {0.0, -model.baseline()}) {
        const Eigen::Vector3d p = pose * Eigen::Vector3d(bx, by, 0) + Eigen::Vector3d(shift, 0, 0);
        Eigen::Vector2d px;
        if (!model.project(p, &px) || px.x() < 4 || px.y() < 4 || px.x() > k.width - 5 || px.y() > k.height - 5)
          return std::nullopt;
      }
  return pose;
}

// True when the rendered depth at every inner corner and along the board's outer edge is the
// board's own: nothing of the scene (a wall the board would cut into) hides any of it in the left
// view, so the right view, 9 cm aside, sees it whole too.
bool board_unoccluded(const vision::StereoFrame& frame, const vision::StereoCameraModel& model, const Eigen::Isometry3d& pose,
                      cv::Size inner, double square) {
  std::vector<Eigen::Vector3d> probes;
  for (int r = 0; r < inner.height; ++r)
    for (int c = 0; c < inner.width; ++c) probes.push_back(pose * Eigen::Vector3d(c * square, r * square, 0));
  // The white board spans [-2, cols] x [-2, rows] squares in the board frame (cols = inner + 1).
  const double x0 = -1.9 * square, x1 = (inner.width + 0.9) * square, y0 = -1.9 * square, y1 = (inner.height + 0.9) * square;
  for (int i = 0; i <= 40; ++i) {
    const double t = i / 40.0;
    for (const Eigen::Vector3d& b : {Eigen::Vector3d(x0 + t * (x1 - x0), y0, 0), Eigen::Vector3d(x0 + t * (x1 - x0), y1, 0),
                                     Eigen::Vector3d(x0, y0 + t * (y1 - y0), 0), Eigen::Vector3d(x1, y0 + t * (y1 - y0), 0)})
      probes.push_back(pose * b);
  }
  for (const Eigen::Vector3d& p : probes) {
    Eigen::Vector2d px;
    if (!model.project(p, &px)) return false;
    const int u = static_cast<int>(std::lround(px.x())), v = static_cast<int>(std::lround(px.y()));
    if (u < 0 || v < 0 || u >= frame.depth.cols || v >= frame.depth.rows) return false;
    if (std::abs(frame.depth.at<float>(v, u) - p.z()) > 0.02) return false;
  }
  return true;
}

Status write_rig(const std::filesystem::path& dir, const vision::StereoCameraModel& model) {
  return vision::save_stereo_calibration((dir / "rig.yaml").string(), vision::ideal_calibration(model));
}

}  // namespace

void add_render_command(CLI::App& app) {
  struct Opts {
    std::string scenario, camera, out;
    int frames = 30;
    std::optional<double> at;
    double noise = 0, exposure = 1, blur = 0;
    std::vector<std::string> plugin_paths;
    std::string chessboard;
    double square = 0.06;
    int views = 20;
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
  cmd->add_option("--chessboard", opts->chessboard,
                  "render a chessboard of COLSxROWS inner corners at random poses in front of the camera instead");
  cmd->add_option("--square", opts->square, "chessboard square side (m, default 0.06)")->check(CLI::PositiveNumber);
  cmd->add_option("--views", opts->views, "chessboard views (default 20)")->check(CLI::Range(1, 1000));
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
    if (Status s = write_rig(opts->out, model); !s) throw Exit{report(s.error())};

    if (!opts->chessboard.empty()) {
      auto board = vision::parse_board_size(opts->chessboard, "--chessboard");
      if (!board) throw Exit{report(board.error())};
      const cv::Size inner = *board;
      // Each view is rendered at 3x the resolution and area-averaged down, as a real sensor
      // integrates light over each pixel: the board's edges are not aliased, so the corners are
      // found to a fraction of a pixel as on a real camera's images.
      constexpr int kSuper = 3;
      vision::Intrinsics ks = model.intrinsics();
      ks.width *= kSuper;
      ks.height *= kSuper;
      ks.fx *= kSuper;
      ks.fy *= kSuper;
      ks.cx = (ks.cx + 0.5) * kSuper - 0.5;
      ks.cy = (ks.cy + 0.5) * kSuper - 0.5;
      const vision::StereoCameraModel fine(ks, model.baseline(), model.pose());
      auto fine_renderer = render::OsmesaRenderer::create(ks.width, ks.height, ro);
      if (!fine_renderer) throw Exit{report(fine_renderer.error())};
      const render::RenderScene base = render::build_render_scene(**world, scene_options);
      Rng rng = Rng::stream(scenario->seed, "chessboard_views");
      int written = 0;
      for (int attempt = 0; written < opts->views; ++attempt) {
        if (attempt >= 200 * opts->views)
          throw Exit{report(bad_input("", 0, "--square",
                                      "a board of these squares does not fit in the camera's view (" + std::to_string(written) +
                                          " of " + std::to_string(opts->views) + " views placed)"))};
        const auto pose = chessboard_pose(model, inner, opts->square, &rng);
        if (!pose) continue;
        render::RenderScene scene = base;
        add_chessboard(&scene, model, *pose, inner, opts->square);
        vision::StereoFrame frame;
        // Checked at the camera's resolution, then rendered fine.
        if (Status s = (*renderer)->render(scene, model, &frame); !s) throw Exit{report(s.error())};
        if (!board_unoccluded(frame, model, *pose, inner, opts->square)) continue;
        if (Status s = (*fine_renderer)->render(scene, fine, &frame); !s) throw Exit{report(s.error())};
        cv::resize(frame.left, frame.left, cv::Size(cam.width, cam.height), 0, 0, cv::INTER_AREA);
        cv::resize(frame.right, frame.right, cv::Size(cam.width, cam.height), 0, 0, cv::INTER_AREA);
        const int i = written++;
        char name[32];
        for (const auto& [kind, img] : {std::pair{"left", frame.left}, std::pair{"right", frame.right}}) {
          std::snprintf(name, sizeof name, "%s_%06d.png", kind, static_cast<int>(i));
          if (Status s = write_png(std::filesystem::path(opts->out) / name, img); !s) throw Exit{report(s.error())};
        }
      }
      std::printf("%d chessboard views (%dx%d inner corners, %g m squares) from %s written to %s with rig.yaml\n",
                  written, inner.width, inner.height, opts->square, cam.id.c_str(), opts->out.c_str());
      return;
    }

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
