// Our VTI reader against VTK's writer in every mode VTK writes: the voxels, geometry and
// modality must come back exactly. Also: what VTK's reader used to crash on is refused with a
// one-line error.
#include <gtest/gtest.h>

#include <vtkFieldData.h>
#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkShortArray.h>
#include <vtkFloatArray.h>
#include <vtkStringArray.h>
#include <vtkXMLImageDataWriter.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>

#include "test_data.hpp"
#include "vellum/io/volume_io.hpp"

using namespace vellum;
namespace fs = std::filesystem;

namespace {

struct WriterMode {
  const char* name;
  int dataMode;  ///< vtkXMLWriter::Ascii / Binary / Appended
  bool encodeAppended, zlib, uint64Header, bigEndian;
};

/// A 7x5x6 int16 (or float) image with a non-trivial extent start, spacing, origin and
/// direction, written by VTK in `mode`.
template <class Array>
void writeWithVtk(const fs::path& path, const WriterMode& mode, bool withModality) {
  vtkNew<vtkImageData> img;
  img->SetExtent(2, 8, -1, 3, 0, 5);
  img->SetSpacing(0.5, 0.75, 1.25);
  img->SetOrigin(-10, 20, 3.5);
  const double dir[9] = {0, -1, 0, 1, 0, 0, 0, 0, 1};  // a 90 degree turn about z
  img->SetDirectionMatrix(dir);
  vtkNew<Array> values;
  values->SetName("ct");
  values->SetNumberOfComponents(1);
  values->SetNumberOfTuples(7 * 5 * 6);
  for (vtkIdType i = 0; i < 7 * 5 * 6; ++i) values->SetValue(i, static_cast<typename Array::ValueType>(i * 37 % 2001 - 1000));
  img->GetPointData()->SetScalars(values);
  if (withModality) {
    vtkNew<vtkStringArray> s;
    s->SetName("vellum_modality");
    s->InsertNextValue("MR");
    img->GetFieldData()->AddArray(s);
  }
  vtkNew<vtkXMLImageDataWriter> w;
  w->SetInputData(img);
  w->SetFileName(path.c_str());
  w->SetDataMode(mode.dataMode);
  w->SetEncodeAppendedData(mode.encodeAppended);
  if (mode.zlib) w->SetCompressorTypeToZLib();
  else w->SetCompressorTypeToNone();
  w->SetBlockSize(64);  // many blocks even for a small image
  if (mode.uint64Header) w->SetHeaderTypeToUInt64();
  else w->SetHeaderTypeToUInt32();
  w->SetByteOrder(mode.bigEndian ? vtkXMLWriter::BigEndian : vtkXMLWriter::LittleEndian);
  ASSERT_EQ(w->Write(), 1);
}

const WriterMode kModes[] = {
    {"ascii", vtkXMLWriter::Ascii, false, false, false, false},
    {"inline base64", vtkXMLWriter::Binary, false, false, false, false},
    {"inline base64 zlib", vtkXMLWriter::Binary, false, true, true, false},
    {"inline base64 zlib UInt32", vtkXMLWriter::Binary, false, true, false, false},
    {"appended raw", vtkXMLWriter::Appended, false, false, true, false},
    {"appended raw zlib", vtkXMLWriter::Appended, false, true, true, false},
    {"appended raw zlib UInt32 big endian", vtkXMLWriter::Appended, false, true, false, true},
    {"appended raw big endian", vtkXMLWriter::Appended, false, false, false, true},
    {"appended base64", vtkXMLWriter::Appended, true, false, true, false},
    {"appended base64 zlib", vtkXMLWriter::Appended, true, true, false, false},
};

void expectGeometry(const Geometry& g) {
  EXPECT_EQ(g.dims, (Dims{7, 5, 6}));
  EXPECT_DOUBLE_EQ(g.spacing.x, 0.5);
  EXPECT_DOUBLE_EQ(g.spacing.y, 0.75);
  EXPECT_DOUBLE_EQ(g.spacing.z, 1.25);
  EXPECT_DOUBLE_EQ(g.direction(0, 1), -1);
  EXPECT_DOUBLE_EQ(g.direction(1, 0), 1);
  // Our origin is the first voxel of the extent: VTK origin + D * (extent start * spacing).
  const Vec3 expected = Vec3{-10, 20, 3.5} + g.direction * Vec3{2 * 0.5, -1 * 0.75, 0};
  EXPECT_LT(norm(g.origin - expected), 1e-12);
}

}  // namespace

