// Reading files written by hand (as other tools write them): conventions, encodings, types.
#include <gtest/gtest.h>
#include <zlib.h>

#include <cstring>

#include "io_test_util.hpp"
#include "vellum/core/error.hpp"
#include "vellum/io/volume_io.hpp"
#include "vec3_near.hpp"

using namespace vellum;
using namespace vellum::test;
namespace fs = std::filesystem;

namespace {

std::string nrrdHeader(const std::string& type, const std::string& extra) {
  return "NRRD0004\n# comment\ntype: " + type + "\ndimension: 3\nsizes: 2 1 2\n" + extra + "\n\n";
}

std::string gzipString(const std::string& s) {
  z_stream zs{};
  deflateInit2(&zs, 6, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY);
  std::string out(deflateBound(&zs, s.size()) + 32, '\0');
  zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(s.data()));
  zs.avail_in = static_cast<uInt>(s.size());
  zs.next_out = reinterpret_cast<Bytef*>(out.data());
  zs.avail_out = static_cast<uInt>(out.size());
  deflate(&zs, Z_FINISH);
  out.resize(zs.total_out);
  deflateEnd(&zs);
  return out;
}

std::string zlibString(const std::string& s) {
  uLongf n = compressBound(s.size());
  std::string out(n, '\0');
  compress2(reinterpret_cast<Bytef*>(out.data()), &n, reinterpret_cast<const Bytef*>(s.data()), s.size(), 6);
  out.resize(n);
  return out;
}

template <class T>
void expectSameVoxels(const Volume<T>& a, const AnyVolume& b) {
  ASSERT_TRUE(std::holds_alternative<Volume<T>>(b)) << "voxel type changed";
  EXPECT_EQ(a.voxels(), std::get<Volume<T>>(b).voxels());
}

template <class T>
T at(const AnyVolume& v, int64_t i, int64_t j, int64_t k) {
  return std::get<Volume<T>>(v)(i, j, k);
}

}  // namespace

TEST(Nrrd, RasSpaceIsConvertedToLps) {
  const fs::path dir = tempDir("nrrd-ras");
  const std::string h = nrrdHeader("short",
                                   "space: right-anterior-superior\nspace directions: (0,2,0) (-3,0,0) (0,0,4)\n"
                                   "space origin: (10,20,30)\nendian: little\nencoding: raw");
  const std::vector<int16_t> vox{1, 2, 3, 4};
  writeFile(dir / "r.nrrd", h + bytesOf(vox));
  const auto lv = io::loadVolume(dir / "r.nrrd");
  const Geometry& g = geometryOf(lv.volume);
  EXPECT_EQ(g.dims, (Dims{2, 1, 2}));
  EXPECT_VEC3_NEAR(g.spacing, 2, 3, 4, 1e-12);
  EXPECT_VEC3_NEAR(g.origin, -10, -20, 30, 1e-12);
  // RAS (0,1,0) -> LPS (0,-1,0); RAS (-1,0,0) -> LPS (1,0,0).
  EXPECT_NEAR(g.direction(1, 0), -1, 1e-12);
  EXPECT_NEAR(g.direction(0, 1), 1, 1e-12);
  EXPECT_NEAR(g.direction(2, 2), 1, 1e-12);
  // Physical position of voxel (1,0,1) in LPS: RAS (10,22,34) -> (-10,-22,34).
  const Vec3 p = g.indexToPhysical({1, 0, 1});
  EXPECT_VEC3_NEAR(p, -10, -22, 34, 1e-12);
  EXPECT_EQ(at<int16_t>(lv.volume, 1, 0, 1), 4);
}

