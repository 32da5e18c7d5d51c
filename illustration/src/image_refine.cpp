#include "image_refine.hpp"

#include <algorithm>
#include <cmath>

#include "vellum/core/parallel.hpp"

namespace vellum::illustration::detail {

namespace {

int roundUp4(int n) { return (n + 3) / 4 * 4; }

/// Points past the image edge: a tile of the next level reads the coarse points up to two
/// past its own, and tiles are whole.
RefineLevel makeLevel(int width, int height, int spacing) {
  RefineLevel l;
  l.spacing = spacing;
  l.nx = roundUp4((width - 1 + spacing - 1) / spacing + 3);
  l.ny = roundUp4((height - 1 + spacing - 1) / spacing + 3);
  l.rgba.assign(size_t(l.nx) * size_t(l.ny) * 4, 0.f);
  l.near.assign(size_t(l.nx) * size_t(l.ny), 1e30f);
  return l;
}

/// Whether the 3 x 3 coarse points from (i0, j0) leave the tile between them to interpolation.
bool smooth(const RefineLevel& c, int i0, int j0, float tolerance) {
  // A line within 0.71 spacings of a pixel is within that of one of its coarse neighbours
  // (plus a pixel of margin): those pixels are traced.
  const float nearPx = 0.75f * float(c.spacing) + 1.f;
  float v[9][4];
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 3; ++i) {
      const size_t p = size_t(std::min(j0 + j, c.ny - 1)) * size_t(c.nx) + size_t(std::min(i0 + i, c.nx - 1));
      if (c.near[p] < nearPx) return false;
      for (int ch = 0; ch < 4; ++ch) v[j * 3 + i][ch] = c.rgba[p * 4 + size_t(ch)];
    }
  for (int ch = 0; ch < 4; ++ch) {
    float lo = v[0][ch], hi = lo;
    for (const auto& q : v) {
      lo = std::min(lo, q[ch]);
      hi = std::max(hi, q[ch]);
    }
    // An edge: a large step is traced even where it looks linear.
    if (hi - lo > 8.f * tolerance) return false;
    // Curvature: bilinear interpolation between points 2s apart misses |second difference| / 8
    // (rows, columns, both diagonals).
    auto d2 = [&](int a, int b, int e) { return std::abs(v[a][ch] - 2.f * v[b][ch] + v[e][ch]); };
    float m = std::max(d2(0, 4, 8), d2(2, 4, 6));
    for (int k = 0; k < 3; ++k) m = std::max({m, d2(3 * k, 3 * k + 1, 3 * k + 2), d2(k, k + 3, k + 6)});
    if (m > 8.f * tolerance) return false;
  }
  return true;
}

}  // namespace

RgbaImage refineImage(int width, int height, int levels, float tolerance, const TraceRuns& trace, RefineStats* stats) {
  levels = std::max(levels, 0);
  RefineStats st;
  st.levels = levels;
  RefineLevel coarse = makeLevel(width, height, 1 << levels);
  {
    std::vector<TileRun> all;
    for (int b = 0; b < coarse.ny / 4; ++b) all.push_back({b, 0, coarse.nx / 4});
    trace(coarse, all);
    st.traced += int64_t(coarse.nx) * coarse.ny;
  }
  for (int s = (1 << levels) / 2; s >= 1; s /= 2) {
    RefineLevel fine = makeLevel(width, height, s);
    const int tx = fine.nx / 4, ty = fine.ny / 4;
    std::vector<uint8_t> refine(size_t(tx) * size_t(ty));
    parallelFor(ty, [&](int64_t b0, int64_t b1) {
      for (int64_t b = b0; b < b1; ++b)
        for (int a = 0; a < tx; ++a) {
          const bool r = !smooth(coarse, 2 * a, int(2 * b), tolerance);
          refine[size_t(b) * size_t(tx) + size_t(a)] = r;
          if (r) continue;
          // Bilinear from the coarse points (a fine point is one, or the mean of two or four).
          for (int j = 0; j < 4; ++j)
            for (int i = 0; i < 4; ++i) {
              const int fi = 4 * a + i, fj = int(4 * b) + j;
              const int ci0 = std::min(fi / 2, coarse.nx - 1), ci1 = std::min((fi + 1) / 2, coarse.nx - 1);
              const int cj0 = std::min(fj / 2, coarse.ny - 1), cj1 = std::min((fj + 1) / 2, coarse.ny - 1);
              const size_t q[4] = {size_t(cj0) * size_t(coarse.nx) + size_t(ci0), size_t(cj0) * size_t(coarse.nx) + size_t(ci1),
                                   size_t(cj1) * size_t(coarse.nx) + size_t(ci0), size_t(cj1) * size_t(coarse.nx) + size_t(ci1)};
              const size_t p = size_t(fj) * size_t(fine.nx) + size_t(fi);
              float nearest = 1e30f;
              for (int ch = 0; ch < 4; ++ch) {
                float sum = 0.f;
                for (size_t k : q) sum += coarse.rgba[k * 4 + size_t(ch)];
                fine.rgba[p * 4 + size_t(ch)] = 0.25f * sum;
              }
              for (size_t k : q) nearest = std::min(nearest, coarse.near[k]);
              fine.near[p] = nearest;
            }
        }
    });
    std::vector<TileRun> runs;
    for (int b = 0; b < ty; ++b)
      for (int a = 0; a < tx;) {
        if (!refine[size_t(b) * size_t(tx) + size_t(a)]) {
          ++a;
          continue;
        }
        TileRun r{b, a, a};
        while (r.x1 < tx && refine[size_t(b) * size_t(tx) + size_t(r.x1)]) ++r.x1;
        st.traced += int64_t(r.x1 - r.x0) * 16;
        a = r.x1;
        runs.push_back(r);
      }
    if (!runs.empty()) trace(fine, runs);
    coarse = std::move(fine);
  }
  RgbaImage image(width, height);
  parallelFor(height, [&](int64_t y0, int64_t y1) {
    for (int64_t y = y0; y < y1; ++y)
      for (int x = 0; x < width; ++x)
        for (int ch = 0; ch < 4; ++ch) {
          const float v = coarse.rgba[(size_t(y) * size_t(coarse.nx) + size_t(x)) * 4 + size_t(ch)];
          image.at(x, int(y))[ch] = uint8_t(std::lround((v > 0.f ? std::min(v, 1.f) : 0.f) * 255.f));  // NaN: 0, as GL
        }
  });
  if (stats) *stats = st;
  return image;
}

}  // namespace vellum::illustration::detail
