// Headless (EGL) and windowed (GLFW) OpenGL 4.5 core contexts.
#include "vellum/render/gl_context.hpp"

#define GL_GLEXT_PROTOTYPES
#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <GL/glcorearb.h>
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include "vellum/core/error.hpp"

namespace vellum::render {
namespace {

bool hasExtension(const char* list, const char* name) {
  if (!list) return false;
  const size_t n = std::strlen(name);
  for (const char* p = list; (p = std::strstr(p, name)) != nullptr; p += n)
    if ((p == list || p[-1] == ' ') && (p[n] == ' ' || p[n] == '\0')) return true;
  return false;
}

std::string glString(GLenum name) {
  const auto* s = reinterpret_cast<const char*>(glGetString(name));
  return s ? s : "";
}

std::string eglErrorName(EGLint e) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "EGL error 0x%04X", static_cast<unsigned>(e));
  return buf;
}

// EGL displays are process-wide: the same platform/device gives the same handle to every
// caller, and eglTerminate would kill every context on it. Count users per display.
std::mutex gDisplayMutex;
std::map<EGLDisplay, int> gDisplayUsers;

void retainDisplay(EGLDisplay d) {
  std::lock_guard lock(gDisplayMutex);
  ++gDisplayUsers[d];
}
void releaseDisplay(EGLDisplay d) {
  std::lock_guard lock(gDisplayMutex);
  if (--gDisplayUsers[d] <= 0) {
    gDisplayUsers.erase(d);
    eglTerminate(d);
  }
}

class EglContext final : public GlContext {
 public:
  EglContext(EGLDisplay display, EGLContext context) : display_(display), context_(context) {
    makeCurrent();
    renderer_ = glString(GL_RENDERER);
    version_ = glString(GL_VERSION);
  }
  ~EglContext() override {
    if (eglGetCurrentContext() == context_)
      eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    eglDestroyContext(display_, context_);
    releaseDisplay(display_);
  }
  void makeCurrent() override {
    if (eglGetCurrentContext() == context_) return;
    if (!eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, context_))
      throw Error("eglMakeCurrent failed: " + eglErrorName(eglGetError()));
  }
  std::string renderer() const override { return renderer_; }
  std::string version() const override { return version_; }

 private:
  EGLDisplay display_;
  EGLContext context_;
  std::string renderer_, version_;
};

// Creates a 4.5 (else 4.3) core context on `display` and makes it current without a surface.
// Returns nullptr and appends the reason to `log` when that fails.
std::unique_ptr<GlContext> tryDisplay(EGLDisplay display, const std::string& what,
                                      std::string& log) {
  auto fail = [&](const std::string& why) -> std::unique_ptr<GlContext> {
    log += "\n  " + what + ": " + why;
    return nullptr;
  };
  if (display == EGL_NO_DISPLAY) return fail("no display (" + eglErrorName(eglGetError()) + ")");
  EGLint major = 0, minor = 0;
  if (!eglInitialize(display, &major, &minor))
    return fail("eglInitialize failed (" + eglErrorName(eglGetError()) + ")");
  retainDisplay(display);
  auto failRelease = [&](const std::string& why) {
    releaseDisplay(display);
    return fail(why);
  };
  const char* exts = eglQueryString(display, EGL_EXTENSIONS);
  if (!hasExtension(exts, "EGL_KHR_surfaceless_context"))
    return failRelease("no EGL_KHR_surfaceless_context");
  if (!eglBindAPI(EGL_OPENGL_API)) return failRelease("eglBindAPI(OpenGL) failed");

  EGLConfig config = nullptr;
  EGLint count = 0;
  const EGLint pbufferAttribs[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_SURFACE_TYPE,
                                   EGL_PBUFFER_BIT, EGL_NONE};
  const EGLint anyAttribs[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_NONE};
  if (!eglChooseConfig(display, pbufferAttribs, &config, 1, &count) || count == 0) {
    count = 0;
    if (!eglChooseConfig(display, anyAttribs, &config, 1, &count) || count == 0) {
      if (!hasExtension(exts, "EGL_KHR_no_config_context"))
        return failRelease("no OpenGL-renderable EGL config");
      config = EGL_NO_CONFIG_KHR;
    }
  }
  for (int minorWanted : {5, 3}) {
    const EGLint ctxAttribs[] = {EGL_CONTEXT_MAJOR_VERSION, 4, EGL_CONTEXT_MINOR_VERSION,
                                 minorWanted, EGL_CONTEXT_OPENGL_PROFILE_MASK,
                                 EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT, EGL_NONE};
    EGLContext ctx = eglCreateContext(display, config, EGL_NO_CONTEXT, ctxAttribs);
    if (ctx == EGL_NO_CONTEXT) {
      log += "\n  " + what + ": no 4." + std::to_string(minorWanted) + " core context (" +
             eglErrorName(eglGetError()) + ")";
      continue;
    }
    if (!eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, ctx)) {
      log += "\n  " + what + ": eglMakeCurrent without surface failed (" +
             eglErrorName(eglGetError()) + ")";
      eglDestroyContext(display, ctx);
      continue;
    }
    return std::make_unique<EglContext>(display, ctx);  // owns one display reference
  }
  releaseDisplay(display);
  return nullptr;
}

struct EglDevice {
  EGLDeviceEXT device;
  std::string name;
  bool software;
};

