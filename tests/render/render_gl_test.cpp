// GL ray caster on llvmpipe (EGL): against the CPU reference, analytic geometry, and goldens.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <numbers>
#include <set>

#include "analytic_volumes.hpp"
#include "headless_gl.hpp"
#include "image_compare.hpp"
#include "light_volume.hpp"
#include "vellum/core/error.hpp"
#include "vellum/phantom/phantom.hpp"
#include "vellum/render/volume_renderer.hpp"

namespace vellum::render {
namespace {

GlContext& gl() { return test::headlessGl(); }

// GL vs CPU tolerances, in 8-bit levels. On llvmpipe the two agree to within one level on a
// handful of pixels (float vs double arithmetic; measured values in docs/benchmarks-render.md).
// The margin is for GPUs, whose texture filters use 8-bit sub-texel weights.
constexpr double kMeanTolerance = 1.0;  // per channel
constexpr double kP99Tolerance = 4.0;

void expectClose(const RgbaImage& gpu, const RgbaImage& cpu, const std::string& what) {
  const test::ImageDiff d = test::compareImages(gpu, cpu);
  std::cout << "[ diff ] " << what << ": mean " << d.meanAbs[0] << " " << d.meanAbs[1] << " "
            << d.meanAbs[2] << " " << d.meanAbs[3] << "  p99 " << d.p99 << "  max " << d.maxAbs
            << "  psnr " << d.psnr << " dB\n";
  for (int c = 0; c < 4; ++c) EXPECT_LT(d.meanAbs[c], kMeanTolerance) << what << " channel " << c;
  EXPECT_LE(d.p99, kP99Tolerance) << what;
}

RenderSettings baseSettings(Preset p, int w = 160, int h = 128) {
  RenderSettings s;
  s.preset = p;
  s.width = w;
  s.height = h;
  return s;
}

/// Fraction of pixels that are not the background colour (guards against empty images).
double coverage(const RgbaImage& img) {
  size_t n = 0;
  for (size_t i = 0; i < img.pixels.size(); i += 4)
    n += img.pixels[i] > 8 || img.pixels[i + 1] > 8 || img.pixels[i + 2] > 8;
  return double(n) / double(img.pixels.size() / 4);
}

TEST(RenderGl, ContextIsGl4Core) {
  EXPECT_FALSE(gl().renderer().empty());
  EXPECT_EQ(gl().version().rfind("4.", 0), 0u) << gl().version();
  std::cout << "[ gl   ] " << gl().renderer() << " | " << gl().version() << "\n";
}

// A (hidden) GLFW window renders like the headless context; needs a display (xvfb-run -a).
TEST(RenderGl, WindowContextRenders) {
  const char* display = std::getenv("DISPLAY");
  if (!display || !*display) GTEST_SKIP() << "no DISPLAY (run under xvfb-run -a)";
  const AnyVolume v = test::makeAnalyticVolume(32);
  RenderSettings s = baseSettings(Preset::SoftTissueBone, 64, 64);
  RgbaImage windowed;
  {
    auto window = GlContext::createWindow(64, 64, "vellum test", false);
    EXPECT_EQ(window->version().rfind("4.", 0), 0u) << window->version();
    VolumeRenderer r(*window);
    r.setVolume(v);
    windowed = r.render(s);
  }
  VolumeRenderer r(gl());
  r.setVolume(v);
  expectClose(windowed, r.render(s), "window vs headless");
}

TEST(RenderGl, RejectsBadSizesAndNoVolume) {
  VolumeRenderer r(gl());
  RenderSettings s = baseSettings(Preset::Mip, 16, 16);
  EXPECT_THROW(r.render(s), Error);  // no volume yet
  r.setVolume(test::makeBallVolume(8, 1.0, 2.0));
  s.width = 4097;
  EXPECT_THROW(r.render(s), Error);
  s.width = 16;
  s.height = 0;
  EXPECT_THROW(r.render(s), Error);
}

// The largest size renders: a small volume zoomed out so that few rays hit it.
TEST(RenderGl, AcceptsMaximumSize) {
  VolumeRenderer r(gl());
  r.setVolume(test::makeBallVolume(8, 1.0, 3.0));
  RenderSettings s = baseSettings(Preset::Mip, 4096, 4096);
  s.camera.zoom = 0.25;
  const RgbaImage img = r.render(s);
  ASSERT_EQ(img.width, 4096);
  ASSERT_EQ(img.height, 4096);
  EXPECT_GT(img.at(2048, 2048)[0], 150);  // ball centre: 1000 HU -> grey 0.8
  EXPECT_EQ(img.at(0, 0)[0], 0);
}

TEST(RenderGl, MipMatchesCpu) {
  const AnyVolume v = test::makeAnalyticVolume(64);
  VolumeRenderer r(gl());
  r.setVolume(v);
  for (double fov : {30.0, 0.0}) {
    RenderSettings s = baseSettings(Preset::Mip);
    s.camera.fieldOfViewDeg = fov;
    const RgbaImage gpu = r.render(s);
    EXPECT_GT(coverage(gpu), 0.1);  // the ellipsoid covers ~12% of the frame
    expectClose(gpu, renderReferenceCpu(v, s), "mip fov " + std::to_string(int(fov)));
  }
}

TEST(RenderGl, DvrMatchesCpu) {
  const AnyVolume v = test::makeAnalyticVolume(64);
  VolumeRenderer r(gl());
  r.setVolume(v);
  for (Preset p : {Preset::SoftTissueBone, Preset::Bone}) {
    RenderSettings s = baseSettings(p);
    s.camera.azimuthDeg = 60;
    const RgbaImage gpu = r.render(s);
    EXPECT_GT(coverage(gpu), p == Preset::Bone ? 0.015 : 0.1);
    expectClose(gpu, renderReferenceCpu(v, s), std::string("dvr ") + presetName(p));
  }
}

// Axis-aligned orthographic rays do not move along two axes: empty-space skipping once
// ended them at once (an empty picture after seconds). Every preset, GL == CPU.
TEST(RenderGl, AxisAlignedOrthographicViewsMatchCpu) {
  phantom::PhantomOptions o;
  o.dims = {64, 64, 64};
  const AnyVolume v = phantom::makePhantom(o).ct;
  VolumeRenderer r(gl());
  r.setVolume(v);
  for (auto [az, el] : {std::pair{0.0, 0.0}, {90.0, 0.0}, {0.0, 90.0}})
    for (Preset p : allPresets()) {
      RenderSettings s = baseSettings(p, 96, 96);
      s.camera.fieldOfViewDeg = 0;
      s.camera.azimuthDeg = az;
      s.camera.elevationDeg = el;
      const RgbaImage gpu = r.render(s);
      EXPECT_GT(coverage(gpu), 0.01) << presetName(p) << " az " << az << " el " << el;
      expectClose(gpu, renderReferenceCpu(v, s), std::string("axis-aligned ") + presetName(p));
    }
}

TEST(RenderGl, DeformedMatchesCpu) {
  const VolumeI16 vol = test::makeAnalyticVolume(64);
  const AnyVolume v = vol;
  const BackwardMap map = test::makeTwistMap(vol.geometry(), 17, true);
  VolumeRenderer r(gl());
  r.setVolume(v);
  r.setBackwardMap(&map);
  for (Preset p : {Preset::SoftTissueBone, Preset::Bone, Preset::Mip}) {
    const RenderSettings s = baseSettings(p);
    const RgbaImage gpu = r.render(s);
    EXPECT_GT(coverage(gpu), p == Preset::Bone ? 0.005 : 0.03);  // the map's larger box makes the volume smaller
    expectClose(gpu, renderReferenceCpu(v, s, &map), std::string("deformed ") + presetName(p));
  }
  // The deformation really changes the picture.
  const RgbaImage deformed = r.render(baseSettings(Preset::SoftTissueBone));
  r.setBackwardMap(nullptr);
  const RgbaImage plain = r.render(baseSettings(Preset::SoftTissueBone));
  EXPECT_GT(test::compareImages(deformed, plain).meanAbs[0], 5.0);
}

TEST(RenderGl, IdentityMapMatchesUndeformed) {
  const VolumeI16 vol = test::makeAnalyticVolume(48);
  const BackwardMap map = test::makeIdentityMap(vol.geometry());
  VolumeRenderer r(gl());
  r.setBackwardMap(&map);  // before the volume: converted when the volume arrives
  r.setVolume(vol);
  const RenderSettings s = baseSettings(Preset::SoftTissueBone);
  const RgbaImage deformed = r.render(s);
  r.setBackwardMap(nullptr);
  expectClose(deformed, r.render(s), "identity map vs none");
}

TEST(RenderGl, RowBandsEqualTheFullRender) {
  // renderRows() (the studio's progressive refinement) gives render()'s exact pixels.
  VolumeRenderer r(gl());
  r.setVolume(test::makeAnalyticVolume(48));
  for (Preset p : {Preset::SoftTissueBone, Preset::Mip}) {
    const RenderSettings s = baseSettings(p, 96, 70);
    const RgbaImage full = r.render(s);
    RgbaImage banded(s.width, s.height);
    for (int row = 0; row < s.height; row += 16) r.renderRows(s, row, row + 16, banded);
    EXPECT_EQ(banded.pixels, full.pixels) << presetName(p);
  }
  RgbaImage wrong(10, 10);
  EXPECT_THROW(r.renderRows(baseSettings(Preset::Bone, 96, 70), 0, 10, wrong), Error);
}

TEST(RenderGl, VoxelTypesGiveTheSamePicture) {
  const VolumeI16 vol = test::makeAnalyticVolume(48);
  VolumeRenderer r(gl());
  r.setVolume(vol);
  const RenderSettings s = baseSettings(Preset::SoftTissueBone);
  const RgbaImage i16 = r.render(s);
  r.setVolume(toFloat32(vol));
  expectClose(r.render(s), i16, "float32 vs int16");
}

TEST(RenderGl, MipBallHasTheAnalyticRadius) {
  const double radius = 12.0;
  VolumeRenderer r(gl());
  r.setVolume(test::makeBallVolume(48, 1.0, radius));
  RenderSettings s = baseSettings(Preset::Mip, 256, 256);
  s.camera.fieldOfViewDeg = 0;
  const RgbaImage img = r.render(s);
  int count = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) count += img.at(x, y)[0] > 76;  // 0 HU, halfway between ball and air
  const double measured = std::sqrt(count / std::numbers::pi);
  const double expected = radius / (2 * std::sqrt(3.0) * 24.0 / s.height);
  EXPECT_NEAR(measured, expected, 0.6);
}

TEST(RenderGl, TransparentBackground) {
  VolumeRenderer r(gl());
  r.setVolume(test::makeAnalyticVolume(48));
  for (Preset p : allPresets()) {
    RenderSettings s = baseSettings(p, 64, 64);
    s.background = {1, 1, 1, 0};
    const RgbaImage img = r.render(s);
    for (auto [x, y] : {std::pair{0, 0}, {63, 0}, {0, 63}, {63, 63}})
      EXPECT_EQ(img.at(x, y)[3], 0) << presetName(p);
    EXPECT_GT(img.at(32, 32)[3], 100) << presetName(p);
  }
  // An opaque background is opaque everywhere.
  RenderSettings s = baseSettings(Preset::Bone, 64, 64);
  s.background = {0.2f, 0.3f, 0.4f, 1};
  const RgbaImage img = r.render(s);
  EXPECT_EQ(img.at(0, 0)[3], 255);
  EXPECT_NEAR(img.at(0, 0)[2], 102, 1);
}

// Seen from behind, a front-back symmetric volume is the mirror image of the front view.
TEST(RenderGl, Azimuth180MirrorsAzimuth0) {
  // Ball off-centre along x (so the mirror is visible), symmetric in y.
  const VolumeI16 vol = test::makeBallVolume(48, 1.0, 8.0, 1000, {9, 0, 4});
  VolumeRenderer r(gl());
  r.setVolume(vol);
  for (Preset p : {Preset::Mip, Preset::Bone}) {
    RenderSettings s = baseSettings(p, 96, 96);
    s.jitter = false;  // the per-pixel jitter pattern is not mirror-symmetric
    s.camera.azimuthDeg = 0;
    s.camera.elevationDeg = 0;
    const RgbaImage front = r.render(s);
    s.camera.azimuthDeg = 180;
    const RgbaImage back = r.render(s);
    const test::ImageDiff d = test::compareImages(test::mirrored(back), front);
    EXPECT_LT(d.meanAbs[0], 0.1) << presetName(p);
    EXPECT_LE(d.maxAbs, 2) << presetName(p);
    // ... and not trivially equal to the unmirrored one.
    EXPECT_GT(test::compareImages(back, front).meanAbs[0], 2.0) << presetName(p);
  }
}

// Fixed pictures: regenerate with VELLUM_UPDATE_GOLDEN=1 after an intended change.
TEST(RenderGl, GoldenImages) {
  const bool update = std::getenv("VELLUM_UPDATE_GOLDEN") != nullptr;
  VolumeRenderer r(gl());
  r.setVolume(test::makeAnalyticVolume(64));
  for (Preset p : allPresets()) {
    const RgbaImage img = r.render(baseSettings(p, 256, 256));
    const std::filesystem::path path =
        std::filesystem::path(VELLUM_RENDER_GOLDEN_DIR) / (std::string(presetName(p)) + ".png");
    if (update) {
      test::writePng(img, path);
      std::cout << "[ gold ] wrote " << path << "\n";
      continue;
    }
    const RgbaImage golden = test::readPng(path);
    ASSERT_EQ(golden.width, 256) << "missing golden " << path << " (VELLUM_UPDATE_GOLDEN=1)";
    const test::ImageDiff d = test::compareImages(img, golden);
    const double meanAll = (d.meanAbs[0] + d.meanAbs[1] + d.meanAbs[2] + d.meanAbs[3]) / 4;
    std::cout << "[ gold ] " << presetName(p) << ": psnr " << d.psnr << " dB, mean " << meanAll << "\n";
    EXPECT_TRUE(d.psnr >= 40.0 || meanAll <= 1.0) << presetName(p) << " psnr " << d.psnr;
    // Inside the object's footprint too: bone covers a few percent of the frame, so a large
    // shading error there would hardly move the whole-image figures.
    const auto& bg = baseSettings(p, 256, 256).background;
    const std::array<uint8_t, 4> bg8{uint8_t(std::lround(bg[0] * 255)), uint8_t(std::lround(bg[1] * 255)),
                                     uint8_t(std::lround(bg[2] * 255)), uint8_t(std::lround(bg[3] * 255))};
    const auto mask = test::objectMask(img, golden, bg8);
    const test::ImageDiff inside = test::compareImages(img, golden, &mask);
    const double meanInside = (inside.meanAbs[0] + inside.meanAbs[1] + inside.meanAbs[2] + inside.meanAbs[3]) / 4;
    std::cout << "[ gold ] " << presetName(p) << " inside the object: psnr " << inside.psnr << " dB, mean "
              << meanInside << "\n";
    EXPECT_GT(std::count(mask.begin(), mask.end(), uint8_t{1}), 256 * 256 / 100) << presetName(p);
    EXPECT_TRUE(inside.psnr >= 35.0 && meanInside <= 1.5) << presetName(p) << " inside psnr " << inside.psnr;
  }
}

}  // namespace
// Issue 10: label colours in the 3D view. GL and the CPU reference agree; the tint pulls the
// labelled structures to their colours; blend 0 draws exactly what no tint draws.
TEST(RenderGl, LabelColoursTintTheVolume) {
  phantom::PhantomOptions o;
  o.dims = {48, 48, 48};
  const auto ph = phantom::makePhantom(o);
  const AnyVolume v = ph.ct;
  LabelVolume green = ph.labels;
  for (const Label& l : ph.labels.table()) green.setLabel({l.id, l.name, {0, 255, 0}});
  const LabelTint tint = makeLabelTint(green);
  VolumeRenderer r(gl());
  r.setVolume(v);
  RenderSettings s = baseSettings(Preset::Bone);
  const RgbaImage plain = r.render(s);
  r.setLabelTint(&tint);
  EXPECT_EQ(r.render(s).pixels, plain.pixels) << "label_blend 0: no tint";
  s.labelBlend = 0.9;
  const RgbaImage tinted = r.render(s);
  expectClose(tinted, renderReferenceCpu(v, s, nullptr, &tint), "bone, label colours");
  double red = 0, greenSum = 0;
  size_t n = 0;
  for (size_t i = 0; i < tinted.pixels.size(); i += 4)
    if (tinted.pixels[i + 3] > 128 && (tinted.pixels[i] > 8 || tinted.pixels[i + 1] > 8)) {
      red += tinted.pixels[i];
      greenSum += tinted.pixels[i + 1];
      ++n;
    }
  ASSERT_GT(n, 100u);
  EXPECT_GT(greenSum, 2.0 * red) << "the bones take the (green) label colour";
  // Hidden labels are not tinted: hiding every id gives the plain picture back.
  std::set<uint16_t> all;
  for (const Label& l : ph.labels.table()) all.insert(l.id);
  const LabelTint none = makeLabelTint(green, all);
  r.setLabelTint(&none);
  EXPECT_LE(test::compareImages(r.render(s), plain).maxAbs, 1);
  // A label map of another grid is refused.
  Geometry other;
  other.dims = {8, 8, 8};
  LabelTint wrong = tint;
  wrong.ids = VolumeU16(other, 0, 0);
  EXPECT_THROW(r.setLabelTint(&wrong), Error);
}

