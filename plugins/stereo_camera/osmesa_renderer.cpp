// OSMesa stereo renderer: context and targets, GLSL shaders, instanced unit shapes, readback
// and the CPU sensor effects.
#include "plugins/stereo_camera/osmesa_renderer.h"

#define GL_GLEXT_PROTOTYPES 1
#include <GL/osmesa.h>
#include <GL/gl.h>
#include <GL/glext.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <tuple>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "world/floorplan.h"
#include "world/world.h"

namespace vigil::render {
namespace {

// ---------------------------------------------------------------- shaders

// Procedural textures are one branch-free formula whose parameters depend on the texture kind
// (render_scene.h's Texture): t = c0 + a1 * noise(uv * f1 * (1, stretch)) + a2 * noise(uv * f2)
// + tint * hash(grid cell), darkened to `line` on grid lines of frequency gf and half-width
// (0.5 - gw); emissive surfaces are not lit. llvmpipe runs both sides of data-dependent branches,
// so one formula is several times cheaper than a branch per kind.
// Per kind: {c0, a1, f1, stretch}, {a2, f2, gf, gw}, {line, tint, emissive, anchored}.
const float kTextureParams[9][12] = {
    {0.85f, 0.20f, 13.0f, 1.0f, 0.0f, 1.0f, 0.0f, 1.0f, 1.0f, 0.0f, 0.0f, 0.0f},           // plain
    {0.72f, 0.28f, 7.0f, 1.0f, 0.18f, 23.0f, 0.0f, 1.0f, 1.0f, 0.0f, 0.0f, 1.0f},          // plaster
    {0.78f, 0.0f, 1.0f, 1.0f, 0.22f, 19.0f, 2.0f, 0.47f, 0.45f, 0.2f, 0.0f, 1.0f},         // tiles
    {0.9f, 0.1f, 11.0f, 1.0f, 0.0f, 1.0f, 1.0f / 0.6f, 0.48f, 0.6f, 0.0f, 0.0f, 1.0f},     // ceiling
    {0.62f, 0.30f, 21.0f, 1.0f, 0.20f, 57.0f, 0.0f, 1.0f, 1.0f, 0.0f, 0.0f, 0.0f},         // cloth
    {0.9f, 0.12f, 35.0f, 1.0f, 0.0f, 1.0f, 0.0f, 1.0f, 1.0f, 0.0f, 0.0f, 0.0f},            // skin
    {0.65f, 0.35f, 1.5f, 8.0f, 0.1f, 40.0f, 0.0f, 1.0f, 1.0f, 0.0f, 0.0f, 0.0f},           // wood
    {1.0f, 0.0f, 1.0f, 1.0f, 0.0f, 1.0f, 0.0f, 1.0f, 1.0f, 0.0f, 1.0f, 0.0f},              // emissive
    {0.8f, 0.25f, 45.0f, 1.0f, 0.0f, 1.0f, 0.0f, 1.0f, 1.0f, 0.0f, 0.0f, 0.0f},            // paint
};

const char* kVertexShader = R"(#version 330 core
layout(location = 0) in vec3 a_pos;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in vec4 i_row0;      // rotation row 0 | translation x
layout(location = 3) in vec4 i_row1;
layout(location = 4) in vec4 i_row2;
layout(location = 5) in vec4 i_size_tex;  // full size xyz | texture kind
layout(location = 6) in vec4 i_colour;
layout(location = 7) in int i_label;
uniform mat4 u_view;   // optical frame from map frame
uniform vec4 u_proj;   // 2fx/W, 2fy/H, 2(cx+0.5)/W-1, 2(cy+0.5)/H-1
uniform float u_near;
uniform vec4 u_tex[27];  // texture parameters, three per kind
out vec3 v_world;
out vec3 v_tex_pos;
out vec3 v_tex_normal;
out vec3 v_normal;
out float v_depth;
flat out vec3 v_colour;
flat out vec4 v_tp0;
flat out vec4 v_tp1;
flat out vec4 v_tp2;
flat out int v_label;
void main() {
  vec3 local = a_pos * i_size_tex.xyz;
  mat3 r = transpose(mat3(i_row0.xyz, i_row1.xyz, i_row2.xyz));
  vec3 world = r * local + vec3(i_row0.w, i_row1.w, i_row2.w);
  vec3 nl = normalize(a_normal / i_size_tex.xyz);
  vec4 o = u_view * vec4(world, 1.0);
  // Reversed depth with an infinite far plane: NDC z = near / z.
  gl_Position = vec4(u_proj.x * o.x + u_proj.z * o.z, u_proj.y * o.y + u_proj.w * o.z, u_near, o.z);
  int k = 3 * int(i_size_tex.w);
  v_tp0 = u_tex[k];
  v_tp1 = u_tex[k + 1];
  v_tp2 = u_tex[k + 2];
  // Static surfaces are textured in the map frame, entities in their own.
  bool anchored = v_tp2.w > 0.5;
  v_world = world;
  v_normal = r * nl;
  v_tex_pos = anchored ? world : local;
  v_tex_normal = anchored ? v_normal : nl;
  v_depth = o.z;
  v_colour = i_colour.rgb;
  v_label = i_label;
}
)";

const char* kFragmentShader = R"(#version 330 core
in vec3 v_world;
in vec3 v_tex_pos;
in vec3 v_tex_normal;
in vec3 v_normal;
in float v_depth;
flat in vec3 v_colour;
flat in vec4 v_tp0;
flat in vec4 v_tp1;
flat in vec4 v_tp2;
flat in int v_label;
layout(location = 0) out vec4 o_colour;
layout(location = 1) out float o_depth;
layout(location = 2) out int o_label;
uniform int u_nlights;
uniform vec4 u_lights[8];  // position | intensity
uniform float u_ambient;

float hash(ivec2 c) {
  uint h = uint(c.x) * 0x8da6b343u ^ uint(c.y) * 0xd8163841u;
  h = (h ^ (h >> 13u)) * 0x5bd1e995u;
  h ^= h >> 15u;
  return float(h & 0xffffu) * (1.0 / 65535.0);
}
float noise(vec2 p) {
  vec2 i = floor(p);
  vec2 f = p - i;
  ivec2 c = ivec2(i);
  vec2 u = f * f * (3.0 - 2.0 * f);
  float a = hash(c), b = hash(c + ivec2(1, 0)), d = hash(c + ivec2(0, 1)), e = hash(c + ivec2(1, 1));
  return mix(mix(a, b, u.x), mix(d, e, u.x), u.y);
}
void main() {
  vec3 an = abs(v_tex_normal);
  vec3 p = v_tex_pos;
  vec2 uv = (an.z >= an.x && an.z >= an.y) ? p.xy : ((an.x >= an.y) ? p.yz : p.xz);
  vec2 q = uv * v_tp1.z;
  vec2 g = abs(fract(q) - 0.5);
  float t = v_tp0.x + v_tp0.y * noise(uv * (v_tp0.z * vec2(1.0, v_tp0.w))) + v_tp1.x * noise(uv * v_tp1.y) +
            v_tp2.y * hash(ivec2(floor(q)));
  t = mix(t, v_tp2.x, step(v_tp1.w, max(g.x, g.y)));
  vec3 nw = normalize(v_normal);
  float light = u_ambient;
  for (int k = 0; k < u_nlights; ++k) {
    vec3 l = u_lights[k].xyz - v_world;
    float d2 = dot(l, l);
    light += u_lights[k].w * max(dot(nw, l), 0.0) * inversesqrt(d2) / (1.0 + 0.12 * d2);
  }
  light = mix(light, 3.0, v_tp2.z);
  // Soft exposure curve: bright surfaces near a light keep their texture.
  o_colour = vec4(1.0 - exp(-1.6 * v_colour * t * light), 1.0);
  o_depth = v_depth;
  o_label = v_label;
}
)";

