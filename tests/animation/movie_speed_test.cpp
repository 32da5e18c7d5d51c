// Issue 23 §6 (a 3 s, 30 fps movie of a 512^2 x 350 CT in minutes): what makes it fast must not
// change the frames. Each frame's map is made on another thread while the frame before renders
// (MovieSpec::overlapFrames); a large volume's in-between frames are measured at their nodes.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>

#include "test_volumes.hpp"
#include "vellum/animation/movie.hpp"
#include "vellum/deformation/control_volume.hpp"
#include "vellum/deformation/placement.hpp"
#include "vellum/render/gl_context.hpp"

using namespace vellum;

namespace {
// Soft tissue (40 HU) with two bone blocks, 32^3 at 2 mm.
VolumeI16 limb() {
  VolumeI16 ct(test::grid({32, 32, 32}, {2, 2, 2}), -1000, -1000.0);
  test::fillWhere(ct, test::voxelBox(6, 26, 6, 26, 3, 29), 40);
  test::fillWhere(ct, test::voxelBox(12, 20, 12, 20, 3, 14), 1200);
  return test::fillWhere(ct, test::voxelBox(12, 20, 12, 20, 17, 29), 1200);
}
}  // namespace

TEST(MovieSpeed, OverlappedFramesAreTheSameAndInBetweenFramesMayBeMeasuredAtTheirNodes) {
  const VolumeI16 ct = limb();
  const auto rest = deformation::boxControlPoints(ct.geometry(), 16, 0.1);
  auto bent = rest;
  // The lower half turned 20 degrees about x through the volume's centre (a knee bending).
  const Vec3 c = ct.geometry().indexToPhysical({15.5, 15.5, 15.5});
  const double a = 20 * 3.14159265358979 / 180;
  for (auto& p : bent)
    if (p.source.z < c.z) {
      const Vec3 d = p.source - c;
      p.target = c + Vec3{d.x, std::cos(a) * d.y - std::sin(a) * d.z, std::sin(a) * d.y + std::cos(a) * d.z};
    }
  deformation::KeyframeTrack track;
  track.keyframes = {{1.0, rest, std::nullopt, ""}, {0.0, bent, std::nullopt, ""}};
  animation::MovieSpec spec;
  spec.fps = 4;  // frames at 0, 0.25, ..., 1 s: keyframes at frames 0 and 4
  spec.settings.width = spec.settings.height = 48;
  spec.settings.preset = render::Preset::SoftTissueBone;  // shaded, turned normals, snapped bones
  const auto bodies = deformation::RigidBodies::fromThreshold(ct);
  static auto context = render::GlContext::createHeadless();
  auto run = [&](bool overlap, animation::MovieRigidity rigidity, std::vector<RgbaImage>& images) {
    animation::MovieSpec s = spec;
    s.overlapFrames = overlap;
    animation::MovieRenderer movie(*context, ct, track, {}, rigidity, s);
    while (!movie.done()) images.push_back(movie.renderNext());
    return movie.finish();
  };
  std::vector<RgbaImage> one, overlapped;
  const auto serial = run(false, {&bodies, 6, 1}, one);
  const auto r = run(true, {&bodies, 6, 1, 0, false}, overlapped);
  ASSERT_EQ(one.size(), 5u);
  ASSERT_EQ(overlapped.size(), 5u);
  // The same pixels (the rigid fits sum over threads in any order: allow a last-bit wobble).
  for (size_t f = 0; f < 5; ++f) {
    int over1 = 0, differ = 0;
    for (size_t i = 0; i < one[f].pixels.size(); ++i) {
      const int d = std::abs(int(one[f].pixels[i]) - int(overlapped[f].pixels[i]));
      differ += d > 0;
      over1 += d > 1;
    }
    EXPECT_EQ(over1, 0) << "frame " << f;
    EXPECT_LE(differ, 3) << "frame " << f;
  }
  // The bend shows (frame 4 differs from frame 0) and the bones stay rigid.
  EXPECT_NE(one[0].pixels, one[4].pixels);
  EXPECT_LT(serial.worst.boneRmsResidualMm, 0.05);
  // Voxel level at the keyframes (0, 4), nodes only in between; the node measures are the same.
  ASSERT_EQ(r.perFrame.size(), 5u);
  for (size_t f = 0; f < 5; ++f) {
    const bool key = f == 0 || f == 4;
    EXPECT_EQ(r.perFrame[f].voxelsAsRendered.voxelLevel, key) << "frame " << f;
    EXPECT_EQ(r.perFrame[f].voxelsAsRendered.stride, key ? 1 : 0) << "frame " << f;
    EXPECT_EQ(r.perFrame[f].nodes.nodes, serial.perFrame[f].nodes.nodes) << "frame " << f;
    EXPECT_NEAR(r.perFrame[f].nodes.boneRmsResidualMm, serial.perFrame[f].nodes.boneRmsResidualMm, 1e-9) << "frame " << f;
    if (key) {
      EXPECT_NEAR(r.perFrame[f].voxelsAsRendered.boneMaxResidualMm, serial.perFrame[f].voxelsAsRendered.boneMaxResidualMm, 1e-9);
    }
  }
  EXPECT_NEAR(r.worst.boneRmsResidualMm, std::max(serial.perFrame[0].voxelsAsRendered.boneRmsResidualMm,
                                                  serial.perFrame[4].voxelsAsRendered.boneRmsResidualMm), 1e-9);
}

