// Issue 21, section 3: styles an illustrator would publish. Ivory stays ivory (colour error
// of lit mid-tones), pen draws ink lines of constant pixel width that close around a shape
// and hatching that follows the tone, skin outlines have no gaps, x-ray's empty-space
// skipping never changes the picture (GL = CPU reference across block boundaries; on a real
// CT crop: illustration_real_styles_test.cpp). Small analytic scenes.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <iostream>
#include <numbers>

#include "headless_gl.hpp"
#include "image_compare.hpp"
#include "shape_fixtures.hpp"
#include "vellum/illustration/illustration_renderer.hpp"
#include "vellum/illustration/shape.hpp"
#include "vellum/illustration/style.hpp"

namespace vellum::illustration {
namespace {

render::GlContext& gl() { return test::headlessGl(); }

RgbaImage gpu(const ShapeScene& scene, const Style& st, const IllustrationSettings& s) {
  IllustrationRenderer r(gl());
  r.setScene(scene);
  return r.render(st, s);
}

/// Front view, orthographic: 96 px span the bounding sphere of the 48 mm box at size 96.
IllustrationSettings front(int size, std::array<float, 4> background = {1, 1, 1, 1}) {
  IllustrationSettings s;
  s.render.width = s.render.height = size;
  s.render.camera.azimuthDeg = 0;
  s.render.camera.elevationDeg = 0;
  s.render.camera.fieldOfViewDeg = 0;
  s.render.background = background;
  return s;
}

void maybeSave(const RgbaImage& img, const std::string& name) {
  if (const char* dir = std::getenv("VELLUM_ILLUSTRATION_PNG_DIR"); dir && *dir) {
    std::filesystem::create_directories(dir);
    test::writePng(img, std::filesystem::path(dir) / (name + ".png"));
  }
}

const ShapeScene& ball() {  // r = 16 mm sphere "bone" in a 48 mm box, 1 mm voxels
  static const ShapeScene s =
      test::makeScene(48, {{"bone", [](const Vec3& p) { return test::sphereSdf(p, {0, 0, 0}, 16); }}});
  return s;
}
constexpr double kBallMm = 16;
double pxPerMm(int size) { return size / (2 * std::sqrt(3.0) * 24.0); }

/// Camera-space unit normal of the ball under pixel (x, y) (right, up, toward the viewer), or
/// false outside the ball's disc shrunk by `marginPx`.
bool ballNormal(int size, int x, int y, double marginPx, std::array<double, 3>& n) {
  const double r = kBallMm * pxPerMm(size);
  const double u = (x + 0.5 - size * 0.5) / r, v = -(y + 0.5 - size * 0.5) / r;
  const double q = u * u + v * v;
  if (std::sqrt(q) > 1 - marginPx / r) return false;
  n = {u, v, std::sqrt(1 - q)};
  return true;
}
double dotLight(const Style& st, const std::array<double, 3>& n) {
  const double l = std::sqrt(double(st.light[0]) * st.light[0] + double(st.light[1]) * st.light[1] +
                             double(st.light[2]) * st.light[2]);
  return (n[0] * st.light[0] + n[1] * st.light[1] + n[2] * st.light[2]) / l;
}

/// CIE L*a*b* (D65) of an sRGB colour in [0, 1].
std::array<double, 3> lab(const std::array<double, 3>& rgb) {
  auto lin = [](double c) { return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4); };
  const double r = lin(rgb[0]), g = lin(rgb[1]), b = lin(rgb[2]);
  const double X = (0.4124 * r + 0.3576 * g + 0.1805 * b) / 0.95047, Y = 0.2126 * r + 0.7152 * g + 0.0722 * b,
               Z = (0.0193 * r + 0.1192 * g + 0.9505 * b) / 1.08883;
  auto f = [](double t) { return t > 216.0 / 24389 ? std::cbrt(t) : (24389.0 / 27 * t + 16) / 116; };
  return {116 * f(Y) - 16, 500 * (f(X) - f(Y)), 200 * (f(Y) - f(Z))};
}
double deltaE(const std::array<double, 3>& a, const std::array<double, 3>& b) {
  const auto p = lab(a), q = lab(b);
  return std::sqrt((p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) + (p[2] - q[2]) * (p[2] - q[2]));
}

struct ToneError {
  double meanDeltaE = 0, meanRgb = 0;  ///< CIE76 Delta E; mean |RGB difference| in 8-bit levels
  std::array<double, 3> mean{};        ///< mean colour of the pixels (0..1)
  int pixels = 0;
};
/// Lit mid-tones of the ball: pixels whose normal is 37 to 53 degrees from the light
/// (n.l in [0.6, 0.8], around the textbook's tone key 0.7), against `colour`.
ToneError litMidToneError(const RgbaImage& img, const Style& st, const Rgb& colour) {
  ToneError e;
  const std::array<double, 3> want{colour[0], colour[1], colour[2]};
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      std::array<double, 3> n;
      if (!ballNormal(img.width, x, y, 2.0, n)) continue;
      const double ndl = dotLight(st, n);
      if (ndl < 0.6 || ndl > 0.8) continue;
      const uint8_t* p = img.at(x, y);
      const std::array<double, 3> got{p[0] / 255.0, p[1] / 255.0, p[2] / 255.0};
      e.meanDeltaE += deltaE(got, want);
      for (int c = 0; c < 3; ++c) {
        e.meanRgb += std::abs(got[size_t(c)] - want[size_t(c)]) * 255 / 3;
        e.mean[size_t(c)] += got[size_t(c)];
      }
      ++e.pixels;
    }
  if (e.pixels) {
    e.meanDeltaE /= e.pixels;
    e.meanRgb /= e.pixels;
    for (auto& m : e.mean) m /= e.pixels;
  }
  return e;
}

