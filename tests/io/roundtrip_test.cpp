// Every writable format: voxels exact, geometry within 1e-5, types and CT-ness preserved.
#include <gtest/gtest.h>

#include <limits>

#include "io_test_util.hpp"
#include "vellum/core/error.hpp"
#include "vellum/io/volume_io.hpp"

using namespace vellum;
using namespace vellum::test;
namespace fs = std::filesystem;

namespace {

struct Case {
  const char* name;
  const char* file;
  bool gzip;
};

class RoundTrip : public ::testing::TestWithParam<Case> {};

template <class T>
void expectSameVoxels(const Volume<T>& a, const AnyVolume& b) {
  ASSERT_TRUE(std::holds_alternative<Volume<T>>(b)) << "voxel type changed";
  const auto& v = std::get<Volume<T>>(b);
  ASSERT_EQ(a.size(), v.size());
  for (size_t i = 0; i < a.size(); ++i) ASSERT_EQ(a.data()[i], v.data()[i]) << "voxel " << i;
}

}  // namespace

TEST_P(RoundTrip, CtInt16WithObliqueGeometry) {
  const Case c = GetParam();
  const fs::path dir = tempDir(std::string("rt-ct-") + c.name);
  const VolumeI16 ct = makeCt();
  io::SaveOptions opt;
  opt.gzip = c.gzip;
  io::saveVolume(ct, dir / c.file, opt);
  const io::LoadedVolume lv = io::loadVolume(dir / c.file);
  expectSameVoxels(ct, lv.volume);
  expectGeometryNear(ct.geometry(), geometryOf(lv.volume));
  EXPECT_EQ(lv.modality, "CT");
  EXPECT_EQ(backgroundOf(lv.volume), -1000.0);
  EXPECT_EQ(lv.format, io::formatForPath(dir / c.file));
  EXPECT_EQ(leftoverTemps(dir), 0);
}

TEST_P(RoundTrip, OtherVoxelTypesKeepTypeAndZeroBackground) {
  const Case c = GetParam();
  const fs::path dir = tempDir(std::string("rt-types-") + c.name);
  io::SaveOptions opt;
  opt.gzip = c.gzip;
  const auto u8 = makeRamp<uint8_t>(7);
  const auto u16 = makeRamp<uint16_t>(911);
  auto f32 = makeRamp<float>(3.5);
  f32.data()[3] = -1234.5f;
  io::saveVolume(u8, dir / c.file, opt);
  auto lv = io::loadVolume(dir / c.file);
  expectSameVoxels(u8, lv.volume);
  expectGeometryNear(u8.geometry(), geometryOf(lv.volume));
  EXPECT_EQ(lv.modality, "");
  EXPECT_EQ(backgroundOf(lv.volume), 0.0);
  io::saveVolume(u16, dir / c.file, opt);
  expectSameVoxels(u16, io::loadVolume(dir / c.file).volume);
  io::saveVolume(f32, dir / c.file, opt);
  lv = io::loadVolume(dir / c.file);
  expectSameVoxels(f32, lv.volume);
  expectGeometryNear(f32.geometry(), geometryOf(lv.volume));
}

TEST_P(RoundTrip, LabelIdsSurviveEveryFormat) {
  const Case c = GetParam();
  const fs::path dir = tempDir(std::string("rt-labels-") + c.name);
  LabelVolume labels(obliqueGeometry());
  for (size_t i = 0; i < labels.ids().size(); ++i) labels.ids().data()[i] = static_cast<uint16_t>(i % 5 == 0 ? 300 : i % 4);
  labels.setLabel({1, "skin", {200, 150, 120}});
  labels.setLabel({300, "bone", {255, 255, 240}});
  io::SaveOptions opt;
  opt.gzip = c.gzip;
  io::saveLabels(labels, dir / c.file, opt);
  const LabelVolume back = io::loadLabels(dir / c.file);
  ASSERT_EQ(back.ids().size(), labels.ids().size());
  EXPECT_EQ(back.ids().voxels(), labels.ids().voxels());
  expectGeometryNear(labels.geometry(), back.geometry());
}

INSTANTIATE_TEST_SUITE_P(Formats, RoundTrip,
                         ::testing::Values(Case{"nrrd_gzip", "v.nrrd", true}, Case{"nrrd_raw", "v.nrrd", false},
                                           Case{"nhdr", "v.nhdr", true}, Case{"raw", "v.raw", false},
                                           Case{"mha", "v.mha", false}, Case{"mhd", "v.mhd", false},
                                           Case{"vti", "v.vti", false}),
                         [](const auto& info) { return std::string(info.param.name); });

