// The figure commands as app calls (shape_pipeline, illustrate_pipeline, render_pipeline):
// named views, one call drawing several styles / presets and views from one upload whose files
// are the single calls' files byte for byte, plates made of the same tiles, and the shape
// folder with its report.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>

#include "test_volumes.hpp"
#include "image_compare.hpp"
#include "shape_fixtures.hpp"
#include "test_data.hpp"
#include "vellum/app/illustrate_pipeline.hpp"
#include "vellum/app/render_pipeline.hpp"
#include "vellum/app/shape_pipeline.hpp"
#include "vellum/core/error.hpp"
#include "vellum/io/volume_io.hpp"

using namespace vellum;
namespace fs = std::filesystem;

namespace {

/// The tile at (column, row) of a plate of w x h tiles.
RgbaImage tileOf(const RgbaImage& plate, int column, int row, int w, int h) {
  RgbaImage t(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) std::copy(plate.at(column * w + x, row * h + y), plate.at(column * w + x, row * h + y) + 4, t.at(x, y));
  return t;
}

std::string readAll(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

nlohmann::json readJson(const fs::path& p) { return nlohmann::json::parse(readAll(p)); }

}  // namespace

TEST(FigureViews, NamedAndNumericViews) {
  const app::FigureView a = app::parseView("anterior", 15);
  EXPECT_EQ(a.name, "anterior");
  EXPECT_EQ(a.azimuthDeg, 0);
  EXPECT_EQ(a.elevationDeg, 0);  // a named view is that view, whatever --elevation says
  const app::FigureView l = app::parseView("lateral", 15);
  EXPECT_EQ(l.azimuthDeg, 90);  // from the patient's left, as `left`
  EXPECT_EQ(app::parseView("right", 0).azimuthDeg, -90);
  EXPECT_EQ(app::parseView("posterior", 0).azimuthDeg, 180);
  EXPECT_GT(app::parseView("superior", 0).elevationDeg, 80);
  EXPECT_LT(app::parseView("inferior", 0).elevationDeg, -80);
  const app::FigureView n = app::parseView("30", 15);  // AZ keeps the elevation
  EXPECT_EQ(n.name, "az30");
  EXPECT_EQ(n.azimuthDeg, 30);
  EXPECT_EQ(n.elevationDeg, 15);
  const app::FigureView ne = app::parseView("-45:12.5", 15);
  EXPECT_EQ(ne.name, "az-45el12.5");
  EXPECT_EQ(ne.azimuthDeg, -45);
  EXPECT_EQ(ne.elevationDeg, 12.5);
  for (const char* bad : {"front", "", "30:", "x:10", "30:10:5", "nan"}) {
    try {
      app::parseView(bad, 0);
      ADD_FAILURE() << "accepted '" << bad << "'";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("--view"), std::string::npos) << e.what();
    }
  }
  EXPECT_EQ(app::splitList("textbook,pen", "--preset"), (std::vector<std::string>{"textbook", "pen"}));
  EXPECT_THROW(app::splitList("textbook,,pen", "--preset"), Error);
  EXPECT_THROW(app::splitList("textbook,", "--preset"), Error);
  EXPECT_EQ(app::figurePath("out/fig.png", {"pen", "lateral"}), fs::path("out/fig-pen-lateral.png"));
  EXPECT_EQ(app::figurePath("out/fig.png", {}), fs::path("out/fig.png"));
}

