// `vellum labels` as one call (label_edit.hpp).
#include "vellum/app/label_edit.hpp"
#include "vellum/app/run_io.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <climits>
#include <set>

#include "vellum/app/outputs.hpp"
#include "vellum/app/run_report.hpp"
#include "vellum/core/error.hpp"
#include "vellum/segmentation/label_map.hpp"
#include "vellum/segmentation/mask.hpp"

namespace vellum::app {
namespace {

std::vector<LabelEditResult::Entry> entries(const LabelVolume& labels) {
  const std::vector<uint64_t> counts = labels.histogram();
  const double voxelMm3 = segmentation::voxelVolumeMm3(labels.geometry());
  // Per id: index sums and bounds in one pass (ids are dense, a few hundred at most).
  struct Sums {
    double x = 0, y = 0, z = 0;
    int lo[3] = {INT_MAX, INT_MAX, INT_MAX}, hi[3] = {-1, -1, -1};
  };
  std::vector<Sums> sums(counts.size());
  const Dims d = labels.geometry().dims;
  const uint16_t* v = labels.ids().data();
  for (int z = 0; z < int(d.z); ++z)
    for (int y = 0; y < int(d.y); ++y)
      for (int x = 0; x < int(d.x); ++x, ++v) {
        if (!*v) continue;
        Sums& s = sums[*v];
        s.x += x, s.y += y, s.z += z;
        const int ijk[3] = {x, y, z};
        for (int a = 0; a < 3; ++a) s.lo[a] = std::min(s.lo[a], ijk[a]), s.hi[a] = std::max(s.hi[a], ijk[a]);
      }
  const Geometry& g = labels.geometry();
  std::vector<LabelEditResult::Entry> out;
  for (size_t id = 1; id < counts.size(); ++id) {
    if (!counts[id]) continue;
    const auto l = labels.label(static_cast<uint16_t>(id));
    const Sums& s = sums[id];
    const double n = double(counts[id]);
    const Vec3 a = g.indexToPhysical(Vec3{double(s.lo[0]), double(s.lo[1]), double(s.lo[2])});
    const Vec3 b = g.indexToPhysical(Vec3{double(s.hi[0]), double(s.hi[1]), double(s.hi[2])});
    out.push_back({static_cast<uint16_t>(id), l ? l->name : "", static_cast<int64_t>(counts[id]),
                   n * voxelMm3, g.indexToPhysical(Vec3{s.x / n, s.y / n, s.z / n}),
                   Vec3{std::min(a.x, b.x), std::min(a.y, b.y), std::min(a.z, b.z)},
                   Vec3{std::max(a.x, b.x), std::max(a.y, b.y), std::max(a.z, b.z)}});
  }
  return out;
}

nlohmann::json entriesJson(const std::vector<LabelEditResult::Entry>& es) {
  nlohmann::json j = nlohmann::json::array();
  for (const auto& e : es) j.push_back({{"id", e.id}, {"name", e.name}, {"voxels", e.voxels}, {"volume_mm3", e.volumeMm3},
                 {"centre_mm", {e.centreMm.x, e.centreMm.y, e.centreMm.z}},
                 {"box_mm", {e.boxMinMm.x, e.boxMinMm.y, e.boxMinMm.z, e.boxMaxMm.x, e.boxMaxMm.y, e.boxMaxMm.z}}});
  return j;
}

}  // namespace

LabelEditResult runLabelEdit(const LabelEditRequest& r, Progress& progress) {
  io::OutputPlan().input(r.input).output(r.output, "--out").json(r.report, "--report").force(r.force).check();
  RunReport run(r.commandLine);
  run.input(r.input, "label map");
  io::LoadOptions load = r.load;
  load.progress = &progress;
  const LabelVolume labels = io::loadLabels(r.input, load);
  run.mark("load");
  LabelEditResult result;
  result.before = entries(labels);
  auto present = [&](uint16_t id) {
    return std::any_of(result.before.begin(), result.before.end(), [id](const auto& e) { return e.id == id; });
  };
  auto requirePresent = [&](uint16_t id, const char* what) {
    if (!present(id)) throw FileError(r.input, std::string(what) + ": id " + std::to_string(id) + " is not in the label map");
  };
  std::map<uint16_t, uint16_t> mapping;
  auto move = [&](uint16_t from, uint16_t to, const char* what) {
    if (from == 0) throw Error(std::string(what) + ": id 0 is background");
    requirePresent(from, what);
    if (mapping.count(from) && mapping[from] != to)
      throw Error(std::string(what) + ": id " + std::to_string(from) + " is moved twice");
    mapping[from] = to;
  };
  for (const auto& [from, to] : r.assign) {
    if (to == 0) throw Error("--assign: the target id must be >= 1 (use --drop to clear ids)");
    for (uint16_t f : from) move(f, to, "--assign");
  }
  for (uint16_t d : r.drop) move(d, 0, "--drop");
  if (!r.keep.empty()) {
    for (uint16_t k : r.keep) requirePresent(k, "--keep");
    for (const auto& e : result.before)
      if (std::find(r.keep.begin(), r.keep.end(), e.id) == r.keep.end() && !mapping.count(e.id)) mapping[e.id] = 0;
  }
  LabelVolume edited = segmentation::relabel(labels, mapping);
  const std::vector<uint64_t> counts = edited.histogram();
  auto holds = [&](uint16_t id) { return id < counts.size() && counts[id] > 0; };
  for (const auto& [id, name] : r.names) {
    if (!holds(id)) throw Error("--name: id " + std::to_string(id) + " is not in the edited map");
    Label l = edited.label(id).value_or(Label{id, "", defaultLabelColor(id)});
    l.name = name;
    edited.setLabel(l);
  }
  for (const auto& [id, rgb] : r.colours) {
    if (!holds(id)) throw Error("--colour: id " + std::to_string(id) + " is not in the edited map");
    Label l = edited.label(id).value_or(Label{id, "label " + std::to_string(id), rgb});
    l.rgb = rgb;
    edited.setLabel(l);
  }
  result.after = entries(edited);
  RunOutputs outputs;
  saveLabelsOutput(outputs, edited, r.output, r.force);
  run.mark("edit and write");
  if (!r.report.empty()) {
    run.outputVolume(r.output);
    nlohmann::json report = {{"before", entriesJson(result.before)}, {"after", entriesJson(result.after)}};
    run.stamp(report);
    writeJsonFile(report, r.report);
  }
  outputs.commit();
  return result;
}

}  // namespace vellum::app
