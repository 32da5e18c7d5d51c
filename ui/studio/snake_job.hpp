#pragma once
// The 3D snake (segmentation::evolveSnake) from a seed clicked in a slice, on a worker
// thread with progress and cancel, like loading. The result is adopted by the UI thread as
// one label edit (one undo step).
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "vellum/core/progress.hpp"
#include "vellum/segmentation/snake.hpp"
#include "vellum/segmentation/threshold.hpp"

namespace vellum::studio {

struct SnakeRequest {
  VolumeI16 ct;  ///< a copy: the scene may change while the snake runs
  Vec3 seedMm;
  double bubbleRadiusMm = 4;
  segmentation::HuInterval interval{-500, 300};  ///< the threshold speed's inside range
  uint64_t volumeGeneration = 0;  ///< Scene::volumeGeneration when started
};

struct SnakeOutcome {
  std::string error;  ///< "snake cancelled" or the segmentation module's message
  segmentation::Mask mask;
  int iterations = 0;
  bool converged = false;
  uint64_t volumeGeneration = 0;
};

class SnakeJob {
 public:
  ~SnakeJob();
  /// Starts the snake; false if one is already running.
  bool start(SnakeRequest request);
  bool busy() const;
  std::pair<std::string, double> progress() const;
  void cancel();
  /// The finished snake, once.
  std::optional<SnakeOutcome> take();

 private:
  void run(SnakeRequest request);
  mutable std::mutex mutex_;
  std::thread thread_;
  std::unique_ptr<Progress> progress_;
  std::string stage_;
  double fraction_ = 0;
  bool running_ = false;
  std::optional<SnakeOutcome> result_;
};

}  // namespace vellum::studio
