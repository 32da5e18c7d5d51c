#pragma once
// Loads a volume, a label map or a whole scene on a worker thread, with progress and
// cancel. The UI polls take() once per frame; the current scene is replaced only when a
// load has fully succeeded, so a bad file leaves it untouched.
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "scene_file.hpp"
#include "vellum/core/label_volume.hpp"
#include "vellum/core/progress.hpp"
#include "vellum/io/volume_io.hpp"

namespace vellum::studio {

struct LoadRequest {
  std::filesystem::path path;    ///< volume file, DICOM folder or scene (*.json)
  std::filesystem::path labels;  ///< optional label map for a volume
  std::string seriesUid;         ///< DICOM: the series to load (default: the largest CT series)
};

struct LoadResult {
  std::string error;  ///< non-empty: the io module's message; nothing else is set
  VolumeI16 ct;
  LabelVolume labels;
  std::filesystem::path volumePath, labelsPath, scenePath;
  std::optional<SceneFile> scene;  ///< set when a scene file was opened
  std::vector<std::string> warnings;
  std::vector<io::SeriesInfo> series;  ///< DICOM: every series found
  std::string seriesUid;
};

class Loader {
 public:
  ~Loader();
  /// Starts loading; false if a load is already running.
  bool start(const LoadRequest& request);
  bool busy() const;
  /// Stage and fraction of the running load.
  std::pair<std::string, double> progress() const;
  void cancel();
  /// The finished load, once; nullopt while running or idle.
  std::optional<LoadResult> take();

 private:
  void run(LoadRequest request);
  mutable std::mutex mutex_;
  std::thread thread_;
  std::unique_ptr<Progress> progress_;
  std::string stage_;
  double fraction_ = 0;
  bool running_ = false;
  std::optional<LoadResult> result_;
};

/// The synchronous part (also used by tests): reads request into a LoadResult, throwing
/// vellum::Error on failure.
LoadResult loadNow(const LoadRequest& request, Progress& progress);

}  // namespace vellum::studio
