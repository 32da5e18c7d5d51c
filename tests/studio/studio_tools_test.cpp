// Issue 22 §3-§4: Export figure and Copy CLI command (the same PNG from the studio and from
// the command it gives), the ruler and angle in mm and degrees on an anisotropic grid, and the
// 3D view's clipping box and segment filter in the renderer.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>

#include "studio_run.hpp"
#include "test_data.hpp"
#include "vellum/io/image_io.hpp"
#include "vellum/io/volume_io.hpp"
#include "vellum/phantom/phantom.hpp"
#include "vellum/render/gl_context.hpp"
#include "vellum/render/label_tint.hpp"
#include "vellum/render/volume_renderer.hpp"

namespace vellum::studio {
namespace {
namespace fs = std::filesystem;
using namespace vellum::test::studio;

// The figure the studio exports (through app::runRender, clip box, annotations and all) and
// the one `vellum render` writes from the copied command are the same file, byte for byte.
TEST(StudioTools, ExportedFigureIsWhatTheCopiedCommandWrites) {
  REQUIRE_DISPLAY();
  const fs::path d = test::tempDir("studio-figure");
  vellum::test::studio::writePhantom(d, 48);
  const std::string script = scriptOnPhantom(d) + R"(
    {"preset":"bone"},{"set":{"clip_max":[1,0.6,1],"azimuth":50}},
    {"export_figure":{"path":)" + q(d / "studio.png") + R"(,"size":[200,160],"scale_bar":true,"orientation":true,"labels":true}},
    {"copy_command":{"figure":)" + q(d / "cli.png") + R"(,"path":)" + q(d / "command.txt") + R"(,"size":[200,160],"scale_bar":true,"orientation":true,"labels":true}},
    {"quit":0}]})";
  const StudioRun r = runStudio(d, "figure", script);
  ASSERT_EQ(r.exitCode, 0) << r.output;
  std::string cmd;
  std::getline(std::ifstream(d / "command.txt"), cmd);
  ASSERT_EQ(cmd.rfind("vellum render ", 0), 0u) << "the clipboard holds the command: " << cmd;
  EXPECT_NE(cmd.find("--clip-max 1 0.6 1"), std::string::npos) << cmd;
  EXPECT_NE(cmd.find("--scale-bar --orientation --label-map"), std::string::npos) << cmd;
  std::string run = "cd / && \"";  // absolute paths: it runs from any folder
  run += VELLUM_CLI_EXE;
  run += "\"" + cmd.substr(6) + " > \"" + (d / "cli.log").string() + "\" 2>&1";
  ASSERT_EQ(std::system(run.c_str()), 0) << run << "\n" << slurp(d / "cli.log");
  const std::string studio = slurp(d / "studio.png"), cli = slurp(d / "cli.png");
  ASSERT_GT(studio.size(), 1000u);
  EXPECT_TRUE(studio == cli) << "the exported PNG and the command's differ";
  const RgbaImage img = io::loadImage(d / "studio.png");
  EXPECT_EQ(img.width, 200);
  EXPECT_EQ(img.height, 160);
}

