// Detached headers (.nhdr "data file", .mhd "ElementDataFile") may only name data in their own
// folder: an absolute path, "..", or a symlink leading out is refused with one line naming the
// header, unless LoadOptions::allowOutsideData (--allow-outside-data) says it is meant.
#include <gtest/gtest.h>

#include <string>

#include "file_errors.hpp"
#include "io_test_util.hpp"
#include "vellum/io/nrrd_reader.hpp"
#include "vellum/io/volume_io.hpp"

using namespace vellum;
namespace fs = std::filesystem;

namespace {

struct Header {
  const char* name;
  std::string (*text)(const std::string& dataFile);
};

const Header kHeaders[] = {
    {"a.nhdr",
     [](const std::string& data) {
       return "NRRD0004\ntype: short\ndimension: 3\nsizes: 2 1 2\nendian: little\nencoding: raw\ndata file: " +
              data + "\n";
     }},
    {"a.mhd",
     [](const std::string& data) {
       return "ObjectType = Image\nNDims = 3\nDimSize = 2 1 2\nElementType = MET_SHORT\n"
              "BinaryDataByteOrderMSB = False\nElementDataFile = " + data + "\n";
     }},
};

class OutsideData : public ::testing::TestWithParam<size_t> {
 protected:
  // dir/x.raw lies outside dir/h/, the header's folder; dir/h/in/x.raw inside it.
  void SetUp() override {
    dir = test::tempDir("outside-data");
    fs::create_directories(dir / "h" / "in");
    const std::string samples = {1, 0, 2, 0, 3, 0, 4, 0};
    test::writeFile(dir / "x.raw", samples);
    test::writeFile(dir / "h" / "in" / "x.raw", samples);
    fs::create_symlink("../x.raw", dir / "h" / "link.raw");
  }
  fs::path header(const std::string& dataFile) const {
    const Header& h = kHeaders[GetParam()];
    test::writeFile(dir / "h" / h.name, h.text(dataFile));
    return dir / "h" / h.name;
  }
  fs::path dir;
};

}  // namespace

TEST_P(OutsideData, RefusedNamingTheHeaderUnlessAllowed) {
  io::LoadOptions allow;
  allow.allowOutsideData = true;
  const struct {
    std::string dataFile, problem;
  } cases[] = {{"../x.raw", "lies outside the header's folder"},
               {(dir / "x.raw").string(), "is an absolute path"},
               {"link.raw", "lies outside the header's folder"},
               {"in/../../x.raw", "lies outside the header's folder"}};
  for (const auto& c : cases) {
    const fs::path h = header(c.dataFile);
    const std::string m = test::errorOf([&] { (void)io::loadVolume(h); });
    EXPECT_EQ(m, h.string() + ": data file '" + c.dataFile + "' " + c.problem + " (--allow-outside-data reads it)");
    EXPECT_THROW((void)io::loadLabels(h), FileError) << c.dataFile;
    const VolumeI16 v = std::get<VolumeI16>(io::loadVolume(h, allow).volume);
    EXPECT_EQ(v.data()[3], 4) << c.dataFile;
  }
}

TEST_P(OutsideData, DataInTheHeadersFolderIsRead) {
  for (const std::string inside : {"in/x.raw", "in/../in/x.raw", "./in/x.raw"}) {
    const VolumeI16 v = std::get<VolumeI16>(io::loadVolume(header(inside)).volume);
    EXPECT_EQ(v.data()[0], 1) << inside;
  }
}

INSTANTIATE_TEST_SUITE_P(Headers, OutsideData, ::testing::Range<size_t>(0, std::size(kHeaders)),
                         [](const auto& info) { return std::string(kHeaders[info.param].name[2] == 'n' ? "nhdr" : "mhd"); });

TEST(OutsideData, TheSampleReaderRefusesItToo) {
  const fs::path dir = test::tempDir("outside-data-samples");
  fs::create_directories(dir / "h");
  test::writeFile(dir / "x.raw", std::string(8, '\0'));
  test::writeFile(dir / "h" / "a.nhdr", kHeaders[0].text("../x.raw"));
  EXPECT_NE(test::errorOf([&] { (void)io::readNrrd(dir / "h" / "a.nhdr"); }).find("a.nhdr: data file '../x.raw'"),
            std::string::npos);
}
