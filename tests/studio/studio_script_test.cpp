// vellum-studio end to end: scripts drive the real window (under the X server the test runs
// in; CI: xvfb-run -a ctest) through the same input handlers as a user.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "image_compare.hpp"
#include "label_tools.hpp"
#include "layout.hpp"
#include "scene_file.hpp"
#include "studio_run.hpp"
#include "test_data.hpp"
#include "view3d.hpp"
#include "vellum/io/image_io.hpp"
#include "vellum/io/volume_io.hpp"
#include "vellum/phantom/phantom.hpp"
#include "vellum/illustration/curve_analogy.hpp"
#include "vellum/illustration/shape.hpp"
#include "vellum/render/projection.hpp"
#include "vellum/render/volume_renderer.hpp"

namespace vellum::studio {
namespace {
namespace fs = std::filesystem;

#define REQUIRE_DISPLAY()                                                        \
  do {                                                                           \
    if (!std::getenv("DISPLAY")) GTEST_SKIP() << "no DISPLAY (run under xvfb-run -a)"; \
  } while (0)

using vellum::test::studio::q;
using vellum::test::studio::runStudio;
using vellum::test::studio::StudioRun;

/// A small phantom CT and its label map in `dir`.
void writePhantom(const fs::path& dir) { vellum::test::studio::writePhantom(dir, 64); }


TEST(StudioScript, ThresholdUndoRedoSceneReopenAndCliRender) {
  REQUIRE_DISPLAY();
  const fs::path d = test::tempDir("studio-e2e");
  writePhantom(d);
  // Layouts, bone threshold into a fresh label map, undo / redo saved at every stage, the
  // scene saved, then window and 3D screenshots.
  const std::string s1 = R"({"actions":[
    {"open":)" + q(d / "ct.nrrd") + R"(},
    {"layout":"3d"},{"layout":"1x3"},{"layout":"2x2"},{"preset":"bone"},{"hud":false},
    {"save_labels":)" + q(d / "l0.nrrd") + R"(},
    {"threshold":{"preset":"bone","label":1}},
    {"save_labels":)" + q(d / "l1.nrrd") + R"(},
    {"key":"ctrl+z"},
    {"save_labels":)" + q(d / "l2.nrrd") + R"(},
    {"key":"ctrl+shift+z"},
    {"save_labels":)" + q(d / "l3.nrrd") + R"(},
    {"tool":"paint"},{"active_label":2},{"brush_radius":6},
    {"drag":{"from":[480,170],"to":[540,190],"button":"left"}},
    {"save_labels":)" + q(d / "l4.nrrd") + R"(},
    {"key":"ctrl+z"},{"tool":"navigate"},{"active_label":1},{"brush_radius":4},
    {"save_labels":)" + q(d / "l5.nrrd") + R"(},
    {"drag":{"from":[850,500],"to":[900,520],"button":"left"}},
    {"click":[500,170]},
    {"save_scene":)" + q(d / "scene.json") + R"(},
    {"screenshot":)" + q(d / "win1.png") + R"(},
    {"screenshot":{"path":)" + q(d / "view1.png") + R"(,"view":"3d"}},
    {"export_command":{"path":)" + q(d / "render.sh") + R"(,"figure":)" + q(d / "cli.png") + R"(}},
    {"quit":0}]})";
  const StudioRun r1 = runStudio(d, "first", s1);
  ASSERT_EQ(r1.exitCode, 0) << r1.output;

  const auto l0 = io::loadLabels(d / "l0.nrrd"), l1 = io::loadLabels(d / "l1.nrrd"),
             l2 = io::loadLabels(d / "l2.nrrd"), l3 = io::loadLabels(d / "l3.nrrd");
  EXPECT_EQ(l0.histogram().size(), 1u);  // nothing labelled yet
  ASSERT_GE(l1.histogram().size(), 2u);
  EXPECT_GT(l1.histogram()[1], 500u);
  EXPECT_EQ(l2.ids().voxels(), l0.ids().voxels()) << "undo restores the label map";
  EXPECT_EQ(l3.ids().voxels(), l1.ids().voxels()) << "redo restores the threshold";
  EXPECT_EQ(l3.table(), l1.table());
  // A brush stroke dragged over the axial slice paints label 2; Ctrl+Z takes the whole stroke back.
  const auto l4 = io::loadLabels(d / "l4.nrrd"), l5 = io::loadLabels(d / "l5.nrrd");
  ASSERT_GE(l4.histogram().size(), 3u);
  EXPECT_GT(l4.histogram()[2], 20u);
  EXPECT_EQ(l5.ids().voxels(), l3.ids().voxels());

  // The scene references the volume relatively and the saved label map.
  const SceneFile sf = readSceneFile(d / "scene.json");
  EXPECT_EQ(sf.volume, (d / "ct.nrrd").lexically_normal());
  ASSERT_FALSE(sf.labels.empty());
  EXPECT_EQ(io::loadLabels(sf.labels).ids().voxels(), l1.ids().voxels());
  EXPECT_EQ(sf.view.render.preset, render::Preset::Bone);
  EXPECT_NE(sf.view.render.camera.azimuthDeg, render::Camera{}.azimuthDeg) << "the drag rotated the camera";

  // Reopening the scene gives the same pixels. The same click as before (on the crosshair it
  // set, so nothing moves) gives ImGui the same focus and hover state.
  const std::string s2 = R"({"actions":[{"hud":false},{"click":[500,170]},{"wait_idle":true},
    {"screenshot":)" + q(d / "win2.png") + R"(},
    {"screenshot":{"path":)" + q(d / "view2.png") + R"(,"view":"3d"}},{"quit":0}]})";
  const StudioRun r2 = runStudio(d, "second", s2, q(d / "scene.json"));
  ASSERT_EQ(r2.exitCode, 0) << r2.output;
  const RgbaImage w1 = io::loadImage(d / "win1.png"), w2 = io::loadImage(d / "win2.png");
  ASSERT_EQ(w1.width, 1024);
  ASSERT_EQ(w1.height, 700);
  // Tool state (tool, active label, brush) is not part of a scene: the script resets it above.
  EXPECT_TRUE(w1.pixels == w2.pixels) << "window screenshots differ after reopening the scene: "
                                      << test::compareImages(w1, w2).maxAbs << " max difference";
  const RgbaImage v1 = io::loadImage(d / "view1.png"), v2 = io::loadImage(d / "view2.png");
  EXPECT_EQ(v1.pixels, v2.pixels);

  // The 3D view is what the CLI renderer gives for the same camera and preset.
  auto context = render::GlContext::createHeadless();
  render::VolumeRenderer renderer(*context);
  renderer.setVolume(io::loadVolume(d / "ct.nrrd").volume);
  Scene scene;
  applySceneView(sf, scene);
  const RgbaImage cli = renderer.render(renderSettingsFor(scene, v1.width, v1.height));
  const auto diff = test::compareImages(v1, cli);
  EXPECT_GE(diff.psnr, 40.0) << "studio 3D view vs VolumeRenderer";

  // ... and what the exported `vellum render` command writes.
  std::ifstream cmdFile(d / "render.sh");
  std::string cmd;
  std::getline(cmdFile, cmd);
  ASSERT_EQ(cmd.rfind("vellum render ", 0), 0u) << cmd;
  // Appended piecewise: GCC 12 warns falsely (-Wrestrict) on one long chain of + here.
  std::string run = "\"";
  run += VELLUM_CLI_EXE;
  run += "\"";
  run += cmd.substr(6);
  run += " > \"" + (d / "cli.log").string() + "\" 2>&1";
  cmd = run;
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  const auto cliDiff = test::compareImages(v1, io::loadImage(d / "cli.png"));
  EXPECT_GE(cliDiff.psnr, 40.0) << "studio 3D view vs `vellum render`: " << cmd;
}

