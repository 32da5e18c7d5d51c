// Deformation authoring in vellum-studio: the track model (no window) and scripted sessions
// under the X server (skipped without $DISPLAY): place the default points, drag a target
// through the real mouse path, rigid bones, keyframes, undo/redo, playback, and the export
// against `vellum animate` on the same keyframes.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <thread>
#include <sstream>
#include <string>

#include "authoring.hpp"
#include "deform_session.hpp"
#include "layout.hpp"
#include "mpr.hpp"
#include "scene_file.hpp"
#include "studio_run.hpp"
#include "test_data.hpp"
#include "undo.hpp"
#include "view3d.hpp"
#include "vellum/animation/movie.hpp"
#include "vellum/core/error.hpp"
#include "vellum/deformation/placement.hpp"
#include "vellum/deformation/point_files.hpp"
#include "vellum/io/image_io.hpp"
#include "vellum/io/video_io.hpp"
#include "vellum/io/volume_io.hpp"
#include "vellum/phantom/phantom.hpp"
#include "vellum/render/projection.hpp"
#include "vellum/render/volume_renderer.hpp"

namespace vellum::studio {
namespace {
namespace fs = std::filesystem;
using namespace vellum::deformation;

using namespace vellum::test::studio;

TEST(StudioAuthoringModel, AddKeyframeCopiesAndTrackEditsUndoExactly) {
  Geometry g;
  g.dims = {32, 32, 32};
  g.spacing = {2, 2, 2};
  Authoring a;
  UndoStack undo;
  LabelVolume labels;
  auto edit = [&](const std::function<void(Authoring&)>& fn) {
    TrackEdit e;
    e.before = a.track;
    e.keyframeBefore = a.keyframe;
    fn(a);
    e.after = a.track;
    e.keyframeAfter = a.keyframe;
    undo.push(std::move(e));
  };
  edit([&](Authoring& x) { placePoints(x, boxControlPoints(g)); });
  ASSERT_EQ(a.currentPoints().size(), 16u);
  edit([](Authoring& x) { addKeyframe(x); });
  ASSERT_EQ(a.track.keyframes.size(), 2u);
  EXPECT_EQ(a.keyframe, 1);
  EXPECT_EQ(a.track.keyframes[0].points, a.track.keyframes[1].points);  // the paper's rule: a copy
  const KeyframeTrack beforeMove = a.track;
  edit([](Authoring& x) { x.editablePoints()[3].target.x += 7; });
  const KeyframeTrack afterMove = a.track;
  ASSERT_TRUE(undo.undo(labels, &a));
  EXPECT_EQ(a.track.keyframes[1].points, beforeMove.keyframes[1].points);
  EXPECT_FALSE(undo.lastWasLabels());
  ASSERT_TRUE(undo.redo(labels, &a));
  EXPECT_EQ(a.track.keyframes[1].points, afterMove.keyframes[1].points);
  edit([](Authoring& x) { deletePoint(x, 0); });
  EXPECT_EQ(a.track.keyframes[0].points.size(), 15u);
  EXPECT_EQ(a.track.keyframes[1].points.size(), 15u);
  // Interpolated while scrubbing: halfway between the keyframes.
  a.timeS = 0.5;
  EXPECT_NEAR(a.currentPoints()[2].target.x, 0.5 * (afterMove.keyframes[0].points[3].target.x + afterMove.keyframes[1].points[3].target.x), 1e-9);
  EXPECT_THROW(undo.undo(labels, nullptr), Error);  // a track edit needs the authoring state
}

TEST(StudioAuthoringModel, SceneFileKeepsTheTrackBesideItAndNamesBadKeyframes) {
  const fs::path d = test::tempDir("studio-authoring-scene");
  const auto ph = phantomOf({24, 24, 24});
  io::saveVolume(AnyVolume(ph.ct), d / "ct.nrrd");
  Scene scene;
  scene.ct = ph.ct;
  scene.volumePath = d / "ct.nrrd";
  placePoints(scene.authoring, boxControlPoints(ph.ct.geometry()));
  addKeyframe(scene.authoring);
  scene.authoring.editablePoints()[2].target.z += 5;
  scene.authoring.rigidLabels = {4, 6};
  writeSceneFile(describeScene(scene), d / "s.json");
  ASSERT_TRUE(fs::exists(d / "s.keyframes.json"));
  const SceneFile f = readSceneFile(d / "s.json");
  ASSERT_TRUE(f.deformation);
  EXPECT_EQ(f.deformation->track.keyframes.size(), 2u);
  EXPECT_EQ(f.deformation->track.keyframes[1].points, scene.authoring.track.keyframes[1].points);
  EXPECT_EQ(f.deformation->keyframe, 1);
  EXPECT_EQ(f.deformation->rigidLabels, (std::vector<uint16_t>{4, 6}));
  // The keyframe file is what `vellum animate --keyframes` reads.
  EXPECT_EQ(loadKeyframes(d / "s.keyframes.json").keyframes[1].points, scene.authoring.track.keyframes[1].points);
  // A keyframe index outside the track is refused naming the scene and the field.
  std::string text = slurp(d / "s.json");
  text.replace(text.find("\"keyframe\": 1"), 13, "\"keyframe\": 9");
  std::ofstream(d / "bad.json") << text;
  try {
    readSceneFile(d / "bad.json");
    FAIL() << "accepted a keyframe index outside the track";
  } catch (const FileError& e) {
    EXPECT_NE(std::string(e.what()).find("deformation.keyframe 9"), std::string::npos) << e.what();
  }
}

// Issue 11: the live deformed view uses the map upsampling of the View settings; with
// "gaussian" its frame is the frame `vellum animate --upsampling gaussian` renders (the movie
// renderer), pixel for pixel, and differs from the trilinear one.
TEST(StudioAuthoringModel, LiveViewUsesTheChosenUpsamplingLikeVellumAnimate) {
  const auto ph = phantomOf({40, 40, 40});
  Scene scene;
  scene.ct = ph.ct;
  scene.view.deformedUpsampling = Upsampling::Gaussian;
  Authoring& a = scene.authoring;
  placePoints(a, boxControlPoints(ph.ct.geometry()));
  a.editablePoints()[5].target += Vec3{6, -4, 3};
  a.touch();
  DeformSession session;
  awaitExactMap(session, scene);
  ASSERT_TRUE(session.map() && !session.preview());
  EXPECT_EQ(session.map()->upsampling, Upsampling::Gaussian);

  auto context = render::GlContext::createHeadless();
  const render::RenderSettings s = renderSettingsFor(scene, 96, 80);
  render::VolumeRenderer live(*context);
  live.setVolume(ph.ct);
  live.setBackwardMap(session.map());
  const RgbaImage liveFrame = live.render(s);
  const auto movieFrame = [&](Upsampling up) {
    animation::MovieSpec spec;
    spec.settings = s;
    spec.upsampling = up;
    animation::MovieRenderer movie(*context, ph.ct, a.track, a.engine, {}, spec);
    return movie.renderNext();
  };
  EXPECT_EQ(liveFrame.pixels, movieFrame(Upsampling::Gaussian).pixels);
  EXPECT_NE(liveFrame.pixels, movieFrame(Upsampling::Trilinear).pixels) << "the kernel changes the picture";
  // Changing the setting re-solves: the map follows it.
  scene.view.deformedUpsampling = Upsampling::Trilinear;
  awaitExactMap(session, scene);
  ASSERT_TRUE(session.map());
  EXPECT_EQ(session.map()->upsampling, Upsampling::Trilinear);
}

TEST(StudioAuthoringScript, DragKeyframesUndoAndExportMatchesVellumAnimate) {
  REQUIRE_DISPLAY();
  const fs::path d = test::tempDir("studio-authoring");
  const auto ph = writePhantom(d, 64);
  const std::string script = scriptOnPhantom(d) + R"(
    {"layout":"3d"},{"hud":false},{"set":{"deformed_upsampling":"gaussian"}},
    {"controls":"default"},{"save_scene":)" + q(d / "s0.json") + R"(},
    {"drag_point":{"index":4,"end":"target","by_px":[40,-30]}},{"wait_idle":true},
    {"save_scene":)" + q(d / "s1.json") + R"(},
    {"keyframe":"add"},
    {"drag_point":{"index":5,"end":"target","by_px":[25,-35],"mods":["shift"]}},
    {"save_scene":)" + q(d / "s2.json") + R"(},
    {"key":"ctrl+z"},{"save_scene":)" + q(d / "s3.json") + R"(},
    {"key":"ctrl+shift+z"},{"save_scene":)" + q(d / "s4.json") + R"(},
    {"keyframe":{"select":0,"duration":0.5}},
    {"play":{"seconds":0.3}},
    {"attribute_drag":{"index":4,"tool":"lightness","by_px":[0,-40]}},
    {"attribute_drag":{"index":4,"tool":"hue","by_px":[20,10]}},
    {"save_scene":)" + q(d / "s5.json") + R"(},
    {"export_movie":{"out":)" + q(d / "studio/") + R"(,"fps":8,"size":"96x80","orbit":30,"command":)" + q(d / "cmd.txt") + R"(}},
    {"screenshot":)" + q(d / "window.png") + R"(},
    {"quit":0}]})";
  std::string log;
  ASSERT_EQ(runStudio(d, "author", script, &log), 0) << log;

  // The drag moved the target in the plane through it parallel to the screen, following the
  // pointer: it projects 40 px right and 30 px up of where it was drawn.
  const SceneFile s0 = readSceneFile(d / "s0.json"), s1 = readSceneFile(d / "s1.json");
  ASSERT_TRUE(s0.deformation && s1.deformation);
  const ControlPoints& p0 = s0.deformation->track.keyframes[0].points;
  const ControlPoints& p1 = s1.deformation->track.keyframes[0].points;
  ASSERT_EQ(p0.size(), 16u);
  EXPECT_EQ(p1[4].source, p0[4].source);
  Scene view;
  view.ct = ph.ct;
  applySceneView(s1, view);
  const std::vector<Pane> panes = layoutPanes(Layout::ThreeD, {kToolPanelWidth, 0, 1024 - kToolPanelWidth, 700});
  const render::Projection proj(ph.ct.geometry(), renderSettingsFor(view, int(panes[0].rect.w), int(panes[0].rect.h)));
  const Vec3 a = *proj.toPixel(p0[4].target), b = *proj.toPixel(p1[4].target);
  EXPECT_NEAR(b.x - a.x, 40, 0.5);
  EXPECT_NEAR(b.y - a.y, -30, 0.5);
  EXPECT_NEAR(dot(p1[4].target - p0[4].target, proj.viewDirection()), 0, 1e-6);  // same depth
  // The map at the dragged target returns the point's source (MLS interpolates its points).
  Deformer deformer(AnyVolume(ph.ct), studioDeformParams());
  deformer.setPoints(p1);
  const Vec3 u = deformer.mapPoints({p1[4].target})[0];
  EXPECT_LT(norm(u - p1[4].source), 0.05) << "map(target) is " << u.x << " " << u.y << " " << u.z;

  // Bones stay rigid in the frame the studio renders (the node map, as the GL path samples it).
  const RigidBodies bodies = RigidBodies::fromLabels(ph.labels, boneLikeLabels(ph.labels));
  EXPECT_EQ(s1.deformation->rigidLabels, boneLikeLabels(ph.labels));
  ControlVolume cv = deformer.update();
  const RigidityReport plain = measureRigidityVoxels(cv, ph.ct.geometry(), bodies);
  applyRigidity(cv, bodies, {s1.deformation->falloffMm});
  cv.rigidSnap.reset();
  const RigidityReport rigid = measureRigidityVoxels(cv, ph.ct.geometry(), bodies);
  EXPECT_LT(rigid.boneRmsResidualMm, 0.5 * plain.boneRmsResidualMm + 1e-9);
  EXPECT_LT(rigid.boneRmsResidualMm, 0.2);

  // "Add keyframe" copied keyframe 0; the Shift drag moved point 5 along one axis only.
  const SceneFile s2 = readSceneFile(d / "s2.json"), s3 = readSceneFile(d / "s3.json"), s4 = readSceneFile(d / "s4.json");
  ASSERT_EQ(s2.deformation->track.keyframes.size(), 2u);
  const ControlPoint& k0 = s2.deformation->track.keyframes[0].points[5];
  const ControlPoint& k1 = s2.deformation->track.keyframes[1].points[5];
  int changed = 0;
  for (int axis = 0; axis < 3; ++axis) changed += std::abs(k1.target[axis] - k0.target[axis]) > 1e-9;
  EXPECT_EQ(changed, 1);
  // Undo restores the copy exactly; redo the drag.
  EXPECT_EQ(s3.deformation->track.keyframes[1].points, s2.deformation->track.keyframes[0].points);
  EXPECT_EQ(s4.deformation->track.keyframes[1].points, s2.deformation->track.keyframes[1].points);

  // Attribute drags on the edited keyframe (0 after "select"): up 40 px = +20 L*; then the
  // hue tool: right 20 px = +10 a*, down 10 px = -5 b*. The export below renders them.
  const SceneFile s5 = readSceneFile(d / "s5.json");
  const PointAttributes& at = s5.deformation->track.keyframes[0].points[4].attributes;
  EXPECT_NEAR(at.lightness, 20, 1e-9);
  EXPECT_NEAR(at.a, 10, 1e-9);
  EXPECT_NEAR(at.b, -5, 1e-9);
  EXPECT_EQ(s5.deformation->track.keyframes[0].points[4].target, s4.deformation->track.keyframes[0].points[4].target);

  // The studio's frames are `vellum animate`'s frames on the same keyframes, pixel for pixel.
  std::string cmd = slurp(d / "cmd.txt");
  ASSERT_NE(cmd.find("vellum animate "), std::string::npos) << cmd;
  EXPECT_NE(cmd.find(" --upsampling gaussian"), std::string::npos) << "the live view's kernel: " << cmd;
  EXPECT_EQ(s5.view.view.deformedUpsampling, Upsampling::Gaussian) << "saved in the scene";
  const std::string studioOut = "'" + (d / "studio/").string() + "'";
  ASSERT_NE(cmd.find(studioOut), std::string::npos) << cmd;
  cmd.replace(cmd.find(studioOut), studioOut.size(), "'" + (d / "cli/").string() + "'");
  cmd.replace(0, std::string("vellum").size(), std::string("\"") + VELLUM_CLI_EXE + "\"");
  cmd.pop_back();  // newline
  ASSERT_EQ(std::system((cmd + " > \"" + (d / "cli.log").string() + "\" 2>&1").c_str()), 0) << slurp(d / "cli.log");
  const int frames = expectSameFrames(d / "studio", d / "cli");
  // 0.5 s + 1 s (the last keyframe holds) at 8 fps, and the end frame.
  EXPECT_EQ(frames, 13);
}

