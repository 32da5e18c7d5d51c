// The studio's joint tool (issue 23 §3) on a small synthetic limb (40³ voxels of 2 mm, as the
// pose tests use): the bones picked by clicks in a slice, the axis estimated, an angle set on
// a second keyframe, the pose file saved with its `vellum pose` line. The child bone lands
// where the analytic rotation about the estimated axis puts it, the fixed block stays, and
// `vellum pose --out` on the saved file gives the volume the studio shows.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <string>

#include "layout.hpp"
#include "mpr.hpp"
#include "studio_run.hpp"
#include "test_data.hpp"
#include "vellum/deformation/pose.hpp"
#include "vellum/io/volume_io.hpp"

namespace vellum::studio {
namespace {
namespace fs = std::filesystem;
using namespace vellum::deformation;
using namespace vellum::test::studio;

constexpr int kN = kLimbN;
constexpr uint16_t kFixed = kLimbFixed;

TEST(StudioJointScript, PickedBonesTurnAboutTheEstimatedAxisAndVellumPoseReproducesTheView) {
  REQUIRE_DISPLAY();
  const fs::path d = test::tempDir("studio-joint");
  VolumeI16 ct;
  LabelVolume labels;
  writeLimb(d, ct, labels);
  const Geometry& g = ct.geometry();
  // Where the coronal pane (1x3 layout, 1024x700 window) draws the two bones' centres.
  const std::vector<Pane> panes = layoutPanes(Layout::OneByThree, {kToolPanelWidth, 0, 1024 - kToolPanelWidth, 700});
  const Pane& cor = panes[1];
  const SlicePlane plane = makePlane(SliceAxis::Coronal, g, g.center(), int(cor.rect.w), int(cor.rect.h));
  const auto px = [&](const Vec3& mm) {
    const auto [x, y] = plane.toPixel(mm);
    return "[" + std::to_string(cor.rect.x + x) + "," + std::to_string(cor.rect.y + y) + "]";
  };
  const std::string script = scriptOnPhantom(d) + R"(
    {"layout":"1x3"},{"hud":false},
    {"joint":{"pick":"parent"}},{"click":)" + px({40, 40, 60}) + R"(},
    {"joint":{"pick":"child"}},{"click":)" + px({40, 40, 24}) + R"(},
    {"joint":{"add_picked":"knee"}},
    {"joint":{"fixed":{"labels":[50]}}},
    {"joint":{"keyframe":"add"}},
    {"joint":{"angle":{"joint":"knee","deg":20}}},
    {"joint":{"save":{"path":)" + q(d / "pose.json") + R"(,"command":)" + q(d / "cmd.txt") + R"(,"out":)" +
                             q(d / "cli.nrrd") + R"(}}},
    {"joint":{"save_volume":)" + q(d / "studio.nrrd") + R"(}},
    {"play":{"seconds":0.2}},
    {"quit":0}]})";
  std::string log;
  ASSERT_EQ(runStudio(d, "joint", script, &log), 0) << log;

  // The pose file: the clicked bones, the axis left to estimate, two keyframes (0°, 20°).
  Pose pose = loadPose(d / "pose.json");
  ASSERT_EQ(pose.joints.size(), 1u);
  EXPECT_EQ(pose.joints[0].parent, std::vector<uint16_t>{1});
  EXPECT_EQ(pose.joints[0].child, std::vector<uint16_t>{2});
  EXPECT_TRUE(pose.joints[0].estimateAxis);
  EXPECT_EQ(pose.fixed.ids, std::vector<uint16_t>{kFixed});
  ASSERT_EQ(pose.angles.keyframes.size(), 2u);
  EXPECT_EQ(pose.anglesAt(0)[0], 0.0);
  EXPECT_EQ(pose.anglesAt(pose.lastKeyframeTimeS())[0], 20.0);

  // The studio's view: the child bone's voxels where the rotation about the estimated axis
  // puts them (bone HU there), the fixed block unchanged.
  estimateAxes(pose, labels, PoseOptions{}.contactMm);
  const RigidTransform r = rotationAbout(pose.joints[0].axisA, pose.joints[0].axisB, 20);
  const VolumeI16 studio = std::get<VolumeI16>(io::loadVolume(d / "studio.nrrd").volume);
  int64_t child = 0, landed = 0, unmoved = 0, fixedSame = 0, fixedAll = 0;
  for (int k = 1; k + 1 < kN; ++k)
    for (int j = 1; j + 1 < kN; ++j)
      for (int i = 1; i + 1 < kN; ++i) {
        if (labels(i, j, k) == kFixed) ++fixedAll, fixedSame += studio(i, j, k) == ct(i, j, k);
        // The child's interior voxels (all 6 neighbours child too): bone where r puts them.
        if (labels(i, j, k) != 2 || labels(i - 1, j, k) != 2 || labels(i + 1, j, k) != 2 || labels(i, j - 1, k) != 2 ||
            labels(i, j + 1, k) != 2 || labels(i, j, k - 1) != 2 || labels(i, j, k + 1) != 2)
          continue;
        const Vec3 v = g.physicalToIndex(r.apply(g.indexToPhysical({double(i), double(j), double(k)})));
        const int64_t a = std::llround(v.x), b = std::llround(v.y), c = std::llround(v.z);
        ++child;
        landed += g.contains(a, b, c) && studio(a, b, c) >= 900;
        unmoved += studio(i, j, k) >= 900;
      }
  ASSERT_GT(child, 200);
  EXPECT_GE(double(landed) / double(child), 0.98);
  EXPECT_LT(double(unmoved) / double(child), 0.7) << "the child did move";
  EXPECT_EQ(fixedSame, fixedAll);

  // `vellum pose` on the saved file, with the line the studio wrote: the same volume.
  std::string cmd = slurp(d / "cmd.txt");
  ASSERT_EQ(cmd.rfind("vellum pose ", 0), 0u) << cmd;
  cmd.replace(0, std::string("vellum").size(), std::string("\"") + VELLUM_CLI_EXE + "\"");
  cmd.pop_back();  // newline
  ASSERT_EQ(std::system((cmd + " > \"" + (d / "cli.log").string() + "\" 2>&1").c_str()), 0) << slurp(d / "cli.log");
  const VolumeI16 cli = std::get<VolumeI16>(io::loadVolume(d / "cli.nrrd").volume);
  int64_t off = 0;
  double sum = 0;
  const size_t count = size_t(kN) * kN * kN;
  ASSERT_EQ(cli.geometry().dims, g.dims);
  for (size_t n = 0; n < count; ++n) {
    const double e = std::abs(double(cli.data()[n]) - double(studio.data()[n]));
    sum += e;
    off += e > 100;
  }
  const double voxels = double(count);
  std::cout << "studio vs vellum pose: mean |diff| " << sum / voxels << " HU, " << 100.0 * off / voxels
            << " % of voxels differ by more than 100 HU" << std::endl;
  EXPECT_LT(sum / voxels, 1.0);  // measured 0.04 HU: vellum pose repairs folds, the live view does not
  EXPECT_LT(off / voxels, 0.001);  // measured 5 of 64000 voxels
  fs::remove_all(d);
}

}  // namespace
}  // namespace vellum::studio