TEST(StudioScript, SnakeFromAClickedSeedIsOneUndoStep) {
  REQUIRE_DISPLAY();
  const fs::path d = test::tempDir("studio-snake");
  writePhantom(d);
  // Soft tissue (the range is the snake's inside) from a seed clicked in the axial slice's
  // muscle, lateral of the knee; waits for the worker, then Ctrl+Z.
  const StudioRun r = runStudio(d, "snake", R"({"actions":[{"open":)" + q(d / "ct.nrrd") + R"(},
      {"threshold":{"preset":"soft-tissue","label":5,"apply":false}},{"tool":"snake"},
      {"click":[430,175]},{"wait_idle":true},{"save_labels":)" + q(d / "s1.nrrd") + R"(},
      {"key":"ctrl+z"},{"save_labels":)" + q(d / "s2.nrrd") + R"(},{"quit":0}]})");
  ASSERT_EQ(r.exitCode, 0) << r.output;
  EXPECT_NE(r.output.find("snake: "), std::string::npos) << r.output;
  const auto h1 = io::loadLabels(d / "s1.nrrd").histogram();
  ASSERT_GE(h1.size(), 6u) << r.output;
  EXPECT_GT(h1[5], 5000u) << "the snake filled the soft tissue of the leg";
  EXPECT_EQ(io::loadLabels(d / "s2.nrrd").histogram().size(), 1u) << "undo removed it";
}

TEST(StudioScript, CtrlClickIn3dMovesTheCrosshairToTheVisibleSurface) {
  REQUIRE_DISPLAY();
  const fs::path d = test::tempDir("studio-pick");
  writePhantom(d);
  // 2x2 at 1024x700: the 3D pane is the bottom-right quarter (678..1024 x 351..700); a
  // point above its centre shows the femur.
  const StudioRun r = runStudio(d, "pick", R"({"actions":[{"open":)" + q(d / "ct.nrrd") + R"(},
      {"preset":"bone"},{"click":{"at":[851,455],"mods":["ctrl"]}},
      {"save_scene":)" + q(d / "pick.json") + R"(},{"quit":0}]})");
  ASSERT_EQ(r.exitCode, 0) << r.output;
  const SceneFile sf = readSceneFile(d / "pick.json");
  const VolumeI16 ct = toInt16(io::loadVolume(d / "ct.nrrd").volume);
  EXPECT_GT(sf.crosshairMm.z, 15.0) << "the crosshair moved up to the femur";
  // Half opacity of the bone preset is reached just inside the bone's surface.
  EXPECT_GT(ct.sampleLinearMm(sf.crosshairMm), 200.0)
      << sf.crosshairMm.x << " " << sf.crosshairMm.y << " " << sf.crosshairMm.z;
}