TEST(Nrrd, BigEndianAndWideTypesAreConverted) {
  const fs::path dir = tempDir("nrrd-types");
  // big-endian int16: 0x0102 = 258, 0xFC18 = -1000
  writeFile(dir / "be.nrrd", nrrdHeader("short", "spacings: 1 1 1\nendian: big\nencoding: raw") +
                                 std::string("\x01\x02\xfc\x18\x00\x05\xff\xff", 8));
  auto lv = io::loadVolume(dir / "be.nrrd");
  EXPECT_EQ(at<int16_t>(lv.volume, 0, 0, 0), 258);
  EXPECT_EQ(at<int16_t>(lv.volume, 1, 0, 0), -1000);
  EXPECT_EQ(at<int16_t>(lv.volume, 1, 0, 1), -1);
  EXPECT_EQ(lv.modality, "CT");  // int16 with minimum <= -1000 and no modality key
  EXPECT_EQ(backgroundOf(lv.volume), -1000.0);

  const std::vector<int32_t> small{-5, 7, 30000, -30000};
  writeFile(dir / "i32.nrrd", nrrdHeader("int", "endian: little\nencoding: raw") + bytesOf(small));
  lv = io::loadVolume(dir / "i32.nrrd");
  EXPECT_EQ(at<int16_t>(lv.volume, 0, 0, 1), 30000);
  const std::vector<int32_t> big{0, 70000, 3, 4};
  writeFile(dir / "i32b.nrrd", nrrdHeader("int32", "endian: little\nencoding: raw") + bytesOf(big));
  lv = io::loadVolume(dir / "i32b.nrrd");
  EXPECT_EQ(at<float>(lv.volume, 1, 0, 0), 70000.f);
  const std::vector<double> d{0.5, -2.25, 1e6, 3};
  writeFile(dir / "d.nrrd", nrrdHeader("double", "endian: little\nencoding: gzip") + gzipString(bytesOf(d)));
  lv = io::loadVolume(dir / "d.nrrd");
  EXPECT_EQ(at<float>(lv.volume, 1, 0, 0), -2.25f);
  writeFile(dir / "i8.nrrd", nrrdHeader("signed char", "encoding: raw") + std::string("\xff\x05\x80\x7f", 4));
  lv = io::loadVolume(dir / "i8.nrrd");
  EXPECT_EQ(at<int16_t>(lv.volume, 0, 0, 1), -128);
  writeFile(dir / "a.nrrd", nrrdHeader("ushort", "encoding: ascii") + "1 2\n65535 4\n");
  lv = io::loadVolume(dir / "a.nrrd");
  EXPECT_EQ(at<uint16_t>(lv.volume, 0, 0, 1), 65535);
}

TEST(Nrrd, DetachedHeaderWithLineAndByteSkip) {
  const fs::path dir = tempDir("nrrd-detached");
  const std::vector<uint16_t> vox{10, 20, 30, 40};
  writeFile(dir / "data.bin", "first line\nsecond line\nXYZ" + bytesOf(vox));
  writeFile(dir / "d.nhdr", nrrdHeader("uint16", "endian: little\nencoding: raw\ndata file: data.bin\n"
                                                 "line skip: 2\nbyte skip: 3"));
  auto lv = io::loadVolume(dir / "d.nhdr");
  EXPECT_EQ(at<uint16_t>(lv.volume, 1, 0, 1), 40);
  // byte skip -1: data at the end of the file.
  writeFile(dir / "e.nhdr", nrrdHeader("uint16", "endian: little\nencoding: raw\ndatafile: data.bin\nbyteskip: -1"));
  EXPECT_EQ(at<uint16_t>(io::loadVolume(dir / "e.nhdr").volume, 0, 0, 0), 10);
}

TEST(Nrrd, WrittenHeaderIsStandardAndLps) {
  const fs::path dir = tempDir("nrrd-text");
  io::saveVolume(makeCt(), dir / "c.nrrd");
  const std::string text = readFile(dir / "c.nrrd");
  EXPECT_EQ(text.rfind("NRRD0004\n", 0), 0u);
  EXPECT_NE(text.find("space: left-posterior-superior\n"), std::string::npos);
  EXPECT_NE(text.find("encoding: gzip\n"), std::string::npos);
  EXPECT_NE(text.find("vellum_modality:=CT\n"), std::string::npos);
  EXPECT_NE(text.find("kinds: domain domain domain\n"), std::string::npos);
}

