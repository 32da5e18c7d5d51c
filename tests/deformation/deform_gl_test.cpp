// GL path of the deformation: the renderer samples the source at u(v) from the control volume
// (no deformed volume is made). Compared with the CPU reference ray caster given the same map,
// and with a CPU-synthesised deformed volume rendered without a map.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>

#include "vellum/deformation/deformer.hpp"
#include "vellum/deformation/placement.hpp"
#include "vellum/deformation/rigidity.hpp"
#include "vellum/deformation/synthesis.hpp"
#include "vellum/phantom/phantom.hpp"
#include "vellum/render/volume_renderer.hpp"

using namespace vellum;
using namespace vellum::deformation;

namespace {

struct Diff {
  double meanAbs = 0, psnr = 0;
  int maxAbs = 0;
};

Diff compare(const RgbaImage& a, const RgbaImage& b) {
  Diff d;
  double se = 0;
  for (size_t i = 0; i < a.pixels.size(); ++i) {
    const int e = std::abs(int(a.pixels[i]) - int(b.pixels[i]));
    d.meanAbs += e;
    se += double(e) * e;
    d.maxAbs = std::max(d.maxAbs, e);
  }
  d.meanAbs /= double(a.pixels.size());
  const double mse = se / double(a.pixels.size());
  d.psnr = mse > 0 ? 10 * std::log10(255.0 * 255.0 / mse) : 99;
  return d;
}

double coverage(const RgbaImage& img) {
  size_t n = 0;
  for (size_t i = 0; i < img.pixels.size(); i += 4) n += img.pixels[i] > 8 || img.pixels[i + 1] > 8;
  return double(n) / double(img.pixels.size() / 4);
}

}  // namespace

TEST(DeformGl, RendererWithBackwardMapMatchesCpuReferences) {
  phantom::PhantomOptions o;
  o.dims = {64, 64, 72};
  const auto ph = phantom::makePhantom(o);
  const AnyVolume ct = ph.ct;
  const KeyframeTrack track = kneeBendTrack(ph.ct.geometry(), 30.0, 2.0, phantom::flexionAxisPointMm());
  DeformParams p;
  p.controlScale = 2;
  ControlPoints pts = track.keyframes[1].points;
  pts[0].attributes.lightness = 30;  // exercise the attribute fields too
  ControlVolume cv = computeControlVolume(ct, pts, p);
  applyRigidity(cv, RigidBodies::fromLabels(ph.labels, {4, 5, 6, 7, 8, 9, 11}));
  render::BackwardMap map;
  map.grid = cv.grid;
  map.sourceMm = cv.sourceMm;
  map.attributes = cv.attributes;

  render::RenderSettings s;
  s.width = 128;
  s.height = 128;
  s.camera.azimuthDeg = 90;
  auto context = render::GlContext::createHeadless();
  render::VolumeRenderer renderer(*context);
  renderer.setVolume(ct);
  const RgbaImage plain = renderer.render(s);
  renderer.setBackwardMap(&map);
  const RgbaImage gl = renderer.render(s);
  EXPECT_GT(coverage(gl), 0.1);
  // The deformation changes the picture.
  EXPECT_GT(compare(gl, plain).meanAbs, 1.0);

  // Same map through the CPU reference ray caster: near-identical.
  const Diff ref = compare(gl, render::renderReferenceCpu(ct, s, &map));
  std::cout << "[ diff ] GL vs CPU reference (same map): mean " << ref.meanAbs << " max " << ref.maxAbs
            << " psnr " << ref.psnr << " dB\n";
  EXPECT_LT(ref.meanAbs, 1.0);
  EXPECT_GT(ref.psnr, 35.0);

  // Without attributes, against a CPU-synthesised deformed volume rendered plainly: the map
  // is then applied to voxel centres and intensities are interpolated twice, so only close.
  map.attributes.clear();
  renderer.setBackwardMap(&map);
  const RgbaImage glNoAttr = renderer.render(s);
  const AnyVolume deformed = synthesize(ct, cv);
  render::RenderSettings s2 = s;
  const Diff syn = compare(glNoAttr, render::renderReferenceCpu(deformed, s2));
  std::cout << "[ diff ] GL (map) vs CPU-synthesised volume: mean " << syn.meanAbs << " max "
            << syn.maxAbs << " psnr " << syn.psnr << " dB\n";
  EXPECT_LT(syn.meanAbs, 4.0);
  EXPECT_GT(syn.psnr, 25.0);
}
