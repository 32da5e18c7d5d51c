#include <gtest/gtest.h>

#include <stdexcept>

#include "io_test_util.hpp"
#include "vellum/core/error.hpp"
#include "vellum/io/atomic_file.hpp"
#include "vellum/io/output_policy.hpp"
#include "vellum/io/replaced_files.hpp"

using namespace vellum;
using namespace vellum::test;
namespace fs = std::filesystem;

TEST(AtomicFile, WritesFileAndLeavesNoTemporary) {
  const fs::path dir = tempDir("atomic-write");
  fs::path seen;
  io::writeAtomically(dir / "out.png", [&](const fs::path& tmp) {
    seen = tmp;
    EXPECT_EQ(tmp.parent_path(), dir);            // same folder: rename is atomic
    EXPECT_EQ(tmp.extension(), ".png");           // extension kept for OpenCV/VTK
    EXPECT_FALSE(fs::exists(dir / "out.png"));    // target not touched while writing
    writeFile(tmp, "new");
  });
  EXPECT_EQ(readFile(dir / "out.png"), "new");
  EXPECT_FALSE(fs::exists(seen));
  EXPECT_EQ(leftoverTemps(dir), 0);
}

TEST(AtomicFile, ThrowingWriterLeavesTargetUntouchedAndNoTemporary) {
  const fs::path dir = tempDir("atomic-throw");
  writeFile(dir / "a.nrrd", "old contents");
  EXPECT_THROW(io::writeAtomically(dir / "a.nrrd",
                                   [&](const fs::path& tmp) {
                                     writeFile(tmp, "half written");
                                     throw std::runtime_error("disk full");
                                   }),
               std::runtime_error);
  EXPECT_EQ(readFile(dir / "a.nrrd"), "old contents");
  EXPECT_EQ(leftoverTemps(dir), 0);
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 1);
}

TEST(AtomicFile, ReplacesExistingFile) {
  const fs::path dir = tempDir("atomic-replace");
  writeFile(dir / "a.raw", "old");
  io::writeAtomically(dir / "a.raw", [](const fs::path& tmp) { writeFile(tmp, "newer"); });
  EXPECT_EQ(readFile(dir / "a.raw"), "newer");
}

TEST(AtomicFile, FolderTargetIsSwappedWhole) {
  const fs::path dir = tempDir("atomic-folder");
  io::writeFolderAtomically(dir / "series", io::FolderKind::DicomSeries, [](const fs::path& tmp) {
    writeFile(tmp / "old1.dcm", "x");
    writeFile(tmp / "old2.dcm", "y");
  });
  io::writeFolderAtomically(dir / "series", io::FolderKind::DicomSeries,
                            [](const fs::path& tmp) { writeFile(tmp / "new1.dcm", "n"); });
  EXPECT_TRUE(fs::exists(dir / "series" / "new1.dcm"));
  EXPECT_TRUE(fs::exists(dir / "series" / ".vellum-series"));
  EXPECT_FALSE(fs::exists(dir / "series" / "old1.dcm"));
  EXPECT_EQ(leftoverTemps(dir), 0);
}

TEST(AtomicFile, ThrowingFolderWriterKeepsOldFolder) {
  const fs::path dir = tempDir("atomic-folder-throw");
  io::writeFolderAtomically(dir / "series", io::FolderKind::DicomSeries,
                            [](const fs::path& tmp) { writeFile(tmp / "old1.dcm", "x"); });
  EXPECT_THROW(io::writeFolderAtomically(dir / "series", io::FolderKind::DicomSeries,
                                         [](const fs::path& tmp) {
                                           writeFile(tmp / "new1.dcm", "n");
                                           throw Cancelled();
                                         }),
               Cancelled);
  EXPECT_TRUE(fs::exists(dir / "series" / "old1.dcm"));
  EXPECT_FALSE(fs::exists(dir / "series" / "new1.dcm"));
  EXPECT_EQ(leftoverTemps(dir), 0);
}

TEST(AtomicFile, ErrorsNameTheTargetNotTheTemporary) {
  const fs::path dir = tempDir("atomic-names");
  try {
    io::writeAtomically(dir / "out.nrrd", [](const fs::path& tmp) { throw FileError(tmp, "No space left on device"); });
    FAIL() << "no error";
  } catch (const FileError& e) {
    EXPECT_EQ(std::string(e.what()), (dir / "out.nrrd").string() + ": No space left on device");
  }
  try {
    io::writeFolderAtomically(dir / "series", io::FolderKind::DicomSeries,
                              [](const fs::path& tmp) { throw FileError(tmp / "IMG0001.dcm", "No space left on device"); });
    FAIL() << "no error";
  } catch (const FileError& e) {
    EXPECT_EQ(std::string(e.what()), (dir / "series" / "IMG0001.dcm").string() + ": No space left on device");
  }
  EXPECT_EQ(leftoverTemps(dir), 0);
}

