// `vellum pose` (issue 23 §3) on a small synthetic limb (40³ voxels of 2 mm): bones are
// cylinders along z with label ids, soft tissue around them, a fixed block aside. A joint's
// child bone must map by the requested rotation about the joint axis (analytic), the parent and
// the fixed block must not move, a chain composes (the grand-child follows), angle 0 is the
// identity, and a malformed pose file is one line and exit 2 through the binary.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstring>
#include <fstream>
#include <iostream>
#include <numbers>

#include "child_process.hpp"
#include "hinge_pose.hpp"
#include "test_data.hpp"
#include "vellum/app/pose_pipeline.hpp"
#include "vellum/deformation/deformer.hpp"
#include "vellum/deformation/point_files.hpp"
#include "vellum/deformation/pose.hpp"
#include "vellum/deformation/synthesis.hpp"
#include "vellum/deformation/twist_frames.hpp"
#include "vellum/io/volume_io.hpp"

using namespace vellum;
using namespace vellum::deformation;
namespace fs = std::filesystem;

namespace {

constexpr int kN = 40;           // voxels per axis
constexpr double kSpacing = 2;   // mm
constexpr double kCentre = 40;   // the limb's axis: x = y = 40 mm
constexpr uint16_t kSoft = 100, kFixed = 50;

Geometry limbGeometry() {
  Geometry g;
  g.dims = {kN, kN, kN};
  g.spacing = {kSpacing, kSpacing, kSpacing};
  return g;
}

/// Bones i + 1 = cylinders of radius 5 mm along z (x half-width boneHalfWidthX) over `bonesZ` (mm), soft tissue (radius
/// 16 mm, z 4..76 mm) around them, and a fixed block (x, y 2..10 mm, z 2..30 mm) aside.
struct Limb {
  VolumeI16 ct;
  LabelVolume labels;
};
Limb makeLimb(const std::vector<std::pair<double, double>>& bonesZ, double boneHalfWidthX = 5) {
  const Geometry g = limbGeometry();
  Limb l{VolumeI16(g, -1000), LabelVolume(g)};
  for (int k = 0; k < kN; ++k)
    for (int j = 0; j < kN; ++j)
      for (int i = 0; i < kN; ++i) {
        const Vec3 p = g.indexToPhysical({double(i), double(j), double(k)});
        const double r = std::hypot(p.x - kCentre, p.y - kCentre);
        uint16_t id = 0;
        int16_t hu = -1000;
        if (r <= 16 && p.z >= 4 && p.z <= 76) id = kSoft, hu = 40;
        for (size_t b = 0; b < bonesZ.size(); ++b)
          if (std::hypot((p.x - kCentre) / boneHalfWidthX, (p.y - kCentre) / 5) <= 1 && p.z >= bonesZ[b].first && p.z <= bonesZ[b].second) id = uint16_t(b + 1), hu = 1000;
        if (p.x >= 2 && p.x <= 10 && p.y >= 2 && p.y <= 10 && p.z >= 2 && p.z <= 30) id = kFixed, hu = 600;
        l.ct(i, j, k) = hu;
        l.labels(i, j, k) = id;
      }
  return l;
}

std::string xAxisAt(double z) {
  return "[[30, 40, " + std::to_string(z) + "], [50, 40, " + std::to_string(z) + "]]";
}

/// A pose of makeLimb({{46, 74}, {12, 36}}): the knee, parent 1 above, child 2 below, the
/// axis along x at z = 41 mm.
Pose limbKnee() { return test::hingePose("knee", 1, 2, {30, 40, 41}, {50, 40, 41}); }

struct Files {
  fs::path dir, ct, labels, pose, out, report;
};
Files writeLimb(const Limb& l, const std::string& name, const std::string& poseJson) {
  Files f;
  f.dir = test::tempDir(name);
  f.ct = f.dir / "ct.nrrd";
  f.labels = f.dir / "labels.nrrd";
  f.pose = f.dir / "pose.json";
  f.out = f.dir / "posed.nrrd";
  f.report = f.dir / "report.json";
  io::saveVolume(l.ct, f.ct);
  io::saveLabels(l.labels, f.labels);
  std::ofstream(f.pose) << poseJson;
  return f;
}

/// The request for `f`: the volume at the pose, the report and the generated points.
app::PoseRequest poseRequest(const Files& f) {
  app::PoseRequest r;
  r.input = f.ct;
  r.labels = f.labels;
  r.pose = f.pose;
  r.output = f.out;
  r.report = f.report;
  r.pointsOut = f.dir / "points.json";
  return r;
}

app::PoseResult runPose(const Files& f) { return app::runPose(poseRequest(f)); }

/// Fraction of `id`'s interior source voxels p (all 6 neighbours `id` too) whose image T(p)
/// shows bone (>= 900 HU) in the output: 1 when the bone moved by T as a whole.
double fractionMovedBy(const Limb& l, const VolumeI16& out, uint16_t id, const RigidTransform& t) {
  const Geometry& g = l.ct.geometry();
  int64_t n = 0, ok = 0;
  for (int k = 1; k + 1 < kN; ++k)
    for (int j = 1; j + 1 < kN; ++j)
      for (int i = 1; i + 1 < kN; ++i) {
        if (l.labels(i, j, k) != id || l.labels(i - 1, j, k) != id || l.labels(i + 1, j, k) != id ||
            l.labels(i, j - 1, k) != id || l.labels(i, j + 1, k) != id || l.labels(i, j, k - 1) != id ||
            l.labels(i, j, k + 1) != id)
          continue;
        const Vec3 q = g.physicalToIndex(t.apply(g.indexToPhysical({double(i), double(j), double(k)})));
        const int64_t a = std::llround(q.x), b = std::llround(q.y), c = std::llround(q.z);
        ++n;
        if (g.contains(a, b, c) && out(a, b, c) >= 900) ++ok;
      }
  EXPECT_GT(n, 20) << "bone " << id << " has too few interior voxels for the check";
  return n ? double(ok) / double(n) : 0;
}

VolumeI16 loadI16(const fs::path& p) { return std::get<VolumeI16>(io::loadVolume(p).volume); }

}  // namespace

