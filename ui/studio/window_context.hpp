#pragma once
// Lets the shared VolumeRenderer draw with the studio window's own GL context (one context
// for the whole window: the renderer's FBO, the slice textures and ImGui live together).
#include <string>

#include "vellum/render/gl_context.hpp"

struct GLFWwindow;

namespace vellum::studio {

class WindowContext final : public render::GlContext {
 public:
  /// Adopts (does not own) `window`'s context and makes it current.
  explicit WindowContext(GLFWwindow* window);
  void makeCurrent() override;
  std::string renderer() const override { return renderer_; }
  std::string version() const override { return version_; }
  void swapBuffers() override;

 private:
  GLFWwindow* window_;
  std::string renderer_, version_;
};

}  // namespace vellum::studio