/// A scene on grid g from analytic segments (each its own field, quantised as `vellum shape`
/// writes it; labels: the later segment wins; the union distance as the pipeline's).
ShapeScene analyticScene(const Geometry& g, const std::vector<test::AnalyticSegment>& segments) {
  ShapeScene scene = test::makeScene(8, segments);  // the label table and field list
  VolumeF32 dist(g, 0.f, 1e3);
  VolumeU16 ids(g, 0);
  std::vector<VolumeI16> own(segments.size(), VolumeI16(g, 0));
  for (int64_t k = 0; k < g.dims.z; ++k)
    for (int64_t j = 0; j < g.dims.y; ++j)
      for (int64_t i = 0; i < g.dims.x; ++i) {
        const Vec3 p = g.indexToPhysical({double(i), double(j), double(k)});
        double u = 1e3;
        for (size_t s = 0; s < segments.size(); ++s) {
          const double v = segments[s].sdf(p);
          u = std::min(u, v);
          if (v < 0) ids(i, j, k) = uint16_t(s + 1);
          own[s](i, j, k) = int16_t(std::lround(std::clamp(v, -300.0, 300.0) / kFieldQuantumMm));
        }
        dist(i, j, k) = float(u);
      }
  scene.distance = dist;
  scene.segments = LabelVolume(std::move(ids), scene.segments.table());
  for (size_t s = 0; s < segments.size(); ++s) scene.fields[s].distance = own[s];
  return scene;
}

/// Textbook bone stays ivory: the lit mid-tones of a ball match the style colour within a
/// stated Delta E (the shading lightens highlights and darkens shadows around it).
TEST(IllustrationStyles, TextbookBoneLitMidTonesKeepTheStyleColour) {
  const Style st = stylePreset("textbook");
  const SegmentStyle& bone = st.segments[0];
  ASSERT_EQ(bone.match, "bone");
  const RgbaImage img = gpu(ball(), st, front(192));
  maybeSave(img, "ivory-ball");
  const ToneError now = litMidToneError(img, st, bone.colour);
  Style plain = st;  // the model before tone_key: Gooch and Phong multiply the colour down
  plain.segments[0].toneKey = 0;
  const ToneError before = litMidToneError(gpu(ball(), plain, front(192)), st, bone.colour);
  std::cout << "[ ivory ] lit mid-tones (" << now.pixels << " px): mean " << now.mean[0] << " " << now.mean[1]
            << " " << now.mean[2] << " vs style " << bone.colour[0] << " " << bone.colour[1] << " "
            << bone.colour[2] << ": Delta E " << now.meanDeltaE << ", RGB " << now.meanRgb
            << " levels | without tone_key: " << before.mean[0] << " " << before.mean[1] << " " << before.mean[2]
            << ", Delta E " << before.meanDeltaE << "\n";
  ASSERT_GT(now.pixels, 500);
  // Stated bound (docs/styles.md): mean Delta E <= 3 (a just noticeable difference is ~2.3).
  EXPECT_LE(now.meanDeltaE, 3.0);
  EXPECT_LE(now.meanRgb, 8.0);
  EXPECT_GT(before.meanDeltaE, 2 * now.meanDeltaE);
  // Still shaded: the side away from the light is clearly darker than the lit mid-tones.
  const uint8_t* shadow = img.at(192 / 2 + int(0.85 * kBallMm * pxPerMm(192)), 192 / 2 + 10);
  EXPECT_LT(int(shadow[1]), int(now.mean[1] * 255) - 40);
}

/// Pen line style on the ball: ink only (no fill), lines of `widthPx`.
Style inkOnly(float widthPx) {
  Style st = stylePreset("pen");
  st.fallback.opacity = 0;
  st.fallback.hatchSpacingPx = 0;
  st.fallback.lineWidthPx = widthPx;
  return st;
}

/// Darkness (0 white .. 1 black) of a pixel on white paper.
double ink(const RgbaImage& img, int x, int y) { return 1.0 - img.at(x, y)[1] / 255.0; }

