#include "vellum/segmentation/components.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <limits>

#include "vellum/core/binary_copy.hpp"
#include "vellum/core/parallel.hpp"

namespace vellum::segmentation {

Mask keepComponentsWithSeeds(const Mask& m, const std::vector<Vec3>& seedsMm,
                             Connectivity connectivity) {
  const auto seeds = seedsToVoxels(m.geometry(), seedsMm);
  const Components c = connectedComponents(m, connectivity);
  std::vector<uint8_t> keep(c.sizes.size(), 0);
  for (const Index3& s : seeds) keep[c.labels[m.linearIndex(s.i, s.j, s.k)]] = 1;
  keep[0] = 0;
  return selectComponents(m.geometry(), c, keep);
}

Mask fillHoles(const Mask& m) {
  Mask out = binaryCopy(m);
  out.setBackground(0.0);  // 0 outside the grid, whatever `m` said (as fillHoles always gave)
  fillHolesInPlace(out);
  return out;
}

void fillHolesInPlace(Mask& m) {
  const Dims d = m.dims();
  // Background components (face-connected) that touch the grid border are outside; the rest
  // are cavities. Painted from the labelling's runs: no component id per voxel.
  paintComponents(m, true, Connectivity::Face6, [&](const Components& c) {
    std::vector<uint8_t> cavity(c.sizes.size(), 0);
    for (size_t l = 1; l < c.sizes.size(); ++l) {
      const IndexBox& b = c.boxes[l];
      bool border = false;
      for (int a = 0; a < 3; ++a) border = border || b.lo[a] == 0 || b.hi[a] == d[a] - 1;
      cavity[l] = !border;
    }
    return cavity;
  }, 1);
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
  fillHolesInPlace(out);
  return out;
}

}  // namespace vellum::segmentation