TEST(AtomicFile, AFolderIsNeverReplacedByAFileWriter) {
  const fs::path dir = tempDir("atomic-dir-file");
  fs::create_directories(dir / "x.nrrd");
  writeFile(dir / "x.nrrd" / "keep.txt", "k");
  EXPECT_THROW(io::writeAtomically(dir / "x.nrrd", [](const fs::path& tmp) { writeFile(tmp, "n"); }), FileError);
  EXPECT_EQ(readFile(dir / "x.nrrd" / "keep.txt"), "k");
  EXPECT_EQ(leftoverTemps(dir), 0);
}

TEST(AtomicFile, MissingFolderAndSilentWriterAreFileErrors) {
  const fs::path dir = tempDir("atomic-missing");
  try {
    io::writeAtomically(dir / "nope" / "a.png", [](const fs::path& tmp) { writeFile(tmp, "x"); });
    FAIL() << "expected FileError";
  } catch (const FileError& e) {
    EXPECT_NE(std::string(e.what()).find("a.png"), std::string::npos);
  }
  EXPECT_THROW(io::writeAtomically(dir / "b.png", [](const fs::path&) {}), FileError);
  EXPECT_FALSE(fs::exists(dir / "b.png"));
}

// A run that fails after writing puts back what it replaced (ReplacedFiles journal).
TEST(ReplacedFiles, RollBackRestoresReplacedFileAndFolder) {
  const fs::path dir = tempDir("replaced-rollback");
  writeFile(dir / "a.nrrd", "old a");
  io::writeFolderAtomically(dir / "series", io::FolderKind::DicomSeries,
                            [](const fs::path& tmp) { writeFile(tmp / "old.dcm", "o"); });
  {
    io::ReplacedFiles journal;
    io::writeAtomically(dir / "a.nrrd", [](const fs::path& tmp) { writeFile(tmp, "new a"); });
    io::writeAtomically(dir / "a.nrrd", [](const fs::path& tmp) { writeFile(tmp, "newer a"); });
    io::writeAtomically(dir / "b.nrrd", [](const fs::path& tmp) { writeFile(tmp, "new b"); });
    io::writeFolderAtomically(dir / "series", io::FolderKind::DicomSeries,
                              [](const fs::path& tmp) { writeFile(tmp / "new.dcm", "n"); });
    EXPECT_EQ(readFile(dir / "a.nrrd"), "newer a");
    EXPECT_TRUE(fs::exists(dir / "series" / "new.dcm"));
    EXPECT_EQ(journal.size(), 2u);  // a.nrrd once (its first old version) and the folder; b.nrrd was new
  }  // not committed: rolled back
  EXPECT_EQ(readFile(dir / "a.nrrd"), "old a");
  EXPECT_TRUE(fs::exists(dir / "series" / "old.dcm"));
  EXPECT_FALSE(fs::exists(dir / "series" / "new.dcm"));
  EXPECT_EQ(readFile(dir / "b.nrrd"), "new b");  // not the journal's to remove (RunOutputs does)
  EXPECT_EQ(leftoverTemps(dir), 0);
  fs::remove_all(dir);
}

TEST(ReplacedFiles, CommitKeepsNewVersionsAndLeavesNoHiddenCopies) {
  const fs::path dir = tempDir("replaced-commit");
  writeFile(dir / "a.nrrd", "old a");
  {
    io::ReplacedFiles outer;
    {
      io::ReplacedFiles inner;
      io::writeAtomically(dir / "a.nrrd", [](const fs::path& tmp) { writeFile(tmp, "new a"); });
      inner.commit();  // handed to the outer run
    }
    EXPECT_EQ(outer.size(), 1u);
    outer.commit();
  }
  EXPECT_EQ(readFile(dir / "a.nrrd"), "new a");
  EXPECT_EQ(leftoverTemps(dir), 0);
  // No journal open: nothing is kept.
  io::writeAtomically(dir / "a.nrrd", [](const fs::path& tmp) { writeFile(tmp, "plain"); });
  EXPECT_EQ(leftoverTemps(dir), 0);
  fs::remove_all(dir);
}
