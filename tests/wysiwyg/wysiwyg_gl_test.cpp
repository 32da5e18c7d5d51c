// What you see is what you export: the GL frame of a deformed, attributed, rigid-bone scene
// (source + node map + voxel snap + Gaussian upsampling) against (a) the CPU reference ray
// caster given the same map, (b) the GL frame of the CPU-synthesised deformed volume with an
// identity map carrying the same attributes, and (c) the rigid truth of each bone.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>

#include "image_compare.hpp"
#include "render_common.hpp"
#include "scene.hpp"
#include "vellum/animation/movie.hpp"
#include "vellum/deformation/synthesis.hpp"
#include "vellum/render/volume_renderer.hpp"

using namespace vellum;
using namespace vellum::deformation;

namespace {

render::GlContext& gl() {
  static std::unique_ptr<render::GlContext> context = render::GlContext::createHeadless();
  return *context;
}

const test::BentKnee& knee() {
  static const test::BentKnee k = test::makeBentKnee(72, 2);
  return k;
}

render::RenderSettings sideView(int size = 128) {
  render::RenderSettings s;
  s.width = s.height = size;
  s.camera.azimuthDeg = 90;  // the bend is about the medio-lateral axis
  s.camera.elevationDeg = 5;
  return s;
}

double report(const RgbaImage& a, const RgbaImage& b, const std::string& what) {
  const test::ImageDiff d = test::compareImages(a, b);
  std::cout << "[ diff ] " << what << ": mean " << d.meanAbs[0] << " " << d.meanAbs[1] << " " << d.meanAbs[2]
            << "  max " << d.maxAbs << "  psnr " << d.psnr << " dB\n";
  return d.psnr;
}

}  // namespace

// (a) The CPU reference is the GL path's oracle: same map, snap, kernel and attributes.
TEST(WysiwygGl, GlMatchesTheCpuReferenceWithSnapAndAttributes) {
  const test::BentKnee& k = knee();
  const AnyVolume ct = k.ph.ct;
  ASSERT_FALSE(k.rigid.attributes.empty());
  render::VolumeRenderer renderer(gl());
  renderer.setVolume(ct);
  for (const Upsampling up : {Upsampling::Trilinear, Upsampling::Gaussian})
    for (const render::Preset preset : {render::Preset::SoftTissueBone, render::Preset::Mip}) {
      render::RenderSettings s = sideView();
      s.preset = preset;
      const render::BackwardMap map = deformation::renderedMap(k.rigid, k.ph.ct.geometry(), up);
      ASSERT_TRUE(map.rigidSnap);
      renderer.setBackwardMap(&map);
      const RgbaImage frame = renderer.render(s);
      const std::string what = std::string("GL vs CPU reference, ") + upsamplingName(up) + " + snap, " +
                               render::presetName(preset);
      EXPECT_GE(report(frame, render::renderReferenceCpu(ct, s, &map), what), 40.0) << what;
    }
}

// The twist kernel (a twist-map movie frame: weights interpolated, each sample turned, then
// the snap): the shader's mapAt() against PreparedMap's, shaded (normals turned by the kernel's
// Jacobian) and MIP.
TEST(WysiwygGl, GlMatchesTheCpuReferenceWithTheTwistKernel) {
  const test::TwistKnee k = test::makeTwistKnee(72, 2);
  ASSERT_TRUE(k.frame->twist);
  const AnyVolume ct = k.ph.ct;
  render::VolumeRenderer renderer(gl());
  renderer.setVolume(ct);
  const render::BackwardMap map = deformation::renderedMap(*k.frame, k.ph.ct.geometry());
  renderer.setBackwardMap(&map);
  for (const render::Preset preset : {render::Preset::SoftTissueBone, render::Preset::Mip}) {
    render::RenderSettings s = sideView();
    s.preset = preset;
    const std::string what = std::string("GL vs CPU reference, twist kernel + snap, ") + render::presetName(preset);
    // Shaded, 55 dB (llvmpipe 90, the H200 66): the weights' gradient turns the normals, and
    // a shader without it (R alone) scored 47 dB.
    EXPECT_GE(report(renderer.render(s), render::renderReferenceCpu(ct, s, &map), what),
              preset == render::Preset::Mip ? 40.0 : 55.0) << what;
  }
}

