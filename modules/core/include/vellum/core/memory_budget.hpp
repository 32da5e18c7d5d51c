#pragma once
// Refuse allocations that would not fit before making them.
#include <cstdint>
#include <string>

#include "vellum/core/geometry.hpp"

namespace vellum {

/// Bytes Vellum may use for one allocation: the VELLUM_MEMORY_LIMIT environment variable
/// (bytes, or with a K/M/G suffix) if set, else 80% of MemAvailable from /proc/meminfo.
uint64_t memoryLimitBytes();

/// "31.3 GiB", "512.0 MiB".
std::string formatBytes(uint64_t bytes);

/// Throws vellum::Error ("volume of 2048x2048x4000 int16 needs 31.3 GiB; limit is 18.9 GiB ...")
/// if dims * bytesPerVoxel exceeds the limit, or if the product overflows.
void checkMemoryBudget(const Dims& dims, uint64_t bytesPerVoxel, const std::string& typeName);
/// Generic form for non-volume allocations; `what` describes them.
void checkMemoryBudget(uint64_t bytes, const std::string& what);

}  // namespace vellum
