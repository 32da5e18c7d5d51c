// Per-segment colours (label_tint.hpp, label_colour.hpp): a two-label block renders each label's
// table colour in its half, blended smoothly across the boundary, in the ray caster's CPU
// reference and in the cinematic CPU path tracer, also through a deformation map.
#include <gtest/gtest.h>

#include "analytic_volumes.hpp"
#include "vellum/core/label_volume.hpp"
#include "vellum/render/label_tint.hpp"
#include "vellum/render/path_tracer.hpp"
#include "vellum/render/volume_renderer.hpp"

namespace vellum::render {
namespace {

constexpr int kN = 32;

/// An opaque block (x, z in [4, 28), y in [8, 24)): label 1 (red) where x < 16, 2 (blue) beyond.
struct TwoLabels {
  VolumeI16 ct;
  LabelTint tint;
};
TwoLabels twoLabels() {
  Geometry g;
  g.dims = {kN, kN, kN};
  VolumeI16 ct(g, -1000, -1000);
  LabelVolume labels(g);
  labels.setLabel({1, "left", {255, 0, 0}});
  labels.setLabel({2, "right", {0, 0, 255}});
  for (int k = 4; k < 28; ++k)
    for (int j = 8; j < 24; ++j)
      for (int i = 4; i < 28; ++i) {
        ct(i, j, k) = 1000;
        labels.ids()(i, j, k) = i < 16 ? 1 : 2;
      }
  return {std::move(ct), makeLabelTint(labels)};
}

RenderSettings frontView() {
  RenderSettings s;
  s.width = s.height = 64;  // about two pixels per voxel
  s.preset = Preset::Bone;
  s.camera.azimuthDeg = 0;  // from anterior: x runs across the picture
  s.camera.elevationDeg = 0;
  s.camera.fieldOfViewDeg = 0;
  s.camera.zoom = 1.6;
  s.labelBlend = 1;
  s.background = {0, 0, 0, 1};
  return s;
}

/// Mean red and blue (0..255) of column x over the block's middle rows.
std::pair<double, double> column(const RgbaImage& img, int x) {
  double r = 0, b = 0;
  for (int y = 24; y < 40; ++y) r += img.at(x, y)[0], b += img.at(x, y)[2];
  return {r / 16, b / 16};
}

/// The block's image: red left, blue right, and the columns between pass from red to blue in
/// at least two steps (a smooth blend, not a hard cut).
void expectTwoColours(const RgbaImage& img, const std::string& what) {
  int left = -1, right = -1;  // the block's first and last columns on screen
  for (int x = 0; x < img.width; ++x)
    if (img.at(x, 32)[3] > 0 && (img.at(x, 32)[0] > 20 || img.at(x, 32)[2] > 20)) (left < 0 ? left : right) = x;
  ASSERT_GT(right - left, 24) << what;
  // Which side is which: the picture's x runs along the patient's -x or +x; find red's side.
  const auto [r0, b0] = column(img, left + 2);
  const auto [r1, b1] = column(img, right - 2);
  const bool redLeft = r0 > b0;
  const double redFar = redLeft ? r0 : r1, blueNear = redLeft ? b0 : b1;
  const double blueFar = redLeft ? b1 : b0, redNear = redLeft ? r1 : r0;
  EXPECT_GT(redFar, 4 * blueNear + 10) << what << ": label 1's half is red";
  EXPECT_GT(blueFar, 4 * redNear + 10) << what << ": label 2's half is blue";
  int mixed = 0;  // columns where both colours are clearly present
  for (int x = left; x <= right; ++x) {
    const auto [r, b] = column(img, x);
    if (r > 0.15 * std::max(redFar, 1.0) && b > 0.15 * std::max(blueFar, 1.0)) ++mixed;
  }
  EXPECT_GE(mixed, 1) << what << ": the colours blend at the boundary";
  EXPECT_LE(mixed, 6) << what << ": the blend stays near the boundary";
}

TEST(LabelColours, TwoLabelsTakeTheirColoursAndBlendAtTheBoundary) {
  const TwoLabels v = twoLabels();
  RenderSettings s = frontView();
  s.shading = false;  // the colour itself
  expectTwoColours(renderReferenceCpu(v.ct, s, nullptr, &v.tint), "ray caster");
  const BackwardMap identity = test::makeIdentityMap(v.ct.geometry());
  expectTwoColours(renderReferenceCpu(v.ct, s, &identity, &v.tint), "ray caster through a map");
  s.shading = true;
  s.quality = Quality::Cinematic;
  s.cinematic.samples = 2;
  s.cinematic.denoise = 0;
  s.cinematic.skyLight = 1.0;
  s.lighting.azimuthDeg = -60;  // the front face lit, its specular highlight far off (white)
  s.lighting.elevationDeg = 45;
  expectTwoColours(renderPathTracedCpu(v.ct, s, nullptr, &v.tint), "cinematic");
}

}  // namespace
}  // namespace vellum::render
