// Keyframes, point files and placement.
#include <gtest/gtest.h>

#include <fstream>
#include <set>

#include "file_errors.hpp"
#include "test_data.hpp"
#include "vellum/core/error.hpp"
#include "vellum/deformation/map_file.hpp"
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
    t.keyframes.push_back({1.0 + k, {p}, std::nullopt, ""});
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

TEST(MapFile, GzipAndRawRoundTripAndErrorsNameTheFile) {
  const auto dir = vellum::test::tempDir("map-file");
  Geometry g;
  g.dims = {5, 4, 3};
  g.spacing = {0.5, 1.5, 2.5};
  g.origin = {-10, 20, 3.25};
  g.direction = Mat3::fromColumns({0, 1, 0}, {-1, 0, 0}, {0, 0, 1});
  std::vector<float> map(3 * 60);
  for (size_t t = 0; t < map.size(); ++t) map[t] = 0.25f * static_cast<float>(t) - 7.0f;
  for (bool gz : {true, false}) {
    const auto path = dir / (gz ? "m.nrrd" : "r.nrrd");
    saveBackwardMapNrrd(map, g, path, gz);
    Geometry back;
    EXPECT_EQ(loadBackwardMapNrrd(path, &back), map);
    EXPECT_TRUE(back.dims == g.dims);
    EXPECT_TRUE(back.approxEqual(g, 1e-12));
  }
  EXPECT_THROW(saveBackwardMapNrrd(std::vector<float>(10), g, dir / "bad.nrrd"), FileError);
  EXPECT_FALSE(std::filesystem::exists(dir / "bad.nrrd"));
  // Truncated gzip data.
  {
    std::ifstream in(dir / "m.nrrd", std::ios::binary);
    std::string all((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream(dir / "cut.nrrd", std::ios::binary) << all.substr(0, all.size() - 20);
  }
  try {
    loadBackwardMapNrrd(dir / "cut.nrrd");
    ADD_FAILURE() << "no error for a truncated file";
  } catch (const FileError& e) {
    EXPECT_NE(std::string(e.what()).find("cut.nrrd"), std::string::npos) << e.what();
  }
  EXPECT_THROW(loadBackwardMapNrrd(dir / "missing.nrrd"), FileError);
  // A detached header (map.nhdr + map.raw.gz) reads back through io's NRRD reader too.
  saveBackwardMapNrrd(map, g, dir / "map.nhdr", true);
  EXPECT_TRUE(std::filesystem::exists(dir / "map.raw.gz"));
  EXPECT_EQ(loadBackwardMapNrrd(dir / "map.nhdr"), map);
  // A scalar volume is not a map.
  {
    std::ofstream(dir / "scalar.nrrd", std::ios::binary)
        << "NRRD0004\ntype: float\ndimension: 3\nsizes: 1 1 1\nendian: little\nencoding: raw\n\n"
        << std::string(4, '\0');
  }
  try {
    loadBackwardMapNrrd(dir / "scalar.nrrd");
    ADD_FAILURE() << "a scalar volume loaded as a map";
  } catch (const FileError& e) {
    EXPECT_NE(std::string(e.what()).find("not a Vellum backward map"), std::string::npos) << e.what();
  }
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
  // Corners + edge midpoints: 3 levels along z (the 4 z edges' midpoints at mid height).
  std::set<double> zs;
  for (const auto& p : pts) zs.insert(std::round(p.source.z * 1000));
  EXPECT_EQ(zs.size(), 3u);
  // Any count, primes included: that many distinct points, inside the inset box, not all on a
  // line or in a plane (from 4 on).
  for (int n = 1; n <= 41; ++n) {
    const auto q = boxControlPoints(g, n, 0.1);
    ASSERT_EQ(q.size(), static_cast<size_t>(n));
    Vec3 mean{};
    for (const auto& p : q) mean += p.source / double(n);
    double minGap = 1e300;
    Mat3 cov = Mat3::fromColumns({0, 0, 0}, {0, 0, 0}, {0, 0, 0});
    for (size_t a = 0; a < q.size(); ++a) {
      const Vec3 idx = g.physicalToIndex(q[a].source);
      for (int ax = 0; ax < 3; ++ax) {
        EXPECT_GE(idx[ax], 0.1 * (g.dims[ax] - 1) - 1e-9) << n;
        EXPECT_LE(idx[ax], 0.9 * (g.dims[ax] - 1) + 1e-9) << n;
      }
      for (size_t b = a + 1; b < q.size(); ++b) minGap = std::min(minGap, norm(q[a].source - q[b].source));
      const Vec3 d = q[a].source - mean;
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) cov(r, c) += d[r] * d[c];
    }
    if (n > 1) {
      EXPECT_GT(minGap, 10.0) << n;
    }
    if (n >= 4) {
      EXPECT_GT(cov.determinant(), 1.0) << n << " points are coplanar";
    }
  }
  EXPECT_THROW(boxControlPoints(g, 0), Error);
}

TEST(Placement, KneeBendSwingsTheCalfAboutThePivot) {
  Geometry g;
  g.dims = {90, 90, 110};
  g.spacing = {2, 2, 2};
  g.origin = {-90, -90, -110};
  const Vec3 pivot{0, 0, 24.5};
  const auto track = kneeBendTrack(g, 30.0, 2.0, pivot);
  const auto& bent = track.keyframes[1].points;
  int moved = 0;
  for (const auto& p : bent) {
    if (p.source.z >= pivot.z) {
      EXPECT_EQ(p.target, p.source);  // the thigh stays
      continue;
    }
    ++moved;
    // Rotation about x through the pivot: x kept, distance to the axis kept, 30 degrees turned.
    EXPECT_NEAR(p.target.x, p.source.x, 1e-9);
    const Vec3 a = p.source - pivot, b = p.target - pivot;
    EXPECT_NEAR(std::hypot(a.y, a.z), std::hypot(b.y, b.z), 1e-9);
    const double ang = std::atan2(b.z, b.y) - std::atan2(a.z, a.y);
    EXPECT_NEAR(std::remainder(ang, 2 * M_PI), 30.0 * M_PI / 180.0, 1e-9);
  }
  EXPECT_GE(moved, 4);
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

TEST(Placement, LabelPointsPerConnectedPartOfALabel) {
  // One label in two separate blobs (like the phantom's cancellous cores, 11, of the fibula
  // and the patella): a centroid for each blob, none between them.
  Geometry g;
  g.dims = {40, 20, 20};
  LabelVolume lv(g);
  for (int64_t k = 8; k < 12; ++k)
    for (int64_t j = 8; j < 12; ++j) {
      for (int64_t i = 2; i < 6; ++i) lv(i, j, k) = 11;
      for (int64_t i = 30; i < 34; ++i) lv(i, j, k) = 11;
    }
  const auto pts = labelControlPoints(lv);
  ASSERT_GE(pts.size(), 8u + 2u);
  EXPECT_LT(norm(pts[8].source - Vec3{3.5, 9.5, 9.5}), 1e-9);
  bool second = false;
  for (size_t t = 9; t < pts.size(); ++t) {
    second = second || norm(pts[t].source - Vec3{31.5, 9.5, 9.5}) < 1e-9;
    EXPECT_GT(norm(pts[t].source - Vec3{17.5, 9.5, 9.5}), 5.0) << "a point between the blobs";
  }
  EXPECT_TRUE(second);
}

// Issue 11: keyframed cameras (turntables, fly-arounds).
TEST(Keyframes, CamerasInterpolateHoldAndRoundTrip) {
  KeyframeTrack t = threeKeys(Interpolation::Linear, false);  // durations 1, 2, 3
  EXPECT_FALSE(t.cameraAt(0.5)) << "no keyframe has a camera";
  t.keyframes[0].camera = KeyframeCamera{0, 10, 1, {0, 0, 0}, std::nullopt};
  t.keyframes[1].camera = KeyframeCamera{90, 30, 2, {4, 0, -2}, std::nullopt};
  // Keyframe 2 has none: it holds keyframe 1's.
  const auto mid = t.cameraAt(0.5);
  ASSERT_TRUE(mid);
  EXPECT_DOUBLE_EQ(mid->azimuthDeg, 45);
  EXPECT_DOUBLE_EQ(mid->elevationDeg, 20);
  EXPECT_DOUBLE_EQ(mid->zoom, 1.5);
  EXPECT_EQ(mid->panMm, (Vec3{2, 0, -1}));
  EXPECT_EQ(*t.cameraAt(2.0), *t.keyframes[1].camera);
  EXPECT_EQ(*t.cameraAt(100.0), *t.keyframes[1].camera) << "end hold";

  const auto dir = test::tempDir("keyframe-cameras");
  saveKeyframes(t, dir / "k.json");
  const KeyframeTrack back = loadKeyframes(dir / "k.json");
  ASSERT_EQ(back.keyframes.size(), 3u);
  EXPECT_EQ(back.keyframes[1].camera, t.keyframes[1].camera);
  EXPECT_FALSE(back.keyframes[2].camera);

  // Bad cameras name the file, the keyframe and the field.
  std::ifstream in(dir / "k.json");
  const std::string good((std::istreambuf_iterator<char>(in)), {});
  for (const auto& [bad, needle] : std::vector<std::pair<std::string, std::string>>{
           {"\"zoom\": 2.0", "\"zoom\": 0"}, {"\"elevation\": 30.0", "\"elevation\": 120"}, {"\"azimuth\": 90.0", "\"azimuthh\": 90"}}) {
    std::string text = good;
    const size_t at = text.find(bad);
    ASSERT_NE(at, std::string::npos) << bad << "\n" << text;
    text.replace(at, bad.size(), needle);
    std::ofstream(dir / "bad.json") << text;
    try {
      loadKeyframes(dir / "bad.json");
      ADD_FAILURE() << needle;
    } catch (const FileError& e) {
      const std::string m = e.what();
      EXPECT_NE(m.find("bad.json"), std::string::npos) << m;
      EXPECT_NE(m.find("keyframe 1"), std::string::npos) << m;
      EXPECT_NE(m.find("camera"), std::string::npos) << m;
    }
  }
}

// Issue 11: the field of view is keyed too (dolly-zooms, perspective <-> orthographic), held
// on its own when a keyframe's camera has none, and absent when no camera has one (the
// render settings' field of view stays).
TEST(Keyframes, FieldOfViewInterpolatesHoldsAndRoundTrips) {
  KeyframeTrack t = threeKeys(Interpolation::Linear, false);  // durations 1, 2, 3
  t.keyframes[0].camera = KeyframeCamera{0, 10, 1, {0, 0, 0}, std::nullopt};
  t.keyframes[1].camera = KeyframeCamera{90, 30, 2, {0, 0, 0}, std::nullopt};
  EXPECT_FALSE(t.cameraAt(0.5)->fieldOfViewDeg) << "no camera has a field of view";
  t.keyframes[0].camera->fieldOfViewDeg = 20;
  t.keyframes[1].camera->fieldOfViewDeg = 60;
  EXPECT_DOUBLE_EQ(*t.cameraAt(0.25)->fieldOfViewDeg, 30);
  EXPECT_DOUBLE_EQ(*t.cameraAt(0.5)->fieldOfViewDeg, 40);
  EXPECT_DOUBLE_EQ(*t.cameraAt(2.0)->fieldOfViewDeg, 60) << "keyframe 2 has no camera: held";
  EXPECT_DOUBLE_EQ(*t.cameraAt(100.0)->fieldOfViewDeg, 60) << "end hold";
  // Keyframe 1's camera without a field of view holds keyframe 0's: 20 all the way.
  t.keyframes[1].camera->fieldOfViewDeg.reset();
  EXPECT_DOUBLE_EQ(*t.cameraAt(0.5)->fieldOfViewDeg, 20);
  EXPECT_DOUBLE_EQ(t.cameraAt(0.5)->azimuthDeg, 45) << "the rest still interpolates";
  // A leading camera without one takes the first one given; 0 (orthographic) blends too.
  t.keyframes[0].camera->fieldOfViewDeg.reset();
  t.keyframes[1].camera->fieldOfViewDeg = 0;
  EXPECT_DOUBLE_EQ(*t.cameraAt(0.0)->fieldOfViewDeg, 0);
  t.keyframes[0].camera->fieldOfViewDeg = 40;
  t.interpolation = Interpolation::Smooth;
  EXPECT_NEAR(*t.cameraAt(0.5)->fieldOfViewDeg, 20, 1e-9) << "Catmull-Rom through 40, 0, 0";

  const auto dir = test::tempDir("keyframe-fov");
  saveKeyframes(t, dir / "k.json");
  const KeyframeTrack back = loadKeyframes(dir / "k.json");
  ASSERT_EQ(back.keyframes.size(), 3u);
  EXPECT_EQ(back.keyframes[0].camera, t.keyframes[0].camera);
  EXPECT_EQ(back.keyframes[1].camera, t.keyframes[1].camera);
  EXPECT_EQ(back.keyframes[1].camera->fieldOfViewDeg, 0.0);
  t.keyframes[1].camera->fieldOfViewDeg.reset();
  saveKeyframes(t, dir / "k2.json");
  EXPECT_FALSE(loadKeyframes(dir / "k2.json").keyframes[1].camera->fieldOfViewDeg) << "absent stays absent";

  // Bad values name the file, the keyframe and the field.
  std::ifstream in(dir / "k.json");
  const std::string good((std::istreambuf_iterator<char>(in)), {});
  for (const char* bad : {"\"fov\": 121", "\"fov\": -1", "\"fov\": \"wide\"", "\"fov\": null"}) {
    std::string text = good;
    const size_t at = text.find("\"fov\": 0.0");
    ASSERT_NE(at, std::string::npos) << text;
    text.replace(at, std::string("\"fov\": 0.0").size(), bad);
    const std::string m = test::fileErrorOf([](const auto& p) { loadKeyframes(p); }, dir / "bad.json", text);
    EXPECT_NE(m.find("keyframe 1"), std::string::npos) << m;
    EXPECT_NE(m.find("\"camera\".\"fov\""), std::string::npos) << m;
  }
}
