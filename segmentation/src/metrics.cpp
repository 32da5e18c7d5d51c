#include "vellum/segmentation/metrics.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "vellum/core/distance_transform.hpp"

namespace vellum::segmentation {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

struct Box {
  int64_t lo[3] = {INT64_MAX, INT64_MAX, INT64_MAX};
  int64_t hi[3] = {-1, -1, -1};
  bool empty() const { return hi[0] < 0; }
};

Box boundingBox(const Mask& a, const Mask& b) {
  const Dims d = a.dims();
  Box box;
  for (int64_t k = 0; k < d.z; ++k)
    for (int64_t j = 0; j < d.y; ++j) {
      const size_t row = a.linearIndex(0, j, k);
      for (int64_t i = 0; i < d.x; ++i)
        if (a.data()[row + i] || b.data()[row + i]) {
          const int64_t c[3] = {i, j, k};
          for (int t = 0; t < 3; ++t) {
            box.lo[t] = std::min(box.lo[t], c[t]);
            box.hi[t] = std::max(box.hi[t], c[t]);
          }
        }
    }
  return box;
}

/// Copy of `m` restricted to the box grown by one voxel (clamped to the grid); the origin
/// does not matter for distances, the spacing does.
Mask crop(const Mask& m, const Box& box, int64_t off[3]) {
  const Dims d = m.dims();
  int64_t hi[3];
  const int64_t dims[3] = {d.x, d.y, d.z};
  for (int t = 0; t < 3; ++t) {
    off[t] = std::max<int64_t>(0, box.lo[t] - 1);
    hi[t] = std::min<int64_t>(dims[t] - 1, box.hi[t] + 1);
  }
  Geometry g = m.geometry();
  g.dims = {hi[0] - off[0] + 1, hi[1] - off[1] + 1, hi[2] - off[2] + 1};
  Mask out(g, 0, 0.0);
  for (int64_t k = 0; k < g.dims.z; ++k)
    for (int64_t j = 0; j < g.dims.y; ++j)
      for (int64_t i = 0; i < g.dims.x; ++i) out(i, j, k) = m(i + off[0], j + off[1], k + off[2]);
  return out;
}

/// Mask voxels with a 6-neighbour outside the mask. A neighbour outside the crop counts as
/// outside only where the crop reaches the border of the original grid (`atBorder`).
Mask boundary(const Mask& m, const bool atBorderLo[3], const bool atBorderHi[3]) {
  const Dims d = m.dims();
  Mask out(m.geometry(), 0, 0.0);
  for (int64_t k = 0; k < d.z; ++k)
    for (int64_t j = 0; j < d.y; ++j)
      for (int64_t i = 0; i < d.x; ++i) {
        if (!m(i, j, k)) continue;
        const int64_t c[3] = {i, j, k};
        bool edge = false;
        for (int t = 0; t < 3 && !edge; ++t)
          for (int s = -1; s <= 1 && !edge; s += 2) {
            int64_t n[3] = {c[0], c[1], c[2]};
            n[t] += s;
            if (n[t] < 0) { edge = atBorderLo[t]; continue; }
            if (n[t] >= d[t]) { edge = atBorderHi[t]; continue; }
            edge = !m(n[0], n[1], n[2]);
          }
        out(i, j, k) = edge;
      }
  return out;
}

std::vector<double> surfaceDistances(const Mask& from, const VolumeF32& toD2) {
  std::vector<double> out;
  for (size_t i = 0; i < from.size(); ++i)
    if (from.data()[i]) out.push_back(std::sqrt(static_cast<double>(toD2.data()[i])));
  return out;
}

double percentile95(std::vector<double> v) {
  if (v.empty()) return 0;
  // Nearest-rank definition: the smallest value with at least 95% of values <= it.
  const size_t rank = static_cast<size_t>(std::ceil(0.95 * static_cast<double>(v.size())));
  const size_t idx = std::clamp<size_t>(rank, 1, v.size()) - 1;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(idx), v.end());
  return v[idx];
}

}  // namespace