namespace {
// Anisotropic voxels (1.0, 1.2, 1.5 mm) on a 48 mm cube, centred at the origin: a tilted slab
// of bone (flat faces: its lighting shows the normals' direction) and a soft-tissue ball, all
// within 20 mm of the superior axis, so a turn about it keeps them inside the box.
VolumeI16 tiltedSlabVolume() {
  Geometry g;
  g.dims = {48, 40, 32};
  g.spacing = {1.0, 1.2, 1.5};
  g.origin = {-23.5, -23.4, -23.25};  // box [-24, 24] mm on every axis
  VolumeI16 vol(g, -1000, -1000.0);
  const Vec3 slabNormal = normalized(Vec3{1, 2, 0.5});
  const auto ramp = [](double d) { return std::clamp(0.5 - d / 2.0, 0.0, 1.0); };  // 2 mm edges
  for (int64_t k = 0; k < g.dims.z; ++k)
    for (int64_t j = 0; j < g.dims.y; ++j)
      for (int64_t i = 0; i < g.dims.x; ++i) {
        const Vec3 q = g.indexToPhysical({double(i), double(j), double(k)});
        const Vec3 b = q - Vec3{-6, 4, 2};
        const double slab = std::max({std::abs(dot(b, slabNormal)) - 4.0, std::hypot(b.x, b.y) - 14.0, std::abs(b.z) - 16.0});
        double v = -1000 + ramp(norm(q - Vec3{8, -6, -4}) - 9.0) * 1040;  // soft tissue
        v += ramp(slab) * (1000 - v);
        vol(i, j, k) = int16_t(std::lround(v));
      }
  return vol;
}

// u(v) = R^T (v - c) + c, R = turn by `deg` about +z: the volume turned by R about the box centre
// c (the origin). Nodes every other voxel, with the same box as the volume's (so the camera
// frames both alike).
BackwardMap turnAboutZ(const Geometry& volume, double deg) {
  BackwardMap m;
  m.grid = volume;
  m.grid.dims = {volume.dims.x / 2, volume.dims.y / 2, volume.dims.z / 2};
  m.grid.spacing = volume.spacing * 2.0;
  m.grid.origin = volume.origin + volume.spacing * 0.5;
  const double a = deg * std::numbers::pi / 180;
  const Dims& d = m.grid.dims;
  for (int64_t k = 0; k < d.z; ++k)
    for (int64_t j = 0; j < d.y; ++j)
      for (int64_t i = 0; i < d.x; ++i) {
        const Vec3 v = m.grid.indexToPhysical({double(i), double(j), double(k)});
        const Vec3 u{std::cos(a) * v.x + std::sin(a) * v.y, -std::sin(a) * v.x + std::cos(a) * v.y, v.z};
        m.sourceMm.insert(m.sourceMm.end(), {float(u.x), float(u.y), float(u.z)});
      }
  return m;
}

// The tilted slab seen from azimuth 40 + turnDeg, elevation 20: a 30 degree turn of the volume
// about the superior axis looks like the camera turned by -30.
RenderSettings slabView(double turnDeg) {
  RenderSettings s = baseSettings(Preset::SoftTissueBone);
  s.camera.azimuthDeg = 40 + turnDeg;
  s.camera.elevationDeg = 20;
  return s;
}
}  // namespace