TEST(IllustratePipeline, SeveralStylesAndViewsFromOneUploadEqualTheSingleCalls) {
  const auto dir = test::tempDir("illustrate-multi");
  const illustration::ShapeScene scene = test::nestedScene(32);
  test::writeShapeFolder(scene, dir / "shape");
  io::saveVolume(VolumeI16(scene.distance.geometry(), -1000, -1000), dir / "ct.nrrd");
  app::IllustrateRequest r;
  r.input = dir / "ct.nrrd";
  r.shape = dir / "shape";
  r.settings.render.width = 64;
  r.settings.render.height = 48;
  r.annotations.scaleBar = true;
  r.presets = {"textbook", "pen"};
  r.views = {app::parseView("anterior", 0), app::parseView("lateral", 0)};
  r.output = dir / "multi" / "fig.png";
  r.report = dir / "multi.json";
  const app::IllustrateResult multi = app::runIllustrate(r);
  ASSERT_EQ(multi.figures.size(), 4u);
  const std::vector<fs::path> expected{dir / "multi" / "fig-textbook-anterior.png", dir / "multi" / "fig-textbook-lateral.png",
                                       dir / "multi" / "fig-pen-anterior.png", dir / "multi" / "fig-pen-lateral.png"};
  for (size_t i = 0; i < expected.size(); ++i) {
    EXPECT_EQ(multi.figures[i].path, expected[i]);
    EXPECT_TRUE(fs::exists(expected[i])) << expected[i];
  }
  const nlohmann::json report = readJson(r.report);
  EXPECT_EQ(report["figures"].size(), 4u);
  EXPECT_EQ(report["figures"][3]["view"], "lateral");
  EXPECT_EQ(report["outputs"].size(), 4u);
  EXPECT_TRUE(report.contains("upload_ms"));

  // The single calls (a fresh upload each) write the same bytes.
  for (const auto& [preset, view, file] : {std::tuple{"textbook", "anterior", 0}, std::tuple{"pen", "lateral", 3}}) {
    app::IllustrateRequest one = r;
    one.presets = {preset};
    one.views = {app::parseView(view, 0)};
    one.output = dir / (std::string(preset) + ".png");
    one.report.clear();
    app::runIllustrate(one);
    EXPECT_EQ(readAll(one.output), readAll(expected[size_t(file)])) << preset << " " << view;
  }
  // A plate: a row per style, a column per view, of the same tiles.
  app::IllustrateRequest plate = r;
  plate.plate = true;
  plate.output = dir / "plate.png";
  plate.report.clear();
  app::runIllustrate(plate);
  const RgbaImage sheet = test::readPng(plate.output);
  ASSERT_EQ(sheet.width, 128);
  ASSERT_EQ(sheet.height, 96);
  EXPECT_EQ(tileOf(sheet, 1, 1, 64, 48).pixels, test::readPng(expected[3]).pixels);
  EXPECT_EQ(tileOf(sheet, 0, 1, 64, 48).pixels, test::readPng(expected[2]).pixels);

  // One style file saved from several styles is refused before anything is written.
  app::IllustrateRequest save = r;
  save.output = dir / "save" / "fig.png";
  save.saveStyle = dir / "style.json";
  EXPECT_THROW(app::runIllustrate(save), Error);
  EXPECT_FALSE(fs::exists(dir / "save"));
}

TEST(RenderPipeline, SeveralPresetsAndViewsFromOneUploadEqualTheSingleCalls) {
  const auto dir = test::tempDir("render-multi");
  Geometry g;
  g.dims = {32, 32, 32};
  g.spacing = {2, 2, 2};
  VolumeI16 ct(g, -1000, -1000);
  for (int64_t k = 0; k < 32; ++k)
    for (int64_t j = 0; j < 32; ++j)
      for (int64_t i = 0; i < 32; ++i) {
        const double r = std::hypot(i - 15.5, j - 13.5, k - 16.5);
        ct(i, j, k) = static_cast<int16_t>(r < 7 ? 1200 : r < 12 ? 40 : -1000);
      }
  io::saveVolume(ct, dir / "ct.nrrd");
  app::RenderRequest r;
  r.input = dir / "ct.nrrd";
  r.settings.width = 48;
  r.settings.height = 40;
  r.presets = {render::Preset::Bone, render::Preset::Skin};
  r.views = {app::parseView("anterior", 0), app::parseView("90:20", 0)};
  r.output = dir / "fig.png";
  r.report = dir / "multi.json";
  const app::RenderResult multi = app::runRender(r);
  ASSERT_EQ(multi.figures.size(), 4u);
  EXPECT_EQ(multi.figures[3].path, dir / "fig-skin-az90el20.png");
  EXPECT_EQ(readJson(r.report)["figures"].size(), 4u);
  app::RenderRequest one = r;
  one.presets = {render::Preset::Skin};
  one.views = {app::parseView("90:20", 0)};
  one.output = dir / "one.png";
  one.report.clear();
  app::runRender(one);
  EXPECT_EQ(readAll(one.output), readAll(dir / "fig-skin-az90el20.png"));
  // Without views: the settings' camera, one file per preset as before ("fig-bone.png").
  app::RenderRequest presets = r;
  presets.views.clear();
  presets.output = dir / "p" / "fig.png";
  presets.report.clear();
  const app::RenderResult pr = app::runRender(presets);
  ASSERT_EQ(pr.figures.size(), 2u);
  EXPECT_EQ(pr.figures[0].path, dir / "p" / "fig-bone.png");
  EXPECT_EQ(pr.figures[0].view, "");
}

