// Image-space refinement (IllustrationSettings::refineLevels, illustration/src/image_refine.hpp):
// the refined figure against the exact one (a ray through every pixel), GL against the CPU
// reference refining alike, and every inked pixel traced, not interpolated. Small scenes.
#include <gtest/gtest.h>

#include <cstdlib>
#include <iostream>

#include "headless_gl.hpp"
#include "image_compare.hpp"
#include "shape_fixtures.hpp"
#include "vellum/illustration/illustration_renderer.hpp"
#include "vellum/illustration/style.hpp"

namespace vellum::illustration {
namespace {

/// Three-quarter view in perspective (curved silhouettes, shading across the image), opaque
/// paper background as the CLI draws it.
IllustrationSettings view(int size, int levels) {
  IllustrationSettings s;
  s.render.width = s.render.height = size;
  s.render.camera.azimuthDeg = 30;
  s.render.camera.elevationDeg = 15;
  s.render.background = {0.96f, 0.95f, 0.9f, 1.f};
  s.refineLevels = levels;
  s.refineTolerance = 4.f / 255.f;  // the CLI's default
  return s;
}

void maybeSave(const RgbaImage& img, const std::string& name) {
  if (const char* dir = std::getenv("VELLUM_ILLUSTRATION_PNG_DIR"); dir && *dir) {
    std::filesystem::create_directories(dir);
    test::writePng(img, std::filesystem::path(dir) / (name + ".png"));
  }
}

int maxChannelDiff(const RgbaImage& a, const RgbaImage& b, int x, int y) {
  int m = 0;
  for (int c = 0; c < 4; ++c) m = std::max(m, std::abs(int(a.at(x, y)[c]) - int(b.at(x, y)[c])));
  return m;
}

TEST(IllustrationRefine, MatchesTheExactFigureAndTheCpuReference) {
  IllustrationRenderer r(test::headlessGl());
  r.setScene(test::nestedScene48());
  const Style st = stylePreset("textbook");  // ink outline on the invisible skin, translucent muscle
  const RgbaImage exact = r.render(st, view(192, 0));
  EXPECT_DOUBLE_EQ(r.lastTracedFraction(), 1.0);
  const RgbaImage refined = r.render(st, view(192, 2));
  const double traced = r.lastTracedFraction();
  maybeSave(exact, "refine-exact");
  maybeSave(refined, "refine-2");
  const test::ImageDiff d = test::compareImages(refined, exact);
  std::cout << "[ refine ] traced " << traced << " rays a pixel; vs exact: max " << d.maxAbs << "  psnr " << d.psnr
            << " dB\n";
  EXPECT_LT(traced, 0.8) << "refinement must skip rays";
  EXPECT_GE(d.psnr, 40.0);
  for (int c = 0; c < 4; ++c) EXPECT_LE(d.meanAbs[c], 0.5) << "channel " << c;
  // The CPU reference refines alike (same levels, tolerance and near-ink test).
  const RgbaImage cpu = renderIllustrationCpu(test::nestedScene48(), st, view(192, 2));
  const test::ImageDiff dc = test::compareImages(refined, cpu);
  std::cout << "[ refine ] GL vs CPU: max " << dc.maxAbs << "  psnr " << dc.psnr << " dB\n";
  EXPECT_GE(dc.psnr, 40.0);
  for (int c = 0; c < 4; ++c) EXPECT_LE(dc.meanAbs[c], 1.0) << "channel " << c;
}

TEST(IllustrationRefine, TracesEveryPixelWhereInkIsDrawn) {
  IllustrationRenderer r(test::headlessGl());
  r.setScene(test::nestedScene48());
  for (const char* preset : {"textbook", "pen"}) {  // outlines; pen: lines, hatching and creases
    const Style st = stylePreset(preset);
    Style noInk = st;
    for (auto* row : {&noInk.fallback, &noInk.unclassified}) row->lineWidthPx = row->hatchSpacingPx = row->creaseWidthPx = 0;
    for (auto& row : noInk.segments) row.lineWidthPx = row.hatchSpacingPx = row.creaseWidthPx = 0;
    const RgbaImage exact = r.render(st, view(160, 0)), plain = r.render(noInk, view(160, 0));
    const RgbaImage refined = r.render(st, view(160, 2));
    maybeSave(refined, std::string("refine-ink-") + preset);
    // Inked pixels: where the ink changes the exact figure. A traced pixel is the exact ray
    // (same jitter): equal but for the float target's rounding; an interpolated one would
    // miss or smear the line.
    int inked = 0, off = 0;
    for (int y = 0; y < 160; ++y)
      for (int x = 0; x < 160; ++x) {
        if (maxChannelDiff(exact, plain, x, y) <= 24) continue;
        ++inked;
        if (maxChannelDiff(refined, exact, x, y) > 2) {
          if (off++ < 5) ADD_FAILURE() << preset << ": inked pixel " << x << "," << y << " not traced";
        }
      }
    std::cout << "[ refine ] " << preset << ": " << inked << " inked pixels, " << off << " off; traced "
              << r.lastTracedFraction() << " rays a pixel\n";
    EXPECT_GT(inked, 200) << preset;
    EXPECT_EQ(off, 0) << preset;
  }
}

}  // namespace
}  // namespace vellum::illustration
