// `vellum qa`: a manifest of three small phantom cases run for real (locally and on Snakemake),
// baselines written and then compared, one deliberate regression reported as exactly one
// failure, the JUnit XML parsed back.
#include <gtest/gtest.h>

#include <cstdlib>

#include "child_process.hpp"
#include "test_data.hpp"
#include "vellum/core/json_input.hpp"

using namespace vellum;
namespace fs = std::filesystem;

namespace {

struct Outcome {
  int rc;
  std::string log;
};

Outcome runVellum(const std::vector<std::string>& args, const fs::path& dir) {
  const int rc = test::Child(args, dir / "log.txt").wait();
  Outcome r{rc, test::readAll(dir / "log.txt")};
  fs::remove(dir / "log.txt");
  return r;
}

/// Three phantom cases: the phantom itself (a CT and its labels against the baseline store,
/// time and memory ceilings), a bone threshold (against its baseline and, as a Dice check,
/// against the phantom's cortical truth) and a figure (without GL: the heat map of
/// `vellum compare` between two phantoms). `noise` changes the first case's CT: the
/// deliberate regression.
nlohmann::json manifest(const std::string& noise) {
  const nlohmann::json phantom = {"phantom", "--size", "24", "--noise", "15", "--out", "ct.nrrd", "--labels", "labels.nrrd"};
  nlohmann::json ctPhantom = phantom;
  ctPhantom[4] = noise;
  return {
      {"name", "phantom smoke"},
      {"baselines", "store"},
      {"cases",
       {{{"name", "phantom-ct"},
         {"command", ctPhantom},
         {"checks",
          {{{"baseline", "ct.nrrd"}, {"kind", "volume"}},
           {{"baseline", "labels.nrrd"}},
           {{"max_seconds", 600}},
           {{"max_rss_mb", 8000}}}}},
        {{"name", "bone"},
         {"commands",
          {phantom, {"segment", "ct.nrrd", "--method", "threshold", "--preset", "whole-bone", "--out", "bone.nrrd"}}},
         {"checks",
          {{{"baseline", "bone.nrrd"}, {"tolerances", {{"min_dice", 0.999}}}},
           {{"output", "bone.nrrd"},
            {"reference", "{out}/labels.nrrd"},
            {"a_ids", {1}},
            {"b_ids", {4, 6, 8, 9}},  // the cortical shells: 0.79 at this size
            {"tolerances", {{"min_dice", 0.7}}}}}}},
        {{"name", "figure"},
         {"commands",
          {phantom,
           {"phantom", "--size", "24", "--seed", "2", "--out", "ct2.nrrd"},
           {"compare", "ct.nrrd", "ct2.nrrd", "--heatmap", "slice.png", "--tolerance", "1000000"}}},
         {"checks", {{{"baseline", "slice.png"}, {"tolerances", {{"tolerance", 0}}}}}}}}}};
}

void writeManifest(const nlohmann::json& j, const fs::path& path) {
  std::ofstream(path) << j.dump(2);
}

/// The JUnit XML through Python's XML parser: "tests failures name-of-each-failing-case".
std::string parseJUnit(const fs::path& xml) {
  const fs::path out = xml.parent_path() / "junit-parsed.txt";
  const std::string cmd =
      "python3 -c \"import sys, xml.etree.ElementTree as E; r = E.parse(sys.argv[1]).getroot(); "
      "s = r.find('testsuite'); f = [c.get('name') for c in s.iter('testcase') if c.find('failure') is not None]; "
      "print(s.get('tests'), s.get('failures'), *f)\" '" + xml.string() + "' > '" + out.string() + "'";
  if (std::system(cmd.c_str()) != 0) return "python3 failed";
  std::string s = test::readAll(out);
  fs::remove(out);
  while (!s.empty() && s.back() == '\n') s.pop_back();
  return s;
}

bool haveSnakemake() { return std::system("snakemake --version > /dev/null 2>&1") == 0; }

/// Baselines, then the regression: exactly one failing case (with its diff), both with `extra`
/// arguments (none: the local scheduler; --snakemake: the Snakemake workflow).
void baselinesThenRegression(const fs::path& dir, const std::vector<std::string>& extra) {
  writeManifest(manifest("15"), dir / "qa.json");
  writeManifest(manifest("25"), dir / "qa-regressed.json");
  auto qa = [&](const std::string& m, const std::string& out, std::vector<std::string> more) {
    std::vector<std::string> args{"qa", (dir / m).string(), "--out", (dir / out).string(), "--jobs", "3"};
    args.insert(args.end(), extra.begin(), extra.end());
    args.insert(args.end(), more.begin(), more.end());
    return runVellum(args, dir);
  };
  Outcome r = qa("qa.json", "run1", {"--update-baselines"});
  ASSERT_EQ(r.rc, 0) << r.log;
  for (const char* f : {"phantom-ct/ct.nrrd", "phantom-ct/labels.nrrd", "bone/bone.nrrd", "figure/slice.png"}) {
    EXPECT_TRUE(fs::exists(dir / "store" / f)) << f;
    const nlohmann::json side = readJsonFile(dir / "store" / (std::string(f) + ".baseline.json"), 1 << 20, "sidecar");
    EXPECT_FALSE(side["vellum_version"].get<std::string>().empty());
    EXPECT_NE(side["commands"][0].get<std::string>().find("vellum phantom"), std::string::npos);
    EXPECT_EQ(side["fingerprint"].get<std::string>().size(), 16u);
  }

  r = qa("qa.json", "run2", {});
  EXPECT_EQ(r.rc, 0) << r.log << test::readAll(dir / "run2" / "report.html").substr(0, 4000);
  EXPECT_EQ(parseJUnit(dir / "run2" / "junit.xml"), "3 0");
  // Outputs byte-identical run to run: the same fingerprint as their baselines.
  const nlohmann::json same = readJsonFile(dir / "run2" / "cases" / "bone" / "result.json", 1 << 20, "result");
  EXPECT_EQ(same["checks"][0]["output_fingerprint"], same["checks"][0]["baseline_fingerprint"]) << same["checks"][0].dump(1);

  r = qa("qa-regressed.json", "run3", {});
  EXPECT_EQ(r.rc, 1) << r.log;
  EXPECT_EQ(parseJUnit(dir / "run3" / "junit.xml"), "3 1 phantom-ct");
  const nlohmann::json sum = readJsonFile(dir / "run3" / "summary.json", 1 << 20, "summary");
  EXPECT_EQ(sum["cases"].get<int>(), 3);
  EXPECT_EQ(sum["failures"].get<int>(), 1);
  const nlohmann::json res = readJsonFile(dir / "run3" / "cases" / "phantom-ct" / "result.json", 1 << 20, "result");
  ASSERT_EQ(res["failures"].size(), 1u) << res.dump(2);  // the CT differs, its labels do not
  EXPECT_NE(res["failures"][0].get<std::string>().find("ct.nrrd"), std::string::npos);
  EXPECT_GT(res["checks"][0]["compare"]["volume"]["max_abs_difference"].get<double>(), 0);
  EXPECT_TRUE(res["checks"][1]["pass"].get<bool>());
  EXPECT_TRUE(fs::exists(dir / "run3" / "cases" / "phantom-ct" / "check0-diff.png"));
  const nlohmann::json bone = readJsonFile(dir / "run3" / "cases" / "bone" / "result.json", 1 << 20, "result");
  EXPECT_GT(bone["checks"][1]["compare"]["labels"][0]["dice"].get<double>(), 0.7);
  const std::string html = test::readAll(dir / "run3" / "report.html");
  EXPECT_NE(html.find("2 of 3 cases pass"), std::string::npos);
  // The triptychs (baseline, current, difference) of the four comparisons, embedded.
  size_t pictures = 0;
  for (size_t p = html.find("data:image/png;base64,"); p != std::string::npos; p = html.find("data:image/png;base64,", p + 1))
    ++pictures;
  EXPECT_EQ(pictures, 3u * 5u);
  EXPECT_EQ(html.find("src=\"http"), std::string::npos);  // self-contained
}

}  // namespace

