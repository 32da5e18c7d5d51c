#pragma once
// Parallel loop helpers over voxel grids (TBB underneath; hidden from headers' users).
#include <cstdint>
#include <functional>

namespace vellum {

/// Calls body(k0, k1) over disjoint slabs [k0, k1) of [0, n) in parallel. Chunks are slabs of
/// whole z-slices so that each task walks memory contiguously.
void parallelFor(int64_t n, const std::function<void(int64_t begin, int64_t end)>& body,
                 int64_t grain = 1);

/// Number of worker threads TBB will use (respects VELLUM_THREADS if set).
int workerCount();

}  // namespace vellum