TEST(Pose, ChildBoneMapsByTheRequestedRotationParentAndFixedStay) {
  const Limb limb = makeLimb({{46, 74}, {12, 36}});  // parent 1 above, child 2 below, axis at z = 41
  const std::string pose = R"({"units": "mm", "joints": [{"name": "knee", "parent": 1, "child": [2], "axis": )" +
                           xAxisAt(41) + R"(}], "fixed_labels": [50],
      "keyframes": [{"duration": 1, "angles": {"knee": 0}}, {"duration": 1, "angles": {"knee": 20}}]})";
  const Files f = writeLimb(limb, "pose-joint", pose);
  const app::PoseResult r = runPose(f);
  ASSERT_EQ(r.anglesDeg.size(), 1u);
  EXPECT_DOUBLE_EQ(r.anglesDeg[0], 20);  // default: the last keyframe
  ASSERT_EQ(r.joints.size(), 1u);
  const JointMeasure& m = r.joints[0];
  EXPECT_NEAR(m.achievedDeg, 20, 0.5);
  EXPECT_LT(m.childRotationErrorDeg, 0.5);
  EXPECT_LT(m.childPositionErrorMm, 0.5);
  EXPECT_LT(m.parentRotationDeg, 0.5);
  // Voxel level, against the analytic rotation: the child's voxels land where the requested
  // rotation puts them; the parent's stay; the fixed block's voxels are the input's, bit for bit.
  const VolumeI16 out = loadI16(f.out);
  const RigidTransform want = rotationAbout({30, 40, 41}, {50, 40, 41}, 20);
  EXPECT_GE(fractionMovedBy(limb, out, 2, want), 0.98);
  EXPECT_LT(fractionMovedBy(limb, out, 2, RigidTransform{}), 0.5) << "the child did move";
  EXPECT_GE(fractionMovedBy(limb, out, 1, RigidTransform{}), 0.98);
  for (int k = 0; k < kN; ++k)
    for (int j = 0; j < kN; ++j)
      for (int i = 0; i < kN; ++i)
        if (limb.labels(i, j, k) == kFixed) {
          ASSERT_EQ(out(i, j, k), limb.ct(i, j, k));
        }
  // The report: the joint, the per-bone rigidity and the fixed region (exactly still).
  const nlohmann::json rep = nlohmann::json::parse(std::ifstream(f.report));
  EXPECT_EQ(rep["joints"][0]["name"], "knee");
  EXPECT_NEAR(rep["joints"][0]["achieved_deg"].get<double>(), 20, 0.5);
  const nlohmann::json& after = rep["deform"]["rigidity"]["after"];
  EXPECT_LE(after["fixed"]["max_displacement_mm"].get<double>(), 1e-4);
  EXPECT_EQ(after["bodies"].size(), 2u);  // one rigid body per bone id
  EXPECT_LT(after["bone_rms_residual_mm"].get<double>(), 0.05);
  EXPECT_FALSE(after["fold_fraction"].is_null());
}

TEST(Pose, ChainGrandChildFollowsBothJoints) {
  // parent 1 (top), child 2, grand-child 3: knee at z = 51 (1 -> 2), ankle at z = 29 (2 -> 3).
  const Limb limb = makeLimb({{54, 76}, {32, 48}, {8, 26}});
  const std::string pose = R"({"joints": [
      {"name": "ankle", "parent": [2], "child": [3], "axis": )" + xAxisAt(29) + R"(},
      {"name": "knee", "parent": [1], "child": [2], "axis": )" + xAxisAt(51) + R"(}],
      "keyframes": [{"angles": {"knee": 15, "ankle": -10}}]})";
  const Files f = writeLimb(limb, "pose-chain", pose);
  const app::PoseResult r = runPose(f);
  ASSERT_EQ(r.pose.joints[0].proximal, 1);  // the ankle hangs below the knee
  ASSERT_EQ(r.pose.joints[1].proximal, -1);
  ASSERT_EQ(r.joints.size(), 2u);
  EXPECT_NEAR(r.joints[0].achievedDeg, -10, 1.0);  // relative to its parent (the shank)
  EXPECT_NEAR(r.joints[1].achievedDeg, 15, 1.0);
  EXPECT_LT(r.joints[0].childRotationErrorDeg, 1.0);
  EXPECT_LT(r.joints[0].childPositionErrorMm, 1.0);
  // The grand-child's voxels: knee's turn composed with the ankle's (about the ankle's rest axis).
  const std::vector<RigidTransform> t = jointTransforms(r.pose, r.anglesDeg);
  const RigidTransform knee = rotationAbout({30, 40, 51}, {50, 40, 51}, 15);
  const RigidTransform ankle = rotationAbout({30, 40, 29}, {50, 40, 29}, -10);
  const Vec3 p{40, 40, 10};
  EXPECT_LT(norm(t[0].apply(p) - knee.apply(ankle.apply(p))), 1e-9);
  const VolumeI16 out = loadI16(f.out);
  EXPECT_GE(fractionMovedBy(limb, out, 3, t[0]), 0.95);
  EXPECT_GE(fractionMovedBy(limb, out, 2, t[1]), 0.95);
  EXPECT_GE(fractionMovedBy(limb, out, 1, RigidTransform{}), 0.95);
}

TEST(Pose, AngleZeroIsTheIdentity) {
  const Limb limb = makeLimb({{46, 74}, {12, 36}});
  const Files f = writeLimb(limb, "pose-zero",
                            R"({"joints": [{"name": "knee", "parent": 1, "child": 2, "axis": )" + xAxisAt(41) +
                                R"(}], "keyframes": [{"angles": {"knee": 0}}]})");
  const app::PoseResult r = runPose(f);
  for (const ControlPoint& p : loadControlPoints(f.dir / "points.json").points) EXPECT_EQ(p.source, p.target);
  const VolumeI16 out = loadI16(f.out);
  int maxDiff = 0;
  for (int k = 0; k < kN; ++k)
    for (int j = 0; j < kN; ++j)
      for (int i = 0; i < kN; ++i) maxDiff = std::max(maxDiff, std::abs(out(i, j, k) - limb.ct(i, j, k)));
  EXPECT_LE(maxDiff, 1);
  EXPECT_NEAR(r.joints[0].achievedDeg, 0, 0.05);
}

