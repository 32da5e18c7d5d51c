#pragma once
// The 3D snake (segmentation::evolveSnake) from a seed clicked in a slice, on a worker
// thread with progress and cancel, like loading. The result is adopted by the UI thread as
// one label edit (one undo step).
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "background_job.hpp"
#include "vellum/app/segment_pipeline.hpp"
#include "vellum/core/progress.hpp"
#include "vellum/segmentation/snake.hpp"

namespace vellum::studio {

struct SnakeRequest {
  VolumeI16 ct;  ///< a copy: the scene may change while the snake runs
  /// What `vellum segment --method snake` takes: seed, bubble radius, HU range, speed, weights.
  app::SegmentSettings segment;
  uint64_t volumeGeneration = 0;  ///< Scene::volumeGeneration when started
};

struct SnakeJobResult {
  std::string error;  ///< "snake cancelled" or the segmentation module's message
  segmentation::Mask mask;
  int iterations = 0;
  bool converged = false;
  uint64_t volumeGeneration = 0;
};

/// The snake on a worker thread (BackgroundJob).
class SnakeJob {
 public:
  /// Starts the snake; false if one is already running.
  bool start(SnakeRequest request);
  bool busy() const { return job_.busy(); }
  /// Running, or finished with a result not taken yet.
  bool pending() const { return job_.busy() || job_.ready(); }
  std::pair<std::string, double> progress() const { return job_.progress(); }
  void cancel() { job_.cancel(); }
  /// While the snake runs: its inside so far (on the grid of the level being evolved) and a
  /// counter that changes with each new contour; null when no snake runs.
  std::pair<std::shared_ptr<const segmentation::Mask>, uint64_t> live() const;
  /// The finished snake (or its error), once, stamped with the volume it ran on.
  std::optional<SnakeJobResult> take() {
    auto outcome = job_.take();
    if (outcome) outcome->volumeGeneration = generation_;
    return outcome;
  }

 private:
  uint64_t generation_ = 0;  ///< volumeGeneration of the running or last snake
  mutable std::mutex liveMutex_;
  std::shared_ptr<const segmentation::Mask> live_;
  uint64_t liveRevision_ = 0;
  BackgroundJob<SnakeJobResult> job_{"snake", [](const std::string& error) {
                                     SnakeJobResult o;
                                     o.error = error;
                                     return o;
                                   }};
};

}  // namespace vellum::studio
