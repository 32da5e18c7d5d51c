// The shared viewport: opaque meshes (MeshRenderer) in the ray caster's camera, and the volume
// drawn into a caller's framebuffer with rays terminated at the meshes' depth (renderInto).
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <limits>
#include <numbers>

#include "analytic_volumes.hpp"
#include "headless_gl.hpp"
#include "image_compare.hpp"
#include "render_common.hpp"  // white-box: detail::pixelRay, the renderer's own rays
#include "vellum/core/error.hpp"
#include "vellum/phantom/phantom.hpp"
#include "vellum/render/mesh_renderer.hpp"
#include "vellum/render/projection.hpp"
#include "vellum/render/volume_renderer.hpp"

namespace vellum::render {
namespace {

GlContext& gl() { return test::headlessGl(); }

RenderSettings settingsOf(Preset p, int w, int h, double fov, double azimuth = 35, double elevation = 20) {
  RenderSettings s;
  s.preset = p;
  s.width = w;
  s.height = h;
  s.camera.fieldOfViewDeg = fov;
  s.camera.azimuthDeg = azimuth;
  s.camera.elevationDeg = elevation;
  return s;
}

/// A sphere: an octahedron subdivided `levels` times, vertices pushed onto the sphere.
SurfaceMesh sphereMesh(const Vec3& centre, double radius, int levels, std::array<float, 3> rgb) {
  std::vector<Vec3> v{{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  std::vector<std::array<uint32_t, 3>> f{{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
                                         {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  for (int l = 0; l < levels; ++l) {
    std::vector<std::array<uint32_t, 3>> next;
    std::map<std::pair<uint32_t, uint32_t>, uint32_t> mid;
    auto midpoint = [&](uint32_t a, uint32_t b) {
      const auto key = std::minmax(a, b);
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      v.push_back(normalized(v[a] + v[b]));
      return mid[key] = uint32_t(v.size() - 1);
    };
    for (const auto& t : f) {
      const uint32_t ab = midpoint(t[0], t[1]), bc = midpoint(t[1], t[2]), ca = midpoint(t[2], t[0]);
      next.insert(next.end(), {{t[0], ab, ca}, {ab, t[1], bc}, {ca, bc, t[2]}, {ab, bc, ca}});
    }
    f = std::move(next);
  }
  SurfaceMesh m;
  m.rgb = rgb;
  for (const Vec3& p : v)
    for (int k = 0; k < 3; ++k) m.positionsMm.push_back(float(centre[k] + radius * p[k]));
  for (const auto& t : f) m.triangles.insert(m.triangles.end(), t.begin(), t.end());
  return m;
}

/// A square facing the view direction, `distanceMm` in front of `centre`, half size `half`.
SurfaceMesh facingSquare(const Projection& cam, const Vec3& centre, double distanceMm, double half,
                         std::array<float, 3> rgb) {
  const Vec3 c = centre - cam.viewDirection() * distanceMm;
  SurfaceMesh m;
  m.rgb = rgb;
  for (auto [a, b] : {std::pair{-1, -1}, {1, -1}, {1, 1}, {-1, 1}}) {
    const Vec3 p = c + cam.screenRight() * (a * half) + cam.screenUp() * (b * half);
    for (int k = 0; k < 3; ++k) m.positionsMm.push_back(float(p[k]));
  }
  m.triangles = {0, 1, 2, 0, 2, 3};
  return m;
}

Vec3 vertex(const SurfaceMesh& m, uint32_t i) {
  return {m.positionsMm[3 * i], m.positionsMm[3 * i + 1], m.positionsMm[3 * i + 2]};
}

/// Nearest ray-triangle hit (Moller-Trumbore), +inf if none.
double rayHit(const SurfaceMesh& m, const detail::Ray& ray) {
  double best = std::numeric_limits<double>::infinity();
  for (size_t t = 0; t < m.triangles.size(); t += 3) {
    const Vec3 a = vertex(m, m.triangles[t]), b = vertex(m, m.triangles[t + 1]), c = vertex(m, m.triangles[t + 2]);
    const Vec3 e1 = b - a, e2 = c - a, pv = cross(ray.dir, e2);
    const double det = dot(e1, pv);
    if (std::abs(det) < 1e-12) continue;
    const Vec3 tv = ray.origin - a;
    const double u = dot(tv, pv) / det;
    const Vec3 qv = cross(tv, e1);
    const double w = dot(ray.dir, qv) / det, dist = dot(e2, qv) / det;
    if (u >= 0 && w >= 0 && u + w <= 1 && dist > 0) best = std::min(best, dist);
  }
  return best;
}

struct Projected {
  double x[3], y[3];
};

/// Smallest signed distance (px) of (px, py) to the edges of a projected triangle: > 0 inside.
double insideMargin(const Projected& t, double px, double py) {
  const double area = (t.x[1] - t.x[0]) * (t.y[2] - t.y[0]) - (t.y[1] - t.y[0]) * (t.x[2] - t.x[0]);
  if (std::abs(area) < 1e-12) return -1e30;
  double m = 1e30;
  for (int e = 0; e < 3; ++e) {
    const int a = e, b = (e + 1) % 3;
    const double ex = t.x[b] - t.x[a], ey = t.y[b] - t.y[a];
    const double cr = (ex * (py - t.y[a]) - ey * (px - t.x[a])) * (area > 0 ? 1 : -1);
    m = std::min(m, cr / std::hypot(ex, ey));
  }
  return m;
}

// The matrix the meshes are drawn with is the Projection camera model: a point's GL window
// position (after the divide and the viewport transform) is toPixel()'s pixel + 0.5.
TEST(RenderDepth, ViewProjectionMatrixIsToPixel) {
  const VolumeI16 vol = test::makeAnalyticVolume(32);
  for (double fov : {30.0, 0.0}) {
    RenderSettings s = settingsOf(Preset::Bone, 120, 90, fov, 50, -25);
    s.camera.zoom = 1.4;
    s.camera.panMm = {5, -3, 8};
    const Projection cam(vol.geometry(), s);
    const auto m = cam.viewProjectionGl(1.0, 1000.0);
    for (int i = 0; i < 50; ++i) {
      const Vec3 p = vol.geometry().center() + Vec3{std::sin(i * 1.3) * 40, std::cos(i * 2.1) * 35, std::sin(i * 0.7) * 50};
      double clip[4] = {};
      for (int r = 0; r < 4; ++r) clip[r] = m[size_t(r)] * p.x + m[size_t(4 + r)] * p.y + m[size_t(8 + r)] * p.z + m[size_t(12 + r)];
      const auto px = cam.toPixel(p);
      ASSERT_TRUE(px.has_value());
      const double wx = (clip[0] / clip[3] + 1) * 0.5 * s.width, wy = (clip[1] / clip[3] + 1) * 0.5 * s.height;
      EXPECT_NEAR(wx, px->x + 0.5, 1e-6) << "fov " << fov;
      EXPECT_NEAR(wy, s.height - 0.5 - px->y, 1e-6) << "fov " << fov;
      EXPECT_NEAR(clip[3], fov > 0 ? px->z : 1.0, 1e-9);
    }
  }
}

// GL's rasterised mesh covers exactly the pixels whose centres lie inside the triangles as
// Projection::toPixel places them (to 0.01 px), and its opaque depth is the ray distance to
// the mesh along the renderer's own ray (detail::pixelRay), perspective and orthographic.
TEST(RenderDepth, MeshLandsWhereProjectionSaysWithRayDistanceDepth) {
  const VolumeI16 vol = test::makeAnalyticVolume(32);
  const SurfaceMesh sphere = sphereMesh(vol.geometry().center() + Vec3{6, -4, 3}, 22, 2, {0.8f, 0.6f, 0.4f});
  MeshRenderer meshes(gl());
  meshes.setMeshes({sphere});
  FramebufferTarget target(gl());
  for (double fov : {30.0, 0.0}) {
    const RenderSettings s = settingsOf(Preset::Bone, 96, 80, fov);
    const Projection cam(vol.geometry(), s);
    const detail::Frame frame = detail::makeFrame(vol.geometry(), nullptr, s);
    target.resize(s.width, s.height);
    target.clear({0, 0, 0, 0});
    meshes.draw(cam, target);
    const RgbaImage colour = target.readColour();
    const std::vector<float> dist = target.readRayDistanceMm();
    std::vector<Projected> tris;
    for (size_t t = 0; t < sphere.triangles.size(); t += 3) {
      Projected p{};
      for (int k = 0; k < 3; ++k) {
        const Vec3 q = *cam.toPixel(vertex(sphere, sphere.triangles[t + size_t(k)]));
        p.x[k] = q.x, p.y[k] = q.y;
      }
      tris.push_back(p);
    }
    int decided = 0, wrong = 0, depthChecked = 0;
    double worstDepth = 0;
    for (int y = 0; y < s.height; ++y)
      for (int x = 0; x < s.width; ++x) {
        double margin = -1e30;
        for (const Projected& t : tris) margin = std::max(margin, insideMargin(t, x, y));
        const size_t i = size_t(y) * size_t(s.width) + size_t(x);
        const bool covered = std::isfinite(dist[i]);
        EXPECT_EQ(covered, colour.at(x, y)[3] == 255) << "colour and depth agree at " << x << "," << y;
        if (std::abs(margin) < 0.01) continue;  // on an edge: the rasteriser's tie rules decide
        ++decided;
        wrong += covered != (margin > 0);
        if (covered && margin > 0) {
          worstDepth = std::max(worstDepth, std::abs(dist[i] - rayHit(sphere, detail::pixelRay(frame, x, y))));
          ++depthChecked;
        }
      }
    std::cout << "[ mesh ] fov " << fov << ": " << decided << " pixels decided, " << wrong << " wrong, depth error max "
              << worstDepth << " mm over " << depthChecked << "\n";
    EXPECT_EQ(wrong, 0) << "fov " << fov;
    EXPECT_GT(depthChecked, 300) << "the sphere covers a good part of the frame";
    EXPECT_LT(worstDepth, 1e-3) << "fov " << fov;
  }
}

// Without an opaque depth, renderInto() writes render()'s exact pixels, whole or in bands.
TEST(RenderDepth, RenderIntoWithoutDepthEqualsRender) {
  const AnyVolume v = test::makeAnalyticVolume(48);
  VolumeRenderer r(gl());
  r.setVolume(v);
  FramebufferTarget target(gl());
  for (Preset p : {Preset::SoftTissueBone, Preset::Mip}) {
    const RenderSettings s = settingsOf(p, 96, 70, 30);
    const RgbaImage reference = r.render(s);
    target.resize(s.width, s.height);
    target.clear({0.3f, 0.6f, 0.9f, 1});
    r.renderInto(s, target.volumeTarget(false));
    EXPECT_EQ(target.readColour().pixels, reference.pixels) << presetName(p);
    target.clear({0.3f, 0.6f, 0.9f, 1});
    for (int row = 0; row < s.height; row += 16) r.renderIntoRows(s, target.volumeTarget(false), row, row + 16);
    EXPECT_EQ(target.readColour().pixels, reference.pixels) << presetName(p) << " in bands";
  }
  RenderSettings wrongSize = settingsOf(Preset::Bone, 50, 70, 30);
  EXPECT_THROW(r.renderInto(wrongSize, target.volumeTarget(false)), Error);
}

// A sphere mesh inside the phantom: GL (rays stopped at the mesh depth, the volume in front
// blended over the mesh colour) equals the CPU reference given the same opaque layer; pixels
// without geometry are render()'s exactly; the mesh really shows.
TEST(RenderDepth, SphereInPhantomMatchesCpuReference) {
  phantom::PhantomOptions o;
  o.dims = {64, 64, 64};
  const auto ph = phantom::makePhantom(o);
  const AnyVolume v = ph.ct;
  const Geometry& g = ph.ct.geometry();
  MeshRenderer meshes(gl());
  meshes.setMeshes({sphereMesh(g.center() + Vec3{0, 0, 10}, 0.22 * g.dims.x * g.spacing.x, 3, {0.2f, 0.5f, 0.9f})});
  VolumeRenderer r(gl());
  r.setVolume(v);
  FramebufferTarget target(gl());
  for (auto [preset, fov] : {std::pair{Preset::SoftTissueBone, 30.0}, {Preset::Skin, 0.0}, {Preset::Mip, 30.0}}) {
    const RenderSettings s = settingsOf(preset, 112, 96, fov);
    target.resize(s.width, s.height);
    target.clear({0, 0, 0, 0});
    meshes.draw(Projection(g, s), target);
    const OpaqueLayer layer{target.readColour(), target.readRayDistanceMm()};
    r.renderInto(s, target.volumeTarget(true));
    const RgbaImage gpu = target.readColour();
    const RgbaImage cpu = renderReferenceCpu(v, s, nullptr, nullptr, &layer);
    const test::ImageDiff d = test::compareImages(gpu, cpu);
    std::cout << "[ diff ] " << presetName(preset) << " + sphere mesh: psnr " << d.psnr << " dB, max " << d.maxAbs << "\n";
    EXPECT_GE(d.psnr, 40.0) << presetName(preset);
    const RgbaImage plain = r.render(s);
    size_t meshPixels = 0, changed = 0;
    for (int y = 0; y < s.height; ++y)
      for (int x = 0; x < s.width; ++x) {
        const bool geometry = std::isfinite(layer.distanceMm[size_t(y) * size_t(s.width) + size_t(x)]);
        const uint8_t *a = gpu.at(x, y), *b = plain.at(x, y);
        const bool same = std::equal(a, a + 4, b);
        if (!geometry) EXPECT_TRUE(same) << presetName(preset) << " no geometry at " << x << "," << y;
        meshPixels += geometry;
        changed += geometry && !same;
      }
    EXPECT_GT(meshPixels, 300u);
    if (preset != Preset::Skin) EXPECT_GT(changed, meshPixels / 4) << presetName(preset) << ": the mesh shows";
  }
}

// A mesh in front of the whole volume hides it: every pixel it covers is its headlight shade
// (orthographic: n.l = 1, so rgb * (ambient + diffuse) + specular).
TEST(RenderDepth, MeshInFrontHidesTheVolume) {
  const AnyVolume v = test::makeAnalyticVolume(48);
  const Geometry& g = geometryOf(v);
  const RenderSettings s = settingsOf(Preset::SoftTissueBone, 80, 64, 0, 0, 0);
  const Projection cam(g, s);
  const double radius = 60;  // > the bounding sphere (0.5 * norm(48 x (1, 1.3, 1.6)) = 55 mm)
  MeshRenderer meshes(gl());
  meshes.setMeshes({facingSquare(cam, g.center(), radius + 3, 4 * radius, {0.4f, 0.2f, 0.6f})});
  VolumeRenderer r(gl());
  r.setVolume(v);
  FramebufferTarget target(gl());
  target.resize(s.width, s.height);
  target.clear({0, 0, 0, 0});
  meshes.draw(cam, target);
  r.renderInto(s, target.volumeTarget(true));
  const RgbaImage img = target.readColour();
  const int expected[3] = {153, 102, 204};  // (0.4, 0.2, 0.6) * 1.0 + 0.2
  int off = 0;
  for (int y = 0; y < s.height; ++y)
    for (int x = 0; x < s.width; ++x)
      for (int c = 0; c < 3; ++c) off += std::abs(img.at(x, y)[c] - expected[c]) > 1;
  EXPECT_EQ(off, 0);
  EXPECT_GT(test::compareImages(img, r.render(s)).meanAbs[0], 20.0) << "the volume alone looks different";
}

/// 48^3, 1 mm, identity direction, centred at the origin: air, and (when `slab`) a 1000 HU
/// slab of y indices [10, 16) across the whole x-z extent.
VolumeI16 slabVolume(bool slab) {
  VolumeI16 vol = test::makeBallVolume(48, 1.0, 0.0, -1000);
  for (int k = 0; k < 48; ++k)
    for (int j = 10; j < 16 && slab; ++j)
      for (int i = 0; i < 48; ++i) vol(i, j, k) = 1000;
  return vol;
}

// A mesh behind a fully opaque slab is hidden: the picture is the slab alone, byte for byte.
// Without the slab the same mesh shows.
TEST(RenderDepth, MeshBehindAnOpaqueSlabIsHidden) {
  RenderSettings s = settingsOf(Preset::Bone, 64, 64, 0, 0, 0);  // looking along +y (anterior view)
  s.transferFunction.points = {{-1000, {0, 0, 0, 0}}, {400, {0, 0, 0, 0}}, {600, {0.9f, 0.9f, 0.8f, 1}}, {3000, {0.9f, 0.9f, 0.8f, 1}}};
  s.windowWidth = 0;  // the transfer function as given
  FramebufferTarget target(gl());
  target.resize(s.width, s.height);
  MeshRenderer meshes(gl());
  VolumeRenderer r(gl());
  for (bool slab : {true, false}) {
    const VolumeI16 vol = slabVolume(slab);
    const Projection cam(vol.geometry(), s);
    // At y = +6 mm (index ~29.5: behind the slab seen from -y), inside the slab's x-z extent.
    meshes.setMeshes({facingSquare(cam, vol.geometry().center(), -6, 18, {1.f, 0.f, 0.f})});
    r.setVolume(vol);
    target.clear({0, 0, 0, 0});
    meshes.draw(cam, target);
    r.renderInto(s, target.volumeTarget(true));
    const RgbaImage img = target.readColour();
    const RgbaImage plain = r.render(s);
    int red = 0;
    for (int y = 0; y < s.height; ++y)
      for (int x = 0; x < s.width; ++x) red += img.at(x, y)[0] > 200 && img.at(x, y)[1] < 60;
    if (slab) {
      EXPECT_EQ(img.pixels, plain.pixels) << "hidden behind the slab";
      EXPECT_EQ(red, 0);
    } else {
      EXPECT_GT(red, 500) << "without the slab the mesh shows";
    }
  }
}

TEST(RenderDepth, BadMeshesAreRefused) {
  MeshRenderer meshes(gl());
  SurfaceMesh m;
  m.positionsMm = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  m.triangles = {0, 1, 3};
  EXPECT_THROW(meshes.setMeshes({m}), Error);
  m.positionsMm.pop_back();
  EXPECT_THROW(meshes.setMeshes({m}), Error);
}

}  // namespace
}  // namespace vellum::render
