// app::runCurveAnalogy: the curve analogy pipeline of `vellum curve-analogy` and the studio.
#include "vellum/app/curve_analogy_pipeline.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "vellum/app/outputs.hpp"
#include "vellum/app/run_report.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/json_input.hpp"
#include "vellum/core/parallel.hpp"
#include "vellum/deformation/map_file.hpp"
#include "vellum/illustration/curve_analogy.hpp"
#include "vellum/io/volume_io.hpp"
#include "vellum/render/projection.hpp"

namespace vellum::app {
namespace ill = vellum::illustration;
namespace fs = std::filesystem;
namespace {

double msSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

nlohmann::json readShapeJson(const fs::path& dir) {
  const fs::path p = dir / "shape.json";
  if (!fs::exists(p)) throw FileError(p, "no such file (is " + dir.string() + " a `vellum shape` folder?)");
  return readJsonFile(p, 16u << 20, "shape report");  // a segment list: KBs
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
std::vector<size_t> carriedSegments(const ShapeFolder& f, const CurveAnalogyRequest& a) {
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
    b.transferMs += msSince(tt);
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
                    LabelVolume& segmentation, std::vector<ill::SegmentField>& fields) {
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
  fields = ill::makeSegmentFields(dist, f.segments, f.shells);
}

/// `out`/meshes, `out`/curve_analogy (proxies, curves, the before/after plate) and the map.
/// Returns shape.json's content for the output folder (the input's, with the new segments' checks).
nlohmann::json writeOutputs(const CurveAnalogyRequest& a, const fs::path& out, const ShapeFolder& f, const Bent& b,
                            int width, int height, const std::vector<float>& map) {
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
nlohmann::json curveAnalogyReport(const CurveAnalogyRequest& a, const ShapeFolder& f, const std::vector<size_t>& carried,
                                  const Bent& b, const render::RenderSettings& view, const render::Projection& proj,
                                  int width, int height) {
  const ill::CurveAnalogyResult& r = b.result;
  const ill::CurveAnalogyOptions& opt = b.options;
  const auto proxyChecks = ill::checkMesh(deformedProxy(r));
  nlohmann::json ca;
  ca["input"] = a.dir;
  ca["segment"] = a.segment;
  for (size_t i : carried) ca["moved"].push_back(f.segments[i].name);
  ca["c0"] = a.curveSource;
  ca["view"] = {{"azimuth_deg", view.camera.azimuthDeg}, {"elevation_deg", view.camera.elevationDeg},
                {"width", width}, {"height", height}, {"pixels_per_mm", proj.pixelsPerMm()},
                {"projection", view.camera.fieldOfViewDeg > 0 ? "perspective" : "orthographic"}};
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

}  // namespace

CurveAnalogyResult runCurveAnalogy(const CurveAnalogyRequest& a, Progress& progress) {
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  if (a.curve.size() < 3)
    throw Error("curve analogy: C0 (" + (a.curveSource.empty() ? std::string("the curve") : a.curveSource) +
                ") has " + std::to_string(a.curve.size()) + " points; at least 3 are needed");
  if (a.out.empty()) throw Error("curve analogy: no output folder");
  std::error_code ec;
  io::OutputPlan()
      .input(a.dir, "the input shape folder")
      .input(fs::is_regular_file(a.curveSource, ec) ? fs::path(a.curveSource) : fs::path(), "C0's file")
      .folder(a.out, io::FolderKind::Shape, "--out")
      .output(a.mapOut, "--map-out")
      .json(a.report, "--report")
      .force(a.force)
      .check();
  progress.begin("curve analogy", 5);
  const ShapeFolder folder = loadShapeFolder(a.dir);
  const Geometry& grid = folder.labels.geometry();
  const std::vector<size_t> carried = carriedSegments(folder, a);
  const int width = a.view.width, height = a.view.height;
  const render::Projection proj(grid, a.view);
  const double loadMs = msSince(t0);
  progress.advance();

  ill::CurveAnalogyOptions opt;
  opt.samples = a.samples;
  opt.lambda = a.lambda;
  opt.anchors = a.anchors;
  opt.proxyFaces = a.proxyFaces;
  const Bent bent = bendWithRetries(folder, carried, a.curve, proj, opt);
  const ill::CurveAnalogyResult& r = bent.result;
  progress.advance();

  auto tt = Clock::now();
  VolumeF32 unionDistance;
  LabelVolume segmentation;
  std::vector<ill::SegmentField> fields;
  rebuildVolumes(folder, bent.meshes, unionDistance, segmentation, fields);
  const double volumesMs = msSince(tt);
  progress.advance();

  tt = Clock::now();
  double mapMs = 0;
  std::vector<float> map;
  if (!a.mapOut.empty()) {
    map = ill::cageBackwardMap(ill::cageOf(r.proxy), r.proxyDeformed, grid, a.mapStep);
    mapMs = msSince(tt);
  }
  progress.advance();

  tt = Clock::now();
  nlohmann::json j, ca;
  ensureParentFolder(a.out);
  RunOutputs written;
  io::writeFolderAtomically(a.out, io::FolderKind::Shape, [&](const fs::path& out) {
    io::SaveOptions raw;
    raw.gzip = false;
    io::saveVolume(unionDistance, out / "distance.nrrd", raw);
    io::saveLabels(segmentation, out / "segments.nrrd");
    ill::saveSegmentFields(fields, out);
    j = writeOutputs(a, out, folder, bent, width, height, map);
    if (!map.empty()) written.wrote(a.mapOut);
    const double writeMs = msSince(tt);
    ca = curveAnalogyReport(a, folder, carried, bent, a.view, proj, width, height);
    ca["timings_ms"] = {{"load", loadMs}, {"proxy", r.proxyMs}, {"curve", r.curveMs}, {"arap", r.arapMs},
                        {"transfer", bent.transferMs}, {"volumes", volumesMs}, {"map", mapMs},
                        {"write", writeMs}, {"total", msSince(t0)}};
    j["curve_analogy"] = ca;
    writeJsonFile(j, out / "shape.json");
  }, a.force);
  if (!a.report.empty()) {
    written.wrote(a.out);  // a report that cannot be written takes the folder with it
    RunReport shared(a.commandLine, t0);
    shared.input(a.dir, "shape folder");
    shared.output(a.out);
    shared.outputVolume(a.mapOut);
    shared.stamp(ca);
    writeJsonFile(ca, a.report);
  }
  written.commit();
  progress.advance();
  progress.end();
  return {j, ca};
}

}  // namespace vellum::app
