// Illustration renderer timing on llvmpipe, and a fixture writer for trying the CLI.
//   illustration_bench [N=256] [SIZE=512] [FRAMES=5] [PRESET=textbook] [ZOOM=1]
//   illustration_bench --fixture DIR [N=96]   -> DIR/ct.nrrd, DIR/shape/{distance,segments}.nrrd
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <string>

#include "shape_fixtures.hpp"
#include "vellum/core/process_time.hpp"
#include "vellum/io/volume_io.hpp"

using namespace vellum;

namespace {

/// Nested bone/muscle/skin with a vessel tube beside the bone and a second, smaller bone.
illustration::ShapeScene benchScene(int n) {
  const double rb = 0.15 * n, rm = 0.30 * n, rs = 0.36 * n;
  const Vec3 b1{-0.06 * n, 0, 0}, b2{0.14 * n, 0.02 * n, 0};
  auto bone = [=](const Vec3& p) { return std::min(test::sphereSdf(p, b1, rb), test::boxSdf(p, b2, {0.04 * n, 0.04 * n, 0.25 * n})); };
  auto vessel = [=](const Vec3& p) {
    return std::max(std::hypot(p.x - 0.05 * n, p.y + 0.17 * n) - 0.035 * n, std::abs(p.z) - 0.28 * n);
  };
  auto inner = [=](const Vec3& p) { return std::min(bone(p), vessel(p)); };
  return test::makeScene(n, {{"bone", bone},
                             {"vessel", [=](const Vec3& p) { return std::max(-bone(p), vessel(p)); }},
                             {"muscle", [=](const Vec3& p) { return std::max(-inner(p), test::sphereSdf(p, {0, 0, 0}, rm)); }},
                             {"skin", [=](const Vec3& p) { return std::max(rm - norm(p), test::sphereSdf(p, {0, 0, 0}, rs)); }}});
}

VolumeI16 ctFor(const illustration::ShapeScene& s) {
  VolumeI16 ct(s.distance.geometry(), -1000, -1000);
  const int16_t hu[] = {-1000, 1100, 250, 50, -80};
  for (size_t i = 0; i < ct.size(); ++i) ct.voxels()[i] = hu[std::min<size_t>(s.segments.ids().voxels()[i], 4)];
  return ct;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    if (argc > 1 && std::string(argv[1]) == "--fixture") {
      if (argc < 3) throw std::runtime_error("usage: illustration_bench --fixture DIR [N]");
      const std::filesystem::path dir = argv[2];
      const int n = argc > 3 ? std::atoi(argv[3]) : 96;
      const auto scene = benchScene(n);
      test::writeShapeFolder(scene, dir / "shape");
      io::saveVolume(ctFor(scene), dir / "ct.nrrd");
      std::cout << "wrote " << (dir / "ct.nrrd").string() << " and " << (dir / "shape").string() << "\n";
      return 0;
    }
    const int n = argc > 1 ? std::atoi(argv[1]) : 256;
    const int size = argc > 2 ? std::atoi(argv[2]) : 512;
    const int frames = argc > 3 ? std::atoi(argv[3]) : 5;
    const std::string preset = argc > 4 ? argv[4] : "textbook";
    const double zoom = argc > 5 ? std::atof(argv[5]) : 1.0;
    auto t0 = std::chrono::steady_clock::now();
    illustration::ShapeScene scene = benchScene(n);
    scene.ct = ctFor(scene);
    const double genMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    auto context = render::GlContext::createHeadless();
    illustration::IllustrationRenderer r(*context);
    r.setScene(scene);
    std::cout << "scene " << n << "^3 (generated in " << genMs << " ms), upload incl. gradient " << r.lastUploadMs()
              << " ms, " << context->renderer() << "\n";
    const illustration::Style style = illustration::stylePreset(preset);
    for (auto mode : {illustration::Interpolation::Nearest, illustration::Interpolation::Eight}) {
      illustration::IllustrationSettings s;
      s.render.width = s.render.height = size;
      s.interpolation = mode;
      s.render.camera.zoom = zoom;
      r.render(style, s);  // compile + first use
      std::vector<double> ms, cpu;
      for (int f = 0; f < frames; ++f) {
        s.render.camera.azimuthDeg = 30 + 15 * f;
        const double c0 = processCpuMs();
        r.render(style, s);
        cpu.push_back(processCpuMs() - c0);
        ms.push_back(r.lastRenderMs());
      }
      std::sort(ms.begin(), ms.end());
      std::sort(cpu.begin(), cpu.end());
      std::cout << preset << " " << illustration::interpolationName(mode) << " " << size << "x" << size << ": median "
                << ms[ms.size() / 2] << " ms, min " << ms.front() << " ms, max " << ms.back() << " ms over " << frames
                << " views; CPU " << cpu[cpu.size() / 2] << " ms per frame (/2 = " << cpu[cpu.size() / 2] / 2
                << " ms on 2 free cores)\n";
    }
  } catch (const std::exception& e) {
    std::cerr << "illustration_bench: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
