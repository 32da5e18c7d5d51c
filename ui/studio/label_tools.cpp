#include "label_tools.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#ifdef __GLIBC__
#include <malloc.h>
#endif

#include "vellum/core/cropped_geometry.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/region.hpp"
#include "vellum/segmentation/components.hpp"
#include "vellum/segmentation/label_map.hpp"
#include "vellum/segmentation/morphology.hpp"
#include "vellum/segmentation/region_growing.hpp"

namespace vellum::studio {

namespace {
// A label operation's temporaries (component runs, per-slice queues) come from the worker
// threads' malloc arenas, which keep freed pages: hand them back, so that the studio's memory
// after an edit is what it holds (issue #22: <= 4x the volume).
void releaseFreedMemory() {
#ifdef __GLIBC__
  malloc_trim(0);
#endif
}

namespace seg = vellum::segmentation;

/// The label table with `label` added or replaced (what setLabel makes).
std::vector<Label> tableWith(const std::vector<Label>& table, const Label& label) {
  LabelVolume t(VolumeU16{}, table);
  t.setLabel(label);
  return t.table();
}

VoxelBox wholeGrid(const Geometry& g) { return {{0, 0, 0}, {g.dims.x - 1, g.dims.y - 1, g.dims.z - 1}}; }

void appendRun(std::vector<LabelDelta::Run>& runs, uint64_t n, uint32_t length, uint16_t before, uint16_t after) {
  LabelDelta::Run* last = runs.empty() ? nullptr : &runs.back();
  if (last && last->start + last->length == n && last->before == before && last->after == after &&
      uint64_t(last->length) + length <= UINT32_MAX)
    last->length += length;
  else
    runs.push_back({n, length, before, after});
}

/// The delta of an operation over `box`: `after(n, m, before)` is the id voxel n (linear index
/// in the map; m in the box) gets. Only the labels are read (no copy of them); each slice of
/// the box makes its own runs in parallel, joined in order (equal runs across slices merged),
/// so the delta is what diffLabels(before, after) would give.
template <class After>
LabelDelta footprintDelta(const LabelVolume& labels, const VoxelBox& box, const std::set<uint16_t>& locked,
                          std::vector<Label> tableAfter, After after) {
  const auto& ids = labels.ids().voxels();
  const Dims d = labels.geometry().dims;
  const Dims bd = box.dims();
  std::vector<uint8_t> isLocked;
  if (!locked.empty()) {
    isLocked.assign(65536, 0);
    for (uint16_t id : locked) isLocked[id] = 1;
  }
  std::vector<std::vector<LabelDelta::Run>> slices(static_cast<size_t>(bd.z));
  tbb::parallel_for(tbb::blocked_range<int64_t>(0, bd.z), [&](const tbb::blocked_range<int64_t>& r) {
    for (int64_t kk = r.begin(); kk < r.end(); ++kk) {
      auto& runs = slices[static_cast<size_t>(kk)];
      const int64_t k = box.lo[2] + kk;
      for (int64_t jj = 0; jj < bd.y; ++jj) {
        const uint64_t row = (uint64_t(k) * d.y + uint64_t(box.lo[1] + jj)) * d.x + uint64_t(box.lo[0]);
        const uint64_t rowBox = (uint64_t(kk) * bd.y + uint64_t(jj)) * bd.x;
        for (int64_t ii = 0; ii < bd.x; ++ii) {
          const uint64_t n = row + uint64_t(ii);
          const uint16_t b = ids[n];
          const uint16_t a = after(n, rowBox + uint64_t(ii), b);
          if (a == b || (!isLocked.empty() && (isLocked[a] || isLocked[b]))) continue;
          appendRun(runs, n, 1, b, a);
        }
      }
    }
  });
  LabelDelta delta;
  delta.tableBefore = labels.table();
  delta.tableAfter = std::move(tableAfter);
  size_t total = 0;
  for (const auto& s : slices) total += s.size();
  delta.runs.reserve(total);
  for (auto& s : slices) {
    for (const auto& run : s) appendRun(delta.runs, run.start, run.length, run.before, run.after);
    std::vector<LabelDelta::Run>().swap(s);  // freed as it is joined
  }
  delta.runs.shrink_to_fit();
  return delta;
}

/// The voxel box of segment `id` (nullopt: it has no voxels).
std::optional<VoxelBox> segmentBox(const LabelVolume& labels, uint16_t id) {
  const auto& ids = labels.ids().voxels();
  const Dims d = labels.geometry().dims;
  std::vector<std::optional<VoxelBox>> perSlice(static_cast<size_t>(d.z));
  tbb::parallel_for(tbb::blocked_range<int64_t>(0, d.z), [&](const tbb::blocked_range<int64_t>& r) {
    for (int64_t k = r.begin(); k < r.end(); ++k) {
      std::optional<VoxelBox> b;
      for (int64_t j = 0; j < d.y; ++j) {
        const uint16_t* row = ids.data() + (uint64_t(k) * d.y + uint64_t(j)) * d.x;
        for (int64_t i = 0; i < d.x; ++i) {
          if (row[i] != id) continue;
          if (!b) b = VoxelBox{{i, j, k}, {i, j, k}};
          b->lo[0] = std::min(b->lo[0], i), b->hi[0] = std::max(b->hi[0], i);
          b->lo[1] = std::min(b->lo[1], j), b->hi[1] = std::max(b->hi[1], j);
        }
      }
      perSlice[static_cast<size_t>(k)] = b;
    }
  });
  std::optional<VoxelBox> box;
  for (const auto& b : perSlice) {
    if (!b) continue;
    if (!box) { box = b; continue; }
    for (int a = 0; a < 3; ++a) box->lo[a] = std::min(box->lo[a], b->lo[a]), box->hi[a] = std::max(box->hi[a], b->hi[a]);
  }
  return box;
}

/// The mask of `id` on `box` (the box's own geometry: the voxels sit where they were).
seg::Mask segmentMaskIn(const LabelVolume& labels, uint16_t id, const VoxelBox& box) {
  seg::Mask m(croppedGeometry(labels.geometry(), box), 0, 0.0);
  const auto& ids = labels.ids().voxels();
  const Dims d = labels.geometry().dims;
  const Dims bd = box.dims();
  uint8_t* out = m.data();
  tbb::parallel_for(tbb::blocked_range<int64_t>(0, bd.z), [&](const tbb::blocked_range<int64_t>& r) {
    for (int64_t kk = r.begin(); kk < r.end(); ++kk)
      for (int64_t jj = 0; jj < bd.y; ++jj) {
        const uint16_t* row = ids.data() + (uint64_t(box.lo[2] + kk) * d.y + uint64_t(box.lo[1] + jj)) * d.x + box.lo[0];
        uint8_t* o = out + (uint64_t(kk) * bd.y + uint64_t(jj)) * bd.x;
        for (int64_t i = 0; i < bd.x; ++i) o[i] = row[i] == id;
      }
  });
  return m;
}

/// Segment `id` becomes `mask` (on `box`) where the background allows: its voxels outside the
/// mask are cleared, background voxels inside it take the id, other segments keep theirs.
/// (Islands and keep-largest only clear, fill holes only fills, morphology does both.)
LabelDelta reshapeDelta(const LabelVolume& labels, uint16_t id, const VoxelBox& box, const seg::Mask& mask,
                        const std::set<uint16_t>& locked, std::vector<Label> tableAfter) {
  const uint8_t* m = mask.data();
  return footprintDelta(labels, box, locked, std::move(tableAfter), [&](uint64_t, uint64_t mb, uint16_t b) -> uint16_t {
    if (m[mb]) return b == 0 ? id : b;
    return b == id ? uint16_t{0} : b;
  });
}

/// An edit that changes no voxel (the table may still change).
LabelDelta tableOnlyDelta(const LabelVolume& labels, std::vector<Label> tableAfter) {
  LabelDelta d;
  d.tableBefore = labels.table();
  d.tableAfter = std::move(tableAfter);
  return d;
}

}  // namespace

LabelDelta diffEdit(const LabelVolume& labels, const std::string& description,
                    const std::function<void(LabelVolume&)>& edit, const std::set<uint16_t>& locked) {
  LabelVolume after = labels;
  edit(after);
  if (!locked.empty()) {
    const auto& b = labels.ids().voxels();
    auto& a = after.ids().voxels();
    for (size_t n = 0; n < a.size(); ++n)
      if (a[n] != b[n] && (locked.count(a[n]) || locked.count(b[n]))) a[n] = b[n];
  }
  return diffLabels(labels, after, description);
}

LabelDelta recordEdit(LabelVolume& labels, const std::string& description,
                      const std::function<void(LabelVolume&)>& edit, const std::set<uint16_t>& locked) {
  LabelDelta delta = diffEdit(labels, description, edit, locked);
  applyDelta(labels, delta, true);
  return delta;
}

LabelDelta thresholdDelta(const LabelVolume& labels, const VolumeI16& ct, const seg::HuInterval& interval,
                          const Label& label, const std::set<uint16_t>& locked) {
  if (label.id == 0) throw Error("segment id must be >= 1 (0 is background)");
  seg::requireSameGeometry(labels.geometry(), ct.geometry(), "thresholding into the labels");
  // The footprint is the threshold's own predicate on the CT: no mask is made.
  const int16_t* v = ct.data();
  const uint16_t id = label.id;
  LabelDelta d = footprintDelta(labels, wholeGrid(labels.geometry()), locked, tableWith(labels.table(), label),
                                [&](uint64_t n, uint64_t, uint16_t b) { return interval.contains(v[n]) ? id : b; });
  releaseFreedMemory();
  return d;
}

LabelDelta maskDelta(const LabelVolume& labels, const seg::Mask& mask, const Label& label,
                     const std::set<uint16_t>& locked) {
  if (label.id == 0) throw Error("segment id must be >= 1 (0 is background)");
  seg::requireSameGeometry(labels.geometry(), mask.geometry(), "adding a segment to the labels");
  const uint8_t* m = mask.data();
  const uint16_t id = label.id;
  return footprintDelta(labels, wholeGrid(labels.geometry()), locked, tableWith(labels.table(), label),
                        [&](uint64_t n, uint64_t, uint16_t b) { return m[n] ? id : b; });
}

LabelDelta keepLargestDelta(const LabelVolume& labels, uint16_t id, const std::set<uint16_t>& locked) {
  const auto box = segmentBox(labels, id);
  if (!box) return tableOnlyDelta(labels, labels.table());
  // Components never reach outside the segment's box: the work (mask, labelling) is the box's.
  const seg::Mask keep = seg::keepLargestComponent(segmentMaskIn(labels, id, *box));
  LabelDelta d = reshapeDelta(labels, id, *box, keep, locked, labels.table());
  releaseFreedMemory();
  return d;
}

LabelDelta removeIslandsDelta(const LabelVolume& labels, uint16_t id, double minVolumeMm3,
                              const std::set<uint16_t>& locked) {
  const auto box = segmentBox(labels, id);
  if (!box) return tableOnlyDelta(labels, labels.table());
  seg::Mask keep = segmentMaskIn(labels, id, *box);
  seg::removeSmallIslandsInPlace(keep, minVolumeMm3);  // in place: one mask, no component ids
  LabelDelta d = reshapeDelta(labels, id, *box, keep, locked, labels.table());
  releaseFreedMemory();
  return d;
}

LabelDelta fillHolesDelta(const LabelVolume& labels, uint16_t id, const std::set<uint16_t>& locked) {
  const auto existing = labels.label(id);
  const Label label = existing ? *existing : Label{id, "Segment " + std::to_string(id), defaultLabelColor(id)};
  const auto box = segmentBox(labels, id);
  if (!box) return tableOnlyDelta(labels, tableWith(labels.table(), label));
  // Exact on the segment's box: a background voxel outside the box reaches the grid's border
  // along the axis it is outside on, so a region touching the box's border is no hole.
  seg::Mask filled = segmentMaskIn(labels, id, *box);
  seg::fillHolesInPlace(filled);  // in place: one mask, no component ids
  LabelDelta d = reshapeDelta(labels, id, *box, filled, locked, tableWith(labels.table(), label));
  releaseFreedMemory();
  return d;
}

LabelDelta growDelta(const LabelVolume& labels, const VolumeI16& ct, const Vec3& seedMm,
                     const seg::HuInterval& interval, const Label& label, const std::set<uint16_t>& locked,
                     int64_t* grownOut) {
  const seg::Mask grown = seg::connectedThreshold(ct, {seedMm}, interval);
  const int64_t n = seg::countVoxels(grown);
  if (grownOut) *grownOut = n;
  if (n == 0) return tableOnlyDelta(labels, labels.table());
  return maskDelta(labels, grown, label, locked);
}

void thresholdInto(LabelVolume& labels, const VolumeI16& ct, const seg::HuInterval& interval,
                   const Label& label) {
  applyDelta(labels, thresholdDelta(labels, ct, interval, label), true);
}

int64_t paintSphere(LabelVolume& labels, const Vec3& centerMm, double radiusMm, uint16_t id,
                    const std::set<uint16_t>& locked, std::vector<std::pair<uint64_t, uint16_t>>* changedOut) {
  if (locked.count(id)) return 0;
  const Geometry& g = labels.geometry();
  const Vec3 c = g.physicalToIndex(centerMm);
  // Index-space bounding box of the ball (spacing may differ per axis).
  int64_t lo[3], hi[3];
  for (int a = 0; a < 3; ++a) {
    const double r = radiusMm / g.spacing[a] + 1;
    lo[a] = std::max<int64_t>(0, static_cast<int64_t>(std::floor(c[a] - r)));
    hi[a] = std::min<int64_t>(g.dims[a] - 1, static_cast<int64_t>(std::ceil(c[a] + r)));
  }
  int64_t changed = 0;
  for (int64_t k = lo[2]; k <= hi[2]; ++k)
    for (int64_t j = lo[1]; j <= hi[1]; ++j)
      for (int64_t i = lo[0]; i <= hi[0]; ++i) {
        const Vec3 p = g.indexToPhysical({double(i), double(j), double(k)});
        if (norm(p - centerMm) > radiusMm) continue;
        uint16_t& v = labels(i, j, k);
        if (v != id && !locked.count(v)) {
          if (changedOut) changedOut->emplace_back(static_cast<uint64_t>(&v - labels.ids().data()), v);
          v = id;
          ++changed;
        }
      }
  if (id && !labels.label(id)) labels.setLabel({id, "Segment " + std::to_string(id), defaultLabelColor(id)});
  return changed;
}

LabelDelta strokeDelta(std::vector<std::pair<uint64_t, uint16_t>> changed, std::vector<Label> tableBefore,
                       const LabelVolume& labels, std::string description) {
  std::sort(changed.begin(), changed.end());
  const auto& ids = labels.ids().voxels();
  LabelDelta d;
  d.description = std::move(description);
  d.tableBefore = std::move(tableBefore);
  d.tableAfter = labels.table();
  for (const auto& [n, before] : changed) {
    const uint16_t after = ids[n];
    if (after == before) continue;
    LabelDelta::Run* last = d.runs.empty() ? nullptr : &d.runs.back();
    if (last && last->start + last->length == n && last->before == before && last->after == after &&
        last->length < UINT32_MAX)
      ++last->length;
    else
      d.runs.push_back({n, 1, before, after});
  }
  return d;
}

void keepLargest(LabelVolume& labels, uint16_t id) { applyDelta(labels, keepLargestDelta(labels, id), true); }

void removeIslands(LabelVolume& labels, uint16_t id, double minVolumeMm3) {
  applyDelta(labels, removeIslandsDelta(labels, id, minVolumeMm3), true);
}

void fillHoles(LabelVolume& labels, uint16_t id) { applyDelta(labels, fillHolesDelta(labels, id), true); }

int64_t growFromSeed(LabelVolume& labels, const VolumeI16& ct, const Vec3& seedMm,
                     const seg::HuInterval& interval, const Label& label) {
  int64_t n = 0;
  applyDelta(labels, growDelta(labels, ct, seedMm, interval, label, {}, &n), true);
  return n;
}

const char* morphologyName(Morphology m) {
  switch (m) {
    case Morphology::Dilate: return "dilate";
    case Morphology::Erode: return "erode";
    case Morphology::Open: return "open";
    case Morphology::Close: return "close";
  }
  return "?";
}

LabelDelta morphologyDelta(const LabelVolume& labels, uint16_t id, Morphology op, double radiusMm,
                           const std::set<uint16_t>& locked, Progress& progress) {
  auto box = segmentBox(labels, id);
  if (!box) return tableOnlyDelta(labels, labels.table());  // nothing grows from or shrinks to nothing
  // A dilation reaches one radius beyond the segment and a closing's erosion looks one more
  // radius out: with two radii (and a voxel) of margin, the grid's edge is only seen where
  // the full map's is too, so the box gives the full map's result.
  const Geometry& g = labels.geometry();
  for (int a = 0; a < 3; ++a) {
    const int64_t margin = 2 * static_cast<int64_t>(std::ceil(radiusMm / g.spacing[a])) + 2;
    box->lo[a] = std::max<int64_t>(0, box->lo[a] - margin);
    box->hi[a] = std::min<int64_t>(g.dims[a] - 1, box->hi[a] + margin);
  }
  const seg::Mask m = segmentMaskIn(labels, id, *box);
  seg::Mask r;
  switch (op) {
    case Morphology::Dilate: r = seg::dilate(m, radiusMm, progress); break;
    case Morphology::Erode: r = seg::erode(m, radiusMm, progress); break;
    case Morphology::Open: r = seg::open(m, radiusMm, progress); break;
    case Morphology::Close: r = seg::close(m, radiusMm, progress); break;
  }
  LabelDelta d = reshapeDelta(labels, id, *box, r, locked, labels.table());
  releaseFreedMemory();
  return d;
}

void morphology(LabelVolume& labels, uint16_t id, Morphology op, double radiusMm, Progress& progress) {
  applyDelta(labels, morphologyDelta(labels, id, op, radiusMm, {}, progress), true);
}

double otsuHu(const VolumeI16& ct) {
  seg::HistogramParams p;
  p.lowerHu = -900;
  // Two-class Otsu splits fat from muscle on a limb; three classes (fat | soft tissue |
  // bone) put the upper threshold where a user of the button wants it.
  return seg::multiOtsuThresholds(seg::histogram(ct, p), 3).back();
}

}  // namespace vellum::studio