TEST(MetaImage, TransformMatrixListsAxisVectorsAndCompressedDataReads) {
  const fs::path dir = tempDir("mha-itk");
  const std::vector<int16_t> vox{-1000, 1, 2, 3};
  // ITK convention: the first three numbers are the direction of the i axis.
  const std::string h =
      "ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\n"
      "CompressedData = True\nCompressedDataSize = " + std::to_string(zlibString(bytesOf(vox)).size()) +
      "\nTransformMatrix = 0 1 0 -1 0 0 0 0 1\nOffset = 1 2 3\nElementSpacing = 0.5 0.25 2\n"
      "DimSize = 2 1 2\nElementType = MET_SHORT\nElementDataFile = LOCAL\n";
  writeFile(dir / "i.mha", h + zlibString(bytesOf(vox)));
  const auto lv = io::loadVolume(dir / "i.mha");
  const Geometry& g = geometryOf(lv.volume);
  EXPECT_EQ(g.direction.column(0), (Vec3{0, 1, 0}));
  EXPECT_EQ(g.direction.column(1), (Vec3{-1, 0, 0}));
  EXPECT_EQ(g.spacing, (Vec3{0.5, 0.25, 2}));
  EXPECT_EQ(g.origin, (Vec3{1, 2, 3}));
  EXPECT_EQ(at<int16_t>(lv.volume, 1, 0, 1), 3);
  EXPECT_EQ(lv.modality, "CT");

  io::saveVolume(makeCt(), dir / "w.mhd");
  EXPECT_TRUE(fs::exists(dir / "w.raw"));
  EXPECT_NE(readFile(dir / "w.mhd").find("ElementDataFile = w.raw"), std::string::npos);
}

namespace {
// A minimal NIfTI-1 header written field by field (little-endian).
struct Nifti {
  std::string h = std::string(348, '\0');
  template <class T>
  void put(size_t off, T v) { std::memcpy(h.data() + off, &v, sizeof v); }
  Nifti(int16_t datatype, int16_t bitpix) {
    put<int32_t>(0, 348);
    put<int16_t>(40, 3);
    put<int16_t>(42, 2);
    put<int16_t>(44, 1);
    put<int16_t>(46, 2);
    put<int16_t>(70, datatype);
    put<int16_t>(72, bitpix);
    put<float>(108, 352.f);
    std::memcpy(h.data() + 344, "n+1", 4);
  }
  std::string file(const std::string& data) const { return h + std::string(4, '\0') + data; }
};
}  // namespace

TEST(Nifti, SformIsRasAndBecomesLps) {
  const fs::path dir = tempDir("nifti-sform");
  Nifti n(4, 16);
  n.put<int16_t>(254, 1);  // sform_code
  // srow: column i = (0,2,0), j = (-3,0,0), k = (0,0,4); offset (10,20,30), all RAS.
  const float srow[12] = {0, -3, 0, 10, 2, 0, 0, 20, 0, 0, 4, 30};
  for (int i = 0; i < 12; ++i) n.put<float>(280 + 4 * size_t(i), srow[i]);
  const std::vector<int16_t> vox{5, 6, 7, 8};
  writeFile(dir / "s.nii", n.file(bytesOf(vox)));
  const auto lv = io::loadVolume(dir / "s.nii");
  const Geometry& g = geometryOf(lv.volume);
  EXPECT_EQ(lv.format, "nifti");
  EXPECT_EQ(g.spacing, (Vec3{2, 3, 4}));
  const Vec3 p = g.indexToPhysical({1, 0, 1});  // RAS (10,22,34)
  EXPECT_VEC3_NEAR(p, -10, -22, 34, 1e-6);
  EXPECT_EQ(at<int16_t>(lv.volume, 1, 0, 1), 8);
}

TEST(Nifti, QformWithNegativeQfacAndScalingAndGzip) {
  const fs::path dir = tempDir("nifti-qform");
  Nifti n(512, 16);  // uint16
  n.put<int16_t>(252, 1);  // qform_code, quaternion = identity rotation
  const float pixdim[4] = {-1, 0.5f, 0.75f, 2};
  for (int i = 0; i < 4; ++i) n.put<float>(76 + 4 * size_t(i), pixdim[i]);
  n.put<float>(268, 1.f);
  n.put<float>(272, 2.f);
  n.put<float>(276, 3.f);
  n.put<float>(112, 1.f);      // scl_slope
  n.put<float>(116, -1024.f);  // scl_inter
  const std::vector<uint16_t> vox{0, 24, 1024, 3000};
  writeFile(dir / "q.nii.gz", gzipString(n.file(bytesOf(vox))));
  const auto lv = io::loadVolume(dir / "q.nii.gz");
  const Geometry& g = geometryOf(lv.volume);
  EXPECT_EQ(g.spacing, (Vec3{0.5, 0.75, 2}));
  EXPECT_EQ(g.direction.column(0), (Vec3{-1, 0, 0}));
  EXPECT_EQ(g.direction.column(1), (Vec3{0, -1, 0}));
  EXPECT_EQ(g.direction.column(2), (Vec3{0, 0, -1}));  // qfac = -1 flips k
  EXPECT_EQ(g.origin, (Vec3{-1, -2, 3}));
  EXPECT_EQ(at<int16_t>(lv.volume, 0, 0, 0), -1024);  // scaled to HU, kept integer
  EXPECT_EQ(at<int16_t>(lv.volume, 1, 0, 1), 1976);
  EXPECT_EQ(lv.modality, "CT");
}