/// Darkest ink along the ray from the image centre at angle a, between radii r0 and r1 px
/// (bilinear samples every 0.25 px).
double darkestAlong(const RgbaImage& img, double a, double r0, double r1) {
  double best = 0;
  for (double r = r0; r <= r1; r += 0.25) {
    const double fx = img.width * 0.5 + r * std::cos(a) - 0.5, fy = img.height * 0.5 - r * std::sin(a) - 0.5;
    const int x0 = int(std::floor(fx)), y0 = int(std::floor(fy));
    const double tx = fx - x0, ty = fy - y0;
    if (x0 < 0 || y0 < 0 || x0 + 1 >= img.width || y0 + 1 >= img.height) continue;
    const double v = (1 - tx) * (1 - ty) * ink(img, x0, y0) + tx * (1 - ty) * ink(img, x0 + 1, y0) +
                     (1 - tx) * ty * ink(img, x0, y0 + 1) + tx * ty * ink(img, x0 + 1, y0 + 1);
    best = std::max(best, v);
  }
  return best;
}
/// Total ink across the outline along that ray (its width in px for opaque ink).
double inkAcross(const RgbaImage& img, double a, double r0, double r1) {
  double sum = 0;
  for (double r = r0; r <= r1; r += 0.25) {
    const int x = int(std::lround(img.width * 0.5 + r * std::cos(a) - 0.5));
    const int y = int(std::lround(img.height * 0.5 - r * std::sin(a) - 0.5));
    sum += 0.25 * ink(img, x, y);
  }
  return sum;
}

/// Gaps in the outline: runs of angles (1 degree apart) where the outline's ink stays under
/// half, counted once per run.
int outlineGaps(const RgbaImage& img, double radiusPx, double* meanWidth = nullptr) {
  int gaps = 0;
  bool inGap = false;
  double widths = 0;
  for (int deg = 0; deg < 360; ++deg) {
    const double a = deg * std::numbers::pi / 180;
    const bool gap = darkestAlong(img, a, radiusPx - 6, radiusPx + 6) < 0.5;
    if (gap && !inGap) ++gaps;
    inGap = gap;
    widths += inkAcross(img, a, radiusPx - 6, radiusPx + 6);
  }
  if (meanWidth) *meanWidth = widths / 360;
  return gaps;
}

/// Ink lines of constant pixel width: the same width (px) at two image sizes (two zooms in
/// mm per pixel), and a closed outline around the ball. GL = CPU.
TEST(IllustrationStyles, PenOutlineIsClosedAndOfConstantPixelWidth) {
  for (float widthPx : {1.5f, 3.f}) {
    double w[2];
    int i = 0;
    for (int size : {128, 256}) {
      const Style st = inkOnly(widthPx);
      const RgbaImage g = gpu(ball(), st, front(size));
      maybeSave(g, "pen-outline-" + std::to_string(size) + "-" + std::to_string(int(widthPx * 10)));
      const int gaps = outlineGaps(g, kBallMm * pxPerMm(size), &w[i]);
      std::cout << "[ ink ] " << size << " px, line " << widthPx << " px: mean width " << w[i] << " px, gaps "
                << gaps << "\n";
      EXPECT_EQ(gaps, 0) << size;
      EXPECT_NEAR(w[i], widthPx, 0.35 * widthPx) << size;
      if (size == 128) {
        const test::ImageDiff d = test::compareImages(g, renderIllustrationCpu(ball(), st, front(size)));
        EXPECT_LE(d.meanAbs[1], 1.0) << "GL vs CPU";
      }
      ++i;
    }
    EXPECT_NEAR(w[0], w[1], 0.15 * widthPx) << "constant pixel width whatever the mm per pixel";
  }
}

