// boneMap: which bone (rigid body) each voxel of a phantom label volume belongs to.
#include <array>
#include <vector>

#include "vellum/core/parallel.hpp"
#include "vellum/phantom/phantom.hpp"

namespace vellum::phantom {

VolumeU8 boneMap(const LabelVolume& labels) {
  const Geometry& g = labels.geometry();
  const Dims d = g.dims;
  VolumeU8 out(g, 0, 0.0);
  const uint16_t* ids = labels.ids().data();
  uint8_t* bone = out.data();
  const int64_t slice = d.x * d.y;
  parallelFor(d.z, [&](int64_t k0, int64_t k1) {
    for (int64_t v = k0 * slice; v < k1 * slice; ++v)
      bone[v] = static_cast<uint8_t>(boneOf(ids[v]));
  });

  // Cancellous cores are shared by the fibula and the patella: each 26-connected core
  // component belongs to the shell it touches most. Cores are small: a serial flood fill,
  // marking visited voxels in the output itself (no second volume-sized allocation).
  constexpr uint8_t kVisited = 0xFF;
  std::vector<int64_t> stack, component;
  bool orphans = false;
  for (int64_t start = 0; start < static_cast<int64_t>(out.size()); ++start) {
    if (ids[start] != kCancellous || bone[start] != 0) continue;
    bone[start] = kVisited;
    stack.assign(1, start);
    component.clear();
    std::array<int64_t, 5> touches{};  // per Bone
    while (!stack.empty()) {
      const int64_t v = stack.back();
      stack.pop_back();
      component.push_back(v);
      const int64_t i = v % d.x, j = (v / d.x) % d.y, k = v / slice;
      for (int64_t c = k - 1; c <= k + 1; ++c)
        for (int64_t b = j - 1; b <= j + 1; ++b)
          for (int64_t a = i - 1; a <= i + 1; ++a) {
            if (!g.contains(a, b, c)) continue;
            const int64_t n = (c * d.y + b) * d.x + a;
            if (ids[n] == kCancellous) {
              if (bone[n] != kVisited) {
                bone[n] = kVisited;
                stack.push_back(n);
              }
            } else if (ids[n] == kFibula || ids[n] == kPatella) {
              ++touches[static_cast<size_t>(boneOf(ids[n]))];
            }
          }
    }
    const auto f = touches[size_t(Bone::kFibula)], p = touches[size_t(Bone::kPatella)];
    const Bone owner = f == 0 && p == 0 ? Bone::kNone : f >= p ? Bone::kFibula : Bone::kPatella;
    if (owner == Bone::kNone) {
      orphans = true;  // stays kVisited until the loop is done, so it is not flooded again
      continue;
    }
    for (const int64_t v : component) bone[v] = static_cast<uint8_t>(owner);
  }
  if (orphans)
    for (size_t v = 0; v < out.size(); ++v)
      if (bone[v] == kVisited) bone[v] = 0;
  return out;
}

}  // namespace vellum::phantom
