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

size_t TrackEdit::bytes() const {
  size_t n = 0;
  for (const auto* t : {&before, &after})
    for (const auto& k : t->keyframes) n += k.points.size() * sizeof(deformation::ControlPoint);
  return n;
}

size_t PoseEdit::bytes() const {
  size_t n = sizeof(PoseEdit);
  for (const auto* p : {&before, &after}) {
    n += p->joints.size() * sizeof(deformation::Joint);
    for (const auto& k : p->angles.keyframes) n += k.points.size() * sizeof(deformation::ControlPoint);
  }
  return n;
}

void UndoStack::record(UndoEntry entry) {
  undo_.push_back(std::move(entry));
  redo_.clear();
  ++changes_;
}

void UndoStack::push(LabelDelta delta) {
  if (delta.empty()) return;
  record(std::move(delta));
}

void UndoStack::push(TrackEdit edit) {
  record(std::move(edit));
}

void UndoStack::push(ViewEdit edit) {
  if (edit.before == edit.after) return;
  record(std::move(edit));
}

void UndoStack::push(ShapesEdit edit) {
  if (edit.before == edit.after) return;
  record(std::move(edit));
}

void UndoStack::push(PoseEdit edit) {
  if (edit.keyframeBefore == edit.keyframeAfter && samePose(edit.before, edit.after)) return;
  record(std::move(edit));
}

void UndoStack::apply(const UndoEntry& e, LabelVolume& labels, Authoring* authoring, ViewState* view, bool forward) {
  lastWasView_ = false;
  ++changes_;
  if (const auto* s = std::get_if<ShapesEdit>(&e)) {
    shapesToLoad_ = forward ? s->after : s->before;  // the studio loads it (a worker job)
    lastWasLabels_ = false;
    return;
  }
  if (const auto* p = std::get_if<PoseEdit>(&e)) {
    poseToRestore_ = PoseToRestore{forward ? p->after : p->before, forward ? p->keyframeAfter : p->keyframeBefore};
    lastWasLabels_ = false;
    return;
  }
  if (const auto* d = std::get_if<LabelDelta>(&e)) {
    applyDelta(labels, *d, forward);
    lastWasLabels_ = true;
    return;
  }
  if (const auto* v = std::get_if<ViewEdit>(&e)) {
    if (!view) throw Error("undo: a view edit needs the view state");
    *view = forward ? v->after : v->before;
    lastWasLabels_ = false;
    lastWasView_ = true;
    return;
  }
  const TrackEdit& t = std::get<TrackEdit>(e);
  if (!authoring) throw Error("undo: a control-point edit needs the authoring state");
  authoring->track = forward ? t.after : t.before;
  authoring->keyframe = forward ? t.keyframeAfter : t.keyframeBefore;
  authoring->engine = forward ? t.engineAfter : t.engineBefore;
  if (const auto& rigid = forward ? t.rigidAfter : t.rigidBefore) {
    authoring->rigidLabels = rigid->labels;
    authoring->falloffMm = rigid->falloffMm;
  }
  authoring->timeS.reset();
  authoring->playing = false;
  const int n = authoring->active() ? int(authoring->track.keyframes.front().points.size()) : 0;
  if (authoring->selected >= n) authoring->selected = -1;
  authoring->touch();
  lastWasLabels_ = false;
}

bool UndoStack::step(bool forward, LabelVolume& labels, Authoring* authoring, ViewState* view) {
  // Undo takes the last edit to the redo side; redo the other way.
  std::vector<UndoEntry>& from = forward ? redo_ : undo_;
  std::vector<UndoEntry>& to = forward ? undo_ : redo_;
  if (from.empty()) return false;
  apply(from.back(), labels, authoring, view, forward);
  to.push_back(std::move(from.back()));
  from.pop_back();
  return true;
}

bool UndoStack::undo(LabelVolume& labels, Authoring* authoring, ViewState* view) {
  return step(false, labels, authoring, view);
}

bool UndoStack::redo(LabelVolume& labels, Authoring* authoring, ViewState* view) {
  return step(true, labels, authoring, view);
}

void UndoStack::clear() {
  undo_.clear();
  redo_.clear();
}

size_t UndoStack::bytes() const {
  size_t n = 0;
  for (const auto* v : {&undo_, &redo_})
    for (const auto& e : *v) n += std::visit([](const auto& x) { return x.bytes(); }, e);
  return n;
}

}  // namespace vellum::studio
