// Bad input: truncated files, random bytes, empty folders, non-DICOM folders, missing pixel
// data, absurd dims. Every case is a FileError naming the file or folder; nothing crashes.
#include <gtest/gtest.h>

#include <fstream>
#include <random>

#include "dicom_test_support.hpp"

namespace vellum::test {
namespace {

using io::detail::loadDicom;
using io::detail::looksLikeDicom;
using io::detail::saveDicomSeries;

std::string loadError(const fs::path& path) {
  try {
    loadDicom(path, {});
  } catch (const FileError& e) {
    return e.what();
  }
  return "(no error)";
}

void writeRandom(const fs::path& file, size_t bytes, unsigned seed) {
  std::mt19937 rng(seed);
  std::ofstream out(file, std::ios::binary);
  for (size_t n = 0; n < bytes; ++n) out.put(static_cast<char>(rng() & 0xff));
}

void truncateBy(const fs::path& file, uintmax_t bytes) {
  fs::resize_file(file, fs::file_size(file) - bytes);
}

bool has(const std::string& s, const std::string& needle) { return s.find(needle) != std::string::npos; }

TEST(DicomMalformed, TruncatedPixelDataNamesTheFile) {
  const fs::path dir = tempDir("dicom-trunc") / "series";
  saveDicomSeries(makeVolume({32, 32, 4}), dir, {});
  const fs::path bad = sliceFiles(dir)[2];
  truncateBy(bad, 100);
  const std::string inFolder = loadError(dir);
  EXPECT_TRUE(has(inFolder, bad.string())) << inFolder;
  const std::string single = loadError(bad);
  EXPECT_TRUE(has(single, bad.string())) << single;
  EXPECT_TRUE(looksLikeDicom(bad));
}

TEST(DicomMalformed, FileCutInsideTheHeader) {
  const fs::path dir = tempDir("dicom-cut") / "series";
  saveDicomSeries(makeVolume({32, 32, 4}), dir, {});
  const fs::path bad = sliceFiles(dir)[1];
  fs::resize_file(bad, 300);
  const std::string single = loadError(bad);
  EXPECT_TRUE(has(single, bad.string())) << single;
  // In a folder too: a damaged file of unknown series may be a slice; refuse, naming it.
  const std::string inFolder = loadError(dir);
  EXPECT_TRUE(has(inFolder, bad.string())) << inFolder;
  EXPECT_TRUE(has(inFolder, "unreadable DICOM")) << inFolder;
  // Every truncation point of a slice file: an error naming the file, never a crash.
  const fs::path good = sliceFiles(dir)[0];
  const auto size = fs::file_size(good);
  const fs::path cut = dir.parent_path() / "cut.dcm";
  for (uintmax_t n = 0; n < size; n += n < 1200 ? 3 : 97) {  // densely through the header
    fs::copy_file(good, cut, fs::copy_options::overwrite_existing);
    fs::resize_file(cut, n);
    const std::string msg = loadError(cut);
    ASSERT_TRUE(has(msg, cut.string())) << n << ": " << msg;
  }
}

TEST(DicomMalformed, RandomBytesNamedDcm) {
  const fs::path dir = tempDir("dicom-random");
  const fs::path file = dir / "noise.dcm";
  writeRandom(file, 4096, 7);
  const std::string msg = loadError(file);
  EXPECT_TRUE(has(msg, file.string())) << msg;
  EXPECT_TRUE(has(msg, "not a DICOM file")) << msg;
  EXPECT_FALSE(looksLikeDicom(file));
}

TEST(DicomMalformed, EmptyFolderAndMissingPath) {
  const fs::path dir = tempDir("dicom-empty");
  const std::string msg = loadError(dir);
  EXPECT_TRUE(has(msg, dir.string())) << msg;
  EXPECT_TRUE(has(msg, "no DICOM images found")) << msg;
  const std::string missing = loadError(dir / "nothing-here");
  EXPECT_TRUE(has(missing, "nothing-here")) << missing;
  EXPECT_TRUE(io::listDicomSeries(dir).empty());
}

TEST(DicomMalformed, FolderOfNonDicomFiles) {
  const fs::path dir = tempDir("dicom-nondicom");
  writeRandom(dir / "a.dcm", 1000, 1);
  writeRandom(dir / "b.bin", 200, 2);
  std::ofstream(dir / "notes.txt") << "not an image\n";
  std::ofstream(dir / "empty.dcm");
  const std::string msg = loadError(dir);
  EXPECT_TRUE(has(msg, dir.string())) << msg;
  EXPECT_TRUE(has(msg, "4 not DICOM")) << msg;
}

TEST(DicomMalformed, NonDicomFilesBesideASeriesAreSkipped) {
  const fs::path dir = tempDir("dicom-beside") / "series";
  const VolumeI16 v = makeVolume();
  saveDicomSeries(v, dir, {});
  writeRandom(dir / "junk.dcm", 500, 3);
  std::ofstream(dir / "README.txt") << "hello\n";
  const io::LoadedVolume loaded = loadDicom(dir, {});
  EXPECT_EQ(std::get<VolumeI16>(loaded.volume).voxels(), v.voxels());
  EXPECT_TRUE(contains(loaded.warnings, "2 not DICOM")) << joined(loaded.warnings);
}

TEST(DicomMalformed, MissingPixelData) {
  const fs::path dir = tempDir("dicom-nopixels") / "series";
  saveDicomSeries(makeVolume(), dir, {});
  const fs::path bad = sliceFiles(dir)[0];
  removeTag(bad, 0x7fe0, 0x0010);
  const std::string msg = loadError(dir);
  EXPECT_TRUE(has(msg, bad.string())) << msg;
  EXPECT_TRUE(has(loadError(bad), bad.string()));
}

TEST(DicomMalformed, AbsurdDims) {
  const fs::path dir = tempDir("dicom-absurd") / "series";
  saveDicomSeries(makeVolume(), dir, {});
  const auto files = sliceFiles(dir);
  setTag(files[0], 0x0028, 0x0008, "IS", "999999999");
  std::string msg = loadError(files[0]);
  EXPECT_TRUE(has(msg, files[0].string()) && has(msg, "NumberOfFrames")) << msg;
  // Rows = 0: not an image.
  gdcm::Reader reader;
  reader.SetFileName(files[1].string().c_str());
  ASSERT_TRUE(reader.Read());
  gdcm::DataElement rows(gdcm::Tag(0x0028, 0x0010));
  rows.SetVR(gdcm::VR::US);
  const char zero[2] = {0, 0};
  rows.SetByteValue(zero, 2);
  reader.GetFile().GetDataSet().Replace(rows);
  gdcm::Writer writer;
  writer.SetFile(reader.GetFile());
  writer.SetFileName(files[1].string().c_str());
  ASSERT_TRUE(writer.Write());
  msg = loadError(files[1]);
  EXPECT_TRUE(has(msg, files[1].string()) && has(msg, "no image")) << msg;
  // Pixel data that disagrees with Rows x Columns.
  gdcm::Reader r2;
  r2.SetFileName(files[3].string().c_str());
  ASSERT_TRUE(r2.Read());
  gdcm::DataElement cols(gdcm::Tag(0x0028, 0x0011));
  cols.SetVR(gdcm::VR::US);
  const char big[2] = {static_cast<char>(0x00), static_cast<char>(0x10)};  // 4096 columns
  cols.SetByteValue(big, 2);
  r2.GetFile().GetDataSet().Replace(cols);
  gdcm::Writer w2;
  w2.SetFile(r2.GetFile());
  w2.SetFileName(files[3].string().c_str());
  ASSERT_TRUE(w2.Write());
  msg = loadError(files[3]);
  EXPECT_TRUE(has(msg, files[3].string())) << msg;
}

TEST(DicomMalformed, RandomHeaderMutationsNeverCrash) {
  // Flipped bytes anywhere in the header: each load either works or throws a vellum::Error
  // (GDCM alone aborts the process on many of these).
  const fs::path dir = tempDir("dicom-mutate") / "series";
  saveDicomSeries(makeVolume({16, 16, 1}), dir, {});
  const fs::path good = sliceFiles(dir)[0];
  std::string original;
  {
    std::ifstream in(good, std::ios::binary);
    original.assign(std::istreambuf_iterator<char>(in), {});
  }
  const size_t headerEnd = original.size() - 16 * 16 * 2;
  const fs::path file = dir.parent_path() / "mutant.dcm";
  std::mt19937 rng(2024);
  int loaded = 0, refused = 0;
  for (int n = 0; n < 400; ++n) {
    std::string bytes = original;
    for (int m = 1 + static_cast<int>(rng() % 3); m > 0; --m) {
      const size_t pos = 128 + rng() % (headerEnd - 128);
      bytes[pos] = static_cast<char>(rng() % 2 ? rng() : bytes[pos] ^ (1 << (rng() % 8)));
    }
    std::ofstream(file, std::ios::binary | std::ios::trunc) << bytes;
    try {
      loadDicom(file, {});
      ++loaded;
    } catch (const Error&) {
      ++refused;
    }
  }
  EXPECT_EQ(loaded + refused, 400);
  EXPECT_GT(refused, 50);  // most structural damage is caught
}

TEST(DicomMalformed, LooksLikeDicom) {
  const fs::path dir = tempDir("dicom-looks") / "series";
  saveDicomSeries(makeVolume({4, 4, 1}), dir, {});
  EXPECT_TRUE(looksLikeDicom(sliceFiles(dir)[0]));
  std::ofstream(dir.parent_path() / "t.txt") << "text";
  EXPECT_FALSE(looksLikeDicom(dir.parent_path() / "t.txt"));
  EXPECT_FALSE(looksLikeDicom(dir));  // a folder is not a file
  EXPECT_FALSE(looksLikeDicom(dir / "missing.dcm"));
}

}  // namespace
}  // namespace vellum::test