OverlapMetrics overlap(const Mask& a, const Mask& truth) {
  requireSameGeometry(a.geometry(), truth.geometry(), "overlap metrics");
  struct C { int64_t a = 0, b = 0, ab = 0; };
  const uint8_t* pa = a.data();
  const uint8_t* pb = truth.data();
  const C c = tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, a.size(), 1 << 16), C{},
      [&](const tbb::blocked_range<size_t>& r, C acc) {
        for (size_t i = r.begin(); i < r.end(); ++i) {
          const bool x = pa[i] != 0, y = pb[i] != 0;
          acc.a += x; acc.b += y; acc.ab += x && y;
        }
        return acc;
      },
      [](C x, const C& y) { x.a += y.a; x.b += y.b; x.ab += y.ab; return x; });
  OverlapMetrics m;
  m.voxels = c.a;
  m.truthVoxels = c.b;
  m.intersection = c.ab;
  const double sum = static_cast<double>(c.a + c.b), uni = static_cast<double>(c.a + c.b - c.ab);
  m.dice = sum > 0 ? 2.0 * static_cast<double>(c.ab) / sum : 1.0;
  m.jaccard = uni > 0 ? static_cast<double>(c.ab) / uni : 1.0;
  const double vv = voxelVolumeMm3(a.geometry());
  m.volumeMm3 = static_cast<double>(c.a) * vv;
  m.truthVolumeMm3 = static_cast<double>(c.b) * vv;
  m.volumeDifferenceMm3 = m.volumeMm3 - m.truthVolumeMm3;
  m.volumeDifferencePercent = c.b > 0 ? 100.0 * m.volumeDifferenceMm3 / m.truthVolumeMm3 : 0.0;
  return m;
}

SegmentMetrics compareMasks(const Mask& a, const Mask& truth) {
  SegmentMetrics s;
  static_cast<OverlapMetrics&>(s) = overlap(a, truth);
  if (s.voxels == 0 && s.truthVoxels == 0) return s;
  if (s.voxels == 0 || s.truthVoxels == 0) {
    s.hd95Mm = s.hausdorffMm = s.meanSurfaceDistanceMm = kInf;
    return s;
  }
  const Box box = boundingBox(a, truth);
  int64_t off[3];
  const Mask ca = crop(a, box, off);
  const Mask cb = crop(truth, box, off);
  const Dims d = a.dims(), cd = ca.dims();
  bool lo[3], hi[3];
  for (int t = 0; t < 3; ++t) {
    lo[t] = off[t] == 0;
    hi[t] = off[t] + cd[t] == d[t];
  }
  const Mask ba = boundary(ca, lo, hi), bb = boundary(cb, lo, hi);
  const auto dab = surfaceDistances(ba, squaredDistanceMm(bb));
  const auto dba = surfaceDistances(bb, squaredDistanceMm(ba));
  s.hd95Mm = std::max(percentile95(dab), percentile95(dba));
  s.hausdorffMm = std::max(*std::max_element(dab.begin(), dab.end()),
                           *std::max_element(dba.begin(), dba.end()));
  double total = 0;
  for (double v : dab) total += v;
  for (double v : dba) total += v;
  s.meanSurfaceDistanceMm = total / static_cast<double>(dab.size() + dba.size());
  return s;
}

std::vector<SegmentMetrics> compareLabels(const VolumeU16& labels, const VolumeU16& truth,
                                          const std::vector<uint16_t>& ids) {
  requireSameGeometry(labels.geometry(), truth.geometry(), "label metrics");
  std::vector<uint16_t> list = ids;
  if (list.empty()) {
    std::vector<uint8_t> present(65536, 0);
    for (uint16_t v : labels.voxels()) present[v] = 1;
    for (uint16_t v : truth.voxels()) present[v] = 1;
    for (size_t v = 1; v < present.size(); ++v)
      if (present[v]) list.push_back(static_cast<uint16_t>(v));
  }
  std::vector<SegmentMetrics> out;
  for (uint16_t id : list) {
    auto is = [id](uint16_t v) { return v == id; };
    SegmentMetrics m = compareMasks(maskFromIds(labels, is), maskFromIds(truth, is));
    m.id = id;
    out.push_back(m);
  }
  return out;
}

}  // namespace vellum::segmentation
