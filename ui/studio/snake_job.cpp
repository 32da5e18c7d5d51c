#include "snake_job.hpp"

#include "vellum/app/segment_pipeline.hpp"
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
        // Every few iterations the contour so far goes to the slices (live evolution).
        const auto publish = [this](const seg::Mask& inside, int) {
          auto copy = std::make_shared<const seg::Mask>(inside);
          std::lock_guard lock(liveMutex_);
          live_ = std::move(copy);
          ++liveRevision_;
        };
        app::SegmentationResult r = app::runSegmentation(request.ct, request.segment, progress, publish);
        SnakeJobResult out;
        out.mask = std::move(r.mask);
        out.iterations = r.info["snake"]["iterations"].get<int>();
        out.converged = r.info["snake"]["converged"].get<bool>();
        return out;
      },
      "snake");
}

}  // namespace vellum::studio
