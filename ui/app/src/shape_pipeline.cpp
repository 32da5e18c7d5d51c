// `vellum shape` as one call (shape_pipeline.hpp).
#include "vellum/app/shape_pipeline.hpp"

#include <tbb/parallel_invoke.h>

#include <chrono>

#include "vellum/app/figures.hpp"
#include "vellum/app/outputs.hpp"
#include "vellum/app/run_report.hpp"
#include "vellum/app/table_removal.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/parallel.hpp"
#include "vellum/core/params_json.hpp"
#include "vellum/io/nrrd_reader.hpp"

namespace vellum::app {
namespace ill = vellum::illustration;
namespace fs = std::filesystem;
namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

nlohmann::json vec3Json(const Vec3& v) { return {v.x, v.y, v.z}; }

nlohmann::json checksJson(const ill::SegmentShape& s) {
  const auto& c = s.checks;
  return {{"name", s.segment.name}, {"ids", s.segment.ids},
          {"vertices", s.mesh.vertices.size()}, {"faces", s.mesh.faces.size()},
          {"closed", c.closed}, {"manifold", c.manifold}, {"outward", c.outward},
          {"self_intersections", c.selfIntersections},
          {"self_intersections_repaired", c.selfIntersectionsRepaired},
          {"holes_filled", c.holesFilled}, {"degenerate_faces_removed", c.degenerateRemoved},
          {"volume_mm3", c.volumeMm3}, {"voxel_volume_mm3", c.voxelVolumeMm3},
          {"volume_ratio", c.voxelVolumeMm3 > 0 ? c.volumeMm3 / c.voxelVolumeMm3 : 0.0},
          {"max_boundary_distance_mm", c.maxBoundaryDistanceMm}};
}

/// The CT's grid and its labels on it; the labels lose the table with removeTable.
struct ShapeInputs {
  Geometry grid;
  LabelVolume labels;
  std::optional<segmentation::BodyMaskReport> tableRemoval;
  std::vector<std::string> warnings;
};

/// The CT's voxels are used only by --remove-table: otherwise a plain NRRD's grid comes from
/// its header alone (the same header parsing as the loader; a 512x512x350 CT: its inflate and
/// 180 MB less). Other formats, crops, rescales and vector files are loaded as before.
std::optional<Geometry> gridFromHeader(const ShapeRequest& r) {
  if (r.removeTable || !r.load.region.empty() || r.load.rescale || r.load.allowOutsideData || r.load.raw) return {};
  std::error_code ec;
  if (fs::is_directory(r.input, ec) || io::formatForPath(r.input) != "nrrd") return {};
  const io::NrrdLayout layout = io::readNrrdHeader(r.input);
  if (!layout.leadingSizes.empty()) return {};  // not a scalar volume: the loader says why
  return layout.geometry;
}

ShapeInputs loadInputs(const ShapeRequest& r, Progress& progress) {
  ShapeInputs in;
  io::LoadedVolume ct;
  if (const auto grid = gridFromHeader(r)) {
    in.grid = *grid;
  } else {
    io::LoadOptions load = r.load;
    load.progress = &progress;
    ct = io::loadVolume(r.input, load);
    in.grid = geometryOf(ct.volume);
    in.warnings = std::move(ct.warnings);
  }
  // The labels get the input's crop / downsample (the raw-input options describe the CT only).
  in.labels = loadLabelsLike(r.labels, r.load);
  const std::string labels = r.labels.string();
  if (!(in.labels.geometry().dims == in.grid.dims))
    throw Error("--labels " + labels + ": dims " + in.labels.geometry().dims.str() + " differ from the CT's " +
                in.grid.dims.str());
  if (!in.labels.geometry().approxEqual(in.grid, 1e-3))
    throw Error("--labels " + labels + ": spacing/origin/direction differ from the CT's");
  if (r.removeTable) {
    // Labels from a threshold include the CT table: keep only what lies in the body.
    const segmentation::Mask body = ctBodyMask(ct.volume, r.input, *r.removeTable, progress, &in.tableRemoval.emplace());
    uint16_t* ids = in.labels.ids().data();
    for (size_t v = 0; v < in.labels.ids().size(); ++v)
      if (!body.data()[v]) ids[v] = 0;
  }
  return in;
}

/// shape.json: inputs, options, per-segment checks, the label table, shells, grows, timings.
nlohmann::json shapeReport(const ShapeRequest& r, const Geometry& grid, const ill::ShapeResult& s,
                           nlohmann::json timings) {
  const ill::ShapeOptions& opt = r.options;
  nlohmann::json j;
  j["input"] = r.input.string();
  j["labels"] = r.labels.string();
  j["dims"] = {grid.dims.x, grid.dims.y, grid.dims.z};
  j["spacing_mm"] = vec3Json(grid.spacing);
  j["options"] = params::toJson(ill::shapeOptionsTable(), opt);  // keys as in `vellum params`
  j["options"]["exact_band_mm"] = opt.exactBandMm > 0 ? opt.exactBandMm : ill::defaultExactBandMm(grid);
  j["options"]["mesh_format"] = r.meshFormat;
  j["segments"] = nlohmann::json::array();
  for (const auto& shape : s.shapes) j["segments"].push_back(checksJson(shape));
  j["labels_out"] = nlohmann::json::array();
  for (const auto& l : s.segmentation.table())
    j["labels_out"].push_back({{"id", l.id}, {"name", l.name}, {"rgb", l.rgb}});
  for (const auto& sh : r.shells) j["shells"].push_back({{"segment", sh.segment}, {"thickness_mm", sh.thicknessMm}});
  for (const auto& g : r.grows) j["grows"].push_back({{"segment", g.segment}, {"offset_mm", g.offsetMm}});
  j["timings_ms"] = std::move(timings);
  j["threads"] = workerCount();
  return j;
}

}  // namespace