/// The textbook's skin outline is continuous (it was a thin opacity-modulated rim that came
/// out dashed where the ray step missed it): the outline of a skin ball has no gaps, on a
/// 1 x 1 x 3 mm grid too.
TEST(IllustrationStyles, SkinOutlineIsContinuous) {
  for (double dz : {1.0, 3.0}) {
    Geometry grid;  // both grids span the same 48 mm box
    const int nz = int(48 / dz);
    grid.dims = {48, 48, nz};
    grid.spacing = {1, 1, dz};
    grid.origin = {-23.5, -23.5, -(nz - 1) * 0.5 * dz};
    const ShapeScene scene =
        analyticScene(grid, {{"skin", [](const Vec3& p) { return test::sphereSdf(p, {0, 0, 0}, 16); }}});
    const Style st = stylePreset("textbook");
    IllustrationSettings s = front(128);
    // On paper, the outline is the skin line colour: its darkness against the paper, doubled.
    auto gapsOf = [&](const RgbaImage& g, double* width) {
      RgbaImage grey = g;
      for (int y = 0; y < g.height; ++y)
        for (int x = 0; x < g.width; ++x) {
          const int v = std::clamp(255 - 2 * (int(st.background[1] * 255) - int(g.at(x, y)[1])), 0, 255);
          for (int c = 0; c < 3; ++c) grey.at(x, y)[c] = uint8_t(v);
        }
      return outlineGaps(grey, kBallMm * pxPerMm(128), width);
    };
    const RgbaImage g = gpu(scene, st, s);
    maybeSave(g, "skin-outline-dz" + std::to_string(int(dz)));
    double width = 0, oldWidth = 0;
    const int gaps = gapsOf(g, &width);
    // The row before: a faint translucent skin whose rim came from silhouette enhancement.
    Style old = st;
    for (auto& r : old.segments)
      if (r.match == "skin") {
        r.opacity = 0.03f;
        r.lineWidthPx = 0;
        r.silhouetteKc = 0;
        r.silhouetteKs = 3;
        r.silhouetteKe = 8;
      }
    const RgbaImage o = gpu(scene, old, s);
    maybeSave(o, "skin-outline-old-dz" + std::to_string(int(dz)));
    const int oldGaps = gapsOf(o, &oldWidth);
    std::cout << "[ skin ] dz " << dz << ": outline gaps " << gaps << ", mean ink across " << width
              << " px | silhouette-enhanced rim before: gaps " << oldGaps << ", ink across " << oldWidth << " px\n";
    EXPECT_EQ(gaps, 0) << "dz " << dz;
    if (dz > 1) {
      const test::ImageDiff d = test::compareImages(g, renderIllustrationCpu(scene, st, s));
      EXPECT_LE(d.meanAbs[1], 1.0) << "GL vs CPU";
    }
  }
}

/// Hatching follows the tone: no ink where the ball faces the light (clean paper, no rings),
/// dense ink where it faces away.
TEST(IllustrationStyles, PenHatchingFollowsTheTone) {
  const Style st = stylePreset("pen");
  const RgbaImage img = gpu(ball(), st, front(192));
  maybeSave(img, "pen-hatching");
  double lit = 0, dark = 0, mid = 0;
  int nLit = 0, nDark = 0, nMid = 0;
  for (int y = 0; y < 192; ++y)
    for (int x = 0; x < 192; ++x) {
      std::array<double, 3> n;
      if (!ballNormal(192, x, y, 4.0, n)) continue;
      const double ndl = dotLight(st, n), v = ink(img, x, y);
      if (ndl > 0.7) lit += v, ++nLit;
      else if (ndl > 0.3 && ndl < 0.5) mid += v, ++nMid;
      else if (ndl < 0.1) dark += v, ++nDark;
    }
  lit /= std::max(nLit, 1);
  mid /= std::max(nMid, 1);
  dark /= std::max(nDark, 1);
  std::cout << "[ hatch ] mean ink: lit " << lit << " (" << nLit << " px), mid " << mid << " (" << nMid
            << "), dark (n.l < 0.1) " << dark << " (" << nDark << ")\n";
  ASSERT_GT(nLit, 200);
  ASSERT_GT(nDark, 100);
  EXPECT_LT(lit, 0.02);
  EXPECT_GT(mid, lit + 0.05);
  EXPECT_GT(dark, mid + 0.1);
  const test::ImageDiff d = test::compareImages(img, renderIllustrationCpu(ball(), st, front(192)));
  EXPECT_LE(d.meanAbs[1], 1.0) << "GL vs CPU";
}

/// x-ray: empty-space skipping must not change the picture (a skipped block that holds
/// visible samples shows as a darker square): a bone box whose faces lie on the 8-voxel block
/// boundaries inside a skin ball, on an anisotropic grid, oblique view, zoom 1.8. GL (skips
/// blocks) equals the CPU reference (samples everything).
TEST(IllustrationStyles, XrayGlEqualsCpuAcrossBlockBoundaries) {
  Geometry g;
  g.dims = {48, 48, 24};
  g.spacing = {0.8, 0.8, 2.0};
  g.origin = {0, 0, 0};
  const Vec3 centre = g.indexToPhysical({23.5, 23.5, 11.5});
  // Bone box faces at voxel indices 8 and 40 (x, y) and 8 and 16 (z): block boundaries.
  const Vec3 lo = g.indexToPhysical({8, 8, 8}), hi = g.indexToPhysical({40, 40, 16});
  const Vec3 boxC = (lo + hi) * 0.5, boxH = (hi - lo) * 0.5;
  const ShapeScene scene = analyticScene(
      g, {{"skin", [=](const Vec3& p) { return test::sphereSdf(p, centre, 18.5); }},
          {"bone", [=](const Vec3& p) { return test::boxSdf(p, boxC, boxH); }}});
  const Style st = stylePreset("x-ray");
  for (double az : {20.0, 90.0}) {
    IllustrationSettings s = front(96, {0.02f, 0.03f, 0.05f, 1});
    s.render.camera.azimuthDeg = az;
    s.render.camera.elevationDeg = 50;
    s.render.camera.zoom = 1.8;
    const RgbaImage a = gpu(scene, st, s), b = renderIllustrationCpu(scene, st, s);
    maybeSave(a, "xray-blocks-" + std::to_string(int(az)));
    const test::ImageDiff d = test::compareImages(a, b);
    std::cout << "[ x-ray ] blocks az " << az << ": max " << d.maxAbs << " psnr " << d.psnr << " dB\n";
    EXPECT_LE(d.maxAbs, 2.0);
  }
}