TEST(StudioScript, BadFileLeavesSceneAndFailuresNameTheAction) {
  REQUIRE_DISPLAY();
  const fs::path d = test::tempDir("studio-bad");
  writePhantom(d);
  std::ofstream(d / "broken.nrrd") << "NRRD0004\ntype: short\ndimension: 3\nsizes: 10 10\n\n";
  const StudioRun ok = runStudio(d, "expect", R"({"actions":[{"open":)" + q(d / "ct.nrrd") + R"(},
      {"open":{"path":)" + q(d / "broken.nrrd") + R"(,"expect_error":true}},
      {"save_labels":)" + q(d / "still.nrrd") + R"(},{"quit":0}]})");
  EXPECT_EQ(ok.exitCode, 0) << ok.output;
  EXPECT_NE(ok.output.find("broken.nrrd"), std::string::npos) << ok.output;
  EXPECT_TRUE(fs::exists(d / "still.nrrd")) << "the first volume stayed open";

  const StudioRun missing = runStudio(d, "missing", R"({"actions":[{"frames":1},{"open":)" + q(d / "nope.nrrd") + R"(}]})");
  EXPECT_NE(missing.exitCode, 0);
  EXPECT_NE(missing.output.find("script action #1 (open)"), std::string::npos) << missing.output;

  const StudioRun unknown = runStudio(d, "unknown", R"({"actions":[{"frames":1},{"fly":true}]})");
  EXPECT_NE(unknown.exitCode, 0);
  EXPECT_NE(unknown.output.find("script action #1"), std::string::npos) << unknown.output;
  EXPECT_NE(unknown.output.find("fly"), std::string::npos) << unknown.output;

  const StudioRun badScene = runStudio(d, "badscene", R"({"actions":[{"open":)" + q(d / "gone.json") + R"(}]})");
  EXPECT_NE(badScene.exitCode, 0);
  EXPECT_NE(badScene.output.find("gone.json"), std::string::npos) << badScene.output;
}

}  // namespace
// Issue 10 §3-4: view settings set by their table keys and camera bookmarks are undo steps;
// the scene file keeps them under the tables' keys.
TEST(StudioScript, ViewSettingsAndBookmarksUndoRedoAndSave) {
  REQUIRE_DISPLAY();
  const auto dir = test::tempDir("studio-view-undo");
  writePhantom(dir);
  const std::string script = R"({"actions":[{"open":)" + q(dir / "ct.nrrd") + R"(},
    {"set":{"preset":"bone","shading":false,"slice_window_width":900}},
    {"camera":{"azimuth":90}},{"bookmark":{"add":"lateral"}},{"camera":{"azimuth":10}},{"bookmark":{"go":"lateral"}},
    {"save_scene":)" + q(dir / "a.json") + R"(},
    {"key":"ctrl+z"},{"save_scene":)" + q(dir / "b.json") + R"(},
    {"key":"ctrl+z"},{"key":"ctrl+z"},{"save_scene":)" + q(dir / "c.json") + R"(},
    {"key":"ctrl+shift+z"},{"save_scene":)" + q(dir / "d.json") + R"(},{"quit":0}]})";
  const StudioRun r = runStudio(dir, "view", script);
  ASSERT_EQ(r.exitCode, 0) << r.output;
  const SceneFile a = readSceneFile(dir / "a.json"), b = readSceneFile(dir / "b.json"),
                  c = readSceneFile(dir / "c.json"), d = readSceneFile(dir / "d.json");
  EXPECT_EQ(a.view.render.preset, render::Preset::Bone);
  EXPECT_FALSE(a.view.render.shading);
  EXPECT_EQ(a.view.view.sliceWindow.width, 900);
  ASSERT_EQ(a.view.bookmarks.size(), 1u);
  EXPECT_EQ(a.view.bookmarks[0].camera.azimuthDeg, 90);
  EXPECT_EQ(a.view.render.camera.azimuthDeg, 90) << "went to the bookmark";
  EXPECT_EQ(b.view.render.camera.azimuthDeg, 10) << "undo: back from the bookmark";
  EXPECT_EQ(c.view.bookmarks.size(), 0u) << "undo: the bookmark is gone";
  EXPECT_EQ(c.view.view.sliceWindow.width, 400) << "undo: the slice window is back";
  EXPECT_FALSE(c.view.render.shading) << "shading was an earlier step";
  EXPECT_EQ(d.view.view.sliceWindow.width, 900) << "redo";
  EXPECT_EQ(d.view.bookmarks.size(), 0u);
}

