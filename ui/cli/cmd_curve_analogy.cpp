// `vellum curve-analogy DIR --segment NAME (--curve C0.json | --drawing IMG) --out DIR2`:
// bends a shape folder's segment toward an illustrator's outline (issue 9, [SAVI 2.3] in
// docs/references.md), carries other segments along (--transfer), rebuilds the distance and segmentation
// volumes, and writes the CT backward map (--map-out) in `deform --map-out`'s format.
#include <chrono>
#include <cmath>
#include <limits>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>

#include "cli_params.hpp"
#include "cli_util.hpp"
#include "commands.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/parallel.hpp"
#include "vellum/deformation/map_file.hpp"
#include "vellum/app/curve_analogy_pipeline.hpp"
#include "vellum/illustration/curve_analogy.hpp"
#include "vellum/io/volume_io.hpp"

namespace vellum::cli {
namespace ill = vellum::illustration;
namespace fs = std::filesystem;
namespace {

/// The request's fields (and defaults) are the flags; C0 and the view come from these.
struct CurveArgs {
  app::CurveAnalogyRequest request;
  std::string curve, drawing, view = "front", size = "512x512";
  std::optional<double> azimuth;  ///< overrides --view when given
  double elevation = 0;
  int darkThreshold = 128;
};

/// The flags of `curve-analogy` besides its paths, described once (docs/parameters.md).
const params::Table<CurveArgs>& curveFlagsTable() {
  using A = CurveArgs;
  using R = app::CurveAnalogyRequest;
  static const params::Table<A> t{
      params::text<A>("segment", params::nested(&A::request, &R::segment),
                      {"Segment", "the segment whose outline follows the curve", ""}),
      params::real<A>("azimuth", &A::azimuth, {"Azimuth", "camera azimuth; overrides --view", "degrees"}),
      params::text<A>("view", &A::view, {"View", "the orthographic view the curve is drawn in", ""},
                      {"front", "side", "top", "oblique"}),
      params::real<A>("elevation", &A::elevation, {"Elevation", "camera elevation, with --azimuth", "degrees", -90, 90}),
      params::text<A>("size", &A::size, {"Size", "image size WxH the --curve pixels refer to", "px"}),
      params::real<A>("lambda", params::nested(&A::request, &R::lambda),
                      {"Lambda", "anchor weight of the Laplacian curve deformation", "", 0}),
      params::integer<A>("anchors", params::nested(&A::request, &R::anchors),
                         {"Anchors", "curve points kept in place (where the drawing agrees best)", "", 0}),
      params::integer<A>("samples", params::nested(&A::request, &R::samples),
                         {"Samples", "points of the resampled curves", "", 3}),
      params::integer<A>("proxy_faces", params::nested(&A::request, &R::proxyFaces),
                         {"Proxy faces", "face budget of the proxy (cage) mesh; doubled (twice at most) while a moved "
                                         "mesh self-intersects",
                          "", 1}),
      params::integer<A>("dark_threshold", &A::darkThreshold,
                         {"Dark threshold", "--drawing: grey level below which a pixel is a stroke", "", 0, 255}),
      params::integer<A>("map_step", params::nested(&A::request, &R::mapStep),
                         {"Map step", "voxels between exact map samples (trilinear in between)", "voxels", 1}),
  };
  return t;
}

render::RenderSettings viewSettings(const CurveArgs& a, int width, int height) {
  render::RenderSettings s;
  s.width = width;
  s.height = height;
  s.camera.fieldOfViewDeg = 0;  // orthographic: an illustration plate has no perspective
  s.camera.zoom = 1.0;
  s.camera.panMm = {0, 0, 0};
  if (a.azimuth) {
    s.camera.azimuthDeg = *a.azimuth;
    s.camera.elevationDeg = a.elevation;
  } else if (a.view == "front") {
    s.camera.azimuthDeg = 0, s.camera.elevationDeg = 0;
  } else if (a.view == "side") {
    s.camera.azimuthDeg = 90, s.camera.elevationDeg = 0;
  } else if (a.view == "top") {
    s.camera.azimuthDeg = 0, s.camera.elevationDeg = 89;  // 90 would make "up" undefined
  } else if (a.view == "oblique") {
    s.camera.azimuthDeg = 40, s.camera.elevationDeg = 20;
  } else {
    throw Error("--view '" + a.view + "': expected front, side, top or oblique");
  }
  render::validate(s);
  return s;
}

void runCurveAnalogy(const CurveArgs& a) {
  const auto t0 = std::chrono::steady_clock::now();
  if (a.curve.empty() == a.drawing.empty()) throw Error("give exactly one of --curve C0.json or --drawing IMG");
  app::CurveAnalogyRequest r = a.request;
  // C0 and the view: the drawing is read as the view's image at the drawing's own size.
  int width = 0, height = 0;
  if (!a.drawing.empty()) {
    r.curve = ill::loadDrawingOutline(a.drawing, width, height, a.darkThreshold);
    r.curveSource = a.drawing;
  } else {
    std::tie(width, height) = parseSize(a.size);
    r.curve = ill::loadCurveJson(a.curve);
    r.curveSource = a.curve;
  }
  r.view = viewSettings(a, width, height);
  r.commandLine = commandLine();
  ProgressBar bar;
  const app::CurveAnalogyResult o = app::runCurveAnalogy(r, bar.progress());
  bar.finish();
  const nlohmann::json& ca = o.report;
  std::printf("curve analogy of %s -> %s: Hausdorff %.2f -> %.2f px (%.2f -> %.2f mm); proxy %zu faces; %.2f s\n",
              r.segment.c_str(), r.out.string().c_str(), ca["hausdorff_before_px"].get<double>(),
              ca["hausdorff_after_px"].get<double>(), ca["hausdorff_before_mm"].get<double>(),
              ca["hausdorff_after_mm"].get<double>(), ca["proxy"]["faces"].get<size_t>(), secondsSince(t0));
  for (const auto& s : o.shape["segments"])
    std::printf("  %-12s %7zu faces  closed=%d manifold=%d self-intersections=%lld\n",
                s["name"].get<std::string>().c_str(), s["faces"].get<size_t>(), s["closed"].get<bool>(),
                s["manifold"].get<bool>(), static_cast<long long>(s["self_intersections"].get<int64_t>()));
}

/// The demo's drawing: a side view (512x512 pixels, as `--view side` sees the phantom) of a
/// lower leg whose calf bulges backwards, traced as one closed pen outline.
constexpr int kCalf[][2] = {
    {174, 88}, {168, 93}, {169, 103}, {170, 113}, {170, 123}, {170, 133}, {170, 144}, {171, 153},
    {172, 163}, {173, 173}, {173, 183}, {173, 193}, {173, 204}, {173, 214}, {172, 224},
    {170, 234}, {167, 244}, {163, 254}, {158, 264}, {155, 274}, {152, 284}, {150, 295},
    {151, 305}, {153, 315}, {157, 325}, {160, 335}, {163, 345}, {166, 355}, {168, 365},
    {169, 376}, {170, 386}, {170, 396}, {170, 406}, {170, 416}, {173, 422}, {183, 423},
    {193, 423}, {203, 423}, {214, 423}, {224, 423}, {234, 423}, {244, 423}, {255, 423},
    {265, 423}, {275, 423}, {285, 423}, {296, 423}, {306, 423}, {316, 423}, {326, 423},
    {337, 423}, {341, 418}, {341, 408}, {341, 397}, {341, 387}, {341, 377}, {341, 367},
    {341, 357}, {340, 347}, {340, 337}, {339, 326}, {339, 316}, {339, 306}, {338, 296},
    {338, 286}, {338, 276}, {337, 266}, {337, 256}, {337, 245}, {337, 235}, {337, 225},
    {337, 215}, {337, 205}, {337, 195}, {338, 185}, {338, 174}, {338, 164}, {338, 154},
    {339, 144}, {339, 134}, {340, 124}, {341, 114}, {342, 105}, {343, 95}, {338, 88}, {328, 88},
    {318, 88}, {308, 88}, {297, 88}, {287, 88}, {277, 88}, {267, 88}, {256, 88}, {246, 88},
    {236, 88}, {226, 88}, {215, 88}, {205, 88}, {195, 88}, {185, 88}};

std::string quoted(const fs::path& p) { return "\"" + p.string() + "\""; }

}  // namespace

const ListTable<CurveArgs>& curveListTable() {
  static const ListTable<CurveArgs> t{
      repeated<CurveArgs>("transfer", params::nested(&CurveArgs::request, &app::CurveAnalogyRequest::transfer),
                          "NAME[,NAME..]", {"Transfer", "other segments moved by the cage (repeatable)", ""}),
  };
  return t;
}

std::string curveAnalogyFlagsMarkdown() {
  return params::markdown(curveFlagsTable()) + listMarkdownRows(curveListTable());
}

void demoCurveAnalogy(const DemoContext& ctx) {
  const fs::path dir = ctx.outDir / "curve-analogy";
  fs::create_directories(dir);
  ill::Polyline2 calf;
  for (const auto& p : kCalf) calf.push_back({double(p[0]), double(p[1])});
  ill::writeCurveDrawing(dir / "calf-drawing.png", 512, 512, calf, 3);
  // The same code paths as the commands: shape folder, then the curve analogy from the drawing.
  auto runCli = [](const std::string& line) {
    CLI::App app;
    addShapeCommand(app);
    addCurveAnalogyCommand(app);
    app.parse(line, false);
  };
  runCli("shape " + quoted(ctx.phantomCt) + " --labels " + quoted(ctx.phantomLabels) +
         " --segment skin=1,2,3,4,5,6,7,8,9,10,11 --segment bone=4,5,6,7,8,9,11 --out " + quoted(dir / "shape"));
  runCli("curve-analogy " + quoted(dir / "shape") + " --segment skin --drawing " + quoted(dir / "calf-drawing.png") +
         " --view side --transfer bone --out " + quoted(dir / "bent") + " --map-out " + quoted(dir / "bent-map.nrrd") +
         " --report " + quoted(dir / "report.json"));
  std::cout << "curve analogy: " << (dir / "bent" / "curve_analogy" / "before_after.png").string() << "\n";
}

void addCurveAnalogyCommand(CLI::App& app) {
  auto a = std::make_shared<CurveArgs>();
  auto* cmd = app.add_subcommand("curve-analogy", "Bend a shape folder's segment toward an illustrator's outline (curve analogy), carry other segments and the CT along");
  addInput(*cmd, "dir", a->request.dir, "input shape folder (from `vellum shape`)")->required();
  addInput(*cmd, "--curve", a->curve, "C0 as JSON {\"points\": [[x, y], ...]} in image pixels of the view (--size)");
  addInput(*cmd, "--drawing", a->drawing, "C0 from a drawing (PNG/JPG): outer contour of its dark strokes; the view's image has the drawing's size");
  addFlags(*cmd, *a, curveFlagsTable(), {}, "", {{"segment", "-s"}}).at("segment")->required();
  addLists(*cmd, *a, curveListTable());  // --transfer
  addOutput(*cmd, "--out,-o", a->request.out, "output shape folder (+ curve_analogy/ with curves, proxies, before_after.png)")->required();
  addOutput(*cmd, "--map-out", a->request.mapOut, "CT backward map NRRD (format of `deform --map-out`)");
  addOutput(*cmd, "--report", a->request.report, "also write the curve-analogy report JSON here");
  addForceFlag(*cmd, a->request.force);
  cmd->footer("Example: vellum curve-analogy shape/ --segment skin --drawing calf.png --view side --transfer bone --out shape-bent/ --map-out bent-map.nrrd");
  cmd->callback([a] { runCurveAnalogy(*a); });
}

}  // namespace vellum::cli
