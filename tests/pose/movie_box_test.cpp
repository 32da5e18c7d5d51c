// `vellum pose --movie` on a grown box (issue 23 §4, "the output box grows to hold what moves"):
// a child bone that swings past the volume's face keeps every voxel in every frame with
// --pad-mm -1 (one grid for the whole movie, framed on the content), and is cut with --pad-mm 0.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <iostream>

#include "test_data.hpp"
#include "vellum/app/grown_box.hpp"
#include "vellum/app/pose_pipeline.hpp"
#include "vellum/io/volume_io.hpp"

using namespace vellum;
namespace fs = std::filesystem;

namespace {

constexpr uint16_t kParent = 1, kChild = 2, kSoft = 100;

/// 20 x 20 x 36 voxels of 2 mm (x, y 0..38 mm, z 0..70 mm): a limb along z about x = y = 19 mm,
/// soft tissue (radius 10 mm, z 2..68) around a parent bone (radius 6 mm, z 48..68) and a child
/// bone (z 6..28: 32 voxels a slice, 12 slices), each 8 mm or more from the axis (no collision
/// along the turn). A hinge along x at z = 40 mm turning the child 60° carries its distal end
/// (34 mm from the axis) 29 mm sideways: out through the y = 0 or y = 38 mm face.
struct Limb {
  fs::path dir, ct, labels, pose;
};
Limb writeLimb(const std::string& name) {
  Geometry g;
  g.dims = {20, 20, 36};
  g.spacing = {2, 2, 2};
  VolumeI16 ct(g, -1000);
  LabelVolume labels(g);
  for (int64_t k = 0; k < g.dims.z; ++k)
    for (int64_t j = 0; j < g.dims.y; ++j)
      for (int64_t i = 0; i < g.dims.x; ++i) {
        const Vec3 p = g.indexToPhysical({double(i), double(j), double(k)});
        const double r = std::hypot(p.x - 19, p.y - 19);
        uint16_t id = 0;
        int16_t hu = -1000;
        if (r <= 10 && p.z >= 2 && p.z <= 68) id = kSoft, hu = 40;
        if (r <= 6 && p.z >= 48 && p.z <= 68) id = kParent, hu = 1000;
        if (r <= 6 && p.z >= 6 && p.z <= 28) id = kChild, hu = 1000;
        ct(i, j, k) = hu;
        labels(i, j, k) = id;
      }
  Limb l;
  l.dir = test::tempDir(name);
  l.ct = l.dir / "ct.nrrd";
  l.labels = l.dir / "labels.nrrd";
  l.pose = l.dir / "pose.json";
  io::saveVolume(AnyVolume(ct), l.ct);
  io::saveLabels(labels, l.labels);
  std::ofstream(l.pose) << R"({"units": "mm", "map": "twist",
      "joints": [{"name": "knee", "parent": 1, "child": [2], "axis": [[8, 19, 40], [30, 19, 40]]}],
      "keyframes": [{"duration": 1, "angles": {"knee": 0}}, {"duration": 1, "angles": {"knee": 60}}]})";
  return l;
}

/// `vellum pose --movie` of the limb with `padMm`: its report's "movie".
nlohmann::json movieReport(const Limb& l, double padMm, const std::string& name) {
  app::PoseRequest r;
  r.input = l.ct;
  r.labels = l.labels;
  r.pose = l.pose;
  r.movie = l.dir / (name + "/");
  r.report = l.dir / (name + ".json");
  r.padMm = padMm;
  // The twist map at every voxel (s = 1): the child's voxels exactly turned (at the default s = 2
  // the coarse map near the bone's rim leaves a few of them to the tissue, with or without a pad).
  r.engine.params.controlScale = 1;
  r.movieSettings.fps = 2;  // 5 frames over the 2 s track (0°, 30°, 60°, held)
  r.movieSettings.settings.width = r.movieSettings.settings.height = 24;
  app::runPose(r);
  return nlohmann::json::parse(std::ifstream(r.report))["movie"];
}

/// Output voxels whose source lies in the child bone in frame `f` (the frame's map as rendered,
/// every voxel): the child's voxels in the frame's resampled labels.
int64_t childVoxels(const nlohmann::json& movie, size_t f) {
  for (const auto& b : movie["rigidity_per_frame"][f]["voxels_as_rendered"]["bodies"])
    if (b["ids"] == std::vector<uint16_t>{kChild}) return b["samples"].get<int64_t>();
  ADD_FAILURE() << "no child body in frame " << f;
  return 0;
}

}  // namespace

