// Issue 19: everyday slips on the command line never destroy data. Each case runs the real
// `vellum` binary and asserts that everything that was on disk survives byte for byte, and
// that the refusal is one line naming the output.
#include <gtest/gtest.h>

#include <sys/resource.h>

#include <map>

#include "child_process.hpp"
#include "test_data.hpp"
#include "vellum/io/output_policy.hpp"
#include "vellum/io/volume_io.hpp"
#include "vellum/phantom/phantom.hpp"

using namespace vellum;
namespace fs = std::filesystem;

namespace {

using test::readAll;

/// Every regular file below `dir` with its bytes.
std::map<fs::path, std::string> snapshot(const fs::path& dir) {
  std::map<fs::path, std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file()) files[e.path()] = readAll(e.path());
  return files;
}

struct Result {
  int rc;
  std::string err;
};

Result runVellum(const fs::path& dir, const std::vector<std::string>& args,
              const std::function<void()>& beforeExec = {}) {
  const int rc = test::Child(args, dir / "log.txt", beforeExec).wait();
  Result r{rc, readAll(dir / "log.txt")};
  fs::remove(dir / "log.txt");
  return r;
}

void writeCt(const fs::path& path, int size = 32) {
  phantom::PhantomOptions o;
  o.dims = {size, size, size};
  io::saveVolume(phantom::makePhantom(o).ct, path);
}

/// A refusal: exit 1, one line that names `what`, and the folder exactly as before.
void expectRefused(const Result& r, const std::string& what, const std::map<fs::path, std::string>& before,
                   const fs::path& dir) {
  EXPECT_EQ(r.rc, 1) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_NE(r.err.find(what), std::string::npos) << r.err;
  EXPECT_EQ(snapshot(dir), before);
}

}  // namespace

TEST(OutputPolicyCli, AnOutputFolderNeverReplacesTheUsersFolder) {
  const auto dir = test::tempDir("policy-folder");
  fs::create_directories(dir / "proj" / "data");
  writeCt(dir / "proj" / "data" / "ct.nrrd");
  std::ofstream(dir / "proj" / "data" / "notes.txt") << "my notes";
  fs::create_directories(dir / "results");
  std::ofstream(dir / "results" / "notes.txt") << "results notes";
  auto before = snapshot(dir);
  const std::string ct = (dir / "proj" / "data" / "ct.nrrd").string();
  // The folder holding the input itself, and a folder of the user's.
  expectRefused(runVellum(dir, {"convert", ct, (dir / "proj" / "data").string()}), (dir / "proj" / "data").string(), before, dir);
  expectRefused(runVellum(dir, {"segment", ct, "--preset", "bone", "--out", (dir / "results").string()}),
                (dir / "results").string(), before, dir);
  expectRefused(runVellum(dir, {"convert", ct, (dir / "results").string(), "--force"}), "Vellum did not write", before, dir);
  // A new folder is written and marked; the next run replaces it; a folder of another kind
  // needs --force.
  EXPECT_EQ(runVellum(dir, {"convert", ct, (dir / "series").string()}).rc, 0);
  EXPECT_TRUE(fs::exists(dir / "series" / io::folderMarkerName(io::FolderKind::DicomSeries)));
  EXPECT_EQ(runVellum(dir, {"convert", ct, (dir / "series").string()}).rc, 0);
  fs::create_directories(dir / "frames");
  std::ofstream(dir / "frames" / io::folderMarkerName(io::FolderKind::Frames)) << "";
  std::ofstream(dir / "frames" / "frame-00000.png") << "png";
  before = snapshot(dir);
  expectRefused(runVellum(dir, {"convert", ct, (dir / "frames").string()}), "--force", before, dir);
  EXPECT_EQ(runVellum(dir, {"convert", ct, (dir / "frames").string(), "--force"}).rc, 0);
  EXPECT_FALSE(fs::exists(dir / "frames" / "frame-00000.png"));
  EXPECT_EQ(io::loadVolume(dir / "frames").format, "dicom");  // the marker is not read as a slice
}