// ---------------------------------------------------------------- unit meshes

struct Vertex {
  float p[3], n[3];
};

struct Mesh {
  std::vector<Vertex> vertices;
  std::vector<uint32_t> indices;
};

// Unit cube [-0.5, 0.5]^3, 4 vertices per face, counter-clockwise seen from outside.
Mesh make_box() {
  Mesh m;
  const float faces[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  for (const auto& f : faces) {
    const Eigen::Vector3f n(f[0], f[1], f[2]);
    // Two in-face axes u, v with u x v = n.
    const Eigen::Vector3f u = (std::abs(n.z()) > 0.5f) ? Eigen::Vector3f(1, 0, 0) : Eigen::Vector3f(0, 0, 1);
    const Eigen::Vector3f a = u.cross(n).normalized() * -1.0f;  // a x u... chosen so (a, b) is CCW
    const Eigen::Vector3f b = n.cross(a);
    const uint32_t base = static_cast<uint32_t>(m.vertices.size());
    const float corners[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
    for (const auto& c : corners) {
      const Eigen::Vector3f p = 0.5f * (n + c[0] * a + c[1] * b);
      m.vertices.push_back({{p.x(), p.y(), p.z()}, {n.x(), n.y(), n.z()}});
    }
    for (uint32_t i : {0u, 1u, 2u, 0u, 2u, 3u}) m.indices.push_back(base + i);
  }
  return m;
}

// Cylinder of radius 0.5 and height 1 along z, centred, with caps.
Mesh make_cylinder(int segments) {
  Mesh m;
  for (int i = 0; i <= segments; ++i) {
    const float a = 2.0f * static_cast<float>(M_PI) * i / segments;
    const float c = std::cos(a), s = std::sin(a);
    m.vertices.push_back({{0.5f * c, 0.5f * s, -0.5f}, {c, s, 0}});
    m.vertices.push_back({{0.5f * c, 0.5f * s, 0.5f}, {c, s, 0}});
  }
  for (int i = 0; i < segments; ++i) {
    const uint32_t k = 2 * i;
    for (uint32_t j : {k, k + 2, k + 3, k, k + 3, k + 1}) m.indices.push_back(j);
  }
  for (float z : {-0.5f, 0.5f}) {
    const uint32_t centre = static_cast<uint32_t>(m.vertices.size());
    m.vertices.push_back({{0, 0, z}, {0, 0, z * 2}});
    for (int i = 0; i <= segments; ++i) {
      const float a = 2.0f * static_cast<float>(M_PI) * i / segments;
      m.vertices.push_back({{0.5f * std::cos(a), 0.5f * std::sin(a), z}, {0, 0, z * 2}});
    }
    for (int i = 0; i < segments; ++i) {
      const uint32_t a = centre + 1 + i, b = centre + 2 + i;
      if (z > 0) {
        for (uint32_t j : {centre, a, b}) m.indices.push_back(j);
      } else {
        for (uint32_t j : {centre, b, a}) m.indices.push_back(j);
      }
    }
  }
  return m;
}

// Sphere of radius 0.5 (latitude-longitude).
Mesh make_sphere(int slices, int stacks) {
  Mesh m;
  for (int j = 0; j <= stacks; ++j) {
    const float th = static_cast<float>(M_PI) * j / stacks;
    for (int i = 0; i <= slices; ++i) {
      const float ph = 2.0f * static_cast<float>(M_PI) * i / slices;
      const float x = std::sin(th) * std::cos(ph), y = std::sin(th) * std::sin(ph), z = std::cos(th);
      m.vertices.push_back({{0.5f * x, 0.5f * y, 0.5f * z}, {x, y, z}});
    }
  }
  for (int j = 0; j < stacks; ++j) {
    for (int i = 0; i < slices; ++i) {
      const uint32_t a = j * (slices + 1) + i, b = a + slices + 1;
      for (uint32_t k : {a, b, a + 1, a + 1, b, b + 1}) m.indices.push_back(k);
    }
  }
  return m;
}

// Per-instance attributes (see the vertex shader).
struct Instance {
  float row[3][4];
  float size_tex[4];
  float colour[4];
  int32_t label;
  int32_t pad[3];
};
static_assert(sizeof(Instance) == 96);

constexpr size_t kMaxLights = 8;  // per view; the shader's loop is a large part of its cost

Error gl_failure(const std::string& what) { return internal_error("OSMesa renderer: " + what); }

std::string gl_string(GLenum e) {
  const GLubyte* s = glGetString(e);
  return s ? reinterpret_cast<const char*>(s) : "";
}

Result<GLuint> compile(GLenum type, const char* source, const char* name) {
  const GLuint s = glCreateShader(type);
  glShaderSource(s, 1, &source, nullptr);
  glCompileShader(s);
  GLint ok = 0;
  glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    std::array<char, 4096> log{};
    glGetShaderInfoLog(s, static_cast<GLsizei>(log.size()), nullptr, log.data());
    glDeleteShader(s);
    return gl_failure(std::string("the ") + name + " shader does not compile: " + log.data());
  }
  return s;
}

}  // namespace

