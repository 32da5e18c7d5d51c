// The cinematic lighting's light volume (light_volume.hpp) against analytic transmittance:
// a uniform slab lit along an axis and obliquely, an opaque ball's umbra, and the openness of
// a flat floor against a corner.
#include <gtest/gtest.h>

#include <cmath>

#include "light_volume.hpp"
#include "render_common.hpp"

namespace vellum::render::detail {
namespace {

constexpr double kStepMm = 0.5;
constexpr float kAlpha = 0.05f;  // per step of kStepMm where the value is >= 0
const double kSigma = -std::log(1.0 - kAlpha) / kStepMm;  // extinction per mm

/// Opacity kAlpha for values >= 0, none below.
TfTable stepTable() {
  TfTable t;
  t.lo = -1000;
  t.hi = 1000;
  t.rgba.assign(4 * kTfTableSize, 0.f);
  for (int i = 0; i < kTfTableSize; ++i)
    if (t.lo + (t.hi - t.lo) * i / (kTfTableSize - 1) >= 0) t.rgba[4 * i + 3] = kAlpha;
  return t;
}

/// n^3 voxels of 1 mm (identity direction, origin 0), air; `inside(i, j, k)` voxels at 100.
template <class F>
AnyVolume volume(int n, F inside) {
  Geometry g;
  g.dims = {n, n, n};
  VolumeI16 v(g, -1000, -1000);
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        if (inside(i, j, k)) v(i, j, k) = 100;
  return v;
}

float transmittance(const LightVolume& lv, int i, int j, int k) {
  return lv.rg[2 * size_t((k * lv.dims.y + j) * lv.dims.x + i)] / 255.f;
}
float openness(const LightVolume& lv, int i, int j, int k) {
  return lv.rg[2 * size_t((k * lv.dims.y + j) * lv.dims.x + i) + 1] / 255.f;
}

TEST(LightVolume, SlabLitAlongAnAxisAttenuatesByBeerLambert) {
  const AnyVolume v = volume(32, [](int, int, int k) { return k < 16; });
  const LightVolume lv = computeLightVolume(makeLightSource(v), stepTable(), kStepMm, {0, 0, 1}, Lighting{});
  ASSERT_EQ(lv.factor, 1);
  for (int k : {15, 12, 8, 2}) {
    // Midpoint rule between cell centres: depth 15.5 - k mm below the slab's top face.
    const double expected = std::exp(-kSigma * (15.5 - k));
    EXPECT_NEAR(transmittance(lv, 16, 16, k), expected, 0.003) << "k " << k;
  }
  EXPECT_FLOAT_EQ(transmittance(lv, 16, 16, 20), 1.f);  // air above the slab
  EXPECT_NEAR(lv.towardsLight.z, 1.0, 1e-12);
}

TEST(LightVolume, ObliqueLightTravelsTheLongerPath) {
  const AnyVolume v = volume(32, [](int, int, int k) { return k < 16; });
  const Vec3 dir = Vec3{1, 0, 1} * (1 / std::sqrt(2.0));  // 45 degrees
  const LightVolume lv = computeLightVolume(makeLightSource(v), stepTable(), kStepMm, dir, Lighting{});
  for (int k : {14, 10, 6}) {
    const double expected = std::exp(-kSigma * std::sqrt(2.0) * (15.5 - k));
    EXPECT_NEAR(transmittance(lv, 8, 16, k), expected, 0.004) << "k " << k;
  }
}

TEST(LightVolume, AnOpaqueBallCastsAnUmbra) {
  // A floor (k < 6) and a ball of radius 5 above it; opaque: alpha 0.95 per 0.5 mm.
  TfTable opaque = stepTable();
  for (int i = 0; i < kTfTableSize; ++i)
    if (opaque.rgba[4 * i + 3] > 0) opaque.rgba[4 * i + 3] = 0.95f;
  const AnyVolume v = volume(40, [](int i, int j, int k) {
    return k < 6 || std::hypot(i - 20.0, j - 20.0, k - 20.0) <= 5;
  });
  const LightVolume lv = computeLightVolume(makeLightSource(v), opaque, kStepMm, {0, 0, 1}, Lighting{});
  EXPECT_LT(transmittance(lv, 20, 20, 8), 0.01);  // in the air under the ball
  EXPECT_LT(transmittance(lv, 20, 20, 5), 0.01);  // on the floor in the umbra
  EXPECT_GT(transmittance(lv, 5, 5, 8), 0.99);    // air beside it
  EXPECT_GT(transmittance(lv, 5, 5, 5), 0.0);      // the floor's top cell: half a cell of floor
  EXPECT_NEAR(transmittance(lv, 5, 5, 5), std::exp(0.5 * std::log(0.05) / kStepMm), 0.003);
}

TEST(LightVolume, OpennessIsOneOnAFlatFloorAndLessInACorner) {
  TfTable opaque = stepTable();
  for (int i = 0; i < kTfTableSize; ++i)
    if (opaque.rgba[4 * i + 3] > 0) opaque.rgba[4 * i + 3] = 0.95f;
  // A floor (k < 16) and a wall (i < 10) meeting in a concave edge.
  const AnyVolume v = volume(40, [](int i, int, int k) { return k < 16 || i < 10; });
  Lighting l;
  l.occlusionRadiusMm = 6;
  const LightVolume lv = computeLightVolume(makeLightSource(v), opaque, kStepMm, {0, 0, 1}, l);
  const float floor = openness(lv, 28, 20, 16), corner = openness(lv, 10, 20, 16), air = openness(lv, 30, 20, 34);
  EXPECT_GT(floor, 0.9f);  // the air cell just above a flat floor: about half occupied around it
  EXPECT_LT(corner, floor - 0.2f);
  EXPECT_FLOAT_EQ(air, 1.f);
}

TEST(LightVolume, KeyLightTurnsWithTheCamera) {
  Frame f;
  f.right = {1, 0, 0};
  f.up = {0, 0, 1};
  f.forward = {0, 1, 0};  // looking from anterior
  Lighting l;
  l.azimuthDeg = 0;
  l.elevationDeg = 0;
  Vec3 d = keyLightDirection(f, l);
  EXPECT_NEAR(d.y, -1.0, 1e-12);  // from the eye
  l.azimuthDeg = -90;
  d = keyLightDirection(f, l);
  EXPECT_NEAR(d.x, -1.0, 1e-12);  // from the left of the view
  l.elevationDeg = 90;
  d = keyLightDirection(f, l);
  EXPECT_NEAR(d.z, 1.0, 1e-12);  // from the top
}

}  // namespace
}  // namespace vellum::render::detail