// Issue 11: a deformed render shades with the normals the deformation turned. A map that
// turns the volume 30 degrees about the superior axis looks like the plain volume seen from a
// camera turned -30 degrees; with the source's unturned normals the lighting is clearly off.
TEST(RenderGl, DeformedShadingTurnsNormalsWithTheMap) {
  const VolumeI16 vol = tiltedSlabVolume();
  BackwardMap turn = turnAboutZ(vol.geometry(), 30);
  ASSERT_NEAR(norm(turn.grid.indexToPhysical({-0.5, -0.5, -0.5}) - vol.geometry().indexToPhysical({-0.5, -0.5, -0.5})), 0, 1e-9);
  VolumeRenderer r(gl());
  r.setVolume(vol);
  RenderSettings s = slabView(0), truthSettings = slabView(-30);
  const RgbaImage truth = r.render(truthSettings);
  EXPECT_GT(coverage(truth), 0.05);
  for (const Upsampling up : {Upsampling::Trilinear, Upsampling::Gaussian}) {  // both reproduce a turn
    const std::string kernel = up == Upsampling::Gaussian ? "gaussian" : "trilinear";
    turn.upsampling = up;
    r.setBackwardMap(&turn);
    const RgbaImage turned = r.render(s);
    s.turnDeformedNormals = false;
    const RgbaImage unturned = r.render(s);
    s.turnDeformedNormals = true;
    if (std::getenv("VELLUM_DUMP")) {
      test::writePng(truth, "/tmp/a2-truth.png");
      test::writePng(turned, "/tmp/a2-turned.png");
      test::writePng(unturned, "/tmp/a2-unturned.png");
    }
    const std::vector<uint8_t> mask = test::objectMask(truth, turned, {0, 0, 0, 255});
    const double pTurned = test::compareImages(turned, truth, &mask).psnr;
    const double pUnturned = test::compareImages(unturned, truth, &mask).psnr;
    std::cout << "[ psnr ] " << kernel << ": turned map vs turned camera " << pTurned << " dB; unturned normals "
              << pUnturned << " dB\n";
    EXPECT_GE(pTurned, 40.0) << kernel;
    EXPECT_LT(pUnturned, 32.0) << kernel << ": the source's normals light the turned slab as if unturned";
    // The CPU reference turns them the same way.
    const RgbaImage cpu = renderReferenceCpu(vol, s, &turn);
    expectClose(turned, cpu, "turned normals, GL vs CPU, " + kernel);
    EXPECT_GE(test::compareImages(turned, cpu).psnr, 40.0) << kernel;
    EXPECT_GE(test::compareImages(cpu, renderReferenceCpu(vol, truthSettings), &mask).psnr, 40.0) << kernel;
  }
}

}  // namespace vellum::render