TEST(Pose, MovieTrackStepsAndPoseFileErrors) {
  Pose pose;
  pose.joints.push_back({"knee", {1}, {2}, {30, 40, 41}, {50, 40, 41}});
  pose.angles.keyframes = {{1.0, {{{0, 0, 0}, {0, 0, 0}, {}}}, {}, {}}, {1.0, {{{20, 0, 0}, {20, 0, 0}, {}}}, {}, {}}};
  linkJoints(pose);
  const Limb limb = makeLimb({{46, 74}, {12, 36}});
  PoseOptions o;
  const PoseSamples s = poseSamples(pose, limb.labels, o);
  EXPECT_GE(s.bonePoints, 8);  // well-spread samples on both bones
  EXPECT_EQ(s.anchorPoints, 8);
  // 20 degrees in steps of at most 2: 10 generated keyframes, then the final hold.
  const KeyframeTrack t = poseTrack(s, pose, 2.0);
  ASSERT_EQ(t.keyframes.size(), 11u);
  EXPECT_DOUBLE_EQ(t.totalDurationS(), 2.0);
  const ControlPoints mid = posedPoints(s, pose, {10.0});
  for (size_t i = 0; i < mid.size(); ++i) EXPECT_LT(norm(t.keyframes[5].points[i].target - mid[i].target), 1e-9);

  // Each frame's known bone transforms (movies): backward, the child's the inverse rotation,
  // the parent's the identity, nothing for a body the pose does not name.
  const RigidBodies bodies = RigidBodies::fromLabels(limb.labels, {1, 2, kFixed});
  const auto known = knownBodyTransforms(pose, bodies, {20.0});
  ASSERT_EQ(known.size(), 3u);
  ASSERT_TRUE(known[0] && known[1]);
  EXPECT_FALSE(known[2]);
  const Vec3 p{40, 40, 20};
  const RigidTransform turn = rotationAbout({30, 40, 41}, {50, 40, 41}, 20);
  EXPECT_LT(norm(known[1]->apply(turn.apply(p)) - p), 1e-9);
  EXPECT_LT(norm(known[0]->apply(p) - p), 1e-12);

  // Semantic errors in a pose file name the file and the joint.
  const fs::path dir = test::tempDir("pose-errors");
  const auto refused = [&](const std::string& text, const std::string& expected) {
    std::ofstream(dir / "p.json") << text;
    try {
      loadPose(dir / "p.json");
      ADD_FAILURE() << "accepted: " << text;
    } catch (const FileError& e) {
      EXPECT_NE(std::string(e.what()).find("p.json"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
  };
  const std::string j1 = R"({"name": "a", "parent": 1, "child": 2, "axis": [[0, 0, 0], [1, 0, 0]]})";
  refused(R"({"joints": [)" + j1 + R"(], "keyframes": [{"angles": {"b": 3}}]})", "names no joint \"b\"");
  refused(R"({"joints": [)" + j1 + "," + R"({"name": "b", "parent": 3, "child": 2, "axis": [[0, 0, 0], [1, 0, 0]]})" +
              R"(], "keyframes": [{"angles": {}}]})",
          "also the child of joint \"a\"");
  refused(R"({"joints": [{"name": "a", "parent": 1, "child": 2, "axis": [[0, 0, 0], [0, 0, 0]]}], "keyframes": [{"angles": {}}]})",
          "coincide");
  refused(R"({"joints": [)" + j1 + R"(], "keyframes": [{"angles": {"a": "x"}}]})", "\"angles\".\"a\"");
  refused(R"({"joints": [)" + j1 + R"(], "fixed_labels": [2], "keyframes": [{"angles": {}}]})", "fixed_labels");
  // An axis hint goes with "estimate", has two distinct points, and its cone is 0..45°.
  const std::string est = R"({"name": "a", "parent": 1, "child": 2, "axis": "estimate", )";
  refused(R"({"joints": [{"name": "a", "parent": 1, "child": 2, "axis": [[0, 0, 0], [1, 0, 0]], "axis_hint": [[0, 0, 0], [1, 0, 0]]}], "keyframes": [{"angles": {}}]})",
          "goes with \"axis\": \"estimate\"");
  refused(R"({"joints": [)" + est + R"("axis_hint": [[0, 0, 0], [0, 0, 0]]}], "keyframes": [{"angles": {}}]})", "coincide");
  refused(R"({"joints": [)" + est + R"("axis_hint": [[0, 0, 0]]}], "keyframes": [{"angles": {}}]})", "two points");
  refused(R"({"joints": [)" + est + R"("axis_hint": [[0, 0, 0], [1, 0, 0]], "axis_hint_cone": 50}], "keyframes": [{"angles": {}}]})",
          "[0, 45]");
  refused(R"({"joints": [)" + est + R"("axis_hint_cone": 5}], "keyframes": [{"angles": {}}]})", "goes with \"axis_hint\"");
}

TEST(Pose, MalformedPoseFileIsOneLineAndExit2) {
  const Limb limb = makeLimb({{46, 74}, {12, 36}});
  const Files f = writeLimb(limb, "pose-cli", R"({"joints": [{"name": "knee", "parent": 1, "child": 2, "axis": [[30, 40)");
  for (const std::string& text :
       {std::string(R"({"joints": [{"name": "knee", "parent": 1, "child": 2, "axis": [[30, 40)"),
        std::string(R"({"joints": [{"name": "knee", "parent": 1, "child": 2, "axis": "estimate"}], "keyframes": [{"angles": {"knee": 5}}]})")}) {
    std::ofstream(f.pose) << text;
    test::Child child({"pose", f.ct.string(), "--labels", f.labels.string(), "--pose", f.pose.string(), "--out",
                       f.out.string()},
                      f.dir / "log.txt");
    EXPECT_EQ(child.wait(), 2);
    const std::string log = child.errors();
    EXPECT_EQ(std::count(log.begin(), log.end(), '\n'), 1) << log;
    EXPECT_NE(log.find("pose.json"), std::string::npos) << log;
    EXPECT_FALSE(fs::exists(f.out));
  }
}

TEST(Pose, EstimatedAxisOfAFlatContactIsTheContactZonesWidestDirection) {
  // Two blocks 40 mm wide in x, 20 in y, 2 mm apart at z = 25 (1 mm voxels): flat faces, no
  // hinge surface to fit, so the estimate falls back to the contact zone, whose widest
  // direction is x, through (24, 24, 25), and says so in a warning.
  Geometry g;
  g.dims = {48, 48, 48};
  g.spacing = {1, 1, 1};
  LabelVolume labels(g);
  for (int k = 8; k <= 41; ++k)
    for (int j = 14; j <= 34; ++j)
      for (int i = 4; i <= 44; ++i) labels(i, j, k) = k >= 26 ? 1 : k <= 24 ? 2 : 0;
  const fs::path path = test::tempDir("pose-estimate") / "pose.json";
  std::ofstream(path) << R"({"joints": [{"name": "knee", "parent": 1, "child": 2, "axis": "estimate"}],
                             "keyframes": [{"angles": {"knee": 10}}]})";
  Pose pose = loadPose(path);
  estimateAxes(pose, labels, 3.0);
  const Joint& j = pose.joints[0];
  const Vec3 dir = normalized(j.axisB - j.axisA), mid = (j.axisA + j.axisB) * 0.5;
  EXPECT_EQ(j.fit.method, "contact");
  EXPECT_FALSE(j.fit.warning.empty());
  EXPECT_GT(dir.x, 0.99);  // sign: the largest component positive
  EXPECT_LT(norm(mid - Vec3{24, 24, 25}), 1.0);
  Pose far = pose;
  far.joints[0].estimateAxis = true;
  EXPECT_THROW(estimateAxes(far, labels, 1.0), Error);  // 2 mm apart: no contact within 1 mm

  // The child split in two ids (x < 24 mm: 2, the rest: 3) that touch the parent equally: the
  // partner is one of them, and the warning says the choice is a tie.
  for (int k = 8; k <= 24; ++k)
    for (int j = 14; j <= 34; ++j)
      for (int i = 24; i <= 44; ++i) labels(i, j, k) = 3;
  std::ofstream(path) << R"({"joints": [{"name": "knee", "parent": 1, "child": [2, 3], "axis": "estimate"}],
                             "keyframes": [{"angles": {"knee": 10}}]})";
  Pose split = loadPose(path);
  estimateAxes(split, labels, 3.0);
  EXPECT_NE(split.joints[0].fit.warning.find("touch the parent almost equally"), std::string::npos)
      << split.joints[0].fit.warning;
  EXPECT_EQ(pose.joints[0].fit.warning.find("almost equally"), std::string::npos);  // one child id: no tie
}

