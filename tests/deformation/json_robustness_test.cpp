// Control-point and keyframe JSON readers on damaged input: truncated files, wrong types,
// NaN/inf, empty arrays, mismatched point counts, huge counts and durations. Each must be one
// line of vellum::FileError naming the file and the field; never a crash or another exception.
#include <gtest/gtest.h>

#include <fstream>
#include <functional>
#include <string>

#include "file_errors.hpp"
#include "hostile_json.hpp"
#include "test_data.hpp"
#include "vellum/core/error.hpp"
#include "vellum/deformation/point_files.hpp"

using namespace vellum;
using namespace vellum::deformation;
namespace fs = std::filesystem;

namespace {

const char* kPoint = R"({"source": [1, 2, 3], "target": [1.5, 2, 3]})";

std::string pointFile(const std::string& points) { return R"({"units": "mm", "points": )" + points + "}"; }

std::string keyframeFile(const std::string& keyframes, const std::string& extra = "") {
  return R"({"units": "mm", )" + extra + R"("keyframes": )" + keyframes + "}";
}
std::string keyframe(const std::string& duration, const std::string& points) {
  return R"({"duration": )" + duration + R"(, "points": )" + points + "}";
}

void loadPoints(const fs::path& p) { (void)loadControlPoints(p); }
void loadTrack(const fs::path& p) { (void)loadKeyframes(p); }

}  // namespace

TEST(JsonRobustness, ControlPointFileErrorsNameTheField) {
  const fs::path dir = test::tempDir("json-points");
  const fs::path f = dir / "cp.json";
  const std::string one = std::string("[") + kPoint + "]";
  struct Case {
    std::string text, field;
  };
  const std::vector<Case> cases = {
      {"", "not valid JSON"},
      {"[1, 2]", "expected a JSON object"},
      {R"({"units": "mm"})", "\"points\""},
      {pointFile("[]"), "\"points\" must be a non-empty array"},
      {pointFile("{}"), "\"points\""},
      {pointFile("[3]"), "point 0 is not an object"},
      {pointFile(R"([{"target": [1, 2, 3]}])"), "\"source\""},
      {pointFile(R"([{"source": [1, 2]}])"), "\"source\""},
      {pointFile(R"([{"source": ["1", 2, 3]}])"), "\"source\""},
      {pointFile(R"([{"source": [1, 2, 3], "target": [1e999, 0, 0]}])"), "number overflow parsing '1e999'"},
      {pointFile(R"([{"source": [1, 2, 3], "target": [Infinity, 0, 0]}])"), "not valid JSON"},
      {pointFile(R"([{"source": [1, 2, NaN]}])"), "not valid JSON"},
      {pointFile(R"([{"source": [1, 2, 3], "attributes": 5}])"), "\"attributes\""},
      {pointFile(R"([{"source": [1, 2, 3], "attributes": {"lightness": "x"}}])"), "\"lightness\""},
      {pointFile(R"([{"source": [1, 2, 3], "attributes": {"density": null}}])"), "\"density\""},
      {R"({"units": "cm", "points": )" + one + "}", "\"units\""},
      {R"({"power": "two", "points": )" + one + "}", "\"power\""},
      {R"({"power": 0, "points": )" + one + "}", "\"power\""},
  };
  for (const Case& c : cases) {
    const std::string m = test::fileErrorOf(loadPoints, f, c.text);
    EXPECT_NE(m.find(c.field), std::string::npos) << "want " << c.field << " in: " << m;
  }
  // Huge count: one point over the limit, named with the count.
  std::string many = "[";
  for (size_t i = 0; i <= kMaxControlPoints; ++i) many += std::string(i ? "," : "") + R"({"source":[0,0,0]})";
  many += "]";
  const std::string m = test::fileErrorOf(loadPoints, f, pointFile(many));
  EXPECT_NE(m.find(std::to_string(kMaxControlPoints + 1)), std::string::npos) << m;
}

