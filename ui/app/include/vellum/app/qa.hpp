#pragma once
// `vellum qa MANIFEST`: regression runs over sample scans. A JSON manifest lists cases (vellum
// command lines and the checks on what they wrote: comparisons against a baseline store or a
// reference, time and memory ceilings); each case runs as a child `vellum qa --case NAME`
// (locally, several at once, or as one Snakemake job each), writes its result.json, and the
// report (JUnit XML, a self-contained HTML page, summary.json) is made from those files.
// docs/qa.md describes the manifest and the run folder.
#include <nlohmann/json.hpp>

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "vellum/app/compare.hpp"

namespace vellum::app {

/// One check on a case's outputs.
struct QaCheck {
  enum class Type { Baseline, Reference, MaxSeconds, MaxRss };
  Type type = Type::Baseline;
  std::string output;                 ///< Baseline / Reference: a file the case wrote (relative to its folder)
  /// Reference: the file to compare with, relative to the manifest; "{out}", "{scan}" and
  /// "{manifest_dir}" are replaced as in the commands.
  std::string reference;
  CompareKind kind = CompareKind::Auto;
  CompareTolerances tolerances;
  std::vector<uint16_t> ids, aIds, bIds;
  double limit = 0;                   ///< MaxSeconds: s (the commands' wall time); MaxRss: MiB (the largest peak)
};

struct QaCase {
  std::string name;                   ///< letters, digits, '.', '_', '-'
  std::filesystem::path scan;         ///< optional; "{scan}" in the commands
  std::vector<std::vector<std::string>> commands;  ///< `vellum` arguments, run in order in the case folder
  std::vector<QaCheck> checks;
  double timeoutSeconds = 0;          ///< a command running longer is stopped (0: no limit)
};

struct QaManifest {
  std::filesystem::path path;         ///< absolute
  std::string name;
  std::filesystem::path baselines;    ///< the baseline store (absolute)
  std::vector<QaCase> cases;
};

/// Reads and checks a manifest (core/json_input.hpp's guarded reader). Paths are relative to
/// the manifest's folder. Throws vellum::FileError "MANIFEST: cases[2].checks[0]: problem".
QaManifest readQaManifest(const std::filesystem::path& path);

struct QaRunOptions {
  std::filesystem::path out;          ///< the run folder (a Vellum "qa" folder)
  std::filesystem::path baselines;    ///< overrides the manifest's store when set
  bool updateBaselines = false;       ///< write the outputs into the store instead of comparing
  int jobs = 1;                       ///< cases at once
  bool force = false;                 ///< replace a Vellum folder of another kind
  std::filesystem::path vellum;       ///< the `vellum` binary the cases run (default: this process's)
};

/// The case folder `out`/cases/NAME.
std::filesystem::path qaCaseFolder(const std::filesystem::path& out, const std::string& name);

/// Prepares the run folder: checks it against the output policy, makes it a "qa" folder,
/// removes the previous run's results and writes qa-run.json (the manifest, the case names, the
/// arguments a case runner needs).
void prepareQaRun(const QaManifest& manifest, const QaRunOptions& options);

/// Runs one case in this process: its commands as child processes (wall time and peak memory
/// from wait4), then its checks; writes the case folder's result.json (also when a command
/// fails). Returns whether every check passed.
bool runQaCase(const QaManifest& manifest, const QaCase& qaCase, const QaRunOptions& options);

/// Runs every case as a child `vellum qa MANIFEST --case NAME`, at most options.jobs at once;
/// a case that fails or crashes never stops the others. Prints one line per finished case.
void runQaCases(const QaManifest& manifest, const QaRunOptions& options);

struct QaSummary {
  int cases = 0, failures = 0;
  double seconds = 0;
};

/// Reads the run folder's results and writes junit.xml, report.html and summary.json. A case
/// without a result counts as failed.
QaSummary writeQaReport(const std::filesystem::path& out);

/// The Snakemake workflow (scripts/qa/Snakefile, built into the binary).
const char* qaSnakefile();

}  // namespace vellum::app
