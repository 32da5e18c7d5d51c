// The studio's joint tool (issue 23 §3) on a small synthetic limb (40³ voxels of 2 mm, as the
// pose tests use): the bones picked by clicks in a slice, the axis estimated, an angle set on
// a second keyframe, the pose file saved with its `vellum pose` line. The child bone lands
// where the analytic rotation about the estimated axis puts it, the fixed block stays, and
// `vellum pose --out` on the saved file gives the volume the studio shows; the twist map's movie
// export is `vellum pose --movie`'s frames.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdlib>
#include <string>

#include "layout.hpp"
#include "mpr.hpp"
#include "studio_run.hpp"
#include "test_data.hpp"
#include "vellum/deformation/pose.hpp"
#include "vellum/deformation/synthesis.hpp"
#include "vellum/deformation/twist_frames.hpp"
#include "vellum/io/image_io.hpp"
#include "vellum/io/volume_io.hpp"

namespace vellum::studio {
namespace {
namespace fs = std::filesystem;
using namespace vellum::deformation;
using namespace vellum::test::studio;

constexpr int kN = kLimbN;
constexpr uint16_t kFixed = kLimbFixed;

/// Where the coronal pane (1x3 layout, 1024x700 window, the slice through the centre) draws
/// the point `mm`: a script's click there.
std::string coronalClick(const Geometry& g, const Vec3& mm) {
  const std::vector<Pane> panes = layoutPanes(Layout::OneByThree, {kToolPanelWidth, 0, 1024 - kToolPanelWidth, 700});
  const Pane& cor = panes[1];
  const SlicePlane plane = makePlane(SliceAxis::Coronal, g, g.center(), int(cor.rect.w), int(cor.rect.h));
  const auto [x, y] = plane.toPixel(mm);
  return "[" + std::to_string(cor.rect.x + x) + "," + std::to_string(cor.rect.y + y) + "]";
}

/// The joint script on the limb (with `extra` actions after the joint is added and `after` ones
/// before it quits), the studio's shown volume and `vellum pose` run with the line the studio wrote.
struct JointRun {
  VolumeI16 ct;
  LabelVolume labels;
  Pose pose;  ///< as saved, its axis estimated
  VolumeI16 studio, cli;
  std::string command;
  double meanDiffHu = 0, offFraction = 0;  ///< studio against cli: mean |diff|, share over 100 HU
};
JointRun runJointScript(const fs::path& d, const std::string& extra, const std::string& after = "",
                        const std::string& beforeAdd = "") {
  JointRun run;
  writeLimb(d, run.ct, run.labels);
  const Geometry& g = run.ct.geometry();
  const auto px = [&](const Vec3& mm) { return coronalClick(g, mm); };
  const std::string script = scriptOnPhantom(d) + R"(
    {"layout":"1x3"},{"hud":false},
    {"joint":{"pick":"parent"}},{"click":)" + px({40, 40, 60}) + R"(},
    {"joint":{"pick":"child"}},{"click":)" + px({40, 40, 24}) + R"(},)" + beforeAdd + R"(
    {"joint":{"add_picked":"knee"}},)" + extra + R"(
    {"joint":{"fixed":{"labels":[50]}}},
    {"joint":{"keyframe":"add"}},
    {"joint":{"angle":{"joint":"knee","deg":20}}},
    {"joint":{"save":{"path":)" + q(d / "pose.json") + R"(,"command":)" + q(d / "cmd.txt") + R"(,"out":)" +
                             q(d / "cli.nrrd") + R"(}}},
    {"joint":{"save_volume":)" + q(d / "studio.nrrd") + R"(}},
    {"play":{"seconds":0.2}},)" + after + R"(
    {"quit":0}]})";
  std::string log;
  EXPECT_EQ(runStudio(d, "joint", script, &log), 0) << log;
  run.pose = loadPose(d / "pose.json");
  estimateAxes(run.pose, run.labels, PoseOptions{}.contactMm);
  run.studio = std::get<VolumeI16>(io::loadVolume(d / "studio.nrrd").volume);
  // `vellum pose` on the saved file, with the line the studio wrote.
  run.command = slurp(d / "cmd.txt");
  std::string cmd = run.command;
  EXPECT_EQ(cmd.rfind("vellum pose ", 0), 0u) << cmd;
  cmd.replace(0, std::string("vellum").size(), std::string("\"") + VELLUM_CLI_EXE + "\"");
  cmd.pop_back();  // newline
  EXPECT_EQ(std::system((cmd + " > \"" + (d / "cli.log").string() + "\" 2>&1").c_str()), 0) << slurp(d / "cli.log");
  run.cli = std::get<VolumeI16>(io::loadVolume(d / "cli.nrrd").volume);
  EXPECT_EQ(run.cli.geometry().dims, g.dims);
  const size_t count = size_t(kN) * kN * kN;
  double sum = 0;
  int64_t off = 0;
  for (size_t n = 0; n < count; ++n) {
    const double e = std::abs(double(run.cli.data()[n]) - double(run.studio.data()[n]));
    sum += e;
    off += e > 100;
  }
  run.meanDiffHu = sum / double(count);
  run.offFraction = double(off) / double(count);
  std::cout << "studio vs vellum pose: mean |diff| " << run.meanDiffHu << " HU, " << 100.0 * run.offFraction
            << " % of voxels differ by more than 100 HU" << std::endl;
  return run;
}

/// Of the child bone's interior voxels (all 6 neighbours child too): the share shown as bone
/// where the joint's 20° turn puts them, and the share still bone where they were; and whether
/// every voxel of the fixed block is unchanged.
struct ChildCheck {
  int64_t child = 0;
  double landed = 0, unmoved = 0;
  bool fixedSame = false;
};
ChildCheck checkChild(const JointRun& run) {
  const Geometry& g = run.ct.geometry();
  const RigidTransform r = rotationAbout(run.pose.joints[0].axisA, run.pose.joints[0].axisB, 20);
  const LabelVolume& labels = run.labels;
  int64_t landed = 0, unmoved = 0, fixedSame = 0, fixedAll = 0;
  ChildCheck c;
  for (int k = 1; k + 1 < kN; ++k)
    for (int j = 1; j + 1 < kN; ++j)
      for (int i = 1; i + 1 < kN; ++i) {
        if (labels(i, j, k) == kFixed) ++fixedAll, fixedSame += run.studio(i, j, k) == run.ct(i, j, k);
        if (labels(i, j, k) != 2 || labels(i - 1, j, k) != 2 || labels(i + 1, j, k) != 2 || labels(i, j - 1, k) != 2 ||
            labels(i, j + 1, k) != 2 || labels(i, j, k - 1) != 2 || labels(i, j, k + 1) != 2)
          continue;
        const Vec3 v = g.physicalToIndex(r.apply(g.indexToPhysical({double(i), double(j), double(k)})));
        const int64_t a = std::llround(v.x), b = std::llround(v.y), cc = std::llround(v.z);
        ++c.child;
        landed += g.contains(a, b, cc) && run.studio(a, b, cc) >= 900;
        unmoved += run.studio(i, j, k) >= 900;
      }
  c.landed = c.child ? double(landed) / double(c.child) : 0;
  c.unmoved = c.child ? double(unmoved) / double(c.child) : 1;
  c.fixedSame = fixedSame == fixedAll;
  return c;
}

TEST(StudioJointScript, PickedBonesTurnAboutTheEstimatedAxisAndVellumPoseReproducesTheView) {
  REQUIRE_DISPLAY();
  const fs::path d = test::tempDir("studio-joint");
  // The MLS map, chosen (the default is the twist map, which the studio shows on its control
  // grid while `vellum pose --out` makes it at full size: the next test checks that one).
  const JointRun run = runJointScript(d, R"({"joint":{"map":"mls"}},)");

  // The pose file: the clicked bones, the axis left to estimate, two keyframes (0°, 20°).
  const Pose& pose = run.pose;
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
  const ChildCheck c = checkChild(run);
  ASSERT_GT(c.child, 200);
  EXPECT_GE(c.landed, 0.98);
  EXPECT_LT(c.unmoved, 0.7) << "the child did move";
  EXPECT_TRUE(c.fixedSame);
  // `vellum pose` on the saved file: the same volume.
  EXPECT_LT(run.meanDiffHu, 1.0);  // measured 0.04 HU: vellum pose repairs folds, the live view does not
  EXPECT_LT(run.offFraction, 0.001);  // measured 5 of 64000 voxels
  fs::remove_all(d);
}

// Two clicked axis points with "Place by motion" (the Joints panel's box, the script's
// {"joint":{"hint":true}}) are the pose's "axis_hint": the saved file carries the clicks as the
// hint, the axis is the motion search's — moved from the hint towards the bones' gap — and the
// studio shows the child turned about it exactly as `vellum pose` on the saved file does.
TEST(StudioJointScript, ClickedAxisPlacedByMotionIsTheSavedHint) {
  REQUIRE_DISPLAY();
  const fs::path d = test::tempDir("studio-joint-hint");
  // The clicks land on the coronal slice through the volume's centre (y = 39 mm); the hint lies
  // 11 mm above the bones' 2 mm gap (z 38–40).
  const Geometry g = limbGeometry();
  const Vec3 a{16, g.center().y, 50}, b{64, g.center().y, 50};
  const std::string clicks = R"({"joint":{"pick":"axis1"}},{"click":)" + coronalClick(g, a) +
                             R"(},{"joint":{"pick":"axis2"}},{"click":)" + coronalClick(g, b) + R"(},{"joint":{"hint":true}},)";
  const JointRun run = runJointScript(d, R"({"joint":{"map":"mls"}},)", "", clicks);
  ASSERT_EQ(run.pose.joints.size(), 1u);
  const Joint& j = run.pose.joints[0];
  EXPECT_TRUE(j.estimateAxis);
  ASSERT_TRUE(j.hasAxisHint);
  EXPECT_LT(norm(j.hintA - a), 2.0);  // a click is a pixel's worth of the slice (~0.3 mm here)
  EXPECT_LT(norm(j.hintB - b), 2.0);
  EXPECT_EQ(j.fit.method, "motion");
  EXPECT_GT(dot(normalized(j.axisB - j.axisA), Vec3{1, 0, 0}), 0.999);  // the hint's direction and sense
  // The bones' ends are flat, so the score's valley is shallow: the search moved the axis down
  // (measured: from 50 to 45.4 mm), not necessarily onto the gap.
  EXPECT_LT((j.axisA.z + j.axisB.z) / 2, 48.0);
  EXPECT_GT(j.fit.motion.shiftMm, 2.0);
  const ChildCheck c = checkChild(run);
  ASSERT_GT(c.child, 200);
  EXPECT_GE(c.landed, 0.95);  // measured 0.975: turned about an axis above the gap, the child's
                              // corners pass the parent's edge and give there
  EXPECT_LT(run.meanDiffHu, 1.0);  // measured 2e-5 HU: the studio placed the axis as vellum pose does
  EXPECT_LT(run.offFraction, 0.001);
  fs::remove_all(d);
}

// The Joints panel's map choice (`vellum pose --map`): with the twist map the exact map the
// studio shows is the pose's twist map (on its control grid, the bones snapped exactly), and
// the `vellum pose` line it writes asks for the twist map too.
TEST(StudioJointScript, TwistMapChosenInTheStudioIsTheMapItShowsAndWrites) {
  REQUIRE_DISPLAY();
  const fs::path d = test::tempDir("studio-joint-twist");
  const JointRun run = runJointScript(d, R"({"joint":{"map":"twist"}},)");
  EXPECT_NE(run.command.find("--map twist"), std::string::npos) << run.command;
  const ChildCheck c = checkChild(run);
  ASSERT_GT(c.child, 200);
  EXPECT_GE(c.landed, 0.98);
  EXPECT_LT(c.unmoved, 0.7) << "the child did move";
  EXPECT_TRUE(c.fixedSame);
  // What the studio shows is the pose's twist map on its s = 4 grid (deformation::TwistFrames),
  // the CT resampled through it as saveShownVolume() does, to the HU.
  const Geometry& g = run.ct.geometry();
  const std::vector<std::vector<uint16_t>> groups{{1}, {2}};
  const RigidBodies bodies = RigidBodies::fromLabelGroups(run.labels, groups, 20, run.pose.fixed);
  auto nodeBodies = std::make_shared<const RigidBodies>(
      RigidBodies::fromLabelGroups(labelsAtNodes(run.labels, 4), groups, 1, run.pose.fixed));
  const MapSampler twist(TwistFrames(run.pose, nodeBodies, g, 4).at({20.0}, bodies), g);
  const VolumeI16 ct = std::get<VolumeI16>(io::loadVolume(d / "ct.nrrd").volume);  // as the studio read it
  int64_t differ = 0;
  for (int k = 0; k < kN; ++k)
    for (int j = 0; j < kN; ++j)
      for (int i = 0; i < kN; ++i) {
        const auto u = twist.sourceMm(g.indexToPhysical({double(i), double(j), double(k)}));
        const double hu = u ? std::lround(std::clamp(ct.sampleLinearMm(*u), -32768.0, 32767.0)) : ct.background();
        differ += std::abs(hu - run.studio(i, j, k)) > 1;
      }
  EXPECT_EQ(differ, 0) << "the studio does not show the twist map";
  // `vellum pose --out` makes it at every voxel: the bones agree exactly, the tissue between
  // them within the coarse grid's interpolation (measured 4.4 HU mean, 1.6 % over 100 HU).
  EXPECT_LT(run.meanDiffHu, 20.0);
  EXPECT_LT(run.offFraction, 0.05);
  fs::remove_all(d);
}

// The movie export with the twist map chosen (the Joints panel's "Pose map"): the frames are the
// twist map's at each frame's angles on the movie's grown box, as `vellum pose --movie` makes
// them; the command the studio writes is that `vellum pose` line, and it renders the same pixels.
// (The automatic box is tested in tests/pose/movie_box_test.cpp; this limb's tissue cannot swing
// past its box, so the export asks for a 6 mm margin: 3 voxels each side.)
TEST(StudioJointScript, TwistMovieExportIsVellumPoseMovieOnTheGrownBox) {
  REQUIRE_DISPLAY();
  const fs::path d = test::tempDir("studio-joint-movie");
  const JointRun run = runJointScript(d, R"({"joint":{"map":"twist"}},)",
                                      R"({"export_movie":{"out":)" + q(d / "studio/") +
                                          R"(,"fps":3,"size":"48x40","pad_mm":6,"command":)" + q(d / "movie-cmd.txt") +
                                          "}},");
  std::string cmd = slurp(d / "movie-cmd.txt");
  ASSERT_EQ(cmd.rfind("vellum pose ", 0), 0u) << cmd;
  EXPECT_NE(cmd.find(" --movie "), std::string::npos) << cmd;
  EXPECT_NE(cmd.find("--pad-mm 6"), std::string::npos) << "the export's box: " << cmd;
  EXPECT_NE(cmd.find("--map twist"), std::string::npos) << cmd;
  const std::string studioOut = "'" + (d / "studio/").string() + "'";
  ASSERT_NE(cmd.find(studioOut), std::string::npos) << cmd;
  cmd.replace(cmd.find(studioOut), studioOut.size(), "'" + (d / "cli/").string() + "'");
  cmd.replace(0, std::string("vellum").size(), std::string("\"") + VELLUM_CLI_EXE + "\"");
  cmd.pop_back();  // newline
  cmd += " --report '" + (d / "cli.json").string() + "'";
  ASSERT_EQ(std::system((cmd + " > \"" + (d / "cli-movie.log").string() + "\" 2>&1").c_str()), 0)
      << slurp(d / "cli-movie.log");
  // The box grew by the margin, and the studio's frames are the command's, pixel for pixel.
  const nlohmann::json rep = nlohmann::json::parse(slurp(d / "cli.json"));
  EXPECT_EQ(rep["movie"]["box"]["pad_voxels"]["low"], (std::vector<int>{3, 3, 3})) << rep["movie"]["box"].dump();
  EXPECT_EQ(rep["movie"]["box"]["grid"]["dims"], (std::vector<int>{kN + 6, kN + 6, kN + 6}));
  const int frames = expectSameFrames(d / "studio", d / "cli");
  EXPECT_EQ(frames, rep["movie"]["frames"].get<int>());
  EXPECT_GT(frames, 3);
  fs::remove_all(d);
}

}  // namespace
}  // namespace vellum::studio
