#include "view3d.hpp"

#include <GL/glcorearb.h>

#include <algorithm>
#include <cmath>
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

std::optional<std::pair<double, double>> projectToView(const Scene& scene, int width, int height, const Vec3& p) {
  // The orbit camera of render::RenderSettings (modules/render/src/render_common.cpp).
  const Geometry& g = scene.ct.geometry();
  const Vec3 centre = g.center();
  double radius = 0;
  for (int c = 0; c < 8; ++c) {
    const Vec3 corner{(c & 1) ? g.dims.x - 0.5 : -0.5, (c & 2) ? g.dims.y - 0.5 : -0.5, (c & 4) ? g.dims.z - 0.5 : -0.5};
    radius = std::max(radius, norm(g.indexToPhysical(corner) - centre));
  }
  const render::Camera& cam = scene.camera;
  const Vec3 lookAt = centre + cam.panMm;
  const double az = cam.azimuthDeg * M_PI / 180.0, el = cam.elevationDeg * M_PI / 180.0;
  const Vec3 forward = -Vec3{std::cos(el) * std::sin(az), -std::cos(el) * std::cos(az), std::sin(el)};
  const Vec3 right{std::cos(az), std::sin(az), 0};
  const Vec3 up = cross(right, forward);
  const double aspect = double(width) / height;
  const double sx = aspect >= 1 ? aspect : 1.0, sy = aspect >= 1 ? 1.0 : 1.0 / aspect;
  double x, y, halfW, halfH;
  if (cam.fieldOfViewDeg > 0) {
    const double half = cam.fieldOfViewDeg * M_PI / 360.0;
    const Vec3 eye = lookAt - forward * (radius / std::sin(half));
    const Vec3 d = p - eye;
    const double z = dot(d, forward);
    if (z <= 1e-6) return std::nullopt;
    x = dot(d, right) / z;
    y = dot(d, up) / z;
    halfW = std::tan(half) / cam.zoom * sx;
    halfH = std::tan(half) / cam.zoom * sy;
  } else {
    x = dot(p - lookAt, right);
    y = dot(p - lookAt, up);
    halfW = radius / cam.zoom * sx;
    halfH = radius / cam.zoom * sy;
  }
  return std::pair{(x / halfW + 1) / 2 * width, (1 - y / halfH) / 2 * height};
}

std::string cliRenderCommand(const Scene& scene, int width, int height, const std::string& out) {
  const render::RenderSettings s = renderSettingsFor(scene, width, height);
  std::ostringstream c;
  c.precision(10);
  auto quoted = [](const std::string& t) { return "'" + t + "'"; };
  c << "vellum render " << quoted(scene.volumePath.string()) << " --out " << quoted(out)
    << " --preset " << render::presetName(s.preset) << " --size " << s.width << "x" << s.height
    << " --azimuth " << s.camera.azimuthDeg << " --elevation " << s.camera.elevationDeg << " --zoom "
    << s.camera.zoom << " --fov " << s.camera.fieldOfViewDeg << " --pan " << s.camera.panMm.x << ' '
    << s.camera.panMm.y << ' ' << s.camera.panMm.z << " --window " << s.windowCenter << ' ' << s.windowWidth;
  return c.str();
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
