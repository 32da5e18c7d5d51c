// Connected components by union-find over runs: each row (fixed j, k) is cut into runs of
// equal non-zero value, runs are united with the overlapping runs of the already-scanned
// neighbour rows, then every voxel takes its run's component number. Work follows the number
// of runs, not voxels (a solid body is a few runs per row). Rows are processed in z-slabs in
// parallel (a slab only links runs inside itself), then the slab faces are merged.
#include "vellum/core/components.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>

#include "vellum/core/binary_copy.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/memory_budget.hpp"
#include "vellum/core/parallel.hpp"

namespace vellum {
namespace {

struct Run {
  int32_t x0, x1;  ///< voxels [x0, x1) of the row
  uint16_t value;
};

/// A neighbour row (j + dj, k + dk) that precedes the row in scan order, and how far runs may
/// be apart along x and still touch (1 where diagonal neighbours along x count, else 0).
struct RowLink {
  int dj, dk, reach;
};

std::vector<RowLink> precedingRows(Connectivity c) {
  // Offsets (di, dj, dk) with dj or dk non-zero; a row pair admits di = -1..1 when the offset
  // with di != 0 is still within the connectivity.
  switch (c) {
    case Connectivity::Face6: return {{-1, 0, 0}, {0, -1, 0}};
    case Connectivity::Edge18: return {{-1, 0, 1}, {0, -1, 1}, {-1, -1, 0}, {1, -1, 0}};
    case Connectivity::Vertex26: return {{-1, 0, 1}, {0, -1, 1}, {-1, -1, 1}, {1, -1, 1}};
  }
  return {};
}

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

class RunLabeller {
 public:
  RunLabeller(const Dims& d, Connectivity c) : d_(d), links_(precedingRows(c)) {
    if (d.voxelCount() >= static_cast<int64_t>(std::numeric_limits<uint32_t>::max()) ||
        d.x >= std::numeric_limits<int32_t>::max())
      throw Error("connected components: volume has too many voxels");
    rows_ = d.y * d.z;
    slabs_ = std::max<int64_t>(1, std::min<int64_t>(workerCount() * 4, d.z));
  }

  /// Cuts every row into runs of equal non-zero value(row pointer, i).
  template <class Value>
  void findRuns(Value&& value) {
    std::vector<int64_t> count(static_cast<size_t>(rows_) + 1, 0);
    tbb::parallel_for(tbb::blocked_range<int64_t>(0, rows_, 64), [&](const tbb::blocked_range<int64_t>& r) {
      for (int64_t row = r.begin(); row < r.end(); ++row)
        scanRow(row, value, [&](int32_t, int32_t, uint16_t) { ++count[static_cast<size_t>(row) + 1]; });
    });
    for (int64_t row = 0; row < rows_; ++row) count[static_cast<size_t>(row) + 1] += count[static_cast<size_t>(row)];
    checkMemoryBudget(static_cast<uint64_t>(count.back()) * (sizeof(Run) + 2 * sizeof(uint32_t)), "component runs");
    runs_.resize(static_cast<size_t>(count.back()));
    tbb::parallel_for(tbb::blocked_range<int64_t>(0, rows_, 64), [&](const tbb::blocked_range<int64_t>& r) {
      for (int64_t row = r.begin(); row < r.end(); ++row) {
        size_t n = static_cast<size_t>(count[static_cast<size_t>(row)]);
        scanRow(row, value, [&](int32_t x0, int32_t x1, uint16_t v) { runs_[n++] = {x0, x1, v}; });
      }
    });
    rowStart_ = std::move(count);
  }

  /// Unites touching runs: inside z-slabs in parallel, then across the slab faces.
  void link() {
    parent_.resize(runs_.size());
    for (size_t r = 0; r < parent_.size(); ++r) parent_[r] = static_cast<uint32_t>(r);
    tbb::parallel_for(int64_t{0}, slabs_, [&](int64_t s) {
      for (int64_t k = slabStart(s); k < slabStart(s + 1); ++k)
        for (int64_t j = 0; j < d_.y; ++j) linkRow(j, k, slabStart(s), false);
    });
    for (int64_t s = 1; s < slabs_; ++s)
      for (int64_t j = 0; j < d_.y; ++j) linkRow(j, slabStart(s), 0, true);
  }

