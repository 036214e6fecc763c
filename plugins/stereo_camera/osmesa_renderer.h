// Off-screen stereo rendering with OSMesa (Mesa's llvmpipe, no display): an OpenGL 4.5 core
// context, instanced unit shapes (box, cylinder, sphere) drawn from a RenderScene, procedural
// textures and ceiling lights in GLSL. One call renders the left and right views of a
// StereoCameraModel and reads back the left and right colour, the left view's ground-truth
// depth (metres along the optical axis, written per fragment into a float target, exact to
// float precision), disparity (fx * baseline / depth) and entity labels.
//
// The projection puts pixel (u, v) exactly where StereoCameraModel::project says (pixel centres
// at integer coordinates, row 0 at the top). Depth testing uses a reversed, 32-bit float depth
// buffer with an infinite far plane. The renderer keeps only GL resources: everything drawn
// comes from the RenderScene passed in, so it cannot drift from the world.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "common/status.h"
#include "plugins/stereo_camera/render_scene.h"
#include "vision/frame_source.h"
#include "vision/stereo_camera_model.h"

namespace vigil {
struct CameraSpec;
class World;
}  // namespace vigil

namespace vigil::render {

// Optional sensor effects, applied on the CPU to both colour images after readback.
struct SensorEffects {
  double exposure = 1.0;   // gain on the colour values
  double blur_sigma = 0;   // px, Gaussian blur (0 = none)
  double noise_std = 0;    // grey levels, Gaussian pixel noise (0 = none)
  uint64_t seed = 1;       // noise seed; combined with the frame index, so frames differ but repeat
};

struct RendererOptions {
  int gl_major = 4, gl_minor = 5;  // core-profile version requested from OSMesa
  double near_clip = 0.005;        // m (reversed float depth keeps precision at any near)
  SensorEffects effects;
};

class OsmesaRenderer {
 public:
  // Creates the OSMesa context and the off-screen targets for width x height views. Errors
  // (kInternal) name what failed: the context, making it current, a size beyond the GL limits,
  // shader compilation, an incomplete framebuffer.
  static Result<std::unique_ptr<OsmesaRenderer>> create(int width, int height, const RendererOptions& options = {});
  ~OsmesaRenderer();
  OsmesaRenderer(const OsmesaRenderer&) = delete;
  OsmesaRenderer& operator=(const OsmesaRenderer&) = delete;

  // Renders the scene from the camera's left and right views into `out` (left, right, depth,
  // disparity, labels; index and stamp are left as they are). The camera's image size must be
  // the renderer's.
  Status render(const RenderScene& scene, const vision::StereoCameraModel& camera, vision::StereoFrame* out);

  int width() const;
  int height() const;
  // GL_RENDERER and GL_VERSION strings of the context, e.g. "llvmpipe (LLVM 15.0.6, 256 bits)".
  std::string gl_renderer() const;
  std::string gl_version() const;

 private:
  struct Impl;
  explicit OsmesaRenderer(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

// The stereo camera model of a scenario camera.
vision::StereoCameraModel camera_model(const CameraSpec& spec);

// Scene options for a world seen by `camera` (may be null): the floorplan's wall height when
// the map is a floorplan, and the camera's position as the lights' viewpoint.
SceneOptions scene_options_for(const World& world, const CameraSpec* camera = nullptr);

struct RenderBenchResult {
  int width = 0, height = 0, pairs = 0;
  size_t primitives = 0;          // primitives in the scene
  double seconds = 0;             // wall time of all pairs (scene build + render + readback)
  double pairs_per_second = 0;
  std::string gl_renderer;
};

// Times `pairs` stereo pairs of the world as it is now from `camera` at width x height (scene
// built from the world every pair, colour, depth, disparity and labels read back), after one
// warm-up pair.
Result<RenderBenchResult> bench_render(const World& world, const CameraSpec& camera, int width, int height, int pairs);

}  // namespace vigil::render