// Points clicked in the coronal slice of a 0.7 x 0.7 x 2 mm grid: lengths and angles are
// physical (in voxel units they would be 23.3 and 53.1 degrees); deleting one keeps the other.
TEST(StudioTools, RulerAndAngleMeasureMillimetresAndDegreesOnAnAnisotropicGrid) {
  REQUIRE_DISPLAY();
  const fs::path d = test::tempDir("studio-measure");
  phantom::PhantomOptions o;
  o.dims = {40, 40, 24};
  o.spacing = {0.7, 0.7, 2.0};
  io::saveVolume(AnyVolume(phantom::makePhantom(o).ct), d / "ct.nrrd");
  const std::string script = R"({"actions":[{"open":)" + q(d / "ct.nrrd") + R"(},{"layout":"2x2"},
    {"measure":{"tool":"ruler","view":"coronal","points_voxel":[[10,20,6],[30,20,18]]}},
    {"measure":{"tool":"angle","view":"coronal","points_voxel":[[30,20,17],[20,20,12],[30,20,7]]}},
    {"screenshot":)" + q(d / "window.png") + R"(},
    {"measure":{"delete":1}},{"quit":0}]})";
  const StudioRun r = runStudio(d, "measure", script);
  ASSERT_EQ(r.exitCode, 0) << r.output;
  std::vector<std::pair<std::string, double>> lines;  // (text, value) as printed, in order
  const std::regex line(R"(measurement \d+: ([0-9.]+ (?:mm|deg)) ([0-9.]+))");
  for (std::sregex_iterator it(r.output.begin(), r.output.end(), line), end; it != end; ++it)
    lines.emplace_back((*it)[1].str(), std::stod((*it)[2].str()));
  ASSERT_EQ(lines.size(), 4u) << r.output;  // 1 | 1, 2 | 1 (after the delete)
  const double ruler = std::hypot(20 * 0.7, 12 * 2.0), angle = 2 * std::atan(10.0 / 7.0) * 180 / M_PI;
  EXPECT_NEAR(lines[0].second, ruler, 1e-6);
  EXPECT_EQ(lines[0].first, "27.8 mm");
  EXPECT_NEAR(lines[2].second, angle, 1e-6);
  EXPECT_EQ(lines[2].first, "110.0 deg");
  EXPECT_NEAR(lines[3].second, angle, 1e-6) << "deleting the ruler keeps the angle";
}

// Open RAW: a bare big-endian int16 file with a 16-byte header opened through the dialog's
// answers reads the right voxels and spacing; its header goes to the state folder, nothing is
// written beside the data.
TEST(StudioTools, OpenRawWritesItsHeaderInTheStateFolderNotBesideTheData) {
  REQUIRE_DISPLAY();
  const fs::path d = test::tempDir("studio-raw");
  fs::create_directories(d / "data");
  Geometry g;
  g.dims = {12, 10, 8};
  g.spacing = {0.5, 0.75, 2.0};
  VolumeI16 truth(g);
  std::string bytes(16, 'H');  // the header the dialog is told to skip
  for (int64_t k = 0; k < 8; ++k)
    for (int64_t j = 0; j < 10; ++j)
      for (int64_t i = 0; i < 12; ++i) {
        const int16_t v = int16_t(i * 100 - j * 7 + k * 300 - 1000);
        truth(i, j, k) = v;
        bytes.push_back(char(uint16_t(v) >> 8));  // big endian
        bytes.push_back(char(uint16_t(v) & 0xff));
      }
  std::ofstream(d / "data" / "scan.raw", std::ios::binary) << bytes;
  const std::string script = R"({"actions":[
    {"open_raw":{"path":)" + q(d / "data" / "scan.raw") + R"(,"dims":[12,10,8],"type":"int16","spacing":[0.5,0.75,2],"endian":"big","header":16}},
    {"quit":0}]})";
  const StudioRun r = runStudio(d, "raw", script);
  ASSERT_EQ(r.exitCode, 0) << r.output;
  const fs::path header = vellum::test::studio::stateHome(d) / "vellum" / "raw-headers" / "scan.nhdr";
  ASSERT_TRUE(fs::exists(header)) << r.output;
  int files = 0;
  for (const auto& e : fs::directory_iterator(d / "data")) files += e.is_regular_file();
  EXPECT_EQ(files, 1) << "only the data itself beside the data";
  io::LoadOptions outside;
  outside.allowOutsideData = true;  // it names the data by absolute path
  const io::LoadedVolume lv = io::loadVolume(header, outside);
  const VolumeI16& v = std::get<VolumeI16>(lv.volume);
  EXPECT_TRUE(v.geometry().approxEqual(g));
  EXPECT_EQ(v.voxels(), truth.voxels());
  // A layout that does not fit the file is refused, naming it.
  const std::string bad = R"({"actions":[
    {"open_raw":{"path":)" + q(d / "data" / "scan.raw") + R"(,"dims":[12,10,9],"type":"int16"}},{"quit":0}]})";
  const StudioRun rb = runStudio(d, "raw-bad", bad);
  EXPECT_NE(rb.exitCode, 0);
  EXPECT_NE(rb.output.find("scan.raw"), std::string::npos) << rb.output;
}

