// `vellum qa MANIFEST --out DIR`: the regression cases of a manifest, several at once or as a
// Snakemake workflow, with a baseline store and a report (app/qa.hpp, docs/qa.md).
// Exit 0 when every case passes, 1 when any fails, 2 on a manifest or usage error.
#include <spawn.h>
#include <sys/wait.h>

#include <fstream>
#include <iostream>
#include <memory>
#include <thread>

#include "cli_params.hpp"
#include "cli_util.hpp"
#include "commands.hpp"
#include "vellum/app/qa.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/json_input.hpp"
#include "vellum/io/atomic_file.hpp"

extern char** environ;

namespace vellum::cli {
namespace fs = std::filesystem;
namespace {

struct QaArgs {
  std::string manifest, out, baselines, caseName, reportFrom, profile;
  bool update = false, listCases = false, snakemake = false, snakefileOnly = false, force = false;
  std::optional<int> jobs;  ///< unset: the machine's core count

  int jobCount() const { return jobs.value_or(static_cast<int>(std::max(1u, std::thread::hardware_concurrency()))); }
};

/// The single-valued flags of `qa` besides its paths, described once (docs/parameters.md).
const params::Table<QaArgs>& qaFlagsTable() {
  using A = QaArgs;
  static const params::Table<A> t{
      params::integer<A>("jobs", &A::jobs,
                         {"Jobs", "cases at once (Snakemake: --cores); unset: the machine's core count", "", 1, 1024}),
      params::text<A>("baselines", &A::baselines,
                      {"Baselines", "the baseline store (default: the manifest's \"baselines\", else baselines/ "
                                    "beside it)", ""}),
      params::flag<A>("update_baselines", &A::update,
                      {"Update baselines", "write the cases' outputs into the baseline store (with a sidecar naming "
                                           "the commands and the Vellum version) instead of comparing", ""}),
      params::text<A>("case", &A::caseName,
                      {"Case", "run only this case, in this process (what each parallel or Snakemake job runs)", ""}),
      params::flag<A>("list_cases", &A::listCases, {"List cases", "print the manifest's case names", ""}),
      params::flag<A>("snakemake", &A::snakemake,
                      {"Snakemake", "run the cases as a Snakemake workflow (one job per case, the report last)", ""}),
      params::flag<A>("snakefile_only", &A::snakefileOnly,
                      {"Snakefile only", "write the workflow to OUT/workflow and print how to run it", ""}),
      params::text<A>("profile", &A::profile,
                      {"Profile", "--snakemake: a Snakemake profile (e.g. scripts/qa/slurm for Slurm)", ""}),
  };
  return t;
}

int finish(const app::QaSummary& s, const fs::path& out) {
  std::cout << s.cases - s.failures << " of " << s.cases << " cases pass; report: " << (out / "report.html").string()
            << ", " << (out / "junit.xml").string() << "\n";
  return s.failures ? 1 : 0;
}

/// Runs the workflow written to OUT/workflow through the `snakemake` on PATH.
int runSnakemake(const QaArgs& a, const fs::path& out) {
  const fs::path workflow = out / "workflow";
  fs::create_directories(workflow);
  io::writeAtomically(workflow / "Snakefile", [](const fs::path& tmp) {
    std::ofstream f(tmp);
    f << app::qaSnakefile();
    if (!f) throw FileError(tmp, "cannot write");
  });
  const std::string self = fs::read_symlink("/proc/self/exe").string();
  if (a.snakefileOnly) {
    std::cout << "wrote " << (workflow / "Snakefile").string() << "; run:\n  snakemake -s " << (workflow / "Snakefile").string()
              << " --directory " << workflow.string() << " --cores " << a.jobCount() << " --config out=" << out.string()
              << " vellum=" << self << "\n";
    return 0;
  }
  std::vector<std::string> args{"snakemake", "-s", (workflow / "Snakefile").string(), "--directory", workflow.string(),
                                "--cores", std::to_string(a.jobCount()), "--quiet", "--config", "out=" + out.string(),
                                "vellum=" + self};
  if (!a.profile.empty()) args.insert(args.end(), {"--profile", a.profile});
  std::vector<char*> argv;
  for (auto& s : args) argv.push_back(s.data());
  argv.push_back(nullptr);
  pid_t pid = -1;
  if (posix_spawnp(&pid, "snakemake", nullptr, nullptr, argv.data(), environ) != 0)
    throw Error("--snakemake: cannot start `snakemake` (Debian package snakemake)");
  int status = 0;
  ::waitpid(pid, &status, 0);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
    throw Error("--snakemake: snakemake failed (exit " + std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status)) +
                "); its log is under " + (workflow / ".snakemake" / "log").string());
  const nlohmann::json s = readJsonFile(out / "summary.json", 1 << 20, "QA summary");
  app::QaSummary sum;
  sum.cases = s["cases"].get<int>();
  sum.failures = s["failures"].get<int>();
  return finish(sum, out);
}

int run(const QaArgs& a) {
  if (!a.reportFrom.empty()) {
    if (!a.manifest.empty()) throw Error("--report-from takes no manifest");
    return finish(app::writeQaReport(a.reportFrom), a.reportFrom);
  }
  if (a.manifest.empty()) throw Error("a manifest is needed (or --report-from DIR)");
  const app::QaManifest m = app::readQaManifest(a.manifest);
  if (a.listCases) {
    for (const auto& c : m.cases) std::cout << c.name << "\n";
    return 0;
  }
  if (a.out.empty()) throw Error("--out DIR is needed (the run folder)");
  app::QaRunOptions o;
  o.out = fs::absolute(a.out).lexically_normal();
  o.baselines = a.baselines;
  o.updateBaselines = a.update;
  o.jobs = a.jobCount();
  o.force = a.force;
  if (!a.caseName.empty()) {
    for (const auto& c : m.cases)
      if (c.name == a.caseName) return app::runQaCase(m, c, o) ? 0 : 1;
    throw FileError(a.manifest, "no case named '" + a.caseName + "'");
  }
  app::prepareQaRun(m, o);
  if (a.snakemake || a.snakefileOnly) return runSnakemake(a, o.out);
  app::runQaCases(m, o);
  return finish(app::writeQaReport(o.out), o.out);
}

}  // namespace

std::string qaFlagsMarkdown() { return params::markdown(qaFlagsTable()); }

void addQaCommand(CLI::App& app) {
  auto a = std::make_shared<QaArgs>();
  auto* cmd = app.add_subcommand(
      "qa", "Run a QA manifest's cases (vellum commands, checks against baselines and references, time and memory "
            "ceilings) in parallel or on Snakemake; JUnit XML and HTML report; exit 0 all pass, 1 any failure, 2 error");
  addInput(*cmd, "manifest", a->manifest, "the QA manifest (JSON; docs/qa.md)");
  addOutput(*cmd, "--out,-o", a->out, "the run folder: case outputs, logs, report.html, junit.xml, summary.json");
  addFlags(*cmd, *a, qaFlagsTable(), {}, "", {{"jobs", "-j"}});
  addInput(*cmd, "--report-from", a->reportFrom, "write the report of a run folder from its cases' results");
  addForceFlag(*cmd, a->force);
  cmd->footer("Example: vellum qa qa.json --out qa-run --jobs 4   (first run: --update-baselines)\n"
              "         vellum qa qa.json --out qa-run --snakemake --profile scripts/qa/slurm");
  cmd->callback(resultCommand([a] { return run(*a); }));
}

}  // namespace vellum::cli
