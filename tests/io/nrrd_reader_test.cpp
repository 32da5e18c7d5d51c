// readNrrd (io/nrrd_reader.hpp): vector-valued NRRD files, written by io's writer and by hand.
#include <gtest/gtest.h>

#include <cstring>

#include "io_test_util.hpp"
#include "vellum/core/error.hpp"
#include "vellum/io/nrrd_reader.hpp"
#include "vellum/io/nrrd_writer.hpp"
#include "vellum/io/volume_io.hpp"

using namespace vellum;
using namespace vellum::test;
namespace fs = std::filesystem;

TEST(NrrdReader, VectorFieldsRoundTripInEveryContainer) {
  const auto dir = tempDir("nrrd-reader");
  io::NrrdLayout layout;
  layout.type = "float";
  layout.leadingSizes = {3};
  layout.leadingKinds = {"vector"};
  layout.geometry = obliqueGeometry({4, 3, 2});
  std::vector<float> v(3 * 24);
  for (size_t t = 0; t < v.size(); ++t) v[t] = 0.5f * static_cast<float>(t) - 9.0f;
  for (const char* name : {"a.nrrd", "b.nhdr"})
    for (bool gzip : {false, true}) {
      const fs::path path = dir / (std::string(gzip ? "gz-" : "raw-") + name);
      io::writeNrrd(path, layout, v.data(), v.size() * sizeof(float), gzip);
      const io::NrrdContents c = io::readNrrd(path);
      EXPECT_EQ(c.layout.type, "float");
      EXPECT_EQ(c.layout.leadingSizes, std::vector<int64_t>{3});
      EXPECT_EQ(c.layout.leadingKinds, std::vector<std::string>{"vector"});
      expectGeometryNear(c.layout.geometry, layout.geometry, 1e-12);
      ASSERT_EQ(c.bytes.size(), v.size() * sizeof(float)) << path;
      EXPECT_EQ(std::memcmp(c.bytes.data(), v.data(), c.bytes.size()), 0) << path;
    }
}

TEST(NrrdReader, BigEndianSamplesComeBackInHostOrder) {
  const auto dir = tempDir("nrrd-reader");
  // Two 2-vectors of big-endian int16: (1, 2) at voxel 0, (-3, 256) at voxel 1.
  const std::string header =
      "NRRD0004\ntype: short\ndimension: 4\nsizes: 2 2 1 1\nkinds: covariant-vector domain domain domain\n"
      "endian: big\nencoding: raw\nspacings: NaN 1 1 1\n\n";
  const std::string data{"\x00\x01\x00\x02\xff\xfd\x01\x00", 8};
  writeFile(dir / "be.nrrd", header + data);
  const io::NrrdContents c = io::readNrrd(dir / "be.nrrd");
  EXPECT_EQ(c.layout.type, "short");
  EXPECT_EQ(c.layout.leadingKinds, std::vector<std::string>{"covariant-vector"});
  ASSERT_EQ(c.bytes.size(), 8u);
  int16_t s[4];
  std::memcpy(s, c.bytes.data(), 8);
  EXPECT_EQ(s[0], 1);
  EXPECT_EQ(s[1], 2);
  EXPECT_EQ(s[2], -3);
  EXPECT_EQ(s[3], 256);
  // The volume loader still refuses several components per voxel, with the same message.
  try {
    io::loadVolume(dir / "be.nrrd");
    ADD_FAILURE() << "a 2-component file loaded as a volume";
  } catch (const FileError& e) {
    EXPECT_NE(std::string(e.what()).find("2 components per voxel"), std::string::npos) << e.what();
  }
}

TEST(NrrdReader, ErrorsNameTheFile) {
  const auto dir = tempDir("nrrd-reader");
  writeFile(dir / "cut.nrrd", "NRRD0004\ntype: float\ndimension: 3\nsizes: 4 4 4\nendian: little\nencoding: raw\n\nabc");
  try {
    io::readNrrd(dir / "cut.nrrd");
    ADD_FAILURE() << "no error for truncated data";
  } catch (const FileError& e) {
    EXPECT_NE(std::string(e.what()).find("cut.nrrd"), std::string::npos) << e.what();
  }
  EXPECT_THROW(io::readNrrd(dir / "missing.nrrd"), FileError);
}
