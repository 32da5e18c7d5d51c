// Issue 12: labels in `vellum animate` follow their structures from frame to frame.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "test_volumes.hpp"
#include "vellum/animation/movie.hpp"
#include "vellum/deformation/placement.hpp"
#include "vellum/render/gl_context.hpp"
#include "vellum/render/projection.hpp"

using namespace vellum;

TEST(MovieAnnotations, LabelAnchorsFollowTheDeformation) {
  // A bright box of id 1 in air, seen from the front, orthographic.
  Geometry g;
  g.dims = {48, 48, 48};
  g.spacing = {2, 2, 2};
  VolumeI16 ct(g, -1000, -1000.0);
  LabelVolume labels(g);
  labels.setLabel({1, "box", {200, 50, 50}});
  test::fillWhere(ct, test::voxelBox(18, 30, 18, 30, 18, 30), 1500);
  test::fillWhere(labels, test::voxelBox(18, 30, 18, 30, 18, 30), 1);
  // Every control point moves 20 mm along +x: the box is translated by 20 mm.
  const deformation::ControlPoints start = deformation::boxControlPoints(g, 16, 0.1);
  deformation::ControlPoints moved = start;
  for (auto& p : moved) p.target = p.source + Vec3{20, 0, 0};
  deformation::KeyframeTrack track;
  track.keyframes = {{1.0, start, std::nullopt, ""}, {0.0, moved, std::nullopt, ""}};

  animation::MovieSpec spec;
  spec.fps = 1;  // two frames: the start and the end
  spec.settings.width = spec.settings.height = 256;
  spec.settings.preset = render::Preset::Bone;
  spec.settings.camera.fieldOfViewDeg = 0;
  spec.settings.camera.azimuthDeg = 0;
  spec.settings.camera.elevationDeg = 0;
  spec.annotations.labels = true;
  spec.labels = &labels;
  auto context = render::GlContext::createHeadless();
  animation::MovieRenderer movie(*context, ct, track, {}, {}, spec);
  ASSERT_EQ(movie.frameCount(), 2);
  while (!movie.done()) movie.renderNext();
  const auto& anchors = movie.result().anchors;
  ASSERT_EQ(anchors.size(), 2u);
  ASSERT_EQ(anchors[0].size(), 1u);
  ASSERT_EQ(anchors[1].size(), 1u);

  // Each anchor lies on the box as projected in its frame, and moves with it.
  const render::Projection projection(g, spec.settings);
  const double ppm = projection.pixelsPerMm();
  for (int f = 0; f < 2; ++f) {
    const Vec3 shift{f == 0 ? 0.0 : 20.0, 0, 0};
    const auto lo = projection.toPixel(g.indexToPhysical({17.5, 23.5, 17.5}) + shift);
    const auto hi = projection.toPixel(g.indexToPhysical({29.5, 23.5, 29.5}) + shift);
    const auto& a = anchors[size_t(f)][0];
    EXPECT_EQ(a.name, "box");
    EXPECT_GE(a.x, std::min(lo->x, hi->x) - 1) << "frame " << f;
    EXPECT_LE(a.x, std::max(lo->x, hi->x) + 1) << "frame " << f;
    EXPECT_GE(a.y, std::min(lo->y, hi->y) - 1) << "frame " << f;
    EXPECT_LE(a.y, std::max(lo->y, hi->y) + 1) << "frame " << f;
  }
  EXPECT_NEAR(anchors[1][0].x - anchors[0][0].x, 20 * ppm, 3.0);
}

namespace {
// Centroid (pixels) of the non-transparent pixels of an image rendered on a transparent background.
Vec3 drawnCentroid(const RgbaImage& img) {
  double sx = 0, sy = 0, n = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x)
      if (img.at(x, y)[3] > 0) sx += x, sy += y, n += 1;
  return {sx / std::max(n, 1.0), sy / std::max(n, 1.0), n};
}
}  // namespace

// Issue 11: in deformed frames each leader line ends where the structure's centre is drawn:
// the forward image of its source position through the frame's map, projected as the renderer
// frames the map's grid. A ball turned 30 degrees about the superior axis and shifted: the
// anchor is the drawn ball's centre to within a pixel, in every frame.
TEST(MovieAnnotations, AnchorsSitOnTheDeformedStructuresCentre) {
  Geometry g;
  g.dims = {42, 42, 42};  // the control grid (s = 8) reaches 6 voxels beyond: the map's box is larger
  g.spacing = {2, 2, 2};
  VolumeI16 ct(g, -1000, -1000.0);
  LabelVolume labels(g);
  labels.setLabel({1, "ball", {200, 50, 50}});
  const Vec3 ball = g.indexToPhysical({28, 21, 16});
  const auto inBall = [&](int64_t i, int64_t j, int64_t k) {
    return norm(g.indexToPhysical({double(i), double(j), double(k)}) - ball) <= 7.0;
  };
  test::fillWhere(ct, inBall, 1500);
  test::fillWhere(labels, inBall, 1);
  deformation::DeformParams params;
  params.controlScale = 8;
  const Vec3 c = g.center();
  const double a = 30 * std::numbers::pi / 180;
  const deformation::ControlPoints start = deformation::boxControlPoints(g, 16, 0.1);
  deformation::ControlPoints moved = start;
  for (auto& p : moved) {
    const Vec3 q = p.source - c;
    p.target = c + Vec3{std::cos(a) * q.x - std::sin(a) * q.y, std::sin(a) * q.x + std::cos(a) * q.y, q.z} + Vec3{-6, 4, 2};
  }
  deformation::KeyframeTrack track;
  track.keyframes = {{1.0, start, std::nullopt, ""}, {0.0, moved, std::nullopt, ""}};

  animation::MovieSpec spec;
  spec.fps = 2;  // frames at 0, 0.5 and 1 s: the turn half done in the middle one
  spec.settings.width = spec.settings.height = 200;
  spec.settings.preset = render::Preset::Bone;
  spec.settings.background = {0, 0, 0, 0};
  spec.settings.camera.azimuthDeg = 20;
  spec.settings.camera.elevationDeg = 25;
  auto context = render::GlContext::createHeadless();
  std::vector<RgbaImage> plain;
  {
    animation::MovieRenderer movie(*context, ct, track, params, {}, spec);
    while (!movie.done()) plain.push_back(movie.renderNext());
  }
  spec.annotations.labels = true;
  spec.labels = &labels;
  animation::MovieRenderer movie(*context, ct, track, params, {}, spec);
  while (!movie.done()) movie.renderNext();
  const auto& anchors = movie.result().anchors;
  ASSERT_EQ(anchors.size(), 3u);
  for (size_t f = 0; f < 3; ++f) {
    ASSERT_EQ(anchors[f].size(), 1u) << "frame " << f;
    const Vec3 drawn = drawnCentroid(plain[f]);
    ASSERT_GT(drawn.z, 100) << "the ball is in the picture";
    EXPECT_NEAR(anchors[f][0].x, drawn.x, 1.0) << "frame " << f;
    EXPECT_NEAR(anchors[f][0].y, drawn.y, 1.0) << "frame " << f;
  }
  const Vec3 first = drawnCentroid(plain[0]), last = drawnCentroid(plain[2]);
  EXPECT_GT(std::hypot(last.x - first.x, last.y - first.y), 5.0) << "the ball moved on screen";
}
