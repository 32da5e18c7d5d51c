// The cinematic path tracer's CPU reference (path_tracer.hpp) against analytic radiance: an
// opaque ball lit from one side by the key light under a uniform-ish sky. A convex surface sees
// its whole upper hemisphere of sky and the key light exactly where n.L > 0, so the radiance of
// each visible point is known in closed form.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "analytic_volumes.hpp"
#include "light_volume.hpp"
#include "path_tracer.hpp"
#include "render_common.hpp"
#include "vellum/render/path_tracer.hpp"

namespace vellum::render::detail {
namespace {

constexpr float kGrey = 0.8f;  // sRGB; albedo 0.8^2.2

/// Opaque grey above 0 HU (alpha 0.99 per mm: a mean free path of 0.22 mm).
TransferFunction greyOpaque() {
  TransferFunction tf;
  tf.points = {{-1024, {kGrey, kGrey, kGrey, 0.f}}, {0, {kGrey, kGrey, kGrey, 0.f}},
               {100, {kGrey, kGrey, kGrey, 0.99f}}, {3071, {kGrey, kGrey, kGrey, 0.99f}}};
  return tf;
}

RenderSettings ballSettings() {
  RenderSettings s;
  s.width = s.height = 32;
  s.preset = Preset::Bone;
  s.transferFunction = greyOpaque();
  s.windowWidth = 0;  // the table as given
  s.camera.azimuthDeg = 0;
  s.camera.elevationDeg = 0;
  s.camera.fieldOfViewDeg = 0;  // orthographic: the analytic hit point is simple
  s.camera.zoom = 1.6;
  s.quality = Quality::Cinematic;
  s.cinematic.samples = 32;
  s.cinematic.lightSizeDeg = 0;
  s.cinematic.fillLight = 0;
  s.cinematic.skyLight = 0.5;
  s.cinematic.denoise = 0;
  s.lighting.azimuthDeg = 90;  // from the right of the view
  s.lighting.elevationDeg = 0;
  return s;
}

TEST(PathTracerCpu, BallLitFromOneSideHasTheAnalyticRadiance) {
  constexpr double kRadius = 12;
  const VolumeI16 ball = test::makeBallVolume(40, 1.0, kRadius);
  const RenderSettings s = ballSettings();
  const PathSums sums = pathTraceCpu(ball, s, nullptr);
  const Frame f = makeFrame(ball.geometry(), nullptr, s);
  const Vec3 key = keyLightDirection(f, s.lighting);
  ASSERT_NEAR(dot(key, f.right), 1.0, 1e-9);
  const double albedo = std::pow(kGrey, 2.2);
  const double sky = s.cinematic.skyLight;
  // Sums of measured and expected radiance over the pixels well inside each half of the disc
  // (the hit point's radius is where the value crosses 50 HU: the ball's edge profile is
  // symmetric about kRadius).
  double measured[2] = {0, 0}, expected[2] = {0, 0};
  int count[2] = {0, 0};
  const Vec3 centre = ball.geometry().center();
  for (int y = 0; y < s.height; ++y)
    for (int x = 0; x < s.width; ++x) {
      const Ray r = pixelRay(f, x, y);
      const Vec3 oc = r.origin - centre;
      const double b = dot(oc, r.dir), c = dot(oc, oc) - kRadius * kRadius, disc = b * b - c;
      if (disc <= 0) continue;
      const Vec3 n = normalized(oc + r.dir * (-b - std::sqrt(disc)));
      const double side = dot(n, f.right);
      if (std::abs(side) < 0.3 || dot(n, r.dir * -1.0) < 0.5) continue;  // away from the terminator and the rim
      const int half = side > 0 ? 1 : 0;
      // Sky: the hemisphere about n of sky * (0.75 + 0.25 w.up), cosine-weighted over pi.
      double L = albedo * sky * (0.75 + 0.25 * (2.0 / 3.0) * dot(n, f.up));
      if (side > 0) {  // key light: irradiance pi at normal incidence, Lambert + normalised Blinn-Phong
        const Vec3 h = normalized(key + r.dir * -1.0);
        L += albedo * side + kSpecular * (kShininess + 8) / 8 * std::pow(std::max(dot(n, h), 0.0), double(kShininess)) * side;
      }
      const float* px = sums.rgba.data() + 4 * (size_t(y) * size_t(s.width) + size_t(x));
      ASSERT_NEAR(px[3], sums.samples, 0.5) << "every path hits the ball at " << x << "," << y;
      measured[half] += px[0] / sums.samples;
      expected[half] += L;
      ++count[half];
    }
  ASSERT_GT(count[0], 30);
  ASSERT_GT(count[1], 30);
  std::cout << "[ ball ] shadowed half: " << measured[0] / count[0] << " vs " << expected[0] / count[0]
            << "; lit half: " << measured[1] / count[1] << " vs " << expected[1] / count[1] << "\n";
  EXPECT_NEAR(measured[0] / expected[0], 1.0, 0.08) << "shadowed half: sky light only";
  EXPECT_NEAR(measured[1] / expected[1], 1.0, 0.08) << "lit half: key + sky";
}

TEST(PathTracerCpu, DeterministicForASeedAndDifferentForAnother) {
  const VolumeI16 v = test::makeAnalyticVolume(32);
  RenderSettings s;
  s.width = s.height = 24;
  s.quality = Quality::Cinematic;
  s.cinematic.samples = 4;
  const RgbaImage a = renderPathTracedCpu(v, s), b = renderPathTracedCpu(v, s);
  EXPECT_EQ(a.pixels, b.pixels);
  s.cinematic.seed = 2;
  EXPECT_NE(a.pixels, renderPathTracedCpu(v, s).pixels);
}

TEST(PathTracerCpu, MajorantsBoundTheExtinction) {
  const VolumeI16 v = test::makeAnalyticVolume(32);
  RenderSettings s;
  const TfTable tf = buildTfTable(s, 0.5);
  const BlockRanges ranges = computeBlockRanges(v);
  const std::vector<float> maj = blockMajorants(ranges, tf, 0.5);
  const Dims& b = ranges.blocks;
  // Every voxel's extinction is within its block's majorant; empty blocks have none.
  for (int64_t k = 0; k < 32; ++k)
    for (int64_t j = 0; j < 32; ++j)
      for (int64_t i = 0; i < 32; ++i) {
        const float alpha = std::min(tf.lookup(v(i, j, k))[3], kMaxPathAlpha);
        const float sigma = float(-std::log1p(-alpha) / 0.5);
        const size_t n = size_t(((k / kBlockSize) * b.y + j / kBlockSize) * b.x + i / kBlockSize);
        EXPECT_LE(sigma, maj[n] * 1.0001f);
      }
  // A small ball in air: the blocks far from it have no extinction (delta tracking skips them).
  const VolumeI16 ball = test::makeBallVolume(48, 1.0, 6);
  const std::vector<float> ballMaj = blockMajorants(computeBlockRanges(ball), tf, 0.5);
  EXPECT_GT(std::count(ballMaj.begin(), ballMaj.end(), 0.f), 0) << "the corners are air";
  EXPECT_GT(*std::max_element(ballMaj.begin(), ballMaj.end()), 1.f) << "the ball is dense";
}

}  // namespace
}  // namespace vellum::render::detail
