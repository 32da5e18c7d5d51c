// GL frame time of the deformed render with the rigid snap and Gaussian upsampling (not a test).
// Usage: wysiwyg_bench [phantom size, default 128] [image size, default 512] [control scale, default 2]
//        [repeats, default 3] [turned normals 1|0, default 1: 0 shades with the source's normals]
#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <iostream>

#include "scene.hpp"
#include "vellum/animation/movie.hpp"
#include "vellum/core/process_time.hpp"
#include "vellum/render/volume_renderer.hpp"

int main(int argc, char** argv) {
  using namespace vellum;
  using namespace vellum::deformation;
  const int n = argc > 1 ? std::atoi(argv[1]) : 128;
  const int size = argc > 2 ? std::atoi(argv[2]) : 512;
  const int scale = argc > 3 ? std::atoi(argv[3]) : 2;
  const int repeats = argc > 4 ? std::max(1, std::atoi(argv[4])) : 3;
  const bool turnNormals = argc > 5 ? std::atoi(argv[5]) != 0 : true;
  const auto t0 = std::chrono::steady_clock::now();
  const test::BentKnee k = test::makeBentKnee(n, scale);
  std::cout << "phantom " << k.ph.ct.dims().str() << ", control grid " << k.rigid.grid.dims.str() << " (s=" << scale
            << "), bent + rigid bones in "
            << std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() << " s\n";
  auto context = render::GlContext::createHeadless();
  std::cout << "GL: " << context->renderer() << "\nimage " << size << "x" << size << ", best of " << repeats
            << (turnNormals ? ", normals turned by the map\n" : ", the source's unturned normals\n");
  render::VolumeRenderer renderer(*context);
  renderer.setVolume(AnyVolume(k.ph.ct));
  ControlVolume unsnapped = k.rigid;
  unsnapped.rigidSnap.reset();
  for (const render::Preset p : {render::Preset::SoftTissueBone, render::Preset::Bone})
    for (const Upsampling up : {Upsampling::Trilinear, Upsampling::Gaussian})
      for (const bool snap : {false, true}) {
        const render::BackwardMap map = deformation::renderedMap(snap ? k.rigid : unsnapped, k.ph.ct.geometry(), up);
        const auto u0 = std::chrono::steady_clock::now();
        renderer.setBackwardMap(&map);
        render::RenderSettings s;
        s.preset = p;
        s.width = s.height = size;
        s.camera.azimuthDeg = 90;
        s.turnDeformedNormals = turnNormals;
        renderer.render(s);  // uploads the map, compiles the program
        const double firstMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - u0).count();
        double best = 1e30, bestCpu = 1e30;
        for (int i = 0; i < repeats; ++i) {
          const double c0 = processCpuMs();
          renderer.render(s);
          bestCpu = std::min(bestCpu, processCpuMs() - c0);
          best = std::min(best, renderer.lastRenderMs());
        }
        std::cout << render::presetName(p) << ", " << upsamplingName(up) << (snap ? " + snap" : "") << ": " << best
                  << " ms wall (GL draw + glFinish), " << bestCpu << " ms CPU (all threads); first frame incl. map upload "
                  << firstMs << " ms\n";
      }
  return 0;
}
