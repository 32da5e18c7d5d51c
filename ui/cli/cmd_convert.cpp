// `vellum convert IN OUT [--type T] [--labels]`: any supported format to any writable one.
#include <iostream>
#include <memory>

#include "cli_util.hpp"
#include "commands.hpp"
#include "vellum/core/error.hpp"

namespace vellum::cli {
namespace {

struct ConvertArgs {
  std::string input, output, type;
  bool labels = false;
  bool rawEncoding = false;
  bool force = false;
  InputOptions in;
};

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

void addConvertCommand(CLI::App& app) {
  auto a = std::make_shared<ConvertArgs>();
  auto* cmd = app.add_subcommand("convert", "Convert a volume or label map between formats (DICOM, NRRD, RAW, MetaImage, NIfTI, VTI)");
  cmd->add_option("input", a->input, "input volume file or DICOM folder")->required();
  cmd->add_option("output", a->output, "output file (format from extension) or folder (DICOM series)")->required();
  cmd->add_option("--type", a->type, "convert voxels to int16 | uint8 | uint16 | float32 (rounding, saturating)");
  cmd->add_flag("--labels", a->labels, "treat the input as a label map (keeps the label table)");
  cmd->add_flag("--no-gzip", a->rawEncoding, "NRRD: raw encoding instead of gzip");
  a->in.addTo(*cmd);
  addForceFlag(*cmd, a->force);
  cmd->footer("Example: vellum convert ../shared/data/ct-head-phantom head.nrrd");
  cmd->callback([a] {
    OutputPlan().input(a->input).output(a->output, "the output", !a->rawEncoding).force(a->force).check();
    ensureParentFolder(a->output);
    io::SaveOptions so;
    so.gzip = !a->rawEncoding;
    so.force = a->force;
    if (a->labels) {
      const LabelVolume labels = io::loadLabels(a->input, a->in.toLoadOptions(nullptr));
      io::saveLabels(labels, a->output, so);
      std::cout << a->input << " -> " << a->output << " (label map, " << labels.table().size() << " labels)\n";
      return;
    }
    io::LoadedVolume lv = loadWithProgress(a->input, a->in);
    if (!a->type.empty()) lv.volume = convertTo(lv.volume, parseVoxelType(a->type));
    so.modality = lv.modality.empty() ? "OT" : lv.modality;
    ProgressBar bar;
    so.progress = &bar.progress();
    io::saveVolume(lv.volume, a->output, so);
    bar.finish();
    std::cout << a->input << " -> " << a->output << " (" << geometryOf(lv.volume).dims.str() << " "
              << voxelTypeName(voxelTypeOf(lv.volume)) << ")\n";
  });
}

}  // namespace vellum::cli