// ---------------------------------------------------------------- renderer

struct OsmesaRenderer::Impl {
  int width = 0, height = 0;
  RendererOptions options;
  OSMesaContext ctx = nullptr;
  std::array<uint8_t, 4 * 4 * 4> dummy{};  // the OSMesa buffer; views go to framebuffer objects
  GLuint program = 0, vao = 0, vertex_vbo = 0, index_ibo = 0, instance_vbo = 0;
  struct Draw {
    GLsizei count = 0;
    size_t first_index = 0;
    GLint base_vertex = 0;
  };
  std::array<Draw, 3> draws;  // by Shape
  GLuint fbo[2] = {0, 0};
  GLuint tex_colour[2] = {0, 0}, tex_zbuf[2] = {0, 0}, tex_depth = 0, tex_label = 0;
  GLint loc_view = -1, loc_proj = -1, loc_near = -1, loc_nlights = -1, loc_lights = -1, loc_ambient = -1;
  std::vector<Instance> instances;
  cv::Mat bgra[2];

  ~Impl() {
    if (!ctx) return;
    if (OSMesaMakeCurrent(ctx, dummy.data(), GL_UNSIGNED_BYTE, 4, 4)) {
      glDeleteFramebuffers(2, fbo);
      glDeleteTextures(2, tex_colour);
      glDeleteTextures(2, tex_zbuf);
      glDeleteTextures(1, &tex_depth);
      glDeleteTextures(1, &tex_label);
      glDeleteBuffers(1, &vertex_vbo);
      glDeleteBuffers(1, &index_ibo);
      glDeleteBuffers(1, &instance_vbo);
      glDeleteVertexArrays(1, &vao);
      glDeleteProgram(program);
    }
    OSMesaDestroyContext(ctx);
  }