TEST(RoundTrip, NrrdLabelTableAndSmallestType) {
  const fs::path dir = tempDir("rt-label-table");
  LabelVolume labels(obliqueGeometry());
  for (size_t i = 0; i < labels.ids().size(); ++i) labels.ids().data()[i] = static_cast<uint16_t>(i % 4);
  labels.setLabel({1, "skin", {200, 150, 120}});
  labels.setLabel({2, "left femur head", {10, 20, 30}});
  labels.setLabel({3, "bone", {255, 255, 255}});
  io::saveLabels(labels, dir / "l.nrrd");
  const std::string text = readFile(dir / "l.nrrd");
  EXPECT_NE(text.find("type: uchar"), std::string::npos);
  EXPECT_NE(text.find("vellum_label_3:=bone 255 255 255"), std::string::npos);
  EXPECT_NE(text.find("Segment1_Name:=left femur head"), std::string::npos);
  EXPECT_NE(text.find("Segment1_LabelValue:=2"), std::string::npos);
  const LabelVolume back = io::loadLabels(dir / "l.nrrd");
  EXPECT_EQ(back.ids().voxels(), labels.ids().voxels());
  ASSERT_EQ(back.table().size(), 3u);
  EXPECT_EQ(back.table(), labels.table());

  labels.ids().data()[0] = 256;  // no longer fits uint8
  io::saveLabels(labels, dir / "l.nrrd");
  EXPECT_NE(readFile(dir / "l.nrrd").find("type: ushort"), std::string::npos);
  EXPECT_EQ(io::loadLabels(dir / "l.nrrd").ids().voxels(), labels.ids().voxels());
}

TEST(RoundTrip, SlicerSegmentFieldsAloneGiveTheTable) {
  const fs::path dir = tempDir("slicer-seg");
  std::string hdr =
      "NRRD0004\ntype: unsigned char\ndimension: 3\nspace: left-posterior-superior\nsizes: 2 2 1\n"
      "space directions: (1,0,0) (0,1,0) (0,0,1)\nkinds: domain domain domain\nencoding: raw\n"
      "space origin: (0,0,0)\nSegment0_ID:=Segment_1\nSegment0_Name:=liver\n"
      "Segment0_Color:=1 0.5 0\nSegment0_LabelValue:=7\nSegment0_Layer:=0\n"
      "Segment1_Name:=kidney\nSegment1_Color:=0 0 1\nSegment1_LabelValue:=2\n\n";
  writeFile(dir / "s.seg.nrrd", hdr + std::string("\x00\x07\x02\x07", 4));
  const LabelVolume l = io::loadLabels(dir / "s.seg.nrrd");
  EXPECT_EQ(l(1, 0, 0), 7);
  EXPECT_EQ(l(0, 1, 0), 2);
  ASSERT_EQ(l.table().size(), 2u);
  EXPECT_EQ(l.label(7)->name, "liver");
  EXPECT_EQ(l.label(7)->rgb, (std::array<uint8_t, 3>{255, 128, 0}));
  EXPECT_EQ(l.label(2)->name, "kidney");
}

TEST(RoundTrip, LabelsFromNonIntegerVolumeAreRejected) {
  const fs::path dir = tempDir("labels-bad");
  auto f = makeRamp<float>(3.5);
  f.data()[1] = 1.5f;
  io::saveVolume(f, dir / "f.nrrd");
  EXPECT_THROW(io::loadLabels(dir / "f.nrrd"), FileError);
  io::saveVolume(makeCt(), dir / "ct.nrrd");  // negative values
  EXPECT_THROW(io::loadLabels(dir / "ct.nrrd"), FileError);
}

TEST(RoundTrip, NonCtInt16StaysNonCtAndUint8IsNeverMarkedCt) {
  const fs::path dir = tempDir("rt-nonct");
  VolumeI16 v(obliqueGeometry(), 5, 0.0);  // int16 with background 0: e.g. headsq
  io::saveVolume(v, dir / "v.nrrd");        // default options say "CT"
  EXPECT_EQ(readFile(dir / "v.nrrd").find("vellum_modality"), std::string::npos);
  auto lv = io::loadVolume(dir / "v.nrrd");
  EXPECT_EQ(lv.modality, "");
  EXPECT_EQ(backgroundOf(lv.volume), 0.0);
  io::SaveOptions mr;
  mr.modality = "MR";
  io::saveVolume(v, dir / "v.mha", mr);
  EXPECT_EQ(io::loadVolume(dir / "v.mha").modality, "MR");
}

TEST(RoundTrip, NonFiniteVoxelsBecomeTheBackgroundWithAWarning) {
  const fs::path dir = tempDir("rt-nonfinite");
  Geometry g;
  g.dims = {4, 3, 2};
  VolumeF32 f(g);
  for (size_t n = 0; n < f.size(); ++n) f.voxels()[n] = static_cast<float>(n);
  f.voxels()[3] = std::numeric_limits<float>::quiet_NaN();
  f.voxels()[7] = std::numeric_limits<float>::infinity();
  io::saveVolume(f, dir / "f.nrrd");
  const io::LoadedVolume lv = io::loadVolume(dir / "f.nrrd");
  const VolumeF32& r = std::get<VolumeF32>(lv.volume);
  EXPECT_EQ(r.voxels()[3], 0.f);
  EXPECT_EQ(r.voxels()[7], 0.f);
  EXPECT_EQ(r.voxels()[8], 8.f);
  ASSERT_EQ(lv.warnings.size(), 1u);
  EXPECT_NE(lv.warnings[0].find("2 voxels are NaN or infinite"), std::string::npos) << lv.warnings[0];
  // A rescale that is not a number is refused, naming the file.
  io::LoadOptions o;
  o.rescale = std::pair{std::numeric_limits<double>::quiet_NaN(), 0.0};
  EXPECT_THROW(io::loadVolume(dir / "f.nrrd", o), FileError);
  o.rescale = std::pair{0.0, -1024.0};
  EXPECT_THROW(io::loadVolume(dir / "f.nrrd", o), FileError);
}
