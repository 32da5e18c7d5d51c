// `vellum slice IN --out FIG.png [--axis axial|coronal|sagittal] [--index I,..|--mm P,..|--every N]
// [--plate] [--window PRESET] [--labels MAP]`: slices as pictures at physical aspect. The work
// is app::runSlice (slice_pipeline.hpp); this file binds the flags and prints.
#include <iostream>
#include <memory>

#include "cli_params.hpp"
#include "cli_util.hpp"
#include "commands.hpp"
#include "vellum/app/slice_pipeline.hpp"

namespace vellum::cli {
namespace {

struct SliceArgs {
  app::SliceRequest request;
  InputOptions in;
};

/// The request's lists, described once (docs/parameters.md).
const ListTable<app::SliceRequest>& sliceListTable() {
  using R = app::SliceRequest;
  static const ListTable<R> t{
      commaList<R>("index", &R::indices, "I,I..",
                   {"Index", "voxel indices of the slices along the volume axis nearest the slice normal (repeatable)",
                    "voxels", 0, 1e9}),
      commaList<R>("mm", &R::positionsMm, "MM,MM..",
                   {"Position", "slice positions along the normal, LPS mm: axial z, coronal y, sagittal x "
                                "(as `vellum info` gives the origin; repeatable)", "mm"}),
      numbers<R>("box_mm", &R::boxMm, 6, "X0 X1 Y0 Y1 Z0 Z1",
                 {"Box", "show only this box's in-plane part (LPS mm); the volume is loaded whole, so --index "
                         "keeps counting in the input", "mm"}),
  };
  return t;
}

}  // namespace

std::string sliceFlagsMarkdown() {
  return params::markdown(app::sliceRequestTable()) + listMarkdownRows(sliceListTable());
}

void addSliceCommand(CLI::App& app) {
  auto a = std::make_shared<SliceArgs>();
  app::SliceRequest& r = a->request;
  auto* cmd = app.add_subcommand("slice", "Export axial, coronal or sagittal slices as PNG pictures at physical aspect "
                                          "(window/level, label overlay, orientation letters)");
  addInput(*cmd, "input", r.input, "volume file or DICOM folder")->required();
  addOutput(*cmd, "--out,-o", r.output,
            "picture (.png, .tif, .jpg); several slices: OUT-INDEX.png each, or one sheet with --plate")
      ->required();
  addInput(*cmd, "--labels", r.labels, "label map on the volume's grid, drawn in its table's colours");
  addInput(*cmd, "--beside", r.beside,
           "another volume resampled on the same planes (mm), a column beside the input's on the --plate "
           "(repeatable: before | after comparisons)");
  addOutput(*cmd, "--report", r.report, "write a JSON report: the slices, window, pixel size, inputs and outputs");
  addFlags(*cmd, r, app::sliceRequestTable());
  addLists(*cmd, r, sliceListTable());
  a->in.addTo(*cmd);
  cmd->footer("Examples:\n"
              "  vellum slice ct-feet-vhf --axis sagittal --mm -60 --window bone --out feet-sag.png\n"
              "  vellum slice ct.nrrd --every 10 --plate --caption --labels bones.nrrd --out sheet.png\n"
              "  vellum slice before.nrrd --beside after.nrrd --plate --axis sagittal --mm 240,247 --out pair.png");
  cmd->callback([a] {
    app::SliceRequest r = a->request;
    r.load = a->in.toLoadOptions(nullptr);
    r.commandLine = commandLine();
    const app::SliceResult result = runPipeline(r, app::runSlice);
    for (const auto& f : result.figures)
      std::cout << f.path.string() << "  " << app::sliceAxisName(r.axis) << " " << f.index << "  "
                << f.positionMm << " mm  " << f.width << "x" << f.height << "\n";
    std::cout << "window " << result.window.center << "/" << result.window.width << " HU, " << result.mmPerPixel
              << " mm per pixel\n";
  });
}

}  // namespace vellum::cli
