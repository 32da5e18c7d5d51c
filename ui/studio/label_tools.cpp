#include "label_tools.hpp"

#include <algorithm>
#include <cmath>
#ifdef __GLIBC__
#include <malloc.h>
#endif

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
}  // namespace

namespace seg = vellum::segmentation;

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

void thresholdInto(LabelVolume& labels, const VolumeI16& ct, const seg::HuInterval& interval,
                   const Label& label) {
  seg::addSegment(labels, seg::threshold(ct, interval), label, seg::OverlapRule::Overwrite);
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

void keepLargest(LabelVolume& labels, uint16_t id) {
  const seg::Mask keep = seg::keepLargestComponent(seg::segmentMask(labels, id));
  auto& ids = labels.ids().voxels();
  const auto& k = keep.voxels();
  for (size_t n = 0; n < ids.size(); ++n)
    if (ids[n] == id && !k[n]) ids[n] = 0;
  releaseFreedMemory();
}

void removeIslands(LabelVolume& labels, uint16_t id, double minVolumeMm3) {
  seg::Mask keep = seg::segmentMask(labels, id);
  seg::removeSmallIslandsInPlace(keep, minVolumeMm3);  // in place: one mask, no component ids
  auto& ids = labels.ids().voxels();
  const auto& k = keep.voxels();
  for (size_t n = 0; n < ids.size(); ++n)
    if (ids[n] == id && !k[n]) ids[n] = 0;
  releaseFreedMemory();
}

void fillHoles(LabelVolume& labels, uint16_t id) {
  const auto existing = labels.label(id);
  const Label label = existing ? *existing : Label{id, "Segment " + std::to_string(id), defaultLabelColor(id)};
  seg::Mask filled = seg::segmentMask(labels, id);
  seg::fillHolesInPlace(filled);  // in place: one mask, no component ids
  seg::addSegment(labels, filled, label, seg::OverlapRule::KeepExisting);
  releaseFreedMemory();
}

int64_t growFromSeed(LabelVolume& labels, const VolumeI16& ct, const Vec3& seedMm,
                     const seg::HuInterval& interval, const Label& label) {
  const seg::Mask grown = seg::connectedThreshold(ct, {seedMm}, interval);
  const int64_t n = seg::countVoxels(grown);
  if (n > 0) seg::addSegment(labels, grown, label, seg::OverlapRule::Overwrite);
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

void morphology(LabelVolume& labels, uint16_t id, Morphology op, double radiusMm, Progress& progress) {
  const seg::Mask m = seg::segmentMask(labels, id);
  seg::Mask r;
  switch (op) {
    case Morphology::Dilate: r = seg::dilate(m, radiusMm, progress); break;
    case Morphology::Erode: r = seg::erode(m, radiusMm, progress); break;
    case Morphology::Open: r = seg::open(m, radiusMm, progress); break;
    case Morphology::Close: r = seg::close(m, radiusMm, progress); break;
  }
  auto& ids = labels.ids().voxels();
  const auto& v = r.voxels();
  for (size_t n = 0; n < ids.size(); ++n) {
    if (ids[n] == id && !v[n]) ids[n] = 0;
    else if (ids[n] == 0 && v[n]) ids[n] = id;
  }
}

double otsuHu(const VolumeI16& ct) {
  seg::HistogramParams p;
  p.lowerHu = -900;
  // Two-class Otsu splits fat from muscle on a limb; three classes (fat | soft tissue |
  // bone) put the upper threshold where a user of the button wants it.
  return seg::multiOtsuThresholds(seg::histogram(ct, p), 3).back();
}

}  // namespace vellum::studio
