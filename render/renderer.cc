#include "render/renderer.h"

#include <GLFW/glfw3.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <utility>

#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#include <sanitizer/lsan_interface.h>
#define RAGDOLL_LEAK_CHECKED 1
#endif
#endif

namespace ragdoll::render {
namespace {

// Making an OpenGL context leaves a few hundred bytes that LeakSanitizer reports at exit from
// frames it cannot name (`<unknown module>`: the GL driver, loaded by GLX, is gone by then).
// While this is alive, what this thread allocates is the driver's, not ours to check; memory
// errors are still caught. A no-op unless built with AddressSanitizer.
class DriverAllocations {
 public:
#ifdef RAGDOLL_LEAK_CHECKED
  DriverAllocations() { __lsan_disable(); }
  ~DriverAllocations() { __lsan_enable(); }
#else
  DriverAllocations() {}
#endif
  DriverAllocations(const DriverAllocations&) = delete;
  DriverAllocations& operator=(const DriverAllocations&) = delete;
};

}  // namespace

Renderer::Renderer(const mjModel* model, const View& view) : view_(view) { Open(model, nullptr); }

Renderer::Renderer(const mjModel* model, const View& view, const std::string& title,
                   KeyCallback on_key)
    : view_(view), visible_(true), on_key_(std::move(on_key)) {
  Open(model, title.c_str());
}

void Renderer::Open(const mjModel* model, const char* title) {
  const DriverAllocations driver;
  const View& view = view_;
  if (!glfwInit()) {
    throw std::runtime_error("cannot initialise GLFW: no X display? (run under xvfb-run)");
  }
  glfwWindowHint(GLFW_VISIBLE, visible_ ? GLFW_TRUE : GLFW_FALSE);
  glfwWindowHint(GLFW_DOUBLEBUFFER, visible_ ? GLFW_TRUE : GLFW_FALSE);
  window_ = visible_ ? glfwCreateWindow(view.width, view.height, title, nullptr, nullptr)
                     : glfwCreateWindow(64, 64, "ragdoll", nullptr, nullptr);
  if (!window_) {
    glfwTerminate();
    throw std::runtime_error("cannot create an OpenGL context (is the display's GLX working?)");
  }
  glfwMakeContextCurrent(window_);
  if (visible_) {
    // The caller paces frames to the simulation; waiting for vertical sync would stall it.
    glfwSwapInterval(0);
    // Mesa's software OpenGL (Xvfb, no GPU) spends two thirds of a frame on shadows and the
    // floor's reflection (960x540: 83 ms a frame with them, 28 ms without): drop them there.
    using GetString = const GLubyte* (*)(GLenum);
    auto get_string = reinterpret_cast<GetString>(glfwGetProcAddress("glGetString"));
    const GLubyte* gl_renderer = get_string ? get_string(GL_RENDERER) : nullptr;
    software_ =
        gl_renderer && (std::strstr(reinterpret_cast<const char*>(gl_renderer), "llvmpipe") ||
                        std::strstr(reinterpret_cast<const char*>(gl_renderer), "softpipe"));
    glfwSetWindowUserPointer(window_, this);
    glfwSetKeyCallback(window_, [](GLFWwindow* w, int key, int, int action, int) {
      auto* self = static_cast<Renderer*>(glfwGetWindowUserPointer(w));
      if (action != GLFW_REPEAT && self->on_key_) self->on_key_(key, action == GLFW_PRESS);
    });
  }

  model_ = mj_copyModel(nullptr, model);
  model_->vis.global.offwidth = view.width;
  model_->vis.global.offheight = view.height;
  model_->vis.quality.shadowsize = 2048;
  model_->vis.quality.offsamples = 4;
  // A brighter headlight than MuJoCo's default: the sun alone leaves the near side dark.
  for (int i = 0; i < 3; ++i) {
    model_->vis.headlight.ambient[i] = 0.35f;
    model_->vis.headlight.diffuse[i] = 0.55f;
  }
  scratch_ = mj_makeData(model_);

  mjv_defaultCamera(&camera_);
  mjv_defaultOption(&option_);
  mjv_defaultPerturb(&perturb_);
  mjv_defaultScene(&scene_);
  mjr_defaultContext(&context_);
  mjv_makeScene(model_, &scene_, 2000);
  if (software_) {
    scene_.flags[mjRND_SHADOW] = 0;
    scene_.flags[mjRND_REFLECTION] = 0;
  }
  mjr_makeContext(model_, &context_, mjFONTSCALE_150);
  mjr_setBuffer(visible_ ? mjFB_WINDOW : mjFB_OFFSCREEN, &context_);
  if (!visible_ && context_.currentBuffer != mjFB_OFFSCREEN) {
    throw std::runtime_error("the OpenGL context has no offscreen buffer");
  }
  // A free camera re-aimed at the character every frame (MuJoCo's tracking camera smooths its
  // motion, so a single frame or the first frames would lag behind).
  camera_.type = mjCAMERA_FREE;
  camera_.distance = view.distance;
  camera_.azimuth = view.azimuth;
  camera_.elevation = view.elevation;
  if (!visible_) pixels_.resize(static_cast<size_t>(view.width) * view.height * 3);
}

Renderer::~Renderer() {
  mjr_freeContext(&context_);
  mjv_freeScene(&scene_);
  if (scratch_) mj_deleteData(scratch_);
  if (model_) mj_deleteModel(model_);
  if (window_) glfwDestroyWindow(window_);
  glfwTerminate();
}

void Renderer::Draw(const mjData& simulated, const mjData* reference, const std::string& caption,
                    const std::string& footer) {
  // mjv_updateScene needs a mutable mjData: draw from a copy.
  mj_copyData(scratch_, model_, &simulated);
  mj_comPos(model_, scratch_);
  for (int i = 0; i < 3; ++i) camera_.lookat[i] = scratch_->subtree_com[3 * 1 + i];  // the root's
  camera_.lookat[1] += view_.ghost_offset / 2;  // between the character and a ghost beside it
  mjv_updateScene(model_, scratch_, &option_, &perturb_, &camera_, mjCAT_ALL, &scene_);
  first_ghost_geom_ = scene_.ngeom;
  if (reference) {
    mj_copyData(scratch_, model_, reference);
    if (view_.ghost_offset != 0) {
      scratch_->qpos[1] += view_.ghost_offset;  // the root's y
      mj_kinematics(model_, scratch_);
    }
    mjv_addGeoms(model_, scratch_, &option_, &perturb_, mjCAT_DYNAMIC, &scene_);
    for (int g = first_ghost_geom_; g < scene_.ngeom; ++g) {
      mjvGeom& geom = scene_.geoms[g];
      geom.rgba[0] = 0.45f;
      geom.rgba[1] = 0.75f;
      geom.rgba[2] = 1.0f;
      geom.rgba[3] = view_.ghost_alpha;
      geom.shininess = 0;
      geom.specular = 0;
    }
  }
  mjrRect viewport = {0, 0, view_.width, view_.height};
  if (visible_) glfwGetFramebufferSize(window_, &viewport.width, &viewport.height);
  mjr_render(viewport, &scene_, &context_);
  if (!caption.empty()) {
    mjr_overlay(mjFONT_NORMAL, mjGRID_TOPLEFT, viewport, caption.c_str(), nullptr, &context_);
  }
  if (!footer.empty()) {
    mjr_overlay(mjFONT_NORMAL, mjGRID_BOTTOMLEFT, viewport, footer.c_str(), nullptr, &context_);
  }
  if (visible_) {
    glfwSwapBuffers(window_);
  } else {
    ReadPixels();
  }
}

bool Renderer::PollEvents() {
  glfwPollEvents();
  return !glfwWindowShouldClose(window_);
}

void Renderer::ReadPixels() {
  mjrRect viewport = {0, 0, view_.width, view_.height};
  std::vector<unsigned char> bottom_up(pixels_.size());
  mjr_readPixels(bottom_up.data(), nullptr, viewport, &context_);
  const size_t row = static_cast<size_t>(view_.width) * 3;
  for (int y = 0; y < view_.height; ++y) {
    std::memcpy(pixels_.data() + y * row, bottom_up.data() + (view_.height - 1 - y) * row, row);
  }
}

int Renderer::GeomAt(int x, int y) {
  if (x < 0 || y < 0 || x >= view_.width || y >= view_.height) return -1;
  // Draw the same scene with each scene geom in its own flat colour (segment id + 1).
  scene_.flags[mjRND_SEGMENT] = 1;
  scene_.flags[mjRND_IDCOLOR] = 1;
  mjrRect viewport = {0, 0, view_.width, view_.height};
  mjr_render(viewport, &scene_, &context_);
  std::vector<unsigned char> ids(pixels_.size());
  mjr_readPixels(ids.data(), nullptr, viewport, &context_);
  scene_.flags[mjRND_SEGMENT] = 0;
  scene_.flags[mjRND_IDCOLOR] = 0;
  const unsigned char* p =
      ids.data() + (static_cast<size_t>(view_.height - 1 - y) * view_.width + x) * 3;
  const int segment = p[0] + p[1] * 256 + p[2] * 65536 - 1;
  if (segment < 0 || segment >= first_ghost_geom_) return -1;
  const mjvGeom& geom = scene_.geoms[segment];
  return geom.objtype == mjOBJ_GEOM ? geom.objid : -1;
}

bool Renderer::Project(const double point[3], double* x, double* y) const {
  // Both eyes of the (mono) scene camera are the same; use the first.
  const mjvGLCamera& c = scene_.camera[0];
  const double d[3] = {point[0] - c.pos[0], point[1] - c.pos[1], point[2] - c.pos[2]};
  const double f[3] = {c.forward[0], c.forward[1], c.forward[2]};
  const double u[3] = {c.up[0], c.up[1], c.up[2]};
  const double r[3] = {f[1] * u[2] - f[2] * u[1], f[2] * u[0] - f[0] * u[2],
                       f[0] * u[1] - f[1] * u[0]};
  const double depth = d[0] * f[0] + d[1] * f[1] + d[2] * f[2];
  if (depth <= c.frustum_near) return false;
  const double xn = (d[0] * r[0] + d[1] * r[1] + d[2] * r[2]) * c.frustum_near / depth;
  const double yn = (d[0] * u[0] + d[1] * u[1] + d[2] * u[2]) * c.frustum_near / depth;
  const double height = c.frustum_top - c.frustum_bottom;
  const double width = height * view_.width / view_.height;
  const double left = c.frustum_center - width / 2;
  *x = (xn - left) / width * view_.width;
  *y = view_.height - (yn - c.frustum_bottom) / height * view_.height;
  return true;
}

}  // namespace ragdoll::render