TEST(StudioAuthoringScript, PointsFromLabelsAndASliceDragStaysInTheSlicePlane) {
  REQUIRE_DISPLAY();
  const fs::path d = test::tempDir("studio-authoring-slice");
  const auto ph = writePhantom(d, 48);
  const std::string script = scriptOnPhantom(d) + R"(
    {"layout":"2x2"},{"controls":"labels"},{"save_scene":)" + q(d / "a.json") + R"(},
    {"drag_point":{"index":0,"end":"target","by_px":[20,-10],"view":"axial"}},
    {"save_scene":)" + q(d / "b.json") + R"(},{"quit":0}]})";
  std::string log;
  ASSERT_EQ(runStudio(d, "slice", script, &log), 0) << log;
  const SceneFile a = readSceneFile(d / "a.json"), b = readSceneFile(d / "b.json");
  const ControlPoints& pa = a.deformation->track.keyframes[0].points;
  const ControlPoints& pb = b.deformation->track.keyframes[0].points;
  EXPECT_EQ(pa, labelControlPoints(ph.labels));  // the "Points from labels" placement
  // In the axial slice the target moves within the slice plane: by 20 px along screen right
  // and 10 px up, at the slice's mm per pixel; z stays.
  const std::vector<Pane> panes = layoutPanes(Layout::TwoByTwo, {kToolPanelWidth, 0, 1024 - kToolPanelWidth, 700});
  const Pane* axial = nullptr;
  for (const Pane& p : panes)
    if (p.slice == SliceAxis::Axial) axial = &p;
  ASSERT_TRUE(axial);
  const SlicePlane plane = makePlane(SliceAxis::Axial, ph.ct.geometry(), a.crosshairMm, int(axial->rect.w), int(axial->rect.h));
  const Vec3 expected = pa[0].target + plane.u * (20 * plane.mmPerPixel) - plane.v * (10 * plane.mmPerPixel);
  EXPECT_LT(norm(pb[0].target - expected), 1e-6);
  EXPECT_DOUBLE_EQ(pb[0].target.z, pa[0].target.z);
}

