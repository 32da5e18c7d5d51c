// Issue 21: zoom 1 fits what the figure draws; labels name only segments that are drawn, with
// display names and a text size.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include <nlohmann/json.hpp>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <sys/wait.h>

#include "headless_gl.hpp"
#include "shape_fixtures.hpp"
#include "test_data.hpp"
#include "vellum/core/box_corners.hpp"
#include "vellum/io/volume_io.hpp"
#include "vellum/illustration/figure.hpp"
#include "vellum/render/annotations.hpp"
#include "vellum/render/framing.hpp"
#include "vellum/render/projection.hpp"

namespace vellum::illustration {
namespace {

struct Extent {
  double x0 = std::numeric_limits<double>::infinity(), x1 = -x0, y0 = x0, y1 = -x0;
};

Extent projected(const Geometry& g, const render::RenderSettings& s, const std::vector<Vec3>& points) {
  const render::Projection p(g, s);
  Extent e;
  for (const Vec3& q : points) {
    const auto px = p.toPixel(q);
    if (!px) continue;
    e.x0 = std::min(e.x0, px->x), e.x1 = std::max(e.x1, px->x), e.y0 = std::min(e.y0, px->y), e.y1 = std::max(e.y1, px->y);
  }
  return e;
}

// The eight corners of a box (mm).
std::vector<Vec3> corners(const Vec3& lo, const Vec3& hi) {
  const auto c = boxCorners(lo, hi);
  return {c.begin(), c.end()};
}

Geometry grid(int n, double spacing) {
  Geometry g;
  g.dims = {n, n, n};
  g.spacing = {spacing, spacing, spacing};
  return g;
}

// A small box far off the volume's centre fills the image (less the margin) on its tighter
// side and sits in the middle, in orthographic and perspective views, from any side; the
// zoom and the pan act on top of the fit.
TEST(Framing, FitsPointsAndCentresThem) {
  const Geometry g = grid(100, 2.0);  // 200 mm cube
  const std::vector<Vec3> box = corners({20, 30, 120}, {60, 50, 180});
  for (double fov : {0.0, 30.0})
    for (double az : {0.0, 35.0, 90.0})
      for (int w : {300, 200}) {
        render::RenderSettings s;
        s.width = w;
        s.height = 240;
        s.camera.azimuthDeg = az;
        s.camera.elevationDeg = 12;
        s.camera.fieldOfViewDeg = fov;
        const double margin = 0.06;
        s.camera = render::fitCamera(g, s, box, margin);
        const Extent e = projected(g, s, box);
        const std::string what = "fov " + std::to_string(fov) + " az " + std::to_string(az) + " w " + std::to_string(w);
        // Inside the image with the margin, tight on one side (pixel centres -> edges: +1).
        const double fillX = (e.x1 - e.x0 + 1) / s.width, fillY = (e.y1 - e.y0 + 1) / s.height;
        EXPECT_LE(fillX, 1 - margin + 1e-6) << what;
        EXPECT_LE(fillY, 1 - margin + 1e-6) << what;
        EXPECT_NEAR(std::max(fillX, fillY), 1 - margin, 0.01) << what;
        EXPECT_NEAR(0.5 * (e.x0 + e.x1), 0.5 * (s.width - 1), 1.0) << what;
        EXPECT_NEAR(0.5 * (e.y0 + e.y1), 0.5 * (s.height - 1), 1.0) << what;

        // Zoom 2 on top of the fit: the extent doubles (orthographic exactly).
        render::RenderSettings z = s;
        z.camera = render::Camera{};
        z.camera.azimuthDeg = az;
        z.camera.elevationDeg = 12;
        z.camera.fieldOfViewDeg = fov;
        z.camera.zoom = 2;
        z.camera = render::fitCamera(g, z, box, margin);
        EXPECT_NEAR(z.camera.zoom, 2 * s.camera.zoom, 1e-9) << what;
      }
}

// Insets keep the annotations' room free: the points fit the rest of the image, centred in
// it; insets that would leave less than half the image shrink to leave half.
TEST(Framing, InsetsKeepTheEdgesFree) {
  const Geometry g = grid(100, 2.0);
  const std::vector<Vec3> box = corners({20, 30, 120}, {60, 50, 180});
  render::RenderSettings s;
  s.width = 400;
  s.height = 300;
  s.camera.azimuthDeg = 20;
  s.camera.fieldOfViewDeg = 0;
  const render::ImageInsets in{60, 20, 10, 50};
  render::RenderSettings f = s;
  f.camera = render::fitCamera(g, s, box, 0.0, in);
  const Extent e = projected(g, f, box);
  EXPECT_GE(e.x0, 60 - 0.5 - 1e-6);
  EXPECT_LE(e.x1, 400 - 20 - 0.5 + 1e-6);
  EXPECT_GE(e.y0, 10 - 0.5 - 1e-6);
  EXPECT_LE(e.y1, 300 - 50 - 0.5 + 1e-6);
  EXPECT_NEAR(0.5 * (e.x0 + e.x1), 60 + 0.5 * 320 - 0.5, 1.0);
  EXPECT_NEAR(0.5 * (e.y0 + e.y1), 10 + 0.5 * 240 - 0.5, 1.0);
  EXPECT_NEAR(std::max((e.x1 - e.x0 + 1) / 320, (e.y1 - e.y0 + 1) / 240), 1.0, 0.01);
  // Too wide to honour: 250 px of 400 shrink to 120 + 80, the anatomy keeps 200.
  render::RenderSettings w = s;
  w.camera = render::fitCamera(g, s, box, 0.0, {150, 100, 10, 50});
  const Extent ew = projected(g, w, box);
  EXPECT_NEAR(0.5 * (ew.x0 + ew.x1), 120 + 100 - 0.5, 1.0);
  EXPECT_NEAR(0.5 * (ew.y0 + ew.y1), 129.5, 1.0);
  EXPECT_NEAR(std::max((ew.x1 - ew.x0 + 1) / 200, (ew.y1 - ew.y0 + 1) / 240), 1.0, 0.01);
}

// The outline of a set of voxels holds the whole voxels' corners, so the fit never cuts a
// voxel; ids not wanted are left out.
TEST(Framing, OutlinePointsHoldTheWantedVoxelsWhole) {
  Geometry g = grid(10, 2.0);
  VolumeU16 ids(g, 0);
  ids(3, 4, 5) = 1;
  ids(6, 4, 5) = 1;
  ids(8, 8, 8) = 2;
  const std::vector<Vec3> pts = render::outlinePoints(ids, {0, 1, 0});
  ASSERT_EQ(pts.size(), 8u);  // one row: its two end faces' corners
  Vec3 lo = pts[0], hi = pts[0];
  for (const Vec3& p : pts)
    for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], p[a]), hi[a] = std::max(hi[a], p[a]);
  EXPECT_DOUBLE_EQ(lo.x, 2.5 * 2);
  EXPECT_DOUBLE_EQ(hi.x, 6.5 * 2);
  EXPECT_DOUBLE_EQ(lo.y, 3.5 * 2);
  EXPECT_DOUBLE_EQ(hi.y, 4.5 * 2);
  EXPECT_DOUBLE_EQ(lo.z, 4.5 * 2);
  EXPECT_DOUBLE_EQ(hi.z, 5.5 * 2);
  EXPECT_TRUE(render::outlinePoints(ids, {0, 0, 0, 1}).empty());
}