// The joint-surface estimate against an analytic hinge and ball (48³ voxels of 1 mm): a
// "talus" whose top is a cylinder of radius 12 mm about a tilted axis, under a "plafond" shell
// 2 mm above it with flat "malleoli" plates beside its ends (outliers for the cylinder); then
// a ball in a socket. The recovered axis must lie within 3° and 1 mm of the truth, the fit
// report its radius and residual; the parent's and child's fits must agree.
TEST(Pose, EstimatedAxisIsTheArticularSurfacesCylinderOrSphere) {
  Geometry g;
  g.dims = {48, 48, 48};
  g.spacing = {1, 1, 1};
  const Vec3 c{24.3, 23.6, 22.2};                      // on the true axis (mm)
  const Vec3 d = normalized(Vec3{1, 0.12, 0.08});      // 8.3° off x
  const Vec3 up = normalized(cross(d, cross(Vec3{0, 0, 1}, d)));  // across the axis, upwards
  constexpr double kR = 12;
  LabelVolume hinge(g), ball(g);
  for (int k = 0; k < 48; ++k)
    for (int j = 0; j < 48; ++j)
      for (int i = 0; i < 48; ++i) {
        const Vec3 p = g.indexToPhysical({double(i), double(j), double(k)}) - c;
        const double s = dot(p, d), rho = norm(p - d * s), h = dot(p, up);
        uint16_t id = 0;
        if (std::abs(s) <= 12 && rho <= kR) id = 2;                                  // the talus
        if (std::abs(s) <= 12 && rho >= kR + 2 && rho <= kR + 7 && h >= 0) id = 1;   // the plafond
        if (std::abs(s) >= 13 && std::abs(s) <= 16 && rho <= kR + 7 && h >= 0) id = 1;   // malleoli
        hinge(i, j, k) = id;
        const double r = norm(p);
        ball(i, j, k) = r <= kR ? 2 : (r >= kR + 2 && r <= kR + 7 && h >= -3) ? 1 : 0;
      }
  const std::string json = R"({"joints": [{"name": "j", "parent": 1, "child": 2, "axis": "estimate"}],
                               "keyframes": [{"angles": {"j": 10}}]})";
  const fs::path path = test::tempDir("pose-surface-axis") / "pose.json";
  std::ofstream(path) << json;

  Pose pose = loadPose(path);
  estimateAxes(pose, hinge, 3.0);
  const Joint& j = pose.joints[0];
  const Vec3 dir = normalized(j.axisB - j.axisA), mid = (j.axisA + j.axisB) * 0.5;
  EXPECT_EQ(j.fit.method, "cylinder");
  EXPECT_GT(dot(dir, d), std::cos(3.0 * std::numbers::pi / 180));  // sign: x, the largest, positive
  const Vec3 off = (mid - c) - d * dot(mid - c, d);                   // distance between the axes
  EXPECT_LT(norm(off), 1.0);
  EXPECT_EQ(j.fit.surface, "both");   // the talus's dome and the plafond share the axis
  EXPECT_NEAR(j.fit.radiusMm, kR, 1.0);  // the child's
  EXPECT_LT(j.fit.axisGapMm, 1.0);
  EXPECT_LT(j.fit.rmsMm, 0.8);
  EXPECT_GT(j.fit.arcDeg, 150);
  EXPECT_TRUE(j.fit.warning.empty()) << j.fit.warning;

  Pose bp = loadPose(path);
  estimateAxes(bp, ball, 3.0);
  const Joint& b = bp.joints[0];
  EXPECT_EQ(b.fit.method, "sphere");
  EXPECT_LT(norm((b.axisA + b.axisB) * 0.5 - c), 1.0);  // through the ball's centre
  EXPECT_NEAR(b.fit.radiusMm, kR, 1.0);
  EXPECT_GT(b.fit.confidence, 0.3);
  EXPECT_GT(j.fit.confidence, 0.3);  // the hinge's
  EXPECT_TRUE(j.fit.refusals.empty());
}

// A synthetic ankle (1 mm voxels): a talar trochlea (a cylinder of radius 20 mm, 30 mm long,
// about an axis tilted 8° down laterally and 6° backwards) under a concave plafond 2 mm above
// it, a medial malleolus plate 2 mm beside the trochlea's end (a flat facet: outliers), and
// behind it the tibia's rounded posterior lip resting 2 mm over a calcaneus-like block that is
// wider than the talus, its top flat with irregular bumps. The talus (child id 2) and the
// calcaneus (child id 3) move together; the tibia is id 1.
namespace {

struct Ankle {
  LabelVolume labels;
  Vec3 centre, axis;  // the trochlea's axis (mm)
};

Ankle makeAnkle() {
  Geometry g;
  g.dims = {96, 100, 80};
  g.spacing = {1, 1, 1};
  Ankle a{LabelVolume(g), {48.3, 47.6, 40.2}, normalized(Vec3{1, 0.105, -0.14})};
  const Vec3 up = normalized(cross(a.axis, cross(Vec3{0, 0, 1}, a.axis)));  // across the axis, upwards
  constexpr double kR = 20;
  for (int k = 0; k < 80; ++k)
    for (int j = 0; j < 100; ++j)
      for (int i = 0; i < 96; ++i) {
        const Vec3 x = g.indexToPhysical({double(i), double(j), double(k)});
        const Vec3 p = x - a.centre;
        const double s = dot(p, a.axis), rho = norm(p - a.axis * s), h = dot(p, up);
        const double fromTop = std::acos(std::clamp(h / std::max(rho, 1e-9), -1.0, 1.0)) * 180 / std::numbers::pi;
        uint16_t id = 0;
        if (std::abs(s) <= 15 && rho <= kR && h >= -14) id = 2;                                       // talus
        if (std::abs(s) <= 15 && rho >= kR + 2 && rho <= kR + 9 && fromTop <= 55) id = 1;             // plafond
        if (s >= -20 && s <= -17 && rho <= kR + 4 && h >= -12) id = 1;                               // medial malleolus
        if (std::hypot(x.y - 84, x.z - 52) <= 7 && x.x >= 26 && x.x <= 70) id = 1;                   // posterior lip (a rod)
        if (x.y >= 80 && x.y <= 88 && x.z >= 50 && x.z <= 70 && x.x >= 26 && x.x <= 70) id = 1;      // and the tibia above it
        const double top = 43 + ((i * 7 + j * 3) % 5 == 0 ? 1 : 0);                                   // a bumpy top face
        if (x.y >= 76 && x.y <= 97 && x.z >= 18 && x.z <= top && x.x >= 20 && x.x <= 76) id = 3;     // calcaneus
        a.labels(i, j, k) = id;
      }
  return a;
}

double degreesBetween(const Vec3& a, const Vec3& b) {
  return std::acos(std::min(1.0, std::abs(dot(normalized(a), normalized(b))))) * 180 / std::numbers::pi;
}

Pose estimatedPose(const std::string& child, const std::string& name) {
  const fs::path path = test::tempDir(name) / "pose.json";
  std::ofstream(path) << R"({"joints": [{"name": "ankle", "parent": 1, "child": )" + child +
                             R"(, "axis": "estimate"}], "keyframes": [{"angles": {"ankle": 10}}]})";
  return loadPose(path);
}

}  // namespace

// The articular partner is the talus (most voxels within --contact of the tibia), and only its
// contact is fitted: the estimate is the trochlea's axis (within 3°, passing within 1 mm), with
// a confidence and no refusal; the calcaneus's contact with the lip is not fitted.
TEST(Pose, EstimatedAnkleAxisIsTheTrochleasNotTheLipsContact) {
  const Ankle a = makeAnkle();
  Pose pose = estimatedPose("[2, 3]", "pose-ankle-axis");
  estimateAxes(pose, a.labels, 3.0);
  const Joint& j = pose.joints[0];
  const Vec3 dir = normalized(j.axisB - j.axisA), mid = (j.axisA + j.axisB) * 0.5;
  const Vec3 off = (mid - a.centre) - a.axis * dot(mid - a.centre, a.axis);  // between the axes
  EXPECT_EQ(j.fit.partner, 2);
  ASSERT_EQ(j.fit.contactVoxels.size(), 2u);  // both children touch the tibia
  EXPECT_GT(j.fit.contactVoxels[1].second, 0);  // the calcaneus under the lip: counted, not fitted
  EXPECT_EQ(j.fit.method, "cylinder") << j.fit.warning;
  EXPECT_LT(degreesBetween(dir, a.axis), 3.0);
  EXPECT_LT(norm(off), 1.0);
  EXPECT_NEAR(j.fit.radiusMm, 20, 1.0);  // the talus's dome
  EXPECT_EQ(j.fit.surface, "both");  // the dome and the plafond nest about one axis
  EXPECT_EQ(j.fit.warning.find("almost equally"), std::string::npos) << j.fit.warning;  // no tie
  EXPECT_TRUE(j.fit.refusals.empty());
  EXPECT_GT(j.fit.confidence, 0.3);  // the malleolus facet's voxels are off the cylinder
}

