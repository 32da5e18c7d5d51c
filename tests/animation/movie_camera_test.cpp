// Issue 11: movies follow keyframed cameras (turntables, fly-arounds).
#include <gtest/gtest.h>

#include "vellum/animation/movie.hpp"
#include "vellum/deformation/placement.hpp"
#include "vellum/render/gl_context.hpp"

using namespace vellum;

namespace {
/// An off-centre bright box: each camera sees it differently.
VolumeI16 boxVolume() {
  Geometry g;
  g.dims = {40, 40, 40};
  g.spacing = {2, 2, 2};
  VolumeI16 ct(g, -1000, -1000.0);
  for (int64_t k = 10; k < 30; ++k)
    for (int64_t j = 8; j < 20; ++j)
      for (int64_t i = 22; i < 34; ++i) ct(i, j, k) = 1500;
  return ct;
}

std::vector<RgbaImage> frames(const VolumeI16& ct, const deformation::KeyframeTrack& track, const animation::MovieSpec& spec) {
  static auto context = render::GlContext::createHeadless();
  animation::MovieRenderer movie(*context, ct, track, {}, {}, spec);
  std::vector<RgbaImage> out;
  while (!movie.done()) out.push_back(movie.renderNext());
  return out;
}
}  // namespace

TEST(MovieCamera, FramesFollowKeyframedCameras) {
  const VolumeI16 ct = boxVolume();
  const deformation::ControlPoints still = deformation::boxControlPoints(ct.geometry(), 16, 0.1);  // identity
  animation::MovieSpec spec;
  spec.fps = 2;  // 1 s track: frames at 0, 0.5 and 1 s
  spec.settings.width = spec.settings.height = 96;
  spec.settings.preset = render::Preset::Bone;

  deformation::KeyframeTrack turning;
  turning.keyframes = {{1.0, still, deformation::KeyframeCamera{0, 0, 1, {0, 0, 0}}},
                       {0.0, still, deformation::KeyframeCamera{90, 20, 1.5, {0, 0, 0}}}};
  const auto turned = frames(ct, turning, spec);
  ASSERT_EQ(turned.size(), 3u);

  // The same frames from a track without cameras, the settings' camera set to each key's.
  deformation::KeyframeTrack plain;
  plain.keyframes = {{0.0, still, std::nullopt}};
  const auto at = [&](double az, double el, double zoom) {
    animation::MovieSpec s = spec;
    s.settings.camera.azimuthDeg = az;
    s.settings.camera.elevationDeg = el;
    s.settings.camera.zoom = zoom;
    return frames(ct, plain, s).front();
  };
  EXPECT_EQ(turned[0].pixels, at(0, 0, 1).pixels);
  EXPECT_EQ(turned[1].pixels, at(45, 10, 1.25).pixels) << "half way: interpolated";
  EXPECT_EQ(turned[2].pixels, at(90, 20, 1.5).pixels);
  EXPECT_NE(turned[0].pixels, turned[2].pixels);
}