// Two bright cubes (labels 1 and 2) side by side along x. A clip box ending between them, or
// drawing label 1 only, leaves the second cube's pixels background and the first's unchanged.
TEST(StudioTools, ClipBoxAndSegmentFilterRemoveWhatIsOutside) {
  Geometry g;
  g.dims = {32, 24, 24};
  VolumeI16 ct(g, -1000, -1000);
  LabelVolume labels(ct.geometry());
  labels.setLabel({1, "left", {255, 0, 0}});
  labels.setLabel({2, "right", {0, 0, 255}});
  for (int64_t k = 6; k < 18; ++k)
    for (int64_t j = 6; j < 18; ++j)
      for (int64_t i = 0; i < 32; ++i)
        if ((i >= 3 && i < 12) || (i >= 20 && i < 29)) {
          ct(i, j, k) = 1500;
          labels.ids()(i, j, k) = i < 16 ? 1 : 2;
        }
  auto context = render::GlContext::createHeadless();
  render::VolumeRenderer renderer(*context);
  renderer.setVolume(AnyVolume(ct));
  const render::LabelTint tint = render::makeLabelTint(labels);
  renderer.setLabelTint(&tint);
  render::RenderSettings s;
  s.width = 96;
  s.height = 64;
  s.preset = render::Preset::Bone;
  s.camera.azimuthDeg = s.camera.elevationDeg = 0;  // from anterior: x across the picture
  s.camera.fieldOfViewDeg = 0;
  const RgbaImage full = renderer.render(s);
  // Which half of the picture each cube is in, and what is drawn there.
  const auto drawn = [](const RgbaImage& img, bool rightHalf) {
    int64_t n = 0;
    for (int y = 0; y < img.height; ++y)
      for (int x = rightHalf ? img.width / 2 : 0; x < (rightHalf ? img.width : img.width / 2); ++x) {
        const uint8_t* p = &img.pixels[(size_t(y) * size_t(img.width) + size_t(x)) * 4];
        n += (p[0] | p[1] | p[2]) != 0;
      }
    return n;
  };
  const auto sameHalf = [](const RgbaImage& a, const RgbaImage& b, bool rightHalf) {
    for (int y = 0; y < a.height; ++y)
      for (int x = rightHalf ? a.width / 2 : 0; x < (rightHalf ? a.width : a.width / 2); ++x)
        for (int c = 0; c < 4; ++c) {
          const size_t at = (size_t(y) * size_t(a.width) + size_t(x)) * 4 + size_t(c);
          if (std::abs(int(a.pixels[at]) - int(b.pixels[at])) > 1) return false;
        }
    return true;
  };
  ASSERT_GT(drawn(full, false), 100);  // each cube about 12 x 16 pixels
  ASSERT_GT(drawn(full, true), 100);
  // Seen from anterior the patient's left (+x, the second cube) is on the picture's right.
  render::RenderSettings clipped = s;
  clipped.clipMax = {0.5, 1, 1};  // x < 15.5 mm: the first cube only
  const RgbaImage c = renderer.render(clipped);
  EXPECT_EQ(drawn(c, true), 0) << "what lies outside the clip box is not drawn";
  EXPECT_TRUE(sameHalf(c, full, false)) << "what lies inside is drawn as before";
  render::RenderSettings only = s;
  only.onlyLabel = 1;
  const RgbaImage o = renderer.render(only);
  EXPECT_EQ(drawn(o, true), 0) << "label 2 is not drawn";
  EXPECT_TRUE(sameHalf(o, full, false)) << "label 1 is drawn as before";
}

}  // namespace
}  // namespace vellum::studio