// (b) Live deformed render = render of the exported deformed volume with the attributes.
TEST(WysiwygGl, LiveFrameMatchesTheSynthesisedVolumeWithItsAttributes) {
  const test::BentKnee& k = knee();
  const AnyVolume ct = k.ph.ct;
  render::VolumeRenderer renderer(gl());
  for (const Upsampling up : {Upsampling::Gaussian, Upsampling::Trilinear}) {
    render::RenderSettings s = sideView();
    s.shading = false;  // normals: source gradient at u vs gradient of the deformed volume
    renderer.setVolume(ct);
    const render::BackwardMap live = deformation::renderedMap(k.rigid, k.ph.ct.geometry(), up);
    renderer.setBackwardMap(&live);
    const RgbaImage liveFrame = renderer.render(s);
    renderer.setVolume(synthesize(ct, k.rigid, up));
    const render::BackwardMap identity = render::identityBackwardMap(k.rigid.grid, k.rigid.attributes, k.ph.ct.geometry());
    renderer.setBackwardMap(&identity);
    const RgbaImage exported = renderer.render(s);
    // The comparison means something: without the snap the frame differs more.
    renderer.setVolume(synthesize(ct, k.plain, up));
    const RgbaImage noRigid = renderer.render(s);
    const std::string what = std::string("live (") + upsamplingName(up) + " + snap) vs synthesised + identity map";
    const double p = report(liveFrame, exported, what);
    EXPECT_GE(p, 40.0) << what;
    EXPECT_GT(p, report(liveFrame, noRigid, "live vs synthesised without rigid bones") + 2.0);
  }
}

// Issue 11: shaded, the live frame of the bent knee is closer to the synthesised volume's frame
// (whose normals are the deformed volume's own gradients) with the normals turned by the map
// than with the source's: the bent tibia is lit as bent.
TEST(WysiwygGl, ShadedLiveFrameWithTurnedNormalsIsCloserToTheSynthesisedVolume) {
  const test::BentKnee& k = knee();
  const AnyVolume ct = k.ph.ct;
  render::VolumeRenderer renderer(gl());
  render::RenderSettings s = sideView();
  s.preset = render::Preset::Bone;
  renderer.setVolume(synthesize(ct, k.rigid, Upsampling::Trilinear));
  const render::BackwardMap identity = render::identityBackwardMap(k.rigid.grid, k.rigid.attributes, k.ph.ct.geometry());
  renderer.setBackwardMap(&identity);
  const RgbaImage exported = renderer.render(s);
  renderer.setVolume(ct);
  const render::BackwardMap live = deformation::renderedMap(k.rigid, k.ph.ct.geometry(), Upsampling::Trilinear);
  renderer.setBackwardMap(&live);
  const RgbaImage turned = renderer.render(s);
  s.turnDeformedNormals = false;
  const RgbaImage unturned = renderer.render(s);
  const double pTurned = report(turned, exported, "shaded live (turned normals) vs synthesised");
  const double pUnturned = report(unturned, exported, "shaded live (source normals) vs synthesised");
  // Most of the frame is unbent (femur, background), so the whole-frame gain is small
  // (measured 38.0 -> 38.5 dB, mean difference -13%); the rest is sampling, as unshaded.
  EXPECT_GT(pTurned, pUnturned);
  const double mTurned = test::compareImages(turned, exported).meanAbs[0];
  EXPECT_LT(mTurned, 0.95 * test::compareImages(unturned, exported).meanAbs[0]);
}