namespace vellum::render {

// Where the rigid snap moves a sample, its normal turns with the snapping body exactly, not
// with the node map's differences (which straddle rigid and blended motion near a bone's
// surface). Here the node map is the identity and one body covering the whole volume turns it
// 30 degrees: the positions and the lighting must both be the turned slab's.
TEST(RenderGl, SnappedSamplesShadeWithTheirBodysTurn) {
  const VolumeI16 vol = tiltedSlabVolume();
  BackwardMap map = turnAboutZ(vol.geometry(), 0);  // identity nodes
  auto snap = std::make_shared<RigidSnap>();
  snap->classGrid = vol.geometry();
  snap->classes = std::make_shared<const std::vector<uint16_t>>(static_cast<size_t>(vol.geometry().dims.voxelCount()), uint16_t{2});
  const double a = 30 * std::numbers::pi / 180;  // u = R v as turnAboutZ(30) maps
  snap->fits = {{std::cos(a), std::sin(a), 0, -std::sin(a), std::cos(a), 0, 0, 0, 1, 0, 0, 0}};
  snap->valid = {1};
  snap->maxSnapMm = 1000;
  map.rigidSnap = snap;
  VolumeRenderer r(gl());
  r.setVolume(vol);
  RenderSettings s = slabView(0), truthSettings = slabView(-30);
  const RgbaImage truth = r.render(truthSettings);
  r.setBackwardMap(&map);
  const RgbaImage snapped = r.render(s);
  s.turnDeformedNormals = false;
  const RgbaImage unturned = r.render(s);
  s.turnDeformedNormals = true;
  const std::vector<uint8_t> mask = test::objectMask(truth, snapped, {0, 0, 0, 255});
  const double pSnapped = test::compareImages(snapped, truth, &mask).psnr;
  const double pUnturned = test::compareImages(unturned, truth, &mask).psnr;
  std::cout << "[ psnr ] body-turned normals vs turned camera " << pSnapped << " dB; unturned " << pUnturned << " dB\n";
  EXPECT_GE(pSnapped, 40.0);
  EXPECT_LT(pUnturned, 32.0) << "the identity node map alone would leave the normals unturned";
  const RgbaImage cpu = renderReferenceCpu(vol, s, &map);
  EXPECT_GE(test::compareImages(snapped, cpu).psnr, 40.0) << "GL vs CPU reference";
}

// A held body (RigidSnap::held: a fixed region) stays where it is in the shader as
// on the CPU, whatever the node map says there: here the nodes turn everything 30 degrees and
// the held body covers the volume, so the picture is the unturned slab's.
TEST(RenderGl, HeldBodiesIgnoreTheNodeMap) {
  const VolumeI16 vol = tiltedSlabVolume();
  BackwardMap map = turnAboutZ(vol.geometry(), 30);
  auto snap = std::make_shared<RigidSnap>();
  snap->classGrid = vol.geometry();
  snap->classes = std::make_shared<const std::vector<uint16_t>>(static_cast<size_t>(vol.geometry().dims.voxelCount()), uint16_t{2});
  snap->fits = {{1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0}};
  snap->valid = {1};
  snap->held = {1};
  map.rigidSnap = snap;
  VolumeRenderer r(gl());
  r.setVolume(vol);
  const RenderSettings s = slabView(0);
  const RgbaImage still = r.render(s);
  r.setBackwardMap(&map);
  const RgbaImage held = r.render(s);
  const double pHeld = test::compareImages(held, still).psnr;
  EXPECT_GE(pHeld, 40.0) << "the held body moved with the node map";
  EXPECT_GE(test::compareImages(held, renderReferenceCpu(vol, s, &map)).psnr, 40.0) << "GL vs CPU reference";
  BackwardMap loose = map;
  auto unheld = std::make_shared<RigidSnap>(*snap);
  unheld->held.clear();
  loose.rigidSnap = unheld;
  r.setBackwardMap(&loose);
  EXPECT_LT(test::compareImages(r.render(s), still).psnr, 30.0) << "the case does not turn without the held flag";
}

}  // namespace vellum::render

