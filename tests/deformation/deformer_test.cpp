// The engine over grids: control volume, density-aware weights and the rho cache, synthesis.
#include <gtest/gtest.h>

#include "test_helpers.hpp"
#include "vellum/core/box_corners.hpp"
#include "vellum/deformation/deformer.hpp"
#include "vellum/deformation/synthesis.hpp"

using namespace vellum;
using namespace vellum::deformation;
using namespace vellum::deformation::test;

namespace {

// Bounding box (mm) of a volume's corners.
std::pair<Vec3, Vec3> boxOf(const Geometry& g) {
  Vec3 lo{1e30, 1e30, 1e30}, hi{-1e30, -1e30, -1e30};
  const Dims& d = g.dims;
  for (const Vec3& p : indexBoxCorners(g, {0, 0, 0}, {double(d.x - 1), double(d.y - 1), double(d.z - 1)}))
    for (int a = 0; a < 3; ++a) { lo[a] = std::min(lo[a], p[a]); hi[a] = std::max(hi[a], p[a]); }
  return {lo, hi};
}

DeformParams densityParams(RayMode rays, bool cache) {
  DeformParams p;
  p.density.enabled = true;
  p.density.rays = rays;
  p.density.rhoCache = cache;
  p.density.iterations = 3;
  return p;
}

}  // namespace

TEST(Deformer, AffineTargetsGiveExactInverseOnAnisotropicGridsWithAndWithoutDensity) {
  const VolumeI16 ct = analyticCt();
  const AnyVolume vol = ct;
  const auto [lo, hi] = boxOf(ct.geometry());
  const auto src = spreadPoints(lo, hi);
  const Affine a = someAffine();
  std::vector<Vec3> tgt;
  for (const auto& x : src) tgt.push_back(a.apply(x));
  const auto cp = pointsFrom(src, tgt);
  const auto vs = randomPositions(lo, hi, 800);

  std::vector<DeformParams> variants(1);
  variants.push_back(densityParams(RayMode::Linear, true));
  variants.push_back(densityParams(RayMode::Conic, true));
  variants.push_back(densityParams(RayMode::Linear, false));
  for (double n : {2.0, 3.0, 4.0}) {
    for (auto params : variants) {
      params.mls.power = n;
      params.controlScale = 2;
      Deformer d(vol, params);
      d.setPoints(cp);
      const auto u = d.mapPoints(vs);
      for (size_t i = 0; i < vs.size(); ++i)
        ASSERT_LT(norm(u[i] - a.inverse(vs[i])), 1e-6) << "n=" << n << " density=" << params.density.enabled;
      const ControlVolume& cv = d.update();
      const Geometry& g = cv.grid;
      double worst = 0;
      for (int64_t k = 0; k < g.dims.z; ++k)
        for (int64_t j = 0; j < g.dims.y; ++j)
          for (int64_t i = 0; i < g.dims.x; ++i) {
            const Vec3 v = g.indexToPhysical({double(i), double(j), double(k)});
            worst = std::max(worst, norm(cv.sourceAt((k * g.dims.y + j) * g.dims.x + i) - a.inverse(v)));
          }
      EXPECT_LT(worst, 1e-4) << "float storage; n=" << n;
    }
  }
}

TEST(Deformer, IdentityPointsGiveIdentityControlVolumeAndUnchangedVolume) {
  const VolumeI16 ct = analyticCt();
  const AnyVolume vol = ct;
  const auto [lo, hi] = boxOf(ct.geometry());
  const auto src = spreadPoints(lo, hi);
  for (int s : {1, 2, 4}) {
    DeformParams p = densityParams(RayMode::Conic, true);
    p.controlScale = s;
    const ControlVolume cv = computeControlVolume(vol, pointsFrom(src, src), p);
    const ControlVolume id = identityControlVolume(ct.geometry(), s);
    ASSERT_EQ(cv.sourceMm.size(), id.sourceMm.size());
    for (size_t t = 0; t < cv.sourceMm.size(); ++t) ASSERT_NEAR(cv.sourceMm[t], id.sourceMm[t], 1e-4);
    for (Upsampling up : {Upsampling::Trilinear, Upsampling::Gaussian}) {
      const auto out = std::get<VolumeI16>(synthesize(vol, cv, up));
      EXPECT_EQ(out.voxels(), ct.voxels()) << "s=" << s << " " << upsamplingName(up);
      EXPECT_TRUE(out.geometry().approxEqual(ct.geometry()));
    }
  }
}