// The rigid bones are an undoable edit: the script's `rigid_labels` (the panel's checkboxes
// make the same call) sets them and re-solves with them; Ctrl+Z restores the labels chosen
// from the names, Ctrl+Shift+Z the edit.
TEST(StudioAuthoringScript, RigidLabelEditsUndoAndRedo) {
  REQUIRE_DISPLAY();
  const fs::path d = test::tempDir("studio-authoring-rigid");
  const auto ph = writePhantom(d, 40);
  const std::string script = scriptOnPhantom(d) + R"(
    {"layout":"3d"},{"controls":"default"},{"save_scene":)" + q(d / "a.json") + R"(},
    {"rigid_labels":[6,4,6]},{"save_scene":)" + q(d / "b.json") + R"(},
    {"key":"ctrl+z"},{"save_scene":)" + q(d / "c.json") + R"(},
    {"key":"ctrl+shift+z"},{"save_scene":)" + q(d / "e.json") + R"(},{"quit":0}]})";
  std::string log;
  ASSERT_EQ(runStudio(d, "rigid", script, &log), 0) << log;
  const auto rigid = [&](const char* name) { return readSceneFile(d / name).deformation->rigidLabels; };
  EXPECT_EQ(rigid("a.json"), boneLikeLabels(ph.labels));  // chosen from the label names on open
  EXPECT_NE(rigid("a.json"), (std::vector<uint16_t>{4, 6}));
  EXPECT_EQ(rigid("b.json"), (std::vector<uint16_t>{4, 6}));  // sorted, each id once
  EXPECT_EQ(rigid("c.json"), rigid("a.json"));
  EXPECT_EQ(rigid("e.json"), (std::vector<uint16_t>{4, 6}));
  // The control points are untouched by these edits.
  EXPECT_EQ(readSceneFile(d / "e.json").deformation->track.keyframes[0].points,
            readSceneFile(d / "a.json").deformation->track.keyframes[0].points);
}

