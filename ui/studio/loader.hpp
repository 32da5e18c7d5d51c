#pragma once
// Loads a volume, a label map or a whole scene on a worker thread, with progress and
// cancel. The UI polls take() once per frame; the current scene is replaced only when a
// load has fully succeeded, so a bad file leaves it untouched.
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "background_job.hpp"
#include "scene_file.hpp"
#include "segment_meshes.hpp"
#include "vellum/core/label_volume.hpp"
#include "vellum/core/progress.hpp"
#include "vellum/io/volume_io.hpp"
#include "vellum/render/volume_renderer.hpp"

namespace vellum::studio {

struct LoadRequest {
  std::filesystem::path path;    ///< volume file, DICOM folder or scene (*.json)
  std::filesystem::path labels;  ///< optional label map for a volume
  std::string seriesUid;         ///< DICOM: the series to load (default: the largest CT series)
  bool prepare3d = false;        ///< also make LoadResult::prepared
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
  /// The scene's shape folder, loaded (null: none).
  std::shared_ptr<const illustration::ShapeScene> shapes;
  std::shared_ptr<const SegmentMeshes> shapeMeshes;  ///< the folder's meshes
  std::filesystem::path shapesPath;
  /// The renderer's CPU part of `ct` (empty-space blocks, lighting), made on the worker so
  /// that adopting the load only uploads `ct` (null when not asked for).
  std::shared_ptr<const render::VolumeRenderer::Prepared> prepared;
};

/// Loads on a worker thread (BackgroundJob); `take()` gives the finished load once.
class Loader {
 public:
  /// Starts loading; false if a load is already running.
  bool start(const LoadRequest& request);
  bool busy() const { return job_.busy(); }
  /// Running, or finished with a result not taken yet.
  bool pending() const { return job_.busy() || job_.ready(); }
  /// Stage and fraction of the running load.
  std::pair<std::string, double> progress() const { return job_.progress(); }
  void cancel() { job_.cancel(); }
  /// The finished load, once; nullopt while running or idle.
  std::optional<LoadResult> take() { return job_.take(); }

 private:
  BackgroundJob<LoadResult> job_{"loading", [](const std::string& error) {
                                   LoadResult r;
                                   r.error = error;
                                   return r;
                                 }};
};

/// A `vellum shape` folder for the volume `ct` (same grid, else FileError naming the folder).
illustration::ShapeScene loadShapes(const std::filesystem::path& folder, const VolumeI16& ct);

/// The synchronous part (also used by tests): reads request into a LoadResult, throwing
/// vellum::Error on failure.
LoadResult loadNow(const LoadRequest& request, Progress& progress);

}  // namespace vellum::studio