/// Runs `vellum ARGS`, output to DIR/NAME.log; the exit code.
int runCli(const fs::path& dir, const std::string& name, const std::string& args) {
  std::string cmd = "\"";
  cmd += VELLUM_CLI_EXE;
  cmd += "\" " + args + " > \"" + (dir / (name + ".log")).string() + "\" 2>&1";
  return std::system(cmd.c_str());
}

// Issue 10 §2: the 3D view as a shape-aware illustration is what `vellum illustrate` draws
// for the same shape folder, style and camera; style edits are undo steps and live in the scene.
TEST(StudioScript, IllustrationMatchesVellumIllustrateAndStyleEditsUndo) {
  REQUIRE_DISPLAY();
  const auto dir = test::tempDir("studio-illustration");
  writePhantom(dir);
  const std::string ct = (dir / "ct.nrrd").string();
  ASSERT_EQ(runCli(dir, "shape", "shape \"" + ct + "\" --labels \"" + (dir / "labels.nrrd").string() +
                                     "\" --segment skin=1 --segment muscle=3 --segment femur=4,5 --segment tibia=6,7 --out \"" +
                                     (dir / "shape").string() + "\""),
            0);
  ASSERT_EQ(runCli(dir, "illustrate", "illustrate \"" + ct + "\" --shape \"" + (dir / "shape").string() +
                                          "\" --preset textbook --size 200x200 --frame volume --out \"" + (dir / "cli.png").string() + "\""),
            0);
  const std::string script = R"({"actions":[{"open":)" + q(dir / "ct.nrrd") + R"(},{"layout":"3d"},
    {"shapes":)" + q(dir / "shape") + R"(},{"style":"textbook"},{"illustrate":true},
    {"screenshot":{"path":)" + q(dir / "studio.png") + R"(,"view":"3d","size":[200,200]}},
    {"style_set":{"segment":"femur","colour":[1,0,0],"opacity":0.9}},{"save_scene":)" + q(dir / "a.json") + R"(},
    {"key":"ctrl+z"},{"key":"ctrl+z"},{"save_scene":)" + q(dir / "b.json") + R"(},{"quit":0}]})";
  const StudioRun r = runStudio(dir, "illustration", script);
  ASSERT_EQ(r.exitCode, 0) << r.output;
  // The studio's 3D view frames the volume (its orbit camera): `--frame volume` on the CLI.
  const auto diff = test::compareImages(io::loadImage(dir / "studio.png"), io::loadImage(dir / "cli.png"));
  EXPECT_GE(diff.psnr, 40.0) << "studio illustration vs `vellum illustrate --frame volume`";

  const SceneFile a = readSceneFile(dir / "a.json"), b = readSceneFile(dir / "b.json");
  EXPECT_EQ(a.shapes, (dir / "shape").lexically_normal());
  EXPECT_TRUE(a.view.illustration.enabled);
  const auto femurRow = [](const illustration::Style& s) -> const illustration::SegmentStyle* {
    for (const auto& row : s.segments)
      if (row.match == "femur") return &row;
    return nullptr;
  };
  const auto* red = femurRow(a.view.illustration.style);
  ASSERT_NE(red, nullptr) << "the edit gave femur its own row";
  EXPECT_EQ(red->colour, (illustration::Rgb{1.f, 0.f, 0.f}));
  EXPECT_FLOAT_EQ(red->opacity, 0.9f);
  EXPECT_TRUE(b.view.illustration.style == illustration::stylePreset("textbook")) << "two undos: back to the preset";
  EXPECT_TRUE(b.view.illustration.enabled);
}

}  // namespace vellum::studio

