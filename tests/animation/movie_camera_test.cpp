// Issue 11: movies follow keyframed cameras (turntables, fly-arounds).
#include <gtest/gtest.h>

#include "test_volumes.hpp"
#include "vellum/animation/movie.hpp"
#include "vellum/deformation/placement.hpp"
#include "vellum/render/gl_context.hpp"

using namespace vellum;

namespace {
/// An off-centre bright box: each camera sees it differently.
VolumeI16 boxVolume() {
  VolumeI16 ct(test::grid({40, 40, 40}, {2, 2, 2}), -1000, -1000.0);
  return test::fillWhere(ct, test::voxelBox(22, 34, 8, 20, 10, 30), 1500);
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
  turning.keyframes = {{1.0, still, deformation::KeyframeCamera{0, 0, 1, {0, 0, 0}, std::nullopt}, ""},
                       {0.0, still, deformation::KeyframeCamera{90, 20, 1.5, {0, 0, 0}, std::nullopt}, ""}};
  const auto turned = frames(ct, turning, spec);
  ASSERT_EQ(turned.size(), 3u);

  // The same frames from a track without cameras, the settings' camera set to each key's.
  deformation::KeyframeTrack plain;
  plain.keyframes = {{0.0, still, std::nullopt, ""}};
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

// The keyed field of view: a frame between keys is the render at the interpolated field of
// view (the frame `vellum render --fov` makes with the same camera); cameras without one keep
// the settings' field of view.
TEST(MovieCamera, FramesFollowTheKeyedFieldOfView) {
  const VolumeI16 ct = boxVolume();
  const deformation::ControlPoints still = deformation::boxControlPoints(ct.geometry(), 16, 0.1);  // identity
  animation::MovieSpec spec;
  spec.fps = 2;  // frames at 0, 0.5 and 1 s
  spec.settings.width = spec.settings.height = 96;
  spec.settings.preset = render::Preset::Bone;
  spec.settings.camera.fieldOfViewDeg = 50;
  const deformation::KeyframeCamera wide{20, 10, 1, {0, 0, 0}, 80.0}, ortho{20, 10, 1, {0, 0, 0}, 0.0};

  deformation::KeyframeTrack plain;
  plain.keyframes = {{0.0, still, std::nullopt, ""}};
  const auto at = [&](double fov) {
    animation::MovieSpec s = spec;
    s.settings.camera.azimuthDeg = 20;
    s.settings.camera.elevationDeg = 10;
    s.settings.camera.fieldOfViewDeg = fov;
    return frames(ct, plain, s).front();
  };
  deformation::KeyframeTrack zooming;
  zooming.keyframes = {{1.0, still, wide, ""}, {0.0, still, ortho, ""}};
  const auto zoomed = frames(ct, zooming, spec);
  ASSERT_EQ(zoomed.size(), 3u);
  EXPECT_EQ(zoomed[0].pixels, at(80).pixels);
  EXPECT_EQ(zoomed[1].pixels, at(40).pixels) << "half way: 40 degrees";
  EXPECT_EQ(zoomed[2].pixels, at(0).pixels) << "orthographic";
  EXPECT_NE(zoomed[1].pixels, zoomed[0].pixels);
  EXPECT_NE(zoomed[1].pixels, zoomed[2].pixels);

  // Cameras without a field of view: the settings' 50 degrees throughout.
  deformation::KeyframeTrack turning = zooming;
  turning.keyframes[0].camera->fieldOfViewDeg.reset();
  turning.keyframes[1].camera->fieldOfViewDeg.reset();
  EXPECT_EQ(frames(ct, turning, spec)[1].pixels, at(50).pixels);
}
