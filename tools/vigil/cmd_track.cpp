// vigil track --source SPEC --pipeline planview --out DIR [--frames N] [--no-video]
// Runs a vision pipeline on any stereo frame source (render:, stereo: with a calibration) and
// writes DIR/tracks.jsonl (map frame) and DIR/annotated.avi: the camera view with the tracks,
// the foreground mask, and the plan-view occupancy and height maps.
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "plugins/builtin.h"
#include "plugins/stereo_camera/stereo_camera.h"
#include "tools/vigil/commands.h"
#include "tools/vigil/plugin_search.h"
#include "vision/planview_system.h"
#include "vision/track_io.h"

namespace vigil::cli {

void add_track_command(CLI::App& app) {
  struct Opts {
    std::string source, pipeline = "planview", out, camera_id;
    int64_t frames = 0;
    bool no_video = false, quiet = false;
    double max_range = 8.0, cell_size = 0.02, learning_rate = 0.005;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand("track", "Run a vision pipeline on a stereo frame source and write its tracks");
  cmd->add_option("--source", o->source,
                  "frame source: render:SCENARIO.yaml;camera=ID[;disparity=sgbm] or stereo:L,R,CALIB;disparity=sgbm")
      ->required();
  cmd->add_option("--pipeline", o->pipeline, "vision pipeline (planview)")->check(CLI::IsMember({"planview"}));
  cmd->add_option("--out", o->out, "output folder")->required();
  cmd->add_option("--frames", o->frames, "stop after this many frames (default: the whole source)")->check(CLI::NonNegativeNumber);
  cmd->add_option("--camera-id", o->camera_id, "camera id written on the tracks (default: the source's camera or 'camera')");
  cmd->add_option("--max-range", o->max_range, "plan view: metres from the camera (default 8)")->check(CLI::PositiveNumber);
  cmd->add_option("--cell-size", o->cell_size, "plan view: cell side in metres (default 0.02)")->check(CLI::PositiveNumber);
  cmd->add_option("--learning-rate", o->learning_rate, "foreground: alpha (default 0.005)")->check(CLI::PositiveNumber);
  cmd->add_flag("--no-video", o->no_video, "do not write annotated.avi");
  cmd->add_flag("--quiet,-q", o->quiet, "no progress output");
  cmd->callback([o] {
    WorldOptions wo;
    wo.plugins = builtin_plugin_registry();
    wo.plugin_dirs = plugin_search_path();
    auto source = render::open_any_frame_source(o->source, wo);
    if (!source) throw Exit{report(source.error())};
    auto model = (*source)->camera_model();
    if (!(*source)->is_stereo() || !model) {
      throw Exit{report(bad_input(o->source, 0, "--source",
                                  "the plan-view pipeline needs a calibrated stereo source with a pose (render:, or "
                                  "stereo:LEFT,RIGHT,CALIBRATION;disparity=sgbm); got " + (*source)->describe()))};
    }
    std::string camera_id = o->camera_id;
    if (camera_id.empty()) {
      if (auto* r = dynamic_cast<render::RenderedStereoSource*>(source->get())) camera_id = r->camera().id;
      else camera_id = "camera";
    }
    vision::PlanViewSystemParams sp;
    sp.plan.max_range = o->max_range;
    sp.plan.cell_size = o->cell_size;
    sp.background.learning_rate = static_cast<float>(o->learning_rate);
    sp.tracking.camera = camera_id;
    auto system = vision::PlanViewSystem::create(*model, sp);
    if (!system) throw Exit{report(system.error())};

    const std::filesystem::path out = o->out;
    std::error_code ec;
    std::filesystem::create_directories(out, ec);
    if (ec) throw Exit{report(bad_input(o->out, 0, "--out", "cannot create the folder: " + ec.message()))};
    vision::TrackJsonlWriter writer;
    if (Status s = writer.open(out / "tracks.jsonl"); !s) throw Exit{report(s.error())};
    cv::VideoWriter video;
    const bool tty = isatty(STDERR_FILENO);
    if (!o->quiet) std::fprintf(stderr, "[track] %s\n", (*source)->describe().c_str());

    double fps = 15;  // the chapter's rig, for sources that do not say
    if (auto* r = dynamic_cast<render::RenderedStereoSource*>(source->get())) fps = r->camera().rate_hz;
    vision::StereoFrame frame;
    cv::Mat last_annotated;
    int64_t n = 0, n_tracks = 0;
    double busy = 0;
    const auto t_start = std::chrono::steady_clock::now();
    while (o->frames == 0 || n < o->frames) {
      auto more = (*source)->next(&frame);
      if (!more) throw Exit{report(more.error())};
      if (!*more) break;
      const auto t0 = std::chrono::steady_clock::now();
      auto tracks = system->process(frame);
      busy += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      if (!tracks) {
        Error e = tracks.error();
        if (e.file.empty()) e.file = o->source;
        throw Exit{report(e)};
      }
      for (const auto& t : *tracks) {
        if (Status s = writer.write(t); !s) throw Exit{report(s.error())};
      }
      n_tracks += static_cast<int64_t>(tracks->size());
      if (!o->no_video) {
        const cv::Mat img = system->annotate(frame, *tracks);
        if (!video.isOpened()) {
          const std::string path = (out / "annotated.avi").string();
          if (!video.open(path, cv::CAP_OPENCV_MJPEG, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), fps, img.size()))
            throw Exit{report(bad_input(path, 0, "--out", "cannot open the video for writing"))};
        }
        video.write(img);
        last_annotated = img;
      }
      ++n;
      if (!o->quiet && (n % 30 == 0)) {
        std::fprintf(stderr, tty ? "\r[track] %lld frames, %lld tracks, %.1f ms/frame pipeline" : "[track] %lld frames, %lld tracks, %.1f ms/frame pipeline\n",
                     static_cast<long long>(n), static_cast<long long>(n_tracks), 1e3 * busy / n);
      }
    }
    if (tty && !o->quiet) std::fprintf(stderr, "\n");
    if (!last_annotated.empty() && !cv::imwrite((out / "annotated_last.png").string(), last_annotated))
      throw Exit{report(bad_input((out / "annotated_last.png").string(), 0, "--out", "cannot write the image"))};
    if (Status s = writer.close(); !s) throw Exit{report(s.error())};
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
    std::printf("%lld frames, %lld track records in %s/tracks.jsonl; pipeline %.2f ms/frame (foreground, plan view, "
                "tracking), %.1f s wall with the source\n",
                static_cast<long long>(n), static_cast<long long>(n_tracks), out.c_str(), n ? 1e3 * busy / n : 0.0, wall);
  });
}

}  // namespace vigil::cli