TEST(ShapePipeline, WritesTheFolderAndItsReport) {
  const auto dir = test::tempDir("shape-pipeline");
  const Geometry g = test::grid({24, 24, 24}, {1.5, 1.5, 1.5});
  LabelVolume labels(g);
  labels.setLabel({1, "ball", {200, 180, 150}});
  test::fillWhere(labels, [](int64_t i, int64_t j, int64_t k) { return std::hypot(i - 11.5, j - 11.5, k - 11.5) < 7; }, 1);
  io::saveLabels(labels, dir / "labels.nrrd");
  io::saveVolume(VolumeI16(g, -1000, -1000), dir / "ct.nrrd");
  app::ShapeRequest r;
  r.input = dir / "ct.nrrd";
  r.labels = dir / "labels.nrrd";
  r.segments = {"ball=1"};
  r.shells = {{"ball", 1.5}};
  r.out = dir / "shape";
  r.report = dir / "shape-report.json";
  r.meshFormat = "stl";
  const app::ShapeResult s = app::runShape(r);
  ASSERT_EQ(s.shape.shapes.size(), 1u);
  EXPECT_TRUE(s.shape.shapes[0].checks.closed);
  for (const char* f : {"shape.json", "distance.nrrd", "segments.nrrd", "distances.json", "meshes/ball.stl"})
    EXPECT_TRUE(fs::exists(r.out / f)) << f;
  const nlohmann::json report = readJson(r.report);
  EXPECT_EQ(report["segments"][0]["name"], "ball");
  EXPECT_EQ(report["shells"][0]["thickness_mm"], 1.5);
  EXPECT_EQ(report["options"]["mesh_format"], "stl");
  EXPECT_TRUE(report.contains("outputs"));  // the shared keys (run_report.hpp)
  EXPECT_EQ(readJson(r.out / "shape.json")["segments"], report["segments"]);

  // Bad requests: one line naming the problem, nothing written.
  app::ShapeRequest bad = r;
  bad.out = dir / "bad";
  bad.report.clear();
  bad.meshFormat = "vrml";
  EXPECT_THROW(app::runShape(bad), Error);
  bad.meshFormat = "ply";
  bad.segments = {"ball=9"};
  EXPECT_THROW(app::runShape(bad), Error);
  EXPECT_FALSE(fs::exists(dir / "bad"));
}

// The lighting layer (docs/lighting.md): off, the figure is the one drawn without it whatever
// the other lighting fields say; on, a key light from the left of the view puts the right-hand
// sphere's light-facing side in the left sphere's shadow, while the left sphere's same side is
// in the open (both compared as lit / unlit, so the styles' colours cancel).
TEST(IllustratePipeline, LightingLayerOffIsUnchangedAndShadowsTheSphereBehind) {
  const auto dir = test::tempDir("illustrate-light");
  const illustration::ShapeScene scene = test::twoSpheres(32);
  test::writeShapeFolder(scene, dir / "shape");
  VolumeI16 ct(scene.distance.geometry(), -1000, -1000);
  const Dims d = ct.dims();
  for (int64_t k = 0; k < d.z; ++k)
    for (int64_t j = 0; j < d.y; ++j)
      for (int64_t i = 0; i < d.x; ++i)
        if (scene.segments(i, j, k) != 0) ct(i, j, k) = 1500;  // both spheres bone
  io::saveVolume(ct, dir / "ct.nrrd");
  app::IllustrateRequest r;
  r.input = dir / "ct.nrrd";
  r.shape = dir / "shape";
  r.settings.render.width = r.settings.render.height = 64;
  r.settings.render.camera = {0, 0, 1, {0, 0, 0}, 0};  // anterior, orthographic: the spheres side by side
  r.presets = {"dvr"};
  r.transparent = true;
  r.framing = illustration::Framing::Segments;
  r.output = dir / "absent.png";
  app::runIllustrate(r);
  app::IllustrateRequest off = r;
  off.output = dir / "off.png";
  off.settings.render.lighting.azimuthDeg = -90;  // lighting fields set, every term off
  off.settings.render.lighting.exposure = 1;
  off.settings.render.lighting.occlusionRadiusMm = 3;
  app::runIllustrate(off);
  EXPECT_EQ(readAll(off.output), readAll(r.output));

  app::IllustrateRequest on = off;
  on.output = dir / "on.png";
  on.settings.render.lighting = {};
  on.settings.render.lighting.shadows = 1;
  on.settings.render.lighting.azimuthDeg = -90;  // from the left of the view, level
  on.settings.render.lighting.elevationDeg = 0;
  app::runIllustrate(on);
  const RgbaImage plain = test::readPng(r.output), lit = test::readPng(on.output);
  // The middle row's two runs of figure: each sphere's left quarter, lit / plain.
  const int y = 32;
  std::vector<std::pair<int, int>> runs;
  for (int x = 0; x < 64; ++x)
    if (plain.at(x, y)[3] > 250) {
      if (runs.empty() || runs.back().second != x - 1) runs.push_back({x, x});
      runs.back().second = x;
    }
  ASSERT_EQ(runs.size(), 2u);
  auto ratio = [&](const std::pair<int, int>& run) {
    const int x = run.first + (run.second - run.first) / 4;
    double p = 0, l = 0;
    for (int c = 0; c < 3; ++c) p += plain.at(x, y)[c], l += lit.at(x, y)[c];
    return l / std::max(p, 1.0);
  };
  const double open = ratio(runs[0]), shadowed = ratio(runs[1]);
  EXPECT_GT(open, 0.6) << "the open side keeps most of its light";
  EXPECT_LT(shadowed, 0.75 * open) << "open " << open << " shadowed " << shadowed;
  EXPECT_EQ(lit.at(0, 0)[3], 0) << "the background stays transparent";
}