  /// Numbers the components in scan order and fills sizes, boxes and values, and the labels
  /// per voxel when `perVoxel` (4 bytes a voxel; paintRuns() works from the runs instead).
  Components finish(bool perVoxel = true) {
    Components c;
    c.dims = d_;
    c.sizes.assign(1, 0);
    c.boxes.assign(1, IndexBox{});
    c.values.assign(1, 0);
    // Parents precede children in scan order, so one pass resolves every run.
    std::vector<uint32_t>& label = parent_;
    for (int64_t row = 0; row < rows_; ++row) {
      const int64_t j = row % d_.y, k = row / d_.y;
      for (int64_t r = rowStart_[static_cast<size_t>(row)]; r < rowStart_[static_cast<size_t>(row) + 1]; ++r) {
        const Run& run = runs_[static_cast<size_t>(r)];
        uint32_t& l = label[static_cast<size_t>(r)];
        if (l == static_cast<uint32_t>(r)) {
          l = static_cast<uint32_t>(c.sizes.size());
          c.sizes.push_back(0);
          c.boxes.push_back({{run.x0, j, k}, {run.x1 - 1, j, k}});
          c.values.push_back(run.value);
        } else {
          l = label[l];  // the parent run already holds its component number
        }
        c.sizes[l] += run.x1 - run.x0;
        IndexBox& b = c.boxes[l];
        b.lo = {std::min<int64_t>(b.lo[0], run.x0), std::min(b.lo[1], j), b.lo[2]};
        b.hi = {std::max<int64_t>(b.hi[0], run.x1 - 1), std::max(b.hi[1], j), k};
      }
    }
    if (!perVoxel) return c;
    resizeHugePaged(c.labels, static_cast<size_t>(d_.voxelCount()));
    tbb::parallel_for(tbb::blocked_range<int64_t>(0, rows_, 64), [&](const tbb::blocked_range<int64_t>& r) {
      for (int64_t row = r.begin(); row < r.end(); ++row) {
        uint32_t* out = c.labels.data() + row * d_.x;
        std::fill(out, out + d_.x, 0u);
        for (int64_t n = rowStart_[static_cast<size_t>(row)]; n < rowStart_[static_cast<size_t>(row) + 1]; ++n) {
          const Run& run = runs_[static_cast<size_t>(n)];
          std::fill(out + run.x0, out + run.x1, label[static_cast<size_t>(n)]);
        }
      }
    });
    return c;
  }

  /// After finish(): `value` over the voxels of the runs whose component keep() accepts.
  void paintRuns(uint8_t* out, const std::vector<uint8_t>& keep, uint8_t value) const {
    const std::vector<uint32_t>& label = parent_;
    tbb::parallel_for(tbb::blocked_range<int64_t>(0, rows_, 64), [&](const tbb::blocked_range<int64_t>& r) {
      for (int64_t row = r.begin(); row < r.end(); ++row)
        for (int64_t n = rowStart_[static_cast<size_t>(row)]; n < rowStart_[static_cast<size_t>(row) + 1]; ++n) {
          const Run& run = runs_[static_cast<size_t>(n)];
          if (keep[label[static_cast<size_t>(n)]]) std::fill(out + row * d_.x + run.x0, out + row * d_.x + run.x1, value);
        }
    });
  }

 private:
  template <class Value, class Emit>
  void scanRow(int64_t row, Value& value, Emit&& emit) const {
    const int64_t base = row * d_.x;
    for (int64_t i = 0; i < d_.x; ++i) {
      const uint16_t v = value(base + i);
      if (v == 0) continue;
      const int64_t start = i;
      while (i + 1 < d_.x && value(base + i + 1) == v) ++i;
      emit(static_cast<int32_t>(start), static_cast<int32_t>(i + 1), v);
    }
  }

  int64_t slabStart(int64_t s) const { return s * d_.z / slabs_; }

  /// Unites the runs of row (j, k) with those of its preceding neighbour rows at z >= kMin
  /// (only the rows one slice down when `previousSliceOnly`).
  void linkRow(int64_t j, int64_t k, int64_t kMin, bool previousSliceOnly) {
    const int64_t row = k * d_.y + j;
    for (const RowLink& l : links_) {
      if (previousSliceOnly && l.dk != -1) continue;
      const int64_t nj = j + l.dj, nk = k + l.dk;
      if (nj < 0 || nj >= d_.y || nk < kMin) continue;
      linkRuns(row, nk * d_.y + nj, l.reach);
    }
  }

  /// Two-pointer sweep over two rows' runs (both sorted by x).
  void linkRuns(int64_t row, int64_t other, int reach) {
    const int64_t aEnd = rowStart_[static_cast<size_t>(row) + 1], bEnd = rowStart_[static_cast<size_t>(other) + 1];
    int64_t b = rowStart_[static_cast<size_t>(other)];
    for (int64_t a = rowStart_[static_cast<size_t>(row)]; a < aEnd && b < bEnd; ++a) {
      const Run& ra = runs_[static_cast<size_t>(a)];
      while (b < bEnd && runs_[static_cast<size_t>(b)].x1 + reach <= ra.x0) ++b;
      for (int64_t t = b; t < bEnd && runs_[static_cast<size_t>(t)].x0 < ra.x1 + reach; ++t)
        if (runs_[static_cast<size_t>(t)].value == ra.value)
          unite(parent_.data(), static_cast<uint32_t>(a), static_cast<uint32_t>(t));
    }
  }

