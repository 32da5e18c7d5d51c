#pragma once
// An OpenGL 4.5 core context: headless (EGL; no display needed) or a GLFW window.
// GL headers are not included here, so that users of the renderer stay GL-free.
#include <memory>
#include <string>

namespace vellum::render {

class GlContext {
 public:
  virtual ~GlContext() = default;
  virtual void makeCurrent() = 0;
  /// "llvmpipe (LLVM 15.0.6, 256 bits)" or the GPU's name.
  virtual std::string renderer() const = 0;
  /// "4.5 (Core Profile) Mesa 22.3.6".
  virtual std::string version() const = 0;
  /// Window contexts only: present the back buffer. No-op headless.
  virtual void swapBuffers() {}

  /// Headless context: tries the EGL device platform (real GPUs, no X), then Mesa's
  /// surfaceless platform (llvmpipe). Requests 4.5 core, falls back to 4.3 (compute).
  /// Throws vellum::Error with what was tried when none works.
  static std::unique_ptr<GlContext> createHeadless();
  /// A GLFW window (needs a display, e.g. Xvfb). `visible` false gives a hidden window.
  static std::unique_ptr<GlContext> createWindow(int width, int height, const std::string& title,
                                                 bool visible = true);
};

}  // namespace vellum::render