// The timeline's blocks through the real mouse path: a block dragged onto another moves its
// pose there (the durations stay in place), its right-edge handle dragged sideways retimes
// it; each drag is one undo step.
TEST(StudioAuthoringScript, TimelineBlocksReorderAndRetimeByDragging) {
  REQUIRE_DISPLAY();
  const fs::path d = test::tempDir("studio-authoring-timeline");
  const auto ph = phantomOf({40, 40, 40});
  io::saveVolume(AnyVolume(ph.ct), d / "ct.nrrd");
  const std::string script = R"({"actions":[
    {"open":)" + q(d / "ct.nrrd") + R"(},{"layout":"3d"},{"controls":"default"},
    {"drag_point":{"index":4,"end":"target","by_px":[20,0]}},{"keyframe":"add"},
    {"drag_point":{"index":4,"end":"target","by_px":[0,20]}},{"keyframe":"add"},
    {"drag_point":{"index":4,"end":"target","by_px":[-20,0]}},
    {"keyframe":{"select":0,"duration":1}},{"keyframe":{"select":1,"duration":2}},
    {"keyframe":{"select":2,"duration":3}},{"save_scene":)" + q(d / "a.json") + R"(},
    {"keyframe_drag":{"from":0,"to":2}},{"save_scene":)" + q(d / "b.json") + R"(},
    {"key":"ctrl+z"},{"save_scene":)" + q(d / "c.json") + R"(},
    {"keyframe_drag":{"index":1,"by_px":30}},{"save_scene":)" + q(d / "e.json") + R"(},
    {"key":"ctrl+z"},{"save_scene":)" + q(d / "f.json") + R"(},
    {"keyframe_drag":{"from":0,"to":9}},{"quit":0}]})";
  std::string log;
  // The last action names a block that does not exist: the script fails there, naming it.
  ASSERT_EQ(runStudio(d, "timeline", script, &log), 3) << log;
  EXPECT_NE(log.find("no keyframe block 9"), std::string::npos) << log;
  const auto track = [&](const char* name) { return readSceneFile(d / name).deformation->track; };
  const KeyframeTrack a = track("a.json"), b = track("b.json"), c = track("c.json"), e = track("e.json"),
                      f = track("f.json");
  ASSERT_EQ(a.keyframes.size(), 3u);
  // The poses differ in point 4's target (dragged differently in each keyframe).
  const auto pose = [](const KeyframeTrack& t, size_t k) { return t.keyframes[k].points[4].target; };
  ASSERT_NE(pose(a, 0), pose(a, 1));
  ASSERT_NE(pose(a, 1), pose(a, 2));
  // K0's pose went to the end, the others moved up one place; the durations stayed.
  EXPECT_EQ(pose(b, 0), pose(a, 1));
  EXPECT_EQ(pose(b, 1), pose(a, 2));
  EXPECT_EQ(pose(b, 2), pose(a, 0));
  EXPECT_TRUE(b.keyframes[2].points == a.keyframes[0].points) << "the whole pose moved";
  for (size_t k = 0; k < 3; ++k) EXPECT_EQ(b.keyframes[k].durationS, a.keyframes[k].durationS) << k;
  EXPECT_EQ(readSceneFile(d / "b.json").deformation->keyframe, 2) << "the moved keyframe is the edited one";
  for (size_t k = 0; k < 3; ++k) EXPECT_TRUE(c.keyframes[k].points == a.keyframes[k].points) << "undone, " << k;
  // The handle: 30 px right lengthens K1 by 30 px of the timeline's scale (total 6 s over the
  // panel's width, a few hundred px), the others keep theirs; undo restores 2 s.
  EXPECT_GT(e.keyframes[1].durationS, 2.2);
  EXPECT_LT(e.keyframes[1].durationS, 3.5);
  EXPECT_EQ(e.keyframes[0].durationS, 1);
  EXPECT_EQ(e.keyframes[2].durationS, 3);
  EXPECT_EQ(pose(e, 1), pose(a, 1));
  EXPECT_EQ(f.keyframes[1].durationS, 2);
}

