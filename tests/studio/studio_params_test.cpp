// Issue 10 §4: the View panel's widgets and the scene file's view keys come from the parameter
// tables the CLI uses. Every table field round-trips through a scene file, every scene key is
// a `vellum render` flag, and view edits are undo steps.
#include <array>
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>

#include "scene_file.hpp"
#include "test_data.hpp"
#include "undo.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/params.hpp"
#include "vellum/deformation/deform_params.hpp"
#include "vellum/io/volume_io.hpp"
#include "vellum/phantom/phantom.hpp"

using namespace vellum;
using namespace vellum::studio;
namespace fs = std::filesystem;

namespace {

/// A value of `f` different from its current one and inside its range.
template <class S>
void setOtherValue(const params::Field<S>& f, S& s) {
  if (f.kind == params::Kind::Vector) {  // three numbers: each moved inside its range
    std::array<double, 3> x = f.getVector(s);
    for (double& c : x) c = std::isfinite(f.info.min) && std::isfinite(f.info.max) ? f.info.min + 0.37 * (f.info.max - f.info.min) : c + 1.5;
    f.setVector(s, x);
    return;
  }
  const double v = f.get(s).value_or(0);
  switch (f.kind) {
    case params::Kind::Flag: f.set(s, v != 0 ? 0.0 : 1.0); return;
    case params::Kind::Choice: f.set(s, std::fmod(v + 1, double(f.choices.size()))); return;
    default: break;
  }
  double other = std::isfinite(f.info.min) && std::isfinite(f.info.max) ? f.info.min + 0.37 * (f.info.max - f.info.min)
                                                                         : v + 1.5;
  if (f.kind == params::Kind::Integer) other = std::round(other);
  if (other == v) other = std::isfinite(f.info.max) ? f.info.max : v + 1;
  f.set(s, other);
}

fs::path sceneWithData(const fs::path& dir) {
  phantom::PhantomOptions o;
  o.dims = {16, 16, 16};
  io::saveVolume(AnyVolume(phantom::makePhantom(o).ct), dir / "ct.nrrd");
  return dir / "ct.nrrd";
}

nlohmann::json readJson(const fs::path& p) { return nlohmann::json::parse(std::ifstream(p)); }

template <class S>
std::set<std::string> keysOf(const params::Table<S>& t, const std::vector<std::string>& skip = {}) {
  std::set<std::string> keys;
  for (const auto& f : t)
    if (std::find(skip.begin(), skip.end(), f.key) == skip.end()) keys.insert(f.key);
  return keys;
}

std::set<std::string> objectKeys(const nlohmann::json& j) {
  std::set<std::string> keys;
  for (auto it = j.begin(); it != j.end(); ++it) keys.insert(it.key());
  return keys;
}

}  // namespace

TEST(StudioParams, SceneViewKeysAreTheTablesKeys) {
  const auto dir = test::tempDir("studio-params-keys");
  SceneFile s;
  s.volume = sceneWithData(dir);
  writeSceneFile(s, dir / "scene.json");
  const auto j = readJson(dir / "scene.json");
  EXPECT_EQ(objectKeys(j.at("view")), keysOf(viewSettingsTable()));
  EXPECT_EQ(objectKeys(j.at("render")), keysOf(render::renderSettingsTable(), renderKeysNotInScene()));
}

TEST(StudioParams, EveryTableFieldRoundTripsThroughTheSceneFile) {
  const auto dir = test::tempDir("studio-params-roundtrip");
  const fs::path ct = sceneWithData(dir);
  const auto check = [&](const auto& table, auto member, const std::vector<std::string>& skip) {
    for (const auto& f : table) {
      if (std::find(skip.begin(), skip.end(), f.key) != skip.end()) continue;
      SCOPED_TRACE(f.key);
      SceneFile s;
      s.volume = ct;
      setOtherValue(f, member(s.view));
      const std::string written = params::format(f, member(s.view));
      ViewState defaults;
      EXPECT_NE(written, params::format(f, member(defaults))) << "the test must change the value";
      writeSceneFile(s, dir / "scene.json");
      SceneFile r = readSceneFile(dir / "scene.json");
      EXPECT_EQ(params::format(f, member(r.view)), written);
      EXPECT_TRUE(r.view == s.view);
    }
  };
  check(viewSettingsTable(), [](ViewState& v) -> ViewSettings& { return v.view; }, {});
  check(render::renderSettingsTable(), [](ViewState& v) -> render::RenderSettings& { return v.render; },
        renderKeysNotInScene());
}

