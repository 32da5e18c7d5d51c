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

#include "cli_util.hpp"
#include "commands.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/parallel.hpp"
#include "vellum/deformation/map_file.hpp"
#include "vellum/illustration/curve_analogy.hpp"
#include "vellum/io/volume_io.hpp"

namespace vellum::cli {
namespace ill = vellum::illustration;
namespace fs = std::filesystem;
namespace {

struct CurveArgs {
  std::string dir, segment, curve, drawing, view = "front", out, mapOut, report, size = "512x512";
  std::vector<std::string> transfer;
  double azimuth = std::numeric_limits<double>::quiet_NaN(), elevation = 0;
  double lambda = 10.0;
  int anchors = 4, samples = 200, mapStep = 4, darkThreshold = 128;
  int64_t proxyFaces = 2000;
};

render::RenderSettings viewSettings(const CurveArgs& a, int width, int height) {
  render::RenderSettings s;
  s.width = width;
  s.height = height;
  s.camera.fieldOfViewDeg = 0;  // orthographic: an illustration plate has no perspective
  s.camera.zoom = 1.0;
  s.camera.panMm = {0, 0, 0};
  if (!std::isnan(a.azimuth)) {
    s.camera.azimuthDeg = a.azimuth;
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

nlohmann::json readShapeJson(const fs::path& dir) {
  const fs::path p = dir / "shape.json";
  std::ifstream is(p);
  if (!is) throw FileError(p, "cannot open (is " + dir.string() + " a `vellum shape` folder?)");
  try {
    return nlohmann::json::parse(is);
  } catch (const std::exception& e) {
    throw FileError(p, std::string("not valid JSON: ") + e.what());
  }
}

nlohmann::json curveJson(const ill::Polyline2& c) {
  nlohmann::json pts = nlohmann::json::array();
  for (const auto& p : c) pts.push_back({p.x, p.y});
  return {{"points", pts}};
}

void runCurveAnalogy(const CurveArgs& a) {
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  if (a.curve.empty() == a.drawing.empty()) throw Error("give exactly one of --curve C0.json or --drawing IMG");
  refuseOverwritingInput(a.dir, a.out);
  const fs::path dir = a.dir, out = a.out;
  const nlohmann::json shape = readShapeJson(dir);
  const LabelVolume labels = io::loadLabels(dir / "segments.nrrd");
  const Geometry& grid = labels.geometry();

  // Segments, shells and meshes of the input folder, in its order.
  std::vector<ill::Segment> segments;
  std::vector<ill::TriMesh> meshes;
  const std::string format = shape.value("options", nlohmann::json::object()).value("mesh_format", "ply");
  if (format != "ply") throw FileError(dir / "shape.json", "curve-analogy reads PLY meshes; this folder has " + format);
  std::string names;
  for (const auto& s : shape.at("segments")) {
    ill::Segment seg;
    seg.name = s.at("name").get<std::string>();
    seg.ids = s.at("ids").get<std::vector<uint16_t>>();
    for (const auto& l : labels.table())
      if (l.name == seg.name) seg.rgb = l.rgb;
    segments.push_back(seg);
    meshes.push_back(ill::loadMesh(dir / "meshes" / (seg.name + ".ply")));
    names += (names.empty() ? "" : ", ") + seg.name;
  }
  std::vector<ill::Shell> shells;
  if (shape.contains("shells"))
    for (const auto& s : shape["shells"]) shells.push_back({s.at("segment").get<std::string>(), s.at("thickness_mm").get<double>()});
  auto indexOf = [&](const std::string& name, const char* flag) {
    for (size_t i = 0; i < segments.size(); ++i)
      if (segments[i].name == name) return i;
    throw Error(std::string(flag) + " " + name + ": no such segment in " + (dir / "shape.json").string() + " (has: " + names + ")");
  };
  const size_t target = indexOf(a.segment, "--segment");
  std::vector<size_t> carried{target};
  for (const auto& t : a.transfer) {
    std::stringstream ss(t);
    std::string name;
    while (std::getline(ss, name, ','))
      if (!name.empty()) carried.push_back(indexOf(name, "--transfer"));
  }

  // C0 and the view: the drawing is read as the view's image at the drawing's own size.
  int width = 0, height = 0;
  ill::Polyline2 c0;
  if (!a.drawing.empty()) {
    c0 = ill::loadDrawingOutline(a.drawing, width, height, a.darkThreshold);
  } else {
    std::tie(width, height) = parseSize(a.size);
    c0 = ill::loadCurveJson(a.curve);
  }
  const render::RenderSettings view = viewSettings(a, width, height);
  const render::Projection proj(grid, view);
  const double loadMs = 1000 * secondsSince(t0);

  ill::CurveAnalogyOptions opt;
  opt.samples = a.samples;
  opt.lambda = a.lambda;
  opt.anchors = a.anchors;
  opt.proxyFaces = a.proxyFaces;
  // A coarse cage can fold a fine mesh where it lies outside the cage (MVC extrapolation
  // near sharp rims): if a moved mesh self-intersects, retry with a finer proxy.
  ill::CurveAnalogyResult r;
  std::vector<ill::TriMesh> outMeshes;
  std::vector<ill::MeshChecks> checks;
  double transferMs = 0;
  int attempts = 0;
  for (;;) {
    ++attempts;
    r = ill::curveAnalogy(meshes[target], c0, proj, opt);
    auto tt = Clock::now();
    const ill::Cage cage = ill::cageOf(r.proxy);
    outMeshes = meshes;
    for (size_t i : carried) outMeshes[i] = ill::transferMesh(meshes[i], cage, r.proxyDeformed);
    transferMs += 1000 * secondsSince(tt);
    checks.clear();
    bool folded = false;
    for (const auto& m : outMeshes) {
      checks.push_back(ill::checkMesh(m));
      folded = folded || checks.back().selfIntersections > 0;
    }
    if (!folded || attempts >= 3) break;
    std::fprintf(stderr, "curve-analogy: a moved mesh self-intersects with a %zu-face proxy; retrying with %lld faces\n",
                 r.proxy.faces.size(), static_cast<long long>(2 * opt.proxyFaces));
    opt.proxyFaces *= 2;
  }
  const ill::Cage cage = ill::cageOf(r.proxy);

  auto tt = Clock::now();
  ill::DistanceOptions dopt;
  dopt.bandMm = shape.value("options", nlohmann::json::object()).value("exact_band_mm", 0.0);
  // Shells widen the exact band; grow offsets shift a segment's distances (as runShapePipeline).
  std::vector<double> extra(segments.size(), 0.0), offset(segments.size(), 0.0);
  for (const auto& s : shells) {
    const size_t i = indexOf(s.segment, "shells in shape.json:");
    extra[i] = std::max(extra[i], s.thicknessMm);
  }
  if (shape.contains("grows"))
    for (const auto& g : shape["grows"])
      offset[indexOf(g.at("segment").get<std::string>(), "grows in shape.json:")] += g.at("offset_mm").get<double>();
  for (size_t i = 0; i < segments.size(); ++i)
    extra[i] = std::max(extra[i] + std::max(0.0, -offset[i]), std::abs(offset[i]));
  auto dist = ill::signedDistances(outMeshes, grid, dopt, extra);
  for (size_t i = 0; i < segments.size(); ++i)
    if (offset[i] != 0) {
      for (float& v : dist[i].voxels()) v -= static_cast<float>(offset[i]);
      dist[i].setBackground(dist[i].background() - std::abs(offset[i]));
    }
  VolumeF32 unionDistance;
  LabelVolume segmentation;
  ill::buildRepresentation(dist, segments, shells, unionDistance, segmentation);
  unionDistance.setGeometry(grid);
  const double volumesMs = 1000 * secondsSince(tt);

  tt = Clock::now();
  double mapMs = 0;
  std::vector<float> map;
  if (!a.mapOut.empty()) {
    map = ill::cageBackwardMap(cage, r.proxyDeformed, grid, a.mapStep);
    mapMs = 1000 * secondsSince(tt);
  }

  tt = Clock::now();
  fs::create_directories(out / "meshes");
  io::SaveOptions raw;
  raw.gzip = false;
  io::saveVolume(unionDistance, out / "distance.nrrd", raw);
  io::saveLabels(segmentation, out / "segments.nrrd");
  nlohmann::json j = shape;
  j["segments"] = nlohmann::json::array();
  for (size_t i = 0; i < segments.size(); ++i) {
    ill::saveMesh(outMeshes[i], out / "meshes" / (segments[i].name + ".ply"), "ply");
    const auto& c = checks[i];
    j["segments"].push_back({{"name", segments[i].name}, {"ids", segments[i].ids},
                             {"vertices", outMeshes[i].vertices.size()}, {"faces", outMeshes[i].faces.size()},
                             {"closed", c.closed}, {"manifold", c.manifold}, {"outward", c.outward},
                             {"self_intersections", c.selfIntersections}, {"volume_mm3", c.volumeMm3}});
  }
  fs::create_directories(out / "curve_analogy");
  ill::TriMesh after = r.proxy;
  for (size_t i = 0; i < after.vertices.size(); ++i)
    after.vertices[i] = {float(r.proxyDeformed[i].x), float(r.proxyDeformed[i].y), float(r.proxyDeformed[i].z)};
  ill::saveMesh(r.proxy, out / "curve_analogy" / "proxy_before.ply", "ply");
  ill::saveMesh(after, out / "curve_analogy" / "proxy_after.ply", "ply");
  writeJsonFile(curveJson(r.c1), out / "curve_analogy" / "c1.json");
  writeJsonFile(curveJson(r.c0Aligned), out / "curve_analogy" / "c0_aligned.json");
  writeJsonFile(curveJson(r.c1Deformed), out / "curve_analogy" / "c1_deformed.json");
  writeJsonFile(curveJson(r.silhouetteAfter), out / "curve_analogy" / "silhouette_after.json");
  const fs::path plate = out / "curve_analogy" / "before_after.png";
  ill::writeCurvePlate(plate, width, height, r.c1, r.c0Aligned, r.silhouetteAfter);
  if (!map.empty()) {
    ensureParentFolder(a.mapOut);
    deformation::saveBackwardMapNrrd(map, grid, a.mapOut);
  }
  const double writeMs = 1000 * secondsSince(tt);

  const auto proxyChecks = ill::checkMesh(after);
  nlohmann::json ca;
  ca["input"] = a.dir;
  ca["segment"] = a.segment;
  for (size_t i : carried) ca["moved"].push_back(segments[i].name);
  ca["c0"] = a.curve.empty() ? a.drawing : a.curve;
  ca["view"] = {{"azimuth_deg", view.camera.azimuthDeg}, {"elevation_deg", view.camera.elevationDeg},
                {"width", width}, {"height", height}, {"pixels_per_mm", proj.pixelsPerMm()},
                {"projection", "orthographic"}};
  ca["options"] = {{"samples", opt.samples}, {"lambda", opt.lambda}, {"anchors", opt.anchors},
                   {"proxy_faces", opt.proxyFaces}, {"arap_iterations", opt.arapIterations},
                   {"fixed_vertices", opt.fixedVertices}, {"map_step", a.mapStep}};
  ca["proxy"] = {{"faces", r.proxy.faces.size()}, {"closed", proxyChecks.closed},
                 {"manifold", proxyChecks.manifold}, {"self_intersections", proxyChecks.selfIntersections}};
  ca["attempts"] = attempts;
  ca["anchors"] = r.anchors;
  ca["handles"] = r.handles;
  ca["hausdorff_before_px"] = r.hausdorffBeforePx;
  ca["hausdorff_after_px"] = r.hausdorffAfterPx;
  ca["hausdorff_before_mm"] = r.hausdorffBeforePx / proj.pixelsPerMm();
  ca["hausdorff_after_mm"] = r.hausdorffAfterPx / proj.pixelsPerMm();
  ca["plate"] = plate.string();
  if (!a.mapOut.empty()) ca["map"] = a.mapOut;
  ca["timings_ms"] = {{"load", loadMs}, {"proxy", r.proxyMs}, {"curve", r.curveMs}, {"arap", r.arapMs},
                      {"transfer", transferMs}, {"volumes", volumesMs}, {"map", mapMs},
                      {"write", writeMs}, {"total", 1000 * secondsSince(t0)}};
  ca["threads"] = workerCount();
  j["curve_analogy"] = ca;
  writeJsonFile(j, out / "shape.json");
  if (!a.report.empty()) writeJsonFile(ca, a.report);
  std::printf("curve analogy of %s -> %s: Hausdorff %.2f -> %.2f px (%.2f -> %.2f mm); proxy %zu faces; %.2f s\n",
              a.segment.c_str(), out.string().c_str(), r.hausdorffBeforePx, r.hausdorffAfterPx,
              r.hausdorffBeforePx / proj.pixelsPerMm(), r.hausdorffAfterPx / proj.pixelsPerMm(),
              r.proxy.faces.size(), secondsSince(t0));
  for (const auto& s : j["segments"])
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
  cmd->add_option("dir", a->dir, "input shape folder (from `vellum shape`)")->required();
  cmd->add_option("--segment,-s", a->segment, "segment whose outline follows the curve")->required();
  cmd->add_option("--curve", a->curve, "C0 as JSON {\"points\": [[x, y], ...]} in image pixels of the view (--size)");
  cmd->add_option("--drawing", a->drawing, "C0 from a drawing (PNG/JPG): outer contour of its dark strokes; the view's image has the drawing's size");
  cmd->add_option("--view", a->view, "front | side | top | oblique (orthographic)")->capture_default_str();
  cmd->add_option("--azimuth", a->azimuth, "camera azimuth (deg), overrides --view");
  cmd->add_option("--elevation", a->elevation, "camera elevation (deg), with --azimuth")->capture_default_str();
  cmd->add_option("--size", a->size, "image size WxH the --curve pixels refer to")->capture_default_str();
  cmd->add_option("--lambda", a->lambda, "anchor weight of the Laplacian curve deformation")->capture_default_str();
  cmd->add_option("--anchors", a->anchors, "curve points kept in place (where the drawing agrees best)")->capture_default_str();
  cmd->add_option("--samples", a->samples, "points of the resampled curves")->capture_default_str();
  cmd->add_option("--proxy-faces", a->proxyFaces, "face budget of the proxy (cage) mesh; doubled (twice at most) while a moved mesh self-intersects")->capture_default_str();
  cmd->add_option("--transfer", a->transfer, "NAME[,NAME..]: other segments moved by the cage");
  cmd->add_option("--dark-threshold", a->darkThreshold, "--drawing: grey level below which a pixel is a stroke")->capture_default_str();
  cmd->add_option("--out,-o", a->out, "output shape folder (+ curve_analogy/ with curves, proxies, before_after.png)")->required();
  cmd->add_option("--map-out", a->mapOut, "CT backward map NRRD (format of `deform --map-out`)");
  cmd->add_option("--map-step", a->mapStep, "voxels between exact map samples (trilinear in between)")->capture_default_str();
  cmd->add_option("--report", a->report, "also write the curve-analogy report JSON here");
  cmd->footer("Example: vellum curve-analogy shape/ --segment skin --drawing calf.png --view side --transfer bone --out shape-bent/ --map-out bent-map.nrrd");
  cmd->callback([a] { runCurveAnalogy(*a); });
}

}  // namespace vellum::cli