TEST(Qa, BaselinesThenOneRegressionLocally) {
  baselinesThenRegression(test::tempDir("qa-local"), {});
}

TEST(Qa, SnakemakeRunsTheSameManifest) {
  if (!haveSnakemake()) GTEST_SKIP() << "snakemake not found (Debian package snakemake): the Snakemake path is not tested";
  const fs::path dir = test::tempDir("qa-snakemake");
  ::setenv("XDG_CACHE_HOME", (dir / "cache").c_str(), 1);  // Snakemake's cache stays in the test's folder
  baselinesThenRegression(dir, {"--snakemake"});
  ::unsetenv("XDG_CACHE_HOME");
}

TEST(Qa, AFailingCommandFailsOnlyItsCase) {
  const fs::path dir = test::tempDir("qa-failing");
  writeManifest({{"cases",
                  {{{"name", "ok"}, {"command", {"phantom", "--size", "16", "--out", "ct.nrrd"}}},
                   {{"name", "broken"}, {"command", {"info", "{manifest_dir}/missing.nrrd"}}},
                   {{"name", "missing-output"},
                    {"command", {"phantom", "--size", "16", "--out", "ct.nrrd"}},
                    {"checks", {{{"baseline", "other.nrrd"}}}}},
                   {{"name", "slow"}, {"timeout_s", 0.3}, {"command", {"phantom", "--size", "320", "--out", "ct.nrrd"}}},
                   {{"name", "no-scan"}, {"scan", "absent/ct.nrrd"}, {"command", {"info", "{scan}"}}}}}},
                dir / "qa.json");
  const Outcome r = runVellum({"qa", (dir / "qa.json").string(), "--out", (dir / "run").string(), "--jobs", "2"}, dir);
  EXPECT_EQ(r.rc, 1) << r.log;
  EXPECT_EQ(parseJUnit(dir / "run" / "junit.xml"), "5 4 broken missing-output slow no-scan");
  const nlohmann::json slow = readJsonFile(dir / "run" / "cases" / "slow" / "result.json", 1 << 20, "result");
  EXPECT_NE(slow["failures"][0].get<std::string>().find("timeout"), std::string::npos) << slow.dump(2);
  EXPECT_TRUE(slow["commands"][0]["timed_out"].get<bool>());
  EXPECT_FALSE(fs::exists(dir / "run" / "cases" / "slow" / "ct.nrrd"));  // cancelled: nothing half-written
  const nlohmann::json noScan = readJsonFile(dir / "run" / "cases" / "no-scan" / "result.json", 1 << 20, "result");
  EXPECT_NE(noScan["failures"][0].get<std::string>().find("not found"), std::string::npos) << noScan.dump(2);
  const nlohmann::json broken = readJsonFile(dir / "run" / "cases" / "broken" / "result.json", 1 << 20, "result");
  EXPECT_NE(broken["failures"][0].get<std::string>().find("exit code 2"), std::string::npos);
  EXPECT_NE(broken["log_tail"].get<std::string>().find("missing.nrrd"), std::string::npos);
}

