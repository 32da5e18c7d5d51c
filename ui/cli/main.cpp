// `vellum`: the headless command line of the Vellum volume workstation.
#include <CLI/CLI.hpp>

#include <algorithm>
#include <csignal>
#include <string>
#include <vector>
#include <iostream>

#include <nlohmann/json.hpp>

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

/// The one place that turns what a command threw into its exit code (docs/user-guide.md,
/// "Exit codes"): 0 success; 2 a usage or input error (a bad flag or value, a missing or
/// unreadable input, bad JSON); 1 a runtime failure (an output that cannot be written or is
/// refused, no GL context, out of memory); 130 cancelled. Every error is one line on stderr.
int runAndExit(CLI::App& app, std::vector<std::string>& args) {
  namespace ExitCode = vellum::cli::ExitCode;
  const auto fail = [](const std::string& what, int code) {
    std::string line = what;
    std::replace(line.begin(), line.end(), '\n', ' ');  // CLI11's messages may hold a newline
    std::cerr << "vellum: error: " << line << "\n";
    return code;
  };
  try {
    app.parse(args);
  } catch (const CLI::Success& e) {
    return app.exit(e);  // --help, --version (CallForHelp, CallForVersion derive from Success)
  } catch (const CLI::RuntimeError& e) {
    return e.get_exit_code();  // a command's own result code (compare, qa: 1 = checks failed)
  } catch (const CLI::ParseError& e) {
    std::string cmd;
    for (const CLI::App* sub : app.get_subcommands()) cmd = " " + sub->get_name();
    return fail(std::string(e.what()) + " (see `vellum" + cmd + " --help`)", ExitCode::Usage);
  } catch (const vellum::Cancelled&) {
    std::cerr << "vellum: cancelled\n";
    return ExitCode::Cancelled;
  } catch (const vellum::FileError& e) {
    // A file the command reads is an input error; one it writes (full disk, an output the
    // policy refuses to replace) is a runtime failure.
    return fail(e.what(), vellum::cli::isCommandInput(app, e.path()) ? ExitCode::Usage : ExitCode::Failure);
  } catch (const vellum::Error& e) {
    // Vellum's own errors name the parameter or flag at fault (core/error.hpp).
    return fail(e.what(), ExitCode::Usage);
  } catch (const nlohmann::json::exception& e) {
    return fail(e.what(), ExitCode::Usage);
  } catch (const std::exception& e) {
    return fail(e.what(), ExitCode::Failure);
  }
  return ExitCode::Success;
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
  addSliceCommand(app);
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
  std::vector<std::string> args = joinBooleanFlagValues(app, std::vector<std::string>(argv + 1, argv + argc));
  std::reverse(args.begin(), args.end());  // CLI11 takes them last first
  return runAndExit(app, args);
}