namespace vellum::render {
namespace {

// Cinematic lighting: GL equals the CPU reference (same light volume bytes), and a ball lit
// from the left is darker on its right than the headlit ball.
TEST(RenderGl, LightingMatchesCpuAndShadowsTheFarSide) {
  const AnyVolume v = test::makeAnalyticVolume(64);
  VolumeRenderer r(gl());
  r.setVolume(v);
  for (Preset p : {Preset::SoftTissueBone, Preset::Bone}) {
    RenderSettings s = baseSettings(p);
    s.camera.azimuthDeg = 60;
    s.lighting.shadows = 1;
    s.lighting.occlusion = 1;
    s.lighting.exposure = p == Preset::Bone ? 0.4 : 0.0;
    const RgbaImage lit = r.render(s);
    expectClose(lit, renderReferenceCpu(v, s), std::string("lit ") + presetName(p));
    s.lighting = {};
    EXPECT_GT(test::compareImages(lit, r.render(s)).meanAbs[0], 0.5) << "lighting changes the picture";
  }
  // A ball in the middle, looked at from anterior, the key light from the left of the view:
  // its right half falls into its own shadow.
  const AnyVolume ball = test::makeBallVolume(64, 1.0, 20);
  r.setVolume(ball);
  RenderSettings s = baseSettings(Preset::Bone, 128, 128);
  s.camera.azimuthDeg = 0;
  s.camera.elevationDeg = 0;
  auto halves = [](const RgbaImage& img) {
    double left = 0, right = 0;
    for (int y = 0; y < img.height; ++y)
      for (int x = 0; x < img.width; ++x) (x < img.width / 2 ? left : right) += img.at(x, y)[0];
    return std::pair{left, right};
  };
  const auto [plainLeft, plainRight] = halves(r.render(s));
  EXPECT_NEAR(plainLeft / plainRight, 1.0, 0.03) << "the headlit ball is symmetric";
  s.lighting.shadows = 1;
  s.lighting.azimuthDeg = -90;
  s.lighting.elevationDeg = 0;
  const RgbaImage side = r.render(s);
  const auto [litLeft, litRight] = halves(side);
  EXPECT_GT(litLeft / litRight, 1.25) << "the far side is in the ball's own shadow";
  expectClose(side, renderReferenceCpu(ball, s), "side-lit ball");
  s.lighting.exposure = 0.5;  // a half stop brightens the unclamped lit half by sqrt(2)
  const RgbaImage brighter = r.render(s);
  const auto [brightLeft, brightRight] = halves(brighter);
  EXPECT_GT(brightLeft / litLeft, 1.2);
  EXPECT_LT(brightLeft / litLeft, 1.45);
  expectClose(brighter, renderReferenceCpu(ball, s), "side-lit ball, +0.5 stop");
}

}  // namespace
}  // namespace vellum::render