  Status make_current() {
    if (!OSMesaMakeCurrent(ctx, dummy.data(), GL_UNSIGNED_BYTE, 4, 4)) {
      return gl_failure("OSMesaMakeCurrent failed for the renderer's context");
    }
    return Status::Ok();
  }

  Status init();
  Status build_targets();
  void upload_instances(const RenderScene& scene, const Eigen::Vector3d& eye,
                        std::array<std::pair<size_t, size_t>, 3>* ranges);
  std::vector<std::tuple<int, double, size_t>> order;  // shape, squared distance, primitive
  void draw_view(const Eigen::Isometry3d& optical_from_map, const vision::Intrinsics& k, int target,
                 const std::array<std::pair<size_t, size_t>, 3>& ranges, const RenderScene& scene,
                 const Eigen::Vector3d& eye);
};

Status OsmesaRenderer::Impl::init() {
  // Context: a core profile of the requested version, no OSMesa depth buffer (we use our own).
  const int attribs[] = {OSMESA_FORMAT, OSMESA_RGBA,         OSMESA_DEPTH_BITS,           0,
                         OSMESA_STENCIL_BITS, 0,              OSMESA_ACCUM_BITS,           0,
                         OSMESA_PROFILE, OSMESA_CORE_PROFILE, OSMESA_CONTEXT_MAJOR_VERSION, options.gl_major,
                         OSMESA_CONTEXT_MINOR_VERSION, options.gl_minor, 0};
  ctx = OSMesaCreateContextAttribs(attribs, nullptr);
  if (!ctx) {
    return gl_failure("OSMesaCreateContextAttribs could not create an OpenGL " + std::to_string(options.gl_major) +
                      "." + std::to_string(options.gl_minor) +
                      " core-profile context (is Mesa's llvmpipe OSMesa installed: libosmesa6?)");
  }
  if (Status s = make_current(); !s) return s;

  GLint max_tex = 0, max_rb = 0, max_vp[2] = {0, 0};
  glGetIntegerv(GL_MAX_TEXTURE_SIZE, &max_tex);
  glGetIntegerv(GL_MAX_RENDERBUFFER_SIZE, &max_rb);
  glGetIntegerv(GL_MAX_VIEWPORT_DIMS, max_vp);
  const int limit = std::min({max_tex, max_rb, max_vp[0], max_vp[1]});
  if (width < 1 || height < 1 || width > limit || height > limit) {
    return gl_failure("cannot make " + std::to_string(width) + "x" + std::to_string(height) +
                      " render targets: the context (" + gl_string(GL_RENDERER) + ") allows 1 to " +
                      std::to_string(limit) + " pixels per side");
  }

  auto vs = compile(GL_VERTEX_SHADER, kVertexShader, "vertex");
  if (!vs) return vs.error();
  auto fs = compile(GL_FRAGMENT_SHADER, kFragmentShader, "fragment");
  if (!fs) return fs.error();
  program = glCreateProgram();
  glAttachShader(program, *vs);
  glAttachShader(program, *fs);
  glLinkProgram(program);
  glDeleteShader(*vs);
  glDeleteShader(*fs);
  GLint linked = 0;
  glGetProgramiv(program, GL_LINK_STATUS, &linked);
  if (!linked) {
    std::array<char, 4096> log{};
    glGetProgramInfoLog(program, static_cast<GLsizei>(log.size()), nullptr, log.data());
    return gl_failure(std::string("the shader program does not link: ") + log.data());
  }
  loc_view = glGetUniformLocation(program, "u_view");
  loc_proj = glGetUniformLocation(program, "u_proj");
  loc_near = glGetUniformLocation(program, "u_near");
  loc_nlights = glGetUniformLocation(program, "u_nlights");
  loc_lights = glGetUniformLocation(program, "u_lights");
  loc_ambient = glGetUniformLocation(program, "u_ambient");
  glUseProgram(program);
  glUniform4fv(glGetUniformLocation(program, "u_tex"), 27, &kTextureParams[0][0]);

  // Unit meshes in one vertex and one index buffer.
  const std::array<Mesh, 3> meshes = {make_box(), make_cylinder(16), make_sphere(16, 10)};
  std::vector<Vertex> vertices;
  std::vector<uint32_t> indices;
  for (size_t i = 0; i < meshes.size(); ++i) {
    draws[i].base_vertex = static_cast<GLint>(vertices.size());
    draws[i].first_index = indices.size();
    draws[i].count = static_cast<GLsizei>(meshes[i].indices.size());
    vertices.insert(vertices.end(), meshes[i].vertices.begin(), meshes[i].vertices.end());
    indices.insert(indices.end(), meshes[i].indices.begin(), meshes[i].indices.end());
  }
  glGenVertexArrays(1, &vao);
  glBindVertexArray(vao);
  glGenBuffers(1, &vertex_vbo);
  glBindBuffer(GL_ARRAY_BUFFER, vertex_vbo);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(vertices.size() * sizeof(Vertex)), vertices.data(),
               GL_STATIC_DRAW);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, sizeof(Vertex), reinterpret_cast<void*>(offsetof(Vertex, p)));
  glEnableVertexAttribArray(1);
  glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, sizeof(Vertex), reinterpret_cast<void*>(offsetof(Vertex, n)));
  glGenBuffers(1, &index_ibo);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, index_ibo);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(indices.size() * sizeof(uint32_t)), indices.data(),
               GL_STATIC_DRAW);
  glGenBuffers(1, &instance_vbo);
  glBindBuffer(GL_ARRAY_BUFFER, instance_vbo);
  for (int i = 0; i < 5; ++i) {
    glEnableVertexAttribArray(2 + i);
    glVertexAttribPointer(2 + i, 4, GL_FLOAT, GL_FALSE, sizeof(Instance),
                          reinterpret_cast<void*>(offsetof(Instance, row) + 16 * i));
    glVertexAttribDivisor(2 + i, 1);
  }
  glEnableVertexAttribArray(7);
  glVertexAttribIPointer(7, 1, GL_INT, sizeof(Instance), reinterpret_cast<void*>(offsetof(Instance, label)));
  glVertexAttribDivisor(7, 1);

  if (Status s = build_targets(); !s) return s;

  // Reversed depth in [0, 1]: clear to 0, nearer is greater.
  auto clip_control = reinterpret_cast<void (*)(GLenum, GLenum)>(OSMesaGetProcAddress("glClipControl"));
  if (clip_control) clip_control(GL_LOWER_LEFT, GL_ZERO_TO_ONE);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_GREATER);
  glClearDepth(0.0);
  // The projection flips y (row 0 at the top), which turns counter-clockwise faces clockwise.
  glEnable(GL_CULL_FACE);
  glFrontFace(GL_CW);
  glCullFace(GL_BACK);
  glViewport(0, 0, width, height);
  if (const GLenum e = glGetError(); e != GL_NO_ERROR) {
    return gl_failure("OpenGL error " + std::to_string(e) + " while setting up the renderer");
  }
  return Status::Ok();
}

