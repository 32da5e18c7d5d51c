// Renderer pieces that need no GL: presets, transfer functions, colour shifts, camera
// conventions and the CPU reference ray caster on analytic volumes.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <string>

#include "analytic_volumes.hpp"
#include "empty_space.hpp"
#include "map_layout.hpp"
#include "normal_volume.hpp"
#include "render_common.hpp"
#include "shader_source.hpp"
#include "vellum/core/error.hpp"
#include "vellum/render/volume_renderer.hpp"

namespace vellum::render {
namespace {

// The ray caster's map constants come from core's model (map_layout.hpp), not from numbers
// spelled again in the GLSL.
TEST(MapLayout, GlslNamesTheModelsKernelsAndSnapUniforms) {
  const std::string g = detail::mapLayoutGlsl(Upsampling::Gaussian, true);
  EXPECT_NE(g.find("#define MAP_TRILINEAR " + std::to_string(int(Upsampling::Trilinear)) + "\n"), std::string::npos) << g;
  EXPECT_NE(g.find("#define MAP_GAUSSIAN " + std::to_string(int(Upsampling::Gaussian)) + "\n"), std::string::npos) << g;
  EXPECT_NE(g.find("#define MAP_KERNEL " + std::to_string(int(Upsampling::Gaussian)) + "\n"), std::string::npos) << g;
  EXPECT_NE(g.find("#define MAX_SNAP_BODIES " + std::to_string(kMaxSnapBodies) + "\n"), std::string::npos) << g;
  namespace u = detail::snap_uniform;
  for (const char* name : {u::kClasses, u::kSrcToClass, u::kSrcToClassOffset, u::kSrcDeltaToMm, u::kBodyRows,
                           u::kBodyValid, u::kBodies, u::kMaxSnap2})
    EXPECT_NE(g.find(std::string(" ") + name), std::string::npos) << name;
  const std::string t = detail::mapLayoutGlsl(Upsampling::Trilinear, false);
  EXPECT_NE(t.find("#define MAP_KERNEL 0\n"), std::string::npos) << t;
  EXPECT_EQ(t.find("RIGID_SNAP"), std::string::npos) << t;
  EXPECT_EQ(t.find("uniform"), std::string::npos) << t;
}

// llvmpipe runs every branch a SIMD group holds, so the held-body lookup is compiled in only
// for a snap that holds a body, and a variant with it is another program.
TEST(ShaderVariant, TheHeldLookupOnlyWhereTheSnapHoldsABody) {
  detail::ShaderVariant v;
  v.deformed = v.snap = v.shading = true;
  const std::string without = detail::fragmentShaderSource(v);
  EXPECT_NE(without.find("#define RIGID_SNAP\n"), std::string::npos);
  EXPECT_EQ(without.find("#define HELD_BODIES\n"), std::string::npos);
  detail::ShaderVariant held = v;
  held.held = true;
  EXPECT_NE(detail::fragmentShaderSource(held).find("#define HELD_BODIES\n"), std::string::npos);
  EXPECT_NE(held.key(), v.key());
  held.snap = false;  // no snap, nothing to hold
  EXPECT_EQ(detail::fragmentShaderSource(held).find("#define HELD_BODIES\n"), std::string::npos);
}

TEST(RenderSettings, PresetNamesRoundTrip) {
  for (Preset p : allPresets()) EXPECT_EQ(parsePreset(presetName(p)), p);
  try {
    parsePreset("bones");
    FAIL() << "no exception";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("soft-tissue"), std::string::npos) << e.what();
  }
}

TEST(RenderSettings, TransferFunctionInterpolatesAndClamps) {
  TransferFunction tf;
  tf.points = {{0, {0, 0, 0, 0}}, {100, {1, 0.5f, 0, 0.8f}}};
  EXPECT_FLOAT_EQ(tf.evaluate(50)[0], 0.5f);
  EXPECT_FLOAT_EQ(tf.evaluate(50)[3], 0.4f);
  EXPECT_FLOAT_EQ(tf.evaluate(-10)[3], 0.f);
  EXPECT_FLOAT_EQ(tf.evaluate(1000)[1], 0.5f);
}

TEST(RenderSettings, TableCorrectsOpacityForTheStep) {
  RenderSettings s;
  s.transferFunction.points = {{0, {1, 1, 1, 0.5f}}, {10, {1, 1, 1, 0.5f}}};
  s.windowWidth = 0;  // no window transform
  for (double step : {0.25, 1.0, 2.0}) {
    const detail::TfTable t = detail::buildTfTable(s, step);
    EXPECT_NEAR(t.lookup(5)[3], 1 - std::pow(0.5, step), 1e-6) << step;
  }
  // Two half-steps composite to the opacity of one 1 mm step.
  const double a = detail::buildTfTable(s, 0.5).lookup(5)[3];
  EXPECT_NEAR(a + (1 - a) * a, 0.5, 1e-6);
}

TEST(RenderSettings, WindowShiftsTheTransferFunction) {
  RenderSettings s;
  s.preset = Preset::Bone;
  const auto base = detail::buildTfTable(s, 1.0).lookup(500);
  s.windowCenter = 500;  // +100 HU shift of the whole value axis
  const auto shifted = detail::buildTfTable(s, 1.0).lookup(600);
  for (int c = 0; c < 4; ++c) EXPECT_NEAR(base[c], shifted[c], 2e-3) << c;
}

TEST(RenderSettings, LabShift) {
  const std::array<float, 3> c{0.8f, 0.5f, 0.3f};
  const auto same = detail::labShift(c, 0, 0, 0);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(same[k], c[k], 2e-3);
  const auto lighter = detail::labShift(c, 20, 0, 0);
  for (int k = 0; k < 3; ++k) EXPECT_GT(lighter[k], c[k]);
  const auto redder = detail::labShift(c, 0, 30, 0);  // +a: towards red, away from green
  EXPECT_GT(redder[0] - redder[1], c[0] - c[1]);
  const auto grey = detail::labShift({0.5f, 0.5f, 0.5f}, 0, 0, 0);
  EXPECT_NEAR(grey[0], grey[2], 2e-3);
}

TEST(ReferenceCpu, RejectsSizesOutOfRange) {
  const AnyVolume v = test::makeBallVolume(8, 1.0, 2.0);
  RenderSettings s;
  s.width = 4097;
  s.height = 16;
  EXPECT_THROW(renderReferenceCpu(v, s), Error);
  s.width = 0;
  EXPECT_THROW(renderReferenceCpu(v, s), Error);
}

// Projected radius of a ball under MIP: orthographic (pixel size = 2R/height) and perspective.
TEST(ReferenceCpu, MipBallHasTheAnalyticRadius) {
  const double radius = 12.0;
  const AnyVolume v = test::makeBallVolume(48, 1.0, radius);
  RenderSettings s;
  s.preset = Preset::Mip;
  s.width = s.height = 128;
  for (double fov : {0.0, 30.0}) {
    s.camera.fieldOfViewDeg = fov;
    const RgbaImage img = renderReferenceCpu(v, s);
    // Grey = (HU + 600) / 2000: 0 HU (halfway between ball and air) is grey 0.3.
    int count = 0;
    for (int y = 0; y < img.height; ++y)
      for (int x = 0; x < img.width; ++x) count += img.at(x, y)[0] > 76;  // 0 HU, halfway between ball and air
    const double measured = std::sqrt(count / std::numbers::pi);
    const double boxRadius = std::sqrt(3.0) * 24.0;  // half-diagonal of the 48 mm voxel box
    double expected = 0;
    if (fov == 0) {
      expected = radius / (2 * boxRadius / s.height);
    } else {
      const double half = fov * std::numbers::pi / 360, dist = boxRadius / std::sin(half);
      const double tanR = radius / std::sqrt(dist * dist - radius * radius);
      expected = tanR / std::tan(half) * s.height / 2;
    }
    EXPECT_NEAR(measured, expected, 0.6) << "fov " << fov;
  }
}

// Orientation: azimuth 0 looks from anterior (-y), patient left (+x) on screen right,
// superior (+z) up.
TEST(ReferenceCpu, CameraConventions) {
  Geometry g;
  g.dims = {40, 40, 40};
  g.origin = {-19.5, -19.5, -19.5};
  VolumeI16 vol(g, -1000, kCtAirHu);
  auto ball = [&](Vec3 c, double r, int16_t hu) {
    for (int k = 0; k < 40; ++k)
      for (int j = 0; j < 40; ++j)
        for (int i = 0; i < 40; ++i)
          if (norm(g.indexToPhysical({double(i), double(j), double(k)}) - c) < r) vol(i, j, k) = hu;
  };
  ball({0, -10, 0}, 6, 300);   // anterior: red
  ball({0, 10, 0}, 6, 1000);   // posterior: blue, hidden behind the red one
  ball({12, 0, 12}, 4, 1000);  // left-superior: blue
  RenderSettings s;
  s.width = s.height = 64;
  s.shading = false;
  s.camera = Camera{};
  s.camera.azimuthDeg = 0;
  s.camera.elevationDeg = 0;
  s.camera.fieldOfViewDeg = 0;
  // Red band around 300 HU (translucent, so the thin 300 HU shell inside the 1000 HU balls'
  // edges barely tints them), opaque blue above 900 HU; fine steps.
  s.stepVoxels = 0.1;
  s.transferFunction.points = {{240, {1, 0, 0, 0}},    {260, {1, 0, 0, 0.5f}}, {340, {1, 0, 0, 0.5f}},
                               {360, {1, 0, 0, 0}},    {880, {0, 0, 1, 0}},    {900, {0, 0, 1, 1}},
                               {2000, {0, 0, 1, 1}}};
  const AnyVolume any = vol;
  RgbaImage img = renderReferenceCpu(any, s);
  EXPECT_GT(img.at(32, 32)[0], 200);  // anterior ball in front
  EXPECT_LT(img.at(32, 32)[2], 50);
  // Left-superior ball: screen right, upper half. Scale = 2R/64 mm per pixel, R = sqrt(3)*20.
  const double mmPerPx = 2 * std::sqrt(3.0) * 20 / 64;
  const int bx = int(32 + 12 / mmPerPx), by = int(32 - 12 / mmPerPx);
  EXPECT_GT(img.at(bx, by)[2], 200) << bx << "," << by;
  EXPECT_EQ(img.at(64 - bx, by)[2], 0);
  // From posterior (azimuth 180) the blue ball is in front and the small ball is on the left.
  s.camera.azimuthDeg = 180;
  img = renderReferenceCpu(any, s);
  EXPECT_GT(img.at(32, 32)[2], 200);
  EXPECT_GT(img.at(63 - bx, by)[2], 200);
}

// The identity map on the volume's own grid reproduces the undeformed image.
TEST(ReferenceCpu, IdentityMapChangesNothing) {
  const VolumeI16 vol = test::makeAnalyticVolume(32);
  const AnyVolume any = vol;
  const BackwardMap map = test::makeIdentityMap(vol.geometry());
  RenderSettings s;
  s.width = s.height = 48;
  for (Preset p : {Preset::Mip, Preset::SoftTissueBone}) {
    s.preset = p;
    const RgbaImage a = renderReferenceCpu(any, s), b = renderReferenceCpu(any, s, &map);
    int maxDiff = 0;
    for (size_t i = 0; i < a.pixels.size(); ++i)
      maxDiff = std::max(maxDiff, std::abs(int(a.pixels[i]) - int(b.pixels[i])));
    EXPECT_LE(maxDiff, 1) << presetName(p);
  }
}

TEST(ReferenceCpu, RejectsMalformedMaps) {
  const AnyVolume v = test::makeBallVolume(8, 1.0, 2.0);
  BackwardMap map = test::makeIdentityMap(geometryOf(v));
  map.sourceMm.pop_back();
  RenderSettings s;
  s.width = s.height = 8;
  EXPECT_THROW(renderReferenceCpu(v, s, &map), Error);
}

// Block ranges see one block beyond their own voxels (trilinear support) and the background
// at the grid's faces; occupancy follows the transfer function.
TEST(EmptySpace, BlockRangesAndOccupancy) {
  Geometry g;
  g.dims = {40, 24, 24};  // 5 x 3 x 3 blocks
  VolumeI16 vol(g, 0, -1000.0);
  vol(20, 12, 12) = 1000;  // in block (2, 1, 1)
  const detail::BlockRanges r = detail::computeBlockRanges(AnyVolume(vol));
  ASSERT_EQ(r.blocks, (Dims{5, 3, 3}));
  auto at = [&](int x, int y, int z) { return size_t((z * 3 + y) * 5 + x); };
  EXPECT_EQ(r.maxValue[at(2, 1, 1)], 1000.f);
  EXPECT_EQ(r.maxValue[at(1, 0, 0)], 1000.f);  // neighbour
  EXPECT_EQ(r.maxValue[at(0, 1, 1)], 0.f);     // two blocks away
  EXPECT_EQ(r.minValue[at(0, 1, 1)], -1000.f); // on the face: sees the background
  EXPECT_EQ(r.minValue[at(2, 1, 1)], 0.f);     // interior block: all neighbours inside
  RenderSettings s;
  s.preset = Preset::Bone;
  const auto occ = detail::blockOccupancy(r, detail::buildTfTable(s, 0.5));
  EXPECT_EQ(occ[at(2, 1, 1)], 255);
  EXPECT_EQ(occ[at(3, 2, 2)], 255);
  EXPECT_EQ(occ[at(0, 1, 1)], 0);  // 0 HU is transparent for bone
  EXPECT_EQ(occ[at(4, 0, 0)], 0);
}

// Map cells: the source blocks a cell can read come from its corner nodes' u, by the blocks'
// own ranges (a cell adds one voxel of trilinear support, not a block's neighbours).
TEST(EmptySpace, MapCellsFollowTheMap) {
  Geometry g;
  g.dims = {64, 64, 64};  // 8^3 blocks
  VolumeI16 vol(g, 0, -1000.0);
  vol(4, 4, 4) = 1000;  // block 0
  const detail::BlockRanges r = detail::computeBlockRanges(AnyVolume(vol));
  // Nodes every 8 voxels along the diagonal: u = node * 8 (+ a shift of 16 voxels in x).
  for (double shift : {0.0, 16.0}) {
    const Dims nodes{9, 9, 9};
    std::vector<float> u;
    for (int k = 0; k < 9; ++k)
      for (int j = 0; j < 9; ++j)
        for (int i = 0; i < 9; ++i) u.insert(u.end(), {float(8 * i + shift), float(8 * j), float(8 * k)});
    const detail::MapCells cells = detail::computeMapCells(nodes, u, r);
    ASSERT_EQ(cells.cells, (Dims{8, 8, 8}));
    const std::vector<float> maxValue = detail::cellMaxValues(cells, r);
    auto at = [](int x, int y, int z) { return size_t((z * 8 + y) * 8 + x); };
    RenderSettings s;
    s.preset = Preset::Bone;
    const detail::TfTable tf = detail::buildTfTable(s, 0.5);
    const auto occ = detail::cellOccupancy(cells, detail::ownBlockOccupancy(r, tf), r.blocks,
                                           detail::backgroundOccupancy(r, tf) != 0);
    if (shift == 0) {
      EXPECT_EQ(maxValue[at(0, 0, 0)], 1000.f);
      EXPECT_EQ(maxValue[at(1, 1, 1)], 1000.f);  // u in [8, 16]: reads voxel 7 (block 0)
      EXPECT_EQ(maxValue[at(2, 2, 2)], 0.f);     // u in [16, 24]: voxels 15..25, blocks 1..3
      EXPECT_EQ(maxValue[at(3, 0, 0)], 0.f);     // reads blocks 2..4 in x
      EXPECT_EQ(occ[at(1, 0, 0)], 255);
      EXPECT_EQ(occ[at(2, 0, 0)], 0);  // the grown ranges (one block beyond) counted it occupied
    } else {
      EXPECT_EQ(maxValue[at(0, 0, 0)], 0.f);     // u in [16, 24] in x: blocks 1..3
      EXPECT_EQ(occ[at(0, 0, 0)], 0);
    }
  }
}

// The cells' block boxes against the definition, cell by cell: the extremes of u over each
// cell's support texels (trilinear: its 2^3 nodes; Gaussian: 4^3 texels of the padded texture,
// clipped at the faces), widened by the margin. A pseudo-random map with a NaN texel.
TEST(EmptySpace, MapCellsAreTheExtremesOfTheirSupport) {
  Geometry g;
  g.dims = {64, 48, 40};
  const detail::BlockRanges r = detail::computeBlockRanges(AnyVolume(VolumeI16(g, 0, -1000.0)));
  const Dims nodes{11, 9, 7};
  for (const bool gaussian : {false, true}) {
    const Dims td = gaussian ? Dims{nodes.x + 3, nodes.y + 3, nodes.z + 3} : nodes;
    const detail::MapCellSupport sup{td, gaussian ? -1 : 0, gaussian ? 2 : 1, 1.5};
    std::vector<float> u(static_cast<size_t>(3 * td.voxelCount()));
    uint32_t h = 12345;
    for (float& x : u) {
      h = h * 1664525u + 1013904223u;
      x = float(h >> 8) / float(1 << 24) * 70.f - 3.f;
    }
    u[3 * 40 + 1] = std::numeric_limits<float>::quiet_NaN();
    const detail::MapCells cells = detail::computeMapCells(nodes, u, r, &sup);
    ASSERT_EQ(cells.cells, (Dims{10, 8, 6}));
    const Dims& nb = r.blocks;
    for (int64_t cz = 0; cz < 6; ++cz)
      for (int64_t cy = 0; cy < 8; ++cy)
        for (int64_t cx = 0; cx < 10; ++cx) {
          double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
          for (int64_t k = std::max<int64_t>(cz + sup.lo, 0); k <= std::min<int64_t>(cz + sup.hi, td.z - 1); ++k)
            for (int64_t j = std::max<int64_t>(cy + sup.lo, 0); j <= std::min<int64_t>(cy + sup.hi, td.y - 1); ++j)
              for (int64_t i = std::max<int64_t>(cx + sup.lo, 0); i <= std::min<int64_t>(cx + sup.hi, td.x - 1); ++i)
                for (int a = 0; a < 3; ++a) {
                  const double x = u[static_cast<size_t>(((k * td.y + j) * td.x + i) * 3 + a)];
                  if (std::isnan(x)) continue;
                  lo[a] = std::min(lo[a], x);
                  hi[a] = std::max(hi[a], x);
                }
          const auto& box = cells.box[static_cast<size_t>((cz * 8 + cy) * 10 + cx)];
          for (int a = 0; a < 3; ++a) {
            const double last = double(nb[a] - 1), margin = 1.001 + sup.marginVoxels;
            auto block = [&](double x) { return int(std::clamp(std::floor(x / detail::kBlockSize), 0.0, last)); };
            EXPECT_EQ(box[static_cast<size_t>(a)], block(lo[a] - margin)) << gaussian << " cell " << cx << cy << cz;
            EXPECT_EQ(box[static_cast<size_t>(a + 3)], block(hi[a] + margin)) << gaussian << " cell " << cx << cy << cz;
          }
        }
  }
}

// Cells on the map grid's faces also see the background (the output box fades to it), and a
// transfer function that makes the background opaque marks them occupied.
TEST(EmptySpace, FaceCellsSeeTheBackground) {
  Geometry g;
  g.dims = {64, 64, 64};
  VolumeI16 vol(g, 0, 1500.0);  // background 1500 HU: bone for the bone preset
  const detail::BlockRanges r = detail::computeBlockRanges(AnyVolume(vol));
  EXPECT_EQ(r.ownMax[0], 1500.f);                      // face block
  EXPECT_EQ(r.ownMax[size_t((3 * 8 + 3) * 8 + 3)], 0.f);  // interior block: its own voxels only
  // All nodes on the volume's centre: every cell reads interior blocks only.
  const Dims nodes{5, 5, 5};
  std::vector<float> u;
  for (int n = 0; n < 125; ++n) u.insert(u.end(), {32.f, 32.f, 32.f});
  const detail::MapCells cells = detail::computeMapCells(nodes, u, r);
  const std::vector<float> maxValue = detail::cellMaxValues(cells, r);
  RenderSettings s;
  s.preset = Preset::Bone;
  const detail::TfTable tf = detail::buildTfTable(s, 0.5);
  ASSERT_NE(detail::backgroundOccupancy(r, tf), 0);
  const auto occ = detail::cellOccupancy(cells, detail::ownBlockOccupancy(r, tf), r.blocks, true);
  for (int z = 0; z < 4; ++z)
    for (int y = 0; y < 4; ++y)
      for (int x = 0; x < 4; ++x) {
        const size_t n = size_t((z * 4 + y) * 4 + x);
        const bool face = x == 0 || y == 0 || z == 0 || x == 3 || y == 3 || z == 3;
        EXPECT_EQ(occ[n], face ? 255 : 0) << x << " " << y << " " << z;
        EXPECT_EQ(maxValue[n], face ? 1500.f : 0.f);
      }
}

// A coarse block is occupied when any of its kCoarseSkip^3 blocks is (partial ones at the end).
TEST(EmptySpace, CoarseOccupancyIsTheOrOfItsBlocks) {
  const Dims blocks{9, 5, 4};
  std::vector<uint8_t> occ(size_t(blocks.voxelCount()), 0);
  occ[size_t((3 * 5 + 4) * 9 + 8)] = 255;  // block (8, 4, 3): coarse (2, 1, 0)
  occ[size_t((0 * 5 + 0) * 9 + 3)] = 255;  // block (3, 0, 0): coarse (0, 0, 0)
  Dims coarse;
  const auto c = detail::coarseOccupancy(occ, blocks, coarse);
  ASSERT_EQ(coarse, (Dims{3, 2, 1}));
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 3; ++x)
      EXPECT_EQ(c[size_t(y * 3 + x)], (x == 2 && y == 1) || (x == 0 && y == 0) ? 255 : 0) << x << " " << y;
}

}  // namespace
}  // namespace vellum::render

