// The studio at real size (issue #22): the 3D view's tiled refinement draws the pixels of one
// whole render, and the snake's Pause / Accept current keeps the contour shown when accepted.
// Issue #24: the cinematic view at rest converges to one render's picture.
#include <gtest/gtest.h>

#include <cstdlib>
#include <regex>
#include <string>

#include "studio_run.hpp"
#include "test_data.hpp"
#include "view3d.hpp"
#include "vellum/io/volume_io.hpp"
#include "vellum/phantom/phantom.hpp"

namespace vellum::studio {
namespace {
namespace fs = std::filesystem;
using namespace vellum::test::studio;

TEST(StudioRealSize, TiledRefinementGivesTheOneRenderPicture) {
  Scene scene = boneScene();
  auto context = render::GlContext::createHeadless();
  View3D view(*context);
  view.setVolume(scene.ct);
  // A budget no tile fits: every band is kTileRows rows cut into the narrowest column tiles.
  view.setRefineBudgetMs(1e-6);
  const int w = 72, h = 50;
  int frames = 0;
  while (!view.refined() && frames < 1000) {
    view.update(scene, w, h, false);
    ++frames;
  }
  ASSERT_TRUE(view.refined());
  const int bands = (h + View3D::kTileRows - 1) / View3D::kTileRows;
  EXPECT_GT(view.refineTiles(), bands) << "the bands were cut into column tiles";
  const RgbaImage tiled = view.readShown();
  const RgbaImage whole = view.renderImage(scene, w, h);
  ASSERT_EQ(tiled.width, w);
  ASSERT_EQ(tiled.height, h);
  EXPECT_TRUE(tiled.pixels == whole.pixels) << "tiles differ from the whole render";
}

TEST(StudioCinematic, RestingAddsSamplesUpToTheRenderPicture) {
  // Issue #24: at rest the cinematic view adds samples frame by frame (a budget no sample fits:
  // each sample a band of rows per frame), ends on exactly the picture of one render, and a
  // camera change starts again.
  phantom::PhantomOptions o;
  o.dims = {32, 32, 36};
  Scene scene;
  scene.ct = phantom::makePhantom(o).ct;
  scene.resetView();
  scene.render.quality = render::Quality::Cinematic;
  scene.render.cinematic.samples = 4;
  auto context = render::GlContext::createHeadless();
  View3D view(*context);
  view.setVolume(scene.ct);
  view.setRefineBudgetMs(1e-6);
  const int w = 40, h = 30;
  ASSERT_TRUE(view.cinematic(scene));
  view.update(scene, w, h, false);  // a new view: the coarse ray-cast frame first
  EXPECT_EQ(view.cinematicSamples(), 0);
  std::vector<int> samples;  // the distinct counts shown, in order
  int frames = 0, guideFrames = 0;
  for (; !view.refined() && frames < 1000; ++frames) {
    view.update(scene, w, h, false);
    if (samples.empty() || samples.back() != view.cinematicSamples()) samples.push_back(view.cinematicSamples());
    guideFrames += view.cinematicGuideProgress() < 1;
  }
  ASSERT_TRUE(view.refined());
  EXPECT_EQ(samples, (std::vector<int>{0, 1, 2, 3, 4}));
  EXPECT_GT(guideFrames, 2) << "the denoise guide's ray cast drawn in bands, not in one frame";
  EXPECT_EQ(view.cinematicGuideProgress(), 1.0);
  EXPECT_GT(frames, 4 * 2) << "each sample drawn in bands over several frames";
  EXPECT_FALSE(view.update(scene, w, h, false)) << "converged: nothing more to do at rest";
  const RgbaImage rested = view.readShown();
  ASSERT_EQ(rested.width, w);
  EXPECT_TRUE(rested.pixels == view.renderImage(scene, w, h).pixels) << "not the picture of `vellum render`";
  scene.render.camera.azimuthDeg += 20;
  view.update(scene, w, h, false);
  EXPECT_FALSE(view.refined());
  EXPECT_EQ(view.cinematicSamples(), 0);
  for (frames = 0; view.cinematicSamples() == 0 && frames < 1000; ++frames) view.update(scene, w, h, false);
  EXPECT_EQ(view.cinematicSamples(), 1) << "restarted from one sample";
}

TEST(StudioRealSize, SnakePauseThenAcceptKeepsTheContourShown) {
  if (!std::getenv("DISPLAY")) GTEST_SKIP() << "no DISPLAY (run under xvfb-run -a)";
  const fs::path d = test::tempDir("studio-snake-accept");
  vellum::test::studio::writePhantom(d, 64);
  // The SnakeFromAClickedSeed session, paused at its first live contour, held for a while,
  // then accepted: the label is that contour, however long the pause.
  const StudioRun r = runStudio(d, "snake", R"({"actions":[{"open":)" + q(d / "ct.nrrd") + R"(},
      {"threshold":{"preset":"soft-tissue","label":5,"apply":false}},{"tool":"snake"},
      {"click":[430,175]},{"snake_control":"pause"},{"frames":30},{"snake_control":"accept"},
      {"save_labels":)" + q(d / "s1.nrrd") + R"(},{"quit":0}]})");
  ASSERT_EQ(r.exitCode, 0) << r.output;
  std::smatch paused, accepted;
  ASSERT_TRUE(std::regex_search(r.output, paused, std::regex(R"(snake paused at iteration (\d+) \(1/1 resolution\) \((\d+) voxels\))")))
      << r.output;
  ASSERT_TRUE(std::regex_search(r.output, accepted, std::regex(R"(accepted the contour at iteration (\d+) at full resolution)")))
      << r.output;
  EXPECT_EQ(paused[1], accepted[1]) << "the snake did not move while paused";
  const auto h1 = io::loadLabels(d / "s1.nrrd").histogram();
  ASSERT_GE(h1.size(), 6u) << r.output;
  EXPECT_EQ(std::to_string(h1[5]), paused[2].str()) << "the label is the contour shown at the pause";
}

}  // namespace
}  // namespace vellum::studio