// The lip's contact alone (the calcaneus as the only child): its curved side is a rod's edge
// (radius 7 mm along 44 mm) and the block is flat, so no hinge axis may come out of it. At 3 mm
// of contact too little of the rod is reached to count; at 6 and 8 mm its arc does count and
// the edge rule must refuse it: the honest fallback, warned, with the reason.
TEST(Pose, EstimatedAxisRefusesALipOnABlock) {
  const Ankle a = makeAnkle();
  for (const double contact : {3.0, 6.0, 8.0}) {
    Pose pose = estimatedPose("3", "pose-lip-axis");
    estimateAxes(pose, a.labels, contact);
    const Joint& j = pose.joints[0];
    EXPECT_EQ(j.fit.partner, 3);
    EXPECT_EQ(j.fit.method, "contact") << "contact " << contact << " mm: radius " << j.fit.radiusMm;
    EXPECT_EQ(j.fit.confidence, 0);
    EXPECT_FALSE(j.fit.warning.empty());
    if (contact > 3) {
      ASSERT_FALSE(j.fit.refusals.empty()) << "contact " << contact << " mm";
      EXPECT_NE(j.fit.refusals[0].find("an edge"), std::string::npos) << j.fit.refusals[0];
    }
  }
}

// `--gltf`: the child bone's node turns by exactly the joint's rotation at each key (read back
// from the binary glTF), the parent's node stands still, and the skin's last morph target moves
// the skin below the knee while the skin above it stays.
// An axis hint is placed by the motion search (joint_motion.hpp): on the synthetic ankle the
// trochlea turning about its own axis slides along the plafond and the malleolus, so that axis
// scores (nearly) 0 and any other digs the dome into the plafond or lifts it off. From hints
// 6–8 mm off the trochlea's axis, the hint's direction kept (cone 0), the estimate passes within
// 1 mm of it; with a cone of 12° a hint 8° off comes back within 1.5°. The hint's sense of a
// positive angle is kept, the report says how far the search moved it.
TEST(Pose, AxisHintIsPlacedByTheMotionSearch) {
  const Ankle a = makeAnkle();
  const Vec3 up = normalized(cross(a.axis, cross(Vec3{0, 0, 1}, a.axis)));
  const Vec3 side = cross(a.axis, up);
  const auto hinted = [&](const Vec3& p, const Vec3& d, double cone) {
    const fs::path path = test::tempDir("pose-axis-hint") / "pose.json";
    std::ofstream f(path);
    f << R"({"joints": [{"name": "ankle", "parent": 1, "child": 2, "axis": "estimate", "axis_hint": [[)" << p.x << ","
      << p.y << "," << p.z << "], [" << p.x + 20 * d.x << "," << p.y + 20 * d.y << "," << p.z + 20 * d.z
      << R"(]], "axis_hint_cone": )" << cone << R"(}], "keyframes": [{"angles": {"ankle": 0}}, {"angles": {"ankle": 20}}]})";
    f.close();
    Pose pose = loadPose(path);
    estimateAxes(pose, a.labels, 3.0);
    return pose.joints[0];
  };
  const auto offAxis = [&](const Joint& j) {
    const Vec3 mid = (j.axisA + j.axisB) * 0.5;
    return norm((mid - a.centre) - a.axis * dot(mid - a.centre, a.axis));
  };
  for (const Vec3& shift : {up * 6.0, side * -7.0, up * -4.0 + side * 6.0}) {
    const Joint j = hinted(a.centre + shift - a.axis * 30.0, a.axis, 0);
    EXPECT_EQ(j.fit.method, "motion");
    EXPECT_LT(offAxis(j), 1.0) << "hint shifted by " << norm(shift) << " mm";
    EXPECT_GT(dot(normalized(j.axisB - j.axisA), a.axis), 1 - 1e-9);  // cone 0: the hint's direction
    const MotionFit& m = j.fit.motion;
    EXPECT_TRUE(m.searched);
    EXPECT_NEAR(m.shiftMm, norm(shift), 1.0);
    EXPECT_EQ(m.turnDeg, 0);
    EXPECT_LT(m.rmsMm, 0.75 * m.startRmsMm) << m.startRmsMm;  // the hint dug into the plafond or lifted off it
    EXPECT_LT(m.rmsMm, 0.6);
    EXPECT_LT(m.insideFraction, 0.01);
    EXPECT_EQ(m.anglesDeg, kHintAnglesDeg);  // a hinge's working range, whatever the keyframes
    EXPECT_TRUE(j.fit.warning.empty()) << j.fit.warning;
  }
  // A hint pointing the other way keeps its sense of a positive angle.
  const Joint back = hinted(a.centre + up * 5.0 + a.axis * 30.0, a.axis * -1.0, 0);
  EXPECT_LT(dot(normalized(back.axisB - back.axisA), a.axis), -1 + 1e-9);
  EXPECT_LT(offAxis(back), 1.0);
  // A tilted hint within a cone.
  const Vec3 tilted = normalized(a.axis + up * std::tan(8 * std::numbers::pi / 180));
  const Joint t = hinted(a.centre + side * 5.0 - tilted * 30.0, tilted, 12);
  EXPECT_LT(degreesBetween(t.axisB - t.axisA, a.axis), 1.5);
  EXPECT_LT(offAxis(t), 1.0);
  EXPECT_NEAR(t.fit.motion.turnDeg, 8, 1.5);
  // A hint whose best axis lies beyond the search's reach is warned about.
  const Joint far = hinted(a.centre + up * 45.0, a.axis, 0);
  EXPECT_NE(far.fit.warning.find("edge of the search"), std::string::npos) << far.fit.warning;
  // Cancelled (the studio's joint worker): it stops, the pose untouched.
  Pose pose = estimatedPose("2", "pose-axis-hint-cancel");
  pose.joints[0].hasAxisHint = true;
  pose.joints[0].hintA = a.centre, pose.joints[0].hintB = a.centre + a.axis;
  const Joint before = pose.joints[0];
  Progress cancelled;
  cancelled.cancel();
  EXPECT_THROW(estimateAxes(pose, a.labels, 3.0, cancelled), Cancelled);
  EXPECT_EQ(pose.joints[0].axisA, before.axisA);
  EXPECT_TRUE(pose.joints[0].fit.method.empty());
}

