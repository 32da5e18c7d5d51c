// Issue 23 §7: title cards and captions in movies (keyframe captions replace the movie's).
#include <gtest/gtest.h>

#include "test_volumes.hpp"
#include "vellum/animation/movie.hpp"
#include "vellum/deformation/placement.hpp"
#include "vellum/render/annotations.hpp"
#include "vellum/render/gl_context.hpp"

using namespace vellum;

namespace {
VolumeI16 boxVolume() {
  VolumeI16 ct(test::grid({24, 24, 24}, {2, 2, 2}), -1000, -1000.0);
  return test::fillWhere(ct, test::voxelBox(8, 16, 8, 16, 8, 16), 1500);
}

std::vector<RgbaImage> frames(const deformation::KeyframeTrack& track, const animation::MovieSpec& spec) {
  static auto context = render::GlContext::createHeadless();
  animation::MovieRenderer movie(*context, boxVolume(), track, {}, {}, spec);
  std::vector<RgbaImage> out;
  while (!movie.done()) out.push_back(movie.renderNext());
  EXPECT_EQ(movie.finish().frames, static_cast<int>(out.size()));
  return out;
}

// Pixels that differ between two images of one size, in rows [y0, y1).
int64_t differing(const RgbaImage& a, const RgbaImage& b, int y0, int y1) {
  int64_t n = 0;
  for (int y = y0; y < y1; ++y)
    for (int x = 0; x < a.width; ++x)
      for (int c = 0; c < 3; ++c)
        if (a.at(x, y)[c] != b.at(x, y)[c]) {
          ++n;
          break;
        }
  return n;
}
}  // namespace

TEST(MovieTitles, TitleCardFramesComeFirstAndCaptionsFollowTheKeyframes) {
  const auto still = deformation::boxControlPoints(boxVolume().geometry(), 8, 0.1);
  deformation::KeyframeTrack track;
  track.keyframes = {{1.0, still, std::nullopt, "Rest"}, {1.0, still, std::nullopt, ""}, {0.0, still, std::nullopt, "Flexed"}};
  animation::MovieSpec plainSpec;
  plainSpec.fps = 2;  // 2 s track: frames at 0, 0.5, ..., 2 s
  plainSpec.settings.width = plainSpec.settings.height = 160;
  plainSpec.settings.preset = render::Preset::Bone;
  deformation::KeyframeTrack bare = track;
  for (auto& k : bare.keyframes) k.caption.clear();
  const auto plain = frames(bare, plainSpec);
  ASSERT_EQ(plain.size(), 5u);

  animation::MovieSpec spec = plainSpec;
  spec.title = "Knee flexion";
  spec.subtitle = "Phantom, 20 degrees";
  spec.titleSeconds = 1.0;  // 2 frames at 2 fps
  spec.caption = "Fallback";
  const auto titled = frames(track, spec);
  ASSERT_EQ(titled.size(), 7u);

  // The title card: opaque background (the settings' black) with light text in its middle third.
  const RgbaImage& card = titled[0];
  EXPECT_EQ(card.pixels, titled[1].pixels);
  RgbaImage black(160, 160);
  for (size_t i = 3; i < black.pixels.size(); i += 4) black.pixels[i] = 255;
  EXPECT_GT(differing(card, black, 53, 107), 100) << "the title";
  EXPECT_EQ(differing(card, black, 0, 40), 0) << "nothing above it";
  EXPECT_EQ(differing(card, black, 130, 160), 0) << "nothing below it";

  // Track frames: the picture unchanged above the caption band, the caption drawn in it.
  for (size_t f = 0; f < plain.size(); ++f) {
    EXPECT_EQ(differing(titled[2 + f], plain[f], 0, 100), 0) << "frame " << f;
    EXPECT_GT(differing(titled[2 + f], plain[f], 100, 160), 20) << "frame " << f;
  }
  // Keyframe 1 has no caption: "Rest" holds through its segment; "Flexed" at the end hold.
  EXPECT_EQ(titled[2 + 1].pixels, [&] {
    RgbaImage img = plain[1];
    render::drawCaption(img, "Rest");
    return img;
  }().pixels);
  EXPECT_EQ(titled[2 + 2].pixels, titled[2 + 1].pixels) << "1 s: keyframe 1 holds the previous caption";
  RgbaImage flexed = plain[4];
  render::drawCaption(flexed, "Flexed");
  EXPECT_EQ(titled[2 + 4].pixels, flexed.pixels);
}

TEST(MovieTitles, KeyframeCaptionAtTime) {
  deformation::KeyframeTrack track;
  const deformation::ControlPoints none;
  track.keyframes = {{1.0, none, std::nullopt, ""}, {1.0, none, std::nullopt, "B"}, {0.0, none, std::nullopt, "C"}};
  EXPECT_EQ(track.captionAt(0.5), "");
  EXPECT_EQ(track.captionAt(1.0), "B");
  EXPECT_EQ(track.captionAt(1.99), "B");
  EXPECT_EQ(track.captionAt(2.0), "C");
  EXPECT_EQ(track.captionAt(5.0), "C");
}

// Issue 23 §6: a movie's in-between frames may be measured coarser; the frames that show a
// keyframe's pose and the last frame keep the full stride, and each frame says its stride.
TEST(MovieRigidity, InBetweenFramesAreMeasuredAtTheirOwnStride) {
  const VolumeI16 ct = boxVolume();
  const auto rest = deformation::boxControlPoints(ct.geometry(), 8, 0.1);
  auto moved = rest;
  for (auto& p : moved) p.target.x += 2;  // the whole box 2 mm along x: a rigid move
  deformation::KeyframeTrack track;
  track.keyframes = {{1.0, rest, std::nullopt, ""}, {1.0, moved, std::nullopt, ""}, {0.0, rest, std::nullopt, ""}};
  animation::MovieSpec spec;
  spec.fps = 2;  // frames at 0, 0.5, 1, 1.5, 2 s: keyframes at frames 0, 2 and 4
  spec.settings.width = spec.settings.height = 32;
  const auto bodies = deformation::RigidBodies::fromThreshold(ct);
  static auto context = render::GlContext::createHeadless();
  animation::MovieRenderer movie(*context, ct, track, {}, {&bodies, 10, 1, 2}, spec);
  while (!movie.done()) movie.renderNext();
  const animation::MovieResult r = movie.finish();
  ASSERT_EQ(r.perFrame.size(), 5u);
  const int expected[5] = {1, 2, 1, 2, 1};
  for (size_t f = 0; f < 5; ++f) {
    EXPECT_EQ(r.perFrame[f].voxelsAsRendered.stride, expected[f]) << "frame " << f;
    EXPECT_EQ(r.perFrame[f].voxelsAsRendered.nodes, expected[f] == 1 ? 24 * 24 * 24 : 12 * 12 * 12) << "frame " << f;
  }
}
