// `vellum compare A B`: two label maps, images or volumes against tolerances (app/compare.hpp).
// Exit 0 within tolerance, 1 outside it, 2 when an input cannot be read or the flags are wrong.
#include <iostream>
#include <memory>
#include <sstream>

#include "cli_params.hpp"
#include "cli_util.hpp"
#include "commands.hpp"
#include "vellum/app/compare.hpp"
#include "vellum/app/run_report.hpp"
#include "vellum/core/error.hpp"
#include "vellum/io/image_io.hpp"

namespace vellum::cli {
namespace {

struct CompareArgs {
  std::string a, b, kind = "auto", json, heatmap;
  std::vector<uint16_t> ids, aIds, bIds;
  app::CompareTolerances tolerances;
  bool quiet = false;
  InputOptions in;
};

int run(const CompareArgs& a) {
  app::CompareRequest q;
  q.a = a.a;
  q.b = a.b;
  q.kind = app::parseCompareKind(a.kind);
  q.tolerances = a.tolerances;
  q.ids = a.ids;
  q.aIds = a.aIds;
  q.bIds = a.bIds;
  q.load = a.in.toLoadOptions(nullptr);
  const bool jsonToStdout = a.json == "-";
  OutputPlan plan;
  plan.input(a.a, "A").input(a.b, "B");
  if (!jsonToStdout) plan.json(a.json, "--json");
  plan.output(a.heatmap, "--heatmap").check();
  app::RunReport run(commandLine());  // the envelope every command's report shares
  run.input(a.a, "A");
  run.input(a.b, "B");
  const app::CompareResult r = app::compareFiles(q);
  run.mark("compare");
  RunOutputs outputs;
  if (!a.heatmap.empty() && r.heatmap.width == 0) {
    // Grids or image sizes differ: a result (exit 1), with nothing to draw.
    std::cerr << "vellum: warning: --heatmap: nothing to draw (" << (r.failures.empty() ? "" : r.failures.front())
              << "); " << a.heatmap << " not written\n";
  } else if (!a.heatmap.empty()) {
    ensureParentFolder(a.heatmap);
    io::saveImage(r.heatmap, a.heatmap);
    outputs.wrote(a.heatmap);
    run.output(a.heatmap);
  }
  nlohmann::json report = r.report;
  run.stamp(report);
  if (jsonToStdout) {
    std::cout << report.dump(2) << "\n";
  } else {
    if (!a.json.empty()) {
      writeJsonFile(report, a.json);
      outputs.wrote(a.json);
    }
    if (!a.quiet) std::cout << app::compareSummary(r);
  }
  outputs.commit();
  std::cout.flush();
  return r.pass ? ExitCode::Success : ExitCode::Failure;
}

}  // namespace

void addCompareCommand(CLI::App& app) {
  auto a = std::make_shared<CompareArgs>();
  auto* cmd = app.add_subcommand(
      "compare", "Compare two label maps (Dice, Jaccard, HD95, ASSD per id), images (difference, PSNR, SSIM, "
                 "heat map) or volumes (geometry, HU differences); exit 0 within tolerance, 1 outside, 2 on error");
  addInput(*cmd, "a", a->a, "the result: label map, image (PNG, TIFF, JPEG) or volume (any format `info` reads)")
      ->required();
  addInput(*cmd, "b", a->b, "the baseline or reference, of the same kind")->required();
  cmd->add_option("--kind", a->kind, "auto | labels | image | volume (auto: images by extension, unsigned integer "
                                     "volumes as label maps, other volumes as grey)")
      ->capture_default_str();
  cmd->add_option("--ids", a->ids, "labels: compare only these ids (e.g. --ids 1,3)")->delimiter(',');
  cmd->add_option("--a-ids", a->aIds, "labels: compare the union of these ids in A with --b-ids in B as one mask")
      ->delimiter(',');
  cmd->add_option("--b-ids", a->bIds, "labels: the ids of B matched by --a-ids (default: the same)")->delimiter(',');
  addOutput(*cmd, "--json,--report", a->json, "write the comparison as JSON to this file ('-': stdout only)");
  addOutput(*cmd, "--heatmap", a->heatmap, "write the differences as a PNG (images: a heat map; label maps and "
                                           "volumes: the axial slice with the most disagreement)");
  cmd->add_flag("--quiet,-q", a->quiet, "print nothing; the exit code says pass (0) or fail (1)");
  addFlags(*cmd, a->tolerances, app::compareTolerancesTable());
  a->in.addTo(*cmd);
  cmd->footer("Example: vellum compare seg.nrrd truth.nrrd --min-dice 0.95 --max-hd95 2 --json cmp.json\n"
              "         vellum compare new.png baseline.png --tolerance 2 --max-differing-percent 0.1 --heatmap diff.png");
  cmd->callback(resultCommand([a] { return run(*a); }));
}

}  // namespace vellum::cli
