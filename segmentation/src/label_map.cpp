#include "vellum/segmentation/label_map.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>

namespace vellum::segmentation {

const params::EnumTable<OverlapRule>& overlapRules() {
  static const params::EnumTable<OverlapRule> t{
      "overlap rule", {"overwrite", "keep-existing", "replace"}, {{"only-background", OverlapRule::KeepExisting}}};
  return t;
}

namespace {

/// Writes into `ids` the id idOf(i) wherever it is non-zero, under `rule`; `isWritten(v)` says
/// whether an existing id is one of those being written (Replace clears it elsewhere).
template <class IdOf, class IsWritten>
AddResult writeIds(uint16_t* ids, size_t n, IdOf idOf, IsWritten isWritten, OverlapRule rule) {
  struct Counts { int64_t written = 0, skipped = 0, cleared = 0; };
  const Counts c = tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, n, 1 << 16), Counts{},
      [&](const tbb::blocked_range<size_t>& r, Counts acc) {
        for (size_t i = r.begin(); i < r.end(); ++i) {
          const uint16_t id = idOf(i);
          if (!id) {
            if (rule == OverlapRule::Replace && ids[i] && isWritten(ids[i])) { ids[i] = 0; ++acc.cleared; }
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
  return {c.written, c.skipped, c.cleared};
}

}  // namespace

AddResult addSegment(LabelVolume& labels, const Mask& mask, const Label& label, OverlapRule rule) {
  if (label.id == 0) throw Error("segment id must be >= 1 (0 is background)");
  requireSameGeometry(labels.geometry(), mask.geometry(), "adding a segment to a label map");
  const uint8_t* m = mask.data();
  const uint16_t id = label.id;
  const AddResult r = writeIds(
      labels.ids().data(), mask.size(), [&](size_t i) { return m[i] ? id : uint16_t{0}; },
      [id](uint16_t v) { return v == id; }, rule);
  labels.setLabel(label);
  return r;
}

AddResult addSegments(LabelVolume& labels, const VolumeU16& objects, const std::vector<Label>& entries,
                      OverlapRule rule) {
  requireSameGeometry(labels.geometry(), objects.geometry(), "adding segments to a label map");
  std::vector<uint16_t> idOfObject(entries.size() + 1, 0);
  std::vector<uint8_t> written(65536, 0);
  for (size_t o = 0; o < entries.size(); ++o) {
    if (entries[o].id == 0) throw Error("segment id must be >= 1 (0 is background)");
    idOfObject[o + 1] = entries[o].id;
    written[entries[o].id] = 1;
  }
  const uint16_t* obj = objects.data();
  const size_t count = entries.size();
  const AddResult r = writeIds(
      labels.ids().data(), objects.size(),
      [&](size_t i) { return obj[i] <= count ? idOfObject[obj[i]] : uint16_t{0}; },
      [&](uint16_t v) { return written[v] != 0; }, rule);
  for (const Label& l : entries) labels.setLabel(l);
  return r;
}

Mask segmentMask(const LabelVolume& labels, uint16_t id) {
  return maskFromIds(labels.ids(), [id](uint16_t v) { return v == id; });
}

LabelVolume relabel(const LabelVolume& labels, const std::map<uint16_t, uint16_t>& mapping) {
  std::vector<uint16_t> lut(65536);
  for (size_t v = 0; v < lut.size(); ++v) lut[v] = static_cast<uint16_t>(v);
  for (const auto& [from, to] : mapping) {
    if (from == 0) throw Error("relabel: id 0 is background and cannot be moved");
    lut[from] = to;
  }
  VolumeU16 ids = labels.ids();
  uint16_t* d = ids.data();
  tbb::parallel_for(tbb::blocked_range<size_t>(0, ids.size(), 1 << 16), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i < r.end(); ++i) d[i] = lut[d[i]];
  });
  LabelVolume out(std::move(ids));
  const std::vector<uint64_t> counts = out.histogram();
  auto present = [&](uint16_t id) { return id < counts.size() && counts[id] > 0; };
  // Entries of ids that stay (unmoved, or targets that had their own), then targets that take
  // their first source's entry; in id order.
  std::map<uint16_t, Label> table;
  for (const Label& l : labels.table())
    if (present(l.id) && lut[l.id] == l.id) table[l.id] = l;
  for (const auto& [from, to] : mapping) {
    if (to == 0 || table.count(to) || !present(to)) continue;
    if (const auto source = labels.label(from)) {
      Label l = *source;
      l.id = to;
      table[to] = l;
    }
  }
  for (const auto& [id, l] : table) out.setLabel(l);
  return out;
}

}  // namespace vellum::segmentation
