// MapSampler: the backward map at arbitrary output positions (the studio's slice pixels)
// against upsampleMap() at the voxels, and against analytic maps between them.
#include <gtest/gtest.h>

#include <algorithm>
#include <iostream>
#include <random>

#include "vellum/core/error.hpp"
#include "vellum/deformation/deformer.hpp"
#include "vellum/deformation/placement.hpp"
#include "vellum/deformation/rigidity.hpp"
#include "vellum/deformation/synthesis.hpp"
#include "vellum/phantom/phantom.hpp"

using namespace vellum;
using namespace vellum::deformation;

namespace {

struct Bent {
  phantom::Phantom ph;
  ControlVolume cv;  ///< the knee bend with the rigid bones (node blend + voxel snap)
};

const Bent& bentKnee() {
  static const Bent b = [] {
    phantom::PhantomOptions o;
    o.dims = {48, 48, 54};
    Bent k{phantom::makePhantom(o), {}};
    const KeyframeTrack track = kneeBendTrack(k.ph.ct.geometry(), 30.0, 2.0, phantom::flexionAxisPointMm());
    DeformParams p;
    p.controlScale = 4;
    k.cv = computeControlVolume(AnyVolume(k.ph.ct), track.keyframes[1].points, p);
    applyRigidity(k.cv, RigidBodies::fromLabels(k.ph.labels, {4, 5, 6, 7, 8, 9, 11}));
    return k;
  }();
  return b;
}

Vec3 at(const std::vector<float>& map, const Dims& d, int64_t i, int64_t j, int64_t k) {
  const size_t n = static_cast<size_t>((k * d.y + j) * d.x + i) * 3;
  return {map[n], map[n + 1], map[n + 2]};
}

}  // namespace

TEST(MapSampler, EqualsUpsampleMapAtEveryVoxelWithTheRigidSnap) {
  const Bent& k = bentKnee();
  const Geometry& g = k.ph.ct.geometry();
  ASSERT_TRUE(k.cv.rigidSnap);
  ControlVolume noSnap = k.cv;
  noSnap.rigidSnap.reset();
  for (const Upsampling up : {Upsampling::Trilinear, Upsampling::Gaussian}) {
    const MapSampler sampler(k.cv, g, up);
    const std::vector<float> full = upsampleMap(k.cv, g, up), raw = upsampleMap(noSnap, g, up);
    double maxMm = 0;
    int64_t snapped = 0;
    for (int64_t z = 0; z < g.dims.z; ++z)
      for (int64_t y = 0; y < g.dims.y; ++y)
        for (int64_t x = 0; x < g.dims.x; ++x) {
          const auto u = sampler.sourceMm(g.indexToPhysical({double(x), double(y), double(z)}));
          ASSERT_TRUE(u);
          const Vec3 ref = at(full, g.dims, x, y, z);
          maxMm = std::max(maxMm, norm(*u - ref));
          snapped += norm(ref - at(raw, g.dims, x, y, z)) > 1e-3;
        }
    std::cout << "[ sampler ] " << upsamplingName(up) << ": max |u - upsampleMap| " << maxMm << " mm, snapped voxels "
              << snapped << "\n";
    // Float rounding only (the sums run in another order for the x axis); a voxel whose
    // source lies exactly on a class boundary could flip, hence not 0.
    EXPECT_LT(maxMm, 1e-4) << upsamplingName(up);
    EXPECT_GT(snapped, 50);  // the snap is exercised
  }
}

TEST(MapSampler, TrilinearIsLinearBetweenNeighbouringVoxels) {
  // Nodes sit on voxels, so along an axis the trilinear map is linear between two
  // neighbouring voxel centres: the midpoint gives their mean (away from the snap).
  const Bent& k = bentKnee();
  const Geometry& g = k.ph.ct.geometry();
  ControlVolume noSnap = k.cv;
  noSnap.rigidSnap.reset();
  const MapSampler sampler(noSnap, g);
  const std::vector<float> full = upsampleMap(noSnap, g);
  double maxMm = 0;
  for (int64_t z = 0; z < g.dims.z; z += 3)
    for (int64_t y = 0; y < g.dims.y; y += 2)
      for (int64_t x = 0; x + 1 < g.dims.x; ++x) {
        const auto u = sampler.sourceMm(g.indexToPhysical({x + 0.5, double(y), double(z)}));
        ASSERT_TRUE(u);
        const Vec3 mean = (at(full, g.dims, x, y, z) + at(full, g.dims, x + 1, y, z)) * 0.5;
        maxMm = std::max(maxMm, norm(*u - mean));
      }
  EXPECT_LT(maxMm, 1e-4);
}

