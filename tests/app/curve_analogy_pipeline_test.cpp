// app::runCurveAnalogy's refusals: each a one-line error naming the file or field, nothing
// written. (The bend itself is tested through `vellum curve-analogy` and the studio.)
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "file_errors.hpp"
#include "hostile_json.hpp"
#include "test_data.hpp"
#include "vellum/app/curve_analogy_pipeline.hpp"
#include "vellum/core/error.hpp"

using namespace vellum;
namespace fs = std::filesystem;

namespace {
std::string errorOf(const app::CurveAnalogyRequest& r) { return test::errorOf([&] { app::runCurveAnalogy(r); }); }
}  // namespace

TEST(CurveAnalogyPipeline, BadRequestsNameTheFieldOrFile) {
  const fs::path dir = test::tempDir("app-curve");
  app::CurveAnalogyRequest r;
  r.dir = dir / "missing-shape";
  r.out = dir / "out";
  r.segment = "skin";
  r.curveSource = "c0.json";
  r.view.width = r.view.height = 64;
  r.curve = {{1, 1}, {2, 2}};
  EXPECT_NE(errorOf(r).find("C0 (c0.json) has 2 points; at least 3"), std::string::npos);
  r.curve = {{10, 10}, {50, 10}, {30, 50}};
  EXPECT_NE(errorOf(r).find((dir / "missing-shape" / "shape.json").string()), std::string::npos);
  r.out = r.dir;
  EXPECT_NE(errorOf(r).find("missing-shape"), std::string::npos);  // the output may not be the input
  r.out.clear();
  EXPECT_NE(errorOf(r).find("no output folder"), std::string::npos);
  EXPECT_FALSE(fs::exists(dir / "out"));
}

TEST(CurveAnalogyPipeline, DeepOrOversizeShapeReportIsRefused) {
  const fs::path dir = test::tempDir("app-curve-hostile");
  fs::create_directories(dir / "shape");
  app::CurveAnalogyRequest r;
  r.dir = dir / "shape";
  r.out = dir / "out";
  r.segment = "skin";
  r.view.width = r.view.height = 64;
  r.curve = {{10, 10}, {50, 10}, {30, 50}};
  test::expectHostileJsonRefused(dir / "shape" / "shape.json", 16u << 20, [&] { app::runCurveAnalogy(r); });
}