/// Hidden ink lines: one transparent (outline-only) segment made of a big ball and a small
/// ball in front of and behind it along the view axis (radii 4 and 6 mm: whichever is
/// behind, its outline falls inside the big disc). The outline of the ball behind the big
/// one is not drawn: along a radius of the big disc there is one ring (the front ball's),
/// not two. GL = CPU.
TEST(IllustrationStyles, PenDrawsNoLinesBehindATransparentSurface) {
  const ShapeScene scene = test::makeScene(64, {{"skin", [](const Vec3& p) {
    return std::min({test::sphereSdf(p, {0, 0, 0}, 10), test::sphereSdf(p, {0, -18, 0}, 4),
                     test::sphereSdf(p, {0, 18, 0}, 6)});
  }}});
  const Style st = inkOnly(1.5f);
  IllustrationSettings s = front(160);
  const RgbaImage g = gpu(scene, st, s);
  maybeSave(g, "pen-hidden-lines");
  const double pxMm = 160 / (2 * std::sqrt(3.0) * 32.0);
  int ringsMax = 0, ringsMin = 99;
  for (int deg = 0; deg < 360; deg += 15) {
    const double a = deg * std::numbers::pi / 180;
    int rings = 0;
    bool on = false;
    for (double r = 0; r < 9 * pxMm; r += 0.25) {  // inside the big ball's disc (radius 10 mm)
      const bool dark = darkestAlong(g, a, r, r) > 0.4;
      if (dark && !on) ++rings;
      on = dark;
    }
    ringsMax = std::max(ringsMax, rings);
    ringsMin = std::min(ringsMin, rings);
  }
  std::cout << "[ ink ] rings inside the big disc: " << ringsMin << ".." << ringsMax << "\n";
  EXPECT_EQ(ringsMin, 1);
  EXPECT_EQ(ringsMax, 1);
  const test::ImageDiff d = test::compareImages(g, renderIllustrationCpu(scene, st, s));
  EXPECT_LE(d.meanAbs[1], 1.0) << "GL vs CPU";
}

/// The pen preset on a knee-like nesting (bone inside muscle inside skin): the muscle is left
/// out, so the bone's outline shows all round inside the skin's, and the figure is the one
/// of the same scene without a muscle segment. (The preset's fallback drew the muscle as an
/// opaque hatched cylinder that hid the bone.) GL equals the CPU reference.
TEST(IllustrationStyles, PenShowsTheBonesThroughTheMuscle) {
  const int n = 48;
  const ShapeScene nested = test::nestedScene(n);
  const double rb = 0.18 * n, rm = 0.30 * n, rs = 0.36 * n;  // as test::nestedScene
  const ShapeScene noMuscle = test::makeScene(
      n, {{"bone", [=](const Vec3& p) { return test::sphereSdf(p, {0, 0, 0}, rb); }},
          {"skin", [=](const Vec3& p) { return std::max(rm - norm(p), test::sphereSdf(p, {0, 0, 0}, rs)); }}});
  const Style st = stylePreset("pen");
  const IllustrationSettings s = front(128);
  const RgbaImage a = renderIllustrationCpu(nested, st, s), b = renderIllustrationCpu(noMuscle, st, s);
  maybeSave(a, "pen-nested");
  const double pxMm = 128 / (2 * std::sqrt(3.0) * 0.5 * n);
  int boneGaps = 0;
  for (int deg = 0; deg < 360; deg += 5)
    if (darkestAlong(a, deg * std::numbers::pi / 180, rb * pxMm - 3, rb * pxMm + 3) < 0.5) ++boneGaps;
  std::cout << "[ pen ] bone outline: " << boneGaps << " of 72 directions without ink\n";
  EXPECT_EQ(boneGaps, 0);
  const test::ImageDiff withWithout = test::compareImages(a, b);
  EXPECT_LE(withWithout.maxAbs, 2) << "the muscle changes the pen figure";
  const test::ImageDiff d = test::compareImages(gpu(nested, st, s), a);
  EXPECT_LE(d.meanAbs[1], 1.0) << "GL vs CPU";
}

