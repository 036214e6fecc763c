#include "world/robot_model.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>
#include <urdf_parser/urdf_parser.h>

namespace vigil {
namespace {

// Position of `link` in the base frame, following fixed joints up to `base`.
Vec3 link_offset(const urdf::ModelInterface& model, const std::string& link_name, const std::string& base) {
  Vec3 off;
  std::string name = link_name;
  for (int guard = 0; guard < 64 && name != base; ++guard) {
    auto link = model.getLink(name);
    if (!link || !link->parent_joint) break;
    const auto& p = link->parent_joint->parent_to_joint_origin_transform.position;
    off.x += p.x;  // rotations of intermediate joints are ignored: mounts are translations
    off.y += p.y;
    off.z += p.z;
    name = link->parent_joint->parent_link_name;
  }
  return off;
}

}  // namespace

Result<RobotModel> load_robot_model(const std::filesystem::path& urdf_path) {
  const std::string file = urdf_path.string();
  std::ifstream in(urdf_path);
  if (!in) return bad_input(file, 0, "", "cannot open URDF file");
  std::stringstream ss;
  ss << in.rdbuf();
  urdf::ModelInterfaceSharedPtr model;
  {
    // urdfdom's parser is not documented as thread-safe; serialise it.
    static std::mutex mu;
    std::lock_guard<std::mutex> lock(mu);
    model = urdf::parseURDF(ss.str());
  }
  if (!model) return bad_input(file, 0, "", "not a valid URDF robot (urdfdom could not parse it)");

  RobotModel out;
  out.name = model->getName();
  auto base = model->getLink("base_link");
  if (!base) base = model->getRoot() ? model->getLink(model->getRoot()->name) : nullptr;
  if (!base) return bad_input(file, 0, "link", "no base_link and no root link");
  if (!base->collision || !base->collision->geometry) {
    return bad_input(file, 0, "link[" + base->name + "].collision",
                     "the base link needs a collision geometry (box or cylinder) for the footprint");
  }
  const auto& geo = base->collision->geometry;
  const auto& cpos = base->collision->origin.position;
  out.footprint_offset = {cpos.x, cpos.y};
  if (geo->type == urdf::Geometry::BOX) {
    auto box = std::dynamic_pointer_cast<urdf::Box>(geo);
    out.footprint = FootprintShape::kBox;
    out.half_x = box->dim.x / 2;
    out.half_y = box->dim.y / 2;
    out.radius = std::hypot(out.half_x, out.half_y);
  } else if (geo->type == urdf::Geometry::CYLINDER) {
    auto cyl = std::dynamic_pointer_cast<urdf::Cylinder>(geo);
    out.footprint = FootprintShape::kCircle;
    out.radius = cyl->radius;
    out.half_x = out.half_y = cyl->radius;
  } else if (geo->type == urdf::Geometry::SPHERE) {
    auto sph = std::dynamic_pointer_cast<urdf::Sphere>(geo);
    out.footprint = FootprintShape::kCircle;
    out.radius = out.half_x = out.half_y = sph->radius;
  } else {
    return bad_input(file, 0, "link[" + base->name + "].collision.geometry",
                     "footprint must be a box, cylinder or sphere (meshes are not supported)");
  }
  if (!(out.radius > 0.01 && out.radius < 5.0)) {
    return bad_input(file, 0, "link[" + base->name + "].collision.geometry",
                     "footprint size out of range (0.01 to 5 m)");
  }

  if (auto laser = model->getLink("laser")) {
    out.has_laser_link = true;
    out.laser_offset = link_offset(*model, "laser", base->name);
  }
  if (model->getLink("camera")) {
    out.has_camera_link = true;
    out.camera_offset = link_offset(*model, "camera", base->name);
  }

  std::vector<urdf::LinkSharedPtr> links;
  model->getLinks(links);
  std::sort(links.begin(), links.end(), [](const auto& a, const auto& b) { return a->name < b->name; });
  double top = 0;
  for (const auto& link : links) {
    for (const auto& vis : link->visual_array) {
      if (!vis || !vis->geometry) continue;
      RobotVisual rv;
      rv.link = link->name;
      const Vec3 lo = link_offset(*model, link->name, base->name);
      const auto& p = vis->origin.position;
      rv.origin = {lo.x + p.x, lo.y + p.y, lo.z + p.z};
      if (vis->material && vis->material->color.a > 0) {
        rv.rgb = {vis->material->color.r, vis->material->color.g, vis->material->color.b};
      } else if (vis->material_name.size() && model->getMaterial(vis->material_name)) {
        const auto& c = model->getMaterial(vis->material_name)->color;
        rv.rgb = {c.r, c.g, c.b};
      }
      double half_h = 0;
      switch (vis->geometry->type) {
        case urdf::Geometry::BOX: {
          auto b = std::dynamic_pointer_cast<urdf::Box>(vis->geometry);
          rv.shape = RobotVisual::Shape::kBox;
          rv.size = {b->dim.x, b->dim.y, b->dim.z};
          half_h = b->dim.z / 2;
          break;
        }
        case urdf::Geometry::CYLINDER: {
          auto c = std::dynamic_pointer_cast<urdf::Cylinder>(vis->geometry);
          rv.shape = RobotVisual::Shape::kCylinder;
          rv.size = {c->radius, c->radius, c->length};
          half_h = c->length / 2;
          break;
        }
        case urdf::Geometry::SPHERE: {
          auto s = std::dynamic_pointer_cast<urdf::Sphere>(vis->geometry);
          rv.shape = RobotVisual::Shape::kSphere;
          rv.size = {s->radius, s->radius, s->radius};
          half_h = s->radius;
          break;
        }
        default:
          continue;  // meshes are not drawn
      }
      top = std::max(top, rv.origin.z + half_h);
      out.visuals.push_back(rv);
    }
  }
  out.height = top > 0 ? top : 0.5;
  return out;
}

}  // namespace vigil
