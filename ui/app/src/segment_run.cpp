// `vellum segment` as one call (segment_pipeline.hpp: runSegment): load, segment, add to a
// label map, compare with the truth, write.
#include <algorithm>
#include <chrono>
#include <cmath>

#include "vellum/app/figures.hpp"
#include "vellum/app/run_io.hpp"
#include "vellum/app/outputs.hpp"
#include "vellum/app/run_report.hpp"
#include "vellum/app/segment_pipeline.hpp"
#include "vellum/core/error.hpp"
#include "vellum/segmentation/label_map.hpp"
#include "vellum/segmentation/metrics.hpp"

namespace vellum::app {
namespace seg = vellum::segmentation;
namespace {

using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

nlohmann::json metricsJson(const seg::SegmentMetrics& m) {
  auto num = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); };
  return {{"id", m.id}, {"dice", m.dice}, {"jaccard", m.jaccard}, {"voxels", m.voxels},
          {"truth_voxels", m.truthVoxels}, {"volume_mm3", m.volumeMm3}, {"truth_volume_mm3", m.truthVolumeMm3},
          {"volume_difference_mm3", m.volumeDifferenceMm3}, {"volume_difference_percent", m.volumeDifferencePercent},
          {"hd95_mm", num(m.hd95Mm)}, {"hausdorff_mm", num(m.hausdorffMm)},
          {"mean_surface_distance_mm", num(m.meanSurfaceDistanceMm)}};
}

/// A label map on the input's grid: the same region (crop, downsample) as the CT.
LabelVolume loadLabelsLikeInput(const std::filesystem::path& path, const SegmentRequest& r) {
  return loadLabelsLike(path, r.load);
}

/// Adds the segmentation to `labels` as label `id` (or, for k-means classes, ids id..id+k-1);
/// returns the ids written and reports the single segment's counts.
std::vector<uint16_t> addToLabels(const SegmentRequest& r, const SegmentationResult& s, uint16_t id,
                                  LabelVolume& labels, nlohmann::json& report) {
  const seg::OverlapRule rule = seg::parseOverlapRule(r.overlap);
  std::vector<uint16_t> written;
  if (s.classes) {
    for (int c = 1; c <= r.settings.classes; ++c) {
      const uint16_t cid = static_cast<uint16_t>(id + c - 1);
      const seg::Mask m = seg::maskFromIds(*s.classes, [c](uint16_t v) { return v == c; });
      const std::string name = (r.labelName.empty() ? "class " : r.labelName + " ") + std::to_string(c);
      seg::addSegment(labels, m, {cid, name, defaultLabelColor(cid)}, rule);
      written.push_back(cid);
    }
    return written;
  }
  const std::string name = r.labelName.empty() ? r.settings.method : r.labelName;
  if (s.objects) {
    // One id per object: `id` and the next ids free in `labels` (an --into map keeps its own).
    const nlohmann::json& split = s.info["split"]["objects"];  // volumes, largest first
    const int count = static_cast<int>(split.size());
    std::vector<uint16_t> ids;
    for (uint32_t candidate = id; int(ids.size()) < count; ++candidate) {
      if (candidate > 65535) throw Error("split: not enough free label ids for " + std::to_string(count) + " objects");
      if (candidate == id || !labels.label(static_cast<uint16_t>(candidate))) ids.push_back(static_cast<uint16_t>(candidate));
    }
    std::vector<Label> entries;
    for (int o = 1; o <= count; ++o) {
      const uint16_t oid = ids[o - 1];
      const auto colour = o == 1 && r.colour ? *r.colour : defaultLabelColor(oid);
      entries.push_back({oid, name + " " + std::to_string(o), colour});
      written.push_back(oid);
    }
    seg::addSegments(labels, *s.objects, entries, rule);
    nlohmann::json objects = nlohmann::json::array();
    for (int o = 1; o <= count; ++o)
      objects.push_back({{"id", ids[o - 1]}, {"volume_mm3", split[o - 1]["volume_mm3"]}});
    report["segment"] = {{"id", id}, {"voxels", seg::countVoxels(s.mask)}, {"volume_mm3", seg::maskVolumeMm3(s.mask)},
                         {"objects", objects}};
    return written;
  }
  const seg::AddResult a = seg::addSegment(labels, s.mask, {id, name, r.colour.value_or(defaultLabelColor(id))}, rule);
  report["segment"] = {{"id", id}, {"voxels", a.written}, {"skipped_by_overlap_rule", a.skipped},
                       {"cleared", a.cleared}, {"volume_mm3", seg::maskVolumeMm3(s.mask)}};
  written.push_back(id);
  return written;
}

