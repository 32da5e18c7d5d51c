#include "window_context.hpp"

#include <GL/glcorearb.h>
#include <GLFW/glfw3.h>

namespace vellum::studio {
namespace {
std::string glString(GLenum name) {
  const auto* s = reinterpret_cast<const char*>(glGetString(name));
  return s ? s : "";
}
}  // namespace

WindowContext::WindowContext(GLFWwindow* window) : window_(window) {
  makeCurrent();
  renderer_ = glString(GL_RENDERER);
  version_ = glString(GL_VERSION);
}

void WindowContext::makeCurrent() {
  if (glfwGetCurrentContext() != window_) glfwMakeContextCurrent(window_);
}

void WindowContext::swapBuffers() { glfwSwapBuffers(window_); }

}  // namespace vellum::studio
