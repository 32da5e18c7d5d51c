// Hostile input: one case per problem. Each must throw vellum::FileError naming the file and
// saying what is wrong; none may crash, hang or allocate the absurd size it announces.
#include <gtest/gtest.h>

#include <cstring>
#include <functional>
#include <iostream>

#include "hostile_json.hpp"
#include "io_test_util.hpp"
#include "vellum/core/error.hpp"
#include "vellum/io/volume_io.hpp"

using namespace vellum;
using namespace vellum::test;
namespace fs = std::filesystem;

namespace {

struct Malformed {
  const char* name;
  const char* file;     // file given to loadVolume
  const char* problem;  // expected (lower-case) substring of the message
  std::function<void(const fs::path& dir)> make;
};

std::string nrrd(const std::string& fields, const std::string& data = std::string(8, '\0')) {
  return "NRRD0004\n" + fields + "\n\n" + data;
}
const std::string kOk = "type: short\ndimension: 3\nsizes: 2 1 2\nendian: little\nencoding: raw\n";

std::string validFile(const fs::path& dir, const std::string& name, bool gzip = true) {
  io::SaveOptions o;
  o.gzip = gzip;
  io::saveVolume(makeCt({16, 16, 8}), dir / ("valid-" + name), o);
  return readFile(dir / ("valid-" + name));
}

std::string niftiHeader(int16_t dimx) {
  std::string h(352, '\0');
  auto put = [&](size_t off, auto v) { std::memcpy(h.data() + off, &v, sizeof v); };
  put(0, int32_t{348});
  put(40, int16_t{3});
  put(42, dimx);
  put(44, int16_t{2});
  put(46, int16_t{2});
  put(70, int16_t{4});
  put(72, int16_t{16});
  put(80, 1.f);
  put(84, 1.f);
  put(88, 1.f);
  put(108, 352.f);
  std::memcpy(h.data() + 344, "n+1", 4);
  return h;
}

const std::vector<Malformed>& cases() {
  static const std::vector<Malformed> c = {
      {"nrrd_wrong_magic", "a.nrrd", "magic", [](auto d) { writeFile(d / "a.nrrd", "PNG\nstuff\n\n1234"); }},
      {"nrrd_empty_file", "a.nrrd", "magic", [](auto d) { writeFile(d / "a.nrrd", ""); }},
      {"nrrd_line_without_colon", "a.nrrd", "no ':'",
       [](auto d) { writeFile(d / "a.nrrd", nrrd(kOk + "this line is broken")); }},
      {"nrrd_missing_type", "a.nrrd", "missing required nrrd field 'type'",
       [](auto d) { writeFile(d / "a.nrrd", nrrd("dimension: 3\nsizes: 2 1 2\nencoding: raw")); }},
      {"nrrd_missing_sizes", "a.nrrd", "'sizes'",
       [](auto d) { writeFile(d / "a.nrrd", nrrd("type: short\ndimension: 3\nendian: little\nencoding: raw")); }},
      {"nrrd_missing_endian", "a.nrrd", "'endian'",
       [](auto d) { writeFile(d / "a.nrrd", nrrd("type: short\ndimension: 3\nsizes: 2 1 2\nencoding: raw")); }},
      {"nrrd_negative_sizes", "a.nrrd", "sizes",
       [](auto d) { writeFile(d / "a.nrrd", nrrd("type: short\ndimension: 3\nsizes: 2 -1 2\nendian: little\nencoding: raw")); }},
      {"nrrd_absurd_dims", "a.nrrd", "absurd dimensions",
       [](auto d) { writeFile(d / "a.nrrd", nrrd("type: short\ndimension: 3\nsizes: 100000 100000 100000\nendian: little\nencoding: raw")); }},
      {"nrrd_over_memory_budget", "a.nrrd", "needs",
       [](auto d) { writeFile(d / "a.nrrd", nrrd("type: float\ndimension: 3\nsizes: 65536 65536 65536\nendian: little\nencoding: raw")); }},
      {"nrrd_zero_spacing", "a.nrrd", "spacing",
       [](auto d) { writeFile(d / "a.nrrd", nrrd(kOk + "space: left-posterior-superior\nspace directions: (0,0,0) (0,1,0) (0,0,1)")); }},
      {"nrrd_nan_spacing", "a.nrrd", "spacing",
       [](auto d) { writeFile(d / "a.nrrd", nrrd(kOk + "spacings: 1 nan 1")); }},
      {"nrrd_negative_spacing", "a.nrrd", "spacing",
       [](auto d) { writeFile(d / "a.nrrd", nrrd(kOk + "spacings: 1 -2 1")); }},
      {"nrrd_singular_direction", "a.nrrd", "singular",
       [](auto d) { writeFile(d / "a.nrrd", nrrd(kOk + "space: LPS\nspace directions: (1,0,0) (2,0,0) (0,0,1)")); }},
      {"nrrd_bad_number", "a.nrrd", "not a number",
       [](auto d) { writeFile(d / "a.nrrd", nrrd(kOk + "space: LPS\nspace origin: (1,two,3)")); }},
      {"nrrd_truncated_raw", "a.nrrd", "truncated",
       [](auto d) { writeFile(d / "a.nrrd", nrrd(kOk, std::string(5, '\0'))); }},
      {"nrrd_truncated_gzip", "a.nrrd", "truncated",
       [](auto d) { const auto s = validFile(d, "t.nrrd"); writeFile(d / "a.nrrd", s.substr(0, s.size() - 200)); }},
      {"nrrd_corrupt_gzip", "a.nrrd", "corrupt",
       [](auto d) {
         auto s = validFile(d, "c.nrrd");
         for (size_t i = s.size() / 2; i < s.size() / 2 + 64; ++i) s[i] = static_cast<char>(s[i] ^ 0x5a);
         writeFile(d / "a.nrrd", s);
       }},
      {"nrrd_gzip_garbage", "a.nrrd", "corrupt",
       [](auto d) { writeFile(d / "a.nrrd", nrrd("type: short\ndimension: 3\nsizes: 2 1 2\nendian: little\nencoding: gzip", "not gzip at all")); }},
      {"nrrd_gzip_longer_than_sizes", "a.nrrd", "more than the expected",
       [](auto d) {  // a 16x16x8 stream under a header announcing 2x1x2 (decompression bomb)
         const auto s = validFile(d, "g.nrrd");
         const auto data = s.substr(s.find("\n\n") + 2);
         writeFile(d / "a.nrrd", nrrd("type: short\ndimension: 3\nsizes: 2 1 2\nendian: little\nencoding: gzip", data));
       }},
      {"nrrd_gzip_header_promises_far_more", "a.nrrd", "cannot hold",
       [](auto d) {  // 1024^3 shorts claimed by a few hundred compressed bytes: refused before allocating 2 GiB
         const auto s = validFile(d, "g.nrrd");
         const auto data = s.substr(s.find("\n\n") + 2);
         writeFile(d / "a.nrrd", nrrd("type: short\ndimension: 3\nsizes: 1024 1024 1024\nendian: little\nencoding: gzip", data));
       }},
      {"nifti_header_promises_far_more", "a.nii", "truncated voxel data",
       [](auto d) {  // found by the NIfTI fuzzer: 16x4096x4096 shorts in an 8 KB file
         std::string h(352, '\0');
         const auto put16 = [&](size_t at, int16_t v) { std::memcpy(&h[at], &v, 2); };
         const auto put32f = [&](size_t at, float v) { std::memcpy(&h[at], &v, 4); };
         const int32_t size = 348;
         std::memcpy(&h[0], &size, 4);
         for (auto [at, v] : {std::pair<size_t, int16_t>{40, 3}, {42, 16}, {44, 4096}, {46, 4096}, {48, 1}, {70, 4}, {72, 16}})
           put16(at, v);
         for (size_t i = 0; i < 8; ++i) put32f(76 + 4 * i, 1.f);
         put32f(108, 352.f);
         std::memcpy(&h[344], "n+1\0", 4);
         writeFile(d / "a.nii", h + std::string(8192, '\0'));
       }},
      {"nrrd_unknown_encoding", "a.nrrd", "encoding",
       [](auto d) { writeFile(d / "a.nrrd", nrrd("type: short\ndimension: 3\nsizes: 2 1 2\nendian: little\nencoding: bzip2")); }},
      {"nrrd_unknown_type", "a.nrrd", "unsupported nrrd type",
       [](auto d) { writeFile(d / "a.nrrd", nrrd("type: long long\ndimension: 3\nsizes: 2 1 2\nendian: little\nencoding: raw")); }},
      {"nrrd_2d", "a.nrrd", "dimension 2",
       [](auto d) { writeFile(d / "a.nrrd", nrrd("type: short\ndimension: 2\nsizes: 2 2\nendian: little\nencoding: raw")); }},
      {"nrrd_unterminated_header", "a.nrrd", "blank line",
       [](auto d) { writeFile(d / "a.nrrd", "NRRD0004\n" + kOk); }},
      {"nhdr_missing_data_file", "a.nhdr", "does not exist",
       [](auto d) { writeFile(d / "a.nhdr", "NRRD0004\n" + kOk + "data file: gone.raw\n"); }},
      {"raw_no_sidecar", "a.raw", "no sidecar", [](auto d) { writeFile(d / "a.raw", std::string(8, '\0')); }},
      {"raw_malformed_json", "a.raw", "not valid json: line 1",
       [](auto d) { writeFile(d / "a.raw", std::string(8, '\0')); writeFile(d / "a.raw.json", "{\"dims\": [2,1,"); }},
      {"raw_sidecar_missing_dims", "a.raw", "'dims'",
       [](auto d) { writeFile(d / "a.raw", std::string(8, '\0')); writeFile(d / "a.raw.json", R"({"type":"int16"})"); }},
      {"raw_sidecar_negative_dims", "a.raw", "dims",
       [](auto d) { writeFile(d / "a.raw", std::string(8, '\0')); writeFile(d / "a.raw.json", R"({"dims":[2,-1,2],"type":"int16"})"); }},
      {"raw_sidecar_bad_type", "a.raw", "unsupported type",
       [](auto d) { writeFile(d / "a.raw", std::string(8, '\0')); writeFile(d / "a.raw.json", R"({"dims":[2,1,2],"type":"complex"})"); }},
      {"raw_sidecar_zero_spacing", "a.raw", "spacing",
       [](auto d) { writeFile(d / "a.raw", std::string(8, '\0')); writeFile(d / "a.raw.json", R"({"dims":[2,1,2],"type":"int16","spacing":[1,0,1]})"); }},
      {"raw_sidecar_singular_direction", "a.raw", "singular",
       [](auto d) { writeFile(d / "a.raw", std::string(8, '\0')); writeFile(d / "a.raw.json", R"({"dims":[2,1,2],"type":"int16","direction":[1,0,0,1,0,0,0,0,1]})"); }},
      {"raw_size_mismatch", "a.raw", "size mismatch",
       [](auto d) { writeFile(d / "a.raw", std::string(9, '\0')); writeFile(d / "a.raw.json", R"({"dims":[2,1,2],"type":"int16"})"); }},
      {"mha_binary_junk", "a.mha", "",
       [](auto d) { writeFile(d / "a.mha", std::string("\x89PNG\r\n\x1a\n\0\0\0\rIHDR", 16)); }},
      {"mha_line_without_equals", "a.mha", "no '='",
       [](auto d) { writeFile(d / "a.mha", "ObjectType = Image\nNDims 3\nElementDataFile = LOCAL\n"); }},
      {"mha_missing_data_file", "a.mha", "elementdatafile",
       [](auto d) { writeFile(d / "a.mha", "ObjectType = Image\nNDims = 3\nDimSize = 2 1 2\nElementType = MET_SHORT\n"); }},
      {"mha_missing_dimsize", "a.mha", "dimsize",
       [](auto d) { writeFile(d / "a.mha", "ObjectType = Image\nNDims = 3\nElementType = MET_SHORT\nElementDataFile = LOCAL\n"); }},
      {"mha_2d", "a.mha", "ndims",
       [](auto d) { writeFile(d / "a.mha", "ObjectType = Image\nNDims = 2\nDimSize = 2 2\nElementType = MET_SHORT\nElementDataFile = LOCAL\n"); }},
      {"mha_truncated", "a.mha", "truncated",
       [](auto d) { writeFile(d / "a.mha", "ObjectType = Image\nNDims = 3\nDimSize = 2 1 2\nElementType = MET_SHORT\nElementDataFile = LOCAL\nabc"); }},
      {"mha_bad_type", "a.mha", "elementtype",
       [](auto d) { writeFile(d / "a.mha", "ObjectType = Image\nNDims = 3\nDimSize = 2 1 2\nElementType = MET_LONG_LONG\nElementDataFile = LOCAL\n"); }},
      {"mhd_missing_data", "a.mhd", "does not exist",
       [](auto d) { writeFile(d / "a.mhd", "ObjectType = Image\nNDims = 3\nDimSize = 2 1 2\nElementType = MET_SHORT\nElementDataFile = a.zraw\n"); }},
      {"nii_too_short", "a.nii", "truncated", [](auto d) { writeFile(d / "a.nii", std::string(100, '\0')); }},
      {"nii_wrong_magic", "a.nii", "not a nifti",
       [](auto d) { auto h = niftiHeader(2); std::memcpy(h.data() + 344, "xyz", 4); writeFile(d / "a.nii", h + std::string(8, '\0')); }},
      {"nii_negative_dims", "a.nii", "invalid dimensions",
       [](auto d) { writeFile(d / "a.nii", niftiHeader(-5) + std::string(8, '\0')); }},
      {"nii_truncated_data", "a.nii", "truncated", [](auto d) { writeFile(d / "a.nii", niftiHeader(2) + std::string(3, '\0')); }},
      {"nii_gz_corrupt", "a.nii.gz", "",
       [](auto d) { writeFile(d / "a.nii.gz", std::string("\x1f\x8b\x08\x00\x00\x00\x00\x00\x00\x03garbagegarbagegarbage", 31)); }},
      {"vti_garbage", "a.vti", "", [](auto d) { writeFile(d / "a.vti", "<VTKFile type=\"ImageData\"><oops"); }},
      {"vti_truncated", "a.vti", "",
       [](auto d) { const auto s = validFile(d, "t.vti"); writeFile(d / "a.vti", s.substr(0, s.size() * 2 / 3)); }},
      {"vti_absurd_extent", "a.vti", "absurd dimensions",
       [](auto d) {
         writeFile(d / "a.vti",
                   "<?xml version=\"1.0\"?>\n<VTKFile type=\"ImageData\" version=\"1.0\" byte_order=\"LittleEndian\">"
                   "<ImageData WholeExtent=\"0 99999 0 99999 0 99999\" Origin=\"0 0 0\" Spacing=\"1 1 1\">"
                   "<Piece Extent=\"0 99999 0 99999 0 99999\"><PointData Scalars=\"s\">"
                   "<DataArray type=\"Int16\" Name=\"s\" format=\"ascii\">1 2</DataArray>"
                   "</PointData></Piece></ImageData></VTKFile>\n");
       }},
      {"mha_over_memory_budget", "a.mha", "needs",
       [](auto d) { writeFile(d / "a.mha", "ObjectType = Image\nNDims = 3\nDimSize = 60000 60000 60000\nElementType = MET_FLOAT\nElementDataFile = LOCAL\n"); }},
      {"nii_over_memory_budget", "a.nii", "needs",
       [](auto d) { writeFile(d / "a.nii", niftiHeader(30000).replace(44, 4, std::string("\x30\x75\x30\x75", 4)) + std::string(8, '\0')); }},
      {"unknown_extension", "a.xyz", "unknown file extension", [](auto d) { writeFile(d / "a.xyz", "hello"); }},
      {"missing_file", "gone.nrrd", "no such file", [](auto) {}},
  };
  return c;
}

class MalformedFile : public ::testing::TestWithParam<size_t> {};

}  // namespace

