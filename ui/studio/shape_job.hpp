#pragma once
// Shapes for the illustration view, on a worker thread with progress and cancel: made from
// the label map (illustration::runShapePipeline, one segment per label that has voxels, what
// `vellum shape --segment NAME=ID` does) or read from a `vellum shape` folder.
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "background_job.hpp"
#include "segment_meshes.hpp"
#include "vellum/core/label_volume.hpp"
#include "vellum/illustration/illustration_renderer.hpp"
#include "vellum/illustration/shape.hpp"

namespace vellum::studio {

struct ShapeRequest {
  VolumeI16 ct;                   ///< copies: the scene may change while the job runs
  LabelVolume labels;             ///< used when `folder` is empty
  std::filesystem::path folder;   ///< a `vellum shape` folder, or empty: make from `labels`
  uint64_t volumeGeneration = 0;
};

struct ShapeJobResult {
  std::string error;
  std::shared_ptr<const illustration::ShapeScene> shapes;
  std::shared_ptr<const SegmentMeshes> meshes;
  std::filesystem::path folder;
  uint64_t volumeGeneration = 0;
};

/// The segments `vellum shape` would get from `--segment NAME=ID` for every label id with
/// voxels, in the label table's order (names made unique).
std::vector<illustration::Segment> segmentsFromLabels(const LabelVolume& labels);

/// Makes or reads the shapes now (the worker's body; tests call it directly).
ShapeJobResult makeShapes(const ShapeRequest& request, Progress& progress);

class ShapeJob {
 public:
  bool start(ShapeRequest request);
  bool busy() const { return job_.busy(); }
  /// Running, or finished with a result not taken yet.
  bool pending() const { return job_.busy() || job_.ready(); }
  std::pair<std::string, double> progress() const { return job_.progress(); }
  void cancel() { job_.cancel(); }
  std::optional<ShapeJobResult> take() { return job_.take(); }

 private:
  BackgroundJob<ShapeJobResult> job_{"shapes", [](const std::string& error) {
                                      ShapeJobResult o;
                                      o.error = error;
                                      return o;
                                    }};
};

}  // namespace vellum::studio