namespace {

// Float volume: 1000 inside body c (class 2 + c), 0 elsewhere, on the class grid. `interior`:
// only voxels whose 6 neighbours are body c too (samples near that mask's edge read u inside
// the body, where the snap rule applies; the full mask's edge lies on the class boundary, where
// half the samples land outside the body and are, as in CPU synthesis, not snapped).
VolumeF32 bodyMask(const RigidSnap& snap, int c, bool interior) {
  VolumeF32 m(snap.classGrid, 0.f, 0.f);
  const Dims d = snap.classGrid.dims;
  const auto& cls = *snap.classes;
  auto in = [&](int64_t i, int64_t j, int64_t k) {
    return i >= 0 && j >= 0 && k >= 0 && i < d.x && j < d.y && k < d.z && cls[static_cast<size_t>((k * d.y + j) * d.x + i)] == 2 + c;
  };
  for (int64_t k = 0; k < d.z; ++k)
    for (int64_t j = 0; j < d.y; ++j)
      for (int64_t i = 0; i < d.x; ++i) {
        bool on = in(i, j, k);
        if (interior)
          on = on && in(i - 1, j, k) && in(i + 1, j, k) && in(i, j - 1, k) && in(i, j + 1, k) && in(i, j, k - 1) && in(i, j, k + 1);
        m.data()[(k * d.y + j) * d.x + i] = on ? 1000.f : 0.f;
      }
  return m;
}

// The map that moves body c rigidly everywhere: u = R v + t on the node grid.
render::BackwardMap rigidTruth(const ControlVolume& cv, const std::array<double, 12>& f) {
  render::BackwardMap m = render::identityBackwardMap(cv.grid);
  for (size_t n = 0; n < m.sourceMm.size(); n += 3) {
    const double v[3] = {m.sourceMm[n], m.sourceMm[n + 1], m.sourceMm[n + 2]};
    for (int r = 0; r < 3; ++r)
      m.sourceMm[n + r] = float(f[3 * r] * v[0] + f[3 * r + 1] * v[1] + f[3 * r + 2] * v[2] + f[9 + r]);
  }
  return m;
}

// Mean silhouette offset (pixels) of `img` from `truth`, first order: sum |img - truth| over
// sum |grad truth| (the grey edge of the MIP of a mask moves by delta -> |change| = |grad| delta).
double silhouetteOffsetPx(const RgbaImage& img, const RgbaImage& truth) {
  double diff = 0, grad = 0;
  for (int y = 0; y + 1 < truth.height; ++y)
    for (int x = 0; x + 1 < truth.width; ++x) {
      const double t = truth.at(x, y)[0], gx = truth.at(x + 1, y)[0] - t, gy = truth.at(x, y + 1)[0] - t;
      grad += std::sqrt(gx * gx + gy * gy);
      diff += std::abs(double(img.at(x, y)[0]) - t);
    }
  return grad > 0 ? diff / grad : 0;
}

}  // namespace

// (c) The bone as rendered: MIP of each bone's mask through the map against the MIP through
// that bone's rigid transform, before (no snap: the GL path until now) and after (snap), both
// kernels. Asserted on the interior mask; the full mask's numbers are reported.
TEST(WysiwygGl, RenderedBonesFollowTheirRigidTransform) {
  const test::BentKnee& k = knee();
  const RigidSnap& snap = *k.rigid.rigidSnap;
  ControlVolume unsnapped = k.rigid;
  unsnapped.rigidSnap.reset();
  render::VolumeRenderer renderer(gl());
  double worst[2][2] = {{0, 0}, {0, 0}};  // [interior][after]
  for (int c = 0; c < int(snap.fits.size()); ++c) {
    if (!snap.valid[static_cast<size_t>(c)]) continue;
    for (const bool interior : {false, true}) {
      const VolumeF32 mask = bodyMask(snap, c, interior);
      renderer.setVolume(mask);
      render::RenderSettings s = sideView(256);
      s.preset = render::Preset::Mip;
      s.windowCenter = 500;
      s.windowWidth = 1000;
      s.camera.fieldOfViewDeg = 0;  // orthographic: one pixel size everywhere
      const double pixelMm = 2 * render::detail::makeFrame(mask.geometry(), &k.rigid.grid, s).halfH / s.height;
      render::BackwardMap truthMap = rigidTruth(k.rigid, snap.fits[static_cast<size_t>(c)]);
      truthMap.output = k.ph.ct.geometry();
      renderer.setBackwardMap(&truthMap);
      const RgbaImage truth = renderer.render(s);
      double before = 0, after = 0;
      for (const Upsampling up : {Upsampling::Trilinear, Upsampling::Gaussian}) {
        const render::BackwardMap a = deformation::renderedMap(k.rigid, k.ph.ct.geometry(), up);
        const render::BackwardMap b = deformation::renderedMap(unsnapped, k.ph.ct.geometry(), up);
        renderer.setBackwardMap(&a);
        after = std::max(after, pixelMm * silhouetteOffsetPx(renderer.render(s), truth));
        renderer.setBackwardMap(&b);
        before = std::max(before, pixelMm * silhouetteOffsetPx(renderer.render(s), truth));
      }
      std::cout << "[ bone ] body " << c << (interior ? " interior" : " full    ")
                << ": rendered silhouette offset from the rigid truth " << before << " mm without the snap, "
                << after << " mm with it (pixel " << pixelMm << " mm)\n";
      worst[interior][0] = std::max(worst[interior][0], before);
      worst[interior][1] = std::max(worst[interior][1], after);
    }
  }
  std::cout << "[ bone ] worst: full mask " << worst[0][0] << " -> " << worst[0][1] << " mm, interior "
            << worst[1][0] << " -> " << worst[1][1] << " mm\n";
  EXPECT_LT(worst[1][1], 0.2 * worst[1][0]);
  EXPECT_LT(worst[1][1], 0.01);
  EXPECT_LT(worst[0][1], worst[0][0]);
}