// Decoded frames of a movie, one MD5 per frame (ffmpeg's framemd5 muxer), without the header.
std::string decodedFrameHashes(const fs::path& movie, const fs::path& out) {
  const std::string cmd = "ffmpeg -v error -i \"" + movie.string() + "\" -f framemd5 - > \"" + out.string() + "\"";
  if (std::system(cmd.c_str()) != 0) return "ffmpeg failed on " + movie.string();
  std::istringstream in(slurp(out));
  std::string line, hashes;
  while (std::getline(in, line))
    if (!line.empty() && line[0] != '#') hashes += line + "\n";
  return hashes;
}

// The MP4 export: the studio's movie and `vellum animate`'s on the same keyframes decode to
// the same frames.
TEST(StudioAuthoringScript, Mp4ExportDecodesToTheFramesOfVellumAnimate) {
  REQUIRE_DISPLAY();
  if (!io::videoEncoderAvailable()) GTEST_SKIP() << "no ffmpeg on PATH";
  const fs::path d = test::tempDir("studio-authoring-mp4");
  io::saveVolume(AnyVolume(phantomOf({40, 40, 40}).ct), d / "ct.nrrd");
  const std::string script = R"({"actions":[
    {"open":)" + q(d / "ct.nrrd") + R"(},{"layout":"3d"},{"controls":"default"},
    {"keyframe":{"select":0,"duration":0.5}},{"keyframe":"add"},
    {"drag_point":{"index":4,"end":"target","by_px":[30,-20]}},
    {"export_movie":{"out":)" + q(d / "studio.mp4") + R"(,"fps":10,"size":"64x48","command":)" + q(d / "cmd.txt") + R"(}},
    {"export_movie":{"out":)" + q(d / "cancelled" / "m.mp4") + R"(,"fps":60,"size":"256x256","wait":false}},
    {"frames":2},{"key":"escape"},{"frames":2},
    {"quit":0}]})";
  std::string log;
  ASSERT_EQ(runStudio(d, "mp4", script, &log), 0) << log;
  std::string cmd = slurp(d / "cmd.txt");
  const std::string studioOut = "'" + (d / "studio.mp4").string() + "'";
  ASSERT_NE(cmd.find(studioOut), std::string::npos) << cmd;
  cmd.replace(cmd.find(studioOut), studioOut.size(), "'" + (d / "cli.mp4").string() + "'");
  cmd.replace(0, std::string("vellum").size(), std::string("\"") + VELLUM_CLI_EXE + "\"");
  cmd.pop_back();  // newline
  ASSERT_EQ(std::system((cmd + " > \"" + (d / "cli.log").string() + "\" 2>&1").c_str()), 0) << slurp(d / "cli.log");
  const std::string a = decodedFrameHashes(d / "studio.mp4", d / "studio.md5");
  const std::string b = decodedFrameHashes(d / "cli.mp4", d / "cli.md5");
  // Escape during the second export cancelled it: no movie and no temporary left beside it
  // (the keyframes file written at the start stays).
  ASSERT_TRUE(fs::exists(d / "cancelled"));
  for (const auto& e : fs::directory_iterator(d / "cancelled"))
    EXPECT_EQ(e.path().filename(), "m.mp4.keyframes.json");
  // Two keyframes of 0.5 s (the added one copies the duration) at 10 fps, and the end frame.
  EXPECT_EQ(std::count(a.begin(), a.end(), '\n'), 11) << a;
  EXPECT_EQ(a, b);
}

