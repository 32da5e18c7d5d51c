// `vellum phantom --out CT [--labels LABELS] [--size N | --dims X Y Z] ...`
#include <iostream>
#include <memory>

#include "cli_params.hpp"
#include "cli_util.hpp"
#include "commands.hpp"
#include "vellum/app/run_report.hpp"
#include "vellum/phantom/phantom.hpp"

namespace vellum::cli {
namespace {

struct PhantomArgs {
  std::string out, labels;
  int size = 128;
  std::vector<int64_t> dims;
  std::vector<double> spacing;
  uint64_t seed = 1;
  double noise = 15.0;
  double flexion = 0.0;
  bool noPartialVolume = false;
  bool force = false;
  std::string report;
};

/// The phantom's single-valued flags, described once (docs/parameters.md).
const params::Table<PhantomArgs>& phantomFlagsTable() {
  using A = PhantomArgs;
  static const params::Table<A> t{
      params::integer<A>("size", &A::size, {"Size", "voxels per axis (cube)", "voxels", 16, 1024}),
      params::integer<A>("seed", &A::seed, {"Seed", "noise seed", "", 0}),
      params::real<A>("noise", &A::noise, {"Noise", "noise standard deviation", "HU", 0}),
      params::real<A>("flexion", &A::flexion, {"Flexion", "knee flexion", "degrees", -180, 180}),
      params::flag<A>("no_partial_volume", &A::noPartialVolume,
                      {"No partial volume", "hard tissue edges (no supersampling)", ""}),
  };
  return t;
}

/// Its number lists (unset: a cube of --size voxels, 180x180x220 mm).
const ListTable<PhantomArgs>& phantomListTable() {
  using A = PhantomArgs;
  static const ListTable<A> t{
      numbers<A>("dims", &A::dims, 3, "X Y Z", {"Dimensions", "voxels per axis X Y Z (overrides --size)", "voxels"}),
      numbers<A>("spacing", &A::spacing, 3, "SX SY SZ",
                 {"Spacing", "voxel spacing (default: 180x180x220 mm field of view / dims)", "mm"}),
  };
  return t;
}

}  // namespace

std::string phantomFlagsMarkdown() {
  return params::markdown(phantomFlagsTable()) + listMarkdownRows(phantomListTable());
}

void addPhantomCommand(CLI::App& app) {
  auto a = std::make_shared<PhantomArgs>();
  auto* cmd = app.add_subcommand("phantom", "Generate the synthetic knee CT phantom (HU) and its ground-truth labels");
  addOutput(*cmd, "--out,-o", a->out, "CT output: .nrrd, .raw (+ .raw.json sidecar), .mha/.mhd, .vti or a DICOM folder")
      ->required();
  addOutput(*cmd, "--labels", a->labels, "ground-truth label map output (.nrrd with label table)");
  addFlags(*cmd, *a, phantomFlagsTable());
  addLists(*cmd, *a, phantomListTable());  // --dims, --spacing
  addOutput(*cmd, "--report", a->report, "write a JSON report: version, command, options, outputs with fingerprints, time, memory");
  addForceFlag(*cmd, a->force);
  cmd->footer("Example: vellum phantom --size 256 --out knee.nrrd --labels knee-labels.nrrd");
  cmd->callback([a] {
    phantom::PhantomOptions o;
    o.dims = a->dims.empty() ? Dims{a->size, a->size, a->size} : Dims{a->dims[0], a->dims[1], a->dims[2]};
    if (!a->spacing.empty()) o.spacing = {a->spacing[0], a->spacing[1], a->spacing[2]};
    o.seed = a->seed;
    o.noiseSigmaHu = a->noise;
    o.kneeFlexionDeg = a->flexion;
    o.partialVolume = !a->noPartialVolume;
    OutputPlan().output(a->out, "--out").output(a->labels, "--labels").json(a->report, "--report").force(a->force).check();
    const auto t0 = std::chrono::steady_clock::now();
    app::RunReport run(commandLine(), t0);
    ProgressBar bar;
    phantom::Phantom p = phantom::makePhantom(o, bar.progress());
    bar.finish();
    const double genSeconds = secondsSince(t0);
    io::SaveOptions so;
    so.force = a->force;
    RunOutputs outputs;
    ensureParentFolder(a->out);
    io::saveVolume(p.ct, a->out, so);
    outputs.wrote(a->out);
    if (!a->labels.empty()) {
      ensureParentFolder(a->labels);
      io::saveLabels(p.labels, a->labels, so);
      outputs.wrote(a->labels);
    }
    if (!a->report.empty()) {
      run.mark("generate and write");
      run.outputVolume(a->out);
      run.outputVolume(a->labels);
      nlohmann::json report = {{"dims", {o.dims.x, o.dims.y, o.dims.z}}, {"seed", o.seed}, {"noise_hu", o.noiseSigmaHu},
                               {"flexion_deg", o.kneeFlexionDeg}, {"partial_volume", o.partialVolume},
                               {"generate_seconds", genSeconds}};
      run.stamp(report);
      writeJsonFile(report, a->report);
    }
    outputs.commit();
    std::cout << "phantom " << o.dims.str() << " generated in " << genSeconds << " s -> " << a->out
              << (a->labels.empty() ? "" : " + " + a->labels) << "\n";
  });
}

}  // namespace vellum::cli
