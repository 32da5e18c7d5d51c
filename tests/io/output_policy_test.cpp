// The output policy (vellum/io/output_policy.hpp): what an output may replace, and which
// inputs it may never touch.
#include <gtest/gtest.h>

#include <unistd.h>

#include "io_test_util.hpp"
#include "vellum/core/error.hpp"
#include "vellum/io/output_policy.hpp"

using namespace vellum;
using namespace vellum::test;
namespace fs = std::filesystem;

namespace {

/// The FileError message check() throws, or "" when it passes.
std::string refusal(const io::OutputPlan& plan) {
  try {
    plan.check();
  } catch (const FileError& e) {
    return e.what();
  }
  return {};
}

}  // namespace

TEST(OutputPolicy, AFolderVellumDidNotWriteIsNeverReplaced) {
  const fs::path dir = tempDir("policy-foreign");
  fs::create_directories(dir / "data");
  writeFile(dir / "data" / "notes.txt", "mine");
  const std::string why = refusal(io::OutputPlan().folder(dir / "data", io::FolderKind::DicomSeries));
  EXPECT_NE(why.find((dir / "data").string()), std::string::npos) << why;
  EXPECT_NE(why.find("Vellum did not write"), std::string::npos) << why;
  // --force does not change that.
  EXPECT_FALSE(refusal(io::OutputPlan().folder(dir / "data", io::FolderKind::DicomSeries).force(true)).empty());
  EXPECT_THROW(io::writeFolderAtomically(dir / "data", io::FolderKind::DicomSeries,
                                         [](const fs::path& t) { writeFile(t / "a.dcm", "x"); }, true),
               FileError);
  EXPECT_EQ(readFile(dir / "data" / "notes.txt"), "mine");
  EXPECT_EQ(leftoverTemps(dir), 0);
}

TEST(OutputPolicy, VellumFoldersAreReplacedByTheirKindAndOtherKindsOnlyWithForce) {
  const fs::path dir = tempDir("policy-kinds");
  EXPECT_TRUE(refusal(io::OutputPlan().folder(dir / "new", io::FolderKind::Shape)).empty());  // missing: fine
  fs::create_directories(dir / "empty");
  EXPECT_TRUE(refusal(io::OutputPlan().folder(dir / "empty", io::FolderKind::Shape)).empty());  // empty: fine
  io::writeFolderAtomically(dir / "shape", io::FolderKind::Shape, [](const fs::path& t) { writeFile(t / "a", "1"); });
  EXPECT_TRUE(refusal(io::OutputPlan().folder(dir / "shape", io::FolderKind::Shape)).empty());
  const std::string why = refusal(io::OutputPlan().folder(dir / "shape", io::FolderKind::DicomSeries));
  EXPECT_NE(why.find("holds a Vellum shape folder"), std::string::npos) << why;
  EXPECT_NE(why.find("--force"), std::string::npos) << why;
  EXPECT_TRUE(refusal(io::OutputPlan().folder(dir / "shape", io::FolderKind::DicomSeries).force(true)).empty());
  // A file in the folder's place is not replaced by a folder.
  writeFile(dir / "file", "f");
  EXPECT_NE(refusal(io::OutputPlan().folder(dir / "file", io::FolderKind::Frames)).find("not a folder"),
            std::string::npos);
}

TEST(OutputPolicy, AnOutputPathWithoutExtensionIsADicomFolder) {
  const fs::path dir = tempDir("policy-noext");
  fs::create_directories(dir / "results");
  writeFile(dir / "results" / "notes.txt", "keep");
  EXPECT_NE(refusal(io::OutputPlan().output(dir / "results")).find("Vellum did not write"), std::string::npos);
}

TEST(OutputPolicy, NoOutputIsOrContainsOrSharesADataFileWithAnInput) {
  const fs::path dir = tempDir("policy-inputs");
  writeFile(dir / "scan.raw", std::string(64, 'x'));
  // scan.mhd would write its data to scan.raw, the input.
  std::string why = refusal(io::OutputPlan().input(dir / "scan.raw").output(dir / "scan.mhd"));
  EXPECT_NE(why.find("scan.raw"), std::string::npos) << why;
  EXPECT_NE(why.find("refusing to overwrite an input"), std::string::npos) << why;
  // .nhdr --no-gzip: the data file is scan.raw too; gzip writes scan.raw.gz, which is fine.
  EXPECT_FALSE(refusal(io::OutputPlan().input(dir / "scan.raw").output(dir / "scan.nhdr", "out", false)).empty());
  EXPECT_TRUE(refusal(io::OutputPlan().input(dir / "scan.raw").output(dir / "scan.nhdr", "out", true)).empty());
  // An input's detached data file (p.mhd -> p.raw) is part of the input.
  writeFile(dir / "p.mhd", "ObjectType = Image\nNDims = 3\nElementDataFile = p.raw\n");
  writeFile(dir / "p.raw", "d");
  why = refusal(io::OutputPlan().input(dir / "p.mhd").output(dir / "p.raw"));
  EXPECT_NE(why.find("refusing to overwrite an input"), std::string::npos) << why;
  // A reference mask given under another flag.
  writeFile(dir / "truth.nrrd", "NRRD0004\n");
  why = refusal(io::OutputPlan().input(dir / "ct.nrrd").input(dir / "truth.nrrd", "the --truth label map")
                    .output(dir / "truth.nrrd", "--out"));
  EXPECT_NE(why.find("--truth"), std::string::npos) << why;
  // Through a symlink and a hard link.
  fs::create_symlink(dir / "truth.nrrd", dir / "link.nrrd");
  EXPECT_FALSE(refusal(io::OutputPlan().input(dir / "truth.nrrd").output(dir / "link.nrrd")).empty());
  fs::create_hard_link(dir / "truth.nrrd", dir / "hard.nrrd");
  EXPECT_FALSE(refusal(io::OutputPlan().input(dir / "truth.nrrd").output(dir / "hard.nrrd")).empty());
  // A folder output that holds an input.
  why = refusal(io::OutputPlan().input(dir / "truth.nrrd").folder(dir, io::FolderKind::DicomSeries));
  EXPECT_FALSE(why.empty());
  // Two outputs onto one file.
  why = refusal(io::OutputPlan().output(dir / "a.nrrd", "--out").output(dir / "a.nrrd", "--map-out"));
  EXPECT_NE(why.find("overwrite each other"), std::string::npos) << why;
}

