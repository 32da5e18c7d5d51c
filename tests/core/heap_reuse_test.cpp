// ReuseFreedMemory (core/heap_reuse.hpp): large blocks come from the heap while one lives.
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>

#include "vellum/core/heap_reuse.hpp"

#if defined(__GLIBC__)
#include <malloc.h>
#endif

using namespace vellum;

namespace {

// Blocks glibc holds as their own mmap()s now.
long mappedBlocks() {
#if defined(__GLIBC__)
  return static_cast<long>(mallinfo2().hblks);
#else
  return 0;
#endif
}

// Whether a fresh 64 MiB block is an mmap() of its own (the count while it is held).
bool bigBlockIsMapped() {
  const long before = mappedBlocks();
  void* p = std::malloc(size_t(64) << 20);
  EXPECT_NE(p, nullptr);
  std::memset(p, 1, 4096);  // used, so that it is not optimised away
  const bool mapped = mappedBlocks() > before;
  std::free(p);
  return mapped;
}

}  // namespace

TEST(HeapReuse, LargeBlocksComeFromTheHeapWhileAGuardLivesAndNested) {
#if !defined(__GLIBC__) || defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "glibc's own malloc only";
#else
  EXPECT_FALSE(ReuseFreedMemory::active());
  EXPECT_TRUE(bigBlockIsMapped()) << "glibc maps 64 MiB blocks by default";
  {
    ReuseFreedMemory outer;
    EXPECT_TRUE(ReuseFreedMemory::active());
    EXPECT_FALSE(bigBlockIsMapped());
    {
      ReuseFreedMemory inner;
      EXPECT_FALSE(bigBlockIsMapped());
    }
    // The inner one ending leaves the outer's policy in force.
    EXPECT_TRUE(ReuseFreedMemory::active());
    EXPECT_FALSE(bigBlockIsMapped());
  }
  EXPECT_FALSE(ReuseFreedMemory::active());
  EXPECT_TRUE(bigBlockIsMapped()) << "the defaults did not come back";
#endif
}