namespace vellum::studio {
namespace {

// Issue 10 §1: the shape folder's meshes in the 3D view's depth buffer. With "meshes_3d" on,
// where the (recoloured blue) femur mesh projects the view turns blue under the translucent
// soft tissue; far from every mesh the
// pixels are exactly the meshes-off view's (which is `vellum render`'s); the key is saved.
TEST(StudioScript, MeshesInThe3dViewShareItsDepth) {
  REQUIRE_DISPLAY();
  const auto dir = test::tempDir("studio-meshes");
  writePhantom(dir);
  ASSERT_EQ(runCli(dir, "shape", "shape \"" + (dir / "ct.nrrd").string() + "\" --labels \"" + (dir / "labels.nrrd").string() +
                                     "\" --segment femur=4,5 --segment tibia=6,7 --out \"" + (dir / "shape").string() + "\""),
            0);
  // The femur's colour (segments.nrrd's table) made pure blue: no tissue or bone colour is.
  LabelVolume segments = io::loadLabels(dir / "shape" / "segments.nrrd");
  for (Label l : segments.table())
    if (l.name == "femur") l.rgb = {0, 0, 255}, segments.setLabel(l);
  io::saveLabels(segments, dir / "shape" / "segments.nrrd");
  const std::string script = R"({"actions":[{"open":)" + q(dir / "ct.nrrd") + R"(},{"layout":"3d"},
    {"shapes":)" + q(dir / "shape") + R"(},{"illustrate":false},{"preset":"soft-tissue"},{"set":{"meshes_3d":true}},
    {"screenshot":{"path":)" + q(dir / "on.png") + R"(,"view":"3d","size":[200,200]}},{"save_scene":)" + q(dir / "on.json") + R"(},
    {"set":{"meshes_3d":false}},
    {"screenshot":{"path":)" + q(dir / "off.png") + R"(,"view":"3d","size":[200,200]}},{"quit":0}]})";
  const StudioRun r = runStudio(dir, "meshes", script);
  ASSERT_EQ(r.exitCode, 0) << r.output;
  const SceneFile sf = readSceneFile(dir / "on.json");
  EXPECT_TRUE(sf.view.view.meshesIn3d);
  const RgbaImage on = io::loadImage(dir / "on.png"), off = io::loadImage(dir / "off.png");
  ASSERT_EQ(on.width, 200);
  ASSERT_EQ(off.width, 200);

  // Where the meshes project (every vertex, widened by 6 px): the femur's pixels and the rest.
  Scene scene;
  applySceneView(sf, scene);
  const render::Projection cam(geometryOf(io::loadVolume(dir / "ct.nrrd").volume), renderSettingsFor(scene, 200, 200));
  std::vector<uint8_t> femur(200 * 200, 0), nearMesh(200 * 200, 0);
  for (const char* name : {"femur", "tibia"})
    for (const auto& v : illustration::loadMesh(dir / "shape" / "meshes" / (std::string(name) + ".ply")).vertices) {
      const auto p = cam.toPixel({v[0], v[1], v[2]});
      ASSERT_TRUE(p.has_value());
      const int x = int(std::lround(p->x)), y = int(std::lround(p->y));
      for (int dy = -6; dy <= 6; ++dy)
        for (int dx = -6; dx <= 6; ++dx)
          if (x + dx >= 0 && x + dx < 200 && y + dy >= 0 && y + dy < 200) nearMesh[size_t((y + dy) * 200 + x + dx)] = 1;
      if (std::string(name) == "femur" && x >= 0 && x < 200 && y >= 0 && y < 200) femur[size_t(y * 200 + x)] = 1;
    }
  double blueOn = 0, blueOff = 0;
  int femurPixels = 0, farPixels = 0, farDiffer = 0;
  for (int i = 0; i < 200 * 200; ++i) {
    const uint8_t *a = on.pixels.data() + 4 * i, *b = off.pixels.data() + 4 * i;
    if (femur[size_t(i)]) {
      blueOn += a[2] - 0.5 * (a[0] + a[1]);
      blueOff += b[2] - 0.5 * (b[0] + b[1]);
      ++femurPixels;
    }
    if (!nearMesh[size_t(i)]) farDiffer += !std::equal(a, a + 4, b), ++farPixels;
  }
  ASSERT_GT(femurPixels, 200);
  blueOn /= femurPixels, blueOff /= femurPixels;
  std::cout << "[ mesh ] femur pixels " << femurPixels << ": blue excess on " << blueOn << ", off " << blueOff << "; far pixels "
            << farPixels << ", differing " << farDiffer << "\n";
  EXPECT_GT(blueOn, blueOff + 40) << "the blue femur mesh shows where it projects";
  EXPECT_GT(farPixels, 20000);
  EXPECT_EQ(farDiffer, 0) << "far from the meshes the view is the meshes-off one";
}

