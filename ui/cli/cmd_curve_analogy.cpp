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

/// A `vellum shape` folder: its shape.json, segments (in order), meshes and shells.
struct ShapeFolder {
  fs::path dir;
  nlohmann::json shape;
  LabelVolume labels;
  std::vector<ill::Segment> segments;
  std::vector<ill::TriMesh> meshes;
  std::vector<ill::Shell> shells;
  std::string names;  ///< "a, b, c" for messages

  size_t indexOf(const std::string& name, const std::string& what) const {
    for (size_t i = 0; i < segments.size(); ++i)
      if (segments[i].name == name) return i;
    throw Error(what + " " + name + ": no such segment in " + (dir / "shape.json").string() + " (has: " + names + ")");
  }
  nlohmann::json options() const { return shape.value("options", nlohmann::json::object()); }
};

ShapeFolder loadShapeFolder(const fs::path& dir) {
  ShapeFolder f;
  f.dir = dir;
  f.shape = readShapeJson(dir);
  f.labels = io::loadLabels(dir / "segments.nrrd");
  const std::string format = f.options().value("mesh_format", "ply");
  if (format != "ply") throw FileError(dir / "shape.json", "curve-analogy reads PLY meshes; this folder has " + format);
  for (const auto& s : f.shape.at("segments")) {
    ill::Segment seg;
    seg.name = s.at("name").get<std::string>();
    seg.ids = s.at("ids").get<std::vector<uint16_t>>();
    for (const auto& l : f.labels.table())
      if (l.name == seg.name) seg.rgb = l.rgb;
    f.segments.push_back(seg);
    f.meshes.push_back(ill::loadMesh(dir / "meshes" / (seg.name + ".ply")));
    f.names += (f.names.empty() ? "" : ", ") + seg.name;
  }
  if (f.shape.contains("shells"))
    for (const auto& s : f.shape["shells"]) f.shells.push_back({s.at("segment").get<std::string>(), s.at("thickness_mm").get<double>()});
  return f;
}

/// The bent segment and the ones carried along (--transfer), in that order.
std::vector<size_t> carriedSegments(const ShapeFolder& f, const CurveArgs& a) {
  std::vector<size_t> carried{f.indexOf(a.segment, "--segment")};
  for (const auto& t : a.transfer) {
    std::stringstream ss(t);
    std::string name;
    while (std::getline(ss, name, ','))
      if (!name.empty()) carried.push_back(f.indexOf(name, "--transfer"));
  }
  return carried;
}

/// The curve analogy and the carried meshes. A coarse cage can fold a fine mesh where it lies
/// outside the cage (MVC extrapolation near sharp rims): if a moved mesh self-intersects,
/// retry with a finer proxy (at most 3 attempts).
struct Bent {
  ill::CurveAnalogyResult result;
  ill::CurveAnalogyOptions options;
  std::vector<ill::TriMesh> meshes;
  std::vector<ill::MeshChecks> checks;
  double transferMs = 0;
  int attempts = 0;
};

Bent bendWithRetries(const ShapeFolder& f, const std::vector<size_t>& carried, const ill::Polyline2& c0,
                     const render::Projection& proj, ill::CurveAnalogyOptions opt) {
  Bent b;
  for (;;) {
    ++b.attempts;
    b.result = ill::curveAnalogy(f.meshes[carried.front()], c0, proj, opt);
    const auto tt = std::chrono::steady_clock::now();
    const ill::Cage cage = ill::cageOf(b.result.proxy);
    b.meshes = f.meshes;
    for (size_t i : carried) b.meshes[i] = ill::transferMesh(f.meshes[i], cage, b.result.proxyDeformed);
    b.transferMs += 1000 * secondsSince(tt);
    b.checks.clear();
    bool folded = false;
    for (const auto& m : b.meshes) {
      b.checks.push_back(ill::checkMesh(m));
      folded = folded || b.checks.back().selfIntersections > 0;
    }
    if (!folded || b.attempts >= 3) break;
    std::fprintf(stderr, "curve-analogy: a moved mesh self-intersects with a %zu-face proxy; retrying with %lld faces\n",
                 b.result.proxy.faces.size(), static_cast<long long>(2 * opt.proxyFaces));
    opt.proxyFaces *= 2;
  }
  b.options = opt;
  return b;
}