namespace vellum::render {
namespace {

// The shading normal is computed where it is sampled (no normal volume, issue #22): on
// v = |p - c|^2 (spheres about c) its central differences of the trilinear volume are exact
// anywhere, so the normal must be the sphere's radial direction in PHYSICAL space under an
// oblique direction matrix and anisotropic spacing, and the magnitude |grad| = 2r scaled.
// The GL shader's gradientNormal() is held to this by the GL-vs-CPU tests.
TEST(GradientNormals, EqualTheAnalyticSphereNormal) {
  Geometry g;
  g.dims = {24, 20, 16};
  g.spacing = {0.8, 1.1, 1.7};
  g.origin = {3, -2, 5};
  const double a = 0.5, b = 0.3;  // rotations about z and x
  const Mat3 rz = Mat3::fromColumns({std::cos(a), std::sin(a), 0}, {-std::sin(a), std::cos(a), 0}, {0, 0, 1});
  const Mat3 rx = Mat3::fromColumns({1, 0, 0}, {0, std::cos(b), std::sin(b)}, {0, -std::sin(b), std::cos(b)});
  g.direction = rz * rx;
  const Vec3 c = g.indexToPhysical({11.3, 9.6, 7.2});
  VolumeF32 vol(g, 0, 0.f);
  for (int64_t k = 0; k < g.dims.z; ++k)
    for (int64_t j = 0; j < g.dims.y; ++j)
      for (int64_t i = 0; i < g.dims.x; ++i) {
        const Vec3 d = g.indexToPhysical({double(i), double(j), double(k)}) - c;
        vol(i, j, k) = float(dot(d, d));
      }
  const detail::GradientNormals gn = detail::gradientNormals(AnyVolume(vol));
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> ui(1.0, 22.0), uj(1.0, 18.0), uk(1.0, 14.0);
  for (int n = 0; n < 200; ++n) {
    const Vec3 u{ui(rng), uj(rng), uk(rng)};
    const Vec3 r = g.indexToPhysical(u) - c;
    if (norm(r) < 2.0) continue;
    const auto s = gn.sample(vol, u);
    const Vec3 expect = r * (1.0 / norm(r));
    EXPECT_NEAR(s[0], expect.x, 1e-4) << n;
    EXPECT_NEAR(s[1], expect.y, 1e-4) << n;
    EXPECT_NEAR(s[2], expect.z, 1e-4) << n;
    EXPECT_NEAR(s[3], std::min(2.0 * norm(r) * gn.magScale, 1.0), 1e-4) << n;
  }
  // No gradient: no normal (shading leaves the colour as it is).
  const VolumeF32 flat(g, 0, 7.f);
  const auto z = detail::gradientNormals(AnyVolume(flat)).sample(flat, {5.5, 5.5, 5.5});
  EXPECT_EQ(z[0] * z[0] + z[1] * z[1] + z[2] * z[2] + z[3], 0.f);
}

}  // namespace
}  // namespace vellum::render
