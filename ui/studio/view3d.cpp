#include "view3d.hpp"

#include <GL/glcorearb.h>

#include <algorithm>
#include <chrono>
#include <sstream>

namespace vellum::studio {

render::RenderSettings renderSettingsFor(const Scene& scene, int width, int height) {
  render::RenderSettings s;
  s.width = std::clamp(width, 1, 4096);
  s.height = std::clamp(height, 1, 4096);
  s.preset = scene.preset;
  s.camera = scene.camera;
  s.windowCenter = scene.renderWindow.center;
  s.windowWidth = scene.renderWindow.width;
  return s;
}

namespace {
/// What a frame depends on; a change means "render again".
std::string viewKey(const Scene& s, int w, int h) {
  std::ostringstream k;
  k.precision(17);
  const auto& c = s.camera;
  k << w << ' ' << h << ' ' << int(s.preset) << ' ' << c.azimuthDeg << ' ' << c.elevationDeg << ' '
    << c.zoom << ' ' << c.fieldOfViewDeg << ' ' << c.panMm.x << ' ' << c.panMm.y << ' ' << c.panMm.z
    << ' ' << s.renderWindow.center << ' ' << s.renderWindow.width;
  return k.str();
}
}  // namespace

View3D::View3D(render::GlContext& context)
    : context_(context), renderer_(std::make_unique<render::VolumeRenderer>(context)) {}

void View3D::setVolume(const VolumeI16& ct) {
  context_.makeCurrent();
  renderer_->setVolume(AnyVolume(ct));
  hasVolume_ = true;
  invalidate();
}

RgbaImage View3D::renderImage(const Scene& scene, int width, int height) {
  context_.makeCurrent();
  RgbaImage img = renderer_->render(renderSettingsFor(scene, width, height));
  glBindFramebuffer(GL_FRAMEBUFFER, 0);  // the renderer leaves its FBO bound
  return img;
}

bool View3D::update(const Scene& scene, int paneWidth, int paneHeight, bool interacting) {
  if (!hasVolume_ || paneWidth < 2 || paneHeight < 2) return false;
  const std::string key = viewKey(scene, paneWidth, paneHeight);
  const bool changed = key != lastKey_;
  if (!changed && (refined_ || interacting)) return false;
  const int scale = interacting ? scale_ : 1;
  const auto t0 = std::chrono::steady_clock::now();
  const RgbaImage img = renderImage(scene, std::max(1, paneWidth / scale), std::max(1, paneHeight / scale));
  texture_.upload(img);
  lastMs_ = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  lastScale_ = scale;
  lastKey_ = key;
  refined_ = scale == 1;
  if (interacting) {
    // Cost scales with pixels: halve the resolution when over budget; double it only when
    // 4x the pixels are predicted to fit (hysteresis: no oscillation between two factors).
    if (lastMs_ > kInteractiveBudgetMs && scale_ < 8) scale_ *= 2;
    else if (lastMs_ * 4 < kInteractiveBudgetMs * 0.9 && scale_ > 2) scale_ /= 2;
  }
  return true;
}

}  // namespace vellum::studio