ShapeResult runShape(const ShapeRequest& r, Progress& progress) {
  const auto t0 = Clock::now();
  if (r.meshFormat != "ply" && r.meshFormat != "obj" && r.meshFormat != "stl")
    throw Error("--mesh-format '" + r.meshFormat + "': expected ply, obj or stl");
  io::OutputPlan()
      .input(r.input)
      .input(r.labels, "the --labels map")
      .folder(r.out, io::FolderKind::Shape, "--out")
      .json(r.report, "--report")
      .force(r.force)
      .check();
  ShapeInputs in = loadInputs(r, progress);
  ShapeResult result;
  result.warnings = std::move(in.warnings);
  const double loadMs = msSince(t0);

  std::vector<ill::Segment> segments;
  for (const auto& s : r.segments) segments.push_back(ill::parseSegmentSpec(s, in.labels));
  params::validate(ill::shapeOptionsTable(), r.options);
  const auto tp = Clock::now();
  ill::ShapeResult& s = result.shape;
  s = ill::runShapePipeline(in.labels, segments, r.shells, r.grows, r.options, progress);
  result.pipelineMs = msSince(tp);
  s.distance.setGeometry(in.grid);
  for (auto& f : s.fields) f.distance.setGeometry(in.grid);

  // The folder is written whole beside its target and then moved into place (a reader never
  // sees a mix of two runs' meshes), with the report first: nothing claims a finished result
  // that is not there.
  const auto tw = Clock::now();
  ensureParentFolder(r.out);
  RunOutputs outputs;  // opened before the folder replaces an older one: a failed run puts it back
  io::writeFolderAtomically(r.out, io::FolderKind::Shape, [&](const fs::path& tmp) {
    fs::create_directories(tmp / "meshes");
    // The three big writes side by side: each is mostly the copy into the page cache (and
    // segments.nrrd its gzip), one core each.
    tbb::parallel_invoke(
        [&] {
          io::SaveOptions raw;
          raw.gzip = false;  // 4 bytes a voxel of smooth floats: gzip would cost seconds for little
          // Moved into the AnyVolume saveVolume takes and back (a copy would be a volume-sized
          // allocation), also when saving throws.
          AnyVolume any(std::move(s.distance));
          struct Back {
            AnyVolume& any;
            VolumeF32& v;
            ~Back() { v = std::move(std::get<VolumeF32>(any)); }
          } back{any, s.distance};
          io::saveVolume(any, tmp / "distance.nrrd", raw);
        },
        [&] { io::saveLabels(s.segmentation, tmp / "segments.nrrd"); },
        [&] { ill::saveSegmentFields(s.fields, tmp); });  // per-segment distances (docs/shape.md)
    for (const auto& shape : s.shapes)
      ill::saveMesh(shape.mesh, tmp / "meshes" / (shape.segment.name + "." + r.meshFormat), r.meshFormat);
    const auto& t = s.times;
    nlohmann::json j = shapeReport(r, in.grid, s,
                                   {{"load", loadMs}, {"denoise", t.denoiseMs}, {"mesh", t.meshMs},
                                    {"process", t.processMs}, {"distances", t.distancesMs},
                                    {"segmentation", t.segmentationMs}, {"pipeline", result.pipelineMs},
                                    {"write", msSince(tw)}, {"total", msSince(t0)}});
    if (in.tableRemoval) j["table_removal"] = tableRemovalJson(*in.tableRemoval);
    writeJsonFile(j, tmp / "shape.json");
    result.report = std::move(j);
  }, r.force);
  if (in.tableRemoval) result.tableRemoval = tableRemovalSummary(*in.tableRemoval);
  outputs.wrote(r.out);  // a report that cannot be written takes the folder with it
  if (!r.report.empty()) {
    RunReport shared(r.commandLine, t0);
    shared.input(r.input, "volume");
    shared.input(r.labels, "label map");
    shared.output(r.out);
    shared.stamp(result.report);
    writeJsonFile(result.report, r.report);
  }
  outputs.commit();
  return result;
}

}  // namespace vellum::app
