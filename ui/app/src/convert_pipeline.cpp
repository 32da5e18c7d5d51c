// `vellum convert` as one call (convert_pipeline.hpp).
#include "vellum/app/convert_pipeline.hpp"

#include "vellum/app/outputs.hpp"
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

}  // namespace

ConvertResult runConvert(const ConvertRequest& r, Progress& progress) {
  io::OutputPlan().input(r.input).output(r.output, "the output", r.gzip).force(r.force).check();
  ensureParentFolder(r.output);
  io::SaveOptions so;
  so.gzip = r.gzip;
  so.force = r.force;
  so.progress = &progress;
  io::LoadOptions load = r.load;
  load.progress = &progress;
  ConvertResult result;
  if (r.labels) {
    const LabelVolume labels = io::loadLabels(r.input, load);
    io::saveLabels(labels, r.output, so);
    result.dims = labels.geometry().dims;
    result.type = VoxelType::UInt16;
    result.labelCount = labels.table().size();
    return result;
  }
  io::LoadedVolume lv = io::loadVolume(r.input, load);
  if (r.type) lv.volume = convertTo(lv.volume, *r.type);
  so.modality = lv.modality.empty() ? "OT" : lv.modality;
  io::saveVolume(lv.volume, r.output, so);
  result.dims = geometryOf(lv.volume).dims;
  result.type = voxelTypeOf(lv.volume);
  result.warnings = std::move(lv.warnings);
  return result;
}

}  // namespace vellum::app