// A drag solves the exact map at once while that is cheap (a target moved, the last exact
// solve within the budget); a moved source needs a rho field rebuilt: the coarse preview.
TEST(StudioAuthoringModel, TargetDragsSolveTheExactMapLiveSourceDragsThePreview) {
  Scene scene;
  scene.ct = phantomOf({40, 40, 40}).ct;
  Authoring& a = scene.authoring;
  placePoints(a, boxControlPoints(scene.ct.geometry()));
  a.touch();
  DeformSession session;
  session.setLiveExactBudgetMs(1e9);  // the choice is tested, not the machine's speed (ASan, load)
  awaitExactMap(session, scene);
  ASSERT_TRUE(session.map() && !session.preview());
  // A target moves during a drag: the exact map, in this call, with no worker.
  a.editablePoints()[5].target += Vec3{4, 0, 0};
  a.touch();
  EXPECT_TRUE(session.update(scene, true));
  EXPECT_FALSE(session.preview());
  EXPECT_FALSE(session.solving());
  EXPECT_EQ(session.map()->grid.dims, controlGrid(scene.ct.geometry(), a.engine.controlScale).dims);
  // A source moves: the preview on the coarser grid, solved on its worker (the call never
  // waits for it: a rho field must be rebuilt); a later call adopts it.
  a.editablePoints()[5].source += Vec3{4, 0, 0};
  a.touch();
  bool landed = false;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (!landed && std::chrono::steady_clock::now() < deadline) {
    landed = session.update(scene, true);
    if (!landed) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  ASSERT_TRUE(landed);
  EXPECT_TRUE(session.preview());
  EXPECT_EQ(session.map()->grid.dims, controlGrid(scene.ct.geometry(), 2 * a.engine.controlScale).dims);
}

// The rigid bodies' copy of the label map (the size of the CT) is made where the scene reader
// runs it (the studio: the task queue's worker, after the queued edits), never inside
// update() on the UI thread; a copy that was dropped (its task cancelled) is asked again.
TEST(StudioAuthoringModel, RigidBodiesAreBuiltFromTheCopyTheSceneReaderMakes) {
  Scene scene;
  const phantom::Phantom ph = phantomOf({40, 40, 40});
  scene.ct = ph.ct;
  scene.labels = ph.labels;
  Authoring& a = scene.authoring;
  a.rigidLabels = boneLikeLabels(scene.labels);
  ASSERT_FALSE(a.rigidLabels.empty());
  placePoints(a, boxControlPoints(scene.ct.geometry()));
  a.touch();
  std::vector<std::function<void(const Scene&)>> asked;
  DeformSession session;
  session.setSceneReader([&](const std::string& name, std::function<void(const Scene&)> read) {
    EXPECT_FALSE(name.empty()) << "the task queue shows what runs";
    asked.push_back(std::move(read));
    return true;
  });
  for (int i = 0; i < 3; ++i) session.update(scene);
  ASSERT_EQ(asked.size(), 1u) << "one copy asked for, not made here";
  EXPECT_EQ(session.bodies(), nullptr);
  EXPECT_TRUE(session.busy() && session.solving()) << "the map waits for its bodies";
  EXPECT_EQ(session.map(), nullptr);
  asked.clear();  // dropped before it ran
  session.update(scene);
  ASSERT_EQ(asked.size(), 1u) << "a dropped copy is asked for again";
  asked.front()(scene);  // the worker's part
  awaitExactMap(session, scene);
  ASSERT_NE(session.bodies(), nullptr);
  EXPECT_EQ(asked.size(), 1u);
  EXPECT_TRUE(session.map() && !session.preview());
  const RigidBodies direct = RigidBodies::fromLabels(scene.labels, a.rigidLabels, 20);
  EXPECT_EQ(session.bodies()->componentCount(), direct.componentCount());
  EXPECT_EQ(session.bodies()->classes().voxels(), direct.classes().voxels()) << "built from an exact copy";
  // A label edit (a stroke) while bones are rigid: once the labels settle, a new copy is asked
  // for and the bodies rebuilt from it.
  auto& ids = scene.labels.ids().voxels();
  const auto bone = std::find(ids.begin(), ids.end(), a.rigidLabels.front());
  ASSERT_NE(bone, ids.end());
  *bone = 0;
  scene.touchLabels();
  const RigidBodies edited = RigidBodies::fromLabels(scene.labels, a.rigidLabels, 20);
  ASSERT_NE(edited.classes().voxels(), direct.classes().voxels()) << "the edit must show in the bodies";
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (asked.size() < 2 && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    session.update(scene);
    if (asked.size() < 2) EXPECT_TRUE(session.busy()) << "settling counts as work (scripts' wait_idle waits for it)";
  }
  ASSERT_EQ(asked.size(), 2u);
  asked.back()(scene);
  awaitExactMap(session, scene);
  ASSERT_NE(session.bodies(), nullptr);
  EXPECT_EQ(session.bodies()->classes().voxels(), edited.classes().voxels());
}

// Ctrl+click in a deformed 3D view picks the surface where the view draws it: a translation
// of 10 mm away from the eye moves the picked point 10 mm along the ray.
TEST(StudioAuthoringModel, PickingThroughTheDeformationFindsTheDrawnSurface) {
  Scene scene;
  scene.ct = phantomOf({64, 64, 64}).ct;
  const Geometry& g = scene.ct.geometry();
  const auto p0 = pickSurface(scene, 200, 200, 100, 100);  // the centre pixel: its ray passes the centre
  ASSERT_TRUE(p0);
  const Vec3 t = normalized(g.center() - *p0) * 10.0;
  ControlPoints points = boxControlPoints(g);
  for (auto& p : points) p.target = p.source + t;
  const MapSampler map(computeControlVolume(AnyVolume(scene.ct), points, DeformParams{}), g);
  const auto p1 = pickSurface(scene, 200, 200, 100, 100, &map);
  ASSERT_TRUE(p1);
  const double voxel = g.minSpacing();
  EXPECT_LT(norm(*p1 - (*p0 + t)), voxel) << "picked " << norm(*p1 - *p0) << " mm from the undeformed surface";
  // The picked point's source is the undeformed surface point (where seeds go).
  EXPECT_LT(norm(*map.sourceMm(*p1) - *p0), voxel);
}

// Box points stacked along the axial view's normal share one dot there: a press on it takes
// the point nearest the slice plane (the one the slice shows), not the lowest index.
TEST(StudioAuthoringScript, StackedDotsPickThePointNearestTheSlice) {
  REQUIRE_DISPLAY();
  const fs::path d = test::tempDir("studio-authoring-stacked");
  writePhantom(d, 48);
  const std::string script = R"({"actions":[
    {"open":)" + q(d / "ct.nrrd") + R"(},{"layout":"2x2"},{"controls":"default"},{"save_scene":)" + q(d / "a.json") + R"(},
    {"drag_point":{"index":0,"end":"target","by_px":[15,-10],"view":"axial"}},{"save_scene":)" + q(d / "b.json") + R"(},
    {"quit":0}]})";
  std::string log;
  ASSERT_EQ(runStudio(d, "stacked", script, &log), 0) << log;
  const SceneFile a = readSceneFile(d / "a.json"), b = readSceneFile(d / "b.json");
  const ControlPoints& pa = a.deformation->track.keyframes[0].points;
  const ControlPoints& pb = b.deformation->track.keyframes[0].points;
  // The points under point 0's axial dot, and the one nearest the axial plane.
  std::vector<size_t> stacked;
  size_t nearest = 0;
  for (size_t i = 0; i < pa.size(); ++i)
    if (std::abs(pa[i].target.x - pa[0].target.x) < 1e-6 && std::abs(pa[i].target.y - pa[0].target.y) < 1e-6) {
      stacked.push_back(i);
      if (std::abs(pa[i].target.z - a.crosshairMm.z) < std::abs(pa[nearest].target.z - a.crosshairMm.z)) nearest = i;
    }
  ASSERT_GE(stacked.size(), 2u) << "the default box stacks points along z";
  ASSERT_NE(nearest, 0u);
  for (size_t i = 0; i < pa.size(); ++i)
    if (i == nearest) EXPECT_NE(pb[i].target, pa[i].target) << "the dragged point";
    else EXPECT_EQ(pb[i].target, pa[i].target) << i;
}

}  // namespace
}  // namespace vellum::studio