namespace vellum::render {
namespace {

// The ray caster with the cinematic lights (lighting.toneMap: soft key, fill, sky, ACES): GL
// equals the CPU reference (the same light volume bytes, lights and tone map), and the soft key
// light's penumbra is wider than the sharp one's: more light-volume cells half in shadow.
TEST(RenderGl, ToneMappedAreaLightMatchesCpu) {
  const AnyVolume ball = test::makeBallVolume(48, 1.0, 14);
  VolumeRenderer r(gl());
  r.setVolume(ball);
  RenderSettings s = baseSettings(Preset::Bone, 96, 96);
  s.camera.azimuthDeg = 0;
  s.camera.elevationDeg = 0;
  s.lighting.shadows = 1;
  s.lighting.occlusion = 1;
  s.lighting.azimuthDeg = -70;
  s.lighting.elevationDeg = 20;
  s.lighting.toneMap = true;
  s.lighting.exposure = 0.3;
  s.cinematic.lightSizeDeg = 8;
  s.cinematic.fillLight = 0.3;
  s.cinematic.skyLight = 0.4;
  const RgbaImage soft = r.render(s);
  expectClose(soft, renderReferenceCpu(ball, s), "tone-mapped area light");
  s.lighting.toneMap = false;
  EXPECT_GT(test::compareImages(soft, r.render(s)).meanAbs[0], 1.0) << "the tone map changes the picture";
  // Left vs right half: lit from the left, the right half is darker (the tone map, the fill
  // and the sky soften the contrast); the fill keeps it above black.
  double left = 0, right = 0;
  for (int y = 0; y < soft.height; ++y)
    for (int x = 0; x < soft.width; ++x) (x < soft.width / 2 ? left : right) += soft.at(x, y)[1];
  EXPECT_GT(left, 1.06 * right);
  EXPECT_GT(right, 0.0);
  const auto penumbra = [&](double sizeDeg) {
    const detail::Frame f = detail::makeFrame(geometryOf(ball), nullptr, s);
    const detail::LightVolume lv =
        detail::computeLightVolume(detail::makeLightSource(ball), detail::buildTfTable(s, f.stepMm), f.stepMm,
                                   detail::keyLightDirection(f, s.lighting), s.lighting, sizeDeg);
    int n = 0;
    for (size_t i = 0; i < lv.rg.size(); i += 2) n += lv.rg[i] > 25 && lv.rg[i] < 230;
    return n;
  };
  EXPECT_GT(penumbra(8), penumbra(0) * 3 / 2) << "a disc light softens the shadow's edge";
}

}  // namespace
}  // namespace vellum::render

