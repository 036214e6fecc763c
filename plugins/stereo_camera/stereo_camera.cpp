#include "plugins/stereo_camera/stereo_camera.h"

#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <mutex>
#include <thread>

#include "plugins/builtin.h"
#include "vision/image_sources.h"
#include "common/rng.h"

namespace vigil::render {

// ---- RenderedStereoSource ----

Result<std::unique_ptr<RenderedStereoSource>> RenderedStereoSource::open(const Scenario& scenario,
                                                                         const std::string& camera_id,
                                                                         const RenderedSourceOptions& options) {
  auto found = find_camera(scenario, camera_id);
  if (!found) return found.error();
  const CameraSpec* spec = *found;
  std::unique_ptr<RenderedStereoSource> src(new RenderedStereoSource());
  src->camera_ = *spec;
  src->scenario_name_ = scenario.name;
  src->max_frames_ = options.max_frames;
  WorldOptions wo = options.world;
  if (!wo.plugins) wo.plugins = builtin_plugin_registry();  // robots drive as in a run
  auto world = World::create(scenario, wo);
  if (!world) return world.error();
  src->world_ = std::move(*world);
  RendererOptions ro = options.renderer;
  ro.effects.seed = options.noise_seed.value_or(camera_noise_seed(scenario.seed, camera_id));
  auto renderer = OsmesaRenderer::create(spec->width, spec->height, ro);
  if (!renderer) return renderer.error();
  src->renderer_ = std::move(*renderer);
  src->model_ = render::camera_model(*spec);
  src->scene_options_ = scene_options_for(*src->world_, spec);
  if (options.matcher) {
    auto m = vision::StereoMatcher::create(*options.matcher);
    if (!m) return m.error();
    src->matcher_ = std::move(*m);
  }
  return src;
}

Result<bool> RenderedStereoSource::next(vision::StereoFrame* frame) {
  if (max_frames_ > 0 && index_ >= max_frames_) return false;
  const SimTime tick = from_seconds(static_cast<double>(index_) / camera_.rate_hz);
  if (tick > world_->end_time()) return false;
  while (world_->time() < tick) {
    if (Status s = world_->advance(); !s) return s.error();
  }
  const RenderScene scene = build_render_scene(*world_, scene_options_);
  label_ids_ = scene.label_ids;
  frame->index = index_;
  frame->stamp_ns = world_->time();
  if (Status s = renderer_->render(scene, model_, frame); !s) return s.error();
  if (matcher_) {
    if (Status s = match_disparity(*matcher_, model_, frame); !s) return s.error();
  }
  ++index_;
  return true;
}

std::string RenderedStereoSource::describe() const {
  char buf[256];
  std::snprintf(buf, sizeof buf, "rendered %s of %s (%dx%d, %g Hz, %s disparity)", camera_.id.c_str(),
                scenario_name_.c_str(), camera_.width, camera_.height, camera_.rate_hz,
                matcher_ ? (matcher_->params().algorithm == vision::StereoAlgorithm::kBM ? "BM" : "SGBM")
                         : "ground-truth");
  return buf;
}

uint64_t camera_noise_seed(uint64_t scenario_seed, const std::string& camera_id) {
  return Rng::stream(scenario_seed, "camera_noise:" + camera_id).next();
}

Status match_disparity(const vision::StereoMatcher& matcher, const vision::StereoCameraModel& model,
                       vision::StereoFrame* frame, const cv::Mat& wanted) {
  cv::Mat measured;
  auto d = wanted.empty() ? matcher.compute(frame->left, frame->right)
                          : matcher.compute_in(frame->left, frame->right, wanted, &measured);
  if (!d) return d.error();
  // New images: the frame may share its buffers with another consumer's.
  frame->disparity = *d;
  frame->depth = vision::depth_from_disparity(*d, model);
  frame->depth_measured = measured;
  return Status::Ok();
}

// ---- CameraRig ----

// One persistent thread per camera, so that its OpenGL context is always used from the same
// thread: run() hands it a job and waits for nothing; wait() blocks until the job is done.
class CameraThread {
 public:
  CameraThread() : thread_([this] { loop(); }) {}
  ~CameraThread() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      quit_ = true;
    }
    cv_.notify_all();
    thread_.join();
  }
  void run(std::function<void()> job) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      job_ = std::move(job);
      busy_ = true;
    }
    cv_.notify_all();
  }
  void wait() {
    std::unique_lock<std::mutex> lock(mutex_);
    cv_.wait(lock, [this] { return !busy_; });
  }

 private:
  void loop() {
    std::unique_lock<std::mutex> lock(mutex_);
    for (;;) {
      cv_.wait(lock, [this] { return quit_ || (busy_ && job_); });
      if (quit_) return;
      std::function<void()> job = std::move(job_);
      job_ = nullptr;
      lock.unlock();
      job();
      lock.lock();
      busy_ = false;
      cv_.notify_all();
    }
  }
  std::mutex mutex_;
  std::condition_variable cv_;
  std::function<void()> job_;
  bool busy_ = false, quit_ = false;
  std::thread thread_;
};