// Drawn framing fits the segments the style draws: with the big segment invisible, the small
// one fills the figure; "segments" framing fits both whatever the style.
TEST(Framing, FitsTheDrawnSegmentsOnly) {
  const ShapeScene scene = test::makeScene(
      48, {{"small", [](const Vec3& p) { return test::sphereSdf(p, {-10, 0, 0}, 5); }},
           {"big", [](const Vec3& p) { return test::sphereSdf(p, {8, 0, 0}, 14); }}});
  Style st;
  SegmentStyle big;
  big.match = "big";
  big.visible = false;
  st.segments = {big};
  const std::vector<uint8_t> drawn = styleDrawnIds(st, scene.segments);
  ASSERT_GE(drawn.size(), 3u);
  EXPECT_EQ(drawn[0], 0);
  EXPECT_EQ(drawn[1], 1);
  EXPECT_EQ(drawn[2], 0);

  render::RenderSettings s;
  s.width = s.height = 200;
  s.camera.azimuthDeg = 0;
  s.camera.elevationDeg = 0;
  s.camera.fieldOfViewDeg = 0;
  const Geometry& g = scene.segments.geometry();
  const auto extentOf = [&](const render::RenderSettings& rs, std::vector<uint8_t> wanted) {
    const Extent e = projected(g, rs, render::outlinePoints(scene.segments.ids(), wanted));
    return std::max(e.x1 - e.x0 + 1, e.y1 - e.y0 + 1) / 200.0;
  };
  render::RenderSettings d = s;
  d.camera = frameFigure(scene.segments, st, s, Framing::Drawn);
  EXPECT_NEAR(extentOf(d, {0, 1, 0}), 0.94, 0.01);  // the small sphere fills the figure
  render::RenderSettings a = s;
  a.camera = frameFigure(scene.segments, st, s, Framing::Segments);
  EXPECT_NEAR(extentOf(a, {0, 1, 1}), 0.94, 0.01);  // both fill it
  EXPECT_GT(d.camera.zoom, 1.5 * a.camera.zoom);
  render::RenderSettings v = s;
  v.camera = frameFigure(scene.segments, st, s, Framing::Volume);
  EXPECT_EQ(v.camera.zoom, 1.0);  // the bounding sphere, as before
  EXPECT_LT(extentOf(v, {0, 1, 1}), 0.6);
}