TEST(JsonRobustness, KeyframeFileErrorsNameTheKeyframeAndField) {
  const fs::path dir = test::tempDir("json-keyframes");
  const fs::path f = dir / "track.json";
  const std::string pts1 = std::string("[") + kPoint + "]", pts2 = std::string("[") + kPoint + "," + kPoint + "]";
  struct Case {
    std::string text, field;
  };
  const std::vector<Case> cases = {
      {keyframeFile("[]"), "\"keyframes\" must be a non-empty array"},
      {keyframeFile("7"), "\"keyframes\""},
      {keyframeFile("[" + keyframe("1", pts1) + ", 4]"), "keyframe 1: not an object"},
      {keyframeFile("[" + keyframe("\"long\"", pts1) + "]"), "keyframe 0: \"duration\" must be a number"},
      {keyframeFile("[" + keyframe("-1", pts1) + "]"), "keyframe 0: \"duration\""},
      {keyframeFile("[" + keyframe("1", pts1) + "," + keyframe("1e12", pts1) + "]"), "keyframe 1: \"duration\""},
      {keyframeFile("[" + keyframe("1e999", pts1) + "]"), "number overflow parsing '1e999'"},
      {keyframeFile("[" + keyframe("NaN", pts1) + "]"), "not valid JSON"},
      {keyframeFile("[" + keyframe("1", "[]") + "]"), "keyframe 0: \"points\" must be a non-empty array"},
      {keyframeFile(R"([{"duration": 1}])"), "keyframe 0: missing \"points\""},
      {keyframeFile("[" + keyframe("1", pts1) + "," + keyframe("1", R"([{"source": [1, 2]}])") + "]"),
       "keyframe 1: point 0: \"source\""},
      {keyframeFile("[" + keyframe("1", pts1) + "," + keyframe("1", pts2) + "]"), "keyframe 1 has 2 points; keyframe 0 has 1"},
      {keyframeFile("[" + keyframe("1", pts1) + "]", R"("interpolation": 3, )"), "\"interpolation\""},
      {keyframeFile("[" + keyframe("1", pts1) + "]", R"("interpolation": "cubic", )"), "\"interpolation\""},
      {keyframeFile("[" + keyframe("1", pts1) + "]", R"("loop": "yes", )"), "\"loop\""},
  };
  for (const Case& c : cases) {
    const std::string m = test::fileErrorOf(loadTrack, f, c.text);
    EXPECT_NE(m.find(c.field), std::string::npos) << "want " << c.field << " in: " << m;
  }
  // Huge counts: keyframes over the limit.
  std::string many = "[";
  for (size_t i = 0; i <= kMaxKeyframes; ++i) many += std::string(i ? "," : "") + keyframe("0", pts1);
  many += "]";
  const std::string m = test::fileErrorOf(loadTrack, f, keyframeFile(many));
  EXPECT_NE(m.find("\"keyframes\" has " + std::to_string(kMaxKeyframes + 1)), std::string::npos) << m;
}

TEST(JsonRobustness, EveryTruncationOfAValidFileIsANamedError) {
  const fs::path dir = test::tempDir("json-truncated");
  KeyframeTrack track;
  for (int k = 0; k < 3; ++k) {
    Keyframe kf;
    kf.durationS = 0.5 + k;
    kf.points = {{{1, 2, 3}, {1, 2, 3.0 + k}, {}}, {{4, 5, 6}, {4, 5, 6}, {10.0 * k, 0, 0, 1}}};
    track.keyframes.push_back(kf);
  }
  saveKeyframes(track, dir / "full.json");
  std::ifstream in(dir / "full.json");
  const std::string full{std::istreambuf_iterator<char>(in), {}};
  ASSERT_NO_THROW(loadKeyframes(dir / "full.json"));
  // Prefixes short of the closing brace (every 3rd, and the last 40), for both readers: never
  // a crash, always a FileError.
  const size_t end = full.rfind('}');
  for (size_t n = 0; n < end; n += (n + 40 < end ? 3 : 1)) {
    (void)test::fileErrorOf(loadTrack, dir / "cut.json", full.substr(0, n));
    (void)test::fileErrorOf(loadPoints, dir / "cut.json", full.substr(0, n));
  }
}

TEST(KeyframeTrack, FrameCountRefusesAbsurdTracks) {
  KeyframeTrack t;
  t.keyframes.push_back({kMaxKeyframeDurationS, {{{0, 0, 0}, {0, 0, 0}, {}}}, std::nullopt, ""});
  t.keyframes.push_back({kMaxKeyframeDurationS, {{{0, 0, 0}, {1, 0, 0}, {}}}, std::nullopt, ""});
  EXPECT_EQ(t.frameCount(1), int(2 * kMaxKeyframeDurationS) + 1);
  EXPECT_THROW(t.frameCount(1000), Error);  // 7.2 M frames
  t.keyframes[0].durationS = 1e12;
  try {
    t.validate();
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("keyframe 0: \"duration\""), std::string::npos) << e.what();
  }
}

TEST(JsonRobustness, DeepOrOversizeFilesAreRefusedWithoutParsing) {
  const fs::path dir = test::tempDir("json-hostile");
  test::expectHostileJsonRefused(dir / "cp.json", 64u << 20, [&] { loadPoints(dir / "cp.json"); });
  test::expectHostileJsonRefused(dir / "kf.json", 512u << 20, [&] { loadTrack(dir / "kf.json"); });
}
