// The command contract's exit codes (ui/cli/main.cpp decides them in one place): 2 for a usage
// or input error, 1 for a runtime failure, each with one line on stderr naming the problem;
// and the one colour syntax (--colour in 0..1, the old --color spelling in 0..255).
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>

#include "child_process.hpp"
#include "test_data.hpp"
#include "vellum/io/volume_io.hpp"

using namespace vellum;
namespace fs = std::filesystem;

namespace {

struct CliRun {
  int rc;
  std::string out;  ///< stdout and stderr together
};

CliRun runCli(const fs::path& dir, const std::vector<std::string>& args) {
  const int rc = test::Child(args, dir / "log.txt").wait();
  return {rc, test::readAll(dir / "log.txt")};
}

bool oneErrorLineNaming(const CliRun& r, const std::string& what) {
  return std::count(r.out.begin(), r.out.end(), '\n') == 1 && r.out.rfind("vellum: error: ", 0) == 0 &&
         r.out.find(what) != std::string::npos;
}

}  // namespace

TEST(CliExitCodes, UsageAndInputErrorsExitTwoRuntimeFailuresOne) {
  const fs::path dir = test::tempDir("exit_codes");
  const std::string ct = (dir / "ct.nrrd").string();
  ASSERT_EQ(runCli(dir, {"phantom", "--size", "16", "--out", ct}).rc, 0);

  const CliRun flag = runCli(dir, {"info", ct, "--bogus"});
  EXPECT_EQ(flag.rc, 2);
  EXPECT_TRUE(oneErrorLineNaming(flag, "--bogus")) << flag.out;

  const std::string missing = (dir / "missing.nrrd").string();
  const CliRun file = runCli(dir, {"info", missing});
  EXPECT_EQ(file.rc, 2);
  EXPECT_TRUE(oneErrorLineNaming(file, missing)) << file.out;

  std::ofstream(dir / "bad.nrrd") << "not a volume\n";
  const CliRun bad = runCli(dir, {"info", (dir / "bad.nrrd").string()});
  EXPECT_EQ(bad.rc, 2);
  EXPECT_TRUE(oneErrorLineNaming(bad, "bad.nrrd")) << bad.out;

  const CliRun value = runCli(dir, {"segment", ct, "--out", (dir / "s.nrrd").string(), "--colour", "2,0,0"});
  EXPECT_EQ(value.rc, 2);
  EXPECT_TRUE(oneErrorLineNaming(value, "--colour")) << value.out;

  // An output that cannot be written (its folder is a file) is a runtime failure.
  std::ofstream(dir / "file") << "x";
  const CliRun write = runCli(dir, {"convert", ct, (dir / "file" / "out.nrrd").string()});
  EXPECT_EQ(write.rc, 1) << write.out;
  EXPECT_NE(write.out.find("out.nrrd"), std::string::npos) << write.out;
}

TEST(CliColour, BritishSpellingInZeroToOneAndTheOldSpellingInBytesGiveOneColour) {
  const fs::path dir = test::tempDir("colour_syntax");
  const std::string ct = (dir / "ct.nrrd").string();
  ASSERT_EQ(runCli(dir, {"phantom", "--size", "16", "--out", ct}).rc, 0);
  const auto segment = [&](const std::string& flag, const std::string& value, const std::string& out) {
    return runCli(dir, {"segment", ct, "--method", "threshold", "--lower", "200", "--upper", "3000", "--out",
                        (dir / out).string(), flag, value})
        .rc;
  };
  ASSERT_EQ(segment("--colour", "1,0.5,0", "new.nrrd"), 0);
  ASSERT_EQ(segment("--color", "255,128,0", "old.nrrd"), 0);
  for (const char* name : {"new.nrrd", "old.nrrd"}) {
    const LabelVolume labels = io::loadLabels(dir / name);
    ASSERT_EQ(labels.table().size(), 1u) << name;
    const Label& l = labels.table().front();
    EXPECT_EQ(l.rgb[0], 255) << name;
    EXPECT_EQ(l.rgb[1], 128) << name;
    EXPECT_EQ(l.rgb[2], 0) << name;
  }
}
