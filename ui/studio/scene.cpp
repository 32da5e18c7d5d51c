#include "scene.hpp"

#include "vellum/core/error.hpp"

namespace vellum::studio {

const char* layoutName(Layout l) {
  switch (l) {
    case Layout::ThreeD: return "3d";
    case Layout::TwoByTwo: return "2x2";
    case Layout::OneByThree: return "1x3";
  }
  return "?";
}

Layout parseLayout(const std::string& name) {
  if (name == "3d") return Layout::ThreeD;
  if (name == "2x2") return Layout::TwoByTwo;
  if (name == "1x3") return Layout::OneByThree;
  throw Error("unknown layout '" + name + "' (valid: 3d, 2x2, 1x3)");
}

void Scene::resetView() {
  camera = render::Camera{};
  if (hasVolume()) crosshairMm = ct.geometry().center();
}

}  // namespace vellum::studio
