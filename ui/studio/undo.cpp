#include "undo.hpp"

#include "vellum/core/error.hpp"

namespace vellum::studio {

LabelDelta diffLabels(const LabelVolume& before, const LabelVolume& after, std::string description) {
  const auto& a = before.ids().voxels();
  const auto& b = after.ids().voxels();
  if (a.size() != b.size()) throw Error("diffLabels: label maps differ in size");
  LabelDelta d;
  d.description = std::move(description);
  d.tableBefore = before.table();
  d.tableAfter = after.table();
  for (size_t n = 0; n < a.size(); ++n) {
    if (a[n] == b[n]) continue;
    LabelDelta::Run* last = d.runs.empty() ? nullptr : &d.runs.back();
    if (last && last->start + last->length == n && last->before == a[n] && last->after == b[n] &&
        last->length < UINT32_MAX) {
      ++last->length;
    } else {
      d.runs.push_back({n, 1, a[n], b[n]});
    }
  }
  return d;
}

void applyDelta(LabelVolume& labels, const LabelDelta& delta, bool forward) {
  auto& ids = labels.ids().voxels();
  for (const auto& r : delta.runs) {
    if (r.start + r.length > ids.size()) throw Error("applyDelta: run outside the label map");
    std::fill_n(ids.begin() + static_cast<std::ptrdiff_t>(r.start), r.length,
                forward ? r.after : r.before);
  }
  // The table is replaced as a whole: LabelVolume offers setLabel only, so rebuild it.
  LabelVolume rebuilt(std::move(labels.ids()), forward ? delta.tableAfter : delta.tableBefore);
  labels = std::move(rebuilt);
}

void UndoStack::push(LabelDelta delta) {
  if (delta.empty()) return;
  undo_.push_back(std::move(delta));
  redo_.clear();
}

bool UndoStack::undo(LabelVolume& labels) {
  if (undo_.empty()) return false;
  applyDelta(labels, undo_.back(), false);
  redo_.push_back(std::move(undo_.back()));
  undo_.pop_back();
  return true;
}

bool UndoStack::redo(LabelVolume& labels) {
  if (redo_.empty()) return false;
  applyDelta(labels, redo_.back(), true);
  undo_.push_back(std::move(redo_.back()));
  redo_.pop_back();
  return true;
}

void UndoStack::clear() {
  undo_.clear();
  redo_.clear();
}

size_t UndoStack::bytes() const {
  size_t n = 0;
  for (const auto& d : undo_) n += d.bytes();
  for (const auto& d : redo_) n += d.bytes();
  return n;
}

}  // namespace vellum::studio