Status OsmesaRenderer::Impl::build_targets() {
  auto make_tex = [&](GLenum internal) {
    GLuint t = 0;
    glGenTextures(1, &t);
    glBindTexture(GL_TEXTURE_2D, t);
    glTexStorage2D(GL_TEXTURE_2D, 1, internal, width, height);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    return t;
  };
  tex_depth = make_tex(GL_R32F);
  tex_label = make_tex(GL_R32I);
  glGenFramebuffers(2, fbo);
  for (int v = 0; v < 2; ++v) {
    tex_colour[v] = make_tex(GL_RGBA8);
    tex_zbuf[v] = make_tex(GL_DEPTH_COMPONENT32F);
    glBindFramebuffer(GL_FRAMEBUFFER, fbo[v]);
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, tex_colour[v], 0);
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, tex_zbuf[v], 0);
    if (v == 0) {
      glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT1, GL_TEXTURE_2D, tex_depth, 0);
      glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT2, GL_TEXTURE_2D, tex_label, 0);
      const GLenum bufs[3] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1, GL_COLOR_ATTACHMENT2};
      glDrawBuffers(3, bufs);
    } else {
      const GLenum bufs[1] = {GL_COLOR_ATTACHMENT0};
      glDrawBuffers(1, bufs);
    }
    const GLenum status = glCheckFramebufferStatus(GL_FRAMEBUFFER);
    if (status != GL_FRAMEBUFFER_COMPLETE) {
      return gl_failure("the " + std::string(v == 0 ? "left" : "right") + " view's framebuffer is incomplete (status " +
                        std::to_string(status) + ") at " + std::to_string(width) + "x" + std::to_string(height));
    }
  }
  if (glGetError() == GL_OUT_OF_MEMORY) {
    return gl_failure("out of memory making " + std::to_string(width) + "x" + std::to_string(height) + " render targets");
  }
  for (auto& m : bgra) m.create(height, width, CV_8UC4);
  return Status::Ok();
}

