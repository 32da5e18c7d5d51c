// The studio's model without a window: undo deltas, label tools, scene files, MPR planes.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <fstream>
#include <thread>

#include "label_tools.hpp"
#include "loader.hpp"
#include "recent_files.hpp"
#include "segment_meshes.hpp"
#include "mpr.hpp"
#include "scene_file.hpp"
#include "test_data.hpp"
#include "task_queue.hpp"
#include "undo.hpp"
#include "vellum/core/error.hpp"
#include "vellum/io/volume_io.hpp"
#include "vellum/phantom/phantom.hpp"
#include "vellum/segmentation/morphology.hpp"
#include "vellum/segmentation/label_map.hpp"
#include "vellum/segmentation/components.hpp"

namespace vellum::studio {
namespace {

phantom::Phantom smallPhantom() {
  phantom::PhantomOptions o;
  o.dims = {48, 48, 48};
  return phantom::makePhantom(o);
}

TEST(StudioUndo, ThresholdUndoRedoRestoresExactlyWithCompressedDelta) {
  const auto ph = smallPhantom();
  LabelVolume labels(ph.ct.geometry());
  const LabelVolume empty = labels;
  UndoStack stack;
  stack.push(recordEdit(labels, "threshold", [&](LabelVolume& l) {
    thresholdInto(l, ph.ct, segmentation::presetInterval(segmentation::Preset::Bone), {1, "bone", {255, 255, 200}});
  }));
  const LabelVolume thresholded = labels;
  ASSERT_GT(thresholded.histogram().at(1), 100u);
  // Runs, not a copy: far smaller than the label map itself.
  EXPECT_LT(stack.bytes(), labels.ids().size() * sizeof(uint16_t) / 4);
  ASSERT_TRUE(stack.undo(labels));
  EXPECT_EQ(labels.ids().voxels(), empty.ids().voxels());
  EXPECT_TRUE(labels.table().empty());
  ASSERT_TRUE(stack.redo(labels));
  EXPECT_EQ(labels.ids().voxels(), thresholded.ids().voxels());
  EXPECT_EQ(labels.table(), thresholded.table());
  EXPECT_FALSE(stack.redo(labels));
}

TEST(StudioUndo, BrushStrokeAndNewEditClearsRedo) {
  const auto ph = smallPhantom();
  LabelVolume labels(ph.ct.geometry());
  UndoStack stack;
  stack.push(recordEdit(labels, "paint", [&](LabelVolume& l) { paintSphere(l, {0, 0, 0}, 10.0, 2); }));
  const auto painted = labels.histogram();
  ASSERT_GT(painted.at(2), 0u);
  // A 10 mm ball over 3.75 x 3.75 x 4.58 mm voxels: 4189 mm3 / 64.4 mm3 ~ 65 voxels.
  EXPECT_NEAR(double(painted[2]), 65.0, 25.0);
  stack.push(recordEdit(labels, "erase", [&](LabelVolume& l) { paintSphere(l, {0, 0, 0}, 5.0, 0); }));
  ASSERT_TRUE(stack.undo(labels));
  EXPECT_EQ(labels.histogram(), painted);
  stack.push(recordEdit(labels, "paint", [&](LabelVolume& l) { paintSphere(l, {20, 0, 0}, 5.0, 3); }));
  EXPECT_FALSE(stack.canRedo());
}

TEST(StudioLabelTools, LockedSegmentsSurviveEveryEdit) {
  const auto ph = smallPhantom();
  LabelVolume labels = ph.labels;  // ground truth: skin 1, fat 2, muscle 3, bones ...
  const std::set<uint16_t> locked{4};  // femur cortex
  const auto before = labels.histogram();
  // A bone threshold into label 12 would take the femur cortex: it stays 4.
  const LabelDelta d = recordEdit(labels, "threshold", [&](LabelVolume& l) {
    thresholdInto(l, ph.ct, segmentation::presetInterval(segmentation::Preset::Bone), {12, "bone", {1, 2, 3}});
  }, locked);
  EXPECT_FALSE(d.empty());
  EXPECT_EQ(labels.histogram()[4], before[4]);
  // Painting or erasing over it changes nothing of it, and painting the locked id does nothing.
  paintSphere(labels, {0, 0, 60}, 30.0, 0, locked);
  EXPECT_EQ(labels.histogram()[4], before[4]);
  EXPECT_EQ(paintSphere(labels, {0, 0, 60}, 30.0, 4, locked), 0);
}

TEST(StudioLabelTools, KeepLargestAndFillHoles) {
  const auto ph = smallPhantom();
  LabelVolume labels(ph.ct.geometry());
  paintSphere(labels, {0, 0, 0}, 20.0, 1);
  paintSphere(labels, {60, 60, 60}, 6.0, 1);  // a separate island
  paintSphere(labels, {0, 0, 0}, 6.0, 0);     // a cavity
  const auto before = labels.histogram()[1];
  LabelVolume islands = labels;
  removeIslands(islands, 1, 2000.0);  // the 6 mm ball (~900 mm3) goes, the 20 mm one stays
  keepLargest(labels, 1);
  const auto afterKeep = labels.histogram()[1];
  EXPECT_EQ(islands.ids().voxels(), labels.ids().voxels());
  EXPECT_LT(afterKeep, before);
  fillHoles(labels, 1);
  EXPECT_GT(labels.histogram()[1], afterKeep);
  EXPECT_EQ(labels(24, 24, 24), 1);  // the centre is filled again
}

TEST(StudioLabelTools, GrowFromSeedAndMorphology) {
  const auto ph = smallPhantom();
  LabelVolume labels(ph.ct.geometry());
  // The femur shaft's cortex (radius 13 mm, 4 mm thick, centred near x=y=0) at z = 60 mm.
  const segmentation::HuInterval bone{700, 3071};
  Vec3 seed{0, 0, 60};
  for (double r = 9; r < 16 && !bone.contains(ph.ct.sampleNearestMm(seed)); r += 0.5) seed = {r, 0, 60};
  ASSERT_TRUE(bone.contains(ph.ct.sampleNearestMm(seed)));
  EXPECT_GT(growFromSeed(labels, ph.ct, seed, bone, {3, "femur", {255, 255, 255}}), 50);
  EXPECT_EQ(growFromSeed(labels, ph.ct, {0, 0, 60}, bone, {3, "femur", {255, 255, 255}}), 0)
      << "a seed in the marrow grows nothing";
  const auto grown = labels.histogram()[3];
  morphology(labels, 3, Morphology::Dilate, 4.0);
  EXPECT_GT(labels.histogram()[3], grown);
  morphology(labels, 3, Morphology::Erode, 4.0);
  EXPECT_LT(labels.histogram()[3], grown * 2);
  const double otsu = otsuHu(ph.ct);  // between soft tissue (~50 HU) and cortex (1400 HU)
  EXPECT_GT(otsu, 150.0);
  EXPECT_LT(otsu, 1000.0);
}

TEST(StudioSceneFile, RoundTripsWithRelativePaths) {
  const auto dir = test::tempDir("studio-scene");
  const auto ph = smallPhantom();
  std::filesystem::create_directories(dir / "data");
  io::saveVolume(AnyVolume(ph.ct), dir / "data" / "ct.nrrd");
  io::saveLabels(ph.labels, dir / "data" / "labels.nrrd");
  SceneFile s;
  s.volume = dir / "data" / "ct.nrrd";
  s.labels = dir / "data" / "labels.nrrd";
  s.view.view.layout = Layout::OneByThree;
  s.view.render.preset = render::Preset::Bone;
  s.view.render.camera.azimuthDeg = 75;
  s.view.render.camera.panMm = {1, 2, 3};
  s.view.view.sliceWindow = {300, 1500};
  s.crosshairMm = {4, 5, 6};
  s.hiddenLabels = {3, 7};
  s.lockedLabels = {4};
  writeSceneFile(s, dir / "scene.json");
  std::ifstream in(dir / "scene.json");
  const std::string text((std::istreambuf_iterator<char>(in)), {});
  EXPECT_NE(text.find("\"data/ct.nrrd\""), std::string::npos) << text;
  EXPECT_NE(text.find("\"version\": " + std::to_string(kSceneFormatVersion)), std::string::npos);
  const SceneFile r = readSceneFile(dir / "scene.json");
  EXPECT_EQ(r.volume, (dir / "data" / "ct.nrrd").lexically_normal());
  EXPECT_EQ(r.labels, (dir / "data" / "labels.nrrd").lexically_normal());
  EXPECT_EQ(r.view.view.layout, Layout::OneByThree);
  EXPECT_EQ(r.view.render.preset, render::Preset::Bone);
  EXPECT_EQ(r.view.render.camera.azimuthDeg, 75);
  EXPECT_EQ(r.view.render.camera.panMm, (Vec3{1, 2, 3}));
  EXPECT_EQ(r.view.view.sliceWindow, (WindowLevel{300, 1500}));
  EXPECT_EQ(r.crosshairMm, (Vec3{4, 5, 6}));
  EXPECT_EQ(r.hiddenLabels, (std::set<uint16_t>{3, 7}));
  EXPECT_EQ(r.lockedLabels, (std::set<uint16_t>{4}));
}

TEST(StudioSceneFile, MissingDataAndBadFilesGiveClearMessages) {
  const auto dir = test::tempDir("studio-scene-bad");
  {
    std::ofstream(dir / "missing.json") << R"({"format":"vellum-studio-scene","version":1,"volume":"gone.nrrd"})";
    std::ofstream(dir / "future.json") << R"({"format":"vellum-studio-scene","version":99,"volume":"x.nrrd"})";
    std::ofstream(dir / "junk.json") << "{ not json";
  }
  try {
    readSceneFile(dir / "missing.json");
    FAIL() << "no error";
  } catch (const FileError& e) {
    EXPECT_NE(std::string(e.what()).find("gone.nrrd"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("referenced by missing.json"), std::string::npos) << e.what();
  }
  EXPECT_THROW(readSceneFile(dir / "future.json"), FileError);
  EXPECT_THROW(readSceneFile(dir / "junk.json"), FileError);
}

TEST(StudioLoader, LoadsOnAWorkerReportsErrorsAndCancels) {
  const auto dir = test::tempDir("studio-loader");
  const auto ph = smallPhantom();
  io::saveVolume(AnyVolume(ph.ct), dir / "ct.nrrd");
  io::saveLabels(ph.labels, dir / "labels.nrrd");
  auto wait = [](Loader& l) {
    for (int i = 0; i < 3000; ++i) {
      if (auto r = l.take()) return *r;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    ADD_FAILURE() << "load did not finish";
    return LoadResult{};
  };
  Loader loader;
  ASSERT_TRUE(loader.start({dir / "ct.nrrd", dir / "labels.nrrd"}));
  const LoadResult ok = wait(loader);
  EXPECT_EQ(ok.error, "");
  EXPECT_EQ(ok.ct.dims(), ph.ct.dims());
  EXPECT_EQ(ok.labels.ids().voxels(), ph.labels.ids().voxels());

  ASSERT_TRUE(loader.start({dir / "missing.nrrd"}));
  const LoadResult bad = wait(loader);
  EXPECT_NE(bad.error.find("missing.nrrd"), std::string::npos) << bad.error;
  EXPECT_TRUE(bad.ct.empty());

  // Cancellation goes through vellum::Progress: a cancelled progress stops the io module.
  Progress cancelled;
  cancelled.cancel();
  EXPECT_THROW(loadNow({dir / "ct.nrrd"}, cancelled), Cancelled);
}

TEST(StudioRecentFiles, MostRecentFirstDeduplicatedAndKept) {
  const auto dir = test::tempDir("studio-recent");
  const auto storage = dir / "cfg" / "studio-recent.txt";
  {
    RecentFiles r(storage);
    for (int i = 0; i < 10; ++i) r.add(dir / ("f" + std::to_string(i) + ".nrrd"));
    r.add(dir / "f5.nrrd");
    ASSERT_EQ(r.paths().size(), RecentFiles::kMax);
    EXPECT_EQ(r.paths().front(), dir / "f5.nrrd");
    EXPECT_EQ(r.paths()[1], dir / "f9.nrrd");
  }
  const RecentFiles again(storage);  // the next session
  ASSERT_EQ(again.paths().size(), RecentFiles::kMax);
  EXPECT_EQ(again.paths().front(), dir / "f5.nrrd");
  EXPECT_TRUE(RecentFiles().paths().empty());
}

TEST(StudioMpr, PlanesMapPixelsToMmAndBack) {
  const auto ph = smallPhantom();
  const Vec3 cross{10, -5, 20};
  for (SliceAxis a : {SliceAxis::Axial, SliceAxis::Coronal, SliceAxis::Sagittal}) {
    const SlicePlane p = makePlane(a, ph.ct.geometry(), cross, 300, 200);
    const auto [px, py] = p.toPixel(cross);
    const Vec3 back = p.toMm(px, py);
    EXPECT_NEAR(norm(back - cross), 0.0, 1e-9) << sliceAxisName(a);
    // The whole volume fits: the field of view is 180 x 180 x 220 mm.
    EXPECT_GE(p.mmPerPixel * 200, a == SliceAxis::Axial ? 180.0 : 220.0);
  }
  // Axial: screen right is patient left (+x), screen down is posterior (+y).
  const SlicePlane ax = makePlane(SliceAxis::Axial, ph.ct.geometry(), cross, 300, 200);
  EXPECT_GT(ax.toMm(200, 100).x, ax.toMm(100, 100).x);
  EXPECT_GT(ax.toMm(100, 150).y, ax.toMm(100, 50).y);
  SliceStyle style;
  style.labels = &ph.labels;
  const RgbaImage img = renderSlice(ph.ct, ax, style);
  EXPECT_EQ(img.width, 300);
  EXPECT_EQ(img.height, 200);
}

// Slice views zoom about the pointer and pan with it (Ctrl+wheel, middle-drag); the letters
// name the patient directions at each edge (radiological convention).
TEST(StudioMpr, ZoomKeepsThePointUnderThePointerAndPanFollowsIt) {
  const auto ph = smallPhantom();
  const Geometry& g = ph.ct.geometry();
  const SlicePlane fit = makePlane(SliceAxis::Coronal, g, g.center(), 400, 300);
  SliceNavigation nav;
  EXPECT_LT(norm(navigated(fit, nav).toMm(17, 33) - fit.toMm(17, 33)), 1e-12) << "no zoom, no pan: the fit";
  const Vec3 under = fit.toMm(100, 50);
  nav = zoomedAbout(fit, nav, 2.0, 100, 50);
  const SlicePlane zoomed = navigated(fit, nav);
  EXPECT_NEAR(zoomed.mmPerPixel, fit.mmPerPixel / 2, 1e-12);
  EXPECT_LT(norm(zoomed.toMm(100, 50) - under), 1e-9) << "the position under the pointer stays";
  EXPECT_GT(norm(zoomed.toMm(300, 250) - fit.toMm(300, 250)), 1.0) << "elsewhere the picture is magnified";
  // A second zoom about another pixel composes.
  const Vec3 under2 = zoomed.toMm(350, 280);
  nav = zoomedAbout(fit, nav, 1.5, 350, 280);
  EXPECT_LT(norm(navigated(fit, nav).toMm(350, 280) - under2), 1e-9);
  // Panning: what was under the pointer follows it.
  const Vec3 grabbed = navigated(fit, nav).toMm(200, 150);
  nav = pannedBy(fit, nav, 30, -20);
  EXPECT_LT(norm(navigated(fit, nav).toMm(230, 130) - grabbed), 1e-9);
  // The plane stays the crosshair's: panning and zooming move within it.
  EXPECT_NEAR(dot(navigated(fit, nav).center - fit.center, fit.normal), 0.0, 1e-9);
  for (int i = 0; i < 20; ++i) nav = zoomedAbout(fit, nav, 2.0, 0, 0);
  EXPECT_EQ(nav.zoom, 64.0) << "zoom is bounded";

  using L = std::array<std::string, 4>;  // left, right, top, bottom
  EXPECT_EQ(orientationLetters(makePlane(SliceAxis::Axial, g, g.center(), 100, 100)), (L{"R", "L", "A", "P"}));
  EXPECT_EQ(orientationLetters(makePlane(SliceAxis::Coronal, g, g.center(), 100, 100)), (L{"R", "L", "S", "I"}));
  EXPECT_EQ(orientationLetters(makePlane(SliceAxis::Sagittal, g, g.center(), 100, 100)), (L{"A", "P", "S", "I"}));
  EXPECT_FALSE(windowPresets().empty());
}

// The task queue runs the studio's long edits one at a time on a worker, in the order they were
// asked for; their results are applied by the thread that polls (the UI thread); an edit asked
// for while one runs waits, a failure or a cancel is reported by name and the next still runs.
TEST(StudioTaskQueue, RunsInOrderAppliesOnThePollingThreadReportsAndCancels) {
  TaskQueue queue;
  std::vector<std::string> applied, errors;
  std::vector<std::thread::id> appliedOn;
  const auto onError = [&](const std::string& e) { errors.push_back(e); };
  const auto pollUntilIdle = [&] {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    while (queue.busy() && std::chrono::steady_clock::now() < deadline) {
      queue.poll(onError);
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  };
  const auto record = [&](const std::string& name) {
    return TaskQueue::Apply([&, name] {
      applied.push_back(name);
      appliedOn.push_back(std::this_thread::get_id());
    });
  };
  std::atomic<bool> release{false};
  std::atomic<std::thread::id> workerThread;
  queue.push("a", [&](Progress&) {
    workerThread = std::this_thread::get_id();
    while (!release) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    return record("a");
  });
  queue.push("b", [&](Progress&) { return record("b"); });
  EXPECT_TRUE(queue.busy());
  queue.poll(onError);  // starts "a"
  EXPECT_EQ(queue.running(), "a");
  EXPECT_EQ(queue.waiting(), 1u);
  queue.push("c", [&](Progress&) { return record("c"); });  // asked for while "a" runs: queued
  for (int i = 0; i < 20; ++i) queue.poll(onError);
  EXPECT_TRUE(applied.empty()) << "nothing is applied before it has finished";
  EXPECT_EQ(queue.waiting(), 2u);
  release = true;
  pollUntilIdle();
  EXPECT_EQ(applied, (std::vector<std::string>{"a", "b", "c"}));
  for (const auto& id : appliedOn) EXPECT_EQ(id, std::this_thread::get_id()) << "applied on the polling thread";
  EXPECT_NE(workerThread.load(), std::this_thread::get_id()) << "the work ran on a worker";
  EXPECT_TRUE(errors.empty());

  applied.clear();
  queue.push("bad", [](Progress&) -> TaskQueue::Apply { throw Error("no room"); });
  queue.push("slow", [&](Progress& p) {
    p.begin("slow", 100000);
    for (int i = 0; i < 100000; ++i) {
      std::this_thread::sleep_for(std::chrono::microseconds(100));
      p.advance();  // throws once cancelled
    }
    return record("slow");
  });
  queue.push("after", [&](Progress&) { return record("after"); });
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (queue.running() != "slow" && std::chrono::steady_clock::now() < deadline) {
    queue.poll(onError);
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ASSERT_EQ(queue.running(), "slow");
  queue.cancel();
  pollUntilIdle();
  EXPECT_EQ(errors, (std::vector<std::string>{"bad: no room", "slow cancelled"}));
  EXPECT_EQ(applied, (std::vector<std::string>{"after"})) << "a cancelled task changes nothing; the next runs";
}

// Two undo deltas hold the same runs: where, how long, the ids before and after.
void expectSameRuns(const LabelDelta& got, const LabelDelta& truth) {
  ASSERT_EQ(got.runs.size(), truth.runs.size());
  for (size_t i = 0; i < truth.runs.size(); ++i) {
    EXPECT_EQ(got.runs[i].start, truth.runs[i].start);
    EXPECT_EQ(got.runs[i].length, truth.runs[i].length);
    EXPECT_EQ(got.runs[i].before, truth.runs[i].before);
    EXPECT_EQ(got.runs[i].after, truth.runs[i].after);
  }
}

// A brush stroke's undo step from the voxels it changed equals the diff of whole copies.
TEST(StudioLabelTools, StrokeDeltaEqualsTheDiffOfCopies) {
  const auto ph = smallPhantom();
  LabelVolume labels = ph.labels;
  const LabelVolume before = labels;
  std::vector<std::pair<uint64_t, uint16_t>> changed;
  int64_t n = 0;
  for (int s = 0; s < 6; ++s) n += paintSphere(labels, {-20.0 + 8 * s, 5, 3 * s}, 9.0, 7, {}, &changed);
  ASSERT_GT(n, 0);
  EXPECT_EQ(changed.size(), static_cast<size_t>(n)) << "each voxel reported once";
  const LabelDelta stroke = strokeDelta(changed, before.table(), labels, "paint");
  const LabelDelta diff = diffLabels(before, labels, "paint");
  expectSameRuns(stroke, diff);
  EXPECT_EQ(stroke.tableBefore, diff.tableBefore);
  EXPECT_EQ(stroke.tableAfter, diff.tableAfter);
  applyDelta(labels, stroke, false);
  EXPECT_EQ(labels.ids().voxels(), before.ids().voxels());
}

// What the worker computes (diffEdit: the labels untouched) is the edit recordEdit makes.
TEST(StudioLabelTools, DiffEditOnAWorkerEqualsTheEditInPlace) {
  const auto ph = smallPhantom();
  LabelVolume inPlace(ph.ct.geometry());
  const auto threshold = [&](LabelVolume& l) {
    thresholdInto(l, ph.ct, segmentation::presetInterval(segmentation::Preset::Bone), {1, "bone", {255, 255, 255}});
    removeIslands(l, 1, 50);
  };
  const LabelVolume before = inPlace;
  const LabelDelta d1 = recordEdit(inPlace, "threshold", threshold);
  LabelVolume untouched(ph.ct.geometry());
  const LabelDelta d2 = diffEdit(untouched, "threshold", threshold);
  EXPECT_EQ(untouched.ids().voxels(), before.ids().voxels()) << "diffEdit leaves the labels alone";
  ASSERT_FALSE(d2.empty());
  applyDelta(untouched, d2, true);
  EXPECT_EQ(untouched.ids().voxels(), inPlace.ids().voxels());
  EXPECT_EQ(untouched.table(), inPlace.table());
  EXPECT_EQ(d1.runs.size(), d2.runs.size());
}

// The studio's label commands build their undo delta from the operation's own footprint, never
// copying the map (issue #22). Each must equal the segmentation module's whole-map operation
// (locked voxels put back), as a delta too (the runs diffLabels finds), and undo exactly.
TEST(StudioLabelTools, FootprintDeltasEqualTheWholeMapEditAndUndoExactly) {
  namespace seg = segmentation;
  const auto ph = smallPhantom();
  // Skin (1) and the locked femur cortex (4) of the phantom's truth; the rest background.
  LabelVolume labels = ph.labels;
  for (auto& v : labels.ids().voxels())
    if (v != 1 && v != 4) v = 0;
  const std::set<uint16_t> locked{4};
  const uint16_t id = 12;
  const Label bone{id, "bone", {9, 9, 9}};
  const auto wholeMap = [&](const std::function<void(LabelVolume&)>& edit) {
    LabelVolume r = labels;
    edit(r);
    auto& a = r.ids().voxels();
    const auto& b = labels.ids().voxels();
    for (size_t n = 0; n < a.size(); ++n)
      if (locked.count(a[n]) || locked.count(b[n])) a[n] = b[n];
    return r;
  };
  const auto reshape = [&](LabelVolume& r, const seg::Mask& m) {  // the old in-place rule
    auto& ids = r.ids().voxels();
    for (size_t n = 0; n < ids.size(); ++n) {
      if (ids[n] == id && !m.voxels()[n]) ids[n] = 0;
      else if (ids[n] == 0 && m.voxels()[n]) ids[n] = id;
    }
  };
  int step = 0;
  const auto check = [&](const LabelDelta& d, const LabelVolume& expected) {
    SCOPED_TRACE("step " + std::to_string(step++));
    const LabelDelta truth = diffLabels(labels, expected, "");
    expectSameRuns(d, truth);
    // The delta holds the changed voxels' runs, not the map.
    EXPECT_LT(d.bytes(), labels.ids().size() * sizeof(uint16_t) / 4);
    const LabelVolume before = labels;
    applyDelta(labels, d, true);
    EXPECT_EQ(labels.ids().voxels(), expected.ids().voxels());
    EXPECT_EQ(labels.table(), expected.table());
    applyDelta(labels, d, false);
    EXPECT_EQ(labels.ids().voxels(), before.ids().voxels());
    EXPECT_EQ(labels.table(), before.table());
    applyDelta(labels, d, true);
  };
  const auto iv = seg::presetInterval(seg::Preset::Bone);
  check(thresholdDelta(labels, ph.ct, iv, bone, locked),
        wholeMap([&](LabelVolume& r) { seg::addSegment(r, seg::threshold(ph.ct, iv), bone); }));
  // A ball against the grid's corner (the segment's box reaches the border) with a closed
  // cavity, and a separate island that outlives Remove islands but not Keep largest.
  const Vec3 corner = labels.geometry().indexToPhysical({2, 2, 2});
  paintSphere(labels, corner, 14.0, id);
  paintSphere(labels, corner, 5.0, 0);
  paintSphere(labels, labels.geometry().indexToPhysical({40, 8, 40}), 7.0, id);
  check(removeIslandsDelta(labels, id, 300.0, locked), wholeMap([&](LabelVolume& r) {
          reshape(r, seg::removeSmallIslands(seg::segmentMask(r, id), 300.0));
        }));
  check(fillHolesDelta(labels, id, locked), wholeMap([&](LabelVolume& r) {
          seg::addSegment(r, seg::fillHoles(seg::segmentMask(r, id)), bone, seg::OverlapRule::KeepExisting);
        }));
  for (auto op : {Morphology::Close, Morphology::Dilate, Morphology::Open, Morphology::Erode}) {
    check(morphologyDelta(labels, id, op, 6.0, locked), wholeMap([&](LabelVolume& r) {
            const seg::Mask m = seg::segmentMask(r, id);
            reshape(r, op == Morphology::Close    ? seg::close(m, 6.0)
                       : op == Morphology::Dilate ? seg::dilate(m, 6.0)
                       : op == Morphology::Open   ? seg::open(m, 6.0)
                                                  : seg::erode(m, 6.0));
          }));
  }
  check(keepLargestDelta(labels, id, locked), wholeMap([&](LabelVolume& r) {
          reshape(r, seg::keepLargestComponent(seg::segmentMask(r, id)));
        }));
  EXPECT_GT(labels.histogram()[id], 100u);
  EXPECT_TRUE(keepLargestDelta(labels, 99, locked).empty()) << "an absent segment changes nothing";
}

}  // namespace
}  // namespace vellum::studio

namespace vellum::studio {
TEST(StudioAuthoring, KeyframesReorderKeepingTheTimeline) {
  Authoring a;
  const auto pose = [](double x) { return deformation::ControlPoints{{{0, 0, 0}, {x, 0, 0}, {}}}; };
  a.track.keyframes = {{1.0, pose(0)}, {2.0, pose(5)}, {3.0, pose(9)}};
  a.keyframe = 1;
  moveKeyframe(a, 1, +1);
  EXPECT_EQ(a.keyframe, 2);
  EXPECT_EQ(a.track.keyframes[2].points[0].target.x, 5);
  EXPECT_EQ(a.track.keyframes[1].points[0].target.x, 9);
  EXPECT_EQ(a.track.keyframes[1].durationS, 2.0) << "durations stay in place";
  EXPECT_EQ(a.track.keyframes[2].durationS, 3.0);
  moveKeyframe(a, 2, -1);
  moveKeyframe(a, 1, -1);
  EXPECT_EQ(a.keyframe, 0);
  EXPECT_EQ(a.track.keyframes[0].points[0].target.x, 5);
  EXPECT_THROW(moveKeyframe(a, 0, -1), Error);
  EXPECT_THROW(moveKeyframe(a, 7, 1), Error);
  // Dragged over several places: poses 5, 0, 9 -> K2's pose first, the others shift later.
  moveKeyframeTo(a, 2, 0);
  EXPECT_EQ(a.keyframe, 0);
  EXPECT_EQ(a.track.keyframes[0].points[0].target.x, 9);
  EXPECT_EQ(a.track.keyframes[1].points[0].target.x, 5);
  EXPECT_EQ(a.track.keyframes[2].points[0].target.x, 0);
  moveKeyframeTo(a, 0, 2);  // and back
  EXPECT_EQ(a.track.keyframes[0].points[0].target.x, 5);
  EXPECT_EQ(a.track.keyframes[2].points[0].target.x, 9);
  EXPECT_EQ(a.track.keyframes[0].durationS, 1.0);
  EXPECT_EQ(a.track.keyframes[2].durationS, 3.0);
  EXPECT_THROW(moveKeyframeTo(a, 0, 3), Error);
  EXPECT_THROW(moveKeyframeTo(a, -1, 0), Error);
}

// The meshes of a `vellum shape` folder for the 3D view: named and given label ids by
// shape.json, coloured by the segment table, PLY only; hidden when all of their ids are.
TEST(SegmentMeshes, LoadFromAShapeFolderAndHideByLabels) {
  namespace fs = std::filesystem;
  const fs::path dir = test::tempDir("segment-meshes");
  fs::create_directories(dir / "meshes");
  illustration::TriMesh tet;
  tet.vertices = {{0, 0, 0}, {10, 0, 0}, {0, 10, 0}, {0, 0, 10}};
  tet.faces = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  illustration::saveMesh(tet, dir / "meshes" / "femur bone.ply", "ply");
  illustration::saveMesh(tet, dir / "meshes" / "tibia.obj", "obj");
  std::ofstream(dir / "shape.json") << R"({"segments":[{"name":"femur bone","ids":[4,5]},{"name":"tibia","ids":[6]}]})";
  Geometry g;
  g.dims = {4, 4, 4};
  LabelVolume segments(g);
  segments.setLabel({1, "femur bone", {10, 20, 30}});
  const SegmentMeshes meshes = loadSegmentMeshes(dir, segments);
  ASSERT_EQ(meshes.size(), 1u) << "the OBJ segment is left out";
  EXPECT_EQ(meshes[0].name, "femur bone");
  EXPECT_EQ(meshes[0].labelIds, (std::vector<uint16_t>{4, 5}));
  EXPECT_EQ(meshes[0].rgb, (std::array<uint8_t, 3>{10, 20, 30}));
  EXPECT_EQ(meshes[0].mesh.faces.size(), 4u);
  const auto surface = toSurfaceMeshes(meshes);
  ASSERT_EQ(surface.size(), 1u);
  EXPECT_EQ(surface[0].positionsMm.size(), 12u);
  EXPECT_FLOAT_EQ(surface[0].positionsMm[3], 10.f);
  EXPECT_EQ(surface[0].triangles, (std::vector<uint32_t>{0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3}));
  EXPECT_FLOAT_EQ(surface[0].rgb[2], 30.f / 255.f);
  EXPECT_EQ(visibleMeshes(meshes, {4}), std::vector<bool>{true}) << "one of its ids still shows";
  EXPECT_EQ(visibleMeshes(meshes, {4, 5, 9}), std::vector<bool>{false});
  // Without shape.json: every PLY, no ids (never hidden).
  fs::remove(dir / "shape.json");
  const SegmentMeshes bare = loadSegmentMeshes(dir, segments);
  ASSERT_EQ(bare.size(), 1u);
  EXPECT_TRUE(bare[0].labelIds.empty());
  EXPECT_EQ(visibleMeshes(bare, {4, 5}), std::vector<bool>{true});
  // A broken report names itself.
  std::ofstream(dir / "shape.json") << "{\"segments\": 3";
  try {
    loadSegmentMeshes(dir, segments);
    FAIL() << "no error";
  } catch (const FileError& e) {
    EXPECT_NE(std::string(e.what()).find("shape.json"), std::string::npos) << e.what();
  }
}

}  // namespace vellum::studio
