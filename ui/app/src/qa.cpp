// `vellum qa`: the manifest, the case runner (commands as child processes measured by wait4)
// and the local scheduler (at most N case runners at once). The report is qa_report.cpp's.
#include "vellum/app/qa.hpp"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <cctype>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <ctime>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <set>
#include <thread>

#include "vellum/app/outputs.hpp"
#include "vellum/app/run_report.hpp"
#include "vellum/core/error.hpp"
#include "vellum/core/json_input.hpp"
#include "vellum/core/params_json.hpp"
#include "vellum/core/progress.hpp"
#include "vellum/io/atomic_file.hpp"
#include "vellum/io/image_io.hpp"
#include "vellum/io/output_policy.hpp"

extern char** environ;

namespace vellum::app {
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace {

constexpr uint64_t kMaxManifestBytes = 16u << 20;

std::string utcNow() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

bool validName(const std::string& s) {
  if (s.empty() || s.size() > 100 || s[0] == '.') return false;
  for (char c : s)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_' && c != '.') return false;
  return true;
}

// ---- manifest ----------------------------------------------------------------------------

/// Reading one part of the manifest: errors name the manifest and the JSON path.
struct At {
  const fs::path& file;
  std::string where;
  [[noreturn]] void fail(const std::string& problem) const {
    throw FileError(file, (where.empty() ? "" : where + ": ") + problem);
  }
  At operator[](const std::string& key) const { return {file, where.empty() ? key : where + "." + key}; }
  At operator[](size_t i) const { return {file, where + "[" + std::to_string(i) + "]"}; }
};

std::string needString(const nlohmann::json& j, const At& at) {
  if (!j.is_string() || j.get<std::string>().empty()) at.fail("expected a non-empty string");
  return j.get<std::string>();
}

double needPositive(const nlohmann::json& j, const At& at) {
  if (!j.is_number() || !(j.get<double>() > 0)) at.fail("expected a positive number");
  return j.get<double>();
}

std::vector<uint16_t> needIds(const nlohmann::json& j, const At& at) {
  if (!j.is_array()) at.fail("expected an array of label ids");
  std::vector<uint16_t> ids;
  for (size_t i = 0; i < j.size(); ++i) {
    if (!j[i].is_number_integer() || j[i].get<int64_t>() < 1 || j[i].get<int64_t>() > 65535)
      at[i].fail("expected a label id 1..65535");
    ids.push_back(static_cast<uint16_t>(j[i].get<int64_t>()));
  }
  return ids;
}

std::vector<std::string> needArgs(const nlohmann::json& j, const At& at) {
  if (!j.is_array() || j.empty()) at.fail("expected a non-empty array of arguments (the `vellum` command line)");
  std::vector<std::string> args;
  for (size_t i = 0; i < j.size(); ++i) {
    if (!j[i].is_string()) at[i].fail("expected a string");
    args.push_back(j[i].get<std::string>());
  }
  if (args[0] == "qa") at.fail("a case may not run `vellum qa`");
  return args;
}

fs::path relativeTo(const fs::path& dir, const std::string& p) {
  const fs::path path(p);
  return (path.is_absolute() ? path : dir / path).lexically_normal();
}

QaCheck readCheck(const nlohmann::json& j, const At& at) {
  if (!j.is_object()) at.fail("expected an object");
  static const std::set<std::string> known{"baseline", "output", "reference", "kind", "tolerances", "ids",
                                           "a_ids", "b_ids", "max_seconds", "max_rss_mb"};
  for (auto it = j.begin(); it != j.end(); ++it)
    if (!known.count(it.key())) at.fail("unknown key '" + it.key() + "'");
  QaCheck c;
  const int kinds = int(j.contains("baseline")) + int(j.contains("reference")) + int(j.contains("max_seconds")) +
                    int(j.contains("max_rss_mb"));
  if (kinds != 1) at.fail("a check has exactly one of 'baseline', 'reference', 'max_seconds', 'max_rss_mb'");
  if (j.contains("max_seconds")) {
    c.type = QaCheck::Type::MaxSeconds;
    c.limit = needPositive(j["max_seconds"], at["max_seconds"]);
    return c;
  }
  if (j.contains("max_rss_mb")) {
    c.type = QaCheck::Type::MaxRss;
    c.limit = needPositive(j["max_rss_mb"], at["max_rss_mb"]);
    return c;
  }
  if (j.contains("baseline")) {
    c.type = QaCheck::Type::Baseline;
    c.output = needString(j["baseline"], at["baseline"]);
    if (j.contains("output")) at.fail("'baseline' names the output itself; 'output' is for 'reference' checks");
  } else {
    c.type = QaCheck::Type::Reference;
    if (!j.contains("output")) at.fail("a 'reference' check needs 'output' (the file of the case compared with it)");
    c.output = needString(j["output"], at["output"]);
    c.reference = needString(j["reference"], at["reference"]);
  }
  const fs::path out(c.output);
  if (out.is_absolute() || out.lexically_normal().string().rfind("..", 0) == 0)
    at.fail("'" + c.output + "' must be a path inside the case folder");
  if (j.contains("kind")) {
    try {
      c.kind = parseCompareKind(needString(j["kind"], at["kind"]));
    } catch (const FileError&) {
      throw;
    } catch (const Error& e) {
      at["kind"].fail(e.what());
    }
  }
  if (j.contains("tolerances")) {
    try {
      params::fromJson(compareTolerancesTable(), j["tolerances"], c.tolerances, "tolerances");
    } catch (const Error& e) {
      at.fail(e.what());
    }
  }
  if (j.contains("ids")) c.ids = needIds(j["ids"], at["ids"]);
  if (j.contains("a_ids")) c.aIds = needIds(j["a_ids"], at["a_ids"]);
  if (j.contains("b_ids")) c.bIds = needIds(j["b_ids"], at["b_ids"]);
  return c;
}

// ---- child processes ---------------------------------------------------------------------

struct ChildExit {
  int code = -1;          ///< exit status, or 128 + signal
  double seconds = 0;     ///< wall
  double cpuSeconds = 0;  ///< user + system
  double maxRssMb = 0;    ///< peak resident set (MiB)
  bool timedOut = false;
};

/// Starts `exe args...` in `cwd` with stdout and stderr appended to `log`.
pid_t spawn(const fs::path& exe, const std::vector<std::string>& args, const fs::path& cwd, const fs::path& log) {
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, 1, log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
  posix_spawn_file_actions_adddup2(&fa, 1, 2);
  posix_spawn_file_actions_addclose(&fa, 0);
  posix_spawn_file_actions_addopen(&fa, 0, "/dev/null", O_RDONLY, 0);
  if (!cwd.empty()) posix_spawn_file_actions_addchdir_np(&fa, cwd.c_str());
  std::vector<char*> argv{const_cast<char*>(exe.c_str())};
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, exe.c_str(), &fa, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&fa);
  if (rc != 0) throw FileError(exe, std::string("cannot start: ") + std::strerror(rc));
  return pid;
}

ChildExit exitOf(int status, const rusage& ru, Clock::time_point t0) {
  ChildExit e;
  e.code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  e.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  e.cpuSeconds = double(ru.ru_utime.tv_sec + ru.ru_stime.tv_sec) + 1e-6 * double(ru.ru_utime.tv_usec + ru.ru_stime.tv_usec);
  e.maxRssMb = double(ru.ru_maxrss) / 1024.0;  // kilobytes on Linux
  return e;
}

/// Waits for `pid`; past `timeout` seconds (0: none) it is asked to stop (SIGTERM: Vellum
/// cancels and cleans up), then killed. Ctrl-C here stops it too and throws Cancelled.
ChildExit waitFor(pid_t pid, Clock::time_point t0, double timeout) {
  bool termSent = false;
  Clock::time_point termAt;
  for (;;) {
    int status = 0;
    rusage ru{};
    const pid_t r = ::wait4(pid, &status, WNOHANG, &ru);
    if (r == pid) {
      ChildExit e = exitOf(status, ru, t0);
      e.timedOut = termSent;
      return e;
    }
    if (r < 0 && errno != EINTR) throw Error(std::string("wait4: ") + std::strerror(errno));
    const double elapsed = std::chrono::duration<double>(Clock::now() - t0).count();
    if (Progress::cancelRequestedEverywhere()) {
      ::kill(pid, SIGKILL);
      ::wait4(pid, &status, 0, &ru);
      throw Cancelled();
    }
    if (timeout > 0 && elapsed > timeout && !termSent) {
      ::kill(pid, SIGTERM);
      termSent = true;
      termAt = Clock::now();
    }
    if (termSent && Clock::now() - termAt > std::chrono::seconds(5)) ::kill(pid, SIGKILL);
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
}

std::string substitute(std::string s, const std::map<std::string, std::string>& vars) {
  for (const auto& [key, value] : vars)
    for (size_t p = s.find(key); p != std::string::npos; p = s.find(key, p + value.size())) s.replace(p, key.size(), value);
  return s;
}

std::string joinArgs(const std::vector<std::string>& args) {
  std::string s = "vellum";
  for (const auto& a : args) s += " " + (a.find_first_of(" \t'\"") == std::string::npos ? a : "'" + a + "'");
  return s;
}

std::string tail(const fs::path& log, size_t maxBytes = 2000) {
  std::ifstream f(log, std::ios::binary);
  std::string s((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  return s.size() > maxBytes ? "..." + s.substr(s.size() - maxBytes) : s;
}

/// A picture for the report, at most 320 pixels wide or high.
void saveThumbnail(const RgbaImage& image, const fs::path& path) {
  if (image.width <= 0) return;
  const int side = std::max(image.width, image.height);
  if (side <= 320) return io::saveImage(image, path);
  const double s = 320.0 / side;
  const cv::Mat in(image.height, image.width, CV_8UC4, const_cast<uint8_t*>(image.pixels.data()));
  RgbaImage out(std::max(1, int(image.width * s)), std::max(1, int(image.height * s)));
  cv::Mat dst(out.height, out.width, CV_8UC4, out.pixels.data());
  cv::resize(in, dst, dst.size(), 0, 0, cv::INTER_AREA);
  io::saveImage(out, path);
}

/// Copies a case output (with a detached data file or sidecar) into the baseline store and
/// records who made it beside it.
void storeBaseline(const fs::path& output, const fs::path& baseline, const nlohmann::json& sidecar) {
  const std::vector<fs::path> from = io::filesReadFrom(output);
  std::vector<fs::path> to;
  for (const auto& f : from) to.push_back(baseline.parent_path() / f.filename());
  for (const auto& t : to) io::checkFileOutput(t);  // replaces only a file of its own kind
  fs::create_directories(baseline.parent_path());
  for (size_t i = 0; i < from.size(); ++i) {
    if (!fs::exists(from[i])) continue;
    io::writeAtomically(to[i], [&](const fs::path& tmp) { fs::copy_file(from[i], tmp, fs::copy_options::overwrite_existing); });
  }
  const fs::path side = baseline.string() + ".baseline.json";
  io::checkFileOutput(side, ".json");
  writeJsonFile(sidecar, side);
}

}  // namespace

QaManifest readQaManifest(const fs::path& path) {
  const nlohmann::json j = readJsonFile(path, kMaxManifestBytes, "QA manifest");
  QaManifest m;
  m.path = fs::absolute(path).lexically_normal();
  const fs::path dir = m.path.parent_path();
  const At root{path, ""};
  if (!j.is_object()) root.fail("expected an object with \"cases\"");
  for (auto it = j.begin(); it != j.end(); ++it)
    if (it.key() != "name" && it.key() != "baselines" && it.key() != "cases" && it.key() != "description")
      root.fail("unknown key '" + it.key() + "'");
  m.name = j.contains("name") ? needString(j["name"], root["name"]) : m.path.stem().string();
  m.baselines = relativeTo(dir, j.contains("baselines") ? needString(j["baselines"], root["baselines"]) : "baselines");
  if (!j.contains("cases") || !j["cases"].is_array() || j["cases"].empty()) root["cases"].fail("expected a non-empty array");
  std::set<std::string> names;
  for (size_t i = 0; i < j["cases"].size(); ++i) {
    const nlohmann::json& c = j["cases"][i];
    const At at = root["cases"][i];
    if (!c.is_object()) at.fail("expected an object");
    static const std::set<std::string> known{"name", "scan", "command", "commands", "checks", "timeout_s", "description"};
    for (auto it = c.begin(); it != c.end(); ++it)
      if (!known.count(it.key())) at.fail("unknown key '" + it.key() + "'");
    QaCase q;
    q.name = c.contains("name") ? needString(c["name"], at["name"]) : "";
    if (!validName(q.name)) at["name"].fail("'" + q.name + "' is not a case name (letters, digits, '.', '_', '-')");
    if (!names.insert(q.name).second) at["name"].fail("'" + q.name + "' appears twice");
    if (c.contains("scan")) q.scan = relativeTo(dir, needString(c["scan"], at["scan"]));
    if (c.contains("command") == c.contains("commands")) at.fail("expected one of 'command' or 'commands'");
    if (c.contains("command")) q.commands.push_back(needArgs(c["command"], at["command"]));
    else {
      if (!c["commands"].is_array() || c["commands"].empty()) at["commands"].fail("expected a non-empty array of command lines");
      for (size_t k = 0; k < c["commands"].size(); ++k) q.commands.push_back(needArgs(c["commands"][k], at["commands"][k]));
    }
    if (c.contains("timeout_s")) q.timeoutSeconds = needPositive(c["timeout_s"], at["timeout_s"]);
    if (c.contains("checks")) {
      if (!c["checks"].is_array()) at["checks"].fail("expected an array");
      for (size_t k = 0; k < c["checks"].size(); ++k) q.checks.push_back(readCheck(c["checks"][k], at["checks"][k]));
    }
    m.cases.push_back(std::move(q));
  }
  return m;
}

fs::path qaCaseFolder(const fs::path& out, const std::string& name) { return out / "cases" / name; }

void prepareQaRun(const QaManifest& m, const QaRunOptions& o) {
  io::OutputPlan().input(m.path, "the manifest").folder(o.out, io::FolderKind::Qa, "--out").force(o.force).check();
  io::prepareFolderInPlace(o.out, io::FolderKind::Qa, o.force);
  // The previous run's results: a report must never mix two runs.
  for (const char* old : {"cases", "logs", "workflow", "junit.xml", "report.html", "summary.json"}) fs::remove_all(o.out / old);
  nlohmann::json caseArgs = {m.path.string(), "--out", fs::absolute(o.out).lexically_normal().string()};
  if (!o.baselines.empty()) caseArgs.insert(caseArgs.end(), {"--baselines", fs::absolute(o.baselines).string()});
  if (o.updateBaselines) caseArgs.push_back("--update-baselines");
  nlohmann::json names = nlohmann::json::array();
  for (const auto& c : m.cases) names.push_back(c.name);
  writeJsonFile({{"manifest", m.path.string()},
                 {"name", m.name},
                 {"cases", names},
                 {"case_args", caseArgs},
                 {"baselines", (o.baselines.empty() ? m.baselines : fs::absolute(o.baselines)).string()},
                 {"update_baselines", o.updateBaselines},
                 {"vellum_version", vellumVersion()},
                 {"started_utc", utcNow()}},
                o.out / "qa-run.json");
}

bool runQaCase(const QaManifest& m, const QaCase& c, const QaRunOptions& o) {
  // Normally prepared by the run that started this case; a case run alone (debugging) makes it.
  if (fs::exists(o.out / io::folderMarkerName(io::FolderKind::Qa))) io::checkFolderOutput(o.out, io::FolderKind::Qa);
  else io::prepareFolderInPlace(o.out, io::FolderKind::Qa, o.force);
  const fs::path dir = fs::absolute(qaCaseFolder(o.out, c.name)).lexically_normal();
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path exe = o.vellum.empty() ? fs::read_symlink("/proc/self/exe") : o.vellum;
  const fs::path store = (o.baselines.empty() ? m.baselines : fs::absolute(o.baselines)) / c.name;
  const std::map<std::string, std::string> vars{
      {"{out}", dir.string()}, {"{scan}", c.scan.string()}, {"{manifest_dir}", m.path.parent_path().string()}};
  nlohmann::json result{{"name", c.name}, {"manifest", m.path.string()}, {"vellum_version", vellumVersion()},
                        {"started_utc", utcNow()}};
  std::vector<std::string> failures;
  nlohmann::json commands = nlohmann::json::array();
  std::vector<std::string> commandLines;
  double seconds = 0, peakMb = 0;
  bool commandsOk = true;
  const fs::path log = dir / "log.txt";
  if (!c.scan.empty() && !fs::exists(c.scan)) {  // sample data absent on this machine: a failure that says so
    failures.push_back("scan " + c.scan.string() + " not found");
    commandsOk = false;
  }
  for (const auto& raw : c.commands) {
    if (!commandsOk) break;
    std::vector<std::string> args;
    for (const auto& a : raw) args.push_back(substitute(a, vars));
    commandLines.push_back(joinArgs(args));
    { std::ofstream(log, std::ios::app) << "$ " << commandLines.back() << "\n"; }
    const auto t0 = Clock::now();
    const ChildExit e = waitFor(spawn(exe, args, dir, log), t0, c.timeoutSeconds);
    seconds += e.seconds;
    peakMb = std::max(peakMb, e.maxRssMb);
    commands.push_back({{"command", commandLines.back()}, {"exit_code", e.code}, {"seconds", e.seconds},
                        {"cpu_seconds", e.cpuSeconds}, {"max_rss_mb", e.maxRssMb}, {"timed_out", e.timedOut}});
    if (e.code != 0) {
      failures.push_back(commandLines.back() + (e.timedOut ? ": stopped after the case's timeout" : ": exit code " + std::to_string(e.code)));
      commandsOk = false;
      break;  // later commands depend on this one's outputs
    }
  }
  result["commands"] = commands;
  result["seconds"] = seconds;
  result["max_rss_mb"] = peakMb;
  nlohmann::json checks = nlohmann::json::array();
  for (size_t i = 0; i < c.checks.size(); ++i) {
    const QaCheck& k = c.checks[i];
    nlohmann::json r;
    std::string failure;
    if (k.type == QaCheck::Type::MaxSeconds || k.type == QaCheck::Type::MaxRss) {
      const bool time = k.type == QaCheck::Type::MaxSeconds;
      const double value = time ? seconds : peakMb;
      r = {{"type", time ? "max_seconds" : "max_rss_mb"}, {"limit", k.limit}, {"value", value}};
      if (value > k.limit)
        failure = time ? "took " + std::to_string(value) + " s > " + std::to_string(k.limit) + " s"
                       : "peak memory " + std::to_string(value) + " MiB > " + std::to_string(k.limit) + " MiB";
    } else {
      const bool baseline = k.type == QaCheck::Type::Baseline;
      const fs::path output = dir / k.output;
      const fs::path other = baseline ? store / k.output : relativeTo(m.path.parent_path(), substitute(k.reference, vars));
      r = {{"type", baseline ? "baseline" : "reference"}, {"output", k.output}, {"against", other.string()}};
      // Content fingerprints (run_report.hpp): "byte-identical to the baseline" at a glance.
      if (fs::exists(output)) r["output_fingerprint"] = contentFingerprint(output);
      if (baseline && !o.updateBaselines && fs::is_regular_file(other)) r["baseline_fingerprint"] = contentFingerprint(other);
      if (!commandsOk) {
        failure = k.output + ": not checked (a command failed)";
      } else if (!fs::exists(output)) {
        failure = k.output + ": the case did not write it";
      } else if (baseline && o.updateBaselines) {
        storeBaseline(output, other,
                      {{"case", c.name}, {"manifest", m.path.string()}, {"commands", commandLines},
                       {"vellum_version", vellumVersion()}, {"git_commit", vellumGitCommit()},
                       {"fingerprint", contentFingerprint(output)}, {"written_utc", utcNow()}});
        r["updated"] = true;
      } else if (!fs::exists(other)) {
        failure = k.output + ": " + (baseline ? "no baseline " + other.string() + " (run with --update-baselines)"
                                               : "no reference " + other.string());
      } else {
        try {
          CompareRequest q;
          q.a = output;
          q.b = other;
          q.kind = k.kind;
          q.tolerances = k.tolerances;
          q.ids = k.ids;
          q.aIds = k.aIds;
          q.bIds = k.bIds;
          const CompareResult cr = compareFiles(q);
          r["compare"] = cr.report;
          if (!cr.pass) {
            failure = k.output + ": ";
            for (size_t f = 0; f < cr.failures.size(); ++f) failure += (f ? "; " : "") + cr.failures[f];
          }
          const std::string stem = "check" + std::to_string(i);
          saveThumbnail(cr.pictureA, dir / (stem + "-current.png"));
          saveThumbnail(cr.pictureB, dir / (stem + "-" + (baseline ? "baseline" : "reference") + ".png"));
          saveThumbnail(cr.heatmap, dir / (stem + "-diff.png"));
          if (cr.heatmap.width > 0)
            r["pictures"] = {stem + "-current.png", stem + "-" + (baseline ? "baseline" : "reference") + ".png",
                             stem + "-diff.png"};
        } catch (const Cancelled&) {
          throw;
        } catch (const std::exception& e) {
          failure = k.output + ": " + e.what();
        }
      }
    }
    r["pass"] = failure.empty();
    if (!failure.empty()) {
      r["failure"] = failure;
      failures.push_back(failure);
    }
    checks.push_back(r);
  }
  result["checks"] = checks;
  result["pass"] = failures.empty();
  result["failures"] = failures;
  if (!failures.empty()) result["log_tail"] = tail(log);
  writeJsonFile(result, dir / "result.json");
  return failures.empty();
}

void runQaCases(const QaManifest& m, const QaRunOptions& o) {
  const fs::path exe = o.vellum.empty() ? fs::read_symlink("/proc/self/exe") : o.vellum;
  const nlohmann::json run = readJsonFile(o.out / "qa-run.json", 1 << 20, "QA run file");
  const auto caseArgs = run["case_args"].get<std::vector<std::string>>();
  fs::create_directories(o.out / "logs");
  struct Running {
    std::string name;
    Clock::time_point t0;
  };
  std::map<pid_t, Running> running;
  size_t next = 0;
  auto reap = [&](bool block) {
    int status = 0;
    rusage ru{};
    const pid_t pid = ::wait4(-1, &status, block ? 0 : WNOHANG, &ru);
    if (pid <= 0) return false;
    const auto it = running.find(pid);
    if (it == running.end()) return true;
    const ChildExit e = exitOf(status, ru, it->second.t0);
    const char* verdict = e.code == 0 ? "PASS" : e.code == 1 ? "FAIL" : "ERROR";
    std::cout << verdict << "  " << it->second.name << "  " << std::fixed << std::setprecision(1) << e.seconds << " s";
    if (e.code > 1) std::cout << "  (case runner exit " << e.code << ": " << (o.out / "logs" / (it->second.name + ".txt")).string() << ")";
    std::cout << std::endl;
    running.erase(it);
    return true;
  };
  try {
    while (next < m.cases.size() || !running.empty()) {
      while (next < m.cases.size() && static_cast<int>(running.size()) < std::max(1, o.jobs)) {
        const std::string& name = m.cases[next++].name;
        std::vector<std::string> args{"qa"};
        args.insert(args.end(), caseArgs.begin(), caseArgs.end());
        args.insert(args.end(), {"--case", name});
        const fs::path log = o.out / "logs" / (name + ".txt");
        running[spawn(exe, args, {}, log)] = {name, Clock::now()};
      }
      if (!reap(false)) {
        if (Progress::cancelRequestedEverywhere()) throw Cancelled();
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
      }
    }
  } catch (...) {
    for (const auto& [pid, r] : running) ::kill(pid, SIGTERM);
    while (!running.empty() && reap(true)) {}
    throw;
  }
}

}  // namespace vellum::app
