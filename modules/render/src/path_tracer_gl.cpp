#include "path_tracer_gl.hpp"

#include <algorithm>
#include <chrono>
#include <string>

#include "vellum/core/error.hpp"

namespace vellum::render::detail {

AccumulationTarget::~AccumulationTarget() {
  if (fbo_) glDeleteFramebuffers(1, &fbo_);
  if (colour_) glDeleteTextures(1, &colour_);
}

void AccumulationTarget::bindCleared(int w, int h) {
  if (!fbo_ || width_ != w || height_ != h) {
    if (!fbo_) glGenFramebuffers(1, &fbo_);
    if (colour_) glDeleteTextures(1, &colour_);
    glGenTextures(1, &colour_);
    glBindTexture(GL_TEXTURE_2D, colour_);
    glTexStorage2D(GL_TEXTURE_2D, 1, GL_RGBA32F, w, h);
    glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, colour_, 0);
    if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
      throw Error("cinematic: float framebuffer of " + std::to_string(w) + "x" + std::to_string(h) + " is incomplete");
    width_ = w;
    height_ = h;
  }
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
  const float zero[4] = {0, 0, 0, 0};
  glClearBufferfv(GL_COLOR, 0, zero);
}

void AccumulationTarget::bind() const {
  if (!fbo_) throw Error("cinematic: the accumulation target was never cleared");
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
}

PathSums AccumulationTarget::read(int samples) const {
  PathSums s;
  s.width = width_;
  s.height = height_;
  s.samples = samples;
  std::vector<float> gl(size_t(width_) * size_t(height_) * 4);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
  glPixelStorei(GL_PACK_ALIGNMENT, 4);
  glReadPixels(0, 0, width_, height_, GL_RGBA, GL_FLOAT, gl.data());
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  checkGlError("cinematic read-back");
  s.rgba.resize(gl.size());
  const size_t row = size_t(width_) * 4;
  for (int y = 0; y < height_; ++y)  // GL row 0 is the bottom
    std::copy_n(gl.data() + size_t(height_ - 1 - y) * row, row, s.rgba.data() + size_t(y) * row);
  return s;
}

void setSceneLightUniforms(GLuint p, const SceneLights& l) {
  auto vec = [&](const char* name, const Vec3& v) {
    glUniform3f(glGetUniformLocation(p, name), float(v.x), float(v.y), float(v.z));
  };
  vec("uKeyDir", l.key);
  vec("uFillDir", l.fill);
  vec("uSkyUp", l.up);
  glUniform1f(glGetUniformLocation(p, "uKeyCos"), l.keyCos);
  glUniform1f(glGetUniformLocation(p, "uKeyE"), l.keyE);
  glUniform1f(glGetUniformLocation(p, "uFillE"), l.fillE);
  glUniform1f(glGetUniformLocation(p, "uSky"), l.sky);
}

void setPathTraceUniforms(GLuint p, const PathLights& l, int seed) {
  setSceneLightUniforms(p, l);
  glUniform1f(glGetUniformLocation(p, "uPickKey"), l.pickKey);
  glUniform1i(glGetUniformLocation(p, "uBounces"), l.bounces);
  glUniform1f(glGetUniformLocation(p, "uSurfaceOffset"), l.surfaceOffsetMm);
  glUniform1ui(glGetUniformLocation(p, "uSeed"), uint32_t(seed));
}

int runSamplePasses(const Cinematic& c, const std::function<void(int first, int count)>& drawPass) {
  const auto t0 = std::chrono::steady_clock::now();
  double last = 0;  // seconds at the end of the previous pass
  int done = 0;
  while (done < c.samples) {
    const int n = std::min(kSamplesPerPass, c.samples - done);
    drawPass(done, n);
    done += n;
    if (c.timeLimitS > 0) {
      glFinish();  // the pass's real cost (llvmpipe and GPUs queue draws)
      const double now = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      // No pass that would end past the limit, predicted from this one (a limit is a limit:
      // `vellum render --time-limit` bounds the whole command).
      if (now + (now - last) > c.timeLimitS) break;
      last = now;
    }
  }
  return done;
}

}  // namespace vellum::render::detail
