// Render time per preset: 256^3 int16 analytic volume into 512x512 (not a test).
// Usage: render_bench [volume size, default 256] [image size, default 512] [repeats, default 3]
#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <iostream>

#include "analytic_volumes.hpp"
#include "vellum/core/process_time.hpp"
#include "vellum/render/volume_renderer.hpp"

int main(int argc, char** argv) {
  using namespace vellum;
  const int n = argc > 1 ? std::atoi(argv[1]) : 256;
  const int size = argc > 2 ? std::atoi(argv[2]) : 512;
  const int repeats = argc > 3 ? std::max(1, std::atoi(argv[3])) : 3;
  auto t0 = std::chrono::steady_clock::now();
  const VolumeI16 vol = test::makeAnalyticVolume(n);
  auto ms = [](auto a) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - a).count();
  };
  std::cout << "volume " << vol.dims().str() << " int16 built in " << ms(t0) << " ms\n";
  auto context = render::GlContext::createHeadless();
  std::cout << "GL: " << context->renderer() << " | " << context->version() << "\n";
  render::VolumeRenderer renderer(*context);
  t0 = std::chrono::steady_clock::now();
  renderer.setVolume(vol);
  std::cout << "setVolume (upload + normal volume): " << ms(t0) << " ms\n";
  std::cout << "image " << size << "x" << size << ", step 0.5 voxel, best of " << repeats << "\n";
  const render::BackwardMap map = test::makeTwistMap(vol.geometry(), 17, true);
  // shaded, unshaded, shaded + deformed (17^3 twist map), the same with the source's unturned
  // normals (the cost of turning them by the map's Jacobian)
  for (int mode = 0; mode < 4; ++mode)
    for (render::Preset p : render::allPresets()) {
      const bool shading = mode != 1;
      if ((!shading || mode == 3) && p == render::Preset::Mip) continue;
      if (mode >= 2) renderer.setBackwardMap(&map);
      render::RenderSettings s;
      s.preset = p;
      s.width = s.height = size;
      s.shading = shading;
      s.turnDeformedNormals = mode != 3;
      renderer.render(s);  // compiles the program
      double best = 1e30, bestCpu = 1e30;
      for (int i = 0; i < repeats; ++i) {
        const double c0 = processCpuMs();
        renderer.render(s);
        bestCpu = std::min(bestCpu, processCpuMs() - c0);
        best = std::min(best, renderer.lastRenderMs());
      }
      std::cout << render::presetName(p) << (shading ? "" : " (no shading)")
                << (mode >= 2 ? " (deformed)" : "") << (mode == 3 ? " (unturned normals)" : "") << ": " << best
                << " ms wall (GL draw + glFinish), " << bestCpu
                << " ms CPU (whole render() incl. read-back, all threads)\n";
    }
  return 0;
}
