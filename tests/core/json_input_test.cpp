// vellum::parseJson / readJsonFile: the size and depth guards every JSON reader relies on, and
// their one-line errors.
#include "vellum/core/json_input.hpp"

#include <gtest/gtest.h>

#include <fstream>

#include "file_errors.hpp"
#include "hostile_json.hpp"
#include "test_data.hpp"

using namespace vellum;
namespace fs = std::filesystem;

namespace {

std::string errorFor(const std::string& text) {
  return test::errorOf([&] { (void)parseJson(text, "in.json"); });
}

}  // namespace

TEST(JsonInput, DepthIsCheckedBeforeParsing) {
  EXPECT_EQ(parseJson(test::deepJson(kMaxJsonDepth), "in.json").dump().size(), 2u * kMaxJsonDepth);
  EXPECT_EQ(errorFor(test::deepJson(kMaxJsonDepth + 1)), "in.json: JSON nested deeper than 64 levels");
  EXPECT_EQ(errorFor(test::deepJson()), "in.json: JSON nested deeper than 64 levels");
  // Objects count as arrays do; an unclosed deep file is refused by depth, not by the parser.
  EXPECT_EQ(errorFor(std::string(100, '{')), "in.json: JSON nested deeper than 64 levels");
  EXPECT_EQ(errorFor(std::string(100000, '[')), "in.json: JSON nested deeper than 64 levels");
}

TEST(JsonInput, BracketsInsideStringsDoNotCount) {
  const std::string brackets(1000, '[');
  const nlohmann::json j = parseJson(R"({"a": ")" + brackets + R"(\"[[", "b": [1]})", "in.json");
  EXPECT_EQ(j["a"].get<std::string>(), brackets + "\"[[");
  EXPECT_EQ(j["b"][0], 1);
  // Stray closers cannot hide depth that follows them (the parser refuses them anyway).
  EXPECT_NE(errorFor("]]]]" + test::deepJson(kMaxJsonDepth)).find("not valid JSON"), std::string::npos);
}

TEST(JsonInput, ParseErrorsNameTheLine) {
  EXPECT_EQ(errorFor("{\n  \"a\": 1,\n  \"b\": }\n"),
            "in.json: not valid JSON: line 3: syntax error while parsing value - unexpected '}'; "
            "expected '[', '{', or a literal");
  EXPECT_NE(errorFor("").find("in.json: not valid JSON: line 1: "), std::string::npos);
  EXPECT_EQ(errorFor("[1e999]"), "in.json: not valid JSON: number overflow parsing '1e999'");
  // The parser's "last read" token is cut short, so a long bad string cannot make a long message.
  std::string longBadString = "\"";
  longBadString.append(100000, 'x') += "\x01\"";
  EXPECT_LT(errorFor(longBadString).size(), 300u);
}

TEST(JsonInput, FilesAreCappedBeforeTheyAreRead) {
  const fs::path dir = test::tempDir("json-input");
  std::ofstream(dir / "ok.json") << R"({"a": [1, 2]})";
  EXPECT_EQ(readJsonFile(dir / "ok.json", 64, "test file")["a"][1], 2);
  test::expectHostileJsonRefused(dir / "hostile.json", 1u << 20, [&] { (void)readJsonFile(dir / "hostile.json", 1u << 20, "test file"); });
  EXPECT_EQ(test::errorOf([&] { (void)readJsonFile(dir / "none.json", 64, "test file"); }),
            (dir / "none.json").string() + ": no such test file");
  EXPECT_EQ(test::errorOf([&] { (void)readJsonFile(dir, 64, "test file"); }), dir.string() + ": is a folder (a test file is expected)");
}
