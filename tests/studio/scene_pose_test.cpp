// The scene file's joints (issue 23 §3): the joint tool's pose saved beside the scene as a
// pose file (deformation::savePose / loadPose: one schema, one parser) and read back exactly;
// a scene written before joints existed (version 3, no "joints") still opens without them; a
// damaged joints section or pose file is one line naming the file.
#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <string>
#include <tuple>

#include "file_errors.hpp"
#include "scene_file.hpp"
#include "test_data.hpp"
#include "vellum/core/error.hpp"

using namespace vellum;
using namespace vellum::studio;
namespace fs = std::filesystem;

TEST(StudioScenePose, JointsRoundTripExactlyOldScenesOpenWithoutAndDamagedJointsAreNamedErrors) {
  const fs::path dir = test::tempDir("studio-scene-pose");
  std::ofstream(dir / "ct.nrrd") << "placeholder";  // only its existence is checked

  // A pose as the joint tool makes it: one estimated axis, one given, a chain, fixed regions,
  // two keyframes with angles that are not round in binary-decimal terms.
  deformation::Pose pose;
  deformation::Joint knee, ankle;
  knee.name = "knee";
  knee.parent = {1};
  knee.child = {2, 3};
  knee.estimateAxis = true;
  ankle.name = "ankle";
  ankle.parent = {2};
  ankle.child = {4};
  ankle.axisA = {10.125, -3.3, 40.7};
  ankle.axisB = {30.5, -3.3, 41.1};
  pose.joints = {knee, ankle};
  pose.fixed.ids = {50, 51};
  pose.fixed.boxesMm = {{0, 0, 0, 10, 12.5, 30}};
  pose.angles.loop = true;
  for (const auto& [kneeDeg, ankleDeg, durationS] : {std::tuple{0.0, 0.0, 1.0}, {17.3, -8.1, 0.7}}) {
    deformation::Keyframe k;
    k.durationS = durationS;
    k.points = {{{kneeDeg, 0, 0}, {kneeDeg, 0, 0}, {}}, {{ankleDeg, 0, 0}, {ankleDeg, 0, 0}, {}}};
    pose.angles.keyframes.push_back(k);
  }
  deformation::linkJoints(pose);

  SceneFile s;
  s.volume = dir / "ct.nrrd";
  s.pose = ScenePose{{}, pose};
  writeSceneFile(s, dir / "posed.json");
  ASSERT_TRUE(fs::exists(dir / "posed.pose.json"));  // a `vellum pose --pose` file beside the scene
  const SceneFile back = readSceneFile(dir / "posed.json");
  ASSERT_TRUE(back.pose.has_value());
  EXPECT_EQ(back.pose->posePath, dir / "posed.pose.json");
  EXPECT_TRUE(samePose(back.pose->pose, pose));
  EXPECT_EQ(back.pose->pose.joints[1].axisA, ankle.axisA);  // given axes exactly
  EXPECT_EQ(back.pose->pose.joints[1].proximal, 0);         // the chain linked again
  EXPECT_EQ(back.pose->pose.anglesAt(pose.lastKeyframeTimeS()), (std::vector<double>{17.3, -8.1}));

  // Version 3, written before joints: opens, no pose.
  std::ofstream(dir / "old.json") << R"({"format": "vellum-studio-scene", "version": 3, "volume": "ct.nrrd"})";
  EXPECT_FALSE(readSceneFile(dir / "old.json").pose.has_value());

  // Damaged: the joints section names the scene and the field; a missing or damaged pose file
  // names that file.
  const auto sceneError = [&](const std::string& joints) {
    return test::fileErrorOf([](const fs::path& f) { (void)readSceneFile(f); }, dir / "scene.json",
                             R"({"format": "vellum-studio-scene", "version": 4, "volume": "ct.nrrd", "joints": )" +
                                 joints + "}",
                             false);
  };
  std::string m = sceneError("5");
  EXPECT_NE(m.find("scene.json"), std::string::npos) << m;
  EXPECT_NE(m.find("\"joints\""), std::string::npos) << m;
  m = sceneError(R"({"pose": 7})");
  EXPECT_NE(m.find("scene.json"), std::string::npos) << m;
  EXPECT_NE(m.find("joints.pose"), std::string::npos) << m;
  m = sceneError(R"({"pose": "posed.pose.json", "angles": 3})");
  EXPECT_NE(m.find("joints.angles"), std::string::npos) << m;
  m = sceneError(R"({"pose": "missing.pose.json"})");
  EXPECT_NE(m.find("missing.pose.json"), std::string::npos) << m;
  std::ofstream(dir / "bad.pose.json") << R"({"joints": [{"name": "knee", "parent": [1]}], "keyframes": []})";
  m = sceneError(R"({"pose": "bad.pose.json"})");
  EXPECT_NE(m.find("bad.pose.json"), std::string::npos) << m;
  {  // a pose file cut in half
    std::ifstream in(dir / "posed.pose.json");
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream(dir / "cut.pose.json") << text.substr(0, text.size() / 2);
  }
  m = sceneError(R"({"pose": "cut.pose.json"})");
  EXPECT_NE(m.find("cut.pose.json"), std::string::npos) << m;
}