namespace vellum::render {
namespace {

// A floor slab and a bone block above it (48^3, 1 mm), the block at x index [x0, x0 + 10].
VolumeI16 blockOverFloor(int x0) {
  Geometry g;
  g.dims = {48, 48, 48};
  g.origin = {-23.5, -23.5, -23.5};
  VolumeI16 vol(g, int16_t(-1000), -1000.0);
  for (int64_t k = 0; k < 48; ++k)
    for (int64_t j = 0; j < 48; ++j)
      for (int64_t i = 0; i < 48; ++i) {
        // Clear of the box's faces, where a map's clamped nodes and the plain texture's border differ.
        const bool floor = k >= 4 && k <= 9 && i >= 3 && i <= 44 && j >= 3 && j <= 44;
        const bool block = i >= x0 && i <= x0 + 10 && j >= 16 && j <= 30 && k >= 24 && k <= 34;
        if (floor || block) vol(i, j, k) = 1000;
      }
  return vol;
}

}  // namespace

// Issue 24: under a deformation the light volume is the DEFORMED anatomy's. A map that moves
// only the upper half (the block, 12 mm along x; the floor stays) must cast the block's shadow
// where the block now is: the deformed render equals the plain render of the moved block, and
// the CPU reference agrees. The light volume made from the undeformed source would keep the
// shadow under the block's old place.
TEST(RenderGl, ShadowsFollowTheDeformation) {
  const int shift = 12;
  const VolumeI16 before = blockOverFloor(10), moved = blockOverFloor(10 + shift);
  BackwardMap map;  // nodes at the voxel centres; u = v - shift above k = 16, identity below
  map.grid = before.geometry();
  for (int64_t k = 0; k < 48; ++k)
    for (int64_t j = 0; j < 48; ++j)
      for (int64_t i = 0; i < 48; ++i) {
        const Vec3 v = map.grid.indexToPhysical({double(i), double(j), double(k)});
        const double dx = k >= 16 ? shift : 0.0;
        map.sourceMm.insert(map.sourceMm.end(), {float(v.x - dx), float(v.y), float(v.z)});
      }
  RenderSettings s = baseSettings(Preset::Bone, 64, 64);
  s.camera.azimuthDeg = 0;
  s.camera.elevationDeg = 35;
  s.lighting.shadows = 1;
  s.lighting.occlusion = 0.5;
  s.lighting.azimuthDeg = 0;
  s.lighting.elevationDeg = 80;  // from above: the block's shadow falls on the floor beneath it

  // The light volume itself: transmittance at the floor's top under the block's new and old places.
  const detail::Frame f = detail::makeFrame(before.geometry(), &map.grid, s);
  const detail::PreparedMap pm = detail::prepareMap(map, before.geometry());
  const detail::LightVolume lv =
      detail::computeLightVolume(detail::lightSourceFor(before, &map, pm), detail::buildTfTable(s, f.stepMm), f.stepMm,
                                 detail::keyLightDirection(f, s.lighting), s.lighting);
  const double underNew = lv.sample({15.0 + shift, 23, 11})[0], underOld = lv.sample({15.0, 23, 11})[0];
  std::cout << "[ light ] transmittance under the moved block " << underNew << ", under its old place " << underOld << "\n";
  EXPECT_LT(underNew, 0.3);
  EXPECT_GT(underOld, 0.8);

  VolumeRenderer r(gl());
  r.setVolume(moved);
  const RgbaImage truth = r.render(s);
  RenderSettings unshadowed = s;
  unshadowed.lighting.shadows = 0;
  const RgbaImage truthUnshadowed = r.render(unshadowed);
  r.setVolume(before);
  r.setBackwardMap(&map);
  const RgbaImage deformed = r.render(s);
  if (std::getenv("VELLUM_DUMP")) {
    test::writePng(truth, "/tmp/s24-moved.png");
    test::writePng(deformed, "/tmp/s24-deformed.png");
  }
  EXPECT_GT(coverage(truth), 0.1);
  expectClose(deformed, truth, "shadows through a moving map vs the moved block");
  expectClose(deformed, renderReferenceCpu(before, s, &map), "deformed shadows, GL vs CPU");

  // The path tracer's volume shadows (the same light volume, looked up in the box): over the
  // moved block's shadow (where the ray cast darkens by more than 20 levels) the traced floor is
  // as dark as the moved block's, not lit as under the block's old place (the undeformed volume).
  std::vector<uint8_t> shadow(size_t(s.width) * size_t(s.height), 0);
  size_t shadowPixels = 0;
  for (int y = 0; y < s.height; ++y)
    for (int x = 0; x < s.width; ++x)
      if (int(truthUnshadowed.at(x, y)[0]) - int(truth.at(x, y)[0]) > 20) shadow[size_t(y * s.width + x)] = 1, ++shadowPixels;
  ASSERT_GT(shadowPixels, 100u);
  const auto shadowMean = [&](const RgbaImage& img) {
    double sum = 0;
    for (size_t i = 0; i < shadow.size(); ++i) sum += shadow[i] ? img.pixels[4 * i] : 0;
    return sum / double(shadowPixels);
  };
  s.quality = Quality::Cinematic;
  s.cinematic.volumeShadows = true;
  s.cinematic.samples = 8;
  s.cinematic.denoise = 0;
  const double tracedDeformed = shadowMean(r.render(s));
  r.setBackwardMap(nullptr);
  // (The first undeformed pass after a deformed one makes a new majorant texture: once, that
  // replaced the light volume on its texture unit.)
  const double tracedOldPlace = shadowMean(r.render(s));
  r.setVolume(moved);
  const double tracedMoved = shadowMean(r.render(s));
  std::cout << "[ traced ] red over the shadow: deformed " << tracedDeformed << ", moved block " << tracedMoved
            << ", block at its old place " << tracedOldPlace << "\n";
  EXPECT_GT(tracedOldPlace - tracedMoved, 15.0) << "the shadow darkens the floor";
  EXPECT_LT(std::abs(tracedDeformed - tracedMoved), 0.2 * (tracedOldPlace - tracedMoved));
}

}  // namespace vellum::render
