#include "snake_job.hpp"

#include "vellum/core/error.hpp"

namespace vellum::studio {
namespace seg = vellum::segmentation;

bool SnakeJob::start(SnakeRequest request) {
  if (job_.busy()) return false;
  generation_ = request.volumeGeneration;
  return job_.start(
      [request = std::move(request)](Progress& progress) {
        seg::ThresholdSpeedParams speedParams;
        speedParams.lower = request.interval.lower;
        speedParams.upper = request.interval.upper;
        const seg::SpeedImage speed = seg::thresholdSpeed(request.ct, speedParams, progress);
        seg::SnakeResult r = seg::evolveSnake(speed, {{request.seedMm, request.bubbleRadiusMm}}, {}, progress);
        SnakeOutcome out;
        out.mask = std::move(r.mask);
        out.iterations = r.iterations;
        out.converged = r.converged;
        return out;
      },
      "snake");
}

}  // namespace vellum::studio