TEST(Pose, GltfNodesCarryTheJointRotation) {
  const Limb limb = makeLimb({{46, 74}, {12, 36}});
  const std::string pose = R"({"units": "mm", "joints": [{"name": "knee", "parent": 1, "child": [2], "axis": )" +
                           xAxisAt(41) + R"(}], "fixed_labels": [50],
      "keyframes": [{"duration": 1, "angles": {"knee": 0}}, {"duration": 1, "angles": {"knee": 30}}]})";
  Files f = writeLimb(limb, "pose-gltf", pose);
  app::PoseRequest r;
  r.input = f.ct;
  r.labels = f.labels;
  r.pose = f.pose;
  r.gltf = f.dir / "knee.glb";
  r.gltfOptions.keysPerSecond = 2;  // keys at 0, 0.5 and 1 s
  r.report = f.report;
  app::runPose(r);
  EXPECT_FALSE(fs::exists(f.out)) << "--gltf alone writes no volume";

  std::ifstream is(r.gltf, std::ios::binary);
  std::vector<char> bytes((std::istreambuf_iterator<char>(is)), std::istreambuf_iterator<char>());
  ASSERT_GT(bytes.size(), 20u);
  ASSERT_EQ(std::string(bytes.data(), 4), "glTF");
  uint32_t jsonLength = 0;
  std::memcpy(&jsonLength, bytes.data() + 12, 4);
  const nlohmann::json doc = nlohmann::json::parse(std::string(bytes.data() + 20, jsonLength));
  const char* bin = bytes.data() + 20 + jsonLength + 8;
  auto floats = [&](int accessor) {
    const auto& view = doc["bufferViews"][doc["accessors"][accessor]["bufferView"].get<int>()];
    std::vector<float> v(view["byteLength"].get<size_t>() / 4);
    std::memcpy(v.data(), bin + view["byteOffset"].get<size_t>(), v.size() * 4);
    return v;
  };
  ASSERT_EQ(doc["nodes"].size(), 3u);  // parent, child, skin
  EXPECT_EQ(doc["nodes"][0]["name"], "knee parent");
  EXPECT_EQ(doc["nodes"][1]["name"], "knee child");
  const auto& anim = doc["animations"][0];
  // Channels: parent rotation, parent translation, child rotation, child translation, skin weights.
  ASSERT_EQ(anim["channels"].size(), 5u);
  const auto times = floats(anim["samplers"][0]["input"]);
  ASSERT_EQ(times.size(), 3u);
  const auto parentQ = floats(anim["samplers"][0]["output"]);
  const auto childQ = floats(anim["samplers"][2]["output"]);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(parentQ[4 * k + 3], 1, 1e-6);  // identity throughout
  // About the x (L) axis, glTF +X: q = (sin(a/2), 0, 0, cos(a/2)); the angle at key k is 15 k degrees.
  for (int k = 0; k < 3; ++k) {
    const double a = 15.0 * k * M_PI / 180;
    EXPECT_NEAR(std::abs(childQ[4 * k]), std::sin(a / 2), 1e-5) << "key " << k;
    EXPECT_NEAR(std::abs(childQ[4 * k + 3]), std::cos(a / 2), 1e-5) << "key " << k;
  }
  const nlohmann::json rep = nlohmann::json::parse(std::ifstream(f.report));
  EXPECT_EQ(rep["gltf"]["bones"], 2);
  EXPECT_GT(rep["gltf"]["skin_max_move_mm"].get<double>(), 5);  // the skin below the knee swings
}

// savePose (the studio's joint tool writes it) reads back as the same pose; a pose file with
// two fixed boxes keeps both exactly still (`"fixed_boxes"`: a list; `deform --fixed-box`
// repeated gives the same engine).
TEST(Pose, SavedPoseReadsBackAndTwoFixedBoxesStayPut) {
  const Limb limb = makeLimb({{46, 74}, {12, 36}});
  const Files f = writeLimb(limb, "pose-save", R"({"units": "mm", "joints": [{"name": "knee", "parent": 1,
      "child": [2], "axis": )" + xAxisAt(41) + R"(}, {"name": "other", "parent": 2, "child": 50, "axis": "estimate",
      "axis_hint": [[1, 2, 3], [4, 5, 6]], "axis_hint_cone": 7.5}],
      "fixed_boxes": [[44, 44, 4, 60, 60, 20], [44, 20, 60, 60, 36, 76]], "interpolation": "smooth", "loop": true,
      "keyframes": [{"duration": 0.5, "angles": {"knee": 0}}, {"duration": 1.25, "angles": {"knee": 20, "other": -5}}]})");
  const Pose a = loadPose(f.pose);
  const fs::path saved = f.dir / "saved.json";
  savePose(a, saved);
  const Pose b = loadPose(saved);
  ASSERT_EQ(b.joints.size(), 2u);
  EXPECT_EQ(b.joints[0].axisA, a.joints[0].axisA);
  EXPECT_EQ(b.joints[0].axisB, a.joints[0].axisB);
  EXPECT_TRUE(b.joints[1].estimateAxis);
  EXPECT_TRUE(b.joints[1].hasAxisHint);
  EXPECT_EQ(b.joints[1].hintA, (Vec3{1, 2, 3}));
  EXPECT_EQ(b.joints[1].hintB, (Vec3{4, 5, 6}));
  EXPECT_EQ(b.joints[1].hintConeDeg, 7.5);
  EXPECT_FALSE(b.joints[0].hasAxisHint);
  Pose unhinted = a;  // "estimate" without a hint stays "estimate"
  unhinted.joints[1].hasAxisHint = false;
  savePose(unhinted, saved);
  const Pose c = loadPose(saved);
  EXPECT_TRUE(c.joints[1].estimateAxis);
  EXPECT_FALSE(c.joints[1].hasAxisHint);
  EXPECT_EQ(b.joints[1].child, std::vector<uint16_t>{50});
  EXPECT_EQ(b.joints[1].proximal, 0);
  EXPECT_EQ(b.fixed.boxesMm, a.fixed.boxesMm);
  EXPECT_EQ(b.angles.interpolation, Interpolation::Smooth);
  EXPECT_TRUE(b.angles.loop);
  ASSERT_EQ(b.angles.keyframes.size(), 2u);
  EXPECT_EQ(b.angles.keyframes[1].durationS, 1.25);
  EXPECT_EQ(b.anglesAt(0.5), (std::vector<double>{20, -5}));

  // Two boxes through the binary's engine: one joint, both boxes' voxels the input's.
  std::ofstream(f.pose) << R"({"units": "mm", "joints": [{"name": "knee", "parent": 1, "child": [2], "axis": )" +
                               xAxisAt(41) + R"(}], "fixed_boxes": [[44, 44, 4, 60, 60, 20], [44, 20, 60, 60, 36, 76]],
      "keyframes": [{"angles": {"knee": 25}}]})";
  runPose(f);
  const VolumeI16 out = loadI16(f.out);
  const Geometry& g = limb.ct.geometry();
  int64_t inBoxes[2] = {0, 0};
  for (int k = 0; k < kN; ++k)
    for (int j = 0; j < kN; ++j)
      for (int i = 0; i < kN; ++i) {
        const Vec3 p = g.indexToPhysical({double(i), double(j), double(k)});
        const bool box0 = p.x >= 44 && p.x <= 60 && p.y >= 44 && p.y <= 60 && p.z >= 4 && p.z <= 20;
        const bool box1 = p.x >= 44 && p.x <= 60 && p.y >= 20 && p.y <= 36 && p.z >= 60 && p.z <= 76;
        if (!box0 && !box1) continue;
        ++inBoxes[box0 ? 0 : 1];
        ASSERT_EQ(out(i, j, k), limb.ct(i, j, k)) << "voxel " << i << " " << j << " " << k;
      }
  EXPECT_GT(inBoxes[0], 100);
  EXPECT_GT(inBoxes[1], 100);
  const nlohmann::json rep = nlohmann::json::parse(std::ifstream(f.report));
  EXPECT_LE(rep["deform"]["rigidity"]["after"]["fixed"]["max_displacement_mm"].get<double>(), 1e-4);
  EXPECT_TRUE(rep["fixed_box_cuts"].empty()) << "neither box holds a voxel of the turning bone";
  fs::remove_all(f.dir);
}