std::vector<EglDevice> listDevices(std::string& log) {
  std::vector<EglDevice> out;
  auto queryDevices =
      reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(eglGetProcAddress("eglQueryDevicesEXT"));
  auto queryString = reinterpret_cast<PFNEGLQUERYDEVICESTRINGEXTPROC>(
      eglGetProcAddress("eglQueryDeviceStringEXT"));
  if (!queryDevices || !queryString) {
    log += "\n  device platform: eglQueryDevicesEXT not available";
    return out;
  }
  EGLint n = 0;
  if (!queryDevices(0, nullptr, &n) || n <= 0) {
    log += "\n  device platform: no EGL devices";
    return out;
  }
  std::vector<EGLDeviceEXT> devices(static_cast<size_t>(n));
  queryDevices(n, devices.data(), &n);
  for (EGLint i = 0; i < n; ++i) {
    const char* exts = queryString(devices[i], EGL_EXTENSIONS);
    const char* drm = hasExtension(exts, "EGL_EXT_device_drm")
                          ? queryString(devices[i], EGL_DRM_DEVICE_FILE_EXT)
                          : nullptr;
    const bool software = hasExtension(exts, "EGL_MESA_device_software");
    out.push_back({devices[i],
                   "EGL device " + std::to_string(i) + (drm ? std::string(" (") + drm + ")" : "") +
                       (software ? " (software)" : ""),
                   software});
  }
  // Hardware devices first.
  std::stable_partition(out.begin(), out.end(), [](const EglDevice& d) { return !d.software; });
  return out;
}

int gGlfwUsers = 0;
std::mutex gGlfwMutex;
std::string gGlfwLastError;

class GlfwContext final : public GlContext {
 public:
  explicit GlfwContext(GLFWwindow* w) : window_(w) {
    makeCurrent();
    renderer_ = glString(GL_RENDERER);
    version_ = glString(GL_VERSION);
  }
  ~GlfwContext() override {
    glfwDestroyWindow(window_);
    std::lock_guard lock(gGlfwMutex);
    if (--gGlfwUsers == 0) glfwTerminate();
  }
  void makeCurrent() override {
    if (glfwGetCurrentContext() != window_) glfwMakeContextCurrent(window_);
  }
  std::string renderer() const override { return renderer_; }
  std::string version() const override { return version_; }
  void swapBuffers() override { glfwSwapBuffers(window_); }

 private:
  GLFWwindow* window_;
  std::string renderer_, version_;
};

}  // namespace

std::unique_ptr<GlContext> GlContext::createHeadless() {
  std::string forced;
  if (const char* env = std::getenv("VELLUM_EGL_PLATFORM"); env && *env) forced = env;
  if (!forced.empty() && forced != "device" && forced != "surfaceless")
    throw Error("VELLUM_EGL_PLATFORM must be 'device' or 'surfaceless' (got '" + forced + "')");
  const char* clientExts = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
  std::string log;

  // 1. Device platform: real GPUs without a display server (the NVIDIA headless route).
  //    Software devices are used only when forced; surfaceless covers llvmpipe otherwise.
  if (forced != "surfaceless") {
    if (hasExtension(clientExts, "EGL_EXT_platform_device")) {
      for (const EglDevice& dev : listDevices(log)) {
        if (dev.software && forced != "device") {
          log += "\n  " + dev.name + ": skipped (software; surfaceless preferred)";
          continue;
        }
        EGLDisplay d = eglGetPlatformDisplay(EGL_PLATFORM_DEVICE_EXT, dev.device, nullptr);
        if (auto ctx = tryDisplay(d, dev.name, log)) return ctx;
      }
    } else {
      log += "\n  device platform: EGL_EXT_platform_device not supported";
    }
  }
  // 2. Mesa's surfaceless platform (llvmpipe, or Mesa's GPU drivers).
  if (forced != "device") {
    if (hasExtension(clientExts, "EGL_MESA_platform_surfaceless")) {
      EGLDisplay d = eglGetPlatformDisplay(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
      if (auto ctx = tryDisplay(d, "surfaceless platform", log)) return ctx;
    } else {
      log += "\n  surfaceless platform: EGL_MESA_platform_surfaceless not supported";
    }
  }
  throw Error("no headless OpenGL 4.5/4.3 core context could be created; tried:" + log);
}

std::unique_ptr<GlContext> GlContext::createWindow(int width, int height, const std::string& title,
                                                   bool visible) {
  std::lock_guard lock(gGlfwMutex);
  if (gGlfwUsers == 0) {
    glfwSetErrorCallback([](int, const char* msg) { gGlfwLastError = msg ? msg : ""; });
    if (!glfwInit()) throw Error("GLFW initialisation failed: " + gGlfwLastError);
  }
  GLFWwindow* window = nullptr;
  for (int minorWanted : {5, 3}) {
    glfwDefaultWindowHints();
    glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 4);
    glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, minorWanted);
    glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
    glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
    glfwWindowHint(GLFW_VISIBLE, visible ? GLFW_TRUE : GLFW_FALSE);
    window = glfwCreateWindow(width, height, title.c_str(), nullptr, nullptr);
    if (window) break;
  }
  if (!window) {
    if (gGlfwUsers == 0) glfwTerminate();
    throw Error("cannot open a GL 4.5/4.3 core window '" + title + "': " + gGlfwLastError);
  }
  ++gGlfwUsers;
  return std::make_unique<GlfwContext>(window);
}

}  // namespace vellum::render
