#include "loader.hpp"
#include "raw_dialog.hpp"

#include "vellum/core/error.hpp"
#include "vellum/io/volume_io.hpp"

namespace vellum::studio {
namespace fs = std::filesystem;

illustration::ShapeScene loadShapes(const fs::path& folder, const VolumeI16& ct) {
  illustration::ShapeScene shapes = illustration::loadShapeFolder(folder);
  if (!shapes.distance.geometry().approxEqual(ct.geometry(), 1e-3))
    throw FileError(folder, "shape grid " + shapes.distance.dims().str() + " does not match the volume " +
                                ct.geometry().dims.str() + ": make the shape folder from this CT");
  shapes.ct = AnyVolume(ct);  // styles with illum = ct or a CT boundary measure read it
  return shapes;
}

LoadResult loadNow(const LoadRequest& request, Progress& progress) {
  LoadResult r;
  fs::path volumePath = request.path, labelsPath = request.labels;
  std::string seriesUid = request.seriesUid;
  if (request.path.extension() == ".json") {
    r.scene = readSceneFile(request.path);
    r.scenePath = request.path;
    volumePath = r.scene->volume;
    labelsPath = r.scene->labels;
    seriesUid = r.scene->seriesUid;
  }
  io::LoadOptions options;
  options.progress = &progress;
  options.seriesUid = seriesUid;
  options.allowOutsideData = isOpenRawHeader(volumePath);  // the user's own Open RAW header
  io::LoadedVolume lv = io::loadVolume(volumePath, options);
  options.seriesUid.clear();
  r.warnings = lv.warnings;
  r.series = lv.series;
  r.seriesUid = lv.seriesUid;
  // A CT stored as int16 is not converted (a copy of the whole volume). The 3D view uploads
  // the scene's CT itself (issue #22: no second copy of the intensity volume).
  if (auto* i16 = std::get_if<VolumeI16>(&lv.volume)) {
    r.ct = std::move(*i16);
  } else {
    r.ct = toInt16(lv.volume);
  }
  lv.volume = AnyVolume();  // not held while the rest is made
  r.volumePath = volumePath;
  if (!labelsPath.empty()) {
    r.labels = io::loadLabels(labelsPath, options);
    if (!r.labels.geometry().approxEqual(r.ct.geometry(), 1e-3))
      throw FileError(labelsPath, "label map geometry " + r.labels.geometry().dims.str() +
                                      " does not match the volume " + r.ct.geometry().dims.str());
    r.labelsPath = labelsPath;
  } else {
    r.labels = LabelVolume(r.ct.geometry());
  }
  if (request.prepare3d) {
    progress.begin("preparing the 3D view", 1);
    // prepare() reads an AnyVolume: the CT is moved in and back out, not copied. Without the
    // light source (21 MiB at 512^2 x 350): the 3D view makes it when lighting is switched on.
    AnyVolume volume(std::move(r.ct));
    r.prepared = render::VolumeRenderer::prepare(volume, false);
    r.ct = std::move(std::get<VolumeI16>(volume));
    progress.advance();
  }
  if (r.scene && !r.scene->shapes.empty()) {
    r.shapes = std::make_shared<const illustration::ShapeScene>(loadShapes(r.scene->shapes, r.ct));
    r.shapeMeshes = std::make_shared<const SegmentMeshes>(loadSegmentMeshes(r.scene->shapes, r.shapes->segments));
    r.shapesPath = r.scene->shapes;
  }
  return r;
}

bool Loader::start(const LoadRequest& request) {
  return job_.start([request](Progress& progress) { return loadNow(request, progress); },
                    "opening " + request.path.filename().string());
}

}  // namespace vellum::studio