// A fixed box over a bone that a joint turns holds its voxels there (the box wins) and cuts the
// bone: the feet bench's box x >= 253 mm holds a voxel of the right calcaneus. The pose says
// which box holds how much of which moving bone; a box over the still parent is no cut.
TEST(Pose, AFixedBoxOverATurningBoneIsACut) {
  const Limb limb = makeLimb({{46, 74}, {12, 36}});  // parent 1 above, child 2 (z 12..36 mm) below
  const LabelVolume& labels = limb.labels;
  Pose pose = limbKnee();
  pose.fixed.boxesMm = {{0, 0, 60, 78, 78, 64}, {78, 78, 20, 0, 0, 10}};  // the parent's z 60..64; the child's z 12..20
  int64_t perSlice = 0;  // the child's cross-section, from one slice (z = 24 mm)
  for (int j = 0; j < kN; ++j)
    for (int i = 0; i < kN; ++i) perSlice += limb.labels(i, j, 12) == 2;
  ASSERT_GT(perSlice, 10);
  const std::vector<FixedBoxCut> cuts = fixedBoxCuts(pose, labels);
  ASSERT_EQ(cuts.size(), 1u);
  EXPECT_EQ(cuts[0].box, 1u);
  EXPECT_EQ(cuts[0].id, 2);
  EXPECT_EQ(cuts[0].voxels, 5 * perSlice);  // slices z = 12, 14, 16, 18, 20 mm (faces included)
  pose.fixed.boxesMm = {{0, 0, 37, 78, 78, 45}};  // between the bones: no cut
  EXPECT_TRUE(fixedBoxCuts(pose, labels).empty());
}

// The feet bench's folds (issue 23 §4): a still block 6 mm beside a child bone split into two
// ids (a shaft and a distal piece). The fixed regions' blend band used to reach over the turning
// bone, pulling the tissue under it towards the identity while the bone kept its turn: a fold
// across the direction of motion. Now the band ends short of the bone: no tissue voxel folds,
// the block stays exactly, and every voxel showing either piece shows it by the joint's turn.
TEST(Pose, ChildPiecesBesideAFixedBlockShareTheJointTurnWithoutFolds) {
  Geometry g;
  g.dims = {40, 40, 40};
  g.spacing = {1.5, 1.5, 1.5};
  VolumeI16 ct(g, -1000);
  LabelVolume labels(g);
  for (int k = 0; k < 40; ++k)
    for (int j = 0; j < 40; ++j)
      for (int i = 0; i < 40; ++i) {
        const Vec3 p = g.indexToPhysical({double(i), double(j), double(k)});
        const bool limb = std::hypot(p.x - 30, p.y - 30) <= 5;
        uint16_t id = p.x >= 4 && p.x <= 56 && p.y >= 4 && p.y <= 56 && p.z >= 4 && p.z <= 56 ? kSoft : 0;
        if (limb && p.z >= 34 && p.z <= 54) id = 1;       // parent
        if (limb && p.z >= 8 && p.z < 21) id = 2;         // the child's shaft ...
        if (limb && p.z >= 21 && p.z <= 28) id = 3;       // ... and its distal piece, touching
        if (p.x >= 41 && p.x <= 54 && p.y >= 12 && p.y <= 48 && p.z >= 6 && p.z <= 40) id = kFixed;  // 6 mm aside
        labels(i, j, k) = id;
        ct(i, j, k) = id == 0 ? -1000 : id == kSoft ? 40 : id == kFixed ? 600 : 1000;
      }
  Pose pose;
  Joint joint;
  joint.name = "knee";
  joint.parent = {1};
  joint.child = {2, 3};
  joint.axisA = {20, 30, 31};
  joint.axisB = {40, 30, 31};
  pose.joints.push_back(joint);
  pose.fixed.ids = {kFixed};
  linkJoints(pose);
  const std::vector<double> angles{25};
  const PoseSamples samples = poseSamples(pose, labels, PoseOptions{});
  DeformParams p;
  p.controlScale = 2;
  Deformer deformer(AnyVolume(ct), p);
  deformer.setPoints(posedPoints(samples, pose, angles));
  ControlVolume cv = deformer.update();
  const RigidBodies bodies = RigidBodies::fromLabels(labels, {1, 2, 3}, 20, pose.fixed);
  applyRigidity(cv, bodies, RigidityParams{}, knownBodyTransforms(pose, bodies, angles));
  const std::vector<float> map = upsampleMap(cv, g);
  const RigidityReport r = measureRigidityMap(map, g, bodies);
  EXPECT_EQ(r.foldFraction, 0.0) << "min det J " << r.minJacobian;
  EXPECT_GT(r.tissueSamples, 20000);
  EXPECT_LT(r.fixedMaxDisplacementMm, 1e-4);
  // Every output voxel whose source lies in piece 2 or 3 shows it by the joint's turn.
  const RigidTransform turn = jointTransforms(pose, angles)[0];
  int64_t shown[2] = {0, 0};
  double worst = 0;
  for (int k = 0; k < 40; ++k)
    for (int j = 0; j < 40; ++j)
      for (int i = 0; i < 40; ++i) {
        const size_t t = static_cast<size_t>((k * 40 + j) * 40 + i);
        const Vec3 u{map[3 * t], map[3 * t + 1], map[3 * t + 2]};
        const Vec3 q = g.physicalToIndex(u);
        const int64_t a = std::llround(q.x), b = std::llround(q.y), c = std::llround(q.z);
        if (!g.contains(a, b, c) || (labels(a, b, c) != 2 && labels(a, b, c) != 3)) continue;
        ++shown[labels(a, b, c) - 2];
        worst = std::max(worst, norm(turn.apply(u) - g.indexToPhysical({double(i), double(j), double(k)})));
      }
  EXPECT_GT(shown[0], 200);
  EXPECT_GT(shown[1], 100);
  EXPECT_LT(worst, 0.1);
}


