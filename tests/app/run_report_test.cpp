// The report envelope every command shares (run_report.hpp): fingerprints that change with the
// content and nothing else, and `vellum render --report` naming its inputs and outputs with the
// same fingerprints.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "child_process.hpp"
#include "phantom_files.hpp"
#include "test_data.hpp"
#include "vellum/app/run_report.hpp"
#include "vellum/io/volume_io.hpp"
#include "vellum/phantom/phantom.hpp"

using namespace vellum;
namespace fs = std::filesystem;

namespace {
void write(const fs::path& p, const std::string& text) { std::ofstream(p, std::ios::binary) << text; }
}  // namespace

TEST(RunReport, FingerprintsFollowTheContentOnly) {
  const auto dir = test::tempDir("fingerprint");
  write(dir / "a.bin", "the same bytes");
  write(dir / "b.bin", "the same bytes");
  write(dir / "c.bin", "the same byteS");
  write(dir / "d.bin", "the same bytes ");
  const std::string a = app::contentFingerprint(dir / "a.bin");
  EXPECT_EQ(a.size(), 16u);
  EXPECT_EQ(a, app::contentFingerprint(dir / "b.bin"));
  EXPECT_NE(a, app::contentFingerprint(dir / "c.bin"));
  EXPECT_NE(a, app::contentFingerprint(dir / "d.bin"));
  // A folder: names and contents, whatever the order the files were made in.
  fs::create_directories(dir / "f1");
  fs::create_directories(dir / "f2");
  write(dir / "f1" / "x", "1");
  write(dir / "f1" / "y", "2");
  write(dir / "f2" / "y", "2");
  write(dir / "f2" / "x", "1");
  EXPECT_EQ(app::contentFingerprint(dir / "f1"), app::contentFingerprint(dir / "f2"));
  fs::rename(dir / "f2" / "y", dir / "f2" / "z");
  EXPECT_NE(app::contentFingerprint(dir / "f1"), app::contentFingerprint(dir / "f2"));
  EXPECT_THROW(app::contentFingerprint(dir / "missing"), Error);
}

TEST(RunReport, RenderReportNamesInputsOutputsAndSettings) {
  const auto dir = test::tempDir("render-report");
  phantom::PhantomOptions o;
  o.dims = {32, 32, 32};
  io::saveVolume(phantom::makePhantom(o).ct, dir / "ct.nrrd");
  const fs::path fig = dir / "fig.png", report = dir / "fig.json";
  const int rc = test::Child({"render", (dir / "ct.nrrd").string(), "--out", fig.string(), "--size",
                              "64x64", "--preset", "bone", "--shadows", "0.5", "--report", report.string()},
                             dir / "log.txt")
                     .wait();
  ASSERT_EQ(rc, 0) << test::readAll(dir / "log.txt");
  std::ifstream in(report);
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j["vellum"]["version"], app::vellumVersion());
  EXPECT_EQ(j["vellum"]["report_schema"], 1);
  EXPECT_NE(j["command"].get<std::string>().find("render"), std::string::npos);
  ASSERT_EQ(j["inputs"].size(), 1u);
  EXPECT_EQ(j["inputs"][0]["fingerprint"], app::contentFingerprint(dir / "ct.nrrd"));
  EXPECT_EQ(j["inputs"][0]["dims"], nlohmann::json({32, 32, 32}));
  ASSERT_EQ(j["outputs"].size(), 1u);
  EXPECT_EQ(j["outputs"][0]["path"], fig.string());
  EXPECT_EQ(j["outputs"][0]["fingerprint"], app::contentFingerprint(fig));
  EXPECT_EQ(j["settings"]["shadows"], 0.5);
  EXPECT_EQ(j["settings"]["width"], 64);
  EXPECT_TRUE(j["stage_ms"].contains("load"));
  EXPECT_GT(j["peak_memory_mb"].get<double>(), 1.0);
}

// VELLUM_THREADS (docs/reliability.md): the outputs of one thread and of several are the same
// bytes — the splitting watershed, the light volume, the deformation and its rigid bones.
TEST(RunReport, OutputsAreTheSameBytesForOneAndManyThreads) {
  const auto dir = test::tempDir("threads");
  test::writePhantomFiles(dir, {48, 48, 48});
  const std::string ct = (dir / "ct.nrrd").string();
  auto run = [&](const std::vector<std::string>& args, const char* threads) {
    const int rc = test::Child(args, dir / "log.txt", [threads] { setenv("VELLUM_THREADS", threads, 1); }).wait();
    EXPECT_EQ(rc, 0) << test::readAll(dir / "log.txt");
  };
  // Control points that bend: the upper half of the default points moves 6 mm along x.
  run({"controls", ct, "--out", (dir / "cp0.json").string()}, "1");
  nlohmann::json cp = nlohmann::json::parse(std::ifstream(dir / "cp0.json"));
  for (auto& p : cp["points"])
    if (p["source"][2].get<double>() > 0) p["target"][0] = p["source"][0].get<double>() + 6.0;
  std::ofstream(dir / "cp.json") << cp.dump();
  for (const char* threads : {"1", "2", "4"}) {
    const std::string t = threads;
    run({"segment", ct, "--preset", "whole-bone", "--fill-holes-slices", "--split", "--out",
         (dir / ("bones-" + t + ".nrrd")).string()}, threads);
    run({"render", ct, "--preset", "bone", "--size", "96x96", "--shadows", "1", "--occlusion", "1", "--out",
         (dir / ("lit-" + t + ".png")).string()}, threads);
    run({"deform", ct, "--points", (dir / "cp.json").string(), "--labels", (dir / "labels.nrrd").string(),
         "--rigid-labels", "4+5,6+7,8+11,9+11", "--out", (dir / ("bent-" + t + ".nrrd")).string()}, threads);
  }
  for (const char* name : {"bones", "lit", "bent"}) {
    const std::string ext = std::string(name) == "lit" ? ".png" : ".nrrd";
    const std::string one = test::readAll(dir / (std::string(name) + "-1" + ext));
    ASSERT_FALSE(one.empty()) << name;
    EXPECT_EQ(test::readAll(dir / (std::string(name) + "-2" + ext)), one) << name << " with 2 threads";
    EXPECT_EQ(test::readAll(dir / (std::string(name) + "-4" + ext)), one) << name << " with 4 threads";
  }
}
