#include "vellum/segmentation/mask.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <cmath>
#include <sstream>

namespace vellum::segmentation {

Mask makeMask(const Geometry& g) { return Mask(g, 0, 0.0); }

int64_t countVoxels(const Mask& m) {
  const auto& v = m.voxels();
  return tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, v.size(), 1 << 16), int64_t{0},
      [&](const tbb::blocked_range<size_t>& r, int64_t s) {
        for (size_t i = r.begin(); i < r.end(); ++i) s += v[i] != 0;
        return s;
      },
      [](int64_t a, int64_t b) { return a + b; });
}

double voxelVolumeMm3(const Geometry& g) {
  return std::abs(g.direction.determinant()) * g.spacing.x * g.spacing.y * g.spacing.z;
}

double maskVolumeMm3(const Mask& m) {
  return static_cast<double>(countVoxels(m)) * voxelVolumeMm3(m.geometry());
}

std::optional<Index3> nearestVoxel(const Geometry& g, const Vec3& pointMm) {
  const Vec3 c = g.physicalToIndex(pointMm);
  if (!isFinite(c)) return std::nullopt;
  const Index3 idx{static_cast<int64_t>(std::floor(c.x + 0.5)),
                   static_cast<int64_t>(std::floor(c.y + 0.5)),
                   static_cast<int64_t>(std::floor(c.z + 0.5))};
  if (!g.contains(idx.i, idx.j, idx.k)) return std::nullopt;
  return idx;
}

std::vector<Index3> seedsToVoxels(const Geometry& g, const std::vector<Vec3>& seedsMm) {
  std::vector<Index3> out;
  for (const Vec3& s : seedsMm) {
    auto v = nearestVoxel(g, s);
    if (!v) {
      std::ostringstream os;
      os << "seed (" << s.x << ", " << s.y << ", " << s.z << ") mm lies outside the volume";
      throw Error(os.str());
    }
    out.push_back(*v);
  }
  return out;
}

void requireSameGeometry(const Geometry& a, const Geometry& b, const char* what) {
  if (!(a.dims == b.dims) || !a.approxEqual(b))
    throw Error(std::string(what) + ": volumes differ in geometry (" + a.dims.str() + " vs " +
                b.dims.str() + ")");
}

namespace {
template <class Op>
Mask combine(const Mask& a, const Mask* b, Op op) {
  if (b) requireSameGeometry(a.geometry(), b->geometry(), "mask operation");
  Mask out(a.geometry(), 0, 0.0);
  const uint8_t* pa = a.data();
  const uint8_t* pb = b ? b->data() : nullptr;
  uint8_t* po = out.data();
  tbb::parallel_for(tbb::blocked_range<size_t>(0, a.size(), 1 << 16),
                    [&](const tbb::blocked_range<size_t>& r) {
                      for (size_t i = r.begin(); i < r.end(); ++i)
                        po[i] = op(pa[i] != 0, pb ? pb[i] != 0 : false) ? 1 : 0;
                    });
  return out;
}
}  // namespace

Mask maskAnd(const Mask& a, const Mask& b) { return combine(a, &b, [](bool x, bool y) { return x && y; }); }
Mask maskOr(const Mask& a, const Mask& b) { return combine(a, &b, [](bool x, bool y) { return x || y; }); }
Mask maskNot(const Mask& a) { return combine(a, nullptr, [](bool x, bool) { return !x; }); }

}  // namespace vellum::segmentation