// The twist map drives the movie (`pose --map twist --movie`): a frame's map is the twist map at
// the frame's angles, so at scale 1 the last frame's map IS the still pose's (--out resampled
// through it bit for bit) and a rest keyframe's frame is the identity; at the default scale 2
// the nodes carry the twist and the voxel snap keeps every bone voxel exactly on its turn; the
// movie's report says which map it drew.
TEST(Pose, TwistMovieFramesAreTheStillPosesMap) {
  const Limb limb = makeLimb({{46, 74}, {12, 36}});
  Files f = writeLimb(limb, "pose-twist-movie",
                      R"({"units": "mm", "map": "twist", "joints": [{"name": "knee", "parent": 1, "child": [2], "axis": )" +
                          xAxisAt(41) + R"(}], "fixed_labels": [50],
      "keyframes": [{"duration": 1, "angles": {"knee": 0}}, {"duration": 1, "angles": {"knee": 30}}]})");
  app::PoseRequest r = poseRequest(f);
  r.movie = f.dir / "frames/";
  r.movieSettings.fps = 2;  // 5 frames over the 2 s track
  r.movieSettings.settings.width = r.movieSettings.settings.height = 24;
  r.gltf = f.dir / "knee.glb";  // the skin follows the same map
  r.gltfOptions.keysPerSecond = 1;
  r.gltfOptions.skinFaces = 2000;
  app::runPose(r);
  const nlohmann::json rep = nlohmann::json::parse(std::ifstream(f.report));
  EXPECT_EQ(rep["map"], "twist");
  EXPECT_EQ(rep["movie"]["map"], "twist");
  EXPECT_EQ(rep["movie"]["map_scale"], 2);
  EXPECT_EQ(rep["movie"]["frames"], 5);
  EXPECT_EQ(rep["gltf"]["skin_map"], "twist");
  // Nearly every vertex found where the map draws it (a few on the snap's seam at the bones'
  // rims keep the MLS estimate).
  EXPECT_LT(rep["gltf"]["skin_uninverted"].get<int>(), 20) << rep["gltf"].dump();
  EXPECT_GT(rep["gltf"]["skin_max_move_mm"].get<double>(), 5);
  // Every frame's bones exact (the snap with the pose's transforms), nothing folded.
  const auto& worst = rep["movie"]["rigidity_worst"];
  EXPECT_LT(worst["bone_rms_residual_mm"].get<double>(), 1e-3) << worst.dump();
  EXPECT_EQ(worst["fold_fraction"].get<double>(), 0.0) << worst.dump();

  const Pose pose = loadPose(f.pose);
  const Geometry g = limb.labels.geometry();
  auto bodies = std::make_shared<const RigidBodies>(RigidBodies::fromLabelGroups(limb.labels, {{1}, {2}}, 20, pose.fixed));
  const TwistFrames full(pose, bodies, g, 1);
  const double last = pose.angles.totalDurationS();
  const ControlVolume end = *full.atTime(last, *bodies);
  EXPECT_EQ(end.grid.dims, g.dims);
  EXPECT_EQ(end.sourceMm, twistMap(pose, pose.anglesAt(pose.lastKeyframeTimeS()), *bodies, g).mapMm);
  // --out is the volume resampled through that very map.
  const VolumeI16 out = loadI16(f.out);
  const VolumeI16 again = std::get<VolumeI16>(synthesizeFromMap(io::loadVolume(f.ct).volume, end.sourceMm));
  EXPECT_EQ(again.voxels(), out.voxels()) << "the last frame's map is not --out's";
  EXPECT_EQ(full.atTime(0, *bodies)->sourceMm, identityNodes(g)) << "the rest keyframe's frame moves";

  // Scale 2: the node grid's own bodies; every voxel shown in the child bone lies on its turn.
  auto nodeBodies = std::make_shared<const RigidBodies>(
      RigidBodies::fromLabelGroups(labelsAtNodes(limb.labels, 2), {{1}, {2}}, 2, pose.fixed));
  const TwistFrames coarse(pose, nodeBodies, g, 2);
  const ControlVolume cv = *coarse.atTime(last, *bodies);
  EXPECT_EQ(cv.grid.dims, controlGrid(g, 2).dims);
  const std::vector<float> map = upsampleMap(cv, g);
  const RigidTransform turn = jointTransforms(pose, {30.0})[0];
  int64_t shown = 0;
  double worstMm = 0, tissueMm = 0;
  for (int k = 0; k < kN; ++k)
    for (int j = 0; j < kN; ++j)
      for (int i = 0; i < kN; ++i) {
        const size_t t = static_cast<size_t>((k * kN + j) * kN + i);
        const Vec3 u{map[3 * t], map[3 * t + 1], map[3 * t + 2]};
        tissueMm = std::max(tissueMm, norm(u - Vec3{end.sourceMm[3 * t], end.sourceMm[3 * t + 1], end.sourceMm[3 * t + 2]}));
        const Vec3 q = g.physicalToIndex(u);
        const int64_t a = std::llround(q.x), b = std::llround(q.y), c = std::llround(q.z);
        if (!g.contains(a, b, c) || limb.labels(a, b, c) != 2) continue;
        ++shown;
        worstMm = std::max(worstMm, norm(turn.apply(u) - g.indexToPhysical({double(i), double(j), double(k)})));
      }
  EXPECT_GT(shown, 200);
  EXPECT_LT(worstMm, 1e-3);
  EXPECT_LT(tissueMm, 2 * kSpacing) << "the coarse twist strays from the full one";
  std::cout << "scale 2 against the full twist map: max " << tissueMm << " mm\n";
}

// A fixed box beside the turning child along the joint's axis (the feet bench: the right foot
// turns beside the fixed left half): the twist's w jumps at the box face (a pure shear), and a
// movie frame's node map (scale 2: nodes every 4 mm, the face at 50 mm mid-cell) straddles the
// jump. The held snap (RigidSnap::held) keeps every voxel of the box exactly where it is (the
// still parent stays exact through the ordinary snap); without it the face cells drag the box's
// voxels by part of the jump.
TEST(Pose, TwistMovieFramesHoldTheFixedBoxExactly) {
  const Limb limb = makeLimb({{46, 74}, {12, 36}});
  Pose pose = limbKnee();
  pose.fixed.ids = {kFixed};
  pose.fixed.boxesMm = {{50, 0, 0, 78, 78, 78}};
  linkJoints(pose);
  const Geometry g = limb.labels.geometry();
  const std::vector<std::vector<uint16_t>> groups{{1}, {2}};
  auto bodies = std::make_shared<const RigidBodies>(RigidBodies::fromLabelGroups(limb.labels, groups, 20, pose.fixed));
  const TwistFrames coarse(pose, nodeBodiesOf(labelsAtNodes(limb.labels, 2), groups, 2, pose.fixed), g, 2);
  const std::shared_ptr<const ControlVolume> cv = coarse.sharedAt({30.0}, *bodies);
  ASSERT_TRUE(cv->rigidSnap);
  const RigidityReport held = measureRigidityMap(upsampleMap(*cv, g), g, *bodies);
  EXPECT_GT(held.fixedSamples, 4000);
  EXPECT_LT(held.fixedMaxDisplacementMm, 1e-4) << "the fixed box moves in the frame";
  EXPECT_EQ(held.foldFraction, 0.0) << "min det J " << held.minJacobian;
  for (const auto& b : held.bodies)
    if (!b.fixed && b.ids == std::vector<uint16_t>{1}) {
      EXPECT_GT(b.samples, 100);
      EXPECT_LT(b.maxResidualMm, 1e-4) << "the still parent moves";
    }

  ControlVolume loose = *cv;
  auto snap = std::make_shared<RigidSnap>(*cv->rigidSnap);
  snap->held.clear();
  loose.rigidSnap = snap;
  const RigidityReport dragged = measureRigidityMap(upsampleMap(loose, g), g, *bodies);
  std::cout << "fixed box in a scale-2 frame: max " << dragged.fixedMaxDisplacementMm << " mm without the held snap, "
            << held.fixedMaxDisplacementMm << " mm with it\n";
  EXPECT_GT(dragged.fixedMaxDisplacementMm, 1.0) << "the case does not straddle the jump";
}

