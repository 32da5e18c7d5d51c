#pragma once
// Refuse allocations that would not fit before making them.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

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

/// Asks the kernel to back the whole 2 MiB pages inside [p, p + bytes) with transparent huge
/// pages (Linux madvise; nothing for ranges under 4 MiB or elsewhere). Call it before the
/// memory is first touched: a 32 MiB volume then costs 16 page faults instead of 8192, about
/// 5x less time to allocate and fill.
void adviseHugePages(void* p, size_t bytes);

/// v.resize(n, fill), with new storage advised for huge pages before it is filled.
template <class T>
void resizeHugePaged(std::vector<T>& v, size_t n, const T& fill = T{}) {
  if (n > v.capacity()) {
    v.reserve(n);
    adviseHugePages(v.data() + v.size(), (n - v.size()) * sizeof(T));
  }
  v.resize(n, fill);
}

}  // namespace vellum