TEST(OutputPolicy, AFileIsReplacedOnlyByItsOwnKind) {
  const fs::path dir = tempDir("policy-kind");
  writeFile(dir / "notes.nrrd", "these are my notes, not a volume");
  EXPECT_NE(refusal(io::OutputPlan().output(dir / "notes.nrrd")).find("is not a nrrd file"), std::string::npos);
  writeFile(dir / "old.nrrd", "NRRD0004\ntype: short\n");
  EXPECT_TRUE(refusal(io::OutputPlan().output(dir / "old.nrrd")).empty());
  writeFile(dir / "fig.png", "\x89PNG\r\n");
  EXPECT_TRUE(refusal(io::OutputPlan().output(dir / "fig.png")).empty());
  writeFile(dir / "movie.mp4", "not a movie");
  EXPECT_FALSE(refusal(io::OutputPlan().output(dir / "movie.mp4")).empty());
  fs::create_directories(dir / "dir.nrrd");
  EXPECT_NE(refusal(io::OutputPlan().output(dir / "dir.nrrd")).find("is a folder"), std::string::npos);
  // A bare RAW without a sidecar is somebody's data.
  writeFile(dir / "bare.raw", "raw bytes");
  EXPECT_FALSE(refusal(io::OutputPlan().output(dir / "bare.raw")).empty());
  // A data file beside a new header that the header does not own.
  writeFile(dir / "vol.raw", "someone's raw");
  writeFile(dir / "vol.raw.json", "{}");
  const std::string why = refusal(io::OutputPlan().output(dir / "vol.mhd"));
  EXPECT_NE(why.find("not vol.mhd's own"), std::string::npos) << why;
  // ...but the header's own data file is replaced with it.
  writeFile(dir / "own.mhd", "ObjectType = Image\nNDims = 3\nElementDataFile = own.raw\n");
  writeFile(dir / "own.raw", "old data");
  EXPECT_TRUE(refusal(io::OutputPlan().output(dir / "own.mhd")).empty());
}

TEST(OutputPolicy, FilesOfAVolumeOnDisk) {
  const fs::path dir = tempDir("policy-files");
  EXPECT_EQ(io::filesWrittenTo(dir / "a.nhdr", true), (std::vector<fs::path>{dir / "a.nhdr", dir / "a.raw.gz"}));
  EXPECT_EQ(io::filesWrittenTo(dir / "a.nhdr", false), (std::vector<fs::path>{dir / "a.nhdr", dir / "a.raw"}));
  EXPECT_EQ(io::filesWrittenTo(dir / "a.mhd"), (std::vector<fs::path>{dir / "a.mhd", dir / "a.raw"}));
  EXPECT_EQ(io::filesWrittenTo(dir / "a.raw"), (std::vector<fs::path>{dir / "a.raw", dir / "a.raw.json"}));
  writeFile(dir / "h.nhdr", "NRRD0004\ntype: short\ndata file: ../elsewhere/h.raw\n\n");
  EXPECT_EQ(io::filesReadFrom(dir / "h.nhdr"), (std::vector<fs::path>{dir / "h.nhdr", dir / "../elsewhere/h.raw"}));
}

TEST(OutputPolicy, PreparingAFolderInPlaceMarksIt) {
  const fs::path dir = tempDir("policy-inplace");
  io::prepareFolderInPlace(dir / "demo", io::FolderKind::Demo);
  EXPECT_TRUE(fs::exists(dir / "demo" / ".vellum-demo"));
  writeFile(dir / "demo" / "fig.png", "x");
  io::prepareFolderInPlace(dir / "demo", io::FolderKind::Demo);  // again: its own folder
  EXPECT_THROW(io::prepareFolderInPlace(dir / "demo", io::FolderKind::Shape), FileError);
  io::prepareFolderInPlace(dir / "demo", io::FolderKind::Shape, true);
  EXPECT_TRUE(fs::exists(dir / "demo" / ".vellum-shape"));
  EXPECT_FALSE(fs::exists(dir / "demo" / ".vellum-demo"));
}