render::GlContext& gl() { return test::headlessGl(); }

IllustrationSettings front(int size) {
  IllustrationSettings s;
  s.render.width = s.render.height = size;
  s.render.camera.azimuthDeg = 0;
  s.render.camera.elevationDeg = 0;
  s.render.camera.fieldOfViewDeg = 0;
  s.render.background = {1, 1, 1, 1};
  return s;
}

std::vector<uint16_t> anchorIds(const std::vector<render::StructureAnchor>& anchors) {
  std::vector<uint16_t> ids;
  for (const auto& a : anchors) ids.push_back(a.id);
  std::sort(ids.begin(), ids.end());
  return ids;
}

// "bone" (id 1) on the left, "muscle" (id 2) on the right: both drawn, both labelled, each
// anchor on its own sphere; an invisible muscle, or one whose style leaves no ink (boundary
// and silhouette gains 0: opacity 0 everywhere), gets no label.
TEST(FigureLabels, OnlyDrawnSegmentsAreLabelled) {
  const ShapeScene scene = test::twoSpheres(48);
  render::GlContext& context = gl();
  IllustrationRenderer renderer(context);
  renderer.setScene(scene);
  const IllustrationSettings s = front(160);

  const Style both = test::twoRowStyle();
  const RgbaImage a = renderer.render(both, s);
  const auto all = drawnSegmentAnchors(renderer, both, s, scene.segments, a);
  ASSERT_EQ(anchorIds(all), (std::vector<uint16_t>{1, 2}));
  for (const auto& an : all) {
    EXPECT_EQ(an.x < 80, an.id == 1) << an.name << " anchor at x " << an.x;
    EXPECT_NEAR(an.y, 80, 20) << an.name;
  }

  Style hidden = test::twoRowStyle();
  hidden.segments[1].visible = false;
  const RgbaImage b = renderer.render(hidden, s);
  EXPECT_EQ(anchorIds(drawnSegmentAnchors(renderer, hidden, s, scene.segments, b)), (std::vector<uint16_t>{1}));

  Style noInk = test::twoRowStyle();
  noInk.segments[1].boundaryKc = noInk.segments[1].boundaryKs = 0;
  const RgbaImage c = renderer.render(noInk, s);
  EXPECT_EQ(anchorIds(drawnSegmentAnchors(renderer, noInk, s, scene.segments, c)), (std::vector<uint16_t>{1}));

  // An outline only (no fill, ink lines: the textbook and pen skin) is drawn: framed and labelled.
  Style outline = test::twoRowStyle();
  outline.segments[1].opacity = 0;
  outline.segments[1].lineWidthPx = 1.5f;
  ASSERT_GE(styleDrawnIds(outline, scene.segments).size(), 3u);
  EXPECT_EQ(styleDrawnIds(outline, scene.segments)[2], 1);
  const RgbaImage e = renderer.render(outline, s);
  EXPECT_EQ(anchorIds(drawnSegmentAnchors(renderer, outline, s, scene.segments, e)), (std::vector<uint16_t>{1, 2}));

  // Only the candidates asked for.
  LabelSearch onlyMuscle;
  onlyMuscle.ids = {2};
  EXPECT_EQ(anchorIds(drawnSegmentAnchors(renderer, both, s, scene.segments, a, onlyMuscle)),
            (std::vector<uint16_t>{2}));

  // Display names and the text size reach the drawn labels.
  render::AnnotationOptions o;
  o.labels = true;
  o.displayNames = {{"BONE", "Tibia and fibula"}, {"2", "Calf muscles"}};
  RgbaImage small = a, large = a;
  const render::Projection projection(scene.segments.geometry(), s.render);
  o.textHeightPx = 8;
  const render::AnnotationLayout ls = render::annotate(small, projection, o, all);
  o.textHeightPx = 16;
  const render::AnnotationLayout ll = render::annotate(large, projection, o, all);
  std::vector<std::string> texts = ls.labelTexts;
  std::sort(texts.begin(), texts.end());
  EXPECT_EQ(texts, (std::vector<std::string>{"Calf muscles", "Tibia and fibula"}));
  ASSERT_EQ(ls.labelBoxes.size(), 2u);
  ASSERT_EQ(ll.labelBoxes.size(), 2u);
  for (size_t i = 0; i < 2; ++i) {
    const double wSmall = ls.labelBoxes[i].x1 - ls.labelBoxes[i].x0, wLarge = ll.labelBoxes[i].x1 - ll.labelBoxes[i].x0;
    EXPECT_NEAR(wLarge / wSmall, 2.0, 0.15) << ls.labelTexts[i];
  }

  // The room annotationInsets() reserves holds the label columns, letters and scale bar.
  o.orientation = o.scaleBar = true;
  o.textHeightPx = 7;
  RgbaImage annotated = a;
  const render::AnnotationLayout lo = render::annotate(annotated, projection, o, all);
  const render::ImageInsets in = render::annotationInsets(o, 160, 160, lo.labelTexts);
  ASSERT_EQ(lo.labelBoxes.size(), 2u);
  for (const auto& b : lo.labelBoxes) EXPECT_TRUE(b.x1 < in.left || b.x0 >= 160 - in.right) << b.x0 << ".." << b.x1;
  EXPECT_GT(in.bottom, 160 - lo.scaleBarStart[1]);
  EXPECT_GT(in.top, 0);
  // One column on the right (figures framed on their anatomy): only that side's room grows.
  o.labelSide = render::AnnotationOptions::LabelSide::Right;
  RgbaImage oneSide = a;
  const render::AnnotationLayout lr = render::annotate(oneSide, projection, o, all);
  const render::ImageInsets inR = render::annotationInsets(o, 160, 160, lr.labelTexts);
  ASSERT_EQ(lr.labelBoxes.size(), 2u);
  for (const auto& b : lr.labelBoxes) EXPECT_GE(b.x0, 160 - inR.right) << b.x0;
  EXPECT_EQ(inR.right, in.right);
  EXPECT_LT(inR.left, in.left);
}

