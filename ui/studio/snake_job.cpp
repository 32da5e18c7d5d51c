#include "snake_job.hpp"

#include "vellum/core/error.hpp"

namespace vellum::studio {
namespace seg = vellum::segmentation;

SnakeJob::~SnakeJob() {
  cancel();
  if (thread_.joinable()) thread_.join();
}

bool SnakeJob::start(SnakeRequest request) {
  std::lock_guard lock(mutex_);
  if (running_) return false;
  if (thread_.joinable()) thread_.join();
  running_ = true;
  result_.reset();
  stage_ = "snake";
  fraction_ = 0;
  progress_ = std::make_unique<Progress>([this](const std::string& stage, double f) {
    std::lock_guard l(mutex_);
    stage_ = stage;
    fraction_ = f;
  });
  thread_ = std::thread(&SnakeJob::run, this, std::move(request));
  return true;
}

void SnakeJob::run(SnakeRequest request) {
  SnakeOutcome out;
  try {
    seg::ThresholdSpeedParams speedParams;
    speedParams.lower = request.interval.lower;
    speedParams.upper = request.interval.upper;
    const seg::SpeedImage speed = seg::thresholdSpeed(request.ct, speedParams, *progress_);
    seg::SnakeResult r = seg::evolveSnake(speed, {{request.seedMm, request.bubbleRadiusMm}}, {}, *progress_);
    out.mask = std::move(r.mask);
    out.iterations = r.iterations;
    out.converged = r.converged;
  } catch (const Cancelled&) {
    out = {};
    out.error = "snake cancelled";
  } catch (const std::exception& e) {
    out = {};
    out.error = e.what();
  }
  out.volumeGeneration = request.volumeGeneration;
  std::lock_guard lock(mutex_);
  result_ = std::move(out);
  running_ = false;
}

bool SnakeJob::busy() const {
  std::lock_guard lock(mutex_);
  return running_;
}

std::pair<std::string, double> SnakeJob::progress() const {
  std::lock_guard lock(mutex_);
  return {stage_, fraction_};
}

void SnakeJob::cancel() {
  std::lock_guard lock(mutex_);
  if (running_ && progress_) progress_->cancel();
}

std::optional<SnakeOutcome> SnakeJob::take() {
  std::lock_guard lock(mutex_);
  if (running_ || !result_) return std::nullopt;
  std::optional<SnakeOutcome> r = std::move(result_);
  result_.reset();
  return r;
}

}  // namespace vellum::studio
