#include "vellum/core/binary_copy.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace vellum {

VolumeU8 binaryCopy(const VolumeU8& mask) {
  VolumeU8 out(mask.geometry(), 0, mask.background());
  const uint8_t* src = mask.data();
  uint8_t* o = out.data();
  tbb::parallel_for(tbb::blocked_range<size_t>(0, out.size(), 1 << 16), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i < r.end(); ++i) o[i] = src[i] != 0;
  });
  return out;
}

}  // namespace vellum