// Issue 10 §2: curve analogy by drawing. C0 is traced with the mouse over the 3D view (the
// skin's projected outline, widened); Apply bends the skin (carrying the bone) into a new shape
// folder that becomes the scene's shapes; undo and redo swap the folders; the result is what
// `vellum curve-analogy` makes from the same C0, view and segments.
TEST(StudioScript, CurveAnalogyByTracingMatchesTheCliAndUndoes) {
  REQUIRE_DISPLAY();
  const auto dir = test::tempDir("studio-curve");
  writePhantom(dir);
  ASSERT_EQ(runCli(dir, "shape", "shape \"" + (dir / "ct.nrrd").string() + "\" --labels \"" + (dir / "labels.nrrd").string() +
                                     "\" --segment skin=1,2,3,4,5,6,7,8,9,10,11 --segment bone=4,5,6,7,8,9,11 --out \"" +
                                     (dir / "shape").string() + "\""),
            0);
  const std::string opening = R"({"open":{"path":)" + q(dir / "ct.nrrd") + R"(,"labels":)" + q(dir / "labels.nrrd") +
                              R"(}},{"layout":"3d"},{"shapes":)" + q(dir / "shape") + R"(},)";
  // The camera the studio opens with (saved), in the plate view Trace switches to.
  StudioRun r = runStudio(dir, "camera", "{\"actions\":[" + opening + R"({"save_scene":)" + q(dir / "s0.json") + R"(},{"quit":0}]})");
  ASSERT_EQ(r.exitCode, 0) << r.output;
  Scene scene;
  applySceneView(readSceneFile(dir / "s0.json"), scene);
  const Pane pane = layoutPanes(Layout::ThreeD, {kToolPanelWidth, 0, 1024 - kToolPanelWidth, 700}).front();
  const int w = int(pane.rect.w), h = int(pane.rect.h);
  render::RenderSettings view = renderSettingsFor(scene, w, h);
  view.camera.fieldOfViewDeg = 0;
  view.camera.zoom = 1;
  view.camera.panMm = {0, 0, 0};
  const Geometry grid = geometryOf(io::loadVolume(dir / "ct.nrrd").volume);
  const illustration::Polyline2 outline =
      illustration::projectedOutline(illustration::loadMesh(dir / "shape" / "meshes" / "skin.ply"), render::Projection(grid, view));
  ASSERT_GT(outline.size(), 20u);
  // C0: the outline 8 % wider about its centre (a fuller leg), every few points, whole pixels.
  double cx = 0;
  for (const auto& p : outline) cx += p.x / double(outline.size());
  illustration::Polyline2 c0;
  std::string trace;
  for (size_t i = 0; i < outline.size(); i += std::max<size_t>(1, outline.size() / 60)) {
    const illustration::Point2 p{std::round(cx + 1.08 * (outline[i].x - cx)), std::round(outline[i].y)};
    if (!c0.empty() && p.x == c0.back().x && p.y == c0.back().y) continue;
    c0.push_back(p);
    trace += (trace.empty() ? "[" : ",[") + std::to_string(pane.rect.x + p.x) + "," + std::to_string(pane.rect.y + p.y) + "]";
  }
  const std::string script = "{\"actions\":[" + opening + R"({"curve_analogy":{"segment":"skin","transfer":["bone"],"trace":[)" +
                             trace + R"(]}},{"save_scene":)" + q(dir / "a.json") + R"(},
    {"key":"ctrl+z"},{"wait_idle":true},{"save_scene":)" + q(dir / "b.json") + R"(},
    {"key":"ctrl+shift+z"},{"wait_idle":true},{"save_scene":)" + q(dir / "c.json") + R"(},{"quit":0}]})";
  r = runStudio(dir, "curve", script);
  ASSERT_EQ(r.exitCode, 0) << r.output;
  const fs::path bent = dir / "shape-curve-1";
  EXPECT_EQ(fs::weakly_canonical(readSceneFile(dir / "a.json").shapes), fs::weakly_canonical(bent));
  EXPECT_EQ(fs::weakly_canonical(readSceneFile(dir / "b.json").shapes), fs::weakly_canonical(dir / "shape"));
  EXPECT_EQ(fs::weakly_canonical(readSceneFile(dir / "c.json").shapes), fs::weakly_canonical(bent));
  const nlohmann::json studio = nlohmann::json::parse(std::ifstream(bent / "shape.json"))["curve_analogy"];
  EXPECT_EQ(studio["c0"], "studio trace");
  EXPECT_EQ(studio["moved"], nlohmann::json({"skin", "bone"}));
  EXPECT_LT(studio["hausdorff_after_px"].get<double>(), studio["hausdorff_before_px"].get<double>());
  std::cout << "[ curve ] Hausdorff " << studio["hausdorff_before_px"] << " -> " << studio["hausdorff_after_px"]
            << " px, C0 " << c0.size() << " points\n";

  // The command line with the traced C0 (pane pixels) and the same view.
  nlohmann::json c0json;
  for (const auto& p : c0) c0json["points"].push_back({p.x, p.y});
  std::ofstream(dir / "c0.json") << c0json.dump();
  std::ostringstream args;
  args.precision(17);
  args << "curve-analogy \"" << (dir / "shape").string() << "\" --segment skin --transfer bone --curve \""
       << (dir / "c0.json").string() << "\" --size " << w << "x" << h << " --azimuth " << view.camera.azimuthDeg
       << " --elevation " << view.camera.elevationDeg << " --out \"" << (dir / "cli").string() << "\"";
  ASSERT_EQ(runCli(dir, "cli", args.str()), 0);
  const nlohmann::json cli = nlohmann::json::parse(std::ifstream(dir / "cli" / "shape.json"))["curve_analogy"];
  EXPECT_DOUBLE_EQ(studio["hausdorff_before_px"].get<double>(), cli["hausdorff_before_px"].get<double>());
  EXPECT_DOUBLE_EQ(studio["hausdorff_after_px"].get<double>(), cli["hausdorff_after_px"].get<double>());
  for (const char* name : {"skin", "bone"})
    EXPECT_EQ(illustration::loadMesh(bent / "meshes" / (std::string(name) + ".ply")).vertices,
              illustration::loadMesh(dir / "cli" / "meshes" / (std::string(name) + ".ply")).vertices)
        << name;
}

}  // namespace
}  // namespace vellum::studio

namespace vellum::studio {
namespace {

struct SliceView {
  double zoom = 0, panU = 0, panV = 0, mmPerPixel = 0;
};
/// The `slice_view` lines a script printed, in order.
std::vector<SliceView> sliceViews(const std::string& output) {
  std::vector<SliceView> r;
  std::istringstream in(output);
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("slice_view ", 0) != 0) continue;
    std::istringstream l(line);
    std::string tag, axis, word;
    SliceView v;
    l >> tag >> axis >> word >> v.zoom >> word >> v.panU >> v.panV >> word >> v.mmPerPixel;
    r.push_back(v);
  }
  return r;
}

