// vigil track --source SPEC --pipeline planview|mser --out DIR [--frames N] [--no-video] [--video-format mp4|avi]
// On a calibrated source (render:, stereo: with a calibration) either system runs through the
// vision::Tracker interface and writes DIR/tracks.jsonl (map frame) and DIR/annotated.mp4 (the
// camera view with the tracks, and the system's own pictures: the foreground and plan-view maps,
// or the MSER segmentation with its lines and foreground).
// mser on an uncalibrated mono source (video:, images:): the colour MSER system (vision/mser)
// in the image, DIR/tracks.txt (MOTChallenge: frame, id, left, top, width, height, 1, -1, -1,
// -1; frames from 1) and DIR/annotated.mp4 (segmentation, lines, foreground, boxes).
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "plugins/builtin.h"
#include "plugins/stereo_camera/stereo_camera.h"
#include "tools/vigil/commands.h"
#include "tools/vigil/plugin_search.h"
#include "vision/mser/mser_system.h"
#include "vision/mser/mser_tracker.h"
#include "vision/planview_system.h"
#include "vision/track_io.h"
#include "world/floorplan.h"
#include "world/map.h"
#include "world/video_writer.h"

namespace vigil::cli {

namespace {

// The colour MSER system on the left images of a source: MOTChallenge boxes and a video.
// `scale` < 1: each frame is shrunk by it (area averaging) before the system sees it, and the
// boxes are scaled back to the source's pixels (the time per frame includes the shrinking).
void run_mser(const std::string& spec, vision::FrameSource& source, const std::string& out_dir, int64_t max_frames,
              bool no_video, VideoFormat video_format, bool quiet, double scale) {
  const std::filesystem::path out = out_dir;
  std::error_code ec;
  std::filesystem::create_directories(out, ec);
  if (ec) throw Exit{report(bad_input(out_dir, 0, "--out", "cannot create the folder: " + ec.message()))};
  const std::string mot_path = (out / "tracks.txt").string();
  std::FILE* mot = std::fopen(mot_path.c_str(), "wb");
  if (!mot) throw Exit{report(bad_input(mot_path, 0, "--out", "cannot create the file"))};
  vision::mser::MserSystem system;
  VideoFile video;
  if (!quiet) std::fprintf(stderr, "[track] %s, colour MSER system\n", source.describe().c_str());
  vision::StereoFrame frame;
  cv::Mat shrunk;
  int64_t n = 0, boxes = 0;
  double busy = 0;
  cv::Mat last;
  while (max_frames == 0 || n < max_frames) {
    auto more = source.next(&frame);
    if (!more) {
      std::fclose(mot);
      throw Exit{report(more.error())};
    }
    if (!*more) break;
    const auto t0 = std::chrono::steady_clock::now();
    std::string why;
    if (scale < 1 && !frame.left.empty()) {
      const cv::Size small(std::max(3, static_cast<int>(std::lround(frame.left.cols * scale))),
                           std::max(3, static_cast<int>(std::lround(frame.left.rows * scale))));
      cv::resize(frame.left, shrunk, small, 0, 0, cv::INTER_AREA);
    }
    const cv::Mat& input = scale < 1 && !frame.left.empty() ? shrunk : frame.left;
    if (!system.process(input, &why)) {
      std::fclose(mot);
      throw Exit{report(bad_input(spec, 0, "--source", "frame " + std::to_string(n) + ": " + why))};
    }
    busy += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    ++n;
    const double up = input.cols > 0 ? static_cast<double>(frame.left.cols) / input.cols : 1.0;
    for (const auto& o : system.objects()) {
      const int x0 = static_cast<int>(std::lround(o.box.x * up)), y0 = static_cast<int>(std::lround(o.box.y * up));
      const int x1 = static_cast<int>(std::lround((o.box.x + o.box.width) * up)), y1 = static_cast<int>(std::lround((o.box.y + o.box.height) * up));
      std::fprintf(mot, "%lld,%lld,%d,%d,%d,%d,1,-1,-1,-1\n", static_cast<long long>(n), static_cast<long long>(o.id), x0, y0,
                   x1 - x0, y1 - y0);
      ++boxes;
    }
    if (!no_video) {
      last = system.annotate(input);
      if (!video.is_open()) {
        const auto path = out / (std::string("annotated") + video_extension(video_format));
        if (!video.open(path, 15, last.size(), video_format)) {
          std::fclose(mot);
          throw Exit{report(bad_input(path.string(), 0, "--out", "cannot open the video for writing: " + video.why()))};
        }
      }
      video.write(last);
    }
    if (!quiet && n % 30 == 0)
      std::fprintf(stderr, "[track] %lld frames, %lld boxes, %.1f ms/frame\n", static_cast<long long>(n),
                   static_cast<long long>(boxes), 1e3 * busy / n);
  }
  std::fclose(mot);
  if (!last.empty()) cv::imwrite((out / "annotated_last.png").string(), last);
  std::printf("%lld frames, %lld boxes in %s (MOTChallenge); colour MSER system %.2f ms/frame (%.1f fps), %d background "
              "regions\n",
              static_cast<long long>(n), static_cast<long long>(boxes), mot_path.c_str(), n ? 1e3 * busy / n : 0.0,
              busy > 0 ? n / busy : 0.0, system.background_entries());
}

}  // namespace

void add_track_command(CLI::App& app) {
  struct Opts {
    std::string source, pipeline = "planview", out, camera_id, map;
    int64_t frames = 0;
    bool no_video = false, quiet = false;
    double max_range = 8.0, cell_size = 0.02, learning_rate = 0.005, scale = 1.0;
    std::string video_format = "mp4";
    VideoFormat format = VideoFormat::kMp4;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand("track", "Run a vision pipeline on a stereo frame source and write its tracks");
  cmd->add_option("--source", o->source,
                  "frame source: render:SCENARIO.yaml;camera=ID[;disparity=sgbm], stereo:L,R,CALIB;disparity=sgbm, "
                  "or (mser) video:FILE, images:PATTERN")
      ->required();
  cmd->add_option("--pipeline", o->pipeline, "vision pipeline: planview (stereo, map frame) or mser (colour MSER, image boxes)")
      ->check(CLI::IsMember({"planview", "mser"}));
  cmd->add_option("--out", o->out, "output folder")->required();
  cmd->add_option("--frames", o->frames, "stop after this many frames (default: the whole source)")->check(CLI::NonNegativeNumber);
  cmd->add_option("--camera-id", o->camera_id, "camera id written on the tracks (default: the source's camera or 'camera')");
  cmd->add_option("--map", o->map,
                  "the building's map (a .floorplan.yaml, map_server YAML or Stage worldfile) for a calibrated recorded "
                  "source: either system then tracks what stands in its free space from the first frame (a rendered "
                  "source uses its scenario's map)");
  cmd->add_option("--max-range", o->max_range, "plan view: metres from the camera (default 8)")->check(CLI::PositiveNumber);
  cmd->add_option("--cell-size", o->cell_size, "plan view: cell side in metres (default 0.02)")->check(CLI::PositiveNumber);
  cmd->add_option("--learning-rate", o->learning_rate, "foreground: alpha (default 0.005)")->check(CLI::PositiveNumber);
  cmd->add_option("--scale", o->scale,
                  "mser on video: or images:: shrink each frame by this factor first (0 < S <= 1; boxes are written in the "
                  "source's pixels; default 1)")
      ->check(CLI::Range(0.05, 1.0));
  cmd->add_flag("--no-video", o->no_video, "do not write the annotated video");
  cmd->add_option("--video-format", o->video_format, "annotated.mp4 (H.264) or annotated.avi (MPEG-4 Part 2)")
      ->check(CLI::IsMember({"mp4", "avi"}))
      ->capture_default_str();
  cmd->add_flag("--quiet,-q", o->quiet, "no progress output");
  cmd->callback([o] {
    o->format = *parse_video_format(o->video_format);  // checked by CLI11
    WorldOptions wo;
    wo.plugins = builtin_plugin_registry();
    wo.plugin_dirs = plugin_search_path();
    auto source = render::open_any_frame_source(o->source, wo);
    if (!source) throw Exit{report(source.error())};
    auto model = (*source)->camera_model();
    // Without a calibrated camera (a plain video or image folder) the MSER system tracks in the
    // image: MOTChallenge boxes.
    if (!o->map.empty() && !model)
      throw Exit{report(bad_input(o->source, 0, "--map",
                                  "the building's map places what the camera sees, which needs a calibrated source with a "
                                  "pose (render:, or stereo:LEFT,RIGHT,CALIBRATION)"))};
    if (o->pipeline == "mser" && !model) {
      run_mser(o->source, **source, o->out, o->frames, o->no_video, o->format, o->quiet, o->scale);
      return;
    }
    if (o->scale != 1.0)
      throw Exit{report(bad_input(o->source, 0, "--scale", "only the mser pipeline on a video: or images: source shrinks frames"))};
    if (o->pipeline == "planview" && (!(*source)->is_stereo() || !model)) {
      throw Exit{report(bad_input(o->source, 0, "--source",
                                  "the plan-view pipeline needs a calibrated stereo source with a pose (render:, or "
                                  "stereo:LEFT,RIGHT,CALIBRATION;disparity=sgbm); got " + (*source)->describe()))};
    }
    if (!(*source)->has_pose())
      throw Exit{report(bad_input(o->source, 0, "--source",
                                  "the rig file has no pose over the floor, which map-frame tracks need: run vigil calibrate "
                                  "floor (docs/RIG.md) or add ;pose=X,Y,Z,YAW,PITCH,ROLL to the source"))};
    std::string camera_id = o->camera_id;
    if (camera_id.empty()) {
      if (auto* r = dynamic_cast<render::RenderedStereoSource*>(source->get())) camera_id = r->camera().id;
      else camera_id = "camera";
    }
    // A calibrated source: either system through the Tracker interface, map-frame tracks.
    std::unique_ptr<vision::Tracker> system;
    if (o->pipeline == "planview") {
      vision::PlanViewSystemParams sp;
      sp.plan.max_range = o->max_range;
      sp.plan.cell_size = o->cell_size;
      sp.background.learning_rate = static_cast<float>(o->learning_rate);
      sp.tracking.camera = camera_id;
      auto pv = vision::PlanViewSystem::create(*model, sp);
      if (!pv) throw Exit{report(pv.error())};
      system = std::make_unique<vision::PlanViewSystem>(std::move(*pv));
    } else {
      vision::mser::MserTrackerParams tp;
      tp.camera = camera_id;
      // A rendered source's building: its table tops are surfaces objects lie on.
      if (auto* r = dynamic_cast<render::RenderedStereoSource*>(source->get()))
        for (const FloorplanFurniture& f : r->world().furniture())
          tp.surfaces.push_back({f.pose.x, f.pose.y, f.pose.yaw, f.size_x, f.size_y, f.height});
      auto mt = vision::mser::MserTracker::create(*model, tp);
      if (!mt) throw Exit{report(mt.error())};
      system = std::make_unique<vision::mser::MserTracker>(std::move(*mt));
    }
    // The building, for what stands there from the first frame: the --map given, or a rendered
    // source's own.
    if (!o->map.empty()) {
      const std::filesystem::path mp = o->map;
      const std::string name = mp.filename().string();
      Result<OccupancyGrid> grid = internal_error("");
      if (name.ends_with(".floorplan.yaml")) {
        auto plan = load_floorplan(mp);
        grid = plan ? Result<OccupancyGrid>(plan->rasterize()) : Result<OccupancyGrid>(plan.error());
      } else {
        grid = load_map(mp);
      }
      if (!grid) {
        Error e = grid.error();
        if (e.key.empty()) e.key = "--map";
        throw Exit{report(e)};
      }
      system->set_static_map(*grid);
    } else if (auto* r = dynamic_cast<render::RenderedStereoSource*>(source->get())) {
      system->set_static_map(r->world().map());
    }

    const std::filesystem::path out = o->out;
    std::error_code ec;
    std::filesystem::create_directories(out, ec);
    if (ec) throw Exit{report(bad_input(o->out, 0, "--out", "cannot create the folder: " + ec.message()))};
    vision::TrackJsonlWriter writer;
    if (Status s = writer.open(out / "tracks.jsonl"); !s) throw Exit{report(s.error())};
    VideoFile video;
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
        if (!video.is_open()) {
          const auto path = out / (std::string("annotated") + video_extension(o->format));
          if (!video.open(path, fps, img.size(), o->format))
            throw Exit{report(bad_input(path.string(), 0, "--out", "cannot open the video for writing: " + video.why()))};
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
    std::printf("%lld frames, %lld track records in %s/tracks.jsonl; %s pipeline %.2f ms/frame, %.1f s wall with the source\n",
                static_cast<long long>(n), static_cast<long long>(n_tracks), out.c_str(), std::string(system->name()).c_str(),
                n ? 1e3 * busy / n : 0.0, wall);
  });
}

}  // namespace vigil::cli