void OsmesaRenderer::Impl::upload_instances(const RenderScene& scene, const Eigen::Vector3d& eye,
                                            std::array<std::pair<size_t, size_t>, 3>* ranges) {
  // Nearest first (distance from the eye to each primitive's box), so early depth tests spare
  // the shading of hidden surfaces; ties keep the scene's order.
  order.clear();
  for (size_t i = 0; i < scene.primitives.size(); ++i) {
    const Primitive& p = scene.primitives[i];
    const Eigen::Vector3d local = p.pose.inverse(Eigen::Isometry) * eye;
    const Eigen::Vector3d outside = (local.cwiseAbs() - p.size / 2).cwiseMax(0.0);
    order.push_back({static_cast<int>(p.shape), outside.squaredNorm(), i});
  }
  std::sort(order.begin(), order.end());
  instances.clear();
  instances.reserve(scene.primitives.size());
  size_t next = 0;
  for (int shape = 0; shape < 3; ++shape) {
    (*ranges)[shape].first = instances.size();
    for (; next < order.size() && std::get<0>(order[next]) == shape; ++next) {
      const Primitive& p = scene.primitives[std::get<2>(order[next])];
      Instance in{};
      const Eigen::Matrix3d r = p.pose.linear();
      const Eigen::Vector3d t = p.pose.translation();
      for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) in.row[i][j] = static_cast<float>(r(i, j));
        in.row[i][3] = static_cast<float>(t[i]);
        in.size_tex[i] = static_cast<float>(p.size[i]);
        in.colour[i] = p.colour[i];
      }
      in.size_tex[3] = static_cast<float>(static_cast<int>(p.texture));
      in.colour[3] = 1.0f;
      in.label = p.label;
      instances.push_back(in);
    }
    (*ranges)[shape].second = instances.size() - (*ranges)[shape].first;
  }
  glBindBuffer(GL_ARRAY_BUFFER, instance_vbo);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(instances.size() * sizeof(Instance)), instances.data(),
               GL_STREAM_DRAW);
}

void OsmesaRenderer::Impl::draw_view(const Eigen::Isometry3d& optical_from_map, const vision::Intrinsics& k, int target,
                                     const std::array<std::pair<size_t, size_t>, 3>& ranges, const RenderScene& scene,
                                     const Eigen::Vector3d& eye) {
  glBindFramebuffer(GL_FRAMEBUFFER, fbo[target]);
  const GLfloat black[4] = {0, 0, 0, 1};
  glClearBufferfv(GL_COLOR, 0, black);
  if (target == 0) {
    const GLfloat zero[4] = {0, 0, 0, 0};
    const GLint none[4] = {0, 0, 0, 0};
    glClearBufferfv(GL_COLOR, 1, zero);
    glClearBufferiv(GL_COLOR, 2, none);
  }
  glClear(GL_DEPTH_BUFFER_BIT);

  glUseProgram(program);
  Eigen::Matrix4f view = optical_from_map.matrix().cast<float>();
  glUniformMatrix4fv(loc_view, 1, GL_FALSE, view.data());  // Eigen is column-major, as GL expects
  const double w = k.width, h = k.height;
  glUniform4f(loc_proj, static_cast<float>(2 * k.fx / w), static_cast<float>(2 * k.fy / h),
              static_cast<float>(2 * (k.cx + 0.5) / w - 1), static_cast<float>(2 * (k.cy + 0.5) / h - 1));
  glUniform1f(loc_near, static_cast<float>(options.near_clip));
  glUniform1f(loc_ambient, scene.ambient);
  // The lights nearest to a point 3 m in front of the camera (those further away add little).
  const Eigen::Vector3d ahead = eye + optical_from_map.linear().transpose() * Eigen::Vector3d(0, 0, 3.0);
  std::vector<std::pair<double, size_t>> order;
  order.reserve(scene.lights.size());
  for (size_t i = 0; i < scene.lights.size(); ++i) order.emplace_back((scene.lights[i].position - ahead).squaredNorm(), i);
  const size_t n = std::min<size_t>(kMaxLights, order.size());
  std::partial_sort(order.begin(), order.begin() + n, order.end());
  std::array<float, 32> lights{};
  for (size_t i = 0; i < n; ++i) {
    const Light& l = scene.lights[order[i].second];
    for (int j = 0; j < 3; ++j) lights[4 * i + j] = static_cast<float>(l.position[j]);
    lights[4 * i + 3] = l.intensity;
  }
  glUniform1i(loc_nlights, static_cast<GLint>(n));
  glUniform4fv(loc_lights, 8, lights.data());

  glBindVertexArray(vao);
  for (int s = 0; s < 3; ++s) {
    if (ranges[s].second == 0) continue;
    glDrawElementsInstancedBaseVertexBaseInstance(
        GL_TRIANGLES, draws[s].count, GL_UNSIGNED_INT, reinterpret_cast<void*>(draws[s].first_index * sizeof(uint32_t)),
        static_cast<GLsizei>(ranges[s].second), draws[s].base_vertex, static_cast<GLuint>(ranges[s].first));
  }
}

