#include "snake_job.hpp"

#include "vellum/core/error.hpp"

namespace vellum::studio {
namespace seg = vellum::segmentation;

std::pair<std::shared_ptr<const seg::Mask>, uint64_t> SnakeJob::live() const {
  std::lock_guard lock(liveMutex_);
  return {busy() ? live_ : nullptr, liveRevision_};
}

bool SnakeJob::start(SnakeRequest request) {
  if (job_.busy()) return false;
  generation_ = request.volumeGeneration;
  {
    std::lock_guard lock(liveMutex_);
    live_.reset();
  }
  return job_.start(
      [this, request = std::move(request)](Progress& progress) {
        seg::ThresholdSpeedParams speedParams;
        speedParams.lower = request.interval.lower;
        speedParams.upper = request.interval.upper;
        const seg::SpeedImage speed = seg::thresholdSpeed(request.ct, speedParams, progress);
        // Every few iterations the contour so far goes to the slices (live evolution).
        const auto publish = [this](const seg::Mask& inside, int) {
          auto copy = std::make_shared<const seg::Mask>(inside);
          std::lock_guard lock(liveMutex_);
          live_ = std::move(copy);
          ++liveRevision_;
        };
        seg::SnakeResult r = seg::evolveSnake(speed, {{request.seedMm, request.bubbleRadiusMm}}, {}, progress, publish, 5);
        SnakeOutcome out;
        out.mask = std::move(r.mask);
        out.iterations = r.iterations;
        out.converged = r.converged;
        return out;
      },
      "snake");
}

}  // namespace vellum::studio
