#include "vellum/core/parallel.hpp"

#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>

#include <cstdlib>
#include <memory>

namespace vellum {
namespace {

// Applies VELLUM_THREADS once, for the life of the process.
void applyThreadLimit() {
  static std::unique_ptr<tbb::global_control> control = [] {
    std::unique_ptr<tbb::global_control> c;
    if (const char* env = std::getenv("VELLUM_THREADS"); env && std::atoi(env) > 0)
      c = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                static_cast<size_t>(std::atoi(env)));
    return c;
  }();
}

}  // namespace

void parallelFor(int64_t n, const std::function<void(int64_t, int64_t)>& body, int64_t grain) {
  if (n <= 0) return;
  applyThreadLimit();
  tbb::parallel_for(tbb::blocked_range<int64_t>(0, n, std::max<int64_t>(grain, 1)),
                    [&](const tbb::blocked_range<int64_t>& r) { body(r.begin(), r.end()); });
}

int workerCount() {
  applyThreadLimit();
  return static_cast<int>(
      tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
}

}  // namespace vellum