OsmesaRenderer::OsmesaRenderer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
OsmesaRenderer::~OsmesaRenderer() = default;

Result<std::unique_ptr<OsmesaRenderer>> OsmesaRenderer::create(int width, int height, const RendererOptions& options) {
  auto impl = std::make_unique<Impl>();
  impl->width = width;
  impl->height = height;
  impl->options = options;
  if (Status s = impl->init(); !s) return s.error();
  return std::unique_ptr<OsmesaRenderer>(new OsmesaRenderer(std::move(impl)));
}

int OsmesaRenderer::width() const { return impl_->width; }
int OsmesaRenderer::height() const { return impl_->height; }

std::string OsmesaRenderer::gl_renderer() const {
  if (!impl_->make_current()) return "";
  return gl_string(GL_RENDERER);
}

std::string OsmesaRenderer::gl_version() const {
  if (!impl_->make_current()) return "";
  return gl_string(GL_VERSION);
}

Status OsmesaRenderer::render(const RenderScene& scene, const vision::StereoCameraModel& camera,
                              vision::StereoFrame* out) {
  Impl& m = *impl_;
  const vision::Intrinsics& k = camera.intrinsics();
  if (k.width != m.width || k.height != m.height) {
    return gl_failure("camera is " + std::to_string(k.width) + "x" + std::to_string(k.height) + " but the renderer is " +
                      std::to_string(m.width) + "x" + std::to_string(m.height));
  }
  if (Status s = m.make_current(); !s) return s;
  std::array<std::pair<size_t, size_t>, 3> ranges{};
  const Eigen::Vector3d eye = camera.map_from_optical().translation();
  m.upload_instances(scene, eye, &ranges);

  const Eigen::Isometry3d left = camera.optical_from_map();
  Eigen::Isometry3d right = Eigen::Translation3d(-camera.baseline(), 0, 0) * left;
  m.draw_view(left, k, 0, ranges, scene, eye);
  m.draw_view(right, k, 1, ranges, scene, eye);

  // Read back: colour of both views, depth and labels of the left one.
  out->depth.create(m.height, m.width, CV_32F);
  out->labels.create(m.height, m.width, CV_32S);
  glPixelStorei(GL_PACK_ALIGNMENT, 4);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, m.fbo[0]);
  glReadBuffer(GL_COLOR_ATTACHMENT0);
  glReadPixels(0, 0, m.width, m.height, GL_BGRA, GL_UNSIGNED_BYTE, m.bgra[0].data);
  glReadBuffer(GL_COLOR_ATTACHMENT1);
  glReadPixels(0, 0, m.width, m.height, GL_RED, GL_FLOAT, out->depth.data);
  glReadBuffer(GL_COLOR_ATTACHMENT2);
  glReadPixels(0, 0, m.width, m.height, GL_RED_INTEGER, GL_INT, out->labels.data);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, m.fbo[1]);
  glReadBuffer(GL_COLOR_ATTACHMENT0);
  glReadPixels(0, 0, m.width, m.height, GL_BGRA, GL_UNSIGNED_BYTE, m.bgra[1].data);
  if (const GLenum e = glGetError(); e != GL_NO_ERROR) {
    return gl_failure("OpenGL error " + std::to_string(e) + " while rendering or reading back");
  }
  cv::cvtColor(m.bgra[0], out->left, cv::COLOR_BGRA2BGR);
  cv::cvtColor(m.bgra[1], out->right, cv::COLOR_BGRA2BGR);

  // Disparity from depth: d = fx * b / Z where there is depth.
  out->disparity.create(m.height, m.width, CV_32F);
  const float fb = static_cast<float>(k.fx * camera.baseline());
  for (int r = 0; r < m.height; ++r) {
    const float* z = out->depth.ptr<float>(r);
    float* d = out->disparity.ptr<float>(r);
    for (int c = 0; c < m.width; ++c) d[c] = z[c] > 0 ? fb / z[c] : 0.0f;
  }

  // Sensor effects.
  const SensorEffects& fx = m.options.effects;
  for (cv::Mat* img : {&out->left, &out->right}) {
    if (fx.exposure != 1.0) img->convertTo(*img, CV_8UC3, fx.exposure);
    if (fx.blur_sigma > 0) cv::GaussianBlur(*img, *img, cv::Size(0, 0), fx.blur_sigma);
  }
  if (fx.noise_std > 0) {
    cv::RNG rng(fx.seed * 0x9E3779B97F4A7C15ull + static_cast<uint64_t>(out->index) + 1);
    for (cv::Mat* img : {&out->left, &out->right}) {
      cv::Mat noise(img->size(), CV_16SC3);
      rng.fill(noise, cv::RNG::NORMAL, 0, fx.noise_std);
      cv::Mat sum;
      img->convertTo(sum, CV_16SC3);
      sum += noise;
      sum.convertTo(*img, CV_8UC3);
    }
  }
  return Status::Ok();
}