// A frame map made elsewhere (MovieSpec::frameMaps: the twist map's TwistFrames) is drawn as it
// is, shared, when it already lies on the volume's grid: no 138 MB copy per frame at 512^2 x 350.
// The frames equal those of the same maps handed over on a grid equal only to within 1e-5 mm
// (which the movie then copies onto the volume's grid exactly), pixel for pixel.
TEST(MovieSpeed, SharedFrameMapsDrawTheSameFrames) {
  const VolumeI16 ct = limb();
  const Geometry& g = ct.geometry();
  const auto rest = deformation::boxControlPoints(g, 16, 0.1);
  deformation::KeyframeTrack track;
  track.keyframes = {{0.5, rest, std::nullopt, ""}, {0.0, rest, std::nullopt, ""}};
  // Each frame's map: the volume's lower half pushed along y by 2 mm a frame.
  auto mapAt = [&](double timeS) {
    auto cv = std::make_shared<deformation::ControlVolume>();
    cv->grid = deformation::controlGrid(g, 2);
    cv->scale = 2;
    const Dims d = cv->grid.dims;
    for (int64_t k = 0; k < d.z; ++k)
      for (int64_t j = 0; j < d.y; ++j)
        for (int64_t i = 0; i < d.x; ++i) {
          Vec3 p = cv->grid.indexToPhysical({double(i), double(j), double(k)});
          if (k < d.z / 2) p.y += 8 * timeS;
          cv->sourceMm.insert(cv->sourceMm.end(), {float(p.x), float(p.y), float(p.z)});
        }
    return cv;
  };
  animation::MovieSpec spec;
  spec.fps = 4;  // frames at 0, 0.25, 0.5 s
  spec.settings.width = spec.settings.height = 48;
  spec.settings.preset = render::Preset::SoftTissueBone;
  static auto context = render::GlContext::createHeadless();
  auto run = [&](bool onGrid, std::vector<RgbaImage>& images) {
    animation::MovieSpec s = spec;
    s.frameMaps = [&, onGrid](double timeS, const deformation::RigidBodies*) {
      auto cv = mapAt(timeS);
      cv->output = g;  // as TwistFrames sets it: drawn without a copy
      if (!onGrid) cv->output->origin.x += 1e-5;
      return std::shared_ptr<const deformation::ControlVolume>(cv);
    };
    animation::MovieRenderer movie(*context, ct, track, {}, {}, s);
    while (!movie.done()) images.push_back(movie.renderNext());
  };
  std::vector<RgbaImage> shared, copied;
  run(true, shared);
  run(false, copied);
  ASSERT_EQ(shared.size(), 3u);
  ASSERT_EQ(copied.size(), 3u);
  for (size_t f = 0; f < 3; ++f) EXPECT_EQ(shared[f].pixels, copied[f].pixels) << "frame " << f;
  EXPECT_NE(shared[0].pixels, shared[2].pixels);  // the push shows
}