TEST(Vti, DirectionIsWrittenAsXmlAttributeAndReadBack) {
  const fs::path dir = tempDir("vti-dir");
  const VolumeI16 ct = makeCt();
  io::saveVolume(ct, dir / "c.vti");
  EXPECT_NE(readFile(dir / "c.vti").find("Direction=\""), std::string::npos);
  const auto lv = io::loadVolume(dir / "c.vti");
  expectGeometryNear(ct.geometry(), geometryOf(lv.volume), 1e-9);
}

TEST(Raw, BareRawThroughLoadOptionsAndExactSizeCheck) {
  const fs::path dir = tempDir("raw-bare");
  const std::vector<uint16_t> vox{1, 2, 3, 4, 5, 6};
  writeFile(dir / "b.raw", "HDR!" + bytesOf(vox));
  io::LoadOptions opt;
  opt.raw = io::RawLayout{};
  opt.raw->dims = {3, 2, 1};
  opt.raw->type = VoxelType::UInt16;
  opt.raw->spacing = {0.5, 0.5, 2};
  opt.raw->headerBytes = 4;
  auto lv = io::loadVolume(dir / "b.raw", opt);
  EXPECT_EQ(at<uint16_t>(lv.volume, 2, 1, 0), 6);
  EXPECT_EQ(geometryOf(lv.volume).spacing, (Vec3{0.5, 0.5, 2}));
  opt.raw->dims = {3, 3, 1};
  try {
    io::loadVolume(dir / "b.raw", opt);
    FAIL() << "expected a size mismatch";
  } catch (const FileError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("b.raw"), std::string::npos) << m;
    EXPECT_NE(m.find("expected 22 bytes"), std::string::npos) << m;
    EXPECT_NE(m.find("file has 16"), std::string::npos) << m;
  }
}

TEST(Raw, SidecarIsColumnMajorJson) {
  const fs::path dir = tempDir("raw-sidecar");
  const VolumeI16 ct = makeCt();
  io::saveVolume(ct, dir / "c.raw");
  const std::string json = readFile(dir / "c.raw.json");
  EXPECT_NE(json.find("\"dims\""), std::string::npos);
  EXPECT_NE(json.find("\"modality\": \"CT\""), std::string::npos);
  // Hand-written sidecar: direction lists the i axis first.
  const std::vector<int16_t> vox{1, 2};
  writeFile(dir / "h.raw", bytesOf(vox));
  writeFile(dir / "h.raw.json",
            R"({"dims":[2,1,1],"type":"int16","endianness":"little","spacing":[1,2,3],)"
            R"("origin":[4,5,6],"direction":[0,1,0, -1,0,0, 0,0,1]})");
  const auto lv = io::loadVolume(dir / "h.raw");
  EXPECT_EQ(geometryOf(lv.volume).direction.column(0), (Vec3{0, 1, 0}));
  EXPECT_EQ(geometryOf(lv.volume).indexToPhysical({1, 0, 0}), (Vec3{4, 6, 6}));
}

