// `vellum`: the headless command line of the Vellum volume workstation.
#include <CLI/CLI.hpp>

#include <algorithm>
#include <csignal>
#include <string>
#include <vector>
#include <iostream>

#include "cli_params.hpp"
#include "cli_util.hpp"
#include "commands.hpp"
#include "vellum/app/run_report.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/parallel.hpp"
#include "vellum/core/progress.hpp"

namespace {

/// First Ctrl-C / SIGTERM: cancel the running work through Progress, which unwinds through
/// the atomic writers (no temporary file is left, no output is half-written) and exits 130.
/// A second one kills at once (the default action).
extern "C" void onInterrupt(int sig) {
  vellum::Progress::requestCancelEverywhere();
  std::signal(sig, SIG_DFL);
}

}  // namespace

int main(int argc, char** argv) {
  std::signal(SIGINT, onInterrupt);
  std::signal(SIGTERM, onInterrupt);
  // Past RLIMIT_FSIZE a write fails with EFBIG instead of killing us: it is then reported as
  // a full disk is (a one-line error naming the target, nothing half-written left behind).
  std::signal(SIGXFSZ, SIG_IGN);
  // VELLUM_THREADS applies to every parallel loop from the start (also those that call TBB
  // directly before the first parallelFor).
  vellum::workerCount();
  CLI::App app{"Vellum: CT volume loading, segmentation, deformation and rendering", "vellum"};
  app.require_subcommand(1);
  const std::string commit = vellum::app::vellumGitCommit();
  app.set_version_flag("--version", "vellum " + vellum::app::vellumVersion() + (commit.empty() ? "" : " (" + commit + ")"));
  using namespace vellum::cli;
  addInfoCommand(app);
  addPhantomCommand(app);
  addConvertCommand(app);
  addRenderCommand(app);
  addSegmentCommand(app);
  addLabelsCommand(app);
  addDeformCommand(app);
  addControlsCommand(app);
  addAnimateCommand(app);
  addPoseCommand(app);
  addShapeCommand(app);
  addIllustrateCommand(app);
  addCurveAnalogyCommand(app);
  addDemoCommand(app);
  addParamsCommand(app);
  addCompareCommand(app);
  addQaCommand(app);
  // Quoted where needed, so that the line in a report can be pasted back into a shell.
  for (int i = 0; i < argc; ++i) {
    std::string a = i == 0 ? std::string("vellum") : std::string(argv[i]);
    if (a.empty() || a.find_first_of(" \t'\"$\\") != std::string::npos) {
      std::string q = "'";
      for (char c : a) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
      a = q + "'";
    }
    commandLine() += (i ? " " : "") + a;
  }
  try {
    std::vector<std::string> args = joinBooleanFlagValues(app, std::vector<std::string>(argv + 1, argv + argc));
    std::reverse(args.begin(), args.end());  // CLI11 takes them last first
    app.parse(args);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const vellum::Cancelled&) {
    std::cerr << "vellum: cancelled\n";
    return 130;
  } catch (const std::exception& e) {
    std::cerr << "vellum: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
