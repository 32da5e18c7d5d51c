#pragma once
// Background work yields to the window: the studio's worker threads (loading, label operations,
// deformation solves, map preparation ...) run at a lower scheduling priority than the UI
// thread, so that on a busy machine the frames are not starved by the studio's own workers.

namespace vellum::studio {

/// Lowers the calling thread's priority (Linux: nice +10 for this thread only; elsewhere a
/// no-op). Once lowered it stays lowered: call it first thing in a worker thread made for one
/// job, never on the UI thread or a pooled thread that runs UI work.
void lowerThreadPriority();

}  // namespace vellum::studio
