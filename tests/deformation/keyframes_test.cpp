// Keyframes, point files and placement.
#include <gtest/gtest.h>

#include <fstream>
#include <set>

#include "test_data.hpp"
#include "vellum/core/error.hpp"
#include "vellum/deformation/placement.hpp"
#include "vellum/deformation/point_files.hpp"

using namespace vellum;
using namespace vellum::deformation;

namespace {
KeyframeTrack threeKeys(Interpolation in, bool loop) {
  KeyframeTrack t;
  t.interpolation = in;
  t.loop = loop;
  for (int k = 0; k < 3; ++k) {
    ControlPoint p{{0, 0, 0}, {10.0 * k, k == 1 ? 5.0 : 0.0, 0}, {}};
    p.attributes.lightness = 10.0 * k;
    t.keyframes.push_back({1.0 + k, {p}});
  }
  return t;
}
}  // namespace

TEST(Keyframes, LinearInterpolationAndTiming) {
  const auto t = threeKeys(Interpolation::Linear, false);
  EXPECT_DOUBLE_EQ(t.totalDurationS(), 6.0);
  EXPECT_EQ(t.at(0.5)[0].target, (Vec3{5, 2.5, 0}));
  EXPECT_DOUBLE_EQ(t.at(0.5)[0].attributes.lightness, 5.0);
  EXPECT_EQ(t.at(1.0)[0].target, (Vec3{10, 5, 0}));  // keyframe 1 starts at t = 1
  EXPECT_EQ(t.at(2.0)[0].target, (Vec3{15, 2.5, 0}));
  EXPECT_EQ(t.at(100)[0].target, (Vec3{20, 0, 0}));  // held at the end
  EXPECT_EQ(t.frameCount(10), 61);
}

TEST(Keyframes, SmoothPassesThroughKeysAndLoopIsSeamless) {
  for (Interpolation in : {Interpolation::Smooth, Interpolation::Eased}) {
    const auto t = threeKeys(in, true);
    EXPECT_LT(norm(t.at(1.0)[0].target - Vec3{10, 5, 0}), 1e-12);
    EXPECT_LT(norm(t.at(3.0)[0].target - Vec3{20, 0, 0}), 1e-12);
    // Loop: the last keyframe travels back to the first; the end equals the start.
    EXPECT_LT(norm(t.at(6.0)[0].target - t.at(0.0)[0].target), 1e-12);
    EXPECT_EQ(t.frameCount(10), 60);  // frame 60 would repeat frame 0
    EXPECT_LT(t.frameTimeS(59, 10), 6.0);
  }
  // Catmull-Rom differs from linear between keys.
  const auto s = threeKeys(Interpolation::Smooth, false).at(0.5)[0].target;
  EXPECT_GT(norm(s - Vec3{5, 2.5, 0}), 0.1);
}

TEST(Keyframes, RejectsInconsistentTracks) {
  auto t = threeKeys(Interpolation::Linear, false);
  t.keyframes[1].points.push_back(t.keyframes[1].points[0]);
  EXPECT_THROW(t.validate(), Error);
  t.keyframes.clear();
  EXPECT_THROW(t.at(0), Error);
}

TEST(PointFiles, RoundTripAndErrorsNameTheFile) {
  const auto dir = vellum::test::tempDir("deform-points");
  PointFile f;
  f.power = 3;
  f.points = {{{1, 2, 3}, {4, 5, 6}, {}}, {{-1, 0, 2.5}, {0, 0, 0}, {10, -5, 3, 0.5}}};
  saveControlPoints(f, dir / "cp.json");
  const auto g = loadControlPoints(dir / "cp.json");
  EXPECT_EQ(g.points, f.points);
  EXPECT_EQ(g.power, 3.0);
  const auto t = threeKeys(Interpolation::Smooth, true);
  saveKeyframes(t, dir / "kf.json");
  const auto u = loadKeyframes(dir / "kf.json");
  EXPECT_EQ(u.keyframes.size(), 3u);
  EXPECT_EQ(u.interpolation, Interpolation::Smooth);
  EXPECT_TRUE(u.loop);
  EXPECT_EQ(u.keyframes[2].points, t.keyframes[2].points);

  auto writeText = [&](const char* name, const char* text) {
    std::ofstream(dir / name) << text;
    return dir / name;
  };
  const auto bad = {writeText("a.json", "{\"points\": [ {\"source\": [1,2]} ]}"),
                    writeText("b.json", "not json"),
                    writeText("c.json", "{\"units\":\"cm\",\"points\":[{\"source\":[1,2,3]}]}"),
                    writeText("d.json", "{\"points\": []}")};
  for (const auto& p : bad) {
    try {
      loadControlPoints(p);
      ADD_FAILURE() << p;
    } catch (const FileError& e) {
      EXPECT_NE(std::string(e.what()).find(p.filename().string()), std::string::npos);
    }
  }
  EXPECT_THROW(loadControlPoints(dir / "missing.json"), FileError);
  EXPECT_THROW(loadKeyframes(writeText("e.json", "{\"keyframes\":[{\"duration\":1,\"points\":[{\"source\":[1,2,3]}]},"
                                                 "{\"duration\":1,\"points\":[]}]}")), FileError);
}

TEST(Placement, BoxPointsLieInsideWithTheInset) {
  Geometry g;
  g.dims = {90, 90, 110};
  g.spacing = {2, 2, 2};
  g.origin = {-90, -90, 0};
  const auto pts = boxControlPoints(g, 16, 0.1);
  ASSERT_EQ(pts.size(), 16u);
  for (const auto& p : pts) {
    const Vec3 idx = g.physicalToIndex(p.source);
    EXPECT_EQ(p.source, p.target);
    for (int a = 0; a < 3; ++a) {
      EXPECT_GE(idx[a], 0.1 * (g.dims[a] - 1) - 1e-9);
      EXPECT_LE(idx[a], 0.9 * (g.dims[a] - 1) + 1e-9);
    }
  }
  // 2 x 2 x 4: four distinct levels along the long (z) axis.
  std::set<double> zs;
  for (const auto& p : pts) zs.insert(std::round(p.source.z * 1000));
  EXPECT_EQ(zs.size(), 4u);
  EXPECT_THROW(boxControlPoints(g, 0), Error);
}

TEST(Placement, LabelPointsIncludeCentroidsOfEachLabel) {
  Geometry g;
  g.dims = {30, 30, 30};
  LabelVolume lv(g);
  for (int64_t k = 5; k < 25; ++k)
    for (int64_t j = 10; j < 14; ++j)
      for (int64_t i = 10; i < 14; ++i) lv(i, j, k) = 3;  // a rod along z
  const auto pts = labelControlPoints(lv);
  ASSERT_EQ(pts.size(), 8u + 3u);  // anchors + centroid + two ends
  EXPECT_LT(norm(pts[8].source - Vec3{11.5, 11.5, 14.5}), 1e-9);
  EXPECT_NEAR(std::abs(pts[9].source.z - pts[10].source.z), 19.0, 1.01);
}
