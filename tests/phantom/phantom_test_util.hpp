#pragma once
// Helpers shared by the phantom tests: cached phantoms, connected components, centroids.
#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <tuple>
#include <vector>

#include "vellum/phantom/phantom.hpp"

namespace vellum::phantom::test {

/// Phantoms are deterministic, so tests share one instance per option set.
inline const Phantom& cached(int nx, int ny, int nz, double flexDeg = 0.0, double sigma = 15.0,
                             bool pv = true, Vec3 spacing = {0, 0, 0}) {
  using Key = std::tuple<int, int, int, double, double, bool, double, double, double>;
  static std::map<Key, Phantom> cache;
  const Key key{nx, ny, nz, flexDeg, sigma, pv, spacing.x, spacing.y, spacing.z};
  auto it = cache.find(key);
  if (it == cache.end()) {
    PhantomOptions o;
    o.dims = {nx, ny, nz};
    o.kneeFlexionDeg = flexDeg;
    o.noiseSigmaHu = sigma;
    o.partialVolume = pv;
    o.spacing = spacing;
    it = cache.emplace(key, makePhantom(o)).first;
  }
  return it->second;
}

/// Number of 26-connected components of the voxels v (linear index) where `in(v)` holds.
inline int countComponents(const Geometry& g, const std::function<bool(size_t)>& in) {
  const Dims d = g.dims;
  const size_t n = static_cast<size_t>(d.voxelCount());
  std::vector<uint8_t> seen(n, 0);
  std::vector<int64_t> stack;
  int components = 0;
  for (size_t start = 0; start < n; ++start) {
    if (seen[start] || !in(start)) continue;
    ++components;
    seen[start] = 1;
    stack.push_back(static_cast<int64_t>(start));
    while (!stack.empty()) {
      const int64_t v = stack.back();
      stack.pop_back();
      const int64_t i = v % d.x, j = (v / d.x) % d.y, k = v / (d.x * d.y);
      for (int dk = -1; dk <= 1; ++dk)
        for (int dj = -1; dj <= 1; ++dj)
          for (int di = -1; di <= 1; ++di) {
            const int64_t a = i + di, b = j + dj, c = k + dk;
            if (!g.contains(a, b, c)) continue;
            const size_t q = static_cast<size_t>((c * d.y + b) * d.x + a);
            if (!seen[q] && in(q)) {
              seen[q] = 1;
              stack.push_back(static_cast<int64_t>(q));
            }
          }
    }
  }
  return components;
}

/// Number of 26-connected components of the voxels where `in(label)` holds.
inline int countComponents(const LabelVolume& labels, const std::function<bool(uint16_t)>& in) {
  const uint16_t* ids = labels.ids().data();
  return countComponents(labels.geometry(), [&](size_t v) { return in(ids[v]); });
}

/// Physical centroid (mm) of the voxels v (linear index) where `in(v)` holds; count in `n`.
inline Vec3 centroid(const Geometry& g, const std::function<bool(size_t)>& in,
                     uint64_t* n = nullptr) {
  Vec3 sum;
  uint64_t count = 0;
  size_t v = 0;
  for (int64_t k = 0; k < g.dims.z; ++k)
    for (int64_t j = 0; j < g.dims.y; ++j)
      for (int64_t i = 0; i < g.dims.x; ++i, ++v)
        if (in(v)) {
          sum += g.indexToPhysical(Vec3{double(i), double(j), double(k)});
          ++count;
        }
  if (n) *n = count;
  return count ? sum / double(count) : sum;
}

/// Physical centroid (mm) of the voxels where `in(label)` holds; count in `n`.
inline Vec3 centroid(const LabelVolume& labels, const std::function<bool(uint16_t)>& in,
                     uint64_t* n = nullptr) {
  const uint16_t* ids = labels.ids().data();
  return centroid(labels.geometry(), [&](size_t v) { return in(ids[v]); }, n);
}

/// Centroid (mm) and voxel count of one bone (cortex + marrow / core) from boneMap.
inline Vec3 boneCentroid(const VolumeU8& bones, Bone bone, uint64_t* n = nullptr) {
  const uint8_t* b = bones.data();
  return centroid(bones.geometry(), [&](size_t v) { return b[v] == uint8_t(bone); }, n);
}

inline constexpr Bone kBones[] = {Bone::kFemur, Bone::kTibia, Bone::kFibula, Bone::kPatella};

}  // namespace vellum::phantom::test