// Label edits run on the task queue's worker: edits asked for while one runs queue behind it
// and give what the same edits give one by one; a brush stroke meanwhile is refused with a
// notice (not lost silently, not racing the worker); the label map is saved after the queued
// edits. The slice views zoom about the pointer (Ctrl+wheel), pan (middle-drag) and fit (F or
// the action); W/L presets are view edits the scene keeps; Ctrl+Q quits.
TEST(StudioScript, EditsQueueBehindTheWorkerAndSliceViewsZoomPanAndFit) {
  REQUIRE_DISPLAY();
  const fs::path d = test::tempDir("studio-queue");
  writePhantom(d);
  // 1024x700 window, 2x2: the axial pane is x 330..676, y 0..348.
  const std::string script = R"({"actions":[{"open":)" + q(d / "ct.nrrd") + R"(},{"layout":"2x2"},
    {"hold_tasks":true},
    {"threshold":{"preset":"bone","label":1,"wait":false}},
    {"remove_islands":{"mm3":100,"wait":false}},
    {"fill_holes":false},
    {"tool":"paint"},{"active_label":2},{"brush_radius":6},
    {"drag":{"from":[480,170],"to":[540,190],"button":"left"}},
    {"hold_tasks":false},
    {"save_labels":)" + q(d / "queued.nrrd") + R"(},
    {"tool":"navigate"},
    {"scroll":{"at":[470,140],"dy":2,"mods":["ctrl"]}},{"slice_view":"axial"},
    {"drag":{"from":[500,175],"to":[540,205],"button":"middle"}},{"slice_view":"axial"},
    {"slice_view":{"fit":"axial"}},{"slice_view":"axial"},
    {"scroll":{"at":[470,140],"dy":1,"mods":["ctrl"]}},{"key":"f"},
    {"slice_view":"axial"},
    {"window_preset":"bone"},
    {"save_scene":)" + q(d / "s.json") + R"(},
    {"key":"ctrl+q"},{"frames":3},{"log":"still running after ctrl+q"}]})";
  const StudioRun r = runStudio(d, "queue", script);
  ASSERT_EQ(r.exitCode, 0) << r.output;
  EXPECT_EQ(r.output.find("still running after ctrl+q"), std::string::npos) << "Ctrl+Q quits: " << r.output;
  EXPECT_NE(r.output.find("painting refused"), std::string::npos) << r.output;

  // The queued edits, one by one.
  const VolumeI16 ct = toInt16(io::loadVolume(d / "ct.nrrd").volume);
  LabelVolume expected(ct.geometry());
  thresholdInto(expected, ct, segmentation::presetInterval(segmentation::Preset::Bone), {1, "bone", {255, 255, 255}});
  removeIslands(expected, 1, 100);
  fillHoles(expected, 1);
  const LabelVolume queued = io::loadLabels(d / "queued.nrrd");
  EXPECT_EQ(queued.ids().voxels(), expected.ids().voxels());
  ASSERT_GE(queued.histogram().size(), 2u);
  EXPECT_GT(queued.histogram()[1], 500u);
  EXPECT_LE(queued.histogram().size(), 2u) << "the refused stroke painted nothing";

  const std::vector<SliceView> v = sliceViews(r.output);
  ASSERT_EQ(v.size(), 4u) << r.output;
  EXPECT_NEAR(v[0].zoom, 1.21, 1e-9) << "two Ctrl+wheel notches";
  EXPECT_NE(v[0].panU, 0.0) << "zoomed about the pointer, not the centre";
  // The middle-drag moved the picture with the pointer: the centre moves against it.
  EXPECT_NEAR(v[1].panU - v[0].panU, -40 * v[0].mmPerPixel, 1e-3);
  EXPECT_NEAR(v[1].panV - v[0].panV, -30 * v[0].mmPerPixel, 1e-3);
  EXPECT_EQ(v[2].zoom, 1.0);
  EXPECT_EQ(v[2].panU, 0.0);
  EXPECT_EQ(v[2].panV, 0.0);
  EXPECT_NEAR(v[2].mmPerPixel, v[0].mmPerPixel * 1.21, 1e-5);  // printed with 6 decimals
  EXPECT_EQ(v[3].zoom, 1.0) << "F over the axial view fits it again";
  const SceneFile sf = readSceneFile(d / "s.json");
  const auto bone = std::find_if(windowPresets().begin(), windowPresets().end(),
                                 [](const WindowPreset& p) { return std::string(p.name) == "bone"; });
  ASSERT_NE(bone, windowPresets().end());
  EXPECT_EQ(sf.view.view.sliceWindow.center, bone->center);
  EXPECT_EQ(sf.view.view.sliceWindow.width, bone->width);
}

}  // namespace
}  // namespace vellum::studio