CameraRig::CameraRig(CameraRigOptions options) : options_(std::move(options)) {}
CameraRig::~CameraRig() = default;

void CameraRig::add_worker(const std::string& camera_id, FrameConsumer worker) {
  workers_.emplace_back(camera_id, std::move(worker));
}

void CameraRig::set_recorded_source(const std::string& camera_id, std::unique_ptr<vision::FrameSource> source) {
  recorded_[camera_id] = std::move(source);
}

CameraSpec camera_spec_from_model(CameraSpec spec, const vision::StereoCameraModel& model) {
  const vision::Intrinsics& k = model.intrinsics();
  spec.width = k.width;
  spec.height = k.height;
  spec.fx = k.fx;
  spec.fy = k.fy;
  spec.cx = k.cx;
  spec.cy = k.cy;
  spec.hfov.reset();
  spec.baseline = model.baseline();
  const vision::CameraPose& p = model.pose();
  spec.position = {p.position.x(), p.position.y(), p.position.z()};
  spec.yaw = p.yaw;
  spec.pitch = p.pitch;
  spec.roll = p.roll;
  return spec;
}

void CameraRig::add_consumer(const std::string& camera_id, FrameConsumer consumer) {
  consumers_.emplace_back(camera_id, std::move(consumer));
}

Status CameraRig::start(const World& world, const std::filesystem::path& out_dir) {
  cameras_.clear();
  frames_.clear();
  if (!active()) return Status::Ok();
  const Scenario& scenario = world.scenario();
  for (const auto& spec : scenario.cameras) {
    bool wanted = options_.video && !out_dir.empty();
    for (const auto& [id, consumer] : consumers_) wanted = wanted || id.empty() || id == spec.id;
    for (const auto& [id, worker] : workers_) wanted = wanted || id.empty() || id == spec.id;
    if (!wanted) continue;
    auto cam = std::make_unique<Camera>();
    cam->spec = spec;
    cam->model = camera_model(spec);
    cam->scene_options = scene_options_for(world, &spec);
    if (auto it = recorded_.find(spec.id); it != recorded_.end() && it->second) {
      cam->recorded = std::move(it->second);
      if (auto m = cam->recorded->camera_model()) cam->model = *m;
    } else {
      RendererOptions ro = options_.renderer;
      ro.effects.seed = camera_noise_seed(scenario.seed, spec.id);
      auto renderer = OsmesaRenderer::create(spec.width, spec.height, ro);
      if (!renderer) return renderer.error();
      cam->renderer = std::move(*renderer);
    }
    if (options_.video && !out_dir.empty()) {
      std::error_code ec;
      std::filesystem::create_directories(out_dir / "cameras", ec);
      const auto path = out_dir / "cameras" / (spec.id + video_extension(options_.video_format));
      if (ec || !cam->video.open(path, spec.rate_hz, cv::Size(spec.width, spec.height), options_.video_format,
                                 VideoContent::kCameraView)) {
        return bad_input(path.string(), 0, "", "cannot open the camera video for writing: " + cam->video.why());
      }
    }
    frames_[spec.id] = 0;
    if (options_.camera_threads && !cam->recorded) cam->thread = std::make_unique<CameraThread>();
    cameras_.push_back(std::move(cam));
  }
  return render_due(world);
}

Status CameraRig::after_step(const World& world) { return render_due(world); }

