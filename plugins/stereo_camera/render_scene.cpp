// Builds the renderer's plain-data scene from the World: static structure (floor, ceiling, walls
// extruded from the map's wall boxes, furniture, light panels) and the entities (robots from
// their URDF visuals, people as articulated walking figures, objects by kind).
#include "plugins/stereo_camera/render_scene.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "world/world.h"

namespace vigil::render {
namespace {

using Eigen::Isometry3d;
using Eigen::Vector3d;
using Eigen::Vector3f;

constexpr double kStride = 1.4;  // m walked per gait cycle (two steps)
const Vector3f kSkin{0.85f, 0.64f, 0.52f};
const Vector3f kHair{0.18f, 0.12f, 0.08f};
const Vector3f kShoe{0.08f, 0.08f, 0.08f};

// A pose at (x, y, z) turned by `yaw` about the map's z.
Isometry3d planar_pose(double x, double y, double z, double yaw) {
  Isometry3d t = Isometry3d::Identity();
  t.translate(Vector3d(x, y, z));
  t.rotate(Eigen::AngleAxisd(yaw, Vector3d::UnitZ()));
  return t;
}

void add(RenderScene* s, Shape shape, const Isometry3d& pose, const Vector3d& size, const Vector3f& colour,
         Texture tex, int32_t label) {
  Primitive p;
  p.shape = shape;
  p.pose = pose;
  p.size = size;
  p.colour = colour;
  p.texture = tex;
  p.label = label;
  s->primitives.push_back(p);
}

// A limb hanging from `joint` (in the figure's frame), swung by `angle` about the figure's
// lateral axis (positive swings the far end forward).
void add_limb(RenderScene* s, const Isometry3d& figure, const Vector3d& joint, double length, double width,
              double depth, double angle, const Vector3f& colour, Texture tex, int32_t label) {
  Isometry3d t = figure;
  t.translate(joint);
  t.rotate(Eigen::AngleAxisd(-angle, Vector3d::UnitY()));  // +x forward, so -angle about y lifts it forward
  t.translate(Vector3d(0, 0, -length / 2));
  add(s, Shape::kBox, t, Vector3d(depth, width, length), colour, tex, label);
}

// True when (x, y) lies in a furniture item's footprint grown by `margin`.
bool in_furniture(const std::vector<FloorplanFurniture>& furniture, double x, double y, double margin) {
  for (const auto& f : furniture) {
    const double c = std::cos(f.pose.yaw), sn = std::sin(f.pose.yaw);
    const double dx = x - f.pose.x, dy = y - f.pose.y;
    const double lx = c * dx + sn * dy, ly = -sn * dx + c * dy;
    if (std::abs(lx) <= f.size_x / 2 + margin && std::abs(ly) <= f.size_y / 2 + margin) return true;
  }
  return false;
}

// Length of the free run through cell (cx, cy) along one axis (looking at most `reach` metres
// either way), and its centre coordinate.
void free_run(const OccupancyGrid& g, int cx, int cy, bool along_x, double reach, double* length, double* centre) {
  const int max_cells = static_cast<int>(reach / g.resolution()) + 1;
  int lo = 0, hi = 0;
  auto free_at = [&](int k) {
    const int x = along_x ? cx + k : cx, y = along_x ? cy : cy + k;
    return g.in_bounds(x, y) && g.at(x, y) == Cell::kFree;
  };
  while (lo > -max_cells && free_at(lo - 1)) --lo;
  while (hi < max_cells && free_at(hi + 1)) ++hi;
  *length = (hi - lo + 1) * g.resolution();
  const Vec2 a = g.cell_center(along_x ? cx + lo : cx, along_x ? cy : cy + lo);
  const Vec2 b = g.cell_center(along_x ? cx + hi : cx, along_x ? cy : cy + hi);
  *centre = along_x ? (a.x + b.x) / 2 : (a.y + b.y) / 2;
}

// True when the straight line between two map points crosses no wall.
bool line_of_sight(const OccupancyGrid& g, const Vector3d& a, const Vector3d& b) {
  const double dx = b.x() - a.x(), dy = b.y() - a.y(), len = std::hypot(dx, dy);
  if (len < 1e-6) return true;
  return g.raycast({a.x(), a.y()}, std::atan2(dy, dx), len) >= len - 1e-6;
}

// Ceiling lights over free space: candidates on a 1 m grid, each centred across narrow spaces
// (corridors), kept unless a light kept before is within `spacing` in sight of it.
std::vector<Light> place_lights(const OccupancyGrid& g, double spacing, double ceiling) {
  std::vector<Light> lights;
  const Vec2 o{g.origin().x, g.origin().y};
  for (double y = o.y + 0.5; y < o.y + g.size_y(); y += 1.0) {
    for (double x = o.x + 0.5; x < o.x + g.size_x(); x += 1.0) {
      int cx = 0, cy = 0;
      if (!g.world_to_cell({x, y}, &cx, &cy) || g.at(cx, cy) != Cell::kFree) continue;
      double lx = x, ly = y, len = 0, mid = 0;
      free_run(g, cx, cy, true, spacing, &len, &mid);
      if (len < spacing) lx = mid;
      free_run(g, cx, cy, false, spacing, &len, &mid);
      if (len < spacing) ly = mid;
      const Vector3d here(lx, ly, ceiling - 0.05);
      const bool near_other = std::any_of(lights.begin(), lights.end(), [&](const Light& l) {
        const double dx = l.position.x() - lx, dy = l.position.y() - ly;
        return dx * dx + dy * dy < spacing * spacing * 0.9 &&
               line_of_sight(g, l.position, here);
      });
      if (near_other) continue;
      Light l;
      l.position = Vector3d(lx, ly, ceiling - 0.05);
      lights.push_back(l);
    }
  }
  return lights;
}

void add_object(RenderScene* s, const ObjectEntity& o, int32_t label) {
  const ObjectSpec& sp = o.spec;
  const Vector3f colour = colour_from_hex(sp.colour);
  const Isometry3d base = planar_pose(o.pose.x, o.pose.y, o.z, o.pose.yaw);
  switch (sp.kind) {
    case ObjectKind::kBottle: {
      const double r = std::min(sp.size_x, sp.size_y) / 2, h = sp.size_z;
      add(s, Shape::kCylinder, base * Eigen::Translation3d(0, 0, h * 0.4), Vector3d(2 * r, 2 * r, h * 0.8), colour,
          Texture::kPaint, label);
      add(s, Shape::kCylinder, base * Eigen::Translation3d(0, 0, h * 0.9), Vector3d(r, r, h * 0.2), colour * 0.8f,
          Texture::kPaint, label);
      break;
    }
    case ObjectKind::kLaptop: {
      // Base and an opened lid leaning back.
      const double t = std::min(0.02, sp.size_z / 2);
      add(s, Shape::kBox, base * Eigen::Translation3d(0, 0, t / 2), Vector3d(sp.size_x, sp.size_y, t), colour,
          Texture::kPaint, label);
      Isometry3d lid = base * Eigen::Translation3d(-sp.size_x / 2, 0, t);
      lid.rotate(Eigen::AngleAxisd(-0.3, Vector3d::UnitY()));
      lid.translate(Vector3d(0, 0, sp.size_x / 2));
      add(s, Shape::kBox, lid, Vector3d(t, sp.size_y, sp.size_x), colour * 0.7f, Texture::kPaint, label);
      break;
    }
    case ObjectKind::kBag: {
      add(s, Shape::kBox, base * Eigen::Translation3d(0, 0, sp.size_z * 0.45),
          Vector3d(sp.size_x, sp.size_y, sp.size_z * 0.9), colour, Texture::kCloth, label);
      // Handle.
      add(s, Shape::kBox, base * Eigen::Translation3d(0, 0, sp.size_z * 0.95),
          Vector3d(sp.size_x * 0.5, 0.02, sp.size_z * 0.1), colour * 0.6f, Texture::kPlain, label);
      break;
    }
    case ObjectKind::kBook:
    case ObjectKind::kBox:
      add(s, Shape::kBox, base * Eigen::Translation3d(0, 0, sp.size_z / 2), Vector3d(sp.size_x, sp.size_y, sp.size_z),
          colour, Texture::kPaint, label);
      break;
  }
}

void add_furniture(RenderScene* s, const FloorplanFurniture& f) {
  const Isometry3d base = planar_pose(f.pose.x, f.pose.y, 0, f.pose.yaw);
  const double top = 0.04, leg = 0.06;
  const Vector3f wood{0.55f, 0.38f, 0.22f}, metal{0.3f, 0.3f, 0.32f};
  if (f.kind == "table") {
    add(s, Shape::kBox, base * Eigen::Translation3d(0, 0, f.height - top / 2), Vector3d(f.size_x, f.size_y, top), wood,
        Texture::kWood, 0);
    for (int sx : {-1, 1}) {
      for (int sy : {-1, 1}) {
        add(s, Shape::kBox,
            base * Eigen::Translation3d(sx * (f.size_x / 2 - leg), sy * (f.size_y / 2 - leg), (f.height - top) / 2),
            Vector3d(leg, leg, f.height - top), metal, Texture::kPaint, 0);
      }
    }
  } else {
    add(s, Shape::kBox, base * Eigen::Translation3d(0, 0, f.height / 2), Vector3d(f.size_x, f.size_y, f.height), wood,
        Texture::kWood, 0);
  }
}

void add_robot(RenderScene* s, const RobotEntity& r, int32_t label) {
  const Isometry3d base = planar_pose(r.pose.x, r.pose.y, 0, r.pose.yaw);
  for (const RobotVisual& v : r.model.visuals) {
    const Vector3f colour(static_cast<float>(v.rgb.x), static_cast<float>(v.rgb.y), static_cast<float>(v.rgb.z));
    Isometry3d t = base * Eigen::Translation3d(v.origin.x, v.origin.y, v.origin.z);
    switch (v.shape) {
      case RobotVisual::Shape::kBox:
        add(s, Shape::kBox, t, Vector3d(v.size.x, v.size.y, v.size.z), colour, Texture::kPaint, label);
        break;
      case RobotVisual::Shape::kCylinder: {
        // URDF visual rotations are not kept; wheels (short cylinders on a "wheel" link) turn their
        // axis sideways, every other cylinder stands upright.
        if (v.link.find("wheel") != std::string::npos) t.rotate(Eigen::AngleAxisd(M_PI / 2, Vector3d::UnitX()));
        add(s, Shape::kCylinder, t, Vector3d(2 * v.size.x, 2 * v.size.x, v.size.z), colour, Texture::kPaint, label);
        break;
      }
      case RobotVisual::Shape::kSphere:
        add(s, Shape::kSphere, t, Vector3d::Constant(2 * v.size.x), colour, Texture::kPaint, label);
        break;
    }
  }
}

}  // namespace

Eigen::Vector3f colour_from_hex(const std::string& hex) {
  if (hex.size() != 7 || hex[0] != '#') return {0.5f, 0.5f, 0.5f};
  char* end = nullptr;
  const unsigned long v = std::strtoul(hex.c_str() + 1, &end, 16);
  if (end != hex.c_str() + 7) return {0.5f, 0.5f, 0.5f};
  return {((v >> 16) & 0xff) / 255.0f, ((v >> 8) & 0xff) / 255.0f, (v & 0xff) / 255.0f};
}

void add_person_figure(RenderScene* s, double x, double y, double yaw, double height, double radius, double walked,
                       double speed, const Vector3f& shirt, const Vector3f& trousers, int32_t label,
                       const Vector3d* hand_target) {
  const double h = height;
  const Isometry3d fig = planar_pose(x, y, 0, yaw);
  const double phase = 2 * M_PI * walked / kStride;
  const double amp = 0.42 * std::clamp(speed / 1.2, 0.0, 1.0);
  const double swing = amp * std::sin(phase);
  const double hip = 0.52 * h, shoulder = 0.81 * h;
  const double leg_len = hip, leg_w = 0.09 * h / 1.75, leg_gap = 0.055 * h / 1.75;
  const double torso_w = std::min(2 * radius * 0.8, 0.42 * h / 1.75), torso_d = std::min(radius * 0.9, 0.22);
  // Legs (left leg forward on positive swing), with shoes.
  for (int side : {1, -1}) {
    const double a = side * swing;
    add_limb(s, fig, Vector3d(0, side * leg_gap, hip), leg_len - 0.06, leg_w, leg_w * 1.2, a, trousers, Texture::kCloth,
             label);
    Isometry3d foot = fig;
    foot.translate(Vector3d(0, side * leg_gap, hip));
    foot.rotate(Eigen::AngleAxisd(-a, Vector3d::UnitY()));
    foot.translate(Vector3d(0.04, 0, -leg_len + 0.035));
    add(s, Shape::kBox, foot, Vector3d(0.26 * h / 1.75, leg_w, 0.07), kShoe, Texture::kPlain, label);
  }
  // Torso and hips.
  add(s, Shape::kBox, fig * Eigen::Translation3d(0, 0, (hip + shoulder) / 2), Vector3d(torso_d, torso_w, shoulder - hip),
      shirt, Texture::kCloth, label);
  add(s, Shape::kBox, fig * Eigen::Translation3d(0, 0, hip - 0.04), Vector3d(torso_d * 0.95, torso_w * 0.9, 0.12),
      trousers, Texture::kCloth, label);
  // Arms swing against the legs; sleeves then hands.
  const double arm_len = 0.36 * h, arm_w = 0.075 * h / 1.75;
  // The reaching arm: the side whose shoulder is nearer the target.
  int reach_side = 0;
  if (hand_target) reach_side = (fig.inverse() * *hand_target).y() >= 0 ? 1 : -1;
  for (int side : {1, -1}) {
    const double a = -side * swing * 0.8;
    const Vector3d joint(0, side * (torso_w / 2 + arm_w / 2 + 0.005), shoulder - 0.03);
    if (side == reach_side) {
      const Vector3d from = fig * joint;
      const Vector3d to = *hand_target - from;
      const double len = std::min(to.norm(), 1.7 * arm_len);
      if (len > 0.05) {
        const Vector3d dir = to / to.norm();
        // The limb's local -z (hanging down) turned onto the reach direction.
        const Eigen::Quaterniond q = Eigen::Quaterniond::FromTwoVectors(-Vector3d::UnitZ(), dir);
        Isometry3d sleeve = Isometry3d::Identity();
        sleeve.translate(from + dir * (0.4 * len));
        sleeve.rotate(q);
        add(s, Shape::kBox, sleeve, Vector3d(arm_w, arm_w, 0.8 * len), shirt, Texture::kCloth, label);
        Isometry3d hand = Isometry3d::Identity();
        hand.translate(from + dir * (0.9 * len));
        hand.rotate(q);
        add(s, Shape::kBox, hand, Vector3d(arm_w * 0.9, arm_w * 0.8, 0.2 * len), kSkin, Texture::kSkin, label);
        continue;
      }
    }
    add_limb(s, fig, joint, arm_len * 0.8, arm_w, arm_w, a, shirt, Texture::kCloth, label);
    Isometry3d hand = fig;
    hand.translate(joint);
    hand.rotate(Eigen::AngleAxisd(-a, Vector3d::UnitY()));
    hand.translate(Vector3d(0, 0, -arm_len * 0.9));
    add(s, Shape::kBox, hand, Vector3d(arm_w * 0.9, arm_w * 0.8, arm_len * 0.2), kSkin, Texture::kSkin, label);
  }
  // Neck, head and hair.
  const double head_d = 0.125 * h;
  add(s, Shape::kCylinder, fig * Eigen::Translation3d(0, 0, shoulder + 0.03), Vector3d(0.1, 0.1, 0.08), kSkin,
      Texture::kSkin, label);
  add(s, Shape::kSphere, fig * Eigen::Translation3d(0.01, 0, h - head_d / 2), Vector3d(head_d * 0.85, head_d * 0.8, head_d),
      kSkin, Texture::kSkin, label);
  add(s, Shape::kSphere, fig * Eigen::Translation3d(-0.015, 0, h - head_d * 0.38),
      Vector3d(head_d * 0.85, head_d * 0.82, head_d * 0.78), kHair, Texture::kCloth, label);
}

RenderScene build_render_scene(const World& world, const SceneOptions& options) {
  RenderScene s;
  const OccupancyGrid& g = world.map();
  const double H = options.wall_height;
  const auto& furniture = world.furniture();
  s.primitives.reserve(world.walls().size() + 32 * world.people().size() + 64);

  // Floor and ceiling over the whole map.
  const double sx = g.size_x(), sy = g.size_y();
  const double mx = g.origin().x + sx / 2, my = g.origin().y + sy / 2;
  add(&s, Shape::kBox, planar_pose(mx, my, -0.05, 0), Vector3d(sx, sy, 0.1), {0.62f, 0.6f, 0.56f}, Texture::kTiles, 0);
  add(&s, Shape::kBox, planar_pose(mx, my, H + 0.05, 0), Vector3d(sx, sy, 0.1), {0.85f, 0.85f, 0.83f},
      Texture::kCeiling, 0);
  // Walls: the map's wall boxes extruded to the wall height (furniture footprints excluded).
  for (const WallBox& w : world.walls()) {
    const double cx = (w.min.x + w.max.x) / 2, cy = (w.min.y + w.max.y) / 2;
    if (in_furniture(furniture, cx, cy, g.resolution())) continue;
    add(&s, Shape::kBox, planar_pose(cx, cy, H / 2, 0), Vector3d(w.max.x - w.min.x, w.max.y - w.min.y, H),
        {0.78f, 0.76f, 0.7f}, Texture::kPlaster, 0);
  }
  for (const auto& f : furniture) add_furniture(&s, f);
  // Ceiling lights and their panels.
  const std::vector<Light> lights = place_lights(g, options.light_spacing, H);
  int vx = 0, vy = 0;
  const bool view_in_free = options.viewpoint &&
                            g.world_to_cell({options.viewpoint->x(), options.viewpoint->y()}, &vx, &vy) &&
                            g.at(vx, vy) == Cell::kFree;
  for (const Light& l : lights) {
    add(&s, Shape::kBox, planar_pose(l.position.x(), l.position.y(), H - 0.01, 0), Vector3d(1.2, 0.3, 0.02),
        {1.0f, 1.0f, 0.95f}, Texture::kEmissive, 0);
    if (!view_in_free || line_of_sight(g, *options.viewpoint, l.position)) s.lights.push_back(l);
  }

  // Entities, labelled in a stable order: robots, people, objects.
  s.label_ids.push_back("");
  int32_t label = 1;
  for (const RobotEntity& r : world.robots()) {
    add_robot(&s, r, label++);
    s.label_ids.push_back(r.spec.id);
  }
  for (const PersonEntity& p : world.people()) {
    if (p.present) {
      const Vector3d reach(p.reach_target.x, p.reach_target.y, p.reach_z);
      add_person_figure(&s, p.pose.x, p.pose.y, p.pose.yaw, p.spec.height, p.spec.radius, p.walked,
                        p.velocity.norm(), colour_from_hex(p.spec.shirt), colour_from_hex(p.spec.trousers), label,
                        p.handling() ? &reach : nullptr);
    }
    ++label;
    s.label_ids.push_back(p.spec.id);
  }
  for (const ObjectEntity& o : world.objects()) {
    if (o.present) add_object(&s, o, label);
    ++label;
    s.label_ids.push_back(o.spec.id);
  }
  return s;
}

}  // namespace vigil::render
