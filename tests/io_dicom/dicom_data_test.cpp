// Integration on the third-party samples in ../shared/data (label "data"; skips when absent).
// Expected values were read from the files' tags with gdcmdump.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "dicom.hpp"
#include "test_data.hpp"
#include "vellum/io/volume_io.hpp"
#include "vec3_near.hpp"

namespace vellum::test {
namespace {

namespace fs = std::filesystem;
using io::detail::loadDicom;

const VolumeI16& asI16(const io::LoadedVolume& l) { return std::get<VolumeI16>(l.volume); }
/// By value, for temporaries.
VolumeI16 loadI16(const fs::path& path) {
  io::LoadedVolume l = loadDicom(path, {});
  return std::get<VolumeI16>(std::move(l.volume));
}

TEST(DicomData, HeadPhantomSeries) {
  VELLUM_REQUIRE_DATA("ct-head-phantom");
  const io::LoadedVolume l = loadDicom(dataDir() / "ct-head-phantom", {});
  const VolumeI16& v = asI16(l);
  const Geometry& g = v.geometry();
  EXPECT_EQ(g.dims, (Dims{512, 512, 28}));
  EXPECT_NEAR(g.spacing.x, 0.451171875, 1e-6);
  EXPECT_NEAR(g.spacing.y, 0.451171875, 1e-6);
  EXPECT_NEAR(g.spacing.z, 5.0, 1e-3);
  // First slice after sorting: the lowest z (IPP -115.5\-1.85\696.21, InstanceNumber 1,
  // file I10.dcm; name order would have put I100.dcm second).
  EXPECT_VEC3_NEAR(g.origin, -115.5, -1.85, 696.21, 1e-6);
  EXPECT_LT(maxAbsDiff(g.direction, Mat3::identity()), 1e-9);
  // Slices strictly increasing along the normal, 5 mm apart, last at 831.21.
  EXPECT_NEAR(g.indexToPhysical({0, 0, 27}).z, 831.21, 1e-3);
  EXPECT_EQ(l.modality, "CT");
  EXPECT_EQ(v.background(), kCtAirHu);
  EXPECT_TRUE(l.warnings.empty()) << l.warnings.front();
  const auto [lo, hi] = v.valueRange();
  // Measured: -1024..782 HU (stored 0..1801, unsigned 12-bit, intercept -1024). The phantom's
  // bone-equivalent shell peaks below 1000 HU.
  EXPECT_EQ(lo, -1024);
  EXPECT_GT(hi, 700);
  EXPECT_LT(hi, 1000);
  ASSERT_EQ(l.series.size(), 1u);
  EXPECT_EQ(l.series[0].description, "STD BRAIN 5MM");
}

TEST(DicomData, HeadPhantomIsSortedByPosition) {
  VELLUM_REQUIRE_DATA("ct-head-phantom");
  // Each loaded slice equals the single file at that position: I(10*(k+1)).dcm.
  const VolumeI16 v = loadI16(dataDir() / "ct-head-phantom");
  for (int k : {0, 1, 9, 10, 27}) {
    const fs::path file = dataDir() / "ct-head-phantom" / ("I" + std::to_string(10 * (k + 1)) + ".dcm");
    const VolumeI16 s = loadI16(file);
    ASSERT_EQ(s.dims(), (Dims{512, 512, 1}));
    EXPECT_NEAR(s.geometry().origin.z, 696.21 + 5.0 * k, 1e-6);
    EXPECT_TRUE(std::equal(s.voxels().begin(), s.voxels().end(), v.voxels().begin() + k * 512 * 512))
        << "slice " << k << " differs from " << file;
  }
}

TEST(DicomData, ListHeadPhantomSeries) {
  VELLUM_REQUIRE_DATA("ct-head-phantom");
  const auto series = io::listDicomSeries(dataDir() / "ct-head-phantom");
  ASSERT_EQ(series.size(), 1u);
  EXPECT_EQ(series[0].modality, "CT");
  EXPECT_EQ(series[0].fileCount, 28);
  EXPECT_EQ(series[0].frames, 28);
  EXPECT_EQ(series[0].rows, 512);
  EXPECT_EQ(series[0].columns, 512);
  EXPECT_EQ(series[0].uid, "1.3.46.670589.33.1.6002432791750815306.26862469513794233732");
  EXPECT_EQ(series[0].sopClassUid, "1.2.840.10008.5.1.4.1.1.2");
}

TEST(DicomData, TinySeries) {
  VELLUM_REQUIRE_DATA("ct-tiny-series");
  const io::LoadedVolume l = loadDicom(dataDir() / "ct-tiny-series", {});
  const Geometry& g = asI16(l).geometry();
  EXPECT_EQ(g.dims, (Dims{16, 16, 5}));
  EXPECT_NEAR(g.spacing.z, 2.5, 1e-3);
  EXPECT_NEAR(g.spacing.x, 0.488281, 1e-6);
  // Lowest z first (file 3353.dcm, InstanceNumber 10: files are numbered top-down).
  EXPECT_NEAR(g.origin.z, -1.2375, 1e-6);
  EXPECT_NEAR(g.origin.x, -72.199997, 1e-6);
  EXPECT_NEAR(g.origin.y, -143.0, 1e-6);
  EXPECT_TRUE(l.warnings.empty());
}

TEST(DicomData, Jpeg2000LosslessEqualsUncompressed) {
  VELLUM_REQUIRE_DATA("ct-single-slices/693_J2KR.dcm");
  const fs::path dir = dataDir() / "ct-single-slices";
  const VolumeI16 raw = loadI16(dir / "693_UNCR.dcm");
  const VolumeI16 j2kr = loadI16(dir / "693_J2KR.dcm");
  ASSERT_EQ(raw.dims(), (Dims{512, 512, 1}));
  EXPECT_EQ(j2kr.voxels(), raw.voxels());  // every voxel
  EXPECT_TRUE(j2kr.geometry().approxEqual(raw.geometry(), 1e-9));
  const auto [lo, hi] = raw.valueRange();
  EXPECT_EQ(lo, -3024);  // padding outside the reconstruction circle
  EXPECT_EQ(hi, 1468);

  // Lossy JPEG 2000: close, not equal.
  const VolumeI16 j2ki = loadI16(dir / "693_J2KI.dcm");
  ASSERT_EQ(j2ki.dims(), raw.dims());
  // The lossy file is tiny (3.5 kB): errors are large near the FOV edge but small on average.
  double sumAbs = 0, sumDiff = 0;
  int64_t differ = 0;
  for (size_t n = 0; n < raw.size(); ++n) {
    const double d = double(j2ki.voxels()[n]) - raw.voxels()[n];
    sumAbs += std::abs(d);
    sumDiff += d;
    differ += d != 0;
  }
  const double count = static_cast<double>(raw.size());
  EXPECT_GT(differ, 0);
  EXPECT_LT(sumAbs / count, 100.0) << "mean |lossy - lossless| HU";
  EXPECT_LT(std::abs(sumDiff / count), 10.0) << "mean lossy - lossless HU";
}

TEST(DicomData, CorruptJpeg2000HeaderIsAnErrorNotACrash) {
  VELLUM_REQUIRE_DATA("ct-single-slices/693_J2KR.dcm");
  // GDCM's JPEG 2000 codec crashes on an inconsistent SIZ marker; the loader checks it first.
  const fs::path dir = tempDir("dicom-j2k");
  const fs::path file = dir / "bad.dcm";
  fs::copy_file(dataDir() / "ct-single-slices" / "693_J2KR.dcm", file);
  std::string bytes;
  {
    std::ifstream in(file, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  const size_t soc = bytes.find(std::string("\xff\x4f\xff\x51", 4));
  ASSERT_NE(soc, std::string::npos);
  bytes[soc + 4 + 9] = 0x02;  // Ysiz 512 -> 0x02000200
  std::ofstream(file, std::ios::binary | std::ios::trunc) << bytes;
  try {
    loadDicom(file, {});
    ADD_FAILURE() << "corrupt JPEG 2000 accepted";
  } catch (const FileError& e) {
    EXPECT_NE(std::string(e.what()).find(file.string()), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("JPEG 2000"), std::string::npos) << e.what();
  }
}

TEST(DicomData, SmallCtSlice) {
  VELLUM_REQUIRE_DATA("ct-single-slices/CT_small.dcm");
  const io::LoadedVolume l = loadDicom(dataDir() / "ct-single-slices" / "CT_small.dcm", {});
  const Geometry& g = asI16(l).geometry();
  EXPECT_EQ(g.dims, (Dims{128, 128, 1}));
  EXPECT_NEAR(g.spacing.x, 0.661468, 1e-6);
  EXPECT_NEAR(g.spacing.z, 5.0, 1e-9);  // single slice: SpacingBetweenSlices
  EXPECT_NEAR(g.origin.x, -158.135803, 1e-6);
  EXPECT_NEAR(g.origin.z, -75.699997, 1e-6);
}

TEST(DicomData, EnhancedCtMultiFrame) {
  VELLUM_REQUIRE_DATA("ct-single-slices/eCT_Supplemental.dcm");
  const io::LoadedVolume l = loadDicom(dataDir() / "ct-single-slices" / "eCT_Supplemental.dcm", {});
  const VolumeI16& v = asI16(l);
  const Geometry& g = v.geometry();
  EXPECT_EQ(g.dims, (Dims{512, 512, 2}));
  EXPECT_NEAR(g.spacing.x, 0.388672, 1e-6);
  EXPECT_NEAR(g.spacing.y, 0.388672, 1e-6);
  // IOP -1\0\0\0\1\0: normal = (0,0,-1). Frames at z = -159 and -149: along the normal
  // -149 comes first, 10 mm apart.
  EXPECT_NEAR(g.spacing.z, 10.0, 1e-6);
  EXPECT_VEC3_NEAR(g.origin, 99.5, -301.5, -149.0, 1e-6);
  EXPECT_EQ(g.direction.column(0), (Vec3{-1, 0, 0}));
  EXPECT_EQ(g.direction.column(1), (Vec3{0, 1, 0}));
  EXPECT_EQ(g.direction.column(2), (Vec3{0, 0, -1}));
  EXPECT_NEAR(g.indexToPhysical({0, 0, 1}).z, -159.0, 1e-6);
  EXPECT_EQ(l.modality, "CT");
  EXPECT_TRUE(l.warnings.empty());
  const auto [lo, hi] = v.valueRange();
  EXPECT_GE(lo, -1024);
  EXPECT_GT(hi, 0);
}

TEST(DicomData, WholeSingleSliceFolderPicksAndListsSeries) {
  VELLUM_REQUIRE_DATA("ct-single-slices");
  const auto series = io::listDicomSeries(dataDir() / "ct-single-slices");
  // The three 693 files share one series (same position: exact duplicates only if the
  // lossy one matched, so loading that series must fail loudly rather than pick one).
  ASSERT_EQ(series.size(), 3u);
  EXPECT_EQ(series[0].fileCount, 3);
  EXPECT_EQ(series[0].frames, 3);
  int64_t total = 0;
  for (const auto& s : series) total += s.frames;
  EXPECT_EQ(total, 6);
  // Default choice: the largest CT series (the 693 slices). UNCR and J2KR are identical
  // duplicates; J2KI (lossy) conflicts at the same position, so the load is refused.
  try {
    loadDicom(dataDir() / "ct-single-slices", {});
    ADD_FAILURE() << "conflicting slices accepted";
  } catch (const FileError& e) {
    EXPECT_NE(std::string(e.what()).find("conflicting slices"), std::string::npos) << e.what();
  }
  // Picking another series works.
  io::LoadOptions options;
  options.seriesUid = "1.3.6.1.4.1.5962.1.3.10.3.1166562673.14401";
  EXPECT_EQ(geometryOf(loadDicom(dataDir() / "ct-single-slices", options).volume).dims.z, 2);
}

}  // namespace
}  // namespace vellum::test
