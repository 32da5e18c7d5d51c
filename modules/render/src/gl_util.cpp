#include "gl_util.hpp"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <vector>

#include "vellum/core/error.hpp"

namespace vellum::render::detail {
namespace {

// The info log of a shader or program (glGetShaderiv/glGetShaderInfoLog or the Program pair).
template <class GetIv, class GetLog>
std::string infoLog(GLuint object, GetIv getIv, GetLog getLog) {
  GLint length = 0;
  getIv(object, GL_INFO_LOG_LENGTH, &length);
  std::vector<char> log(static_cast<size_t>(std::max(length, 1)), '\0');
  getLog(object, length, nullptr, log.data());
  return log.data();
}

GLuint compile(GLenum type, const std::string& source) {
  const GLuint shader = glCreateShader(type);
  const char* text = source.c_str();
  glShaderSource(shader, 1, &text, nullptr);
  glCompileShader(shader);
  GLint ok = GL_FALSE;
  glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
  if (ok != GL_TRUE) {
    const std::string log = infoLog(shader, glGetShaderiv, glGetShaderInfoLog);
    glDeleteShader(shader);
    throw Error(std::string("GLSL ") + (type == GL_VERTEX_SHADER ? "vertex" : "fragment") +
                " shader failed to compile: " + log);
  }
  return shader;
}

}  // namespace

GLuint buildProgram(const std::string& vertexSource, const std::string& fragmentSource) {
  const GLuint vs = compile(GL_VERTEX_SHADER, vertexSource);
  GLuint fs = 0;
  try {
    fs = compile(GL_FRAGMENT_SHADER, fragmentSource);
  } catch (...) {
    glDeleteShader(vs);
    throw;
  }
  const GLuint program = glCreateProgram();
  glAttachShader(program, vs);
  glAttachShader(program, fs);
  glLinkProgram(program);
  glDeleteShader(vs);
  glDeleteShader(fs);
  GLint ok = GL_FALSE;
  glGetProgramiv(program, GL_LINK_STATUS, &ok);
  if (ok != GL_TRUE) {
    const std::string log = infoLog(program, glGetProgramiv, glGetProgramInfoLog);
    glDeleteProgram(program);
    throw Error("GLSL program failed to link: " + log);
  }
  return program;
}

void checkGlError(const char* what) {
  const GLenum e = glGetError();
  if (e != GL_NO_ERROR) {
    char buf[16];
    std::snprintf(buf, sizeof buf, "0x%04X", e);
    throw Error(std::string("OpenGL error ") + buf + " in " + what);
  }
}

void readRgbaRows(GLuint framebuffer, int rowBegin, int rowEnd, RgbaImage& image, const char* what) {
  const int rows = rowEnd - rowBegin;
  if (rows <= 0) return;
  const size_t stride = static_cast<size_t>(image.width) * 4;
  std::vector<uint8_t> pixels(stride * static_cast<size_t>(rows));
  glBindFramebuffer(GL_READ_FRAMEBUFFER, framebuffer);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(0, image.height - rowEnd, image.width, rows, GL_RGBA, GL_UNSIGNED_BYTE, pixels.data());
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  checkGlError(what);
  for (int y = rowBegin; y < rowEnd; ++y)
    std::memcpy(image.at(0, y), pixels.data() + static_cast<size_t>(rowEnd - 1 - y) * stride, stride);
}

OffscreenTarget::~OffscreenTarget() {
  if (fbo_) glDeleteFramebuffers(1, &fbo_);
  if (colour_) glDeleteRenderbuffers(1, &colour_);
}

void OffscreenTarget::bind(int w, int h, const char* who) {
  if (!fbo_ || width_ != w || height_ != h) {
    if (!fbo_) glGenFramebuffers(1, &fbo_);
    if (colour_) glDeleteRenderbuffers(1, &colour_);
    glGenRenderbuffers(1, &colour_);
    glBindRenderbuffer(GL_RENDERBUFFER, colour_);
    glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, w, h);
    glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, colour_);
    if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
      throw Error(std::string(who) + ": framebuffer of " + std::to_string(w) + "x" + std::to_string(h) + " is incomplete");
    width_ = w;
    height_ = h;
  }
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
}

GpuTimer::~GpuTimer() {
  if (queries_[0]) glDeleteQueries(kQueries, queries_);
}

void GpuTimer::collect() {
  // Oldest first, so lastMs_ ends at the newest finished span.
  for (int i = 0; i < kQueries; ++i) {
    const int q = (next_ + i) % kQueries;
    if (!pending_[q]) continue;
    GLint available = 0;
    glGetQueryObjectiv(queries_[q], GL_QUERY_RESULT_AVAILABLE, &available);
    if (!available) continue;
    GLuint64 ns = 0;
    glGetQueryObjectui64v(queries_[q], GL_QUERY_RESULT, &ns);
    lastMs_ = double(ns) * 1e-6;
    pending_[q] = false;
  }
}

void GpuTimer::begin() {
  if (!queries_[0]) glGenQueries(kQueries, queries_);
  collect();
  if (pending_[next_]) {  // every query still in flight: wait for the oldest
    GLuint64 ns = 0;
    glGetQueryObjectui64v(queries_[next_], GL_QUERY_RESULT, &ns);
    pending_[next_] = false;
  }
  glBeginQuery(GL_TIME_ELAPSED, queries_[next_]);
}

void GpuTimer::end() {
  glEndQuery(GL_TIME_ELAPSED);
  pending_[next_] = true;
  next_ = (next_ + 1) % kQueries;
}

double GpuTimer::lastMs() {
  if (queries_[0]) collect();
  return lastMs_;
}

}  // namespace vellum::render::detail
