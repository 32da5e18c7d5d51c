#include "thread_priority.hpp"

#include <algorithm>

#include <tbb/info.h>

#if defined(__linux__)
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>
#endif

namespace vellum::studio {

int workerConcurrency() { return std::max(1, tbb::info::default_concurrency() - 1); }

void lowerThreadPriority() {
#if defined(__linux__)
  // On Linux the nice value is per thread (PRIO_PROCESS with a thread id); a failure leaves the
  // thread as it was, which is harmless.
  const auto tid = static_cast<id_t>(syscall(SYS_gettid));
  const int current = getpriority(PRIO_PROCESS, tid);
  if (current < 10) (void)setpriority(PRIO_PROCESS, tid, 10);
#endif
}

}  // namespace vellum::studio
