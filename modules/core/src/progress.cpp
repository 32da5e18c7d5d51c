#include "vellum/core/progress.hpp"

#include <algorithm>

#include "vellum/core/error.hpp"

namespace vellum {

namespace {
// Lock-free, so that a signal handler may store to it.
std::atomic<bool> gCancelEverywhere{false};
static_assert(std::atomic<bool>::is_always_lock_free);
}  // namespace

void Progress::requestCancelEverywhere() noexcept { gCancelEverywhere.store(true); }
bool Progress::cancelRequestedEverywhere() noexcept {
  return gCancelEverywhere.load(std::memory_order_relaxed);
}

void Progress::begin(const std::string& stage, uint64_t totalUnits) {
  std::lock_guard lock(reportMutex_);
  stage_ = stage;
  total_ = std::max<uint64_t>(totalUnits, 1);
  done_.store(0);
  lastReported_ = -1;
  if (callback_) callback_(stage_, 0.0);
}

void Progress::advance(uint64_t units) {
  checkCancelled();
  const uint64_t done = done_.fetch_add(units) + units;
  if (!callback_) return;
  const double f = std::min(1.0, static_cast<double>(done) / static_cast<double>(total_));
  std::unique_lock lock(reportMutex_, std::try_to_lock);
  if (!lock.owns_lock()) return;  // another thread is reporting; skip rather than wait
  if (f - lastReported_ >= 0.005 || f >= 1.0) {
    lastReported_ = f;
    callback_(stage_, f);
  }
}

void Progress::end() {
  std::lock_guard lock(reportMutex_);
  done_.store(total_);
  if (callback_ && lastReported_ < 1.0) callback_(stage_, 1.0);
  lastReported_ = 1.0;
}

void Progress::checkCancelled() const {
  if (cancelled_.load(std::memory_order_relaxed) || cancelRequestedEverywhere()) throw Cancelled();
}

double Progress::fraction() const {
  return std::min(1.0, static_cast<double>(done_.load()) / static_cast<double>(total_));
}

Progress& Progress::none() {
  static thread_local Progress instance;
  return instance;
}

}  // namespace vellum