TEST_P(MalformedFile, ThrowsFileErrorNamingFileAndProblem) {
  const Malformed& m = cases()[GetParam()];
  const fs::path dir = tempDir(std::string("malformed-") + m.name);
  m.make(dir);
  try {
    io::loadVolume(dir / m.file);
    FAIL() << m.name << ": no error";
  } catch (const FileError& e) {
    std::string msg = e.what();
    EXPECT_NE(msg.find(m.file), std::string::npos) << m.name << ": message does not name the file: " << msg;
    std::cout << "  " << m.name << " -> " << e.what() << "\n";  // visible in the test log
    for (char& ch : msg) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
    EXPECT_NE(msg.find(m.problem), std::string::npos) << m.name << ": expected '" << m.problem << "' in: " << msg;
  } catch (const std::exception& e) {
    FAIL() << m.name << ": wrong exception type: " << e.what();
  }
}

INSTANTIATE_TEST_SUITE_P(Cases, MalformedFile, ::testing::Range<size_t>(0, cases().size()),
                         [](const auto& info) { return std::string(cases()[info.param].name); });

TEST(MalformedRawSidecar, DeepOrOversizeJsonIsRefusedWithoutParsing) {
  const fs::path dir = tempDir("malformed-sidecar");
  writeFile(dir / "a.raw", std::string(8, '\0'));
  expectHostileJsonRefused(dir / "a.raw.json", 1u << 20, [&] { (void)io::loadVolume(dir / "a.raw"); });
}

TEST(MalformedLabels, BadLabelTableEntryNamesKeyAndFile) {
  const fs::path dir = tempDir("malformed-labels");
  writeFile(dir / "l.nrrd", nrrd(kOk + "vellum_label_3:=bone 255 300 1"));
  try {
    io::loadLabels(dir / "l.nrrd");
    FAIL() << "no error";
  } catch (const FileError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("l.nrrd"), std::string::npos) << m;
    EXPECT_NE(m.find("vellum_label_3"), std::string::npos) << m;
  }
  writeFile(dir / "m.nrrd", nrrd(kOk + "vellum_label_0:=background 0 0 0"));
  EXPECT_THROW(io::loadLabels(dir / "m.nrrd"), FileError);  // id 0 is reserved
}
