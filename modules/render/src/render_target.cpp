// Colour + opaque-depth framebuffers for drawing into a caller's viewport.
#include "vellum/render/render_target.hpp"

#include <cstring>
#include <limits>

#include "gl_util.hpp"
#include "render_common.hpp"
#include "vellum/core/error.hpp"

namespace vellum::render {

using namespace detail;

FramebufferTarget::FramebufferTarget(GlContext& context) : context_(context) {}

FramebufferTarget::~FramebufferTarget() {
  if (!opaqueFbo_) return;
  context_.makeCurrent();
  for (GLuint f : {opaqueFbo_, volumeFbo_})
    if (f) glDeleteFramebuffers(1, &f);
  for (GLuint t : {colour_, depth_})
    if (t) glDeleteTextures(1, &t);
}

namespace {

GLuint makeTexture(GLenum internal, int w, int h, GLint filter) {
  GLuint t = 0;
  glGenTextures(1, &t);
  glBindTexture(GL_TEXTURE_2D, t);
  glTexStorage2D(GL_TEXTURE_2D, 1, internal, w, h);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, filter);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, filter);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  return t;
}

void checkComplete(int w, int h) {
  if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
    throw Error("framebuffer target of " + std::to_string(w) + "x" + std::to_string(h) + " is incomplete");
}

}  // namespace

void FramebufferTarget::resize(int width, int height) {
  checkImageSize(width, height);
  context_.makeCurrent();
  if (width == width_ && height == height_ && colour_) return;
  for (GLuint* t : {&colour_, &depth_})
    if (*t) glDeleteTextures(1, t), *t = 0;
  if (!opaqueFbo_) glGenFramebuffers(1, &opaqueFbo_);
  if (!volumeFbo_) glGenFramebuffers(1, &volumeFbo_);
  // Linear colour: a coarse frame is stretched over the pane while the user drags.
  colour_ = makeTexture(GL_RGBA8, width, height, GL_LINEAR);
  depth_ = makeTexture(GL_DEPTH_COMPONENT32F, width, height, GL_NEAREST);
  glBindFramebuffer(GL_FRAMEBUFFER, opaqueFbo_);
  glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, colour_, 0);
  glFramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, depth_, 0);
  checkComplete(width, height);
  glBindFramebuffer(GL_FRAMEBUFFER, volumeFbo_);
  glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, colour_, 0);
  checkComplete(width, height);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  width_ = width;
  height_ = height;
  checkGlError("framebuffer target");
}

void FramebufferTarget::clear(const std::array<float, 4>& rgba) {
  if (!opaqueFbo_) throw Error("framebuffer target: resize() it first");
  context_.makeCurrent();
  glBindFramebuffer(GL_FRAMEBUFFER, opaqueFbo_);
  glDisable(GL_SCISSOR_TEST);
  glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
  glDepthMask(GL_TRUE);
  glClearColor(rgba[0], rgba[1], rgba[2], rgba[3]);
  glClearDepth(1.0);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
}

RenderTarget FramebufferTarget::volumeTarget(bool withDepth) const {
  return {volumeFbo_, width_, height_, withDepth ? depth_ : 0u};
}

void FramebufferTarget::copyColourRows(const FramebufferTarget& from, int rowBegin, int rowEnd) {
  if (!colour_ || from.width_ != width_ || from.height_ != height_)
    throw Error("copyColourRows: the targets must have the same (non-zero) size");
  context_.makeCurrent();
  const int y0 = height_ - rowEnd, y1 = height_ - rowBegin;  // GL rows count from the bottom
  glBindFramebuffer(GL_READ_FRAMEBUFFER, from.volumeFbo_);
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, volumeFbo_);
  glDisable(GL_SCISSOR_TEST);
  glBlitFramebuffer(0, y0, width_, y1, 0, y0, width_, y1, GL_COLOR_BUFFER_BIT, GL_NEAREST);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
}

void FramebufferTarget::copyColourScaled(const FramebufferTarget& from) {
  if (!from.colour_ || !colour_) throw Error("copyColourScaled: resize() both targets first");
  context_.makeCurrent();
  glBindFramebuffer(GL_READ_FRAMEBUFFER, from.volumeFbo_);
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, volumeFbo_);
  glDisable(GL_SCISSOR_TEST);
  glBlitFramebuffer(0, 0, from.width_, from.height_, 0, 0, width_, height_, GL_COLOR_BUFFER_BIT, GL_LINEAR);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
}

RgbaImage FramebufferTarget::readColour() const {
  if (!colour_) return {};
  RgbaImage image(width_, height_);
  context_.makeCurrent();
  readRgbaRows(volumeFbo_, 0, height_, image, "framebuffer target colour read-back");
  return image;
}

std::vector<float> FramebufferTarget::readRayDistanceMm() const {
  if (!depth_) return {};
  const size_t w = static_cast<size_t>(width_), h = static_cast<size_t>(height_);
  std::vector<float> depth(w * h), out(w * h);
  context_.makeCurrent();
  glBindFramebuffer(GL_READ_FRAMEBUFFER, opaqueFbo_);
  glPixelStorei(GL_PACK_ALIGNMENT, 4);
  glReadPixels(0, 0, width_, height_, GL_DEPTH_COMPONENT, GL_FLOAT, depth.data());
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  checkGlError("framebuffer target depth read-back");
  for (size_t y = 0; y < h; ++y)
    for (size_t x = 0; x < w; ++x) {
      const float d = depth[(h - 1 - y) * w + x];
      out[y * w + x] = d >= 1.f ? std::numeric_limits<float>::infinity() : float(d * kOpaqueDepthRangeMm);
    }
  return out;
}

}  // namespace vellum::render
