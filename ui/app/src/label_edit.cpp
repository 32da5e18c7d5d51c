// `vellum labels` as one call (label_edit.hpp).
#include "vellum/app/label_edit.hpp"
#include "vellum/app/run_io.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <climits>
#include <set>

#include "vellum/app/outputs.hpp"
#include "vellum/app/run_report.hpp"
#include "vellum/core/box_corners.hpp"
#include "vellum/core/error.hpp"
#include "vellum/segmentation/label_map.hpp"
#include "vellum/segmentation/mask.hpp"

namespace vellum::app {
namespace {

std::vector<LabelEditResult::Entry> entries(const LabelVolume& labels) {
  const Geometry& g = labels.geometry();
  const double voxelMm3 = segmentation::voxelVolumeMm3(g);
  // Per id, in one pass: its voxels, their index sums and index bounds.
  struct Sums {
    int64_t n = 0;
    double x = 0, y = 0, z = 0;
    int64_t lo[3] = {INT64_MAX, INT64_MAX, INT64_MAX}, hi[3] = {-1, -1, -1};
  };
  std::vector<Sums> sums(65536);
  const Dims d = g.dims;
  const uint16_t* v = labels.ids().data();
  for (int64_t z = 0; z < d.z; ++z)
    for (int64_t y = 0; y < d.y; ++y)
      for (int64_t x = 0; x < d.x; ++x, ++v) {
        if (!*v) continue;
        Sums& s = sums[*v];
        ++s.n;
        s.x += double(x), s.y += double(y), s.z += double(z);
        const int64_t ijk[3] = {x, y, z};
        for (int a = 0; a < 3; ++a) s.lo[a] = std::min(s.lo[a], ijk[a]), s.hi[a] = std::max(s.hi[a], ijk[a]);
      }
  std::vector<LabelEditResult::Entry> out;
  for (size_t id = 1; id < sums.size(); ++id) {
    const Sums& s = sums[id];
    if (!s.n) continue;
    const auto l = labels.label(static_cast<uint16_t>(id));
    const double n = double(s.n);
    LabelEditResult::Entry e{static_cast<uint16_t>(id), l ? l->name : "", s.n, n * voxelMm3,
                             g.indexToPhysical(Vec3{s.x / n, s.y / n, s.z / n}), {}, {}};
    // The physical box of the index box's corners (any direction matrix).
    BoxMm box;
    for (const Vec3& p : indexBoxCorners(g, Vec3{double(s.lo[0]), double(s.lo[1]), double(s.lo[2])},
                                         Vec3{double(s.hi[0]), double(s.hi[1]), double(s.hi[2])}))
      box.add(p);
    e.boxMinMm = box.lo;
    e.boxMaxMm = box.hi;
    out.push_back(std::move(e));
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