TEST(OutputPolicyCli, ADetachedDataFileNeverOverwritesTheInput) {
  const auto dir = test::tempDir("policy-detached");
  std::string voxels(32 * 32 * 32 * 2, '\0');
  for (size_t i = 0; i < voxels.size(); ++i) voxels[i] = char(i * 7);
  std::ofstream(dir / "scan.raw", std::ios::binary) << voxels;
  const auto before = snapshot(dir);
  const std::string raw = (dir / "scan.raw").string();
  const std::vector<std::string> layout{"--raw-dims", "32", "32", "32"};
  auto with = [&](std::vector<std::string> args) {
    args.insert(args.end(), layout.begin(), layout.end());
    return args;
  };
  expectRefused(runVellum(dir, with({"convert", raw, (dir / "scan.mhd").string(), "--downsample", "2"})), "scan.raw",
                before, dir);
  expectRefused(runVellum(dir, with({"convert", raw, (dir / "scan.nhdr").string(), "--no-gzip"})), "scan.raw", before,
                dir);
  // p.mhd's data file p.raw is part of the input p.mhd.
  ASSERT_EQ(runVellum(dir, with({"convert", raw, (dir / "p.mhd").string()})).rc, 0);
  const auto withMhd = snapshot(dir);
  expectRefused(runVellum(dir, {"convert", (dir / "p.mhd").string(), (dir / "p.raw").string(), "--crop", "0", "15", "0",
                             "15", "0", "15"}),
                "p.raw", withMhd, dir);
  EXPECT_EQ(readAll(dir / "scan.raw"), voxels);
}

TEST(OutputPolicyCli, NoFlagsInputIsEverAnOutput) {
  const auto dir = test::tempDir("policy-flags");
  writeCt(dir / "ct.nrrd");
  ASSERT_EQ(runVellum(dir, {"segment", (dir / "ct.nrrd").string(), "--preset", "bone", "--out",
                         (dir / "truth.nrrd").string()}).rc, 0);
  const auto before = snapshot(dir);
  const std::string ct = (dir / "ct.nrrd").string(), truth = (dir / "truth.nrrd").string();
  expectRefused(runVellum(dir, {"segment", ct, "--preset", "bone", "--truth", truth, "--out", truth}), "--truth", before, dir);
  expectRefused(runVellum(dir, {"segment", ct, "--preset", "bone", "--into", truth, "--out", truth}), "--into", before, dir);
  expectRefused(runVellum(dir, {"segment", ct, "--preset", "bone", "--out", (dir / "s.nrrd").string(), "--report", truth}),
                "is not a json file", before, dir);  // a report never replaces a volume
  expectRefused(runVellum(dir, {"controls", ct, "--from-labels", truth, "--out", truth}), "--from-labels", before, dir);
  fs::create_symlink(dir / "truth.nrrd", dir / "alias.nrrd");
  const auto withLink = snapshot(dir);
  expectRefused(runVellum(dir, {"segment", ct, "--preset", "bone", "--truth", truth, "--out", (dir / "alias.nrrd").string()}),
                "--truth", withLink, dir);
}