/// Pen creases: ink where the surface's normal turns sharply, of constant pixel width. A cube
/// seen edge-on (azimuth 45, elevation 0: two faces meet in a vertical edge at the image's
/// centre column) gets a line on that edge and none on the faces; a sphere gets none inside
/// its outline. GL equals the CPU reference.
TEST(IllustrationStyles, PenCreasesFollowACubesEdgesNotASphere) {
  Style st = stylePreset("pen");
  st.fallback.lineWidthPx = 0;     // no silhouettes: only creases ink the picture
  st.fallback.hatchSpacingPx = 0;
  ASSERT_GT(st.fallback.creaseWidthPx, 0.f);
  const ShapeScene cube =
      test::makeScene(48, {{"bone", [](const Vec3& p) { return test::boxSdf(p, {0, 0, 0}, {10, 10, 10}); }}});
  IllustrationSettings s = front(128);
  s.render.camera.azimuthDeg = 45;
  const RgbaImage g = gpu(cube, st, s);
  maybeSave(g, "pen-creases-cube");
  // Across the middle rows: the darkest pixel near the centre column, the line's width (ink
  // > 0.5) and the darkest ink on the faces (3..9 mm either side of the edge on screen).
  const double pxMm = pxPerMm(128);
  double edge = 1, faces = 0, width = 0;
  for (int y = 64 - 8; y <= 64 + 8; ++y) {
    double best = 0;
    int wide = 0;
    for (int x = 64 - 4; x <= 64 + 4; ++x) {
      best = std::max(best, ink(g, x, y));
      wide += ink(g, x, y) > 0.5 ? 1 : 0;
    }
    edge = std::min(edge, best);
    width += wide / 17.0;
    for (double mm : {-9.0, -6.0, -3.0, 3.0, 6.0, 9.0}) faces = std::max(faces, ink(g, 64 + int(std::lround(mm * pxMm)), y));
  }
  const RgbaImage b = gpu(ball(), st, s);
  maybeSave(b, "pen-creases-sphere");
  double sphere = 0;
  for (int y = 0; y < 128; ++y)
    for (int x = 0; x < 128; ++x)
      if (std::hypot(x + 0.5 - 64, y + 0.5 - 64) < (kBallMm - 1.5) * pxMm) sphere = std::max(sphere, ink(b, x, y));
  std::cout << "[ crease ] cube edge ink >= " << edge << ", width " << width << " px (crease_width_px "
            << st.fallback.creaseWidthPx << "), faces <= " << faces << "; sphere inside its outline <= " << sphere << "\n";
  EXPECT_GT(edge, 0.8);
  EXPECT_GE(width, 1.0);
  EXPECT_LE(width, 3.5);
  EXPECT_LT(faces, 0.1);
  EXPECT_LT(sphere, 0.1);
  const test::ImageDiff d = test::compareImages(g, renderIllustrationCpu(cube, st, s));
  EXPECT_LE(d.meanAbs[1], 1.0) << "GL vs CPU";
}

/// Creases on CT-like rounded edges (issue 21, s16): on a 1 mm grid a bone's edge is rounded
/// over a few voxels. A box whose edges are rounded with a 1.5 mm radius, seen edge-on at
/// 0.33 mm a pixel, gets a continuous line (the old probe, half the width plus half a pixel
/// either side, saw about a third of the turn: no ink); a cylinder of 6 mm radius, which turns
/// as far but evenly, gets none inside its outline. GL equals the CPU reference.
TEST(IllustrationStyles, PenCreasesFindRoundedEdgesNotRoundShafts) {
  Style st = stylePreset("pen");
  st.fallback.lineWidthPx = 0;  // only creases ink the picture
  st.fallback.hatchSpacingPx = 0;
  auto rounded = [](const Vec3& p) {
    const double r = 1.5;
    const Vec3 q{std::abs(p.x) - (10 - r), std::abs(p.y) - (10 - r), std::abs(p.z) - (10 - r)};
    const Vec3 o{std::max(q.x, 0.0), std::max(q.y, 0.0), std::max(q.z, 0.0)};
    return norm(o) + std::min(std::max({q.x, q.y, q.z}), 0.0) - r;
  };
  const ShapeScene box = test::makeScene(48, {{"bone", rounded}});
  const int size = 256;
  IllustrationSettings s = front(size);
  s.render.camera.azimuthDeg = 45;  // a vertical edge at the centre column
  const RgbaImage g = gpu(box, st, s);
  maybeSave(g, "pen-creases-rounded-box");
  const double pxMm = pxPerMm(size);
  double edge = 1, faces = 0;
  for (int y = size / 2 - 16; y <= size / 2 + 16; ++y) {
    double best = 0;
    for (int x = size / 2 - 4; x <= size / 2 + 4; ++x) best = std::max(best, ink(g, x, y));
    edge = std::min(edge, best);
    for (double mm : {-6.0, -4.0, 4.0, 6.0}) faces = std::max(faces, ink(g, size / 2 + int(std::lround(mm * pxMm)), y));
  }
  const ShapeScene shaft = test::makeScene(48, {{"bone", [](const Vec3& p) {
    return std::max(std::hypot(p.x, p.y) - 6.0, std::abs(p.z) - 18.0);  // axis along z
  }}});
  IllustrationSettings side = front(size);
  side.render.camera.elevationDeg = 0;
  const RgbaImage c = gpu(shaft, st, side);
  maybeSave(c, "pen-creases-shaft");
  double shaftInk = 0;
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x)
      if (ink(c, x, y) > shaftInk && std::abs(x + 0.5 - size / 2) < (6.0 - 1.0) * pxMm &&
          std::abs(y + 0.5 - size / 2) < (18.0 - 2.0) * pxMm)
        shaftInk = ink(c, x, y);
  std::cout << "[ crease ] rounded edge ink >= " << edge << ", faces <= " << faces << ", shaft <= " << shaftInk << "\n";
  EXPECT_GT(edge, 0.6);  // a continuous dark line (0.8 here; 0 with the old probe)
  EXPECT_LT(faces, 0.1);
  EXPECT_LT(shaftInk, 0.1);
  const test::ImageDiff d = test::compareImages(g, renderIllustrationCpu(box, st, s));
  EXPECT_LE(d.meanAbs[1], 1.0) << "GL vs CPU";
  EXPECT_LE(d.maxAbs, 64.0) << "GL vs CPU";
}

