// Drawing the character with MuJoCo's renderer into an offscreen buffer (or a visible window):
// the simulated state, the reference pose as a translucent ghost (overlaid or beside it), a
// tracking camera and a caption. Needs an X display with OpenGL (`ragdoll render` starts Xvfb
// when there is none).
#pragma once

#include <mujoco/mujoco.h>

#include <functional>
#include <string>
#include <vector>

struct GLFWwindow;

namespace ragdoll::render {

struct View {
  int width = 960;
  int height = 540;
  double distance = 4.0;    // camera distance from the tracked body, metres
  double azimuth = 120;     // degrees; 90 looks along +y (the character's left side)
  double elevation = -12;   // degrees
  double ghost_offset = 0;  // metres along +y between character and reference; 0 overlays
  float ghost_alpha = 0.35f;
};

class Renderer {
 public:
  // Throws std::runtime_error when no OpenGL context can be made (no display).
  Renderer(const mjModel* model, const View& view);
  // A visible window titled `title` (`ragdoll play`), of the view's size and resizable, drawn
  // into instead of the offscreen buffer: Draw shows each frame and pixels() stays empty. Keys
  // pressed and released in it reach `on_key` (a GLFW_KEY_* code, true when pressed; no
  // repeats) from PollEvents. With software OpenGL (Mesa's llvmpipe) it draws without shadows
  // and reflections, to keep up with real time.
  using KeyCallback = std::function<void(int key, bool pressed)>;
  Renderer(const mjModel* model, const View& view, const std::string& title, KeyCallback on_key);
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  // Draws `simulated` (tracked by the camera) and, when given, `reference` as a ghost, with the
  // caption's lines in the top-left corner and the footer's in the bottom-left one.
  void Draw(const mjData& simulated, const mjData* reference, const std::string& caption,
            const std::string& footer = "");
  // Window only: handles the window's pending events (keys); false once it was asked to close.
  bool PollEvents();
  // The last drawn frame as RGB bytes, top row first (width * height * 3).
  const std::vector<unsigned char>& pixels() const { return pixels_; }
  // The model geom drawn at pixel (x, y) of the last frame (top-left origin), -1 for none (sky)
  // or a ghost geom. Draws the segmentation of the last scene again to find out.
  int GeomAt(int x, int y);
  // Where a world point appears in the last frame (top-left origin); false if behind the camera.
  bool Project(const double point[3], double* x, double* y) const;
  const View& view() const { return view_; }

 private:
  void Open(const mjModel* model, const char* title);
  void ReadPixels();

  View view_;
  bool visible_ = false;
  bool software_ = false;  // a window on software OpenGL: no shadows, no reflections
  KeyCallback on_key_;
  mjModel* model_ = nullptr;   // a copy, with an offscreen buffer of the view's size
  mjData* scratch_ = nullptr;  // the reference state, drawn as the ghost
  mjvScene scene_;
  mjvCamera camera_;
  mjvOption option_;
  mjvPerturb perturb_;
  mjrContext context_;
  GLFWwindow* window_ = nullptr;
  int first_ghost_geom_ = 0;  // scene geoms from here on are the ghost's
  std::vector<unsigned char> pixels_;
};

}  // namespace ragdoll::render