TEST(PoseMovieBox, GrownBoxKeepsTheSwungChildBoneInEveryFrameTheInputBoxCutsIt) {
  const Limb l = writeLimb("pose-movie-box");
  const nlohmann::json grown = movieReport(l, -1, "grown"), cut = movieReport(l, 0, "cut");
  std::cout << "grown box " << grown["box"].dump() << "\ncut box " << cut["box"].dump() << "\nchild voxels per frame (grown, cut):";
  for (size_t f = 0; f < 5; ++f) std::cout << " " << childVoxels(grown, f) << "/" << childVoxels(cut, f);
  std::cout << std::endl;
  ASSERT_EQ(grown["frames"], 5);
  ASSERT_EQ(cut["frames"], 5);

  // The input's box: the child's distal half leaves through a y face by the last frame.
  const int64_t first = childVoxels(cut, 0);
  ASSERT_EQ(first, 32 * 12);
  EXPECT_LT(childVoxels(cut, 4), 0.8 * double(first)) << "the input's box should cut the swung child";
  EXPECT_EQ(cut["box"]["pad_voxels"]["low"], (std::vector<int>{0, 0, 0}));
  EXPECT_EQ(cut["box"]["grid"]["dims"], (std::vector<int>{20, 20, 36}));

  // The grown box: every frame keeps the child whole (a turned voxel lattice resamples to within
  // a few voxels of its count: 2 % allowed; measured 384, 386, 382, the nearest-neighbour counts
  // of the turned lattice; the input's box: 190), the first frame is the input's.
  EXPECT_EQ(childVoxels(grown, 0), first);
  for (size_t f = 1; f < 5; ++f)
    EXPECT_NEAR(double(childVoxels(grown, f)), double(first), 0.02 * double(first)) << "frame " << f;
  // It grew along y only (the swing's plane; nothing moves out along x or through the floor),
  // the origin moved out by the low side's voxels, and every frame is on that one grid.
  const auto& pad = grown["box"]["pad_voxels"];
  const auto& grid = grown["box"]["grid"];
  EXPECT_EQ(pad["low"][0], 0);
  EXPECT_EQ(pad["high"][0], 0);
  EXPECT_GT(pad["low"][1].get<int>() + pad["high"][1].get<int>(), 5);
  EXPECT_EQ(grid["dims"][1].get<int>(), 20 + pad["low"][1].get<int>() + pad["high"][1].get<int>());
  EXPECT_DOUBLE_EQ(grid["origin_mm"][1].get<double>(), -2.0 * pad["low"][1].get<int>());
  const int64_t voxels = grid["dims"][0].get<int64_t>() * grid["dims"][1].get<int64_t>() * grid["dims"][2].get<int64_t>();
  for (size_t f = 0; f < 5; ++f)
    EXPECT_EQ(grown["rigidity_per_frame"][f]["voxels_as_rendered"]["samples"].get<int64_t>(), voxels) << "frame " << f;
  // Framed on the content: a grown box is mostly air; the camera zooms in on what moves in it.
  EXPECT_GT(grown["box"]["camera"]["zoom"].get<double>(), 1.0);
  EXPECT_EQ(cut["box"]["camera"]["zoom"], 1.0);
  fs::remove_all(l.dir);
}

// The rule itself: -1 grows only the sides content passes (by the farthest pose), > 0 every side
// by that margin, 0 nothing; a volume padded keeps each voxel's world position.
TEST(PoseMovieBox, GrownBoxIsTheUnionOverThePosesAndPaddingKeepsWorldPositions) {
  Geometry g;
  g.dims = {10, 10, 10};
  g.spacing = {1, 1, 1};
  VolumeI16 v(g, -1000, -1000);  // CT: air, its background
  v(5, 5, 5) = 500;  // one voxel of content at (5, 5, 5) mm
  const deformation::ControlPoints still{{{5, 5, 5}, {5, 5, 5}, {}}};
  const deformation::ControlPoints up6{{{5, 5, 5}, {5, 5, 11}, {}}};    // 2 voxels past the top face (9)
  const deformation::ControlPoints down9{{{5, 5, 5}, {5, 5, -4}, {}}};  // 4 voxels past the bottom face (0)
  const AnyVolume any(v);
  EXPECT_TRUE(app::grownBox(any, -1, {still}, 1).pad.none());
  const app::GrownBox both = app::grownBox(any, -1, {still, up6, down9}, 1);
  // How far the farthest pose passes each face + half the lattice step + a cell's diagonal (voxels).
  EXPECT_EQ(both.pad.hi[2], int64_t(std::ceil(2 + 0.5 + std::sqrt(3.0))));
  EXPECT_EQ(both.pad.lo[2], int64_t(std::ceil(4 + 0.5 + std::sqrt(3.0))));
  EXPECT_EQ(both.pad.lo[0] + both.pad.hi[0] + both.pad.lo[1] + both.pad.hi[1], 0);
  const app::GrownBox fixedMargin = app::grownBox(any, 2.5, {still}, 1);
  EXPECT_EQ(fixedMargin.pad.lo, (std::array<int64_t, 3>{3, 3, 3}));
  EXPECT_EQ(fixedMargin.pad.hi, (std::array<int64_t, 3>{3, 3, 3}));
  const VolumeI16 p = std::get<VolumeI16>(app::padded(any, both.pad));
  EXPECT_EQ(p.geometry().dims.z, 10 + both.pad.lo[2] + both.pad.hi[2]);
  const Vec3 at = p.geometry().physicalToIndex({5, 5, 5});
  EXPECT_EQ(p(std::llround(at.x), std::llround(at.y), std::llround(at.z)), 500);
  EXPECT_EQ(p(0, 0, 0), -1000);  // air around
  const std::optional<app::Padding> placed = app::placementIn(g, p.geometry());
  ASSERT_TRUE(placed);
  EXPECT_EQ(placed->lo, both.pad.lo);
  EXPECT_EQ(placed->hi, both.pad.hi);
  EXPECT_FALSE(app::placementIn(p.geometry(), g)) << "the grown grid is no part of the input's";
}