TEST(Deformer, SynthesisFetchesTheSourceAtTheMappedPosition) {
  const VolumeI16 ct = analyticCt();
  const AnyVolume vol = ct;
  const auto [lo, hi] = boxOf(ct.geometry());
  const auto src = spreadPoints(lo, hi);
  // Output voxel (i,j,k) shows source voxel (i+1, j, k): targets = sources - one voxel along i.
  const Vec3 di = ct.geometry().direction.column(0) * ct.geometry().spacing.x;
  std::vector<Vec3> tgt;
  for (const auto& x : src) tgt.push_back(x - di);
  DeformParams p;
  p.controlScale = 2;
  const auto out = std::get<VolumeI16>(synthesize(vol, computeControlVolume(vol, pointsFrom(src, tgt), p)));
  const Dims d = ct.dims();
  for (int64_t k = 0; k < d.z; ++k)
    for (int64_t j = 0; j < d.y; ++j)
      for (int64_t i = 0; i < d.x; ++i)
        ASSERT_EQ(out(i, j, k), i + 1 < d.x ? ct(i + 1, j, k) : -1000) << i << "," << j << "," << k;
}

TEST(Deformer, CoarseControlVolumeIsCloseToFullResolution) {
  const VolumeI16 ct = analyticCt({64, 60, 48}, {1.0, 1.0, 1.5}, false);
  const AnyVolume vol = ct;
  const auto [lo, hi] = boxOf(ct.geometry());
  const auto src = spreadPoints(lo, hi);
  std::vector<Vec3> tgt = src;
  tgt[5] += Vec3{6, -4, 3};
  tgt[10] += Vec3{-5, 5, 0};
  const auto cp = pointsFrom(src, tgt);
  DeformParams p;
  p.controlScale = 1;
  const AnyVolume ref = synthesize(vol, computeControlVolume(vol, cp, p));
  for (int s : {2, 4}) {
    p.controlScale = s;
    const double db = psnr(ref, synthesize(vol, computeControlVolume(vol, cp, p)));
    EXPECT_GT(db, s == 2 ? 35.0 : 28.0) << "s=" << s;
  }
  EXPECT_TRUE(std::isinf(psnr(ref, ref)));
}

TEST(Deformer, RhoCacheRebuildsOnlyFieldsWhoseSourceMoved) {
  const VolumeI16 ct = analyticCt();
  const AnyVolume vol = ct;
  const auto [lo, hi] = boxOf(ct.geometry());
  const auto src = spreadPoints(lo, hi);
  DeformParams p = densityParams(RayMode::Conic, true);
  p.controlScale = 4;
  Deformer d(vol, p);
  auto cp = pointsFrom(src, src);
  d.setPoints(cp);
  d.update();
  EXPECT_EQ(d.timings().rhoFieldsRebuilt, 16);
  cp[3].target += Vec3{5, 0, 0};  // dragging a target: no ray casting
  cp[7].target += Vec3{0, -4, 2};
  d.setPoints(cp);
  d.update();
  EXPECT_EQ(d.timings().rhoFieldsRebuilt, 0);
  const ControlVolume dragged = d.controlVolume();
  cp[2].source += Vec3{1, 1, 0};
  d.setPoints(cp);
  d.update();
  EXPECT_EQ(d.timings().rhoFieldsRebuilt, 1);
  // The cached fields give the same map as a fresh engine.
  const ControlVolume fresh = computeControlVolume(vol, cp, p);
  ASSERT_EQ(fresh.sourceMm.size(), d.controlVolume().sourceMm.size());
  for (size_t t = 0; t < fresh.sourceMm.size(); ++t)
    ASSERT_NEAR(fresh.sourceMm[t], d.controlVolume().sourceMm[t], 1e-4);
  EXPECT_NE(dragged.sourceMm, fresh.sourceMm);
}

