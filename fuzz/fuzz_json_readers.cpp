// JSON readers of the deformation module (control points, keyframes), chosen at compile time.
#include "fuzz_harness.hpp"
#include "vellum/deformation/point_files.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const auto path = vellum::fuzz::writeInput(data, size, "input.json");
  vellum::fuzz::expectCleanRefusal([&] {
#ifdef VELLUM_FUZZ_KEYFRAMES
    (void)vellum::deformation::loadKeyframes(path);
#else
    (void)vellum::deformation::loadControlPoints(path);
#endif
  });
  return 0;
}