/// Hatching lies on the surface, not the screen: panning the camera by 7 px moves the
/// hatched ball's picture by 7 px, strokes included (screen-space strokes stayed put).
TEST(IllustrationStyles, PenHatchingMovesWithTheSurface) {
  const Style st = stylePreset("pen");
  IllustrationSettings s = front(128);
  s.render.jitter = false;  // the same samples along corresponding rays
  const RgbaImage a = gpu(ball(), st, s);
  const int shift = 7;
  s.render.camera.panMm = {shift / pxPerMm(128), 0, 0};
  const RgbaImage b = gpu(ball(), st, s);
  double best = 1e9, inked = 0;
  for (int sign : {-1, 1}) {  // the pan's direction on screen
    double sum = 0;
    int n = 0;
    for (int y = 16; y < 112; ++y)
      for (int x = 16; x < 112; ++x) {
        sum += std::abs(ink(a, x, y) - ink(b, x + sign * shift, y));
        ++n;
      }
    best = std::min(best, sum / n);
  }
  for (int y = 16; y < 112; ++y)
    for (int x = 16; x < 112; ++x) inked += ink(a, x, y) / (96.0 * 96.0);
  std::cout << "[ hatch ] mean ink " << inked << ", after a 7 px pan the shifted picture differs by " << best << "\n";
  ASSERT_GT(inked, 0.05);  // there is hatching to move
  EXPECT_LT(best, 0.01);
}

/// The adaptive step (homogeneous blocks, one sample for the span) keeps the figure: a
/// nested ball (translucent muscle around an opaque bone, skin outline) whose fields are
/// clamped to a 3 mm band as `vellum shape` writes them, textbook: GL with and without the
/// adaptive step, PSNR >= 40 dB; CPU reference likewise.
TEST(IllustrationStyles, AdaptiveStepKeepsTheFigure) {
  Geometry g;
  g.dims = {64, 64, 48};
  g.spacing = {0.75, 0.75, 1.0};
  const Vec3 c = g.indexToPhysical({31.5, 31.5, 23.5});
  auto clamp3 = [](double v) { return std::clamp(v, -3.0, 3.0); };
  const ShapeScene scene = analyticScene(
      g, {{"skin", [=](const Vec3& p) { return clamp3(test::sphereSdf(p, c, 22)); }},
          {"muscle", [=](const Vec3& p) { return clamp3(test::sphereSdf(p, c, 19)); }},
          {"bone", [=](const Vec3& p) { return clamp3(test::boxSdf(p, c, {5, 5, 14})); }}});
  const Style st = stylePreset("textbook");
  IllustrationSettings s = front(128);
  s.render.camera.azimuthDeg = 30;
  s.render.camera.elevationDeg = 20;
  IllustrationSettings ref = s;
  ref.adaptiveStep = false;
  const RgbaImage fast = gpu(scene, st, s), full = gpu(scene, st, ref);
  maybeSave(fast, "adaptive-step");
  const test::ImageDiff d = test::compareImages(fast, full);
  const test::ImageDiff dc = test::compareImages(renderIllustrationCpu(scene, st, s), renderIllustrationCpu(scene, st, ref));
  std::cout << "[ step ] adaptive vs full march: GL psnr " << d.psnr << " dB (max " << d.maxAbs << "), CPU psnr "
            << dc.psnr << " dB\n";
  EXPECT_GE(d.psnr, 40.0);
  EXPECT_GE(dc.psnr, 40.0);
}

}  // namespace
}  // namespace vellum::illustration

