// The slice views through the deformation (issue #11): renderSlice with the control volume's
// map (deformation::MapSampler) against analytic truth (a translation shifts the slice) and
// against CPU synthesis resampled on the same plane; and in the window (skipped without
// $DISPLAY): View > Deformed slices off restores the undeformed slice byte for byte, the
// scene file keeps the setting, and a Paint click lands at the clicked pixel's source.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>

#include <chrono>
#include <thread>

#include "deform_session.hpp"
#include "layout.hpp"
#include "mpr.hpp"
#include "scene_file.hpp"
#include "studio_run.hpp"
#include "test_data.hpp"
#include "vellum/deformation/deformer.hpp"
#include "vellum/deformation/keyframes.hpp"
#include "vellum/deformation/placement.hpp"
#include "vellum/deformation/rigidity.hpp"
#include "vellum/deformation/synthesis.hpp"
#include "vellum/io/image_io.hpp"
#include "vellum/io/volume_io.hpp"
#include "vellum/phantom/phantom.hpp"

namespace vellum::studio {
namespace {
namespace fs = std::filesystem;
using namespace vellum::deformation;

const std::vector<uint16_t> kBones{4, 5, 6, 7, 8, 9, 11};

const phantom::Phantom& knee() {
  static const phantom::Phantom p = test::studio::phantomOf({64, 64, 72});
  return p;
}

/// The studio's engine (s = 4, density-aware weights) with the phantom's bones rigid.
ControlVolume solve(const ControlPoints& points) {
  DeformParams p;
  p.controlScale = 4;
  ControlVolume cv = computeControlVolume(AnyVolume(knee().ct), points, p);
  applyRigidity(cv, RigidBodies::fromLabels(knee().labels, kBones));
  return cv;
}

SliceStyle styleWith(const LabelVolume* labels, const MapSampler* map) {
  SliceStyle s;
  s.window = {40, 400};
  s.labels = labels;
  s.labelOpacity = 0.4f;
  s.map = map;
  return s;
}

int channelDiff(const RgbaImage& a, int ax, int ay, const RgbaImage& b, int bx, int by) {
  int d = 0;
  for (int c = 0; c < 4; ++c) d = std::max(d, std::abs(int(a.at(ax, ay)[c]) - int(b.at(bx, by)[c])));
  return d;
}

/// True when `mm` lies `marginVoxels` or more inside the volume's outer voxel centres.
bool wellInside(const Geometry& g, const Vec3& mm, double marginVoxels) {
  const Vec3 i = g.physicalToIndex(mm);
  for (int a = 0; a < 3; ++a)
    if (i[a] < marginVoxels || i[a] > double(g.dims[a] - 1) - marginVoxels) return false;
  return true;
}

TEST(StudioDeformedSlices, ATranslationShiftsTheSliceByIt) {
  const phantom::Phantom& ph = knee();
  const Geometry& g = ph.ct.geometry();
  const Vec3 crosshair = phantom::flexionAxisPointMm();
  const SlicePlane plane = makePlane(SliceAxis::Axial, g, crosshair, 220, 200);
  // All targets = sources + t: 3 pixels right, 2 up, 1.5 mm superior.
  const Vec3 t{3 * plane.mmPerPixel, -2 * plane.mmPerPixel, 1.5};
  ControlPoints points = boxControlPoints(g);
  for (ControlPoint& p : points) p.target = p.source + t;
  const ControlVolume cv = solve(points);
  ASSERT_TRUE(cv.rigidSnap);  // the snap runs too (a translation's rigid fit is itself)
  const MapSampler map(cv, g);
  const RgbaImage deformed = renderSlice(ph.ct, plane, styleWith(&ph.labels, &map));
  // The deformed volume at v is the source at v - t: pixel (x, y) of the deformed slice is
  // pixel (x - 3, y + 2) of the undeformed slice 1.5 mm lower.
  const SlicePlane lower = makePlane(SliceAxis::Axial, g, crosshair - Vec3{0, 0, 1.5}, 220, 200);
  const RgbaImage undeformed = renderSlice(ph.ct, lower, styleWith(&ph.labels, nullptr));
  int64_t compared = 0, off = 0;
  int worst = 0;
  for (int y = 1; y + 3 < plane.height; ++y)
    for (int x = 4; x + 1 < plane.width; ++x) {
      const Vec3 v = plane.toMm(x + 0.5, y + 0.5);
      if (!wellInside(g, v, 2) || !wellInside(g, v - t, 2)) continue;  // away from the borders
      ++compared;
      const int d = channelDiff(deformed, x, y, undeformed, x - 3, y + 2);
      worst = std::max(worst, d);
      off += d > 1;
    }
  std::cout << "[ slices ] translation: " << compared << " pixels, max channel difference " << worst << ", " << off
            << " pixels off by more than 1\n";
  ASSERT_GT(compared, 20000);
  EXPECT_LE(worst, 1);  // the map is stored in float: at most one grey level
}

TEST(StudioDeformedSlices, MatchesTheSynthesisedVolumeResampledOnTheSamePlane) {
  const phantom::Phantom& ph = knee();
  const Geometry& g = ph.ct.geometry();
  const KeyframeTrack bend = kneeBendTrack(g, 30.0, 2.0, phantom::flexionAxisPointMm());
  const ControlVolume cv = solve(bend.keyframes[1].points);
  const MapSampler map(cv, g);
  // Generated truth: the CPU synthesis of the same control volume, its labels taken at the
  // same source positions (what the movie renderer's deformed labels do).
  const auto synthesised = std::get<VolumeI16>(synthesize(AnyVolume(ph.ct), cv));
  const std::vector<float> u = upsampleMap(cv, g);
  LabelVolume labels(g);
  for (const Label& l : ph.labels.table()) labels.setLabel(l);
  for (size_t n = 0; n < labels.ids().size(); ++n)
    labels.ids().data()[n] = uint16_t(ph.labels.ids().sampleNearestMm({u[3 * n], u[3 * n + 1], u[3 * n + 2]}));

  // (1) Pixels on the voxel centres (axial, one pixel per voxel): both pictures sample the same
  // u, so they differ only by the synthesised volume's rounding to int16 (half a HU).
  ASSERT_DOUBLE_EQ(g.spacing.x, g.spacing.y);
  SlicePlane onVoxels;
  onVoxels.u = {1, 0, 0};
  onVoxels.v = {0, 1, 0};
  onVoxels.normal = {0, 0, 1};
  onVoxels.mmPerPixel = g.spacing.x;
  onVoxels.width = int(g.dims.x);
  onVoxels.height = int(g.dims.y);
  int64_t changed = 0;
  for (const int64_t k : {20, 30, 36, 44, 52}) {  // through the femur, the joint and the tibia
    onVoxels.center = g.indexToPhysical({g.dims.x / 2.0 - 0.5, g.dims.y / 2.0 - 0.5, double(k)});
    const RgbaImage through = renderSlice(ph.ct, onVoxels, styleWith(&ph.labels, &map));
    const RgbaImage truth = renderSlice(synthesised, onVoxels, styleWith(&labels, nullptr));
    const RgbaImage before = renderSlice(ph.ct, onVoxels, styleWith(&ph.labels, nullptr));
    int worst = 0;
    for (int y = 0; y < onVoxels.height; ++y)
      for (int x = 0; x < onVoxels.width; ++x) {
        worst = std::max(worst, channelDiff(through, x, y, truth, x, y));
        changed += channelDiff(through, x, y, before, x, y) > 20;
      }
    std::cout << "[ slices ] bend, axial slice k = " << k << " on the voxels: max channel difference " << worst << "\n";
    EXPECT_LE(worst, 1) << "slice " << k;
  }
  EXPECT_GT(changed, 2000) << "the bend must move the tissue in these slices";

  // (2) The studio's own plane (pixels between voxels): the two differ by interpolating twice
  // (the map, then the CT) against once; small on average, larger only at tissue edges.
  const SlicePlane studio = makePlane(SliceAxis::Coronal, g, phantom::flexionAxisPointMm(), 474, 399);
  const RgbaImage through = renderSlice(ph.ct, studio, styleWith(nullptr, &map));
  const RgbaImage truth = renderSlice(synthesised, studio, styleWith(nullptr, nullptr));
  const RgbaImage undeformed = renderSlice(ph.ct, studio, styleWith(nullptr, nullptr));
  double sum = 0, moved = 0;
  int64_t n = 0;
  for (int y = 0; y < studio.height; ++y)
    for (int x = 0; x < studio.width; ++x)
      if (wellInside(g, studio.toMm(x + 0.5, y + 0.5), 1)) {
        sum += channelDiff(through, x, y, truth, x, y);
        moved += channelDiff(undeformed, x, y, truth, x, y);
        ++n;
      }
  std::cout << "[ slices ] bend, coronal 474x399: mean channel difference " << sum / double(n)
            << " (the undeformed slice: " << moved / double(n) << ") over " << n << " pixels\n";
  ASSERT_GT(n, 50000);
  // Measured: 2.9 grey levels (64³, 15 HU noise, 2.8 mm voxels), 43.7 for the undeformed slice.
  EXPECT_LT(sum / double(n), 4.0);
  EXPECT_LT(sum, 0.15 * moved);
}

TEST(StudioDeformedSlices, AMapForAnotherGridIsRefused) {
  const phantom::Phantom& ph = knee();
  Geometry other = ph.ct.geometry();
  other.dims.z -= 8;
  const MapSampler map(identityControlVolume(other, 4), other);
  const SlicePlane plane = makePlane(SliceAxis::Axial, ph.ct.geometry(), ph.ct.geometry().center(), 64, 64);
  EXPECT_THROW(renderSlice(ph.ct, plane, styleWith(nullptr, &map)), Error);
}

using namespace vellum::test::studio;

TEST(StudioDeformedSlicesScript, ToggleOffRestoresTheUndeformedSliceAndTheSceneKeepsIt) {
  REQUIRE_DISPLAY();
  const fs::path d = test::tempDir("studio-deformed-slices");
  const auto ph = writePhantom(d, 48);
  const std::string script = scriptOnPhantom(d) + R"(
    {"layout":"2x2"},{"hud":false},{"screenshot":{"path":)" + q(d / "before.png") + R"(,"view":"axial"}},
    {"controls":"default"},
    {"drag_point":{"index":4,"end":"target","by_px":[40,-30],"view":"axial"}},{"wait_idle":true},
    {"screenshot":{"path":)" + q(d / "deformed.png") + R"(,"view":"axial"}},
    {"set":{"deformed_slices":false}},
    {"screenshot":{"path":)" + q(d / "off.png") + R"(,"view":"axial"}},
    {"save_scene":)" + q(d / "s.json") + R"(},
    {"set":{"deformed_slices":true}},
    {"screenshot":{"path":)" + q(d / "on.png") + R"(,"view":"axial"}},
    {"quit":0}]})";
  std::string log;
  ASSERT_EQ(runStudio(d, "toggle", script, &log), 0) << log;
  const RgbaImage before = io::loadImage(d / "before.png"), deformed = io::loadImage(d / "deformed.png"),
                  off = io::loadImage(d / "off.png"), on = io::loadImage(d / "on.png");
  ASSERT_EQ(before.width, deformed.width);
  int64_t moved = 0;
  for (size_t n = 0; n < before.pixels.size(); n += 4) moved += before.pixels[n] != deformed.pixels[n];
  EXPECT_GT(moved, int64_t(before.pixels.size() / 4 / 50)) << "the dragged target deforms the axial slice";
  EXPECT_EQ(off.pixels, before.pixels) << "toggled off: the undeformed slice, byte for byte";
  EXPECT_EQ(on.pixels, deformed.pixels) << "toggled on again: the same deformed slice";

  // The scene file keeps the setting; reopened, the slices stay undeformed although the
  // deformation is shown in 3D.
  const SceneFile s = readSceneFile(d / "s.json");
  EXPECT_FALSE(s.view.view.deformedSlices);
  ASSERT_TRUE(s.deformation);
  const std::string reopen = R"({"actions":[{"open":)" + q(d / "s.json") + R"(},{"hud":false},{"wait_idle":true},
    {"screenshot":{"path":)" + q(d / "reopened.png") + R"(,"view":"axial"}},{"quit":0}]})";
  ASSERT_EQ(runStudio(d, "reopen", reopen, &log), 0) << log;
  EXPECT_EQ(io::loadImage(d / "reopened.png").pixels, before.pixels);
}


