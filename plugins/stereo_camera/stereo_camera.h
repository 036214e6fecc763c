// The simulator's stereo cameras as frame sources and as run observers.
//
// RenderedStereoSource is the FrameSource of a scenario camera: it owns a World, steps it to
// each tick of the camera's rate and renders the pair with OSMesa, so the vision code reads
// rendered frames exactly as it reads recorded ones. Disparity is the renderer's ground truth,
// or (disparity=sgbm|bm) matched from the rendered pair like a real rig's.
//
// CameraRig is the RunObserver that gives every camera of a scenario its frames during
// `vigil run`: it renders each camera at its own rate as the world steps, writes the left view
// to DIR/cameras/<id>.mp4, and hands each frame to the consumers attached to that camera (the
// vision pipelines).
//
// open_any_frame_source() opens every spec the vision library knows (video:, images:, stereo:)
// plus render:SCENARIO.yaml;camera=ID[;frames=N][;disparity=truth|sgbm|bm][;matcher keys].
#pragma once

#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/videoio.hpp>

#include "world/video_writer.h"

#include "common/status.h"
#include "plugins/stereo_camera/osmesa_renderer.h"
#include "plugins/stereo_camera/render_scene.h"
#include "vision/frame_source.h"
#include "vision/stereo_matcher.h"
#include "world/runner.h"
#include "world/scenario.h"
#include "world/world.h"

namespace vigil::render {

struct RenderedSourceOptions {
  int64_t max_frames = 0;                              // 0 = until the scenario ends
  std::optional<vision::StereoMatcherParams> matcher;  // set: disparity and depth from this matcher
  RendererOptions renderer;  // its effects.seed is replaced by noise_seed
  std::optional<uint64_t> noise_seed;  // sensor-noise seed; default: from the scenario's seed and the camera id
  WorldOptions world;
};

class RenderedStereoSource : public vision::FrameSource {
 public:
  // The source of camera `camera_id` of the scenario; errors name the scenario and the key.
  static Result<std::unique_ptr<RenderedStereoSource>> open(const Scenario& scenario, const std::string& camera_id,
                                                            const RenderedSourceOptions& options = {});
  Result<bool> next(vision::StereoFrame* frame) override;
  std::optional<vision::StereoCameraModel> camera_model() const override { return model_; }
  bool is_stereo() const override { return true; }
  std::string describe() const override;

  const World& world() const { return *world_; }
  const CameraSpec& camera() const { return camera_; }
  // label -> entity id of the last frame (labels_[0] = "").
  const std::vector<std::string>& label_ids() const { return label_ids_; }

 private:
  RenderedStereoSource() = default;
  std::unique_ptr<World> world_;
  std::unique_ptr<OsmesaRenderer> renderer_;
  std::optional<vision::StereoMatcher> matcher_;
  CameraSpec camera_;
  vision::StereoCameraModel model_;
  SceneOptions scene_options_;
  std::string scenario_name_;
  int64_t index_ = 0, max_frames_ = 0;
  std::vector<std::string> label_ids_;
};

// The sensor-noise seed of a camera in a run: a stream of the scenario's seed named by the camera.
uint64_t camera_noise_seed(uint64_t scenario_seed, const std::string& camera_id);

// Replaces the frame's disparity and depth with `matcher`'s, from its left and right images
// (invalid disparity gives depth 0). With a non-empty `wanted` mask, only there
// (StereoMatcher::compute_in), and frame->depth_measured says where depth was measured.
Status match_disparity(const vision::StereoMatcher& matcher, const vision::StereoCameraModel& model,
                       vision::StereoFrame* frame, const cv::Mat& wanted = cv::Mat());

// Called with each rendered frame of a camera, the world as it is at the frame's time.
using FrameConsumer = std::function<Status(const CameraSpec&, const vision::StereoFrame&, const World&)>;

struct CameraRigOptions {
  bool video = true;   // write DIR/cameras/<id>.mp4 (left view at the camera's rate; world/video_writer.h)
  VideoFormat video_format = VideoFormat::kMp4;  // kAvi: DIR/cameras/<id>.avi, MJPEG
  RendererOptions renderer;  // effects.seed is replaced per camera by camera_noise_seed()
  // Each camera renders and runs its workers (add_worker) on a thread of its own, the cameras due
  // at one step side by side; the consumers then run on the caller's thread in camera order.
  // The same bytes come out either way (each camera's work reads only the world and its own state).
  bool camera_threads = true;
};

class CameraThread;

class CameraRig : public RunObserver {
 public:
  explicit CameraRig(CameraRigOptions options = {});
  // Frames of `camera_id` (or of every camera when empty) go to `consumer`, in time order.
  void add_consumer(const std::string& camera_id, FrameConsumer consumer);
  // Like a consumer, but run on the camera's own thread (camera_threads) beside the other cameras'
  // work, before any consumer sees the frame: it may read the world and change only state of its
  // own camera's (a vision pipeline's tick). Errors are reported in camera order.
  void add_worker(const std::string& camera_id, FrameConsumer worker);
  ~CameraRig() override;
  // True when the rig has anything to do (video on, or a consumer attached).
  bool active() const { return options_.video || !consumers_.empty(); }
  // Takes `camera_id`'s frames from a recorded source instead of rendering them: one recorded
  // frame per camera tick, stamped with the world's time, until the source ends (then the camera
  // delivers nothing more; recorded_ended() turns true). The caller makes the scenario's camera
  // spec match the source's model (camera_spec_from_model) so the sensors use the rig's pose.
  void set_recorded_source(const std::string& camera_id, std::unique_ptr<vision::FrameSource> source);
  bool recorded_ended() const { return recorded_ended_; }

  Status start(const World& world, const std::filesystem::path& out_dir) override;
  Status after_step(const World& world) override;
  Status finish(const World& world) override;

  // Frames rendered so far, per camera id.
  const std::map<std::string, int64_t>& frames() const { return frames_; }

 private:
  struct Camera {
    CameraSpec spec;
    vision::StereoCameraModel model;
    SceneOptions scene_options;
    std::unique_ptr<OsmesaRenderer> renderer;
    std::unique_ptr<vision::FrameSource> recorded;  // frames from here instead of the renderer
    bool ended = false;
    VideoFile video;
    SimTime next_tick = 0;
    int64_t index = 0;
    vision::StereoFrame frame;  // this step's
    Status status;              // of this step's work
    std::unique_ptr<CameraThread> thread;  // set with camera_threads
  };
  Status render_due(const World& world);
  // Renders (or reads) camera `cam`'s frame and runs its workers; the result in cam.status.
  void camera_work(Camera& cam, const World& world);
  std::vector<std::pair<std::string, FrameConsumer>> workers_;

  CameraRigOptions options_;
  std::vector<std::pair<std::string, FrameConsumer>> consumers_;
  std::vector<std::unique_ptr<Camera>> cameras_;
  std::map<std::string, int64_t> frames_;
  std::map<std::string, std::unique_ptr<vision::FrameSource>> recorded_;
  bool recorded_ended_ = false;
};

// `spec` with its intrinsics, image size, baseline and pose replaced by `model`'s: the camera
// spec of a recorded rig standing where its rig file says.
CameraSpec camera_spec_from_model(CameraSpec spec, const vision::StereoCameraModel& model);

// Opens any frame source: the vision library's (video:, images:, stereo:) or render:SCENARIO.
Result<std::unique_ptr<vision::FrameSource>> open_any_frame_source(const std::string& spec,
                                                                   const WorldOptions& world = {});

}  // namespace vigil::render
