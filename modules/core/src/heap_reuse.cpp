#include "vellum/core/heap_reuse.hpp"

#include <climits>
#include <mutex>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace vellum {

namespace {
std::mutex gMutex;
int gDepth = 0;  // guards alive
}  // namespace

ReuseFreedMemory::ReuseFreedMemory() {
  std::lock_guard lock(gMutex);
  if (gDepth++ > 0) return;
#if defined(__GLIBC__)
  mallopt(M_MMAP_MAX, 0);              // every block from the heap, where a freed one is reused
  mallopt(M_TRIM_THRESHOLD, INT_MAX);  // and the heap's free top kept
#endif
}

ReuseFreedMemory::~ReuseFreedMemory() {
  std::lock_guard lock(gMutex);
  if (--gDepth > 0) return;
#if defined(__GLIBC__)
  // glibc's defaults (DEFAULT_MMAP_MAX, DEFAULT_TRIM_THRESHOLD), then the free pages back.
  mallopt(M_MMAP_MAX, 65536);
  mallopt(M_TRIM_THRESHOLD, 128 * 1024);
  malloc_trim(0);
#endif
}

bool ReuseFreedMemory::active() {
  std::lock_guard lock(gMutex);
  return gDepth > 0;
}

}  // namespace vellum
