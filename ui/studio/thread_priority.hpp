#pragma once
// Background work yields to the window: the studio's worker threads (loading, label operations,
// deformation solves, map preparation ...) run at a lower scheduling priority than the UI
// thread, so that on a busy machine the frames are not starved by the studio's own workers.
#include <utility>

#include <tbb/task_arena.h>

namespace vellum::studio {

/// Lowers the calling thread's priority (Linux: nice +10 for this thread only; elsewhere a
/// no-op). Once lowered it stays lowered: call it first thing in a worker thread made for one
/// job, never on the UI thread or a pooled thread that runs UI work.
void lowerThreadPriority();

/// Threads a studio worker's parallel loops may use: one fewer than the machine's cores (at
/// least 1), so the UI thread keeps a core. The nice value alone does not do it: TBB's pooled
/// threads, which run most of a worker's loops, keep the normal priority.
int workerConcurrency();

/// Runs `f` (a worker's job, on its own thread) in a TBB arena of workerConcurrency() threads.
template <class F>
decltype(auto) inWorkerArena(F&& f) {
  tbb::task_arena arena(workerConcurrency());
  return arena.execute(std::forward<F>(f));
}

}  // namespace vellum::studio
