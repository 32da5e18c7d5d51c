// The renderer's map sampling (PreparedMap: the CPU reference, and the GL shader's oracle)
// against CPU synthesis' upsampleMap(): at every output voxel v (map node index v / s) both
// must give the same source position, for both kernels, with and without the rigid snap.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>

#include "map_sampling.hpp"
#include "scene.hpp"
#include "vellum/animation/movie.hpp"
#include "vellum/core/error.hpp"
#include "vellum/deformation/synthesis.hpp"

using namespace vellum;
using namespace vellum::deformation;

namespace {

struct MapDiff {
  double maxMm = 0;
  int64_t snappedVoxels = 0;  ///< voxels where the snap changed u (by more than 1e-3 mm)
};

// Largest |renderer u - upsampleMap u| over every `stride`-th output voxel.
MapDiff compareWithSynthesis(const ControlVolume& cv, const Geometry& g, Upsampling up, int stride) {
  const render::BackwardMap map = deformation::renderedMap(cv, g, up);
  const render::detail::PreparedMap pm = render::detail::prepareMap(map, g);
  const std::vector<float> full = upsampleMap(cv, g, up);
  ControlVolume noSnap = cv;
  noSnap.rigidSnap.reset();
  const std::vector<float> unsnapped = upsampleMap(noSnap, g, up);
  MapDiff d;
  const double s = cv.scale;
  for (int64_t k = 0; k < g.dims.z; k += stride)
    for (int64_t j = 0; j < g.dims.y; j += stride)
      for (int64_t i = 0; i < g.dims.x; i += stride) {
        const Vec3 u = g.indexToPhysical(pm.at({i / s, j / s, k / s}));
        const size_t n = static_cast<size_t>((k * g.dims.y + j) * g.dims.x + i) * 3;
        const Vec3 ref{full[n], full[n + 1], full[n + 2]};
        const Vec3 raw{unsnapped[n], unsnapped[n + 1], unsnapped[n + 2]};
        d.maxMm = std::max(d.maxMm, norm(u - ref));
        d.snappedVoxels += norm(ref - raw) > 1e-3;
      }
  return d;
}

}  // namespace

TEST(WysiwygMap, RendererSamplesTheMapSynthesisResamplesWith) {
  const test::BentKnee k = test::makeBentKnee(64, 2);
  const Geometry& g = k.ph.ct.geometry();
  ASSERT_TRUE(k.rigid.rigidSnap);
  for (const Upsampling up : {Upsampling::Trilinear, Upsampling::Gaussian})
    for (const ControlVolume* cv : {&k.plain, &k.rigid}) {
      const MapDiff d = compareWithSynthesis(*cv, g, up, 1);
      std::cout << "[ map  ] " << upsamplingName(up) << (cv->rigidSnap ? " + snap" : "") << ": max |u_render - u_synthesis| "
                << d.maxMm << " mm, snapped voxels " << d.snappedVoxels << "\n";
      // Float rounding only (positions of about 100 mm in float: ~1e-5 mm; the class lookup and
      // the snap threshold can flip on a voxel exactly at a boundary, hence a small tolerance
      // that is still far below the 0.45 mm the unsnapped map is off).
      EXPECT_LT(d.maxMm, 5e-4) << upsamplingName(up);
      if (cv->rigidSnap) EXPECT_GT(d.snappedVoxels, 100);  // the snap is exercised
    }
}

// The twist kernel (a movie frame of the twist map): each sample turned by its interpolated
// weight, in the renderer's CPU twin as in synthesis, with the snap.
TEST(WysiwygMap, RendererSamplesTheTwistKernelAsSynthesisDoes) {
  const test::TwistKnee k = test::makeTwistKnee(64, 2);
  const Geometry& g = k.ph.ct.geometry();
  ASSERT_TRUE(k.frame->twist);
  ASSERT_TRUE(k.frame->rigidSnap);
  const MapDiff d = compareWithSynthesis(*k.frame, g, Upsampling::Trilinear, 1);
  std::cout << "[ map  ] twist kernel + snap: max |u_render - u_synthesis| " << d.maxMm << " mm, snapped voxels "
            << d.snappedVoxels << "\n";
  EXPECT_LT(d.maxMm, 5e-4);
  EXPECT_GT(d.snappedVoxels, 100);
  // Interpolating the nodes' positions instead is another map (its chords): the kernel is used.
  ControlVolume positions = *k.frame;
  positions.twist.reset();
  const std::vector<float> a = upsampleMap(*k.frame, g), b = upsampleMap(positions, g);
  float most = 0;
  for (size_t i = 0; i < a.size(); ++i) most = std::max(most, std::abs(a[i] - b[i]));
  EXPECT_GT(most, 1e-3);
}

