// `vellum convert` as one call (convert_pipeline.hpp).
#include "vellum/app/convert_pipeline.hpp"

#include "vellum/app/outputs.hpp"
#include "vellum/app/run_report.hpp"
#include "vellum/core/error.hpp"

namespace vellum::app {
namespace {

AnyVolume convertTo(const AnyVolume& v, VoxelType t) {
  switch (t) {
    case VoxelType::Int16: return convertVolume<int16_t>(v);
    case VoxelType::UInt8: return convertVolume<uint8_t>(v);
    case VoxelType::UInt16: return convertVolume<uint16_t>(v);
    case VoxelType::Float32: return convertVolume<float>(v);
  }
  throw Error("unknown voxel type");
}

/// The report: what was converted, with the shared keys; a report that cannot be written takes
/// the output with it.
void writeReport(RunReport& run, const ConvertRequest& r, nlohmann::json report, RunOutputs& written) {
  written.wrote(r.output);
  if (!r.report.empty()) {
    run.outputVolume(r.output);
    run.stamp(report);
    writeJsonFile(report, r.report);
  }
  written.commit();
}

}  // namespace

ConvertResult runConvert(const ConvertRequest& r, Progress& progress) {
  io::OutputPlan().input(r.input).output(r.output, "the output", r.gzip).json(r.report, "--report").force(r.force).check();
  RunReport run(r.commandLine);
  if (!r.report.empty()) run.input(r.input, r.labels ? "label map" : "volume");
  ensureParentFolder(r.output);
  io::SaveOptions so;
  so.gzip = r.gzip;
  so.force = r.force;
  so.progress = &progress;
  io::LoadOptions load = r.load;
  load.progress = &progress;
  ConvertResult result;
  RunOutputs written;  // opened before the output replaces an older one: a failed run puts it back
  if (r.labels) {
    const LabelVolume labels = io::loadLabels(r.input, load);
    io::saveLabels(labels, r.output, so);
    result.dims = labels.geometry().dims;
    result.type = VoxelType::UInt16;
    result.labelCount = labels.table().size();
    writeReport(run, r, nlohmann::json{{"labels", result.labelCount}}, written);
    return result;
  }
  io::LoadedVolume lv = io::loadVolume(r.input, load);
  if (r.type) lv.volume = convertTo(lv.volume, *r.type);
  so.modality = lv.modality.empty() ? "OT" : lv.modality;
  io::saveVolume(lv.volume, r.output, so);
  result.dims = geometryOf(lv.volume).dims;
  result.type = voxelTypeOf(lv.volume);
  if (!r.report.empty()) run.loaded(r.input, lv);
  result.warnings = std::move(lv.warnings);
  writeReport(run, r, nlohmann::json{{"type", voxelTypeName(result.type)}}, written);
  return result;
}

}  // namespace vellum::app
