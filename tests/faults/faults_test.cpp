// Faults while writing, through the real `vellum` executable in a child process: an output
// that already exists survives a failed write intact, interrupted commands leave no
// temporary files, a DICOM series is complete or absent, and inputs are never modified.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <sched.h>
#include <signal.h>
#include <sys/mount.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>
#include <thread>

#include "child_process.hpp"
#include "phantom_files.hpp"
#include "test_data.hpp"
#include "vellum/io/volume_io.hpp"
#include "vellum/phantom/phantom.hpp"

using namespace vellum;
namespace fs = std::filesystem;

namespace {

using test::Child;
using test::readAll;

int run(const std::vector<std::string>& args, const fs::path& errFile,
        const std::function<void()>& beforeExec = {}) {
  return Child(args, errFile, beforeExec).wait();
}

/// Vellum's temporary siblings (".vellum-tmp-*", ".vellum-old-*") anywhere below `dir`.
int leftoverTemps(const fs::path& dir) {
  int n = 0;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.path().filename().string().rfind(".vellum-tmp-", 0) == 0 ||
        e.path().filename().string().rfind(".vellum-old-", 0) == 0)
      ++n;
  return n;
}

/// A phantom CT + labels written once per test into `dir`.
void writePhantom(const fs::path& dir, int size) {
  test::writePhantomFiles(dir, {size, size, size}, "knee.nrrd");
}

}  // namespace

TEST(Faults, DiskFullKeepsTheExistingOutputIntact) {
  const auto dir = test::tempDir("fault-fsize");
  writePhantom(dir, 48);
  // An earlier NRRD (the output policy lets only a NRRD replace a NRRD).
  const std::string old = "NRRD0004\n# an earlier result that must survive\n";
  std::ofstream(dir / "out.nrrd") << old;
  // RLIMIT_FSIZE makes every write past 64 KiB fail with EFBIG, as a full disk would.
  const int rc = run({"convert", (dir / "knee.nrrd").string(), (dir / "out.nrrd").string(), "--no-gzip"},
                     dir / "err.txt", [] {
                       ::signal(SIGXFSZ, SIG_IGN);
                       rlimit lim{64 * 1024, 64 * 1024};
                       ::setrlimit(RLIMIT_FSIZE, &lim);
                     });
  const std::string err = readAll(dir / "err.txt");
  EXPECT_EQ(rc, 1) << err;
  EXPECT_NE(err.find("out.nrrd"), std::string::npos) << err;  // names the file
  EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;  // one line
  EXPECT_EQ(readAll(dir / "out.nrrd"), old);
  EXPECT_EQ(leftoverTemps(dir), 0);
}

TEST(Faults, ReadOnlyFolderIsAOneLineErrorAndChangesNothing) {
  const auto dir = test::tempDir("fault-ro");
  writePhantom(dir, 32);
  fs::create_directories(dir / "ro");
  std::ofstream(dir / "ro" / "fig.png") << "old figure";
  const fs::path target = dir / "ro";
  // In a private mount namespace of the child only, remount the folder read-only (root
  // ignores permission bits, so chmod would prove nothing).
  const int rc = run({"convert", (dir / "knee.nrrd").string(), (target / "fig.nrrd").string()},
                     dir / "err.txt", [target] {
                       if (::unshare(CLONE_NEWNS) != 0 ||
                           ::mount("none", "/", nullptr, MS_REC | MS_PRIVATE, nullptr) != 0 ||
                           ::mount(target.c_str(), target.c_str(), nullptr, MS_BIND, nullptr) != 0 ||
                           ::mount(nullptr, target.c_str(), nullptr, MS_REMOUNT | MS_BIND | MS_RDONLY, nullptr) != 0)
                         ::_exit(77);  // cannot make a read-only mount here
                     });
  if (rc == 77) GTEST_SKIP() << "no permission for a private read-only mount";
  const std::string err = readAll(dir / "err.txt");
  EXPECT_EQ(rc, 1) << err;
  EXPECT_NE(err.find("fig.nrrd"), std::string::npos) << err;
  EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
  EXPECT_FALSE(fs::exists(target / "fig.nrrd"));
  EXPECT_EQ(readAll(target / "fig.png"), "old figure");
  EXPECT_EQ(leftoverTemps(dir), 0);
}

/// Runs `vellum args` with the stop-before-rename shim preloaded: the child stops itself
/// when its output is complete beside the target; it is then killed with SIGKILL.
/// Returns true if the child reached that point.
static bool killJustBeforeRename(const std::vector<std::string>& args, const fs::path& errFile) {
  Child c(args, errFile, [] {
    ::setenv("LD_PRELOAD", VELLUM_STOP_BEFORE_RENAME, 1);
    ::setenv("ASAN_OPTIONS", "verify_asan_link_order=0:detect_leaks=0", 1);  // sanitizer builds
  });
  int status = 0;
  ::waitpid(c.pid, &status, WUNTRACED);
  const bool stopped = WIFSTOPPED(status);
  ::kill(c.pid, SIGKILL);
  if (stopped) ::waitpid(c.pid, &status, 0);
  return stopped;
}

