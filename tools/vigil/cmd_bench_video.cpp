// vigil bench video: what a run's videos cost. The same rendered camera frames (and the same
// top-down frames) written as H.264 in MP4 (the default) and as the AVI formats runs wrote before
// (MJPEG for camera views, MPEG-4 Part 2 for drawn views), in the same run: wall and CPU time
// per frame (the encoder's threads included), bytes per frame, and the quality of what decodes
// back (PSNR against the frames written). docs/PERFORMANCE.md ("Videos").
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <unistd.h>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/videoio.hpp>

#include "plugins/stereo_camera/stereo_camera.h"
#include "tools/vigil/commands.h"
#include "tools/vigil/plugin_search.h"
#include "world/scenario.h"
#include "world/topdown.h"
#include "world/video_writer.h"
#include "world/world.h"

namespace vigil::cli {
namespace {

using Clock = std::chrono::steady_clock;

struct Result {
  std::string view, format;
  int frames = 0;
  double wall_ms = 0, cpu_ms = 0, bytes_per_frame = 0, psnr = 0;
};

// Writes `frames` with one format and reads them back. CPU time is the process's (all threads).
Result measure(const std::string& view, const std::vector<cv::Mat>& frames, double fps, VideoFormat format,
               VideoContent content, const std::filesystem::path& dir) {
  Result r;
  r.view = view;
  r.frames = static_cast<int>(frames.size());
  const auto path = dir / (view + video_extension(format));
  VideoFile video;
  const std::clock_t c0 = std::clock();
  const auto t0 = Clock::now();
  if (!video.open(path, fps, frames.front().size(), format, content))
    throw Exit{report(internal_error("cannot write " + path.string() + ": " + video.why()))};
  for (const cv::Mat& f : frames) video.write(f);
  video.release();  // the encoder's buffered frames are encoded here
  r.wall_ms = 1e3 * std::chrono::duration<double>(Clock::now() - t0).count() / r.frames;
  r.cpu_ms = 1e3 * static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC / r.frames;
  r.bytes_per_frame = static_cast<double>(std::filesystem::file_size(path)) / r.frames;
  cv::VideoCapture cap(path.string());
  cv::Mat back;
  double sum = 0;
  int n = 0;
  while (n < r.frames && cap.read(back)) {
    const cv::Mat& ref = frames[static_cast<size_t>(n)];
    sum += cv::PSNR(back(cv::Rect(0, 0, ref.cols, ref.rows)), ref);
    ++n;
  }
  if (n != r.frames)
    throw Exit{report(internal_error(path.string() + ": " + std::to_string(n) + " of " + std::to_string(r.frames) +
                                     " frames decode back"))};
  r.psnr = sum / n;
  r.format = format == VideoFormat::kMp4                     ? "H.264 MP4"
             : content == VideoContent::kCameraView          ? "MJPEG AVI"
                                                             : "MPEG-4 Part 2 AVI";
  return r;
}

}  // namespace

void add_bench_video_command(CLI::App* bench) {
  struct Opts {
    std::string scenario, camera = "cam_lab", json;
    int frames = 150;
  };
  auto o = std::make_shared<Opts>();
  o->scenario = (std::filesystem::path(VIGIL_SOURCE_DIR) / "scenarios" / "dis_team_bag_taken.yaml").string();
  auto* cmd = bench->add_subcommand("video", "Video encoding per frame and bytes: H.264 MP4 beside the AVI formats");
  cmd->add_option("--scenario", o->scenario, "frames from this scenario (default scenarios/dis_team_bag_taken.yaml)");
  cmd->add_option("--camera", o->camera, "its camera whose rendered view is written (default cam_lab)");
  cmd->add_option("--frames", o->frames, "frames per view (default 150: 10 s at 15 Hz)")->check(CLI::Range(2, 100000));
  cmd->add_option("--json", o->json, "also write the results as JSON to this file");
  cmd->callback([o] {
    auto scenario = load_scenario(o->scenario);
    if (!scenario) throw Exit{report(scenario.error())};
    render::RenderedSourceOptions ro;
    ro.world.plugin_dirs = plugin_search_path();
    auto src = render::RenderedStereoSource::open(*scenario, o->camera, ro);
    if (!src) throw Exit{report(src.error())};
    // The camera's frames, and the top-down view of the same world at the same instants.
    std::vector<cv::Mat> camera, topdown;
    TopdownRenderer drawer((*src)->world());
    vision::StereoFrame f;
    while (static_cast<int>(camera.size()) < o->frames) {
      auto more = (*src)->next(&f);
      if (!more) throw Exit{report(more.error())};
      if (!*more) break;
      camera.push_back(f.left.clone());
      topdown.push_back(drawer.draw((*src)->world()));
    }
    if (camera.size() < 2) throw Exit{report(bad_input(o->scenario, 0, "--frames", "fewer than two frames rendered"))};
    const double fps = (*src)->camera().rate_hz;
    const auto dir = std::filesystem::temp_directory_path() / ("vigil_bench_video_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    std::vector<Result> results;
    const std::string cam_view = o->camera, td_view = "topdown";
    results.push_back(measure(cam_view, camera, fps, VideoFormat::kMp4, VideoContent::kCameraView, dir));
    results.push_back(measure(cam_view, camera, fps, VideoFormat::kAvi, VideoContent::kCameraView, dir));
    results.push_back(measure(td_view, topdown, fps, VideoFormat::kMp4, VideoContent::kDrawnView, dir));
    results.push_back(measure(td_view, topdown, fps, VideoFormat::kAvi, VideoContent::kDrawnView, dir));
    std::filesystem::remove_all(dir);
    std::printf("%d frames of %s (%dx%d) and of the top-down view (%dx%d), %s, %.0f Hz\n", results[0].frames,
                o->camera.c_str(), camera[0].cols, camera[0].rows, topdown[0].cols, topdown[0].rows, scenario->name.c_str(),
                fps);
    std::printf("%-10s %-18s %10s %10s %12s %12s %9s\n", "view", "format", "wall ms/f", "CPU ms/f", "bytes/frame",
                "MB per 80 s", "PSNR dB");
    nlohmann::json j = nlohmann::json::array();
    for (const Result& r : results) {
      const double mb80 = r.bytes_per_frame * fps * 80 / 1e6;
      std::printf("%-10s %-18s %10.2f %10.2f %12.0f %12.1f %9.2f\n", r.view.c_str(), r.format.c_str(), r.wall_ms, r.cpu_ms,
                  r.bytes_per_frame, mb80, r.psnr);
      j.push_back({{"view", r.view}, {"format", r.format}, {"frames", r.frames}, {"wall_ms_per_frame", r.wall_ms},
                   {"cpu_ms_per_frame", r.cpu_ms}, {"bytes_per_frame", r.bytes_per_frame}, {"mb_per_80s", mb80},
                   {"psnr_db", r.psnr}});
    }
    std::printf("H.264 against the AVI: camera view %.1fx smaller, top-down %.1fx smaller\n",
                results[1].bytes_per_frame / results[0].bytes_per_frame, results[3].bytes_per_frame / results[2].bytes_per_frame);
    if (!o->json.empty()) {
      std::ofstream out(o->json);
      out << j.dump(2) << "\n";
      if (!out) throw Exit{report(bad_input(o->json, 0, "--json", "cannot write the file"))};
    }
  });
}

}  // namespace vigil::cli
