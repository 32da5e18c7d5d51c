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

Loader::~Loader() {
  cancel();
  if (thread_.joinable()) thread_.join();
}

bool Loader::start(const LoadRequest& request) {
  std::lock_guard lock(mutex_);
  if (running_) return false;
  if (thread_.joinable()) thread_.join();
  running_ = true;
  result_.reset();
  stage_ = "opening " + request.path.filename().string();
  fraction_ = 0;
  progress_ = std::make_unique<Progress>([this](const std::string& stage, double f) {
    std::lock_guard l(mutex_);
    stage_ = stage;
    fraction_ = f;
  });
  thread_ = std::thread(&Loader::run, this, request);
  return true;
}

void Loader::run(LoadRequest request) {
  LoadResult r;
  try {
    r = loadNow(request, *progress_);
  } catch (const Cancelled&) {
    r = {};
    r.error = "loading cancelled";
  } catch (const std::exception& e) {
    r = {};
    r.error = e.what();
  }
  std::lock_guard lock(mutex_);
  result_ = std::move(r);
  running_ = false;
}

bool Loader::busy() const {
  std::lock_guard lock(mutex_);
  return running_;
}

std::pair<std::string, double> Loader::progress() const {
  std::lock_guard lock(mutex_);
  return {stage_, fraction_};
}

void Loader::cancel() {
  std::lock_guard lock(mutex_);
  if (running_ && progress_) progress_->cancel();
}

std::optional<LoadResult> Loader::take() {
  std::lock_guard lock(mutex_);
  if (running_ || !result_) return std::nullopt;
  std::optional<LoadResult> r = std::move(result_);
  result_.reset();
  return r;
}

}  // namespace vellum::studio