TEST(Faults, SigkillMidWriteLeavesTheOldOutputIntact) {
  const auto dir = test::tempDir("fault-kill");
  writePhantom(dir, 32);
  const std::string old = "NRRD0004\n# previous output\n";
  std::ofstream(dir / "out.nrrd") << old;
  ASSERT_TRUE(killJustBeforeRename({"convert", (dir / "knee.nrrd").string(), (dir / "out.nrrd").string()},
                                   dir / "err.txt"))
      << "the child never reached the rename: " << readAll(dir / "err.txt");
  // The killed child's complete temporary is orphaned (nothing runs after SIGKILL), and so is
  // the hard link its run kept of the old result to put back on failure; the target still
  // holds the old result.
  EXPECT_EQ(leftoverTemps(dir), 2);
  EXPECT_EQ(readAll(dir / "out.nrrd"), old);
}

TEST(Faults, SigkillWhileWritingADicomSeriesLeavesItAbsent) {
  const auto dir = test::tempDir("fault-dicom");
  writePhantom(dir, 32);
  ASSERT_TRUE(killJustBeforeRename({"convert", (dir / "knee.nrrd").string(), (dir / "series").string()},
                                   dir / "err.txt"))
      << readAll(dir / "err.txt");
  EXPECT_FALSE(fs::exists(dir / "series"));  // complete or absent, never partial
}

TEST(Faults, InterruptCancelsAndLeavesNoTemporaryFiles) {
  for (int sig : {SIGINT, SIGTERM}) {
    const auto dir = test::tempDir("fault-int");
    // Generating a 256^3 phantom takes seconds, with progress checks every slice.
    Child c({"phantom", "--size", "256", "--out", (dir / "knee.nrrd").string(), "--labels",
             (dir / "labels.nrrd").string()},
            dir / "err.txt");
    ASSERT_TRUE(c.waitUntilCatching(sig));
    std::this_thread::sleep_for(std::chrono::milliseconds(300));  // well into the work
    ::kill(c.pid, sig);
    const int rc = c.wait();
    EXPECT_EQ(rc, 130) << "signal " << sig << ": " << c.errors();
    EXPECT_NE(c.errors().find("cancelled"), std::string::npos) << c.errors();
    EXPECT_FALSE(fs::exists(dir / "knee.nrrd"));
    EXPECT_FALSE(fs::exists(dir / "labels.nrrd"));
    EXPECT_EQ(leftoverTemps(dir), 0);
    fs::remove_all(dir);
  }
}

// Issue 19: a GL draw cannot be interrupted, so Ctrl-C during `render` cancels right after it:
// exit 130 and no figure (not even the presets already drawn).
TEST(Faults, InterruptDuringAGlRenderWritesNoFigure) {
  const auto dir = test::tempDir("fault-int-render");
  writePhantom(dir, 64);
  Child c({"render", (dir / "knee.nrrd").string(), "--preset", "all", "--size", "1536x1536", "--out",
           (dir / "fig.png").string()},
          dir / "err.txt");
  ASSERT_TRUE(c.waitUntilCatching(SIGINT));
  std::this_thread::sleep_for(std::chrono::milliseconds(400));  // into the first draws
  ::kill(c.pid, SIGINT);
  const int rc = c.wait();
  if (rc == 0) GTEST_SKIP() << "finished before the interrupt (fast machine)";
  EXPECT_EQ(rc, 130) << c.errors();
  for (const auto& e : fs::directory_iterator(dir))
    EXPECT_NE(e.path().extension(), ".png") << e.path();
  EXPECT_EQ(leftoverTemps(dir), 0);
}

TEST(Faults, NoCommandModifiesItsInputs) {
  const auto dir = test::tempDir("fault-inputs");
  writePhantom(dir, 40);
  const fs::path ct = dir / "knee.nrrd", labels = dir / "labels.nrrd";
  const std::string ctBytes = readAll(ct), labelBytes = readAll(labels);
  const auto out = [&](const char* name) { return (dir / "out" / name).string(); };
  fs::create_directories(dir / "out");
  const std::vector<std::vector<std::string>> commands = {
      {"info", ct.string()},
      {"info", ct.string(), "--json"},
      {"convert", ct.string(), out("c.mha")},
      {"convert", labels.string(), out("l.nrrd"), "--labels"},
      {"render", ct.string(), "--size", "64x64", "--out", out("r.png")},
      {"segment", ct.string(), "--preset", "bone", "--out", out("s.nrrd")},
      {"segment", ct.string(), "--preset", "bone", "--into", labels.string(), "--out", out("s2.nrrd")},
      {"controls", ct.string(), "--out", out("cp.json")},
      {"deform", ct.string(), "--points", out("cp.json"), "--labels", labels.string(),
       "--rigid-labels", "4,5,6,7,8,9,11", "--out", out("d.nrrd")},
      {"shape", ct.string(), "--labels", labels.string(), "--segment", "femur=4,5", "--out", out("shape")},
  };
  for (const auto& args : commands) {
    std::string line;
    for (const auto& a : args) line += a + " ";
    EXPECT_EQ(run(args, dir / "err.txt"), 0) << line << "\n" << readAll(dir / "err.txt");
    EXPECT_EQ(readAll(ct), ctBytes) << "input changed by: " << line;
    EXPECT_EQ(readAll(labels), labelBytes) << "input changed by: " << line;
  }
  // Naming the input as the output is refused before anything is written.
  EXPECT_EQ(run({"convert", ct.string(), ct.string()}, dir / "err.txt"), 1);
  EXPECT_EQ(readAll(ct), ctBytes);
  EXPECT_EQ(leftoverTemps(dir), 0);
}