TEST(OutputPolicyCli, EveryWriterRefusesToReplaceAFolderOrAnotherKindOfFile) {
  const auto dir = test::tempDir("policy-writers");
  writeCt(dir / "ct.nrrd");
  const std::string ct = (dir / "ct.nrrd").string();
  // A folder of the user's under each output name, and a text file under a figure's name.
  for (const char* name : {"o.nrrd", "o.nhdr", "o.mhd", "o.vti", "o.png", "o.tif", "m.mp4", "o.nii", "frames", "shape"}) {
    fs::create_directories(dir / name);
    std::ofstream(dir / name / "keep.txt") << name;
  }
  std::ofstream(dir / "fig.png") << "a drawing that is not a PNG";
  std::ofstream(dir / "film.mp4") << "notes";
  const auto before = snapshot(dir);
  for (const char* name : {"o.nrrd", "o.nhdr", "o.mhd", "o.vti", "o.nii"})
    expectRefused(runVellum(dir, {"convert", ct, (dir / name).string()}), (dir / name).string(), before, dir);
  for (const char* name : {"o.png", "o.tif", "fig.png"})
    expectRefused(runVellum(dir, {"render", ct, "--size", "32x32", "--out", (dir / name).string()}), (dir / name).string(),
                  before, dir);
  for (const char* name : {"m.mp4", "film.mp4", "frames"})
    expectRefused(runVellum(dir, {"animate", ct, "--keyframes", (dir / "k.json").string(), "--out", (dir / name).string()}),
                  (dir / name).string(), before, dir);
  expectRefused(runVellum(dir, {"shape", ct, "--labels", ct, "--segment", "a=1", "--out", (dir / "shape").string()}),
                (dir / "shape").string(), before, dir);
}

TEST(OutputPolicyCli, AReportThatCannotBeWrittenLeavesNoResult) {
  const auto dir = test::tempDir("policy-report");
  writeCt(dir / "ct.nrrd");
  std::ofstream(dir / "afile") << "x";  // a file where the report's folder should be
  const Result r = runVellum(dir, {"segment", (dir / "ct.nrrd").string(), "--preset", "bone", "--out",
                                (dir / "seg.nrrd").string(), "--report", (dir / "afile" / "r.json").string()});
  EXPECT_EQ(r.rc, 1) << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_FALSE(fs::exists(dir / "seg.nrrd"));
}

// The same failure when the output replaced an earlier result: the earlier result comes back
// byte for byte (the run's journal of replaced files), for a volume and for a label map.
TEST(OutputPolicyCli, AFailedRunPutsBackTheResultItReplaced) {
  const auto dir = test::tempDir("policy-restore");
  writeCt(dir / "ct.nrrd");
  std::ofstream(dir / "afile") << "x";
  const std::string bad = (dir / "afile" / "r.json").string();
  for (const std::vector<std::string>& cmd :
       {std::vector<std::string>{"convert", (dir / "ct.nrrd").string(), (dir / "out.nrrd").string(), "--downsample", "2"},
        std::vector<std::string>{"segment", (dir / "ct.nrrd").string(), "--preset", "bone", "--out", (dir / "seg.nrrd").string()}}) {
    ASSERT_EQ(runVellum(dir, cmd).rc, 0);
    const auto before = snapshot(dir);
    std::vector<std::string> again = cmd;
    if (again.front() == "convert") again.pop_back(), again.pop_back();  // a different result: full size
    again.insert(again.end(), {"--report", bad});
    const Result r = runVellum(dir, again);
    EXPECT_EQ(r.rc, 1) << r.err;
    EXPECT_EQ(snapshot(dir), before) << again.front() << ": " << r.err;  // old result back, no hidden copies
  }
}

TEST(OutputPolicyCli, DiskFullWhileWritingADicomSeriesIsAOneLineError) {
  const auto dir = test::tempDir("policy-dicom-full");
  writeCt(dir / "ct.nrrd", 48);
  const Result r = runVellum(dir, {"convert", (dir / "ct.nrrd").string(), (dir / "series").string()}, [] {
    rlimit lim{2048, 2048};  // every slice file past 2 KiB fails, as on a full disk
    ::setrlimit(RLIMIT_FSIZE, &lim);
  });
  EXPECT_EQ(r.rc, 1) << r.err;  // not an abort on a GDCM assertion, not SIGXFSZ
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_NE(r.err.find((dir / "series").string()), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find(".vellum-tmp"), std::string::npos) << r.err;  // the target, not the temporary
  EXPECT_FALSE(fs::exists(dir / "series"));
  for (const auto& e : fs::directory_iterator(dir))
    EXPECT_EQ(e.path().filename().string().rfind(".vellum-", 0), std::string::npos) << e.path();
}