TEST(StudioParams, EverySceneRenderKeyIsAVellumRenderFlag) {
  // The scene's "render" keys and `vellum render`'s flags are the same table's: --KEY.
  const auto dir = test::tempDir("studio-params-cli");
  const std::string cmd = std::string(VELLUM_CLI_EXE) + " render --help > " + (dir / "help.txt").string() + " 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  std::ifstream in(dir / "help.txt");
  const std::string help((std::istreambuf_iterator<char>(in)), {});
  const auto hasFlag = [&](const std::string& flag) {  // "--shading{true}=true", "--zoom NUMBER"
    for (size_t at = help.find(flag); at != std::string::npos; at = help.find(flag, at + 1)) {
      const char next = at + flag.size() < help.size() ? help[at + flag.size()] : ' ';
      if (next == ' ' || next == '{' || next == '=') return true;
    }
    return false;
  };
  for (const auto& key : keysOf(render::renderSettingsTable(), renderKeysNotInScene()))
    EXPECT_TRUE(hasFlag(params::cliFlag(key))) << key << "\n" << help;
}

TEST(StudioParams, VersionTwoScenesStillOpen) {
  const auto dir = test::tempDir("studio-params-v2");
  sceneWithData(dir);
  std::ofstream(dir / "v2.json") << R"({"format":"vellum-studio-scene","version":2,"volume":"ct.nrrd",
    "layout":"1x3","preset":"bone","camera":{"azimuth":75,"elevation":-20,"zoom":2,"fov":0,"pan":[1,2,3]},
    "slice_window":[300,1500],"render_window":[500,1200],"label_opacity":0.25})";
  const SceneFile r = readSceneFile(dir / "v2.json");
  EXPECT_EQ(r.view.view.layout, Layout::OneByThree);
  EXPECT_EQ(r.view.view.sliceWindow, (WindowLevel{300, 1500}));
  EXPECT_FLOAT_EQ(r.view.view.labelOpacity, 0.25f);
  EXPECT_EQ(r.view.render.preset, render::Preset::Bone);
  EXPECT_EQ(r.view.render.camera.azimuthDeg, 75);
  EXPECT_EQ(r.view.render.camera.elevationDeg, -20);
  EXPECT_EQ(r.view.render.camera.fieldOfViewDeg, 0);
  EXPECT_EQ(r.view.render.camera.panMm, (Vec3{1, 2, 3}));
  EXPECT_EQ(r.view.render.windowCenter, 500);
  EXPECT_EQ(r.view.render.windowWidth, 1200);
}

TEST(StudioParams, BadViewValuesNameTheSceneAndTheKey) {
  const auto dir = test::tempDir("studio-params-bad");
  sceneWithData(dir);
  struct Case { const char* json; const char* needle; };
  for (const Case& c : {Case{R"("render":{"zom":2})", "render: unknown parameter 'zom'"},
                        Case{R"("render":{"elevation":120})", "elevation"},
                        Case{R"("render":{"preset":"chrome"})", "chrome"},
                        Case{R"("view":{"label_opacity":"lots"})", "label_opacity: wrong type"},
                        Case{R"("camera_bookmarks":[{"name":"a","zoom":-1}])", "zoom"}}) {
    SCOPED_TRACE(c.json);
    std::ofstream(dir / "bad.json") << R"({"format":"vellum-studio-scene","version":3,"volume":"ct.nrrd",)" << c.json << "}";
    try {
      readSceneFile(dir / "bad.json");
      ADD_FAILURE() << "accepted";
    } catch (const FileError& e) {
      const std::string m = e.what();
      EXPECT_NE(m.find("bad.json"), std::string::npos) << m;
      EXPECT_NE(m.find(c.needle), std::string::npos) << m;
    }
  }
}

