// Issue 12: labels in `vellum animate` follow their structures from frame to frame.
#include <gtest/gtest.h>

#include <cmath>

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
  for (int64_t k = 18; k < 30; ++k)
    for (int64_t j = 18; j < 30; ++j)
      for (int64_t i = 18; i < 30; ++i) ct(i, j, k) = 1500, labels(i, j, k) = 1;
  // Every control point moves 20 mm along +x: the box is translated by 20 mm.
  const deformation::ControlPoints start = deformation::boxControlPoints(g, 16, 0.1);
  deformation::ControlPoints moved = start;
  for (auto& p : moved) p.target = p.source + Vec3{20, 0, 0};
  deformation::KeyframeTrack track;
  track.keyframes = {{1.0, start}, {0.0, moved}};

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
