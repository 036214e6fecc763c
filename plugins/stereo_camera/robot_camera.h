// A robot's inspection camera (chapter 10.6.2: the robot that reaches a "bag taken" event takes a
// high-resolution picture). A robot's controller asks for a picture with a report whose event is
// "take_picture", its goal the map-frame point to aim at and its detail "<kind> <incident id>"
// (plugins/team/). The PictureTaker, a run observer, renders the world with OSMesa from the
// robot's camera link (the URDF's link named "camera", placed on the robot's true pose: this is
// the sensor, not a controller), panned and tilted at the target, and writes
//   DIR/pictures/<incident>_<robot>.png    the colour image (default 1280 x 960)
//   DIR/pictures/<incident>_<robot>.json   the sidecar: time, robot, incident, kind, the robot's
//                                          pose (true and as it reported it), the camera (pose,
//                                          intrinsics), the target and its pixel, and the
//                                          entities in view from the renderer's label image
// The robot's own body is left out of its picture. A robot without a camera link gets a sidecar
// with "error" and no image (and a line on stderr); the run goes on.
#pragma once

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "plugins/stereo_camera/osmesa_renderer.h"
#include "world/runner.h"

namespace vigil::render {

struct PictureOptions {
  int width = 1280, height = 960;
  double hfov = 60.0 * M_PI / 180;  // rad
  double aim_height = 0.3;          // m above the floor: where on the target the camera points
};

// One picture taken, as written in its sidecar.
struct PictureRecord {
  std::string file;        // PNG path ("" when it could not be taken)
  std::string sidecar;     // JSON path
  std::string robot, kind, error;
  uint64_t incident = 0;
  double time = 0;         // s
  Vec2 target;
  bool target_in_view = false;  // the target's aim point projects into the image, unoccluded
  std::vector<std::pair<std::string, int>> entities;  // entity id, pixels in view (most first)
};

class PictureTaker : public RunObserver {
 public:
  explicit PictureTaker(PictureOptions options = {}) : options_(options) {}
  Status start(const World& world, const std::filesystem::path& out_dir) override;
  Status on_report(const World& world, const RobotReport& report) override;
  Status after_step(const World& world) override;
  const std::vector<PictureRecord>& pictures() const { return taken_; }

 private:
  struct Request {
    RobotReport report;
    std::string kind;
    uint64_t incident = 0;
  };
  Status take(const World& world, const Request& req);

  PictureOptions options_;
  std::filesystem::path dir_;
  std::unique_ptr<OsmesaRenderer> renderer_;
  std::vector<Request> pending_;
  std::vector<PictureRecord> taken_;
};

// The camera model of `robot`'s camera link at its true pose, aimed at `target` (a map point,
// aim_height above the floor). False when the robot has no camera link.
bool robot_camera_model(const World& world, const std::string& robot, Vec2 target, const PictureOptions& options,
                        vision::StereoCameraModel* model);

}  // namespace vigil::render
