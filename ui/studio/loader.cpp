#include "loader.hpp"

#include "vellum/core/error.hpp"
#include "vellum/io/volume_io.hpp"

namespace vellum::studio {
namespace fs = std::filesystem;

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
  io::LoadedVolume lv = io::loadVolume(volumePath, options);
  options.seriesUid.clear();
  r.warnings = lv.warnings;
  r.series = lv.series;
  r.seriesUid = lv.seriesUid;
  r.ct = toInt16(lv.volume);
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
  return r;
}

bool Loader::start(const LoadRequest& request) {
  return job_.start([request](Progress& progress) { return loadNow(request, progress); },
                    "opening " + request.path.filename().string());
}

}  // namespace vellum::studio
