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
  app::CompareRequest request;  ///< the flags write here
  std::string json, heatmap;
  bool quiet = false;
  InputOptions in;
};

/// `compare`'s flags besides its paths and tolerances, described once (docs/parameters.md).
const params::Table<CompareArgs>& compareFlagsTable() {
  using A = CompareArgs;
  static const params::Table<A> t{
      params::choice<A>("kind", params::nested(&A::request, &app::CompareRequest::kind), app::compareKinds().names,
                        {"Kind", "what A and B are (auto: images by extension, unsigned integer volumes as label "
                                 "maps, other volumes as grey)", ""}),
      params::flag<A>("quiet", &A::quiet, {"Quiet", "print nothing; the exit code says pass (0) or fail (1)", ""}),
  };
  return t;
}
const ListTable<app::CompareRequest>& compareListTable() {
  using R = app::CompareRequest;
  static const ListTable<R> t{
      commaList<R>("ids", &R::ids, "ID,ID..", {"Ids", "labels: compare only these ids (e.g. --ids 1,3)", ""}),
      commaList<R>("a_ids", &R::aIds, "ID,ID..",
                   {"A ids", "labels: compare the union of these ids in A with --b-ids in B as one mask", ""}),
      commaList<R>("b_ids", &R::bIds, "ID,ID..", {"B ids", "labels: the ids of B matched by --a-ids (default: the same)", ""}),
  };
  return t;
}

int run(const CompareArgs& a) {
  app::CompareRequest q = a.request;
  q.load = a.in.toLoadOptions(nullptr);
  const bool jsonToStdout = a.json == "-";
  OutputPlan plan;
  plan.input(q.a, "A").input(q.b, "B");
  if (!jsonToStdout) plan.json(a.json, "--json");
  plan.output(a.heatmap, "--heatmap").check();
  app::RunReport run(commandLine());  // the envelope every command's report shares
  run.input(q.a, "A");
  run.input(q.b, "B");
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

std::string compareFlagsMarkdown() {
  return params::markdown(compareFlagsTable()) + listMarkdownRows(compareListTable());
}

void addCompareCommand(CLI::App& app) {
  auto a = std::make_shared<CompareArgs>();
  auto* cmd = app.add_subcommand(
      "compare", "Compare two label maps (Dice, Jaccard, HD95, ASSD per id), images (difference, PSNR, SSIM, "
                 "heat map) or volumes (geometry, HU differences); exit 0 within tolerance, 1 outside, 2 on error");
  addInput(*cmd, "a", a->request.a, "the result: label map, image (PNG, TIFF, JPEG) or volume (any format `info` reads)")
      ->required();
  addInput(*cmd, "b", a->request.b, "the baseline or reference, of the same kind")->required();
  addFlags(*cmd, *a, compareFlagsTable(), {}, "", {{"quiet", "-q"}});  // --kind, --quiet
  addLists(*cmd, a->request, compareListTable());  // --ids, --a-ids, --b-ids
  addOutput(*cmd, "--json,--report", a->json, "write the comparison as JSON to this file ('-': stdout only)");
  addOutput(*cmd, "--heatmap", a->heatmap, "write the differences as a PNG (images: a heat map; label maps and "
                                           "volumes: the axial slice with the most disagreement)");
  addFlags(*cmd, a->request.tolerances, app::compareTolerancesTable());
  a->in.addTo(*cmd);
  cmd->footer("Example: vellum compare seg.nrrd truth.nrrd --min-dice 0.95 --max-hd95 2 --json cmp.json\n"
              "         vellum compare new.png baseline.png --tolerance 2 --max-differing-percent 0.1 --heatmap diff.png");
  cmd->callback(resultCommand([a] { return run(*a); }));
}

}  // namespace vellum::cli
