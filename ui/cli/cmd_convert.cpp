// `vellum convert IN OUT [--type T] [--labels]`: any supported format to any writable one
// (app::runConvert; this file binds the flags and prints).
#include <iostream>
#include <memory>

#include "cli_params.hpp"
#include "cli_util.hpp"
#include "commands.hpp"
#include "vellum/app/convert_pipeline.hpp"
#include "vellum/core/error.hpp"

namespace vellum::cli {
namespace {

struct ConvertArgs {
  app::ConvertRequest request;
  std::string type;
  bool rawEncoding = false;
  InputOptions in;
};

/// The flags of `convert` besides its paths, described once (docs/parameters.md).
const params::Table<ConvertArgs>& convertFlagsTable() {
  using A = ConvertArgs;
  static const params::Table<A> t{
      params::text<A>("type", &A::type, {"Voxel type", "convert voxels to this type (rounding, saturating); empty: keep", ""},
                      {"", "int16", "uint8", "uint16", "float32"}),
      params::flag<A>("labels", params::nested(&A::request, &app::ConvertRequest::labels),
                      {"Label map", "treat the input as a label map (keeps the label table)", ""}),
      params::flag<A>("no_gzip", &A::rawEncoding, {"No gzip", "NRRD: raw encoding instead of gzip", ""}),
  };
  return t;
}

}  // namespace

std::string convertFlagsMarkdown() {
  const ConvertArgs defaults;  // named: GCC 12 warns (falsely) on the temporary default argument
  return params::markdown(convertFlagsTable(), defaults);
}

void addConvertCommand(CLI::App& app) {
  auto a = std::make_shared<ConvertArgs>();
  app::ConvertRequest& r = a->request;
  auto* cmd = app.add_subcommand("convert", "Convert a volume or label map between formats (DICOM, NRRD, RAW, MetaImage, NIfTI, VTI)");
  addInput(*cmd, "input", r.input, "input volume file or DICOM folder")->required();
  addOutput(*cmd, "output", r.output, "output file (format from extension) or folder (DICOM series)")->required();
  addFlags(*cmd, *a, convertFlagsTable());
  addOutput(*cmd, "--report", r.report, "write a JSON report: version, command, input and output with fingerprints, memory");
  a->in.addTo(*cmd);
  addForceFlag(*cmd, r.force);
  cmd->footer("Example: vellum convert ../shared/data/ct-head-phantom head.nrrd");
  cmd->callback([a] {
    app::ConvertRequest r = a->request;
    r.gzip = !a->rawEncoding;
    if (!a->type.empty()) r.type = parseVoxelType(a->type);
    setVolumeInput(r, a->in);
    const app::ConvertResult result = runPipeline(r, app::runConvert);
    std::cout << r.input.string() << " -> " << r.output.string();
    if (r.labels) std::cout << " (label map, " << result.labelCount << " labels)\n";
    else std::cout << " (" << result.dims.str() << " " << voxelTypeName(result.type) << ")\n";
  });
}

}  // namespace vellum::cli
