// The shared viewport's costs (not a test): render() with its read-back against renderInto()
// into a caller's framebuffer, and the opaque mesh pass, at a studio pane's size.
// Usage: viewport_bench [volume size, default 256] [width 950] [height 800] [repeats 3]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <iostream>
#include <map>

#include <GL/glcorearb.h>

#include "analytic_volumes.hpp"
#include "vellum/core/process_time.hpp"
#include "vellum/render/mesh_renderer.hpp"
#include "vellum/render/volume_renderer.hpp"

namespace {

using namespace vellum;

/// An octahedron subdivided `levels` times onto a sphere: 8 * 4^levels triangles.
render::SurfaceMesh sphere(const Vec3& c, double r, int levels) {
  std::vector<Vec3> v{{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  std::vector<std::array<uint32_t, 3>> f{{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4}, {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  for (int l = 0; l < levels; ++l) {
    std::map<std::pair<uint32_t, uint32_t>, uint32_t> mid;
    auto m = [&](uint32_t a, uint32_t b) {
      const auto k = std::minmax(a, b);
      if (auto it = mid.find(k); it != mid.end()) return it->second;
      v.push_back(normalized(v[a] + v[b]));
      return mid[k] = uint32_t(v.size() - 1);
    };
    std::vector<std::array<uint32_t, 3>> next;
    for (const auto& t : f) {
      const uint32_t ab = m(t[0], t[1]), bc = m(t[1], t[2]), ca = m(t[2], t[0]);
      next.insert(next.end(), {{t[0], ab, ca}, {ab, t[1], bc}, {ca, bc, t[2]}, {ab, bc, ca}});
    }
    f = std::move(next);
  }
  render::SurfaceMesh s;
  for (const Vec3& p : v)
    for (int k = 0; k < 3; ++k) s.positionsMm.push_back(float(c[k] + r * p[k]));
  for (const auto& t : f) s.triangles.insert(s.triangles.end(), t.begin(), t.end());
  return s;
}

double msSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

/// Best wall and best process CPU time (all llvmpipe threads: the load-independent measure
/// on a shared machine) of `body`, which ends with a read-back or a finish.
struct Times {
  double wall = 1e30, cpu = 1e30;
};
std::ostream& operator<<(std::ostream& o, const Times& t) { return o << t.wall << " ms wall, " << t.cpu << " ms CPU"; }

Times best(int repeats, const std::function<void()>& body) {
  body();  // compiles programs, allocates targets
  Times b;
  for (int i = 0; i < repeats; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    const double c0 = processCpuMs();
    body();
    b.cpu = std::min(b.cpu, processCpuMs() - c0);
    b.wall = std::min(b.wall, msSince(t0));
  }
  return b;
}

}  // namespace

int main(int argc, char** argv) {
  const int n = argc > 1 ? std::atoi(argv[1]) : 256;
  const int w = argc > 2 ? std::atoi(argv[2]) : 950, h = argc > 3 ? std::atoi(argv[3]) : 800;
  const int repeats = argc > 4 ? std::max(1, std::atoi(argv[4])) : 3;
  const VolumeI16 vol = test::makeAnalyticVolume(n);
  auto context = render::GlContext::createHeadless();
  std::cout << "GL: " << context->renderer() << "\nvolume " << vol.dims().str() << ", image " << w << "x" << h
            << ", soft-tissue, best of " << repeats << "\n";
  render::VolumeRenderer renderer(*context);
  renderer.setVolume(vol);
  render::RenderSettings s;
  s.preset = render::Preset::SoftTissueBone;
  s.width = w;
  s.height = h;
  render::FramebufferTarget target(*context);
  target.resize(w, h);
  const Times withReadBack = best(repeats, [&] { renderer.render(s); });
  std::cout << "render() (draw + glFinish + read-back): " << withReadBack << "\n";
  const Times into = best(repeats, [&] {
    renderer.renderInto(s, target.volumeTarget(false));
    glFinish();  // only to time it: the studio never waits
  });
  std::cout << "renderInto() (draw + glFinish, no read-back): " << into << "; GPU timer " << renderer.lastGpuMs() << " ms (last run)\n";
  const Times colourRead = best(repeats, [&] { target.readColour(); });
  std::cout << "colour read-back alone (" << w << "x" << h << " RGBA8): " << colourRead << "\n";
  const Times emptyDepth = best(repeats, [&] {
    target.clear({0, 0, 0, 0});  // depth 1 everywhere: no geometry
    renderer.renderInto(s, target.volumeTarget(true));
    glFinish();
  });
  std::cout << "renderInto() with an empty opaque depth: " << emptyDepth << "\n";

  const Geometry& g = vol.geometry();
  const double r = 0.3 * std::min({g.dims.x * g.spacing.x, g.dims.y * g.spacing.y, g.dims.z * g.spacing.z});
  render::MeshRenderer meshes(*context);
  const render::Projection cam(g, s);
  for (int levels : {4, 6, 8}) {
    const render::SurfaceMesh m = sphere(g.center(), r, levels);
    meshes.setMeshes({m});
    const Times pass = best(repeats, [&] {
      target.clear({0, 0, 0, 0});
      meshes.draw(cam, target);
      glFinish();
    });
    std::cout << "mesh pass, " << m.triangles.size() / 3 << " triangles: " << pass << " (clear + draw + glFinish); GPU timer "
              << meshes.lastDrawMs() << " ms\n";
    const Times composite = best(repeats, [&] {
      target.clear({0, 0, 0, 0});
      meshes.draw(cam, target);
      renderer.renderInto(s, target.volumeTarget(true));
      glFinish();
    });
    std::cout << "  meshes + renderInto() with their depth: " << composite << "; GPU timer " << renderer.lastGpuMs() << " ms\n";
  }
  return 0;
}
