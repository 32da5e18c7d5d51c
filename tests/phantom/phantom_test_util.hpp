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

/// Number of 26-connected components of the voxels where `in(label)` holds.
inline int countComponents(const LabelVolume& labels, const std::function<bool(uint16_t)>& in) {
  const Dims d = labels.geometry().dims;
  const auto& ids = labels.ids().voxels();
  std::vector<uint8_t> seen(ids.size(), 0);
  std::vector<int64_t> stack;
  int components = 0;
  for (size_t start = 0; start < ids.size(); ++start) {
    if (seen[start] || !in(ids[start])) continue;
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
            if (!labels.geometry().contains(a, b, c)) continue;
            const size_t n = labels.ids().linearIndex(a, b, c);
            if (!seen[n] && in(ids[n])) {
              seen[n] = 1;
              stack.push_back(static_cast<int64_t>(n));
            }
          }
    }
  }
  return components;
}

/// Physical centroid (mm) of the voxels where `in(label)` holds; count in `n`.
inline Vec3 centroid(const LabelVolume& labels, const std::function<bool(uint16_t)>& in,
                     uint64_t* n = nullptr) {
  const Geometry& g = labels.geometry();
  Vec3 sum;
  uint64_t count = 0;
  for (int64_t k = 0; k < g.dims.z; ++k)
    for (int64_t j = 0; j < g.dims.y; ++j)
      for (int64_t i = 0; i < g.dims.x; ++i)
        if (in(labels(i, j, k))) {
          sum += g.indexToPhysical(Vec3{double(i), double(j), double(k)});
          ++count;
        }
  if (n) *n = count;
  return count ? sum / double(count) : sum;
}

/// Which rigid body a label belongs to: 1 femur, 2 tibia, 3 fibula, 4 patella, 0 none.
inline int boneOf(uint16_t id) {
  switch (id) {
    case kFemurCortex: case kFemurMarrow: return 1;
    case kTibiaCortex: case kTibiaMarrow: return 2;
    case kFibula: return 3;
    case kPatella: return 4;
    default: return 0;
  }
}

}  // namespace vellum::phantom::test