// Painting in a deformed slice edits the undeformed label map at the source of the pixel under
// the pointer: the sphere lands around u = map(v), not around v.
TEST(StudioDeformedSlicesScript, PaintingInADeformedSliceLandsAtTheClickedPixelsSource) {
  REQUIRE_DISPLAY();
  const fs::path d = test::tempDir("studio-deformed-paint");
  const auto ph = writePhantom(d, 48);
  // The knee bent 30°, the axial slice through the calf (64 mm below the flexion axis).
  SceneFile f;
  f.volume = d / "ct.nrrd";
  f.labels = d / "labels.nrrd";
  f.crosshairMm = {0, 0, -40};
  f.deformation = SceneDeformation{d / "s.keyframes.json",
                                   kneeBendTrack(ph.ct.geometry(), 30.0, 2.0, phantom::flexionAxisPointMm()), 1, kBones,
                                   10.0, studioDeformParams()};
  writeSceneFile(f, d / "s.json");
  const std::vector<Pane> panes = layoutPanes(Layout::TwoByTwo, {kToolPanelWidth, 0, 1024 - kToolPanelWidth, 700});
  const Pane* axial = nullptr;
  for (const Pane& p : panes)
    if (p.slice == SliceAxis::Axial) axial = &p;
  ASSERT_TRUE(axial);
  const double px = std::floor(axial->rect.w * 0.5) + 0.5, py = std::floor(axial->rect.h * 0.55) + 0.5;
  const std::string click = "[" + std::to_string(axial->rect.x + px) + "," + std::to_string(axial->rect.y + py) + "]";
  const uint16_t id = 20;  // not a phantom label
  const std::string script = R"({"actions":[{"open":)" + q(d / "s.json") + R"(},{"wait_idle":true},
    {"tool":"paint"},{"brush_radius":6},{"active_label":20},{"click":)" + click + R"(},
    {"save_labels":)" + q(d / "painted.nrrd") + R"(},{"quit":0}]})";
  std::string log;
  ASSERT_EQ(runStudio(d, "paint", script, &log), 0) << log;

  // The same map as the window's (the session the studio runs, on the same scene).
  const SceneFile read = readSceneFile(d / "s.json");
  Scene scene;
  scene.ct = ph.ct;
  scene.labels = ph.labels;
  scene.authoring.track = read.deformation->track;
  scene.authoring.keyframe = read.deformation->keyframe;
  scene.authoring.rigidLabels = read.deformation->rigidLabels;
  scene.authoring.falloffMm = read.deformation->falloffMm;
  scene.authoring.engine = read.deformation->engine;
  scene.authoring.touch();
  DeformSession session;
  awaitExactMap(session, scene);
  ASSERT_TRUE(session.sampler() && !session.preview());
  const Geometry& g = ph.ct.geometry();
  const SlicePlane plane = makePlane(SliceAxis::Axial, g, f.crosshairMm, int(axial->rect.w), int(axial->rect.h));
  const Vec3 v = plane.toMm(px, py);
  const auto u = session.sampler()->sourceMm(v);
  ASSERT_TRUE(u);
  std::cout << "[ slices ] click at " << v.x << ", " << v.y << ", " << v.z << " mm paints around its source " << u->x
            << ", " << u->y << ", " << u->z << " mm\n";
  ASSERT_GT(norm(*u - v), 6 + 3 * g.spacing.x) << "the bend must move the clicked tissue well beyond the brush";
  const LabelVolume painted = io::loadLabels(d / "painted.nrrd");
  int64_t count = 0;
  double farthest = 0;
  for (int64_t k = 0; k < g.dims.z; ++k)
    for (int64_t j = 0; j < g.dims.y; ++j)
      for (int64_t i = 0; i < g.dims.x; ++i)
        if (painted(i, j, k) == id) {
          ++count;
          farthest = std::max(farthest, norm(g.indexToPhysical({double(i), double(j), double(k)}) - *u));
        }
  EXPECT_GT(count, 0);
  EXPECT_LE(farthest, 6.0 + 1e-6) << "every painted voxel lies in the brush sphere around the source";
}

}  // namespace
}  // namespace vellum::studio
