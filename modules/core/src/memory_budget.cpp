#include "vellum/core/memory_budget.hpp"

#if defined(__linux__)
#include <sys/mman.h>
#endif

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <string>

#include "vellum/core/error.hpp"

namespace vellum {
namespace {

uint64_t parseByteCount(const std::string& text) {
  size_t pos = 0;
  const double value = std::stod(text, &pos);
  uint64_t mult = 1;
  if (pos < text.size()) {
    switch (text[pos]) {
      case 'k': case 'K': mult = 1ull << 10; break;
      case 'm': case 'M': mult = 1ull << 20; break;
      case 'g': case 'G': mult = 1ull << 30; break;
      case 't': case 'T': mult = 1ull << 40; break;
      default: throw Error("VELLUM_MEMORY_LIMIT: cannot parse '" + text + "'");
    }
  }
  if (!(value > 0)) throw Error("VELLUM_MEMORY_LIMIT: must be positive, got '" + text + "'");
  return static_cast<uint64_t>(value * static_cast<double>(mult));
}

uint64_t availableMemoryBytes() {
  std::ifstream in("/proc/meminfo");
  std::string key;
  uint64_t kb = 0;
  std::string unit;
  while (in >> key >> kb >> unit)
    if (key == "MemAvailable:") return kb * 1024;
  return 8ull << 30;  // unknown system: assume 8 GiB
}

}  // namespace

uint64_t memoryLimitBytes() {
  if (const char* env = std::getenv("VELLUM_MEMORY_LIMIT"); env && *env) return parseByteCount(env);
  return availableMemoryBytes() / 10 * 8;
}

std::string formatBytes(uint64_t bytes) {
  const char* units[] = {"B", "KiB", "MiB", "GiB", "TiB", "PiB"};
  double v = static_cast<double>(bytes);
  int u = 0;
  while (v >= 1024.0 && u < 5) { v /= 1024.0; ++u; }
  char buf[32];
  v = std::floor(v * 10.0 + 0.5) / 10.0;  // round half up: 31.25 GiB -> "31.3 GiB"
  std::snprintf(buf, sizeof buf, u == 0 ? "%.0f %s" : "%.1f %s", v, units[u]);
  return buf;
}

void checkMemoryBudget(uint64_t bytes, const std::string& what) {
  const uint64_t limit = memoryLimitBytes();
  if (bytes > limit)
    throw Error(what + " needs " + formatBytes(bytes) + "; limit is " + formatBytes(limit) +
                " (80% of available memory, or VELLUM_MEMORY_LIMIT)");
}

void checkMemoryBudget(const Dims& dims, uint64_t bytesPerVoxel, const std::string& typeName) {
  const std::string what = "volume of " + dims.str() + " " + typeName;
  if (dims.x < 0 || dims.y < 0 || dims.z < 0) throw Error(what + ": negative dimensions");
  constexpr uint64_t kMax = std::numeric_limits<uint64_t>::max();
  const auto x = static_cast<uint64_t>(dims.x), y = static_cast<uint64_t>(dims.y),
             z = static_cast<uint64_t>(dims.z);
  if ((x != 0 && y > kMax / x) || (x * y != 0 && z > kMax / (x * y)) ||
      (x * y * z != 0 && bytesPerVoxel > kMax / (x * y * z)))
    throw Error(what + " is too large to address");
  checkMemoryBudget(x * y * z * bytesPerVoxel, what);
}

void adviseHugePages(void* p, size_t bytes) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  constexpr uintptr_t kHuge = uintptr_t{2} << 20;
  if (!p || bytes < 2 * kHuge) return;
  const auto begin = (reinterpret_cast<uintptr_t>(p) + kHuge - 1) & ~(kHuge - 1);
  const auto end = (reinterpret_cast<uintptr_t>(p) + bytes) & ~(kHuge - 1);
  if (end > begin) ::madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);  // advice only
#else
  (void)p;
  (void)bytes;
#endif
}

}  // namespace vellum
