// The JSON readers, one harness each, chosen at compile time: control points (default),
// keyframes, styles, curves, studio scenes and studio scripts. Every reader goes through
// vellum::readJsonFile (size and depth checked before parsing) and then its own validation.
#include "fuzz_harness.hpp"
#if defined(VELLUM_FUZZ_STYLE)
#include "vellum/illustration/style.hpp"
#elif defined(VELLUM_FUZZ_CURVE)
#include "vellum/illustration/curve_analogy.hpp"
#elif defined(VELLUM_FUZZ_SCENE)
#include "scene_file.hpp"
#elif defined(VELLUM_FUZZ_SCRIPT)
#include "script.hpp"
#else
#include "vellum/deformation/point_files.hpp"
#endif

namespace {

#if defined(VELLUM_FUZZ_SCENE)
/// The files a scene may name ("ct.nrrd", "labels.nrrd", "shape/", "k.json"), so that the
/// fuzzer gets past the existence checks into the view, bookmark and deformation fields.
void writeSceneNeighbours() {
  static const bool written = [] {
    const std::string keyframes =
        R"({"units": "mm", "keyframes": [{"duration": 1, "points": [{"source": [0, 0, 0], "target": [1, 0, 0]}]},)"
        R"( {"duration": 1, "points": [{"source": [0, 0, 0], "target": [2, 0, 0]}]}]})";
    vellum::fuzz::writeInput(reinterpret_cast<const uint8_t*>(keyframes.data()), keyframes.size(), "k.json");
    const uint8_t zero = 0;  // only their existence is checked
    for (const char* name : {"ct.nrrd", "labels.nrrd"}) vellum::fuzz::writeInput(&zero, 1, name);
    std::filesystem::create_directories(vellum::fuzz::scratchDir() / "shape");
    return true;
  }();
  (void)written;
}
#endif

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
#if defined(VELLUM_FUZZ_SCENE)
  writeSceneNeighbours();
#endif
  const auto path = vellum::fuzz::writeInput(data, size, "input.json");
  vellum::fuzz::expectCleanRefusal([&] {
#if defined(VELLUM_FUZZ_KEYFRAMES)
    (void)vellum::deformation::loadKeyframes(path);
#elif defined(VELLUM_FUZZ_STYLE)
    (void)vellum::illustration::loadStyle(path);
#elif defined(VELLUM_FUZZ_CURVE)
    (void)vellum::illustration::loadCurveJson(path);
#elif defined(VELLUM_FUZZ_SCENE)
    (void)vellum::studio::readSceneFile(path);
#elif defined(VELLUM_FUZZ_SCRIPT)
    (void)vellum::studio::ScriptRunner::load(path);
#else
    (void)vellum::deformation::loadControlPoints(path);
#endif
  });
  return 0;
}