  Dims d_;
  std::vector<RowLink> links_;
  int64_t rows_ = 0, slabs_ = 1;
  std::vector<Run> runs_;
  std::vector<int64_t> rowStart_;
  std::vector<uint32_t> parent_;
};

template <class Value>
Components label(const Dims& d, Connectivity connectivity, Progress& progress, Value&& value) {
  progress.begin("connected components", 3);
  RunLabeller labeller(d, connectivity);
  checkMemoryBudget(static_cast<uint64_t>(d.voxelCount()) * sizeof(uint32_t), "component labels");
  labeller.findRuns(value);
  progress.advance();
  labeller.link();
  progress.advance();
  Components c = labeller.finish();
  progress.end();
  return c;
}

}  // namespace

Connectivity connectivityFromInt(int n) {
  switch (n) {
    case 6: return Connectivity::Face6;
    case 18: return Connectivity::Edge18;
    case 26: return Connectivity::Vertex26;
    default: throw Error("connectivity must be 6, 18 or 26 (got " + std::to_string(n) + ")");
  }
}

uint32_t Components::largest() const {
  uint32_t best = 0;
  for (size_t l = 1; l < sizes.size(); ++l)
    if (best == 0 || sizes[l] > sizes[best]) best = static_cast<uint32_t>(l);
  return best;
}

Components connectedComponents(const VolumeU8& mask, Connectivity connectivity, Progress& progress) {
  const uint8_t* m = mask.data();
  return label(mask.dims(), connectivity, progress, [m](int64_t p) { return uint16_t(m[p] != 0); });
}

Components connectedRegions(const VolumeU16& ids, Connectivity connectivity, Progress& progress) {
  const uint16_t* v = ids.data();
  return label(ids.dims(), connectivity, progress, [v](int64_t p) { return v[p]; });
}

VolumeU8 selectComponents(const Geometry& like, const Components& c, const std::vector<uint8_t>& keepLabel) {
  if (like.dims != c.dims || keepLabel.size() != c.sizes.size())
    throw Error("selectComponents: grid or label table does not match the components");
  VolumeU8 out(like, 0, 0.0);
  uint8_t* o = out.data();
  const uint32_t* L = c.labels.data();
  const uint8_t* keep = keepLabel.data();
  tbb::parallel_for(tbb::blocked_range<size_t>(0, out.size(), 1 << 16), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i < r.end(); ++i) o[i] = L[i] != 0 && keep[L[i]];
  });
  return out;
}

void paintComponents(VolumeU8& mask, bool ofZeros, Connectivity connectivity,
                     const std::function<std::vector<uint8_t>(const Components&)>& choose, uint8_t value) {
  const Dims d = mask.dims();
  RunLabeller labeller(d, connectivity);
  const uint8_t* m = mask.data();
  if (ofZeros) labeller.findRuns([m](int64_t p) { return uint16_t(m[p] == 0); });
  else labeller.findRuns([m](int64_t p) { return uint16_t(m[p] != 0); });
  labeller.link();
  const Components c = labeller.finish(false);
  std::vector<uint8_t> chosen = choose(c);
  if (chosen.size() != c.sizes.size()) throw Error("paintComponents: the choice does not match the components");
  chosen[0] = 0;
  // The runs hold all the labelling needs: writing into the mask now changes nothing read.
  labeller.paintRuns(mask.data(), chosen, value);
}

VolumeU8 keepLargestComponent(const VolumeU8& mask, Connectivity connectivity) {
  VolumeU8 out = binaryCopy(mask);
  paintComponents(out, false, connectivity, [](const Components& c) {
    std::vector<uint8_t> drop(c.sizes.size(), 1);
    if (const uint32_t best = c.largest()) drop[best] = 0;
    return drop;
  }, 0);
  return out;
}

VolumeU8 removeSmallIslands(const VolumeU8& mask, double minVolumeMm3, Connectivity connectivity) {
  VolumeU8 out = binaryCopy(mask);
  removeSmallIslandsInPlace(out, minVolumeMm3, connectivity);
  return out;
}

void removeSmallIslandsInPlace(VolumeU8& mask, double minVolumeMm3, Connectivity connectivity) {
  const Geometry& g = mask.geometry();
  const double voxelMm3 = std::abs(g.direction.determinant()) * g.spacing.x * g.spacing.y * g.spacing.z;
  paintComponents(mask, false, connectivity, [&](const Components& c) {
    std::vector<uint8_t> drop(c.sizes.size(), 0);
    for (size_t l = 1; l < c.sizes.size(); ++l) drop[l] = static_cast<double>(c.sizes[l]) * voxelMm3 < minVolumeMm3;
    return drop;
  }, 0);
}

}  // namespace vellum
