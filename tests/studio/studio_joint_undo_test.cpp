// The joint tool's edits as undo steps and its pose in the scene file (issue 23 §3), on the
// joint tests' small limb (studio_run.hpp): Ctrl+Z / Ctrl+Shift+Z give back each angle
// exactly, with the posed track it makes; a scene saved with joints reopens with the same
// pose, posed track, edited keyframe and rigid bones.
#include <gtest/gtest.h>

#include <string>

#include <nlohmann/json.hpp>

#include "studio_run.hpp"
#include "test_data.hpp"
#include "vellum/deformation/point_files.hpp"
#include "vellum/deformation/pose.hpp"

namespace vellum::studio {
namespace {
namespace fs = std::filesystem;
using namespace vellum::deformation;
using namespace vellum::test::studio;

/// The angle of the pose file's only joint in its last keyframe, and its keyframe count.
std::pair<double, size_t> lastAngle(const fs::path& poseFile) {
  const Pose p = loadPose(poseFile);
  return {p.anglesAt(p.lastKeyframeTimeS()).at(0), p.angles.keyframes.size()};
}

/// Script actions that wait for idle and save the joint tool's pose as NAME.pose.json in `d`.
std::string savePoseActions(const fs::path& d, const std::string& name) {
  return R"({"wait_idle":true},{"joint":{"save":{"path":)" + q(d / (name + ".pose.json")) + R"(}}},)";
}

TEST(StudioJointUndo, UndoAndRedoGiveBackEachAngleExactlyAndTheJointItself) {
  REQUIRE_DISPLAY();
  const fs::path d = limbDir("studio-joint-undo");
  const auto save = [&](const std::string& name) { return savePoseActions(d, name); };
  // Four undo steps: the joint, a keyframe, two angles; then back and forth. No 3D pane:
  // waiting for idle then waits for the map, not for a 3D refinement.
  const std::string script = scriptOnPhantom(d) + R"(
    {"layout":"1x3"},{"hud":false},
    {"joint":{"add":{"name":"knee","parent":[1],"child":[2],"axis":[[30,40,39],[50,40,39]]}}},
    {"joint":{"keyframe":"add"}},
    {"joint":{"angle":{"joint":"knee","deg":20.3}}},
    {"joint":{"angle":{"joint":"knee","deg":-33.7}}},)" +
                             save("a") + R"({"save_scene":)" + q(d / "sa.json") + R"(},
    {"key":"ctrl+z"},)" + save("b") + R"(
    {"key":"ctrl+z"},)" + save("c") + R"(
    {"key":"ctrl+shift+z"},)" + save("d") + R"(
    {"key":"ctrl+shift+z"},)" + save("e") + R"({"save_scene":)" + q(d / "se.json") + R"(},
    {"key":"ctrl+z"},{"key":"ctrl+z"},{"key":"ctrl+z"},{"key":"ctrl+z"},{"wait_idle":true},
    {"save_scene":)" + q(d / "sz.json") + R"(},
    {"quit":0}]})";
  std::string log;
  ASSERT_EQ(runStudio(d, "undo", script, &log), 0) << log;
  using P = std::pair<double, size_t>;
  EXPECT_EQ(lastAngle(d / "a.pose.json"), (P{-33.7, 2}));
  EXPECT_EQ(lastAngle(d / "b.pose.json"), (P{20.3, 2}));
  EXPECT_EQ(lastAngle(d / "c.pose.json"), (P{0.0, 2}));
  EXPECT_EQ(lastAngle(d / "d.pose.json"), (P{20.3, 2}));
  EXPECT_EQ(lastAngle(d / "e.pose.json"), (P{-33.7, 2}));
  // Redone, the pose makes the same posed track (what the map is solved from) as before.
  EXPECT_EQ(slurp(d / "se.pose.json"), slurp(d / "sa.pose.json"));
  EXPECT_EQ(slurp(d / "se.keyframes.json"), slurp(d / "sa.keyframes.json"));
  // Undone past "add joint": no joints, none saved.
  const nlohmann::json z = nlohmann::json::parse(slurp(d / "sz.json"));
  EXPECT_FALSE(z.contains("joints")) << z.dump();
}