/// The proxy mesh with its deformed vertices.
ill::TriMesh deformedProxy(const ill::CurveAnalogyResult& r) {
  ill::TriMesh after = r.proxy;
  for (size_t i = 0; i < after.vertices.size(); ++i)
    after.vertices[i] = {float(r.proxyDeformed[i].x), float(r.proxyDeformed[i].y), float(r.proxyDeformed[i].z)};
  return after;
}

/// Distance and segmentation volumes of the moved meshes. Shells widen the exact band; grow
/// offsets shift a segment's distances (as runShapePipeline).
void rebuildVolumes(const ShapeFolder& f, const std::vector<ill::TriMesh>& meshes, VolumeF32& unionDistance,
                    LabelVolume& segmentation) {
  const Geometry& grid = f.labels.geometry();
  ill::DistanceOptions dopt;
  dopt.bandMm = f.options().value("exact_band_mm", 0.0);
  const size_t n = f.segments.size();
  std::vector<double> extra(n, 0.0), offset(n, 0.0);
  for (const auto& s : f.shells) {
    const size_t i = f.indexOf(s.segment, "shells in shape.json:");
    extra[i] = std::max(extra[i], s.thicknessMm);
  }
  if (f.shape.contains("grows"))
    for (const auto& g : f.shape["grows"])
      offset[f.indexOf(g.at("segment").get<std::string>(), "grows in shape.json:")] += g.at("offset_mm").get<double>();
  for (size_t i = 0; i < n; ++i) extra[i] = std::max(extra[i] + std::max(0.0, -offset[i]), std::abs(offset[i]));
  auto dist = ill::signedDistances(meshes, grid, dopt, extra);
  for (size_t i = 0; i < n; ++i)
    if (offset[i] != 0) {
      for (float& v : dist[i].voxels()) v -= static_cast<float>(offset[i]);
      dist[i].setBackground(dist[i].background() - std::abs(offset[i]));
    }
  ill::buildRepresentation(dist, f.segments, f.shells, unionDistance, segmentation);
  unionDistance.setGeometry(grid);
}

/// OUT/meshes, OUT/curve_analogy (proxies, curves, the before/after plate) and the map.
/// Returns shape.json's content for OUT (the input's, with the new segments' checks).
nlohmann::json writeOutputs(const CurveArgs& a, const ShapeFolder& f, const Bent& b, int width, int height,
                            const std::vector<float>& map) {
  const fs::path out = a.out;
  fs::create_directories(out / "meshes");
  nlohmann::json j = f.shape;
  j["segments"] = nlohmann::json::array();
  for (size_t i = 0; i < f.segments.size(); ++i) {
    ill::saveMesh(b.meshes[i], out / "meshes" / (f.segments[i].name + ".ply"), "ply");
    const auto& c = b.checks[i];
    j["segments"].push_back({{"name", f.segments[i].name}, {"ids", f.segments[i].ids},
                             {"vertices", b.meshes[i].vertices.size()}, {"faces", b.meshes[i].faces.size()},
                             {"closed", c.closed}, {"manifold", c.manifold}, {"outward", c.outward},
                             {"self_intersections", c.selfIntersections}, {"volume_mm3", c.volumeMm3}});
  }
  const ill::CurveAnalogyResult& r = b.result;
  fs::create_directories(out / "curve_analogy");
  ill::saveMesh(r.proxy, out / "curve_analogy" / "proxy_before.ply", "ply");
  ill::saveMesh(deformedProxy(r), out / "curve_analogy" / "proxy_after.ply", "ply");
  writeJsonFile(curveJson(r.c1), out / "curve_analogy" / "c1.json");
  writeJsonFile(curveJson(r.c0Aligned), out / "curve_analogy" / "c0_aligned.json");
  writeJsonFile(curveJson(r.c1Deformed), out / "curve_analogy" / "c1_deformed.json");
  writeJsonFile(curveJson(r.silhouetteAfter), out / "curve_analogy" / "silhouette_after.json");
  ill::writeCurvePlate(out / "curve_analogy" / "before_after.png", width, height, r.c1, r.c0Aligned, r.silhouetteAfter);
  if (!map.empty()) {
    ensureParentFolder(a.mapOut);
    deformation::saveBackwardMapNrrd(map, f.labels.geometry(), a.mapOut);
  }
  return j;
}

