#pragma once
// Keeping large freed blocks inside the process while a frame loop runs.

namespace vellum {

/// While one lives (on any thread; they nest), glibc's malloc serves large blocks from its heap
/// instead of a fresh mmap() each, and keeps what is freed instead of unmapping it. A movie
/// makes and frees ~0.5 GB of buffers a frame at 512^2 x 350 (the frame's map, its weights and
/// distances, the renderer's node texture): fresh pages fault one by one, and every mmap or
/// munmap holds the address-space lock that the render threads' own faults then wait for. The
/// 11-frame knee movie: 132-139 s -> 114-117 s wall, 31-35 -> 12-14 s of system time, max
/// RSS 3.22 -> 3.52 GB (docs/benchmarks-deformation.md, s21). When the last one ends the
/// defaults come back and the free memory is handed back (malloc_trim). Without glibc: nothing.
class ReuseFreedMemory {
 public:
  ReuseFreedMemory();
  ~ReuseFreedMemory();
  ReuseFreedMemory(const ReuseFreedMemory&) = delete;
  ReuseFreedMemory& operator=(const ReuseFreedMemory&) = delete;

  /// Whether one lives now.
  static bool active();
};

}  // namespace vellum