/// Dice, Jaccard, HD95 and volume difference of the written labels against the truth (or of
/// the segment against the union of the truth ids).
nlohmann::json truthMetrics(const SegmentRequest& r, const LabelVolume& labels, const SegmentationResult& s,
                            uint16_t id, const std::vector<uint16_t>& written) {
  const LabelVolume truth = loadLabelsLikeInput(r.truth, r);
  nlohmann::json metrics = nlohmann::json::array();
  if (!r.truthIds.empty() && !s.classes) {
    const auto& ids = r.truthIds;
    const seg::Mask t = seg::maskFromIds(truth.ids(), [&](uint16_t v) {
      return std::find(ids.begin(), ids.end(), v) != ids.end();
    });
    seg::SegmentMetrics m = seg::compareMasks(s.mask, t);
    m.id = id;
    nlohmann::json j = metricsJson(m);
    j["truth_ids"] = ids;
    metrics.push_back(j);
    return metrics;
  }
  for (const auto& m : seg::compareLabels(labels.ids(), truth.ids(), written)) metrics.push_back(metricsJson(m));
  return metrics;
}

}  // namespace

SegmentResult runSegment(const SegmentRequest& r, Progress& progress) {
  const auto t0 = Clock::now();
  io::OutputPlan()
      .input(r.input)
      .input(r.into, "the --into label map")
      .input(r.truth, "the --truth label map")
      .output(r.output, "--out")
      .json(r.report, "--report")
      .force(r.force)
      .check();
  RunReport run(r.commandLine);
  run.input(r.input, "volume");
  run.input(r.into, "label map to add into");
  run.input(r.truth, "truth label map");
  io::LoadedVolume lv = loadInput(run, r.input, r.load, progress);
  const VolumeI16 ct = toInt16(lv.volume);
  SegmentResult result;
  result.warnings = std::move(lv.warnings);
  nlohmann::json& report = result.report;
  report["input"] = r.input.string();
  report["method"] = r.settings.method;
  report["dims"] = {ct.dims().x, ct.dims().y, ct.dims().z};
  report["spacing_mm"] = {ct.geometry().spacing.x, ct.geometry().spacing.y, ct.geometry().spacing.z};
  report["load_seconds"] = secondsSince(t0);

  const auto t1 = Clock::now();
  const SegmentationResult s = runSegmentation(ct, r.settings, progress);
  report.update(s.info);
  report["segment_seconds"] = secondsSince(t1);

  LabelVolume labels = r.into.empty() ? LabelVolume(ct.geometry()) : loadLabelsLikeInput(r.into, r);
  const uint16_t id = r.labelId > 0 ? r.labelId : labels.nextFreeId();
  result.written = addToLabels(r, s, id, labels, report);
  // The truth comparison runs before anything is written: a truth map that cannot be read
  // leaves no output behind.
  if (!r.truth.empty()) {
    report["truth"] = r.truth.string();
    report["metrics"] = truthMetrics(r, labels, s, id, result.written);
  }
  RunOutputs outputs;
  saveLabelsOutput(outputs, labels, r.output, r.force);
  run.mark("segment and write");
  report["seconds"] = secondsSince(t0);
  if (!r.report.empty()) {
    run.outputVolume(r.output);
    run.stamp(report);  // the returned report is the file's
    writeJsonFile(report, r.report);
  }
  outputs.commit();
  return result;
}

}  // namespace vellum::app
