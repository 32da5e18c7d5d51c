// Damaged control-point and keyframe files through the binary: one line naming the file and
// the field, a non-zero exit, and no output file (not even a partial one).
#include <gtest/gtest.h>

#include <fstream>

#include "child_process.hpp"
#include "test_data.hpp"
#include "vellum/io/volume_io.hpp"
#include "vellum/phantom/phantom.hpp"

using namespace vellum;
namespace fs = std::filesystem;

namespace {

struct Outcome {
  int rc = 0;
  std::string log;
};
Outcome vellumCli(const std::vector<std::string>& args, const fs::path& log) {
  test::Child child(args, log);
  Outcome o;
  o.rc = child.wait();
  o.log = child.errors();
  return o;
}

// The one error line of `log` (fails the test unless there is exactly one non-empty line).
std::string onlyLine(const std::string& log) {
  std::string line;
  int lines = 0;
  size_t start = 0;
  while (start < log.size()) {
    const size_t end = std::min(log.find('\n', start), log.size());
    if (end > start) {
      line = log.substr(start, end - start);
      ++lines;
    }
    start = end + 1;
  }
  EXPECT_EQ(lines, 1) << log;
  return line;
}

const char* kPoints = R"([{"source": [0, 0, 0], "target": [1, 0, 0]}, {"source": [20, 0, 0]}])";

}  // namespace

TEST(WysiwygCli, DamagedJsonNamesFileAndFieldAndWritesNothing) {
  const fs::path dir = test::tempDir("wysiwyg-json-cli");
  phantom::PhantomOptions o;
  o.dims = {24, 24, 24};
  io::saveVolume(phantom::makePhantom(o).ct, dir / "ct.nrrd");
  const std::string ct = (dir / "ct.nrrd").string();
  // The keyframe duration of 1e12 s (was: "OUT.mp4: no frames").
  std::ofstream(dir / "long.json") << R"({"keyframes": [{"duration": 1, "points": )" << kPoints
                                    << R"(}, {"duration": 1e12, "points": )" << kPoints << "}]}";
  // Mismatched point counts across keyframes.
  std::ofstream(dir / "counts.json") << R"({"keyframes": [{"points": )" << kPoints
                                      << R"(}, {"points": [{"source": [0, 0, 0]}]}]})";
  std::ofstream(dir / "cut.json") << R"({"units": "mm", "points": [{"source": [0, 0)";
  std::ofstream(dir / "types.json") << R"({"points": [{"source": [0, 0, 0], "attributes": {"density": "thick"}}]})";
  struct Case {
    std::vector<std::string> args;
    std::string file, field;
    std::vector<std::string> outputs;
  };
  const std::vector<Case> cases = {
      {{"animate", ct, "--keyframes", (dir / "long.json").string(), "--out", (dir / "OUT.mp4").string()},
       "long.json", "keyframe 1: \"duration\"", {"OUT.mp4"}},
      {{"animate", ct, "--keyframes", (dir / "long.json").string(), "--out", (dir / "frames/").string()},
       "long.json", "keyframe 1: \"duration\"", {"frames"}},
      {{"animate", ct, "--keyframes", (dir / "counts.json").string(), "--out", (dir / "OUT.mp4").string()},
       "counts.json", "keyframe 1 has 1 points; keyframe 0 has 2", {"OUT.mp4"}},
      {{"deform", ct, "--points", (dir / "cut.json").string(), "--out", (dir / "bent.nrrd").string(),
        "--attributes-out", (dir / "attr.nrrd").string()},
       "cut.json", "not valid JSON", {"bent.nrrd", "attr.nrrd"}},
      {{"deform", ct, "--points", (dir / "types.json").string(), "--out", (dir / "bent.nrrd").string()},
       "types.json", "point 0: attribute \"density\"", {"bent.nrrd"}},
  };
  for (const Case& c : cases) {
    const Outcome r = vellumCli(c.args, dir / "log.txt");
    EXPECT_NE(r.rc, 0) << c.file;
    EXPECT_LT(r.rc, 128) << "crashed: " << r.log;
    const std::string line = onlyLine(r.log);
    EXPECT_NE(line.find(c.file), std::string::npos) << line;
    EXPECT_NE(line.find(c.field), std::string::npos) << "want " << c.field << " in: " << line;
    for (const std::string& out : c.outputs) EXPECT_FALSE(fs::exists(dir / out)) << out << " after: " << line;
  }
  // Nothing else (temporaries) was left beside the inputs.
  std::vector<std::string> left;
  for (const auto& e : fs::directory_iterator(dir)) left.push_back(e.path().filename().string());
  EXPECT_EQ(left.size(), 6u) << ::testing::PrintToString(left);
}