TEST(MapSampler, AffineMapsAreExactAnywhereAndOutsideIsNone) {
  Geometry g;
  g.dims = {21, 17, 13};
  g.spacing = {1.5, 2, 2.5};
  g.origin = {-10, 5, 3};
  ControlVolume cv = identityControlVolume(g, 4);
  const auto affine = [](const Vec3& v) {
    return Vec3{1.1 * v.x + 0.2 * v.y + 3, -0.1 * v.x + 0.9 * v.z - 2, 0.3 * v.y + 1.05 * v.z};
  };
  for (size_t n = 0; n < cv.sourceMm.size(); n += 3) {
    const Vec3 u = affine(cv.sourceAt(static_cast<int64_t>(n / 3)));
    cv.sourceMm[n] = float(u.x), cv.sourceMm[n + 1] = float(u.y), cv.sourceMm[n + 2] = float(u.z);
  }
  std::mt19937 rng(3);
  for (const Upsampling up : {Upsampling::Trilinear, Upsampling::Gaussian}) {
    const MapSampler sampler(cv, g, up);
    double maxMm = 0;
    for (int t = 0; t < 2000; ++t) {
      const Vec3 idx{std::uniform_real_distribution<double>(0, g.dims.x - 1)(rng),
                     std::uniform_real_distribution<double>(0, g.dims.y - 1)(rng),
                     std::uniform_real_distribution<double>(0, g.dims.z - 1)(rng)};
      const Vec3 mm = g.indexToPhysical(idx);
      const auto u = sampler.sourceMm(mm);
      ASSERT_TRUE(u);
      maxMm = std::max(maxMm, norm(*u - affine(mm)));
    }
    EXPECT_LT(maxMm, 1e-4) << upsamplingName(up);
    // Half a voxel beyond the outer centres: clamped onto them; beyond that: nothing.
    const auto rim = sampler.sourceMm(g.indexToPhysical({-0.4, 3, 4}));
    ASSERT_TRUE(rim);
    EXPECT_LT(norm(*rim - affine(g.indexToPhysical({0, 3, 4}))), 1e-4);
    EXPECT_FALSE(sampler.sourceMm(g.indexToPhysical({-0.6, 3, 4})));
    EXPECT_FALSE(sampler.sourceMm(g.indexToPhysical({3, 3, g.dims.z - 0.4})));
  }
  EXPECT_THROW(MapSampler(cv, [&] { Geometry h = g; h.dims.x += 9; return h; }()), Error);
}

TEST(MapSampler, RowsEqualPointByPointSampling) {
  // Rows along each grid axis (the fast path: two axes blended once) and an oblique row (point
  // by point), crossing the volume's border (no position exactly on it), with the rigid snap.
  const Bent& k = bentKnee();
  const Geometry& g = k.ph.ct.geometry();
  const Vec3 sp = g.spacing;
  const std::vector<std::pair<Vec3, Vec3>> rows{
      {g.indexToPhysical({-3.35, 20.25, 30}), {0.7 * sp.x, 0, 0}},
      {g.indexToPhysical({17.5, -2.05, 25.5}), {0, 0.9 * sp.y, 0}},
      {g.indexToPhysical({24, 26.4, -4}), {0, 0, 1.1 * sp.z}},
      {g.indexToPhysical({-2, 3, 5}), {0.6 * sp.x, 0.5 * sp.y, 0.7 * sp.z}}};
  for (const Upsampling up : {Upsampling::Trilinear, Upsampling::Gaussian}) {
    const MapSampler sampler(k.cv, g, up);
    for (const auto& [first, step] : rows) {
      const int n = 80;
      std::vector<float> out(3 * n, -7.f);
      std::vector<uint8_t> inside(n, 2);
      sampler.sourceMmRow(first, step, n, out.data(), inside.data());
      int in = 0;
      for (int i = 0; i < n; ++i) {
        const auto u = sampler.sourceMm(first + step * double(i));
        ASSERT_EQ(bool(inside[i]), bool(u)) << upsamplingName(up) << " position " << i;
        if (!u) continue;
        ++in;
        EXPECT_LT(norm(*u - Vec3{out[3 * i], out[3 * i + 1], out[3 * i + 2]}), 1e-4) << upsamplingName(up) << " " << i;
      }
      EXPECT_GT(in, 20);
      EXPECT_LT(in, n);  // the row leaves the volume
    }
  }
}