namespace vellum::studio {
namespace {

// Adopting a load uploads the 3D view's textures a slab per frame (the CPU part prepared on
// the loader's worker): the picture is exactly setVolume()'s, and nothing is drawn before the
// last slab.
TEST(StudioLoad, SteppedUploadOfAPreparedVolumeDrawsWhatSetVolumeDraws) {
  phantom::PhantomOptions o;
  o.dims = {40, 36, 30};
  const AnyVolume ct(phantom::makePhantom(o).ct);
  auto context = render::GlContext::createHeadless();
  render::RenderSettings s;
  s.width = 64;
  s.height = 48;
  s.preset = render::Preset::Bone;
  render::VolumeRenderer whole(*context), stepped(*context);
  whole.setVolume(ct);
  const auto shared = std::make_shared<const AnyVolume>(ct);
  const auto prepared = render::VolumeRenderer::prepare(*shared);
  const size_t slice = 40 * 36 * 2;  // int16 voxels (the normals are computed in the shader)
  int steps = 0;
  while (!stepped.uploadVolumeStep(shared, prepared, 4 * slice)) ASSERT_LT(++steps, 100);
  EXPECT_EQ(steps + 1, 9) << "one allocation, then 30 slices, 4 per step";
  EXPECT_EQ(stepped.render(s).pixels, whole.render(s).pixels);
}

}  // namespace
}  // namespace vellum::studio

namespace vellum::studio {
namespace {

// A deformation with a rigid snap (every voxel of body 0, which moves `shiftMm` along x) on
// the volume's own grid, its nodes moved `nodeShiftMm` along x.
render::BackwardMap shiftedMap(const Geometry& g, double nodeShiftMm, double shiftMm,
                               std::shared_ptr<const std::vector<uint16_t>> classes) {
  render::BackwardMap map = render::identityBackwardMap(g);
  for (size_t i = 0; i < map.sourceMm.size(); i += 3) map.sourceMm[i] += float(nodeShiftMm);
  auto snap = std::make_shared<RigidSnap>();
  snap->classGrid = g;
  snap->classes = std::move(classes);
  snap->fits = {{1, 0, 0, 0, 1, 0, 0, 0, 1, shiftMm, 0, 0}};
  snap->valid = {1};
  snap->maxSnapMm = 1000;
  map.rigidSnap = snap;
  return map;
}

// The map's CPU part made off the context's thread and uploaded in slabs (the studio's 3D view):
// until the last slab the previous map is drawn unchanged, then exactly setBackwardMap()'s
// picture; a map replacing one mid-upload continues its class volume instead of starting over.
TEST(StudioLoad, SteppedUploadOfAPreparedMapDrawsWhatSetBackwardMapDraws) {
  phantom::PhantomOptions o;
  o.dims = {40, 36, 30};
  const AnyVolume ct(phantom::makePhantom(o).ct);
  const Geometry g = geometryOf(ct);
  auto context = render::GlContext::createHeadless();
  render::RenderSettings s;
  s.width = 64;
  s.height = 48;
  s.preset = render::Preset::Bone;
  render::VolumeRenderer whole(*context), stepped(*context);
  whole.setVolume(ct);
  stepped.setVolume(ct);
  const auto prepared = render::VolumeRenderer::prepare(ct);
  const RgbaImage plain = whole.render(s);
  auto classes = std::make_shared<const std::vector<uint16_t>>(size_t(g.dims.voxelCount()), uint16_t{2});
  const auto a = std::make_shared<const render::BackwardMap>(shiftedMap(g, 2.0, 6.0, classes));
  const auto b = std::make_shared<const render::BackwardMap>(shiftedMap(g, 3.0, -5.0, classes));
  const auto pa = render::VolumeRenderer::prepareBackwardMap(a, *prepared);
  const auto pb = render::VolumeRenderer::prepareBackwardMap(b, *prepared);
  const size_t mapSlice = 40 * 36 * 16, classSlice = 40 * 36 * 2;
  // Map a: its 30 map slices, 10 per step, then 8 of the 30 class slices.
  for (int step = 0; step < 4; ++step) {
    ASSERT_FALSE(stepped.uploadBackwardMapStep(pa, step < 3 ? 10 * mapSlice : 8 * classSlice));
    EXPECT_EQ(stepped.render(s).pixels, plain.pixels) << "nothing deformed before the last slab, step " << step;
  }
  // Map b replaces it: its map slices again, then only the class slices a left.
  int steps = 1;
  while (!stepped.uploadBackwardMapStep(pb, 10 * mapSlice)) ASSERT_LT(++steps, 100);
  EXPECT_EQ(steps, 4) << "30 map slices, 10 per step, then the 22 class slices left (2.75 map slices' worth)";
  whole.setBackwardMap(b.get());
  const RgbaImage deformed = whole.render(s);
  EXPECT_NE(deformed.pixels, plain.pixels);
  EXPECT_EQ(stepped.render(s).pixels, deformed.pixels);
  // The old entry point still works after stepped uploads, and removing the map restores the plain view.
  stepped.setBackwardMap(a.get());
  whole.setBackwardMap(a.get());
  EXPECT_EQ(stepped.render(s).pixels, whole.render(s).pixels);
  stepped.setBackwardMap(nullptr);
  EXPECT_EQ(stepped.render(s).pixels, plain.pixels);
}

}  // namespace
}  // namespace vellum::studio
