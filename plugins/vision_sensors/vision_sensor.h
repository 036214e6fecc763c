// Vision sensor models: the plugins attached to a scenario camera (`plugin:` under a camera)
// that turn what the camera sees into map-frame tracks each camera tick. Two kinds, as Stage
// offers a blobfinder beside its camera:
//   - pipelines that need rendered frames (the plan-view tracker of section 10.4), fed by the
//     CameraRig's OSMesa frames;
//   - `truth`: a fast model that reads the world's ground truth and reports what is in the
//     camera's view with position noise, misses and false alarms, for large runs without rendering.
// VisionSensorHost runs them all during `vigil run`, feeds each camera's tracks to its activity
// rules, and writes DIR/tracks.jsonl and DIR/camera_events.jsonl (each camera's own reports;
// the video server's merged incidents go to DIR/events.jsonl, see plugins/dds_bridge).
#pragma once

#include <filesystem>
#include <functional>
#include <map>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/videoio.hpp>

#include "world/video_writer.h"

#include "common/status.h"
#include "plugins/stereo_camera/stereo_camera.h"
#include "vision/activity_rules.h"
#include "vision/event.h"
#include "vision/frame_source.h"
#include "vision/stereo_camera_model.h"
#include "vision/track.h"
#include "vision/track_io.h"
#include "world/floorplan.h"
#include "world/params.h"
#include "world/runner.h"
#include "world/scenario.h"
#include "world/world.h"

namespace vigil::sensors {

struct SensorContext {
  CameraSpec camera;                  // the camera the sensor is attached to
  vision::StereoCameraModel model;    // its stereo model (pose in the map frame)
  std::string scenario_file;
  std::vector<FloorplanFurniture> furniture;  // the map's furniture (table tops objects may lie on)
  uint64_t seed = 0;                  // the sensor's own seed, derived from the run's
};

class VisionSensor {
 public:
  virtual ~VisionSensor() = default;
  virtual std::vector<ParamSpec> params() const = 0;
  // Takes checked parameters; errors name the key.
  virtual Status configure(const ParamSet& params, const SensorContext& ctx) = 0;
  // True when the sensor consumes rendered frames; false when it reads the world directly.
  virtual bool wants_frames() const = 0;
  // True when its tracks say where people's hands are (Track::hand_on; vision::Tracker::sees_hands).
  virtual bool sees_hands() const { return false; }
  // One camera tick at the world's current time: `frame` is the rendered stereo frame (null for
  // sensors that do not want frames). Appends this tick's tracks to `out`.
  virtual Status tick(const vision::StereoFrame* frame, const World& world, std::vector<vision::Track>* out) = 0;
  // The last tick annotated (a tracker's camera view with its tracks and own pictures), for the
  // run's videos; empty when the sensor has no picture to show.
  virtual cv::Mat annotate(const vision::StereoFrame& frame, const std::vector<vision::Track>& tracks) const {
    (void)frame;
    (void)tracks;
    return {};
  }
};

// Built-in vision sensors by name ("truth", ...).
bool vision_sensor_exists(const std::string& name);
std::vector<std::string> vision_sensor_names();
Result<std::unique_ptr<VisionSensor>> create_vision_sensor(const std::string& name);
// Adds a sensor factory (used by the plan-view pipeline and by tests).
void register_vision_sensor(const std::string& name, std::function<std::unique_ptr<VisionSensor>()> factory);

// The activity-rule parameters of a scenario's cameras: its `rules` thresholds and handling
// zones (the furniture the operator marked). Without zones, as marked objects those the scenario
// declares not authorised, where they are when the run starts (the operator's marking of what
// may not be handled, for camera systems that cannot see objects on a table).
vision::ActivityRuleParams activity_rule_params(const World& world);

// Runs the vision sensors of a scenario's cameras during a run, at each camera's rate: frame
// sensors get the rig's rendered frames, the others tick on their own. Each tick's tracks go to
// the camera's activity rules. Writes every track to DIR/tracks.jsonl and every event to
// DIR/camera_events.jsonl in time order (and keeps both for callers), and hands each event to
// the event sink (the DDS relay in `vigil run`).
class VisionSensorHost : public RunObserver {
 public:
  // Configures a sensor for every camera with a `plugin`; the rig is used for frame sensors
  // (it must also be in the run's observers, after this host: the rig's start() renders the
  // t = 0 frames, which the host must be ready to write). Errors name the scenario line.
  static Result<std::unique_ptr<VisionSensorHost>> create(const Scenario& scenario, render::CameraRig* rig);
  ~VisionSensorHost() override;
  VisionSensorHost(const VisionSensorHost&) = delete;
  VisionSensorHost& operator=(const VisionSensorHost&) = delete;
  bool empty() const { return sensors_.empty(); }

  Status start(const World& world, const std::filesystem::path& out_dir) override;
  Status after_step(const World& world) override;
  Status finish(const World& world) override;

  // Every track reported so far, in order (kept in memory unless set_keep_tracks(false): a long
  // run that writes tracks.jsonl keeps none, so its memory stays flat), and how many there were.
  const std::vector<vision::Track>& tracks() const { return tracks_; }
  size_t track_count() const { return track_count_; }
  void set_keep_tracks(bool on) { keep_tracks_ = on; }
  const std::vector<vision::Event>& events() const { return events_; }
  // Called with every event as it is raised (after it is written); an error stops the run.
  void set_event_sink(std::function<Status(const vision::Event&)> sink) { sink_ = std::move(sink); }
  // Also write DIR/cameras/<camera>_<plugin>.mp4 (or .avi): each frame sensor's annotated view
  // per tick (the camera rate). Off by default; `vigil run` turns it on unless --no-video.
  void set_videos(bool on, VideoFormat format = VideoFormat::kMp4) {
    videos_ = on;
    video_format_ = format;
  }

 private:
  VisionSensorHost() = default;
  struct Attached {
    CameraSpec camera;
    std::string file, key;  // the scenario file and "cameras[i]", for run-time errors
    std::unique_ptr<VisionSensor> sensor;
    vision::StereoCameraModel model;
    std::optional<vision::ActivityRules> rules;  // made at start()
    SimTime next_tick = 0;
    int64_t index = 0;
    VideoFile video;  // the annotated view (set_videos)
    std::vector<vision::Track> fresh;  // this frame's tracks, from the worker to the consumer
  };
  // One tick's tracks of a camera: written, kept, and given to the camera's rules.
  Status emit(Attached* a, const World& world, int64_t stamp_ns, std::vector<vision::Track>* fresh);
  // A sensor's run-time error, naming the scenario, the camera's line and key, and the time.
  static Error in_context(const Attached& a, const World& world, Error e);

  std::vector<std::unique_ptr<Attached>> sensors_;
  double robot_radius_ = 0.5;  // m, the rules' robot_radius (set at start())
  std::vector<vision::Track> tracks_;
  size_t track_count_ = 0;
  bool keep_tracks_ = true;
  std::vector<vision::Event> events_;
  std::function<Status(const vision::Event&)> sink_;
  vision::TrackJsonlWriter out_;
  std::FILE* events_out_ = nullptr;
  std::string events_path_;
  bool writing_ = false;
  bool videos_ = false;
  VideoFormat video_format_ = VideoFormat::kMp4;
  std::filesystem::path out_dir_;
};

}  // namespace vigil::sensors