// ---------------------------------------------------------------- helpers

vision::StereoCameraModel camera_model(const CameraSpec& spec) {
  vision::Intrinsics k = vision::Intrinsics::from_hfov(spec.width, spec.height, spec.hfov.value_or(60.0 * M_PI / 180));
  if (spec.fx) {
    k.fx = *spec.fx;
    k.fy = spec.fy.value_or(*spec.fx);
    if (spec.cx) k.cx = *spec.cx;
    if (spec.cy) k.cy = *spec.cy;
  }
  vision::CameraPose pose;
  pose.position = Eigen::Vector3d(spec.position.x, spec.position.y, spec.position.z);
  pose.yaw = spec.yaw;
  pose.pitch = spec.pitch;
  pose.roll = spec.roll;
  return vision::StereoCameraModel(k, spec.baseline, pose);
}

SceneOptions scene_options_for(const World& world, const CameraSpec* camera) {
  SceneOptions o;
  if (camera) o.viewpoint = Eigen::Vector3d(camera->position.x, camera->position.y, camera->position.z);
  const std::string name = world.scenario().map.filename().string();
  if (name.ends_with(".floorplan.yaml")) {
    auto fp = load_floorplan(world.scenario().map);
    if (fp && !fp->walls.empty()) {
      o.wall_height = 0;
      for (const auto& w : fp->walls) o.wall_height = std::max(o.wall_height, w.height);
    }
  }
  return o;
}

Result<RenderBenchResult> bench_render(const World& world, const CameraSpec& camera, int width, int height, int pairs) {
  CameraSpec spec = camera;
  // Keep the field of view when changing the resolution.
  if (spec.fx) {
    const double s = static_cast<double>(width) / spec.width;
    spec.fx = *spec.fx * s;
    if (spec.fy) spec.fy = *spec.fy * s;
    if (spec.cx) spec.cx = (*spec.cx + 0.5) * s - 0.5;
    if (spec.cy) spec.cy = (*spec.cy + 0.5) * static_cast<double>(height) / spec.height - 0.5;
  }
  spec.width = width;
  spec.height = height;
  const vision::StereoCameraModel model = camera_model(spec);
  auto renderer = OsmesaRenderer::create(width, height);
  if (!renderer) return renderer.error();
  const SceneOptions so = scene_options_for(world, &camera);
  vision::StereoFrame frame;
  RenderBenchResult r;
  r.width = width;
  r.height = height;
  r.pairs = pairs;
  r.gl_renderer = (*renderer)->gl_renderer();
  {
    const RenderScene scene = build_render_scene(world, so);
    r.primitives = scene.primitives.size();
    if (Status s = (*renderer)->render(scene, model, &frame); !s) return s.error();
  }
  const auto t0 = std::chrono::steady_clock::now();
  for (int i = 0; i < pairs; ++i) {
    const RenderScene scene = build_render_scene(world, so);
    if (Status s = (*renderer)->render(scene, model, &frame); !s) return s.error();
  }
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.pairs_per_second = r.seconds > 0 ? pairs / r.seconds : 0;
  return r;
}

}  // namespace vigil::render