void CameraRig::camera_work(Camera& cam, const World& world) {
  vision::StereoFrame& frame = cam.frame;
  frame = vision::StereoFrame();
  cam.status = Status::Ok();
  auto run = [&]() -> Status {
    if (cam.recorded) {
      auto more = cam.recorded->next(&frame);
      if (!more) return more.error();
      if (!*more) {
        cam.ended = true;
        return Status::Ok();
      }
      if (frame.left.cols != cam.spec.width || frame.left.rows != cam.spec.height)
        return bad_input(cam.recorded->describe(), 0, "",
                         "frame " + std::to_string(cam.index) + " is " + std::to_string(frame.left.cols) + "x" +
                             std::to_string(frame.left.rows) + " but camera " + cam.spec.id + " is " +
                             std::to_string(cam.spec.width) + "x" + std::to_string(cam.spec.height));
    } else {
      const RenderScene scene = build_render_scene(world, cam.scene_options);
      if (Status s = cam.renderer->render(scene, cam.model, &frame); !s) return s;
    }
    frame.index = cam.index;
    frame.stamp_ns = world.time();
    if (cam.video.is_open()) cam.video.write(frame.left);
    for (const auto& [id, worker] : workers_) {
      if (!id.empty() && id != cam.spec.id) continue;
      if (Status s = worker(cam.spec, frame, world); !s) return s;
    }
    return Status::Ok();
  };
  cam.status = run();
}

Status CameraRig::render_due(const World& world) {
  std::vector<Camera*> due;
  for (auto& cam : cameras_)
    if (world.time() >= cam->next_tick && !cam->ended) due.push_back(cam.get());
  // Every due camera's frame and work, side by side on their threads (recorded ones here).
  for (Camera* cam : due)
    if (cam->thread) cam->thread->run([this, cam, &world] { camera_work(*cam, world); });
  for (Camera* cam : due)
    if (!cam->thread) camera_work(*cam, world);
  for (Camera* cam : due)
    if (cam->thread) cam->thread->wait();
  // Then in camera order: errors, the consumers, the clocks.
  for (Camera* cam : due) {
    if (!cam->status) return cam->status;
    if (cam->ended) {
      recorded_ended_ = true;
      continue;
    }
    for (const auto& [id, consumer] : consumers_) {
      if (!id.empty() && id != cam->spec.id) continue;
      if (Status s = consumer(cam->spec, cam->frame, world); !s) return s;
    }
    ++cam->index;
    ++frames_[cam->spec.id];
    // The next tick on the camera's own clock (not drifting with the physics step).
    cam->next_tick = from_seconds(static_cast<double>(cam->index) / cam->spec.rate_hz);
  }
  return Status::Ok();
}

Status CameraRig::finish(const World& world) {
  for (auto& cam : cameras_) {
    cam->thread.reset();
    if (cam->video.is_open()) cam->video.release();
  }
  return Status::Ok();
}

// ---- open_any_frame_source ----

Result<std::unique_ptr<vision::FrameSource>> open_any_frame_source(const std::string& spec, const WorldOptions& world) {
  auto parsed = vision::parse_source_spec(spec);
  if (!parsed) return parsed.error();
  if (parsed->scheme != "render") return vision::open_frame_source(spec);
  auto& opts = parsed->options;
  RenderedSourceOptions ro;
  ro.world = world;
  std::string camera;
  if (auto it = opts.find("camera"); it != opts.end()) {
    camera = it->second;
    opts.erase(it);
  }
  if (auto it = opts.find("frames"); it != opts.end()) {
    char* end = nullptr;
    const long long n = std::strtoll(it->second.c_str(), &end, 10);
    if (it->second.empty() || *end != '\0' || n <= 0)
      return bad_input(spec, 0, "frames", "expected a positive integer, got '" + it->second + "'");
    ro.max_frames = n;
    opts.erase(it);
  }
  if (auto it = opts.find("disparity"); it != opts.end() && it->second == "truth") opts.erase(it);
  auto matcher = vision::take_matcher_options(spec, &opts);
  if (!matcher) return matcher.error();
  ro.matcher = *matcher;
  auto scenario = load_scenario(parsed->body);
  if (!scenario) return scenario.error();
  if (camera.empty()) {
    if (scenario->cameras.empty()) return bad_input(spec, 0, "camera", "the scenario has no cameras");
    camera = scenario->cameras.front().id;
  }
  auto src = RenderedStereoSource::open(*scenario, camera, ro);
  if (!src) return src.error();
  return std::unique_ptr<vision::FrameSource>(std::move(*src));
}

}  // namespace vigil::render