TEST(StudioParams, CameraBookmarksRoundTrip) {
  const auto dir = test::tempDir("studio-params-bookmarks");
  SceneFile s;
  s.volume = sceneWithData(dir);
  render::Camera lateral;
  lateral.azimuthDeg = 90;
  lateral.zoom = 1.5;
  lateral.panMm = {0, -4, 2};
  s.view.bookmarks = {{"lateral", lateral}, {"front", render::Camera{}}};
  writeSceneFile(s, dir / "scene.json");
  const SceneFile r = readSceneFile(dir / "scene.json");
  ASSERT_EQ(r.view.bookmarks.size(), 2u);
  EXPECT_EQ(r.view.bookmarks[0].name, "lateral");
  EXPECT_EQ(r.view.bookmarks[0].camera.azimuthDeg, 90);
  EXPECT_EQ(r.view.bookmarks[0].camera.zoom, 1.5);
  EXPECT_EQ(r.view.bookmarks[0].camera.panMm, (Vec3{0, -4, 2}));
  EXPECT_TRUE(r.view == s.view);
}

TEST(StudioParams, ViewEditsAreUndoSteps) {
  UndoStack undo;
  LabelVolume labels;
  ViewState before, after = before;
  after.render.preset = render::Preset::Mip;
  after.render.shading = false;
  after.view.sliceWindow = {80, 300};
  after.bookmarks.push_back({"top", render::Camera{}});
  undo.push(ViewEdit{"view", before, after});
  undo.push(ViewEdit{"nothing", after, after});  // no change: no step
  ASSERT_EQ(undo.undoEntries().size(), 1u);
  ViewState now = after;
  ASSERT_TRUE(undo.undo(labels, nullptr, &now));
  EXPECT_TRUE(undo.lastWasView());
  EXPECT_TRUE(now == before);
  ASSERT_TRUE(undo.redo(labels, nullptr, &now));
  EXPECT_TRUE(now == after);
  EXPECT_THROW(undo.undo(labels, nullptr, nullptr), Error) << "a view edit needs the view state";
}

TEST(StudioParams, EngineParametersRoundTripAndUndo) {
  const auto dir = test::tempDir("studio-params-engine");
  SceneFile s;
  s.volume = sceneWithData(dir);
  SceneDeformation d;
  d.track.keyframes.push_back({1.0, {{{0, 0, 0}, {1, 0, 0}, {}}}});
  d.engine.controlScale = 2;
  d.engine.mls.power = 2.5;
  d.engine.density.enabled = false;
  s.deformation = d;
  writeSceneFile(s, dir / "scene.json");
  EXPECT_EQ(readJson(dir / "scene.json")["deformation"]["engine"].size(), deformation::deformParamsTable().size());
  const SceneFile r = readSceneFile(dir / "scene.json");
  ASSERT_TRUE(r.deformation);
  EXPECT_EQ(params::cliArguments(deformation::deformParamsTable(), r.deformation->engine),
            params::cliArguments(deformation::deformParamsTable(), d.engine));

  // An engine edit is a track-edit undo step that leaves the track alone.
  UndoStack undo;
  LabelVolume labels;
  Authoring a;
  a.track = d.track;
  TrackEdit e;
  e.before = e.after = a.track;
  e.engineBefore = a.engine;  // the studio's default: s = 4, density-aware
  a.engine.controlScale = 8;
  e.engineAfter = a.engine;
  undo.push(e);
  ASSERT_TRUE(undo.undo(labels, &a));
  EXPECT_EQ(a.engine.controlScale, 4);
  EXPECT_TRUE(a.engine.density.enabled);
  ASSERT_TRUE(undo.redo(labels, &a));
  EXPECT_EQ(a.engine.controlScale, 8);
  EXPECT_EQ(a.track.keyframes.size(), 1u);
}