namespace vellum::illustration {
namespace {

/// Capsule from a to b, radius r (mm).
double rodSdf(const Vec3& p, const Vec3& a, const Vec3& b, double r) {
  const Vec3 ab = b - a, ap = p - a;
  const double h = std::clamp(dot(ap, ab) / dot(ab, ab), 0.0, 1.0);
  return norm(ap - ab * h) - r;
}

/// Per image column in [x0, x1), the strongest coverage (alpha) of the figure.
std::vector<double> columnCoverage(const RgbaImage& img, int x0, int x1) {
  std::vector<double> out;
  for (int x = x0; x < x1; ++x) {
    double m = 0;
    for (int y = 0; y < img.height; ++y) m = std::max(m, img.at(x, y)[3] / 255.0);
    out.push_back(m);
  }
  return out;
}

/// A structure thinner than a voxel and a ray step draws a continuous line, not beads: a rod
/// 0.9 mm across, oblique to the 1 mm grid, opaque textbook bone on a transparent background.
/// Its exact distances at the voxel centres lose it wherever it passes between two of them
/// (trilinear interpolation never goes below the nearer centre's distance): before the
/// thin-structure values of quantiseField (keepThin), the strongest coverage along it fell to
/// 0.31 at the default step and to 0 in 35 of the 62 columns at a fine step (the coverage
/// ramp is a step wide, so a fine step shows the field's own gaps). GL = CPU.
TEST(IllustrationStyles, ThinRodDrawsAContinuousLine) {
  const ShapeScene scene = test::makeScene(
      48, {{"bone", [](const Vec3& p) { return rodSdf(p, {-16, -5, -9}, {16, 5, 9}, 0.45); }}});
  const Style st = stylePreset("textbook");
  for (double step : {1.0, 0.1}) {
    IllustrationSettings s = front(192, {0, 0, 0, 0});
    s.render.stepVoxels = step;
    const RgbaImage cpu = renderIllustrationCpu(scene, st, s), gl = gpu(scene, st, s);
    maybeSave(gl, "thin-rod-step-" + std::to_string(int(step * 100)));
    // Columns 66..127: the rod's middle 32 mm span x = 62..132 at this scale.
    for (const RgbaImage* img : {&cpu, &gl}) {
      const auto cov = columnCoverage(*img, 66, 128);
      const double lo = *std::min_element(cov.begin(), cov.end());
      std::cout << "[ rod ] step " << step << (img == &cpu ? " CPU" : " GL") << ": weakest column coverage " << lo << "\n";
      EXPECT_GE(lo, step < 1 ? 0.9 : 0.5) << "step " << step;
    }
    EXPECT_LE(test::compareImages(cpu, gl).maxAbs, 8) << "step " << step;
  }
}


/// Rough bone's knots of ink: a bump of voxel noise (here four balls 1.2 mm across beside a
/// 20 mm ball, 1 mm grid) gets no outline of its own, while the ball keeps its closed line
/// (silhouette ink fades for features under two voxels round). Without the fade each bump
/// drew a dark knot (19.5 px of ink in its 11 x 11 box; 0.55 with it). GL = CPU where the fade
/// acts. (Creases still mark such a blob: to the crease probe, 3 voxels either side, it is one
/// sharp turn.)
TEST(IllustrationStyles, PenDrawsNoKnotsOnVoxelSizedBumps) {
  const ShapeScene scene = test::makeScene(48, {{"bone", [](const Vec3& p) {
                                                   double d = test::sphereSdf(p, {0, 0, 0}, 10);
                                                   for (const Vec3 c : {Vec3{15, 0, 0}, Vec3{-15, 0, 0}, Vec3{0, 0, 15}, Vec3{0, 0, -15}})
                                                     d = std::min(d, test::sphereSdf(p, c, 0.6));
                                                   return d;
                                                 }}});
  const int size = 192;
  Style st = inkOnly(2.f);
  st.fallback.creaseWidthPx = 0;  // silhouettes only: a blob is all "crease" to the crease probe
  st.fallback.opacity = 1;        // pen's paper-white fill (outline-only rows keep every line)
  const RgbaImage g = gpu(scene, st, front(size)), c = renderIllustrationCpu(scene, st, front(size));
  maybeSave(g, "pen-bumps");
  const double ppm = pxPerMm(size);
  EXPECT_EQ(outlineGaps(g, 10 * ppm), 0) << "the ball's outline stays closed";
  for (const auto& [dx, dy] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
    const int cx = int(std::lround(size * 0.5 + dx * 15 * ppm)), cy = int(std::lround(size * 0.5 + dy * 15 * ppm));
    double sum = 0;
    for (int y = cy - 5; y <= cy + 5; ++y)
      for (int x = cx - 5; x <= cx + 5; ++x) sum += ink(g, x, y);
    std::cout << "[ knot ] bump at (" << dx << ", " << dy << "): " << sum << " px of ink\n";
    EXPECT_LT(sum, 1.0) << dx << " " << dy;
  }
  EXPECT_LE(test::compareImages(g, c).meanAbs[1], 1.0) << "GL vs CPU";
}

}  // namespace
}  // namespace vellum::illustration
