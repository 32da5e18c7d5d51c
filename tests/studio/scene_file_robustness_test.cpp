// The studio scene reader on damaged scene files: truncated, wrong types, NaN/inf, out-of-range
// values, empty and huge arrays, a damaged keyframe file beside it. Each must be one line of
// vellum::FileError naming the file and the field; never a crash or another exception. Also the
// studio's other JSON readers (scripts, shape reports) on deep and oversize files.
#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "scene_file.hpp"
#include "file_errors.hpp"
#include "hostile_json.hpp"
#include "script.hpp"
#include "segment_meshes.hpp"
#include "test_data.hpp"
#include "vellum/core/error.hpp"

using namespace vellum;
using namespace vellum::studio;
namespace fs = std::filesystem;

namespace {

// The FileError message of reading `text` as a scene (errors about a referenced file name that file).
std::string sceneError(const fs::path& dir, const std::string& text) {
  return test::fileErrorOf([](const fs::path& f) { (void)readSceneFile(f); }, dir / "scene.json", text, false);
}

// Version 2 keeps each view field under its own key; version 3 has the parameter tables.
std::string scene(const std::string& fields, int version = 2) {
  return R"({"format": "vellum-studio-scene", "version": )" + std::to_string(version) + R"(, "volume": "ct.nrrd")" +
         (fields.empty() ? "" : ", " + fields) + "}";
}

}  // namespace

TEST(StudioSceneFile, DamagedFieldsAreNamedErrors) {
  const fs::path dir = test::tempDir("studio-scene-robust");
  std::ofstream(dir / "ct.nrrd") << "placeholder";  // only its existence is checked
  std::ofstream(dir / "ok.json") << scene("");
  ASSERT_NO_THROW(readSceneFile(dir / "ok.json"));
  struct Case {
    std::string fields, want;
  };
  const std::vector<Case> cases = {
      {R"("camera": {"zoom": 0})", "\"camera.zoom\""},
      {R"("camera": {"zoom": "big"})", "\"camera.zoom\" must be a number"},
      {R"("camera": {"fov": 500})", "\"camera.fov\""},
      {R"("camera": {"elevation": 1e300})", "\"camera.elevation\""},
      {R"("camera": 5)", "\"camera\" must be an object"},
      {R"("camera": {"pan": [1, 2]})", "\"camera.pan\""},
      {R"("camera": {"pan": [1, 2, "3"]})", "\"camera.pan\""},
      {R"("crosshair": [])", "\"crosshair\""},
      {R"("slice_window": [40])", "\"slice_window\""},
      {R"("render_window": [400, 0])", "\"render_window[1]\""},
      {R"("render_window": [400, -5])", "\"render_window[1]\""},
      {R"("label_opacity": 7)", "\"label_opacity\""},
      {R"("label_opacity": null)", "\"label_opacity\""},
      {R"("hidden_labels": [1, "two"])", "\"hidden_labels\""},
      {R"("hidden_labels": [70000])", "\"hidden_labels\""},
      {R"("locked_labels": {"a": 1})", "\"locked_labels\""},
      {R"("layout": 4)", "\"layout\" must be a string"},
      {R"("layout": "3x3")", "3x3"},
      {R"("preset": "shiny")", "shiny"},
      {R"("labels": ["a"])", "\"labels\" must be a string"},
      {R"("deformation": [])", "\"deformation\" must be an object"},
      {R"("deformation": {"keyframes": 3})", "\"deformation.keyframes\""},
  };
  for (const Case& c : cases) {
    const std::string m = sceneError(dir, scene(c.fields));
    EXPECT_NE(m.find("scene.json"), std::string::npos) << m;
    EXPECT_NE(m.find(c.want), std::string::npos) << "want " << c.want << " in: " << m;
  }
  const std::vector<Case> v3 = {
      {R"("render": {"zoom": 0})", "zoom"},
      {R"("render": {"zoom": "big"})", "zoom"},
      {R"("render": {"sparkle": 1})", "sparkle"},
      {R"("view": 5)", "view"},
      {R"("pan": [1])", "\"pan\""},
      {R"("pan": [1, 2, null])", "\"pan\""},
      {R"("illustration": {"enabled": "yes"})", "\"illustration.enabled\""},
      {R"("illustration": [])", "\"illustration\" must be an object"},
      {R"("camera_bookmarks": 3)", "\"camera_bookmarks\""},
      {R"("camera_bookmarks": [{"azimuth": 3}])", "\"camera_bookmarks\""},
      {R"("camera_bookmarks": [{"name": "a", "pan": [0, 0]}])", "\"camera_bookmarks.pan\""},
      {R"("crosshair": [1, 2, 3, 4])", "\"crosshair\""},
      {R"("deformation": {"keyframes": "k.json", "engine": []})", "k.json"},
  };
  for (const Case& c : v3) {
    const std::string m = sceneError(dir, scene(c.fields, 3));
    EXPECT_NE(m.find(c.want), std::string::npos) << "want " << c.want << " in: " << m;
  }
  for (const std::string& top : {std::string("[]"), std::string(R"({"format": "vellum-studio-scene", "version": "2"})"),
                                 std::string(R"({"format": "vellum-studio-scene", "version": 2, "volume": 1})"),
                                 std::string(R"({"format": 7})")})
    EXPECT_NE(sceneError(dir, top).find("scene.json"), std::string::npos) << top;
  // Huge array: more ids than labels exist.
  std::string ids = "[";
  for (int i = 0; i <= 65536; ++i) ids += std::string(i ? "," : "") + "1";
  EXPECT_NE(sceneError(dir, scene(R"("hidden_labels": )" + ids + "]")).find("\"hidden_labels\""), std::string::npos);
  // A damaged keyframe file beside the scene: the error names that file and its field.
  std::ofstream(dir / "track.json") << R"({"keyframes": [{"duration": 1e12, "points": [{"source": [0, 0, 0]}]}]})";
  const std::string m = sceneError(dir, scene(R"("deformation": {"keyframes": "track.json"})"));
  EXPECT_NE(m.find("track.json"), std::string::npos) << m;
  EXPECT_NE(m.find("keyframe 0: \"duration\""), std::string::npos) << m;
}

TEST(StudioSceneFile, EveryTruncationIsANamedError) {
  const fs::path dir = test::tempDir("studio-scene-cut");
  std::ofstream(dir / "ct.nrrd") << "placeholder";
  const std::string full = scene(R"("camera": {"azimuth": 30, "zoom": 1.5, "pan": [1, 2, 3]}, "slice_window": [40, 400],)"
                                 R"( "hidden_labels": [3, 7], "label_opacity": 0.5)");
  std::ofstream(dir / "full.json") << full;
  ASSERT_NO_THROW(readSceneFile(dir / "full.json"));
  for (size_t n = 0; n + 1 < full.size(); ++n) (void)sceneError(dir, full.substr(0, n));
}

TEST(StudioJsonReaders, DeepOrOversizeFilesAreRefusedWithoutParsing) {
  const fs::path dir = test::tempDir("studio-json-hostile");
  test::expectHostileJsonRefused(dir / "scene.json", 16u << 20, [&] { (void)readSceneFile(dir / "scene.json"); });
  test::expectHostileJsonRefused(dir / "script.json", 16u << 20, [&] { (void)ScriptRunner::load(dir / "script.json"); });
  test::expectHostileJsonRefused(dir / "shape.json", 16u << 20, [&] { (void)loadSegmentMeshes(dir, LabelVolume()); });
}