TEST(Qa, ManifestErrorsExitTwoWithOneLine) {
  const fs::path dir = test::tempDir("qa-manifest");
  const std::vector<std::pair<nlohmann::json, std::string>> bad{
      {{{"cases", {{{"name", "a"}, {"command", {"info", "x"}}, {"chekcs", nlohmann::json::array()}}}}},
       "cases[0]: unknown key 'chekcs'"},
      {{{"cases", {{{"name", "a b"}, {"command", {"info", "x"}}}}}}, "cases[0].name"},
      {{{"cases", {{{"name", "a"}, {"command", {"info", "x"}}, {"checks", {{{"baseline", "x.nrrd"}, {"tolerances", {{"min_dice", 2}}}}}}}}}},
       "cases[0].checks[0]: tolerances: min_dice"},
      {{{"cases", {{{"name", "a"}, {"command", {"info", "x"}}}, {{"name", "a"}, {"command", {"info", "y"}}}}}}, "appears twice"},
  };
  for (const auto& [j, expected] : bad) {
    writeManifest(j, dir / "bad.json");
    const Outcome r = runVellum({"qa", (dir / "bad.json").string(), "--out", (dir / "run").string()}, dir);
    EXPECT_EQ(r.rc, 2) << r.log;
    EXPECT_NE(r.log.find(expected), std::string::npos) << r.log;
    EXPECT_NE(r.log.find("bad.json"), std::string::npos) << r.log;
    EXPECT_EQ(std::count(r.log.begin(), r.log.end(), '\n'), 1) << r.log;
    EXPECT_FALSE(fs::exists(dir / "run")) << "nothing is written for a bad manifest";
  }
  // A run folder that Vellum did not write is refused.
  fs::create_directories(dir / "mine");
  std::ofstream(dir / "mine" / "notes.txt") << "keep";
  writeManifest({{"cases", {{{"name", "a"}, {"command", {"phantom", "--size", "16", "--out", "ct.nrrd"}}}}}}, dir / "ok.json");
  const Outcome r = runVellum({"qa", (dir / "ok.json").string(), "--out", (dir / "mine").string()}, dir);
  EXPECT_EQ(r.rc, 2) << r.log;
  EXPECT_EQ(test::readAll(dir / "mine" / "notes.txt"), "keep");
}