std::string readText(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// Runs `vellum illustrate ARGS` with stderr captured; returns the exit code.
int illustrate(const std::string& args, const std::filesystem::path& errFile) {
  const std::string cmd = std::string(VELLUM_CLI_PATH) + " illustrate " + args + " > /dev/null 2> " + errFile.string();
  const int rc = std::system(cmd.c_str());
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

// The command: an invisible muscle gets no label and no room in the frame; the bone's label
// has its display name; a display name for a structure that does not exist is an error.
TEST(FigureCli, IllustrateFramesAndLabelsOnlyWhatItDraws) {
  const auto dir = test::tempDir("figure-cli");
  const ShapeScene scene = test::twoSpheres(40);
  test::writeShapeFolder(scene, dir / "shape");
  io::saveVolume(VolumeI16(scene.distance.geometry(), -1000, -1000), dir / "ct.nrrd");
  Style st = test::twoRowStyle();
  st.segments[1].visible = false;
  saveStyle(st, dir / "style.json");
  const std::string base = (dir / "ct.nrrd").string() + " --shape " + (dir / "shape").string() + " --style " +
                           (dir / "style.json").string() + " --size 160x120 --fov 0 --azimuth 0 --elevation 0 ";
  const auto err = dir / "err.txt";
  ASSERT_EQ(illustrate(base + "--labels --label-name 'bone=Tibia and fibula' --label-size 9 --report " +
                           (dir / "r.json").string() + " --out " + (dir / "fig.png").string(),
                       err),
            0)
      << readText(err);
  const auto r = nlohmann::json::parse(readText(dir / "r.json"));
  EXPECT_EQ(r["labels"], nlohmann::json::array({"Tibia and fibula"}));
  EXPECT_EQ(r["camera"]["frame"], "drawn");
  EXPECT_EQ(r["camera"]["zoom"], 1.0);
  // The bone sphere alone (radius 8.8 voxels) against the grid's bounding sphere (34.6): the
  // fit zooms in about 3x even with the label columns' room.
  EXPECT_GT(r["camera"]["zoom_applied"].get<double>(), 2.0);

  ASSERT_EQ(illustrate(base + "--frame volume --report " + (dir / "v.json").string() + " --out " +
                           (dir / "v.png").string(), err),
            0)
      << readText(err);
  EXPECT_EQ(nlohmann::json::parse(readText(dir / "v.json"))["camera"]["zoom_applied"], 1.0);

  EXPECT_EQ(illustrate(base + "--labels --label-name nerve=Nerve --out " + (dir / "x.png").string(), err), 2);  // a usage error (docs/user-guide.md, "Exit codes")
  std::string e = readText(err);
  EXPECT_NE(e.find("--label-name nerve"), std::string::npos) << e;
  EXPECT_EQ(std::count(e.begin(), e.end(), '\n'), 1) << e;
  EXPECT_FALSE(std::filesystem::exists(dir / "x.png"));
  // --remove-table on a CT with two legs and a slab behind them: both legs kept, in the
  // report and in one line on stderr.
  VolumeI16 legs(scene.distance.geometry(), -1000, -1000);
  const Geometry& g = legs.geometry();
  for (int64_t k = 0; k < g.dims.z; ++k)
    for (int64_t j = 0; j < g.dims.y; ++j)
      for (int64_t i = 0; i < g.dims.x; ++i) {
        const Vec3 p = g.indexToPhysical({double(i), double(j), double(k)});
        for (double cx : {-10.0, 10.0})
          if ((p.x - cx) * (p.x - cx) + p.y * p.y <= 49) legs(i, j, k) = 40;
        if (p.y >= 10 && p.y < 13) legs(i, j, k) = 300;  // the slab, 3 mm from the legs
      }
  io::saveVolume(legs, dir / "legs.nrrd");
  ASSERT_EQ(illustrate((dir / "legs.nrrd").string() + " --shape " + (dir / "shape").string() +
                           " --preset textbook --size 64x64 --remove-table --table-min-part-volume 1 "
                           "--table-min-part-thickness 10 --report " + (dir / "t.json").string() + " --out " +
                           (dir / "t.png").string(),
                       err),
            0)
      << readText(err);
  const auto t = nlohmann::json::parse(readText(dir / "t.json"))["table_removal"];
  ASSERT_EQ(t["kept_parts_ml"].size(), 2u) << t;
  for (const auto& ml : t["kept_parts_ml"]) EXPECT_NEAR(ml.get<double>(), 3.14159 * 49 * 40 / 1000, 0.4) << t;
  EXPECT_NEAR(t["removed_ml"].get<double>(), 40 * 3 * 40 / 1000.0, 0.2) << t;
  e = readText(err);
  EXPECT_NE(e.find("--remove-table: kept 2 body parts"), std::string::npos) << e;

  // Not NAME=TEXT.
  EXPECT_EQ(illustrate(base + "--labels --label-name bone --out " + (dir / "x.png").string(), err), 2);
  e = readText(err);
  EXPECT_NE(e.find("NAME=TEXT"), std::string::npos) << e;
}

}  // namespace
}  // namespace vellum::illustration