TEST(WysiwygMap, GaussianReproducesAnAffineMapUpToTheBorder) {
  // Affine maps are exact under both kernels (moment-corrected weights, linear extrapolation
  // past the edge nodes), also between voxels and in the half-node margin clamp.
  Geometry g;
  g.dims = {9, 7, 5};
  g.spacing = {2, 3, 4};
  g.origin = {-5, 4, 1};
  render::BackwardMap map;
  map.grid = g;
  map.upsampling = Upsampling::Gaussian;
  auto affine = [](const Vec3& v) { return Vec3{1.1 * v.x + 0.2 * v.y + 3, -0.1 * v.x + 0.9 * v.z - 2, 0.3 * v.y + 1.05 * v.z}; };
  for (int64_t k = 0; k < g.dims.z; ++k)
    for (int64_t j = 0; j < g.dims.y; ++j)
      for (int64_t i = 0; i < g.dims.x; ++i) {
        const Vec3 u = affine(g.indexToPhysical({double(i), double(j), double(k)}));
        map.sourceMm.insert(map.sourceMm.end(), {float(u.x), float(u.y), float(u.z)});
      }
  Geometry source = g;  // source index = source mm through this geometry
  source.dims = {40, 40, 40};
  const render::detail::PreparedMap pm = render::detail::prepareMap(map, source);
  double worst = 0;
  for (double z = 0; z <= 4; z += 0.37)
    for (double y = 0; y <= 6; y += 0.41)
      for (double x = 0; x <= 8; x += 0.29) {
        const Vec3 u = source.indexToPhysical(pm.at({x, y, z}));
        worst = std::max(worst, norm(u - affine(g.indexToPhysical({x, y, z}))));
      }
  EXPECT_LT(worst, 1e-4);
}

TEST(WysiwygMap, TooManySnapBodiesIsANamedError) {
  render::BackwardMap map = render::identityBackwardMap(Geometry{{4, 4, 4}, {1, 1, 1}, {0, 0, 0}, Mat3::identity()});
  auto snap = std::make_shared<RigidSnap>();
  snap->classGrid = map.grid;
  snap->classes = std::make_shared<std::vector<uint16_t>>(64, 0);
  snap->fits.resize(render::kMaxSnapBodies + 1);
  map.rigidSnap = snap;
  try {
    (void)render::detail::prepareMap(map, map.grid);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("at most 64"), std::string::npos) << e.what();
  }
}

// A held body (RigidSnap::held: a fixed region) keeps its place whatever the
// interpolated map says there, on the CPU sampler as in the shader (deformedSource()); the rest
// keeps the map or the ordinary snap; only the identity may be held.
TEST(WysiwygMap, AHeldBodyKeepsItsPlaceWhateverTheMapSays) {
  const Geometry g{{8, 8, 8}, {1, 1, 1}, {0, 0, 0}, Mat3::identity()};
  render::BackwardMap map = render::identityBackwardMap(g);
  for (size_t n = 0; n < map.sourceMm.size(); n += 3) map.sourceMm[n] += 3;  // u = v + 3 mm along x
  auto snap = std::make_shared<RigidSnap>();
  snap->classGrid = g;
  auto classes = std::make_shared<std::vector<uint16_t>>(512, 1);
  for (size_t n = 0; n < classes->size(); ++n)
    if (n % 8 >= 4) (*classes)[n] = 2;  // body 0: x >= 4
  snap->classes = classes;
  snap->fits = {{1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0}};
  snap->valid = {1};
  snap->maxSnapMm = 0.5;
  snap->held = {1};
  map.rigidSnap = snap;
  const render::detail::PreparedMap held = render::detail::prepareMap(map, g);
  int body = -2;
  EXPECT_EQ(held.at({5, 2, 3}, &body), (Vec3{5, 2, 3})) << "a held voxel follows the map";
  EXPECT_EQ(body, 0);
  EXPECT_EQ(held.at({1, 2, 3}, &body), (Vec3{4, 2, 3})) << "tissue beside it must keep the map";
  EXPECT_EQ(body, -1);

  snap->held.clear();
  const render::detail::PreparedMap loose = render::detail::prepareMap(map, g);
  EXPECT_EQ(loose.at({5, 2, 3}), (Vec3{8, 2, 3}));

  snap->held = {1};
  snap->fits[0][9] = 1;  // a translation cannot be held
  try {
    (void)render::detail::prepareMap(map, g);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("identity"), std::string::npos) << e.what();
  }
}