TEST(VtiReader, ReadsEveryModeVtkWritesInt16) {
  const fs::path dir = test::tempDir("vti-modes");
  for (const auto& mode : kModes) {
    SCOPED_TRACE(mode.name);
    const fs::path f = dir / "a.vti";
    writeWithVtk<vtkShortArray>(f, mode, true);
    // fuzz/make_corpus.sh collects these as the VTI fuzzer's seeds (one per writer mode).
    if (const char* seeds = std::getenv("VELLUM_VTI_SEED_DIR")) {
      std::string name = mode.name;
      std::replace(name.begin(), name.end(), ' ', '-');
      fs::copy_file(f, fs::path(seeds) / (name + ".vti"), fs::copy_options::overwrite_existing);
    }
    io::LoadedVolume lv;
    ASSERT_NO_THROW(lv = io::loadVolume(f));
    // int16 with values down to -1000 but modality MR: kept as int16 data, not converted.
    const auto* v = std::get_if<VolumeI16>(&lv.volume);
    ASSERT_NE(v, nullptr);
    expectGeometry(v->geometry());
    EXPECT_EQ(lv.modality, "MR");
    for (int64_t i = 0; i < 7 * 5 * 6; ++i) ASSERT_EQ(v->data()[i], int16_t(i * 37 % 2001 - 1000)) << i;
  }
}

TEST(VtiReader, ReadsFloatArraysAndPicksTheScalars) {
  const fs::path dir = test::tempDir("vti-float");
  for (const auto& mode : {kModes[0], kModes[2], kModes[5]}) {
    SCOPED_TRACE(mode.name);
    writeWithVtk<vtkFloatArray>(dir / "f.vti", mode, false);
    const auto lv = io::loadVolume(dir / "f.vti");
    const auto* v = std::get_if<VolumeF32>(&lv.volume);
    ASSERT_NE(v, nullptr);
    expectGeometry(v->geometry());
    for (int64_t i = 0; i < 7 * 5 * 6; ++i) ASSERT_EQ(v->data()[i], float(i * 37 % 2001 - 1000)) << i;
  }
}

TEST(VtiReader, OwnWriterRoundTripsThroughOwnReader) {
  const fs::path dir = test::tempDir("vti-own");
  Geometry geom;
  geom.dims = {33, 17, 9};
  geom.spacing = {0.7, 0.8, 2.0};
  geom.origin = {1, 2, 3};
  VolumeI16 ct(geom, -1000, -1000);
  for (size_t i = 0; i < ct.size(); ++i) ct.data()[i] = int16_t(int(i * 7919 % 4000) - 1000);
  io::saveVolume(ct, dir / "ct.vti");
  const auto lv = io::loadVolume(dir / "ct.vti");
  const auto& back = std::get<VolumeI16>(lv.volume);
  EXPECT_TRUE(back.geometry().approxEqual(ct.geometry(), 1e-12));
  EXPECT_EQ(lv.modality, "CT");
  EXPECT_EQ(0, std::memcmp(back.data(), ct.data(), ct.size() * sizeof(int16_t)));
}

namespace {
std::string slurp(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), {}};
}
void writeFile(const fs::path& p, const std::string& s) { std::ofstream(p, std::ios::binary) << s; }
}  // namespace

// Each case broke VTK's reader (crash, SIGFPE or a huge allocation); ours names the problem.
TEST(VtiReader, RefusesWhatVtkCrashedOn) {
  const fs::path dir = test::tempDir("vti-bad");
  writeWithVtk<vtkShortArray>(dir / "good.vti", kModes[5], false);  // appended raw zlib UInt64
  const std::string good = slurp(dir / "good.vti");
  const size_t underscore = good.find('_', good.find("<AppendedData"));
  ASSERT_NE(underscore, std::string::npos);
  const auto patchHeader = [&](int index, uint64_t value) {
    std::string s = good;
    std::memcpy(s.data() + underscore + 1 + 8 * index, &value, 8);
    return s;
  };
  struct Case { std::string name, content, needle; };
  std::string noType = good;
  noType.replace(noType.find("type=\"Int16\""), 12, "");
  std::string unknownType = good;
  unknownType.replace(unknownType.find("type=\"Int16\""), 12, "type=\"Int99\"");
  std::string junkBeforeUnderscore = good;
  junkBeforeUnderscore.insert(underscore, "\xfb");
  const Case cases[] = {
      {"block count 2^56", patchHeader(0, uint64_t{1} << 56), "blocks in a file of"},
      {"block size 0", patchHeader(1, 0), "block size 0"},
      {"last block larger", patchHeader(2, 1u << 20), "corrupt compressed array header"},
      {"block of 2^60 bytes", patchHeader(3, uint64_t{1} << 60), "corrupt compressed array header"},
      {"no type", noType, "without a type"},
      {"unknown type", unknownType, "unsupported DataArray type 'Int99'"},
      {"junk before '_'", junkBeforeUnderscore, "does not start with '_'"},
      {"truncated XML", good.substr(0, good.find("<AppendedData") - 20), ""},
      {"truncated data", good.substr(0, good.size() - 40), ""},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.name);
    writeFile(dir / "bad.vti", c.content);
    try {
      io::loadVolume(dir / "bad.vti");
      ADD_FAILURE() << "accepted";
    } catch (const Error& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find("bad.vti"), std::string::npos) << msg;
      EXPECT_NE(msg.find(c.needle), std::string::npos) << msg;
      EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
    }
  }
}
