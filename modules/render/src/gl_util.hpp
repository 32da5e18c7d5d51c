#pragma once
// Small OpenGL helpers for the renderer (include only from .cpp files of modules/render).
#define GL_GLEXT_PROTOTYPES
#include <GL/glcorearb.h>

#include <string>

#include "vellum/core/image.hpp"

namespace vellum::render::detail {

/// Compiles and links a program; throws vellum::Error with the info log on failure.
GLuint buildProgram(const std::string& vertexSource, const std::string& fragmentSource);

/// Throws vellum::Error naming `what` if glGetError() reports an error.
void checkGlError(const char* what);

/// Reads rows [rowBegin, rowEnd) (row 0 = top) of `framebuffer`'s RGBA8 colour, whose height
/// is image.height, into the same rows of `image` (GL's row 0 is the bottom: flipped). Leaves
/// the default framebuffer bound; throws vellum::Error naming `what` on a GL error.
void readRgbaRows(GLuint framebuffer, int rowBegin, int rowEnd, RgbaImage& image, const char* what);

/// An RGBA8 framebuffer for offscreen rendering, re-made only when its size changes. Needs a
/// current context; destroy it while that context is still current.
class OffscreenTarget {
 public:
  OffscreenTarget() = default;
  ~OffscreenTarget();
  OffscreenTarget(const OffscreenTarget&) = delete;
  OffscreenTarget& operator=(const OffscreenTarget&) = delete;
  /// Makes it w x h (if needed) and binds it; throws vellum::Error naming `who` if incomplete.
  void bind(int w, int h, const char* who);
  GLuint framebuffer() const { return fbo_; }

 private:
  GLuint fbo_ = 0, colour_ = 0;
  int width_ = 0, height_ = 0;
};

/// GPU time of a span of GL commands by GL_TIME_ELAPSED queries, read without stalling: each
/// begin() first collects the previous span's result if the GPU has finished it. A ring of
/// queries so that a pending one is never restarted. Destroy with the context current.
class GpuTimer {
 public:
  GpuTimer() = default;
  ~GpuTimer();
  GpuTimer(const GpuTimer&) = delete;
  GpuTimer& operator=(const GpuTimer&) = delete;
  void begin();
  void end();
  /// Milliseconds of the latest finished span (0 before any).
  double lastMs();

 private:
  static constexpr int kQueries = 4;
  GLuint queries_[kQueries] = {};
  bool pending_[kQueries] = {};
  int next_ = 0;
  double lastMs_ = 0;
  void collect();
};

}  // namespace vellum::render::detail