TEST(Density, RhoIsSegmentLengthInHomogeneousRegionsAndGrowsThroughBone) {
  Geometry g;
  g.dims = {40, 40, 40};
  g.spacing = {1.0, 2.0, 1.0};
  VolumeI16 v(g, 40, -1000);
  for (int64_t k = 0; k < 40; ++k)
    for (int64_t j = 0; j < 40; ++j)
      for (int64_t i = 18; i < 22; ++i) v(i, j, k) = 1400;  // a dense wall across x
  for (RayMode rays : {RayMode::Linear, RayMode::Conic}) {
    DensityParams p;
    p.rays = rays;
    p.lengthNormalisedRho = false;  // the paper's rho
    const DensityVolume dv(AnyVolume(v), p);
    p.lengthNormalisedRho = true;
    const DensityVolume dn(AnyVolume(v), p);
    EXPECT_NEAR(dn.rho({5, 5, 5}, {5, 15, 5}), 1.0, 1e-5);
    EXPECT_GT(dn.rho({5, 20, 20}, {35, 20, 20}), 1.1);
    // Homogeneous soft tissue, anisotropic: 10 voxels along y = 20 mm.
    EXPECT_NEAR(dv.rho({5, 5, 5}, {5, 15, 5}), 20.0, 1e-4);  // float density
    // Across the wall: more than the 30 mm length, by about wall * (I_bone/I_soft - 1).
    const double across = dv.rho({5, 20, 20}, {35, 20, 20});
    const double iSoft = 1040.0 / 3000.0, iBone = 2400.0 / 3000.0;
    EXPECT_GT(across, 30.0 + 3.0 * (iBone / iSoft - 1.0)) << rayModeName(rays);
    EXPECT_LT(across, 30.0 + 5.0 * (iBone / iSoft - 1.0)) << rayModeName(rays);
  }
  DensityParams none;
  none.phi = PhiRule::None;
  none.lengthNormalisedRho = false;
  const DensityVolume dv(AnyVolume(v), none);
  EXPECT_NEAR(dv.rho({5, 5, 5}, {5, 15, 5}), 20.0 * 1040.0 / 3000.0, 1e-4);
}

TEST(Deformer, SinglePrecisionGridAgreesWithTheDoubleMap) {
  const VolumeI16 ct = analyticCt({48, 44, 40}, {1.2, 1.2, 2.0}, true);
  const AnyVolume vol = ct;
  const auto [lo, hi] = boxOf(ct.geometry());
  const auto src = spreadPoints(lo, hi);
  std::vector<Vec3> tgt;
  std::mt19937 rng(9);
  std::normal_distribution<double> nd(0, 7);
  for (const auto& x : src) tgt.push_back(x + Vec3{nd(rng), nd(rng), nd(rng)});
  for (double n : {2.0, 4.0}) {
    for (bool single : {true, false}) {
      DeformParams p;
      p.mls.power = n;
      p.singlePrecisionGrid = single;
      Deformer d(vol, p);
      d.setPoints(pointsFrom(src, tgt));
      const ControlVolume& cv = d.update();
      std::vector<Vec3> nodes;
      const Geometry& g = cv.grid;
      for (int64_t k = 0; k < g.dims.z; ++k)
        for (int64_t j = 0; j < g.dims.y; ++j)
          for (int64_t i = 0; i < g.dims.x; ++i) nodes.push_back(g.indexToPhysical({double(i), double(j), double(k)}));
      const auto ref = d.mapPoints(nodes);
      double worst = 0;
      for (size_t t = 0; t < nodes.size(); ++t) worst = std::max(worst, norm(cv.sourceAt(int64_t(t)) - ref[t]));
      EXPECT_LT(worst, single ? 2e-3 : 1e-4) << "n=" << n << " single=" << single;
    }
  }
}