TEST(Dispatch, FormatForPath) {
  EXPECT_EQ(io::formatForPath("a/b.NRRD"), "nrrd");
  EXPECT_EQ(io::formatForPath("b.nhdr"), "nrrd");
  EXPECT_EQ(io::formatForPath("b.seg.nrrd"), "nrrd");
  EXPECT_EQ(io::formatForPath("b.raw"), "raw");
  EXPECT_EQ(io::formatForPath("b.mhd"), "metaimage");
  EXPECT_EQ(io::formatForPath("b.mha"), "metaimage");
  EXPECT_EQ(io::formatForPath("b.nii"), "nifti");
  EXPECT_EQ(io::formatForPath("b.nii.gz"), "nifti");
  EXPECT_EQ(io::formatForPath("b.vti"), "vti");
  EXPECT_EQ(io::formatForPath("b.dcm"), "dicom");
  EXPECT_EQ(io::formatForPath("series_out"), "dicom");
  try {
    io::formatForPath("scan.xyz");
    FAIL();
  } catch (const FileError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("scan.xyz"), std::string::npos);
    EXPECT_NE(m.find(".nrrd"), std::string::npos);
    EXPECT_NE(m.find(".vti"), std::string::npos);
  }
}

TEST(Dispatch, MissingFileAndWriteOnlyFormats) {
  const fs::path dir = tempDir("dispatch");
  try {
    io::loadVolume(dir / "absent.nrrd");
    FAIL();
  } catch (const FileError& e) {
    EXPECT_NE(std::string(e.what()).find("absent.nrrd: no such file"), std::string::npos) << e.what();
  }
  EXPECT_THROW(io::saveVolume(makeCt(), dir / "x.nii"), FileError);
  EXPECT_FALSE(fs::exists(dir / "x.nii"));
  io::SaveOptions opt;
  opt.format = "nrrd";
  io::saveVolume(makeCt(), dir / "forced.bin", opt);
  EXPECT_EQ(readFile(dir / "forced.bin").rfind("NRRD", 0), 0u);
}

TEST(Dispatch, DicomFolderRoundTripThroughSaveAndLoadVolume) {
  const fs::path dir = tempDir("dispatch-dicom");
  const VolumeI16 ct = makeCt({8, 6, 5});
  io::saveVolume(ct, dir / "series");  // no extension: a folder receiving a DICOM series
  ASSERT_TRUE(fs::is_directory(dir / "series"));
  EXPECT_EQ(leftoverTemps(dir), 0);
  const auto lv = io::loadVolume(dir / "series");
  EXPECT_EQ(lv.format, "dicom");
  EXPECT_EQ(lv.modality, "CT");
  expectSameVoxels(ct, lv.volume);
  expectGeometryNear(ct.geometry(), geometryOf(lv.volume), 1e-4);
  // One slice file without an extension is recognised by content.
  fs::path first;
  for (const auto& e : fs::directory_iterator(dir / "series"))
    if (e.path().extension() == ".dcm") first = e.path();  // a slice, not the folder's marker
  fs::copy_file(first, dir / "IM0001");
  EXPECT_EQ(io::loadVolume(dir / "IM0001").format, "dicom");
  writeFile(dir / "README", "not an image");
  EXPECT_THROW(io::loadVolume(dir / "README"), FileError);
}

// Issue 12: CT numbers without the HU offset (a bare RAW of 0..3000+) warn, and --rescale maps
// them back to HU exactly.
TEST(Raw, RescaleMapsShiftedCtNumbersBackToHuAndUnshiftedOnesWarn) {
  const fs::path dir = tempDir("raw-rescale");
  const std::vector<int16_t> hu{-1000, -200, 0, 40, 700, 2500};
  std::vector<uint16_t> shifted;
  for (int16_t v : hu) shifted.push_back(static_cast<uint16_t>(v + 1024));
  writeFile(dir / "s.raw", bytesOf(shifted));
  io::LoadOptions opt;
  opt.raw = io::RawLayout{};
  opt.raw->dims = {3, 2, 1};
  opt.raw->type = VoxelType::UInt16;
  const auto plain = io::loadVolume(dir / "s.raw", opt);
  ASSERT_EQ(plain.warnings.size(), 1u);
  EXPECT_NE(plain.warnings[0].find("--rescale 1 -1024"), std::string::npos) << plain.warnings[0];
  opt.rescale = std::pair{1.0, -1024.0};
  const auto lv = io::loadVolume(dir / "s.raw", opt);
  EXPECT_TRUE(lv.warnings.empty());
  EXPECT_EQ(lv.modality, "CT");
  const auto& v = std::get<VolumeI16>(lv.volume);
  EXPECT_EQ(v.background(), -1000);
  EXPECT_EQ(v.voxels(), hu);
}