TEST(StudioJointUndo, ASceneSavedWithJointsReopensWithTheSamePoseAndPosedTrack) {
  REQUIRE_DISPLAY();
  const fs::path d = limbDir("studio-joint-scene");
  // Saved at keyframe 1 of 3: the estimated axis, the fixed block, two angles.
  const std::string first = scriptOnPhantom(d) + R"(
    {"layout":"1x3"},{"hud":false},
    {"joint":{"add":{"name":"knee","parent":[1],"child":[2],"axis":"estimate"}}},
    {"joint":{"fixed":{"labels":[50]}}},
    {"joint":{"keyframe":"add"}},{"joint":{"angle":{"joint":"knee","deg":17.3}}},
    {"joint":{"keyframe":"add"}},{"joint":{"angle":{"joint":"knee","deg":-8.1}}},
    {"joint":{"keyframe":{"select":1}}},
    {"wait_idle":true},{"save_scene":)" + q(d / "s1.json") + R"(},
    {"quit":0}]})";
  std::string log;
  ASSERT_EQ(runStudio(d, "first", first, &log), 0) << log;
  const nlohmann::json s1 = nlohmann::json::parse(slurp(d / "s1.json"));
  ASSERT_EQ(s1.at("joints").at("pose"), "s1.pose.json") << s1.dump();
  const std::string second = R"({"actions":[{"open":)" + q(d / "s1.json") + R"(},
    {"wait_idle":true},{"save_scene":)" + q(d / "s2.json") + R"(},
    {"quit":0}]})";
  ASSERT_EQ(runStudio(d, "second", second, &log), 0) << log;
  EXPECT_NE(log.find("joint tool: 1 joints"), std::string::npos) << log;  // prepared on reopening
  EXPECT_EQ(log.find("vellum-studio: joint tool:"), std::string::npos) << log;  // no error
  // The same pose file, the same posed track, the same edited keyframe and rigid bones.
  EXPECT_EQ(slurp(d / "s2.pose.json"), slurp(d / "s1.pose.json"));
  // The posed track: the estimated axis sums voxels in parallel, so in another run its last
  // bits may differ.
  const KeyframeTrack t1 = loadKeyframes(d / "s1.keyframes.json"), t2 = loadKeyframes(d / "s2.keyframes.json");
  ASSERT_EQ(t2.keyframes.size(), 3u);
  ASSERT_EQ(t1.keyframes.size(), 3u);
  for (size_t k = 0; k < 3; ++k) {
    ASSERT_EQ(t2.keyframes[k].points.size(), t1.keyframes[k].points.size());
    ASSERT_GT(t1.keyframes[k].points.size(), 8u);
    for (size_t i = 0; i < t1.keyframes[k].points.size(); ++i)
      EXPECT_LT(norm(t2.keyframes[k].points[i].target - t1.keyframes[k].points[i].target), 1e-6) << k << " " << i;
  }
  const nlohmann::json s2 = nlohmann::json::parse(slurp(d / "s2.json"));
  EXPECT_EQ(s2.at("deformation").at("keyframe"), 1);
  EXPECT_EQ(s2.at("deformation").at("rigid_labels"), s1.at("deformation").at("rigid_labels"));
  const Pose p = loadPose(d / "s2.pose.json");
  ASSERT_EQ(p.joints.size(), 1u);
  EXPECT_TRUE(p.joints[0].estimateAxis);
  EXPECT_EQ(p.fixed.ids, std::vector<uint16_t>{kLimbFixed});
  ASSERT_EQ(p.angles.keyframes.size(), 3u);
  EXPECT_EQ(p.angles.keyframes[1].points[0].source.x, 17.3);
  EXPECT_EQ(p.angles.keyframes[2].points[0].source.x, -8.1);
}


TEST(StudioJointUndo, DeformationPanelKeyframeEditsChangeThePoseAndItsPointEditsAreRefused) {
  REQUIRE_DISPLAY();
  const fs::path d = limbDir("studio-joint-track");
  const auto save = [&](const std::string& name) { return savePoseActions(d, name); };
  // The Deformation panel's keyframe edits ("keyframe": its Add keyframe and Duration) while a
  // joint makes the track: each is one pose edit, undone with Ctrl+Z; then its point
  // placement ("controls") is refused with the reason, and the script stops there.
  const std::string script = scriptOnPhantom(d) + R"(
    {"layout":"1x3"},{"hud":false},
    {"joint":{"add":{"name":"knee","parent":[1],"child":[2],"axis":[[30,40,39],[50,40,39]]}}},
    {"joint":{"angle":{"joint":"knee","deg":12.5}}},{"wait_idle":true},
    {"keyframe":"add"},
    {"joint":{"angle":{"joint":"knee","deg":-20}}},
    {"keyframe":{"duration":2.5}},)" +
                             save("a") + R"({"save_scene":)" + q(d / "sa.json") + R"(},
    {"key":"ctrl+z"},)" + save("b") + R"(
    {"key":"ctrl+z"},{"key":"ctrl+z"},)" + save("c") + R"(
    {"controls":"labels"},
    {"quit":0}]})";
  std::string log;
  EXPECT_EQ(runStudio(d, "track", script, &log), 3) << log;  // the script's error exit
  EXPECT_NE(log.find("the control points come from the joints"), std::string::npos) << log;
  const Pose a = loadPose(d / "a.pose.json");
  ASSERT_EQ(a.angles.keyframes.size(), 2u);
  EXPECT_EQ(a.angles.keyframes[0].points.at(0).source.x, 12.5);
  EXPECT_EQ(a.angles.keyframes[1].points.at(0).source.x, -20.0);
  EXPECT_EQ(a.angles.keyframes[1].durationS, 2.5);
  // The scene's posed track is made from that pose: the same keyframes and durations.
  EXPECT_EQ(slurp(d / "sa.pose.json"), slurp(d / "a.pose.json"));
  const KeyframeTrack t = loadKeyframes(d / "sa.keyframes.json");
  ASSERT_EQ(t.keyframes.size(), 2u);
  EXPECT_EQ(t.keyframes[1].durationS, 2.5);
  EXPECT_GT(t.keyframes[1].points.size(), 8u);
  // Undo: the duration, then the angle and the added keyframe, one step each.
  const Pose b = loadPose(d / "b.pose.json");
  ASSERT_EQ(b.angles.keyframes.size(), 2u);
  EXPECT_EQ(b.angles.keyframes[1].durationS, a.angles.keyframes[0].durationS);
  EXPECT_EQ(b.angles.keyframes[1].points.at(0).source.x, -20.0);
  const Pose c = loadPose(d / "c.pose.json");
  ASSERT_EQ(c.angles.keyframes.size(), 1u);
  EXPECT_EQ(c.angles.keyframes[0].points.at(0).source.x, 12.5);
}

}  // namespace
}  // namespace vellum::studio
