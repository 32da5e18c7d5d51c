#include "vellum/segmentation/label_map.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

namespace vellum::segmentation {

OverlapRule parseOverlapRule(const std::string& name) {
  if (name == "overwrite") return OverlapRule::Overwrite;
  if (name == "keep-existing" || name == "only-background") return OverlapRule::KeepExisting;
  if (name == "replace") return OverlapRule::Replace;
  throw Error("unknown overlap rule '" + name + "' (overwrite, keep-existing, replace)");
}

AddResult addSegment(LabelVolume& labels, const Mask& mask, const Label& label, OverlapRule rule) {
  if (label.id == 0) throw Error("segment id must be >= 1 (0 is background)");
  requireSameGeometry(labels.geometry(), mask.geometry(), "adding a segment to a label map");
  uint16_t* ids = labels.ids().data();
  const uint8_t* m = mask.data();
  const uint16_t id = label.id;
  struct Counts { int64_t written = 0, skipped = 0, cleared = 0; };
  const Counts c = tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, mask.size(), 1 << 16), Counts{},
      [&](const tbb::blocked_range<size_t>& r, Counts acc) {
        for (size_t i = r.begin(); i < r.end(); ++i) {
          if (!m[i]) {
            if (rule == OverlapRule::Replace && ids[i] == id) { ids[i] = 0; ++acc.cleared; }
            continue;
          }
          if (rule == OverlapRule::KeepExisting && ids[i] != 0 && ids[i] != id) { ++acc.skipped; continue; }
          ids[i] = id;
          ++acc.written;
        }
        return acc;
      },
      [](Counts a, const Counts& b) {
        a.written += b.written; a.skipped += b.skipped; a.cleared += b.cleared;
        return a;
      });
  labels.setLabel(label);
  return {c.written, c.skipped, c.cleared};
}

Mask segmentMask(const LabelVolume& labels, uint16_t id) {
  return maskFromIds(labels.ids(), [id](uint16_t v) { return v == id; });
}

}  // namespace vellum::segmentation
