#include "scene.hpp"

#include "vellum/core/error.hpp"

namespace vellum::studio {

void Scene::resetView() {
  render.camera = render::Camera{};
  if (hasVolume()) crosshairMm = ct.geometry().center();
}

}  // namespace vellum::studio
