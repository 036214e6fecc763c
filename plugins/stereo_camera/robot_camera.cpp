#include "plugins/stereo_camera/robot_camera.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "world/world.h"

namespace vigil::render {
namespace fs = std::filesystem;
namespace {

double mm(double v) { return std::round(v * 1000.0) / 1000.0; }

const RobotEntity* find_robot(const World& world, const std::string& id) {
  for (const RobotEntity& r : world.robots())
    if (r.spec.id == id) return &r;
  return nullptr;
}

}  // namespace

bool robot_camera_model(const World& world, const std::string& robot, Vec2 target, const PictureOptions& options,
                        vision::StereoCameraModel* model) {
  const RobotEntity* r = find_robot(world, robot);
  if (!r || !r->model.has_camera_link) return false;
  const Vec3 off = r->model.camera_offset;
  const double c = std::cos(r->pose.yaw), s = std::sin(r->pose.yaw);
  const Eigen::Vector3d cam(r->pose.x + c * off.x - s * off.y, r->pose.y + s * off.x + c * off.y, off.z);
  vision::CameraPose pose;
  pose.position = cam;
  const double dx = target.x - cam.x(), dy = target.y - cam.y();
  pose.yaw = std::atan2(dy, dx);
  // Tilt down to the aim point (positive pitch looks down).
  pose.pitch = std::atan2(cam.z() - options.aim_height, std::max(0.05, std::hypot(dx, dy)));
  *model = vision::StereoCameraModel(vision::Intrinsics::from_hfov(options.width, options.height, options.hfov), 0.09, pose);
  return true;
}

Status PictureTaker::start(const World&, const fs::path& out_dir) {
  dir_ = out_dir.empty() ? fs::path() : out_dir / "pictures";
  pending_.clear();
  taken_.clear();
  return Status::Ok();
}

Status PictureTaker::on_report(const World&, const RobotReport& report) {
  if (report.event != "take_picture") return Status::Ok();
  Request req;
  req.report = report;
  // detail: "<kind> <incident id>"
  std::istringstream in(report.detail);
  in >> req.kind >> req.incident;
  if (req.kind.empty()) req.kind = "incident";
  if (!in) req.incident = report.task_id;
  pending_.push_back(std::move(req));
  return Status::Ok();
}

Status PictureTaker::after_step(const World& world) {
  for (const Request& r : pending_) {
    if (Status s = take(world, r); !s) return s;
  }
  pending_.clear();
  return Status::Ok();
}

Status PictureTaker::take(const World& world, const Request& req) {
  PictureRecord rec;
  rec.robot = req.report.robot;
  rec.kind = req.kind;
  rec.incident = req.incident;
  rec.time = to_seconds(world.time());
  rec.target = req.report.goal;
  const std::string stem = std::to_string(req.incident) + "_" + rec.robot;
  vision::StereoCameraModel model;
  const RobotEntity* robot = find_robot(world, rec.robot);
  nlohmann::ordered_json j;
  j["time"] = mm(rec.time);
  j["robot"] = rec.robot;
  j["incident"] = rec.incident;
  j["kind"] = rec.kind;
  j["target"] = {mm(rec.target.x), mm(rec.target.y)};
  if (!robot_camera_model(world, rec.robot, rec.target, options_, &model)) {
    rec.error = robot ? "robot '" + rec.robot + "' has no link named \"camera\" in " + robot->spec.urdf.string()
                      : "no robot '" + rec.robot + "'";
    std::fprintf(stderr, "picture %s: not taken: %s\n", stem.c_str(), rec.error.c_str());
    j["error"] = rec.error;
  } else {
    if (!renderer_) {
      auto r = OsmesaRenderer::create(options_.width, options_.height);
      if (!r) return r.error();
      renderer_ = std::move(*r);
    }
    RenderScene scene = build_render_scene(world, scene_options_for(world, nullptr));
    // The robot does not see itself.
    int32_t own = -1;
    for (size_t i = 0; i < scene.label_ids.size(); ++i)
      if (scene.label_ids[i] == rec.robot) own = static_cast<int32_t>(i);
    scene.primitives.erase(std::remove_if(scene.primitives.begin(), scene.primitives.end(),
                                          [own](const Primitive& p) { return p.label == own; }),
                           scene.primitives.end());
    vision::StereoFrame frame;
    if (Status s = renderer_->render(scene, model, &frame); !s) return s;
    // Entities in view, from the label image.
    std::map<int32_t, int> count;
    for (int v = 0; v < frame.labels.rows; ++v) {
      const int32_t* row = frame.labels.ptr<int32_t>(v);
      for (int u = 0; u < frame.labels.cols; ++u)
        if (row[u] > 0) ++count[row[u]];
    }
    for (const auto& [label, n] : count)
      if (label < static_cast<int32_t>(scene.label_ids.size())) rec.entities.push_back({scene.label_ids[label], n});
    std::stable_sort(rec.entities.begin(), rec.entities.end(), [](const auto& a, const auto& b) { return a.second > b.second; });
    // The target's aim point: in the image and not hidden (nothing more than 0.3 m in front).
    Eigen::Vector2d px;
    const Eigen::Vector3d aim(rec.target.x, rec.target.y, options_.aim_height);
    const Eigen::Vector3d p_opt = model.optical_from_map() * aim;
    if (model.project_map(aim, &px)) {
      const int u = static_cast<int>(std::lround(px.x())), v = static_cast<int>(std::lround(px.y()));
      if (u >= 0 && v >= 0 && u < frame.depth.cols && v < frame.depth.rows) {
        const float d = frame.depth.at<float>(v, u);
        rec.target_in_view = d <= 0 || d >= p_opt.z() - 0.3;
      }
      j["target_pixel"] = {mm(px.x()), mm(px.y())};
    } else {
      j["target_pixel"] = nullptr;
    }
    j["target_in_view"] = rec.target_in_view;
    j["robot_pose"] = {{"x", mm(robot->pose.x)}, {"y", mm(robot->pose.y)}, {"yaw", mm(robot->pose.yaw)}};
    j["reported_pose"] = {{"x", mm(req.report.pose.x)}, {"y", mm(req.report.pose.y)}, {"yaw", mm(req.report.pose.yaw)}};
    const auto& k = model.intrinsics();
    const auto& cp = model.pose();
    j["camera"] = {{"position", {mm(cp.position.x()), mm(cp.position.y()), mm(cp.position.z())}},
                   {"yaw", mm(cp.yaw)},
                   {"pitch", mm(cp.pitch)},
                   {"width", k.width},
                   {"height", k.height},
                   {"fx", mm(k.fx)},
                   {"fy", mm(k.fy)},
                   {"cx", mm(k.cx)},
                   {"cy", mm(k.cy)}};
    nlohmann::ordered_json ents = nlohmann::ordered_json::array();
    for (const auto& [id, n] : rec.entities) ents.push_back({{"id", id}, {"pixels", n}});
    j["entities"] = ents;
    if (!dir_.empty()) {
      std::error_code ec;
      fs::create_directories(dir_, ec);
      rec.file = (dir_ / (stem + ".png")).string();
      if (!cv::imwrite(rec.file, frame.left)) return internal_error("cannot write " + rec.file);
      j["image"] = stem + ".png";
    }
  }
  if (!dir_.empty()) {
    std::error_code ec;
    fs::create_directories(dir_, ec);
    rec.sidecar = (dir_ / (stem + ".json")).string();
    std::ofstream f(rec.sidecar);
    f << j.dump(2) << "\n";
    if (!f) return internal_error("cannot write " + rec.sidecar);
  }
  taken_.push_back(std::move(rec));
  return Status::Ok();
}

}  // namespace vigil::render
