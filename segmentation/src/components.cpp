#include "vellum/segmentation/components.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <limits>

#include "neighbors.hpp"
#include "vellum/core/parallel.hpp"

namespace vellum::segmentation {
namespace {

constexpr uint32_t kNone = std::numeric_limits<uint32_t>::max();

uint32_t findRoot(uint32_t* parent, uint32_t x) {
  while (parent[x] != x) {
    parent[x] = parent[parent[x]];  // path halving
    x = parent[x];
  }
  return x;
}

// Links the larger root under the smaller one, so parent[x] <= x always holds.
void unite(uint32_t* parent, uint32_t a, uint32_t b) {
  a = findRoot(parent, a);
  b = findRoot(parent, b);
  if (a == b) return;
  if (a < b) parent[b] = a; else parent[a] = b;
}

}  // namespace

uint32_t Components::largest() const {
  uint32_t best = 0;
  for (size_t l = 1; l < sizes.size(); ++l)
    if (best == 0 || sizes[l] > sizes[best]) best = static_cast<uint32_t>(l);
  return best;
}

Components connectedComponents(const Mask& m, Connectivity connectivity, Progress& progress) {
  const Dims d = m.dims();
  const int64_t N = d.voxelCount();
  if (N >= static_cast<int64_t>(kNone)) throw Error("connected components: volume has too many voxels");
  checkMemoryBudget(static_cast<uint64_t>(N) * sizeof(uint32_t), "component labels");
  Components c;
  c.dims = d;
  c.labels.assign(static_cast<size_t>(N), kNone);
  uint32_t* P = c.labels.data();
  const uint8_t* src = m.data();
  const auto back = detail::backwardOffsets(connectivity);
  const int64_t sy = d.x, sz = d.x * d.y;
  progress.begin("connected components", 3);

  // 1. Union-find inside z-slabs, in parallel (each slab touches only its own voxels).
  const int64_t slabs = std::clamp<int64_t>(workerCount() * 4, 1, d.z);
  auto slabStart = [&](int64_t s) { return s * d.z / slabs; };
  auto linkVoxel = [&](int64_t i, int64_t j, int64_t k, int64_t kMin, bool crossOnly) {
    const int64_t p = k * sz + j * sy + i;
    if (!src[p]) return;
    for (const auto& o : back) {
      if (crossOnly && o.dk != -1) continue;
      const int64_t ni = i + o.di, nj = j + o.dj, nk = k + o.dk;
      if (ni < 0 || nj < 0 || nk < kMin || ni >= d.x || nj >= d.y) continue;
      const int64_t q = nk * sz + nj * sy + ni;
      if (src[q]) unite(P, static_cast<uint32_t>(p), static_cast<uint32_t>(q));
    }
  };
  tbb::parallel_for(int64_t{0}, slabs, [&](int64_t s) {
    const int64_t k0 = slabStart(s), k1 = slabStart(s + 1);
    for (int64_t k = k0; k < k1; ++k)
      for (int64_t j = 0; j < d.y; ++j)
        for (int64_t i = 0; i < d.x; ++i) {
          const int64_t p = k * sz + j * sy + i;
          if (src[p]) P[p] = static_cast<uint32_t>(p);
        }
    for (int64_t k = k0; k < k1; ++k)
      for (int64_t j = 0; j < d.y; ++j)
        for (int64_t i = 0; i < d.x; ++i) linkVoxel(i, j, k, k0, false);
  });
  progress.advance();
  // 2. Merge across slab faces.
  for (int64_t s = 1; s < slabs; ++s) {
    const int64_t k = slabStart(s);
    for (int64_t j = 0; j < d.y; ++j)
      for (int64_t i = 0; i < d.x; ++i) linkVoxel(i, j, k, 0, true);
  }
  progress.advance();
  // 3. Flatten (parents precede children in scan order) and number roots in scan order.
  c.sizes.assign(1, 0);
  for (int64_t p = 0; p < N; ++p) {
    const uint32_t q = P[p];
    if (q == kNone) { P[p] = 0; continue; }
    if (q == static_cast<uint32_t>(p)) {
      c.sizes.push_back(1);
      P[p] = static_cast<uint32_t>(c.sizes.size() - 1);
    } else {
      P[p] = P[q];  // P[q] already holds the root's component number
      ++c.sizes[P[p]];
    }
  }
  progress.end();
  return c;
}

namespace {

template <class Keep>
Mask selectComponents(const Mask& m, const Components& c, Keep keep) {
  Mask out(m.geometry(), 0, 0.0);
  uint8_t* o = out.data();
  const uint32_t* L = c.labels.data();
  tbb::parallel_for(tbb::blocked_range<size_t>(0, out.size(), 1 << 16),
                    [&](const tbb::blocked_range<size_t>& r) {
                      for (size_t i = r.begin(); i < r.end(); ++i) o[i] = L[i] != 0 && keep(L[i]);
                    });
  return out;
}

}  // namespace

Mask keepLargestComponent(const Mask& m, Connectivity connectivity) {
  const Components c = connectedComponents(m, connectivity);
  const uint32_t best = c.largest();
  return selectComponents(m, c, [best](uint32_t l) { return l == best; });
}

Mask removeSmallIslands(const Mask& m, double minVolumeMm3, Connectivity connectivity) {
  const Components c = connectedComponents(m, connectivity);
  const double vv = voxelVolumeMm3(m.geometry());
  std::vector<uint8_t> keep(c.sizes.size(), 0);
  for (size_t l = 1; l < c.sizes.size(); ++l) keep[l] = static_cast<double>(c.sizes[l]) * vv >= minVolumeMm3;
  return selectComponents(m, c, [&](uint32_t l) { return keep[l] != 0; });
}

Mask keepComponentsWithSeeds(const Mask& m, const std::vector<Vec3>& seedsMm,
                             Connectivity connectivity) {
  const auto seeds = seedsToVoxels(m.geometry(), seedsMm);
  const Components c = connectedComponents(m, connectivity);
  std::vector<uint8_t> keep(c.sizes.size(), 0);
  for (const Index3& s : seeds) keep[c.labels[m.linearIndex(s.i, s.j, s.k)]] = 1;
  keep[0] = 0;
  return selectComponents(m, c, [&](uint32_t l) { return keep[l] != 0; });
}

Mask fillHoles(const Mask& m) {
  const Dims d = m.dims();
  const Components bg = connectedComponents(maskNot(m), Connectivity::Face6);
  // Background components that touch the grid border are outside; the rest are cavities.
  std::vector<uint8_t> outside(bg.sizes.size(), 0);
  for (int64_t k = 0; k < d.z; ++k)
    for (int64_t j = 0; j < d.y; ++j) {
      const bool face = k == 0 || j == 0 || k == d.z - 1 || j == d.y - 1;
      if (face) {
        for (int64_t i = 0; i < d.x; ++i) outside[bg.labels[m.linearIndex(i, j, k)]] = 1;
      } else {
        outside[bg.labels[m.linearIndex(0, j, k)]] = 1;
        outside[bg.labels[m.linearIndex(d.x - 1, j, k)]] = 1;
      }
    }
  outside[0] = 1;  // label 0 = foreground voxels: stay as they are
  Mask out(m.geometry(), 0, 0.0);
  const uint32_t* L = bg.labels.data();
  const uint8_t* src = m.data();
  uint8_t* o = out.data();
  for (size_t i = 0; i < out.size(); ++i) o[i] = src[i] || !outside[L[i]];
  return out;
}

Mask fillHolesPerSlice(const Mask& m, int axis) {
  if (axis < 0 || axis > 2) throw Error("fillHolesPerSlice: axis must be 0, 1 or 2");
  const Dims d = m.dims();
  // Slice axes (u, v) and the slice-normal axis w, as strides into the volume.
  const int ua = axis == 0 ? 1 : 0, va = axis == 2 ? 1 : 2;
  const int64_t stride[3] = {1, d.x, d.x * d.y};
  const int64_t nu = d[ua], nv = d[va], nw = d[axis];
  const int64_t su = stride[ua], sv = stride[va], sw = stride[axis];
  Mask out = m;
  uint8_t* o = out.data();
  parallelFor(nw, [&](int64_t w0, int64_t w1) {
    std::vector<uint8_t> reached(static_cast<size_t>(nu * nv));
    std::vector<int64_t> queue;
    for (int64_t w = w0; w < w1; ++w) {
      std::fill(reached.begin(), reached.end(), 0);
      queue.clear();
      const int64_t base = w * sw;
      auto fg = [&](int64_t u, int64_t v) { return o[base + u * su + v * sv] != 0; };
      auto push = [&](int64_t u, int64_t v) {
        const int64_t idx = v * nu + u;
        if (reached[idx] || fg(u, v)) return;
        reached[idx] = 1;
        queue.push_back(idx);
      };
      for (int64_t u = 0; u < nu; ++u) { push(u, 0); push(u, nv - 1); }
      for (int64_t v = 0; v < nv; ++v) { push(0, v); push(nu - 1, v); }
      for (size_t h = 0; h < queue.size(); ++h) {
        const int64_t u = queue[h] % nu, v = queue[h] / nu;
        if (u > 0) push(u - 1, v);
        if (u + 1 < nu) push(u + 1, v);
        if (v > 0) push(u, v - 1);
        if (v + 1 < nv) push(u, v + 1);
      }
      for (int64_t v = 0; v < nv; ++v)
        for (int64_t u = 0; u < nu; ++u)
          if (!reached[v * nu + u]) o[base + u * su + v * sv] = 1;
    }
  });
  return out;
}

Mask fillHolesAllSlices(const Mask& m) {
  // Each orientation fills from the original mask: a hole counts when it is enclosed in a
  // slice of any one orientation (not only in slices already filled along another).
  Mask out = fillHolesPerSlice(m, 2);
  for (int axis : {0, 1}) {
    const Mask f = fillHolesPerSlice(m, axis);
    uint8_t* o = out.data();
    const uint8_t* src = f.data();
    for (size_t i = 0; i < out.size(); ++i) o[i] |= src[i];
  }
  return fillHoles(out);
}

}  // namespace vellum::segmentation
