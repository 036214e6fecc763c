// The 3D scene a stereo camera renders, as plain data: a list of primitives (boxes, cylinders,
// spheres) with a rigid pose, a size, a base colour, a procedural texture and an integer label,
// plus the ceiling lights. build_render_scene() derives it from the World every frame (floor,
// ceiling, walls extruded from the map, furniture, robots from their URDF visuals, people as
// articulated walking figures, objects), so nothing in it can drift from the world.
//
// Labels: 0 is the background and everything static (floor, ceiling, walls, furniture, lights);
// then 1 + i in a stable order: robots (in World::robots() order), then people (World::people()
// order), then objects (World::objects() order). RenderScene::label_ids maps a label back to
// the entity's id (label_ids[0] = "").
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

namespace vigil {
class World;
}

namespace vigil::render {

enum class Shape : int { kBox = 0, kCylinder = 1, kSphere = 2 };

// Procedural surface patterns, evaluated in the fragment shader.
enum class Texture : int {
  kPlain = 0,    // faint grain
  kPlaster = 1,  // walls: mottled plaster (world-anchored)
  kTiles = 2,    // floor: 0.5 m tiles with grout (world-anchored)
  kCeiling = 3,  // ceiling panels (world-anchored)
  kCloth = 4,    // clothing weave and folds
  kSkin = 5,     // faces and hands
  kWood = 6,     // table tops
  kEmissive = 7, // light panels: not lit, full brightness
  kPaint = 8,    // robot bodies and object surfaces: fine speckle
};

// One primitive. The unit shape (box: [-0.5, 0.5]^3; cylinder: radius 0.5, height 1 along z,
// centred; sphere: radius 0.5) is scaled by `size` (full extents, metres) and placed by `pose`
// (map frame).
struct Primitive {
  Shape shape = Shape::kBox;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  Eigen::Vector3d size{1, 1, 1};
  Eigen::Vector3f colour{0.5f, 0.5f, 0.5f};  // linear RGB in [0, 1]
  Texture texture = Texture::kPlain;
  int32_t label = 0;
};

// A point light (ceiling light) with a quadratic fall-off.
struct Light {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  float intensity = 1.0f;
};

struct RenderScene {
  std::vector<Primitive> primitives;
  std::vector<Light> lights;  // the renderer uses the eight nearest to the view
  float ambient = 0.35f;
  std::vector<std::string> label_ids;  // label -> entity id; [0] = "" (background)
};

// Options of the scene builder.
struct SceneOptions {
  double wall_height = 2.7;     // m, when the world has no floorplan height
  double light_spacing = 4.0;   // m between ceiling lights along free space
  // When set (a camera's position), only the lights this point sees across the map (walls
  // block, no shadows otherwise) light the scene; their panels are drawn either way.
  std::optional<Eigen::Vector3d> viewpoint;
};

// Builds the scene of the world as it is now.
RenderScene build_render_scene(const World& world, const SceneOptions& options = {});

// Appends a walking person's figure (legs, torso, arms, head) standing at (x, y) facing `yaw`:
// `walked` metres walked so far drives the gait phase (one cycle per 1.4 m), `speed` (m/s)
// its amplitude. Colours are linear RGB. With `hand_target` (map frame), the arm on that side
// reaches from the shoulder towards it (stretched up to 1.7 times its length, as a person
// leans to reach), the hand at its end: someone picking up, putting down or touching a thing.
void add_person_figure(RenderScene* scene, double x, double y, double yaw, double height, double radius,
                       double walked, double speed, const Eigen::Vector3f& shirt,
                       const Eigen::Vector3f& trousers, int32_t label,
                       const Eigen::Vector3d* hand_target = nullptr);

// "#rrggbb" to RGB in [0, 1]; grey for anything malformed.
Eigen::Vector3f colour_from_hex(const std::string& hex);

}  // namespace vigil::render