/// shape.json's "curve_analogy" entry (and --report), without the timings.
nlohmann::json curveAnalogyReport(const CurveArgs& a, const ShapeFolder& f, const std::vector<size_t>& carried,
                                  const Bent& b, const render::RenderSettings& view, const render::Projection& proj,
                                  int width, int height) {
  const ill::CurveAnalogyResult& r = b.result;
  const ill::CurveAnalogyOptions& opt = b.options;
  const auto proxyChecks = ill::checkMesh(deformedProxy(r));
  nlohmann::json ca;
  ca["input"] = a.dir;
  ca["segment"] = a.segment;
  for (size_t i : carried) ca["moved"].push_back(f.segments[i].name);
  ca["c0"] = a.curve.empty() ? a.drawing : a.curve;
  ca["view"] = {{"azimuth_deg", view.camera.azimuthDeg}, {"elevation_deg", view.camera.elevationDeg},
                {"width", width}, {"height", height}, {"pixels_per_mm", proj.pixelsPerMm()},
                {"projection", "orthographic"}};
  ca["options"] = {{"samples", opt.samples}, {"lambda", opt.lambda}, {"anchors", opt.anchors},
                   {"proxy_faces", opt.proxyFaces}, {"arap_iterations", opt.arapIterations},
                   {"fixed_vertices", opt.fixedVertices}, {"map_step", a.mapStep}};
  ca["proxy"] = {{"faces", r.proxy.faces.size()}, {"closed", proxyChecks.closed},
                 {"manifold", proxyChecks.manifold}, {"self_intersections", proxyChecks.selfIntersections}};
  ca["attempts"] = b.attempts;
  ca["anchors"] = r.anchors;
  ca["handles"] = r.handles;
  ca["hausdorff_before_px"] = r.hausdorffBeforePx;
  ca["hausdorff_after_px"] = r.hausdorffAfterPx;
  ca["hausdorff_before_mm"] = r.hausdorffBeforePx / proj.pixelsPerMm();
  ca["hausdorff_after_mm"] = r.hausdorffAfterPx / proj.pixelsPerMm();
  ca["plate"] = (fs::path(a.out) / "curve_analogy" / "before_after.png").string();
  if (!a.mapOut.empty()) ca["map"] = a.mapOut;
  ca["threads"] = workerCount();
  return ca;
}

void runCurveAnalogy(const CurveArgs& a) {
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  if (a.curve.empty() == a.drawing.empty()) throw Error("give exactly one of --curve C0.json or --drawing IMG");
  refuseOverwritingInput(a.dir, a.out);
  const ShapeFolder folder = loadShapeFolder(a.dir);
  const Geometry& grid = folder.labels.geometry();
  const std::vector<size_t> carried = carriedSegments(folder, a);

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
  const Bent bent = bendWithRetries(folder, carried, c0, proj, opt);
  const ill::CurveAnalogyResult& r = bent.result;

  auto tt = Clock::now();
  VolumeF32 unionDistance;
  LabelVolume segmentation;
  rebuildVolumes(folder, bent.meshes, unionDistance, segmentation);
  const double volumesMs = 1000 * secondsSince(tt);

  tt = Clock::now();
  double mapMs = 0;
  std::vector<float> map;
  if (!a.mapOut.empty()) {
    map = ill::cageBackwardMap(ill::cageOf(r.proxy), r.proxyDeformed, grid, a.mapStep);
    mapMs = 1000 * secondsSince(tt);
  }

  tt = Clock::now();
  const fs::path out = a.out;
  fs::create_directories(out);
  io::SaveOptions raw;
  raw.gzip = false;
  io::saveVolume(unionDistance, out / "distance.nrrd", raw);
  io::saveLabels(segmentation, out / "segments.nrrd");
  nlohmann::json j = writeOutputs(a, folder, bent, width, height, map);
  const double writeMs = 1000 * secondsSince(tt);

  nlohmann::json ca = curveAnalogyReport(a, folder, carried, bent, view, proj, width, height);
  ca["timings_ms"] = {{"load", loadMs}, {"proxy", r.proxyMs}, {"curve", r.curveMs}, {"arap", r.arapMs},
                      {"transfer", bent.transferMs}, {"volumes", volumesMs}, {"map", mapMs},
                      {"write", writeMs}, {"total", 1000 * secondsSince(t0)}};
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
